// SPDX-License-Identifier: BSD-3-Clause
// The Slurm executor of a sweep (sweep_slurm.hpp).
#include "hil/campaign/sweep_slurm.hpp"

#include <time.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <ostream>
#include <set>
#include <sstream>

#include "hil/campaign/sweep_pool.hpp"
#include "io/output_dir.hpp"
#include "io/process.hpp"
#include "io/sha256.hpp"
#include "io/text_file.hpp"

namespace fs = std::filesystem;

namespace ehpt::hil {

namespace {

// sbatch, squeue and sinfo retry for a long time when slurmctld is down: give up after this
constexpr double kSlurmCommandTimeout_s = 120.0;

// 'text' as one word of a POSIX shell script: single quotes, a quote as '\''.
std::string shell_word(const std::string& text) {
  std::string out = "'";
  for (const char c : text) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::string first_line(const std::string& text) {
  std::string line = text.substr(0, text.find('\n'));
  while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
  return line;
}

// The job's state from squeue: "" when it is no longer queued or running (or unknown).
// The job name of the sweep in f: the folder's hash, so that a job id the cluster reused (a
// test cluster numbers from 1 again) is never taken for ours.
std::string job_name(const SweepFolder& f) { return "ehpt-sweep-" + io::sha256_hex(f.dir).substr(0, 12); }

// The state of our job (named job_name): "" when it is no longer queued or running, or the id
// now names another job; "?" when squeue cannot tell (error says why).
std::string job_state(const std::string& job, const std::string& name, std::string& error) {
  const std::string squeue = io::find_program("squeue");
  if (squeue.empty()) {
    error = "squeue not found on PATH";
    return "?";
  }
  std::string output, reason;
  const int rc = io::capture_program({squeue, "-h", "-j", job, "-o", "%T %j"}, output, kSlurmCommandTimeout_s, reason);
  if (rc < 0) {
    error = reason;
    return "?";
  }
  if (rc != 0) {
    // a job that left slurmctld's memory: "Invalid job id specified"
    if (output.find("Invalid job id") != std::string::npos) return "";
    error = "squeue: " + first_line(output);
    return "?";
  }
  // one line per array task (or per pending range): the distinct states
  std::set<std::string> states;
  std::istringstream lines(output);
  for (std::string line; std::getline(lines, line);) {
    const std::size_t sp = line.find(' ');
    if (sp != std::string::npos && line.substr(sp + 1) == name) states.insert(line.substr(0, sp));
  }
  std::string text;
  for (const std::string& s : states) text += (text.empty() ? "" : ",") + s;
  return text;
}

// Sleeps up to s seconds; false if a stop signal came.
bool nap(double s, const std::atomic<int>& stop) {
  const double end = now_s() + s;
  while (now_s() < end) {
    if (stop.load() != 0) return false;
    timespec ts{0, 100'000'000};
    nanosleep(&ts, nullptr);
  }
  return stop.load() == 0;
}

std::size_t count_recorded(const SweepFolder& f, const std::vector<std::string>& ids) {
  std::size_t n = 0;
  for (const std::string& id : ids) n += read_outcome(f, id).recorded ? 1 : 0;
  return n;
}

// sbatch expands %A, %a, %j, ... in --output: a '%' of the folder's name is written %%.
std::string slurm_pattern_escaped(const std::string& path) {
  std::string out;
  for (const char c : path) out += c == '%' ? std::string("%%") : std::string(1, c);
  return out;
}

// The cluster's MaxArraySize (scontrol show config), 0 if it cannot be read.
std::int64_t max_array_size() {
  const std::string scontrol = io::find_program("scontrol");
  std::string output, reason;
  if (scontrol.empty() ||
      io::capture_program({scontrol, "show", "config"}, output, kSlurmCommandTimeout_s, reason) != 0) {
    return 0;
  }
  std::istringstream lines(output);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("MaxArraySize", 0) != 0) continue;
    const std::size_t eq = line.find('=');
    std::string v = eq == std::string::npos ? "" : line.substr(eq + 1);
    v.erase(0, v.find_first_not_of(' '));
    std::int64_t n = 0;
    return whole_number(first_line(v), 1, 100'000'000, n) ? n : 0;
  }
  return 0;
}

}  // namespace

int check_slurm(const std::string& partition, std::string& sbatch, std::ostream& err) {
  sbatch = io::find_program("sbatch");
  if (sbatch.empty()) {
    err << "error: --executor slurm: sbatch not found on PATH (Slurm's client commands); nothing was submitted\n";
    return 1;
  }
  if (!partition.empty()) {
    const std::string sinfo = io::find_program("sinfo");
    std::string output, reason;
    const int rc = sinfo.empty() ? -1
                                 : io::capture_program({sinfo, "-h", "-p", partition, "-o", "%P"}, output,
                                                       kSlurmCommandTimeout_s, reason);
    if (rc != 0) {
      err << "error: --partition " << partition << ": cannot ask Slurm (sinfo: "
                << (sinfo.empty() ? "not found on PATH" : rc < 0 ? reason : first_line(output)) << "); nothing was submitted\n";
      return 1;
    }
    if (first_line(output).empty()) {
      err << "error: --partition " << partition << ": no such partition in this Slurm cluster ('sinfo' lists "
                << "them); nothing was submitted\n";
      return 1;
    }
  }
  return 0;
}

