// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The local process pool of a sweep: each run an `ehpt run` child (so that a run that fails, or
// even crashes, fails alone), its outcome recorded in the sweep folder when it ends.

#include <atomic>
#include <iosfwd>
#include <string>
#include <vector>

#include "hil/campaign/sweep_folder.hpp"
#include "hil/campaign/sweep_plan.hpp"

namespace ehpt::hil {

struct PoolOptions {
  std::string ehpt;  // the ehpt executable the runs are started with (its `run` command)
  int jobs = 1;      // runs at a time
  bool quiet = false;
  bool tty = false;  // err is a terminal: one progress line rewritten in place (else a line per tenth)
};

struct PoolCounts {
  std::size_t ok = 0, failed = 0, stopped = 0;
};

// Runs plan.runs[todo[...]], options.jobs at a time, each as `ehpt run SCENARIO --out
// DIR/runs/<id> --quiet --set ...` with its stderr in DIR/logs/<id>.log and
// EHPT_SWEEP_PID in its environment (it ends when this process dies). A run's outcome is
// recorded (DIR/status/<id>.txt) when it ends; a run stopped by our signal, or whose folder
// another process holds, is not (it runs next time: `stopped`). A stop signal is passed on to
// the runs. Progress on err unless quiet.
PoolCounts run_pool(const SweepPlan& plan, const std::vector<std::size_t>& todo, const SweepFolder& f,
                    const PoolOptions& options, const std::atomic<int>& stop, std::ostream& err);

// The CPUs this process may run on (Slurm and cgroups restrict it; nproc says the same).
int usable_cpus();

}  // namespace ehpt::hil
