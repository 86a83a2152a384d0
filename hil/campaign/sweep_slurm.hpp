// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The Slurm executor of a sweep: the runs to do written as a queue (DIR/slurm/queue.txt,
// "INDEX RUN_ID" a line), a job-array script whose every task runs one part of it
// (`ehpt sweep CAMPAIGN --out DIR --shard I/N`, run_shard), submitted with sbatch; the job is
// named after the folder so that a reused job id is never taken for ours. Every Slurm command
// is started with an argument vector and a time limit.

#include <atomic>
#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "hil/campaign/sweep_folder.hpp"
#include "hil/campaign/sweep_plan.hpp"

namespace ehpt::hil {

inline constexpr std::int64_t kDefaultShardSize = 16;

struct SlurmOptions {
  std::string ehpt;       // the ehpt executable the array tasks run
  std::string partition;  // "" the cluster's default
  int max_parallel = 0;   // at most this many tasks at once (0: no limit)
  std::int64_t shard_size = kDefaultShardSize;  // runs per task (more if MaxArraySize needs it)
  bool no_wait = false;   // submit and return
  bool quiet = false;
  bool tty = false;       // err is a terminal (a progress line rewritten in place)
};

// Checks made before anything is written: sbatch is on PATH (its path in sbatch), the
// partition exists (sinfo). 0, or 1 with the reason on err.
int check_slurm(const std::string& partition, std::string& sbatch, std::ostream& err);

// A job of this sweep still queued or running would run the same runs as we are about to (and
// read the queue a submission replaces): true, with the reason on err. unknown_ok: squeue
// cannot tell (the local executor on a machine without Slurm) is a warning, not a refusal.
bool slurm_job_is_live(const SweepFolder& f, bool unknown_ok, std::ostream& err);

// Writes the queue and the job-array script of plan.runs[todo[...]], submits them, and (unless
// no_wait) waits for the job, showing how many runs have ended. 0 when the job has left the
// queue (or was submitted, with no_wait); 1 if it could not be submitted; 128 + N when stopped
// by signal N (the job is cancelled).
int submit_and_wait(const SlurmOptions& a, const std::string& sbatch, const SweepPlan& plan,
                    const std::vector<std::size_t>& todo, const SweepFolder& f, const std::atomic<int>& stop,
                    std::ostream& out, std::ostream& err);

struct ShardOptions {
  std::string ehpt;              // the ehpt executable the runs are started with
  std::string campaign, out_dir;
  std::int64_t shard_index = 0, shard_count = 1;  // the I-th of N parts of the queue
  int jobs = 0;                  // runs at a time (0: $SLURM_CPUS_PER_TASK, else 1)
  bool quiet = false;
};

// An array task: the I-th of N parts of DIR/slurm/queue.txt, each run checked against its
// queued id (a file changed since the submission would make it another run: not run, stays
// pending). 0, 1 (a damaged queue, another campaign's folder), 2 (the campaign does not load),
// or 128 + N when stopped.
int run_shard(const ShardOptions& a, const std::atomic<int>& stop, std::ostream& err);

// The Slurm job recorded in DIR/slurm/job_id: false if there is none. state: "" no longer
// queued, "?" unknown (error says why), else its states ("PENDING,RUNNING").
bool slurm_job_of(const SweepFolder& f, std::string& job, std::string& state, std::string& error);

}  // namespace ehpt::hil