bool slurm_job_is_live(const SweepFolder& f, bool unknown_ok, std::ostream& err) {
  std::string job, reason, error;
  if (!io::read_text_file(f.slurm("job_id"), job, reason)) return false;
  job = first_line(job);
  const std::string state = job_state(job, job_name(f), error);
  if (state.empty()) return false;
  if (state == "?" && unknown_ok) {
    err << "warning: cannot tell whether Slurm job " << job << " of this sweep still runs (" << error << ")\n";
    return false;
  }
  err << "error: Slurm job " << job << " of this sweep is " << (state == "?" ? "in an unknown state (" + error + ")" : state)
            << "; wait for it ('ehpt sweep --status " << f.dir << "') or scancel it; nothing was run\n";
  return true;
}

int submit_and_wait(const SlurmOptions& a, const std::string& sbatch, const SweepPlan& plan,
                    const std::vector<std::size_t>& todo, const SweepFolder& f, const std::atomic<int>& stop,
                    std::ostream& out, std::ostream& err) {
  std::string error;
  if (!make_subfolders(f.dir, {"slurm"}, error)) {
    err << "error: " << error << "; nothing was submitted\n";
    return 1;
  }
  std::string reason;
  std::string queue;
  std::vector<std::string> ids;
  for (const std::size_t i : todo) {
    queue += std::to_string(plan.runs[i].index) + " " + plan.runs[i].id + "\n";
    ids.push_back(plan.runs[i].id);
  }
  // a job array has at most MaxArraySize tasks (Slurm's default 1001): larger shards if needed
  std::int64_t shard_size = a.shard_size;
  const std::int64_t runs = static_cast<std::int64_t>(todo.size());
  if (const std::int64_t max_tasks = max_array_size(); max_tasks > 0 && (runs + shard_size - 1) / shard_size > max_tasks) {
    shard_size = (runs + max_tasks - 1) / max_tasks;
    if (!a.quiet) {
      out << "note: " << runs << " runs in shards of " << a.shard_size << " would be more array tasks than this "
                << "cluster's MaxArraySize (" << max_tasks << "): shards of " << shard_size << "\n";
    }
  }
  const std::int64_t shards = (runs + shard_size - 1) / shard_size;
  const std::string& exe = a.ehpt;
  std::error_code ec;
  const std::string cwd = fs::current_path(ec).string();
  const std::string script =
      "#!/bin/sh\n"
      "# written by ehpt sweep: one array task runs one part of the queue (slurm/queue.txt)\n"
      "cd " + shell_word(cwd) + " || exit 1\n"
      "exec " + shell_word(exe) + " sweep " + shell_word(plan.campaign.path) + " --out " + shell_word(f.dir) +
      " --shard \"$SLURM_ARRAY_TASK_ID/" + std::to_string(shards) + "\" --quiet\n";
  if (!io::write_file_atomically(f.slurm("queue.txt"), queue, error) ||
      !io::write_file_atomically(f.slurm("sweep.sbatch"), script, error)) {
    err << "error: " << error << "\n";
    return 1;
  }
  std::string array = "--array=0-" + std::to_string(shards - 1);
  if (a.max_parallel > 0) array += "%" + std::to_string(a.max_parallel);
  std::vector<std::string> argv{sbatch, "--parsable", array, "--job-name=" + job_name(f),
                                "--output=" + slurm_pattern_escaped(f.slurm("")) + "task-%A_%a.out"};
  if (!a.partition.empty()) argv.push_back("--partition=" + a.partition);
  argv.push_back(f.slurm("sweep.sbatch"));
  std::string output;
  const int rc = io::capture_program(argv, output, kSlurmCommandTimeout_s, reason);
  if (rc != 0) {
    err << "error: sbatch: " << (rc < 0 ? reason : first_line(output)) << "; nothing was submitted\n";
    return 1;
  }
  const std::string job = first_line(output).substr(0, first_line(output).find(';'));
  if (job.empty() || job.find_first_not_of("0123456789") != std::string::npos) {
    err << "error: sbatch answered \"" << first_line(output) << "\", not a job id\n";
    return 1;
  }
  if (!io::write_file_atomically(f.slurm("job_id"), job + "\n", error)) err << "error: " << error << "\n";
  if (!a.quiet) {
    out << "submitted Slurm job " << job << ": " << todo.size() << " runs in " << shards << " array tasks of up to "
              << shard_size << "\n" << std::flush;
  }
  if (a.no_wait) {
    if (!a.quiet) out << "'ehpt sweep --status " << f.dir << "' shows the progress and merges the results\n";
    return 0;
  }
  const double t0 = now_s();
  const bool tty = !a.quiet && a.tty;
  double shown = 0.0;
  for (;;) {
    if (!nap(2.0, stop)) {
      std::string cancel_reason, cancel_output;
      const std::string scancel = io::find_program("scancel");
      if (!scancel.empty()) (void)io::capture_program({scancel, job}, cancel_output, kSlurmCommandTimeout_s, cancel_reason);
      err << "\ninterrupted: Slurm job " << job << " cancelled; runs that ended are kept\n";
      return 128 + stop.load();
    }
    const std::string state = job_state(job, job_name(f), error);
    const std::size_t ended = count_recorded(f, ids);
    if (tty) {
      err << "\r\033[K[" << ended << "/" << ids.size() << "] job " << job << " " << (state.empty() ? "done" : state)
                << ", " << duration_text(now_s() - t0) << std::flush;
    } else if (!a.quiet && now_s() - shown > 30.0) {
      shown = now_s();
      err << "[" << ended << "/" << ids.size() << "] job " << job << " " << state << "\n";
    }
    if (state.empty()) break;
  }
  if (tty) err << "\n";
  return 0;
}

