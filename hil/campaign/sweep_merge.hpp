// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Merging a sweep: results.csv and results.jsonl, one row per run of the campaign as planned
// now (done, failed or pending), from the runs' statuses and summary.json files.

#include <string>

#include "hil/campaign/sweep_folder.hpp"
#include "hil/campaign/sweep_plan.hpp"

namespace ehpt::hil {

struct SweepTally {
  std::size_t ok = 0, failed = 0, pending = 0;
};

// Writes DIR/results.csv and DIR/results.jsonl atomically. CSV columns: run_id, scenario, the
// swept keys (their values, a TOML string without its quotes), sweep_status (ok, failed,
// pending), exit_code, message, then every summary.json key (flattened, dotted) in the order
// first seen; a summary key named like one of the first columns is left out. A summary.json
// that does not parse makes the run failed. JSONL: run_id, scenario, overrides (numbers and
// booleans as JSON, else strings), sweep_status, exit_code (null if pending), message, summary.
// tally counts the rows. False (error says why) if a file cannot be written.
bool merge_results(const SweepPlan& plan, const SweepFolder& f, SweepTally& tally, std::string& error);

// The exit code of a sweep: 4 if a run is pending, else 3 if one failed, else 0.
int sweep_exit_code(const SweepTally& t);

}  // namespace ehpt::hil
