// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// `ehpt sweep`: a SIL campaign (hil/campaign/campaign.hpp) over scenarios x parameters, run by a
// local process pool or as a Slurm job array, resumable, merged into results.csv and
// results.jsonl (the engine: hil/campaign/sweep_*.hpp; the command: targets/cmd_sweep.cpp).

#include <atomic>
#include <string>
#include <vector>

namespace ehpt::cli {

extern const char* const kSweepHelp;

// `ehpt sweep ...` (args without the command word). stop: set to a signal number to stop
// (runs under way are interrupted and recorded as not done). Exit codes: 0 every run done and
// ok, 1 usage, folder or system error (nothing run), 2 the campaign file is invalid (nothing
// run), 3 some runs failed (recorded in results.csv), 4 some runs did not finish (Slurm),
// 5 (--status) the Slurm job is still queued or running, 128 + N stopped by signal N.
int cmd_sweep(const std::vector<std::string>& args, const std::atomic<int>& stop);

}  // namespace ehpt::cli