int run_shard(const ShardOptions& a, const std::atomic<int>& stop, std::ostream& err) {
  SweepPlan plan;
  std::vector<std::string> errors;
  if (!hil::load_campaign(a.campaign, plan.campaign, errors)) {
    for (const std::string& e : errors) err << e << "\n";
    return 2;
  }
  const SweepFolder f{absolute_folder(a.out_dir)};
  std::string theirs, why;
  if (!sweep_campaign_of(f.dir, theirs, why) || theirs != plan.campaign.path) {
    err << "error: " << (why.empty() ? f.dir + " is the sweep of " + theirs : why) << "\n";
    return 1;
  }
  std::string queue, reason;
  if (!io::read_text_file(f.slurm("queue.txt"), queue, reason)) {
    err << "error: " << f.slurm("queue.txt") << ": " << reason << "\n";
    return 1;
  }
  std::vector<std::pair<std::uint64_t, std::string>> entries;
  std::istringstream lines(queue);
  int line_no = 0;
  for (std::string line; std::getline(lines, line);) {
    ++line_no;
    // "INDEX ID": the id names a file under DIR/status, so nothing but 64 hex digits is taken
    const std::size_t sp = line.find(' ');
    std::int64_t index = 0;
    if (sp == std::string::npos || !whole_number(line.substr(0, sp), 0, INT64_MAX / 2, index) ||
        !is_run_id(line.substr(sp + 1))) {
      err << "error: " << f.slurm("queue.txt") << ":" << line_no << ": not \"INDEX RUN_ID\"; the queue is damaged\n";
      return 1;
    }
    entries.emplace_back(static_cast<std::uint64_t>(index), line.substr(sp + 1));
  }
  const std::size_t n = entries.size(), parts = static_cast<std::size_t>(a.shard_count);
  const std::size_t per = (n + parts - 1) / parts;
  const std::size_t begin = std::min(n, static_cast<std::size_t>(a.shard_index) * per), end = std::min(n, begin + per);
  const std::uint64_t total = hil::campaign_run_count(plan.campaign);
  std::vector<std::size_t> todo;
  LoadCache cache;  // the queue's runs read the same files
  for (std::size_t e = begin; e < end; ++e) {
    // plain names, not a structured binding: clang 14 cannot capture one in a lambda
    const std::uint64_t index = entries[e].first;
    const std::string& id = entries[e].second;
    // the campaign or a file changed since the submission: the queued run is not the run at
    // that index any more. Nothing is recorded (it stays pending for the next sweep).
    const auto changed = [&] {
      err << "run " << index << " (" << id << "): the campaign or its files changed since the job was "
                << "submitted; not run (run the sweep again)\n";
    };
    if (index >= total) {
      changed();
      continue;
    }
    PlannedRun p = plan_run(plan.campaign, index, cache);
    if (p.id != id) {
      changed();
      continue;
    }
    if (run_done(f, id, read_outcome(f, id))) continue;
    todo.push_back(plan.runs.size());
    plan.runs.push_back(std::move(p));
  }
  const char* cpus = std::getenv("SLURM_CPUS_PER_TASK");
  std::int64_t jobs = a.jobs;
  if (jobs == 0 && (cpus == nullptr || !whole_number(cpus, 1, 4096, jobs))) jobs = 1;
  const PoolCounts c = run_pool(plan, todo, f, PoolOptions{a.ehpt, static_cast<int>(jobs), true, false}, stop, err);
  if (!a.quiet) err << "shard " << a.shard_index << "/" << a.shard_count << ": " << c.ok << " ok, " << c.failed << " failed\n";
  return stop.load() != 0 ? 128 + stop.load() : 0;
}

bool slurm_job_of(const SweepFolder& f, std::string& job, std::string& state, std::string& error) {
  std::string reason;
  if (!io::read_text_file(f.slurm("job_id"), job, reason)) return false;
  job = first_line(job);
  state = job_state(job, job_name(f), error);
  return true;
}

}  // namespace ehpt::hil
