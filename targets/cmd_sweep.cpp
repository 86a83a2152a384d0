// SPDX-License-Identifier: BSD-3-Clause
// `ehpt sweep`: the options and what is printed. The sweep itself (planning, the folder, the
// local pool, the Slurm executor, merging) is library code in hil/campaign/sweep_*.hpp.

#include "targets/cmd_sweep.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "hil/campaign/sweep_folder.hpp"
#include "hil/campaign/sweep_merge.hpp"
#include "hil/campaign/sweep_plan.hpp"
#include "hil/campaign/sweep_pool.hpp"
#include "hil/campaign/sweep_slurm.hpp"
#include "io/output_dir.hpp"
#include "io/process.hpp"

namespace fs = std::filesystem;

namespace ehpt::cli {

const char* const kSweepHelp =
    "usage: ehpt sweep CAMPAIGN --out DIR [-j N] [--retry-failed] [--quiet]\n"
    "       ehpt sweep CAMPAIGN --out DIR --executor slurm [--partition P] [--max-parallel M]\n"
    "                  [--shard-size K] [--no-wait] [--retry-failed] [--quiet]\n"
    "       ehpt sweep --status DIR\n"
    "       ehpt sweep CAMPAIGN --plan\n"
    "\n"
    "Runs every run of a campaign (campaigns/*.toml: scenarios x [grid] x variants; the format\n"
    "is in docs/campaigns.md) as 'ehpt run' and merges the\n"
    "summaries into DIR/results.csv and DIR/results.jsonl (one row per run: its id, scenario\n"
    "and swept values, then every summary.json key). A run's id is a hash of the bytes of\n"
    "every file it reads and of its overrides: the campaign again into the same DIR runs only\n"
    "what is not done (a changed file or value gives new ids). A run that fails (exit 2 or 3)\n"
    "is recorded with its exit code and message and does not stop the others; it is not run\n"
    "again unless --retry-failed is given.\n"
    "  --out DIR          the sweep folder: new, empty, or an earlier sweep of this campaign\n"
    "  -j N               local runs at a time (default: the CPUs this process may use)\n"
    "  --retry-failed     run the failed runs again (only those, and what is not done)\n"
    "  --executor slurm   submit the runs as a Slurm job array (sbatch --array; DIR must be on a\n"
    "                     filesystem every node sees at the same path), wait for it, merge\n"
    "  --partition P      the Slurm partition (default: the cluster's default)\n"
    "  --max-parallel M   at most M array tasks at once (sbatch --array=...%M)\n"
    "  --shard-size K     runs per array task (default 16)\n"
    "  --no-wait          submit and return; 'ehpt sweep --status DIR' later\n"
    "  --plan             check the campaign and every run's scenario (on every CPU this\n"
    "                     process may use), print the count, the time and peak memory it\n"
    "                     took; nothing is run or written (exit 0, or 2 with the problems)\n"
    "  --status DIR       runs done, failed and pending, the Slurm job's state; merges the\n"
    "                     results so far (exit 5 while the job is queued or running)\n"
    "  --shard I/N        (run by each array task) run the I-th of N parts of DIR's queue\n"
    "Exit codes: 0 all runs ok, 1 usage, folder or system error, 2 invalid campaign (nothing\n"
    "run), 3 some runs failed (see results.csv), 4 some runs are not done (stopped, or a Slurm\n"
    "task died: see DIR/slurm/; run the sweep again), 5 (--status) the Slurm job is still queued\n"
    "or running or its state is unknown, 130 Ctrl-C (runs under way are stopped and run again\n"
    "next time).\n";

namespace {

// ---- arguments -----------------------------------------------------------------------------

struct Args {
  std::string campaign, out_dir, status_dir;
  int jobs = 0;
  bool retry_failed = false, quiet = false, no_wait = false, plan_only = false;
  std::string executor = "local", partition;
  int max_parallel = 0;
  std::int64_t shard_size = hil::kDefaultShardSize;
  bool shard = false;
  std::int64_t shard_index = 0, shard_count = 0;
};

int parse_args(const std::vector<std::string>& args, Args& a) {
  const auto fail = [](const std::string& m) {
    std::cerr << "ehpt sweep: " << m << " ('ehpt sweep --help' lists the options)\n";
    return 1;
  };
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& o = args[i];
    const bool takes_value = o == "--out" || o == "-j" || o == "--executor" || o == "--partition" ||
                             o == "--max-parallel" || o == "--shard-size" || o == "--status" || o == "--shard";
    if (takes_value && i + 1 >= args.size()) return fail(o + " needs a value");
    std::int64_t n = 0;
    if (o == "--out") {
      a.out_dir = args[++i];
      if (a.out_dir.empty()) return fail("--out needs a folder name (got an empty one)");
    } else if (o == "-j") {
      if (!hil::whole_number(args[++i], 1, 4096, n)) return fail("-j " + args[i] + ": must be a whole number in [1, 4096]");
      a.jobs = static_cast<int>(n);
    } else if (o == "--executor") {
      a.executor = args[++i];
      if (a.executor != "local" && a.executor != "slurm") return fail("--executor " + a.executor + ": must be local or slurm");
    } else if (o == "--partition") {
      a.partition = args[++i];
      if (a.partition.empty() || a.partition[0] == '-' ||
          a.partition.find_first_of(" \t\r\n,=") != std::string::npos) {
        return fail("--partition " + a.partition + ": not a partition name");
      }
    } else if (o == "--max-parallel") {
      if (!hil::whole_number(args[++i], 1, 1000000, n)) return fail("--max-parallel " + args[i] + ": must be a whole number in [1, 1000000]");
      a.max_parallel = static_cast<int>(n);
    } else if (o == "--shard-size") {
      if (!hil::whole_number(args[++i], 1, 1000000, n)) return fail("--shard-size " + args[i] + ": must be a whole number in [1, 1000000]");
      a.shard_size = n;
    } else if (o == "--status") {
      a.status_dir = args[++i];
    } else if (o == "--shard") {
      const std::string s = args[++i];
      const std::size_t slash = s.find('/');
      if (slash == std::string::npos || !hil::whole_number(s.substr(slash + 1), 1, 10000000, a.shard_count) ||
          !hil::whole_number(s.substr(0, slash), 0, a.shard_count - 1, a.shard_index)) {
        return fail("--shard " + s + ": expected I/N with 0 <= I < N");
      }
      a.shard = true;
    } else if (o == "--retry-failed") {
      a.retry_failed = true;
    } else if (o == "--no-wait") {
      a.no_wait = true;
    } else if (o == "--quiet") {
      a.quiet = true;
    } else if (o == "--plan") {
      a.plan_only = true;
    } else if (!o.empty() && o[0] == '-') {
      return fail("unknown option " + o);
    } else if (a.campaign.empty()) {
      a.campaign = o;
    } else {
      return fail("one campaign per sweep (got " + a.campaign + " and " + o + ")");
    }
  }
  if (!a.status_dir.empty()) {
    if (!a.campaign.empty() || !a.out_dir.empty()) return fail("--status DIR takes no campaign and no --out");
    return 0;
  }
  if (a.campaign.empty()) return fail("which campaign? (a campaigns/*.toml file)");
  if (a.plan_only) {
    if (!a.out_dir.empty() || a.executor != "local" || a.retry_failed || a.jobs != 0) {
      return fail("--plan checks the campaign and runs nothing: it takes no --out, -j, --executor or --retry-failed");
    }
    return 0;
  }
  if (a.out_dir.empty()) return fail("--out DIR is required (the sweep folder)");
  if (a.executor == "local" && (!a.partition.empty() || a.max_parallel != 0 || a.no_wait)) {
    return fail("--partition, --max-parallel and --no-wait are for --executor slurm");
  }
  return 0;
}

void print_tally(const hil::SweepTally& t, const hil::SweepFolder& f, bool quiet) {
  if (quiet) return;
  std::cout << t.ok + t.failed + t.pending << " runs: " << t.ok << " ok, " << t.failed << " failed, " << t.pending
            << " not done\nresults       " << f.dir << "/results.csv, " << f.dir << "/results.jsonl\n" << std::flush;
}

int cmd_status(const Args& a) {
  const hil::SweepFolder f{hil::absolute_folder(a.status_dir)};
  std::string campaign, why;
  if (!hil::sweep_campaign_of(f.dir, campaign, why)) {
    std::cerr << "error: " << why << "\n";
    return 1;
  }
  hil::SweepPlan plan;
  if (const int rc = hil::plan_sweep(campaign, plan, isatty(STDERR_FILENO), std::cerr); rc != 0) {
    std::cerr << "(--status plans the campaign " << campaign << " as it is now, from " << f.dir << "/sweep.json)\n";
    return rc;
  }
  std::string job, error;
  std::string state;
  if (hil::slurm_job_of(f, job, state, error)) {
    std::cout << "Slurm job " << job << ": " << (state.empty() ? "no longer queued" : state == "?" ? "unknown (" + error + ")" : state)
              << "\n";
  }
  hil::SweepTally t;
  if (!hil::merge_results(plan, f, t, error)) {
    std::cerr << "error: " << error << "\n";
    return 1;
  }
  std::cout << "campaign      " << campaign << "\n";
  print_tally(t, f, false);
  if (!state.empty()) return 5;  // queued, running or unknown: the counts so far
  return hil::sweep_exit_code(t);
}

}  // namespace

