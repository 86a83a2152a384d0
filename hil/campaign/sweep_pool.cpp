// SPDX-License-Identifier: BSD-3-Clause
// The local process pool (sweep_pool.hpp).
#include "hil/campaign/sweep_pool.hpp"

#include <sched.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <map>
#include <ostream>
#include <sstream>

#include "io/output_dir.hpp"
#include "io/process.hpp"

namespace ehpt::hil {

int usable_cpus() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) == 0) return std::max(1, CPU_COUNT(&set));
  const long online = sysconf(_SC_NPROCESSORS_ONLN);  // -1 if unknown
  return online > 0 ? static_cast<int>(std::min(online, 4096L)) : 1;
}

PoolCounts run_pool(const SweepPlan& plan, const std::vector<std::size_t>& todo, const SweepFolder& f,
                    const PoolOptions& options, const std::atomic<int>& stop, std::ostream& err) {
  PoolCounts counts;
  const std::string& exe = options.ehpt;
  const int jobs = options.jobs;
  const bool quiet = options.quiet;
  // each run ends (SIGTERM) when this process dies, even by SIGKILL (targets/ehpt_main.cpp)
  const std::vector<std::string> child_env{"EHPT_SWEEP_PID=" + std::to_string(::getpid())};
  const bool tty = !quiet && options.tty;
  std::map<int, std::size_t> running;  // pid -> run
  std::size_t next = 0, ended = 0;
  bool forwarded = false;
  const double t0 = now_s();
  std::size_t last_decile = 0;
  const auto show = [&](bool final) {
    if (quiet) return;
    const double elapsed = now_s() - t0;
    const std::size_t left = todo.size() - ended;
    std::ostringstream line;
    line << "[" << ended << "/" << todo.size() << "] " << counts.ok << " ok, " << counts.failed << " failed, "
         << running.size() << " running";
    if (ended > 0 && left > 0) line << ", about " << duration_text(elapsed / static_cast<double>(ended) * static_cast<double>(left)) << " left";
    if (final) line << ", " << duration_text(elapsed);
    if (tty) {
      err << "\r\033[K" << line.str() << (final ? "\n" : "") << std::flush;
    } else if (final || (todo.size() >= 10 && ended * 10 / todo.size() > last_decile)) {
      last_decile = ended * 10 / todo.size();
      err << line.str() << "\n";
    }
  };
  for (;;) {
    while (stop.load() == 0 && running.size() < static_cast<std::size_t>(jobs) && next < todo.size()) {
      const PlannedRun& run = plan.runs[todo[next++]];
      std::vector<std::string> argv{exe, "run", plan.campaign.scenarios[run.scenario].path, "--out", f.run_dir(run.id),
                                    "--quiet"};
      for (const CampaignOverride& o : overrides_of(plan.campaign, run)) {
        argv.push_back("--set");
        argv.push_back(o.set_text());
      }
      std::string reason;
      // in our process group: a Ctrl-C at the terminal reaches every run, which ends cleanly
      const int pid = io::start_program(argv, "/dev/null", f.log_file(run.id), false, reason, child_env);
      if (pid < 0) {
        std::string error;
        (void)io::write_file_atomically(f.status_file(run.id), "exit 1\ncannot start ehpt run: " + reason + "\n", error);
        ++counts.failed;
        ++ended;
        continue;
      }
      running.emplace(pid, todo[next - 1]);
    }
    if (running.empty()) break;
    show(false);
    int status = 0;
    const int pid = ::waitpid(-1, &status, 0);
    if (pid < 0) {
      if (errno == EINTR) {
        if (stop.load() != 0 && !forwarded) {
          // a signal sent to us alone (kill, Slurm's scancel): pass it on to the runs
          for (const auto& [child, run] : running) ::kill(child, stop.load());
          forwarded = true;
        }
        continue;
      }
      err << "error: waitpid: " << std::strerror(errno) << "\n";
      break;
    }
    const auto it = running.find(pid);
    if (it == running.end()) continue;
    const PlannedRun& run = plan.runs[it->second];
    running.erase(it);
    ++ended;
    const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    if (stop.load() != 0 && code >= 128) {
      ++counts.stopped;  // not recorded: it runs again next time
      continue;
    }
    if (code == 1 && folder_busy(f, run)) {
      // another process (a run of a killed sweep, a task of a job) holds the run's folder:
      // not a result; the run stays pending
      ++counts.stopped;
      if (!quiet) err << "\nwarning: " << f.run_dir(run.id) << " is being written by another process; not run\n";
      continue;
    }
    std::string error;
    const std::string record = "exit " + std::to_string(code) + "\n" + (code == 0 ? "" : failure_message(f, run.id, overrides_of(plan.campaign, run), code) + "\n");
    if (!io::write_file_atomically(f.status_file(run.id), record, error)) err << "error: " << error << "\n";
    (code == 0 ? counts.ok : counts.failed) += 1;
  }
  show(true);
  return counts;
}

}  // namespace ehpt::hil
