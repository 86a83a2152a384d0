// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The sweep folder: what says which runs of a sweep are done.
//
//   DIR/sweep.json            which campaign this folder belongs to
//   DIR/runs/<id>/            the run's output folder (ehpt run --out: summary.json, ...)
//   DIR/status/<id>.txt       the run's exit code and, if it failed, why (written when it ends)
//   DIR/logs/<id>.log         the run's stderr
//   DIR/results.csv, .jsonl   merged (sweep_merge.hpp): one row per run of the campaign as it is now
//   DIR/slurm/                the job-array script, the queue of its runs, the tasks' output
//
// A run's id is its content address (campaign.hpp): a sweep again skips every run with a
// status, and a changed input file or value gives new ids, so exactly the affected runs run
// again. Nothing outside DIR is written; nothing in DIR is removed.

#include <initializer_list>
#include <string>
#include <vector>

#include "hil/campaign/sweep_plan.hpp"

namespace ehpt::hil {

inline constexpr const char* kSweepFormat = "ehpt sweep folder 1";

struct SweepFolder {
  std::string dir;  // absolute, without a trailing '/' (absolute_folder)
  std::string run_dir(const std::string& id) const { return dir + "/runs/" + id; }
  std::string status_file(const std::string& id) const { return dir + "/status/" + id + ".txt"; }
  std::string log_file(const std::string& id) const { return dir + "/logs/" + id + ".log"; }
  std::string slurm(const std::string& name) const { return dir + "/slurm/" + name; }
};

// Reads "campaign" from DIR/sweep.json; false (why says why) if DIR has no sweep.json or it is
// not ours.
bool sweep_campaign_of(const std::string& dir, std::string& campaign, std::string& why);

// True if dir is an ehpt sweep folder (its sweep.json): its sweep_*.png figures are ehpt's.
bool is_sweep_folder(const std::string& dir);

// DIR's own folders: made if missing; one that is a symbolic link or not a folder is refused
// (the runs, statuses and logs would be written wherever it points).
bool make_subfolders(const std::string& dir, std::initializer_list<const char*> subs, std::string& error);

// DIR for this campaign: made if missing; an empty folder is claimed; an earlier sweep of the
// same campaign is resumed. Anything else (another campaign's sweep, a folder of other files,
// a symbolic link) is refused before anything is written.
bool open_sweep_folder(const std::string& dir, const std::string& campaign, std::string& error);

// Absolute and without a trailing '/': the job-array script and its tasks name the same folder
// from anywhere, and the lock beside it is "DIR.ehpt-lock", not a file inside it.
std::string absolute_folder(const std::string& dir);

// A run's status file: "exit N" (0..255) and the failure message; anything else is not recorded.
struct RunOutcome {
  bool recorded = false;
  int exit_code = -1;
  std::string message;
};
RunOutcome read_outcome(const SweepFolder& f, const std::string& id);

// Done: ended with exit 0 and its folder is there (committed at once with its summary.json);
// a run whose folder went missing runs again. Failed: recorded with another exit code.
bool run_done(const SweepFolder& f, const std::string& id, const RunOutcome& o);
bool run_failed(const RunOutcome& o);

// What the run's stderr (its log) says, on one line (warnings and the loader's closing count
// left out, at most ~2000 characters), the campaign's locations in place of --set labels; if
// it says nothing, "exit N" or "killed by signal N" (code > 128).
std::string failure_message(const SweepFolder& f, const std::string& run_id, const std::vector<CampaignOverride>& overrides,
                            int code);

// The run's log says its folder is locked by another ehpt run (DirLock's message).
bool folder_busy(const SweepFolder& f, const PlannedRun& run);

// The resume decision: which runs of the plan run now. A done run is skipped; a failed one is
// skipped unless retry_failed; every other (no status, a damaged status, a done run whose
// folder went missing) runs.
struct SweepSelection {
  std::vector<std::size_t> todo;  // indices into plan.runs, in plan order
  std::size_t done_before = 0, failed_before = 0;
};
SweepSelection select_runs(const SweepPlan& plan, const SweepFolder& f, bool retry_failed);

}  // namespace ehpt::hil