int cmd_sweep(const std::vector<std::string>& args, const std::atomic<int>& stop) {
  for (const std::string& a : args) {
    if (a == "--help" || a == "-h") {
      std::cout << kSweepHelp << std::flush;
      return std::cout ? 0 : 1;
    }
  }
  Args a;
  if (const int rc = parse_args(args, a); rc != 0) return rc;
  if (!a.status_dir.empty()) return cmd_status(a);
  if (a.shard) {
    return hil::run_shard(hil::ShardOptions{io::self_executable(), a.campaign, a.out_dir, a.shard_index, a.shard_count,
                                            a.jobs, a.quiet},
                          stop, std::cerr);
  }

  std::string sbatch;
  if (a.executor == "slurm") {
    if (const int rc = hil::check_slurm(a.partition, sbatch, std::cerr); rc != 0) return rc;
  }
  hil::SweepPlan plan;
  const auto t0 = std::chrono::steady_clock::now();
  if (const int rc = hil::plan_sweep(a.campaign, plan, !a.quiet && isatty(STDERR_FILENO), std::cerr); rc != 0) return rc;
  if (a.plan_only) {
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    rusage ru{};
    (void)getrusage(RUSAGE_SELF, &ru);  // ru_maxrss: KiB on Linux
    char figures[160];
    std::snprintf(figures, sizeof figures, "planned in %.2f s on %d CPUs, peak memory %.1f MB", s, hil::usable_cpus(),
                  static_cast<double>(ru.ru_maxrss) * 1024.0 / 1e6);
    // one line, also with --quiet: what --plan is asked for (ehpt bench reads it)
    std::cout << "campaign      " << plan.campaign.path << ": " << plan.runs.size() << " runs, every one valid; "
              << figures << "; nothing was run\n" << std::flush;
    return std::cout ? 0 : 1;
  }
  const hil::SweepFolder f{hil::absolute_folder(a.out_dir)};
  std::string error;
  // the lock lives beside DIR ("DIR.ehpt-lock"): DIR must have a name and a parent folder
  const fs::path parent = fs::path(f.dir).parent_path();
  std::error_code ec;
  if (!fs::path(f.dir).has_filename() || f.dir == parent.string()) {
    std::cerr << "error: --out " << a.out_dir << ": give a folder of its own, not the root\n";
    return 1;
  }
  if (!fs::is_directory(parent, ec)) {
    fs::create_directories(parent, ec);
    if (ec) {
      std::cerr << "error: " << parent.string() << ": cannot create: " << ec.message() << "\n";
      return 1;
    }
  }
  io::DirLock lock;
  if (!lock.acquire(f.dir, error)) {
    std::cerr << "error: " << error << "\n";
    return 1;
  }
  if (!hil::open_sweep_folder(f.dir, plan.campaign.path, error)) {
    std::cerr << "error: " << error << "\n";
    return 1;
  }
  if (hil::slurm_job_is_live(f, a.executor == "local", std::cerr)) return 1;
  const hil::SweepSelection selection = hil::select_runs(plan, f, a.retry_failed);
  const std::vector<std::size_t>& todo = selection.todo;
  const std::size_t done_before = selection.done_before, failed_before = selection.failed_before;
  if (!a.quiet) {
    std::cout << "campaign      " << plan.campaign.path << ": " << plan.runs.size() << " runs";
    if (done_before + failed_before > 0) {
      std::cout << " (" << done_before << " done and " << failed_before << " failed earlier" << (a.retry_failed ? ", retried" : "")
                << ")";
    }
    std::cout << ", " << todo.size() << " to run\n" << std::flush;
  }
  int rc = 0;
  if (!todo.empty() && a.executor == "slurm") {
    const hil::SlurmOptions so{io::self_executable(), a.partition, a.max_parallel, a.shard_size, a.no_wait, a.quiet,
                                static_cast<bool>(isatty(STDERR_FILENO))};
    rc = hil::submit_and_wait(so, sbatch, plan, todo, f, stop, std::cout, std::cerr);
    if (rc != 0 || a.no_wait) return rc;
  } else if (!todo.empty()) {
    const int jobs = a.jobs > 0 ? a.jobs : hil::usable_cpus();
    const hil::PoolOptions po{io::self_executable(), jobs, a.quiet, static_cast<bool>(isatty(STDERR_FILENO))};
    const hil::PoolCounts c = hil::run_pool(plan, todo, f, po, stop, std::cerr);
    if (stop.load() != 0) {
      if (!a.quiet) std::cerr << "interrupted: " << c.stopped << " runs stopped; they run again next time\n";
      rc = 128 + stop.load();
    }
  }
  hil::SweepTally t;
  if (!hil::merge_results(plan, f, t, error)) {
    std::cerr << "error: " << error << "\n";
    return 1;
  }
  print_tally(t, f, a.quiet);
  return rc != 0 ? rc : hil::sweep_exit_code(t);
}

}  // namespace ehpt::cli
