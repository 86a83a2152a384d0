// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// `ehpt replay`: a recorded bus session (inputs.log, hil/bus/session_log.hpp) run again offline.
// The driver applies each recorded command at the step it acted from in the session, before
// that step, exactly where the bus plant applied it; everything else is the batch run's. The
// result is the session's trajectory bit for bit.

#include <memory>

#include "hil/run/batch.hpp"
#include "hil/bus/session_log.hpp"

namespace ehpt::hil {

// The driver for run_batch (BatchOptions::driver); log must outlive it.
std::unique_ptr<ExternalDriver> make_replay_driver(const InputsLog& log, const std::string& log_path);

}  // namespace ehpt::hil
