// SPDX-License-Identifier: BSD-3-Clause
// `ehpt sweep`: a campaign's runs, each an `ehpt run` child (so a run that fails, or even
// crashes, fails alone), from a local process pool or from the tasks of a Slurm job array,
// into a folder that says what is done:
//
//   DIR/sweep.json            which campaign this folder belongs to
//   DIR/runs/<id>/            the run's output folder (ehpt run --out: summary.json, ...)
//   DIR/status/<id>.txt       the run's exit code and, if it failed, why (written when it ends)
//   DIR/logs/<id>.log         the run's stderr
//   DIR/results.csv, .jsonl   merged: one row per run of the campaign as it is now
//   DIR/slurm/                the job-array script, the queue of its runs, the tasks' output
//
// A run's id is its content address (hil/campaign/campaign.hpp): running the campaign again skips
// every run with a status, and a changed input file or value gives new ids, so exactly the
// affected runs run again. Nothing outside DIR is written; nothing in DIR is removed.

#include "targets/sweep.hpp"

#include <sched.h>
#include <signal.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <initializer_list>
#include <iostream>
#include <map>
#include <set>
#include <sstream>

#include <toml++/toml.h>

#include "hil/campaign/campaign.hpp"
#include "hil/config/config.hpp"
#include "io/json_value.hpp"
#include "io/number_format.hpp"
#include "io/output_dir.hpp"
#include "io/process.hpp"
#include "io/sha256.hpp"
#include "io/text_file.hpp"

namespace fs = std::filesystem;
using ehpt::hil::Campaign;
using ehpt::hil::CampaignOverride;

const char* const kSweepHelp =
    "usage: ehpt sweep CAMPAIGN --out DIR [-j N] [--retry-failed] [--quiet]\n"
    "       ehpt sweep CAMPAIGN --out DIR --executor slurm [--partition P] [--max-parallel M]\n"
    "                  [--shard-size K] [--no-wait] [--retry-failed] [--quiet]\n"
    "       ehpt sweep --status DIR\n"
    "\n"
    "Runs every run of a campaign (campaigns/*.toml: scenarios x [grid] x variants; the format\n"
    "is in hil/campaign/campaign.hpp and the README, \"Campaigns\") as 'ehpt run' and merges the\n"
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
    "  --status DIR       runs done, failed and pending, the Slurm job's state; merges the\n"
    "                     results so far (exit 5 while the job is queued or running)\n"
    "  --shard I/N        (run by each array task) run the I-th of N parts of DIR's queue\n"
    "Exit codes: 0 all runs ok, 1 usage, folder or system error, 2 invalid campaign (nothing\n"
    "run), 3 some runs failed (see results.csv), 4 some runs are not done (stopped, or a Slurm\n"
    "task died: see DIR/slurm/; run the sweep again), 5 (--status) the Slurm job is still queued\n"
    "or running or its state is unknown, 130 Ctrl-C (runs under way are stopped and run again\n"
    "next time).\n";

namespace {

using namespace ehpt;

constexpr const char* kSweepFormat = "ehpt sweep folder 1";
constexpr std::int64_t kDefaultShardSize = 16;
// sbatch, squeue and sinfo retry for a long time when slurmctld is down: give up after this
constexpr double kSlurmCommandTimeout_s = 120.0;

struct PlannedRun {
  std::uint64_t index = 0;
  std::size_t scenario = 0;
  std::vector<CampaignOverride> overrides;
  std::string id;
};

struct Plan {
  Campaign campaign;
  std::vector<PlannedRun> runs;
};

struct Folder {
  std::string dir;
  std::string run_dir(const std::string& id) const { return dir + "/runs/" + id; }
  std::string status_file(const std::string& id) const { return dir + "/status/" + id + ".txt"; }
  std::string log_file(const std::string& id) const { return dir + "/logs/" + id + ".log"; }
  std::string slurm(const std::string& name) const { return dir + "/slurm/" + name; }
};

// A whole decimal number in [lo, hi] (at most 18 digits: no overflow), nothing else.
bool whole_number(const std::string& text, std::int64_t lo, std::int64_t hi, std::int64_t& out) {
  if (text.empty() || text.size() > 18 || text.find_first_not_of("0123456789") != std::string::npos) return false;
  out = std::stoll(text);
  return out >= lo && out <= hi;
}

bool is_run_id(const std::string& s) {
  return s.size() == 64 && s.find_first_not_of("0123456789abcdef") == std::string::npos;
}

double now_s() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

std::string duration_text(double s) {
  const long long t = std::llround(std::max(0.0, s));
  std::ostringstream o;
  if (t >= 3600) o << t / 3600 << " h ";
  if (t >= 60) o << (t / 60) % 60 << " min ";
  o << t % 60 << " s";
  return o.str();
}

// The CPUs this process may run on (Slurm and cgroups restrict it; nproc says the same).
int usable_cpus() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) == 0) return std::max(1, CPU_COUNT(&set));
  const long online = sysconf(_SC_NPROCESSORS_ONLN);  // -1 if unknown
  return online > 0 ? static_cast<int>(std::min(online, 4096L)) : 1;
}

// A loader message names an override as "--set key=value": say where the campaign wrote it.
std::string blame(std::string message, const std::vector<CampaignOverride>& overrides) {
  for (const CampaignOverride& o : overrides) {
    const std::string label = "--set " + o.set_text();
    for (std::size_t at = message.find(label); at != std::string::npos; at = message.find(label, at + 1)) {
      // only the whole label ("--set a=1" is not "--set a=10")
      const std::size_t end = at + label.size();
      if (end < message.size() && message[end] != ':' && message[end] != ' ') continue;
      const std::string where = o.where + " (" + o.set_text() + ")";
      message.replace(at, label.size(), where);
      at += where.size() - 1;
    }
  }
  return message;
}

// ---- planning ------------------------------------------------------------------------------

// Loads the campaign and every run's scenario (its files give the run's id). A problem that
// comes from the campaign's [set], [grid] or [output], or from a scenario itself, is a problem
// of the campaign: reported, nothing runs (2). A variant whose value the scenario refuses is
// a run that will fail alone (its ehpt run says why, exit 2).
int plan_campaign(const std::string& path, Plan& plan, bool progress) {
  std::vector<std::string> errors;
  if (!hil::load_campaign(path, plan.campaign, errors)) {
    for (const std::string& e : errors) std::cerr << e << "\n";
    std::cerr << "the campaign is not valid; nothing was run\n";
    return 2;
  }
  const Campaign& c = plan.campaign;
  const std::uint64_t n = hil::campaign_run_count(c);
  const std::size_t not_variant = c.fixed.size() + c.grid.size();
  std::vector<std::string> problems;
  std::set<std::string> problem_set;
  std::map<std::string, std::uint64_t> ids;
  plan.runs.reserve(static_cast<std::size_t>(n));
  const double t0 = now_s();
  double shown = t0;
  for (std::uint64_t i = 0; i < n; ++i) {
    hil::CampaignRun r = hil::campaign_run(c, i);
    std::vector<std::string> sets;
    for (const CampaignOverride& o : r.overrides) sets.push_back(o.set_text());
    hil::Scenario sc;
    std::vector<std::string> load_errors;
    if (!hil::load_scenario(c.scenarios[r.scenario].path, sets, sc, load_errors)) {
      // the variant's fault if the run loads without the variant's values (a cross-field check
      // such as ecu.period_s against solver.step_s names neither): it then fails alone
      bool variant_refused = false;
      if (r.overrides.size() > not_variant) {
        const std::vector<std::string> without(sets.begin(), sets.begin() + static_cast<std::ptrdiff_t>(not_variant));
        hil::Scenario probe;
        std::vector<std::string> probe_errors;
        variant_refused = hil::load_scenario(c.scenarios[r.scenario].path, without, probe, probe_errors);
      }
      if (!variant_refused) {
        std::string with;  // the values of this run, for a message that names none of them
        for (std::size_t k = c.fixed.size(); k < not_variant; ++k) {
          with += (with.empty() ? "" : ", ") + r.overrides[k].set_text() + " (" + r.overrides[k].where + ")";
        }
        for (const std::string& e : load_errors) {
          std::string m = c.scenarios[r.scenario].name + ": " + blame(e, r.overrides);
          if (m == c.scenarios[r.scenario].name + ": " + e && !with.empty()) m += " [in the run with " + with + "]";
          if (problem_set.insert(m).second) problems.push_back(m);
        }
      }
    }
    PlannedRun p{i, r.scenario, std::move(r.overrides), ""};
    p.id = hil::run_id(sc.inputs, p.overrides);
    if (const auto [it, fresh] = ids.emplace(p.id, i); !fresh) {
      const std::string m = "runs " + std::to_string(it->second) + " and " + std::to_string(i) +
                            " are the same run (the same files and values; two scenarios with identical files?)";
      if (problem_set.insert(m).second) problems.push_back(m);
    }
    plan.runs.push_back(std::move(p));
    if (progress && now_s() - shown > 0.5) {
      shown = now_s();
      std::cerr << "\rplanning: " << i + 1 << "/" << n << " runs loaded" << std::flush;
    }
  }
  if (progress && shown != t0) std::cerr << "\r\033[K";
  if (!problems.empty()) {
    constexpr std::size_t kShown = 40;
    for (std::size_t i = 0; i < std::min(kShown, problems.size()); ++i) std::cerr << problems[i] << "\n";
    if (problems.size() > kShown) std::cerr << "... and " << problems.size() - kShown << " more problems\n";
    std::cerr << "the campaign is not valid; nothing was run\n";
    return 2;
  }
  return 0;
}

// ---- the sweep folder ----------------------------------------------------------------------

// Reads "campaign" from DIR/sweep.json; false if DIR has no sweep.json (or it is not ours).
bool sweep_campaign_of(const std::string& dir, std::string& campaign, std::string& why) {
  std::string text, reason;
  if (!io::read_text_file(dir + "/sweep.json", text, reason)) {
    why = dir + "/sweep.json: " + reason;
    return false;
  }
  io::JsonValue v;
  std::string error;
  if (!io::parse_json(text, v, error)) {
    why = dir + "/sweep.json: " + error;
    return false;
  }
  const io::JsonValue* f = v.find("format");
  const io::JsonValue* c = v.find("campaign");
  const std::string format = f != nullptr && f->kind == io::JsonValue::Kind::kString ? f->text : "";
  campaign = c != nullptr && c->kind == io::JsonValue::Kind::kString ? c->text : "";
  if (format != kSweepFormat || campaign.empty()) {
    why = dir + "/sweep.json: not an ehpt sweep folder (format \"" + format + "\")";
    return false;
  }
  return true;
}

// DIR's own folders: made if missing; one that is a symbolic link or not a folder is refused
// (the runs, statuses and logs would be written wherever it points).
bool make_subfolders(const std::string& dir, std::initializer_list<const char*> subs, std::string& error) {
  for (const char* sub : subs) {
    const std::string p = dir + "/" + sub;
    std::error_code ec;
    const fs::file_status st = fs::symlink_status(p, ec);
    if (fs::is_symlink(st) || (fs::exists(st) && !fs::is_directory(st))) {
      error = p + ": is " + (fs::is_symlink(st) ? std::string("a symbolic link") : io::describe_path(p)) +
              ", not a folder of this sweep; refused";
      return false;
    }
    fs::create_directory(p, ec);
    if (ec) {
      error = p + ": cannot create: " + ec.message();
      return false;
    }
  }
  return true;
}

// DIR for this campaign: made if missing; an empty folder is claimed; an earlier sweep of the
// same campaign is resumed. Anything else (another campaign's sweep, a folder of other files,
// a symbolic link) is refused before anything is written.
bool open_folder(const std::string& dir, const std::string& campaign, std::string& error) {
  std::error_code ec;
  const fs::file_status st = fs::symlink_status(dir, ec);
  if (fs::is_symlink(st)) {
    error = dir + ": is a symbolic link; give the folder itself";
    return false;
  }
  if (fs::exists(st)) {
    if (!fs::is_directory(st)) {
      error = dir + ": exists and is " + io::describe_path(dir) + ", not a sweep folder";
      return false;
    }
    std::string theirs, why;
    if (fs::exists(dir + "/sweep.json", ec)) {
      if (!sweep_campaign_of(dir, theirs, why)) {
        error = why;
        return false;
      }
      if (theirs != campaign) {
        error = dir + " holds the sweep of another campaign (" + theirs + "); give another --out";
        return false;
      }
    } else if (!fs::is_empty(dir, ec)) {
      std::string names;
      int shown = 0;
      for (const auto& e : fs::directory_iterator(dir, ec)) {
        if (shown++ < 3) names += (names.empty() ? "" : ", ") + e.path().filename().string();
      }
      error = dir + " exists and is not an ehpt sweep folder (it holds " + names + (shown > 3 ? ", ..." : "") +
              "); give a new or empty folder";
      return false;
    } else {
      io::JsonObject j;
      j.text("format", kSweepFormat);
      j.text("campaign", campaign);
      if (!io::write_file_atomically(dir + "/sweep.json", j.str() + "\n", error)) return false;
    }
  } else {
    if (!fs::create_directories(dir, ec) && ec) {
      error = dir + ": cannot create: " + ec.message();
      return false;
    }
    io::JsonObject j;
    j.text("format", kSweepFormat);
    j.text("campaign", campaign);
    if (!io::write_file_atomically(dir + "/sweep.json", j.str() + "\n", error)) return false;
  }
  return make_subfolders(dir, {"runs", "status", "logs"}, error);
}

// Absolute and without a trailing '/': the job-array script and its tasks name the same folder
// from anywhere, and the lock beside it is "DIR.ehpt-lock", not a file inside it.
std::string absolute_folder(const std::string& dir) {
  std::error_code ec;
  fs::path p = fs::absolute(dir, ec).lexically_normal();
  if (ec) p = fs::path(dir).lexically_normal();
  if (!p.has_filename() && p.has_parent_path() && p != p.root_path()) p = p.parent_path();
  return p.string();
}

// ---- outcomes ------------------------------------------------------------------------------

struct Outcome {
  bool recorded = false;
  int exit_code = -1;
  std::string message;
};

Outcome read_outcome(const Folder& f, const std::string& id) {
  Outcome o;
  std::string text, reason;
  if (!io::read_text_file(f.status_file(id), text, reason)) return o;
  if (text.rfind("exit ", 0) != 0) return o;
  const std::size_t nl = text.find('\n');
  std::int64_t code = -1;
  // a whole number 0..255 (an exit status), else the file is not ours or damaged: not recorded
  if (!whole_number(text.substr(5, nl == std::string::npos ? std::string::npos : nl - 5), 0, 255, code)) return o;
  o.recorded = true;
  o.exit_code = static_cast<int>(code);
  if (nl != std::string::npos) o.message = text.substr(nl + 1);
  while (!o.message.empty() && o.message.back() == '\n') o.message.pop_back();
  return o;
}

// Done: ended with exit 0 and its folder is there (committed at once with its summary.json);
// a run whose folder went missing runs again.
bool done(const Folder& f, const std::string& id, const Outcome& o) {
  std::error_code ec;
  return o.recorded && o.exit_code == 0 && fs::is_regular_file(f.run_dir(id) + "/summary.json", ec);
}
bool failed(const Outcome& o) { return o.recorded && o.exit_code != 0; }

// What the run's stderr says, on one line, the campaign's locations in place of --set labels.
std::string failure_message(const Folder& f, const PlannedRun& run, int code) {
  std::string text, reason;
  (void)io::read_text_file(f.log_file(run.id), text, reason);
  std::string message;
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    // warnings, and the loader's closing count ("1 problem; nothing was run."), say nothing more
    if (line.empty() || line.rfind("warning: ", 0) == 0 || line.ends_with("nothing was run.")) continue;
    message += (message.empty() ? "" : " | ") + line;
    if (message.size() > 2000) {
      message.resize(2000);
      message += "...";
      break;
    }
  }
  if (message.empty()) {
    message = code > 128 ? "killed by signal " + std::to_string(code - 128) : "exit " + std::to_string(code);
  }
  return blame(message, run.overrides);
}

// The run's log says its folder is locked by another ehpt run (DirLock's message).
bool folder_busy(const Folder& f, const PlannedRun& run) {
  std::string text, reason;
  return io::read_text_file(f.log_file(run.id), text, reason) &&
         text.find("another ehpt run is writing this folder") != std::string::npos;
}

// ---- the local pool ------------------------------------------------------------------------

struct Counts {
  std::size_t ok = 0, failed = 0, stopped = 0;
};

// Runs the given runs, `jobs` at a time, each as `ehpt run ... --out DIR/runs/<id>`. A run's
// outcome is recorded when it ends; a run stopped by our signal is not (it runs next time).
Counts run_pool(const Plan& plan, const std::vector<std::size_t>& todo, const Folder& f, int jobs, bool quiet,
                const std::atomic<int>& stop) {
  Counts counts;
  const std::string exe = io::self_executable();
  // each run ends (SIGTERM) when this process dies, even by SIGKILL (targets/ehpt_main.cpp)
  const std::vector<std::string> child_env{"EHPT_SWEEP_PID=" + std::to_string(::getpid())};
  const bool tty = !quiet && isatty(STDERR_FILENO);
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
      std::cerr << "\r\033[K" << line.str() << (final ? "\n" : "") << std::flush;
    } else if (final || (todo.size() >= 10 && ended * 10 / todo.size() > last_decile)) {
      last_decile = ended * 10 / todo.size();
      std::cerr << line.str() << "\n";
    }
  };
  for (;;) {
    while (stop.load() == 0 && running.size() < static_cast<std::size_t>(jobs) && next < todo.size()) {
      const PlannedRun& run = plan.runs[todo[next++]];
      std::vector<std::string> argv{exe, "run", plan.campaign.scenarios[run.scenario].path, "--out", f.run_dir(run.id),
                                    "--quiet"};
      for (const CampaignOverride& o : run.overrides) {
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
      std::cerr << "error: waitpid: " << std::strerror(errno) << "\n";
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
      if (!quiet) std::cerr << "\nwarning: " << f.run_dir(run.id) << " is being written by another process; not run\n";
      continue;
    }
    std::string error;
    const std::string record = "exit " + std::to_string(code) + "\n" + (code == 0 ? "" : failure_message(f, run, code) + "\n");
    if (!io::write_file_atomically(f.status_file(run.id), record, error)) std::cerr << "error: " << error << "\n";
    (code == 0 ? counts.ok : counts.failed) += 1;
  }
  show(true);
  return counts;
}

// ---- merging -------------------------------------------------------------------------------

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
  std::string out = "\"";
  for (const char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

// An override's value for the results: a string without its TOML quotes, else as written.
std::string plain_value(const std::string& toml_text) {
  if (toml_text.empty() || toml_text.front() != '"') return toml_text;
  try {
    const toml::table t = toml::parse("v = " + toml_text);
    if (const auto s = t["v"].value<std::string>()) return *s;
  } catch (const toml::parse_error&) {
  }
  return toml_text;
}

// The value as JSON: numbers and booleans as they are (when JSON reads them), else a string.
std::string json_value_text(const std::string& toml_text) {
  const std::string plain = plain_value(toml_text);
  if (plain == toml_text) {
    io::JsonValue v;
    std::string error;
    if (io::parse_json(toml_text, v, error) && v.kind != io::JsonValue::Kind::kString) return toml_text;
  }
  return io::json_escape(plain);
}

struct Tally {
  std::size_t ok = 0, failed = 0, pending = 0;
};

// results.csv and results.jsonl for the campaign as planned, written atomically.
bool merge(const Plan& plan, const Folder& f, Tally& tally, std::string& error) {
  const Campaign& c = plan.campaign;
  const std::vector<std::string> swept = c.swept_keys();
  struct Row {
    Outcome outcome;
    std::string status;  // ok, failed, pending
    std::vector<std::pair<std::string, std::string>> fields;  // the summary, flattened
    std::string summary_json;                                  // compact
  };
  std::vector<Row> rows(plan.runs.size());
  std::vector<std::string> columns;
  // a summary key named like one of our columns (its "scenario", a swept "vehicle_file") is
  // left out: one name, one column
  std::set<std::string> column_set{"run_id", "scenario", "sweep_status", "exit_code", "message"};
  column_set.insert(swept.begin(), swept.end());
  for (std::size_t i = 0; i < plan.runs.size(); ++i) {
    const PlannedRun& run = plan.runs[i];
    Row& row = rows[i];
    row.outcome = read_outcome(f, run.id);
    row.status = done(f, run.id, row.outcome) ? "ok" : failed(row.outcome) ? "failed" : "pending";
    if (row.status == "pending") {
      ++tally.pending;
      continue;
    }
    std::string text, reason;
    io::JsonValue v;
    std::string parse_error;
    if (!io::read_text_file(f.run_dir(run.id) + "/summary.json", text, reason)) {
      (row.status == "ok" ? tally.ok : tally.failed) += 1;  // a failure before any output
      continue;
    }
    if (!io::parse_json(text, v, parse_error)) {
      // a damaged summary is not a result
      row.status = "failed";
      row.outcome.message += (row.outcome.message.empty() ? "" : " | ") + ("summary.json: " + parse_error);
      ++tally.failed;
      continue;
    }
    (row.status == "ok" ? tally.ok : tally.failed) += 1;
    io::flatten(v, row.fields);
    row.summary_json = io::to_compact_json(v);
    for (const auto& [k, value] : row.fields) {
      if (column_set.insert(k).second) columns.push_back(k);
    }
  }
  std::string csv = "run_id,scenario";
  for (const std::string& k : swept) csv += "," + csv_field(k);
  csv += ",sweep_status,exit_code,message";
  for (const std::string& k : columns) csv += "," + csv_field(k);
  csv += "\n";
  std::string jsonl;
  for (std::size_t i = 0; i < plan.runs.size(); ++i) {
    const PlannedRun& run = plan.runs[i];
    const Row& row = rows[i];
    const std::string& status = row.status;
    std::map<std::string, std::string> set_of;
    for (const CampaignOverride& o : run.overrides) set_of[o.key] = o.value;
    csv += run.id + "," + csv_field(c.scenarios[run.scenario].name);
    for (const std::string& k : swept) {
      const auto it = set_of.find(k);
      csv += "," + (it == set_of.end() ? std::string() : csv_field(plain_value(it->second)));
    }
    const std::string code = row.outcome.recorded ? std::to_string(row.outcome.exit_code) : "";
    csv += "," + status + "," + code + "," + csv_field(row.outcome.message);
    std::map<std::string, std::string> value_of(row.fields.begin(), row.fields.end());
    for (const std::string& k : columns) {
      const auto it = value_of.find(k);
      csv += "," + (it == value_of.end() ? std::string() : csv_field(it->second));
    }
    csv += "\n";
    jsonl += "{\"run_id\":\"" + run.id + "\",\"scenario\":" + io::json_escape(c.scenarios[run.scenario].name) +
             ",\"overrides\":{";
    bool first = true;
    for (const std::string& k : swept) {
      const auto it = set_of.find(k);
      if (it == set_of.end()) continue;
      jsonl += (first ? "" : ",") + io::json_escape(k) + ":" + json_value_text(it->second);
      first = false;
    }
    jsonl += "},\"sweep_status\":\"" + status + "\",\"exit_code\":" + (code.empty() ? "null" : code) +
             ",\"message\":" + io::json_escape(row.outcome.message) + ",\"summary\":" +
             (row.summary_json.empty() ? "null" : row.summary_json) + "}\n";
  }
  return io::write_file_atomically(f.dir + "/results.csv", csv, error) &&
         io::write_file_atomically(f.dir + "/results.jsonl", jsonl, error);
}

// ---- arguments -----------------------------------------------------------------------------

struct Args {
  std::string campaign, out_dir, status_dir;
  int jobs = 0;
  bool retry_failed = false, quiet = false, no_wait = false;
  std::string executor = "local", partition;
  int max_parallel = 0;
  std::int64_t shard_size = kDefaultShardSize;
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
      if (!whole_number(args[++i], 1, 4096, n)) return fail("-j " + args[i] + ": must be a whole number in [1, 4096]");
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
      if (!whole_number(args[++i], 1, 1000000, n)) return fail("--max-parallel " + args[i] + ": must be a whole number in [1, 1000000]");
      a.max_parallel = static_cast<int>(n);
    } else if (o == "--shard-size") {
      if (!whole_number(args[++i], 1, 1000000, n)) return fail("--shard-size " + args[i] + ": must be a whole number in [1, 1000000]");
      a.shard_size = n;
    } else if (o == "--status") {
      a.status_dir = args[++i];
    } else if (o == "--shard") {
      const std::string s = args[++i];
      const std::size_t slash = s.find('/');
      if (slash == std::string::npos || !whole_number(s.substr(slash + 1), 1, 10000000, a.shard_count) ||
          !whole_number(s.substr(0, slash), 0, a.shard_count - 1, a.shard_index)) {
        return fail("--shard " + s + ": expected I/N with 0 <= I < N");
      }
      a.shard = true;
    } else if (o == "--retry-failed") {
      a.retry_failed = true;
    } else if (o == "--no-wait") {
      a.no_wait = true;
    } else if (o == "--quiet") {
      a.quiet = true;
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
  if (a.out_dir.empty()) return fail("--out DIR is required (the sweep folder)");
  if (a.executor == "local" && (!a.partition.empty() || a.max_parallel != 0 || a.no_wait)) {
    return fail("--partition, --max-parallel and --no-wait are for --executor slurm");
  }
  return 0;
}

// ---- Slurm ---------------------------------------------------------------------------------

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
std::string job_name(const Folder& f) { return "ehpt-sweep-" + io::sha256_hex(f.dir).substr(0, 12); }

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

// Checks made before anything is written: sbatch is there, the partition exists.
int check_slurm(const Args& a, std::string& sbatch) {
  sbatch = io::find_program("sbatch");
  if (sbatch.empty()) {
    std::cerr << "error: --executor slurm: sbatch not found on PATH (Slurm's client commands); nothing was submitted\n";
    return 1;
  }
  if (!a.partition.empty()) {
    const std::string sinfo = io::find_program("sinfo");
    std::string output, reason;
    const int rc = sinfo.empty() ? -1
                                 : io::capture_program({sinfo, "-h", "-p", a.partition, "-o", "%P"}, output,
                                                       kSlurmCommandTimeout_s, reason);
    if (rc != 0) {
      std::cerr << "error: --partition " << a.partition << ": cannot ask Slurm (sinfo: "
                << (sinfo.empty() ? "not found on PATH" : rc < 0 ? reason : first_line(output)) << "); nothing was submitted\n";
      return 1;
    }
    if (first_line(output).empty()) {
      std::cerr << "error: --partition " << a.partition << ": no such partition in this Slurm cluster ('sinfo' lists "
                << "them); nothing was submitted\n";
      return 1;
    }
  }
  return 0;
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

std::size_t count_recorded(const Folder& f, const std::vector<std::string>& ids) {
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

// A job of this sweep still queued or running would run the same runs as we are about to (and
// read the queue a submission replaces): refused. unknown_ok: squeue cannot tell (the local
// executor on a machine without Slurm) is a warning, not a refusal.
bool job_is_live(const Folder& f, bool unknown_ok) {
  std::string job, reason, error;
  if (!io::read_text_file(f.slurm("job_id"), job, reason)) return false;
  job = first_line(job);
  const std::string state = job_state(job, job_name(f), error);
  if (state.empty()) return false;
  if (state == "?" && unknown_ok) {
    std::cerr << "warning: cannot tell whether Slurm job " << job << " of this sweep still runs (" << error << ")\n";
    return false;
  }
  std::cerr << "error: Slurm job " << job << " of this sweep is " << (state == "?" ? "in an unknown state (" + error + ")" : state)
            << "; wait for it ('ehpt sweep --status " << f.dir << "') or scancel it; nothing was run\n";
  return true;
}

// Writes the queue and the job-array script, submits them, and (unless --no-wait) waits for
// the job, showing how many runs have ended. Returns 0 when the job has left the queue.
int submit_and_wait(const Args& a, const std::string& sbatch, const Plan& plan, const std::vector<std::size_t>& todo,
                    const Folder& f, const std::atomic<int>& stop) {
  std::string error;
  if (!make_subfolders(f.dir, {"slurm"}, error)) {
    std::cerr << "error: " << error << "; nothing was submitted\n";
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
      std::cout << "note: " << runs << " runs in shards of " << a.shard_size << " would be more array tasks than this "
                << "cluster's MaxArraySize (" << max_tasks << "): shards of " << shard_size << "\n";
    }
  }
  const std::int64_t shards = (runs + shard_size - 1) / shard_size;
  const std::string exe = io::self_executable();
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
    std::cerr << "error: " << error << "\n";
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
    std::cerr << "error: sbatch: " << (rc < 0 ? reason : first_line(output)) << "; nothing was submitted\n";
    return 1;
  }
  const std::string job = first_line(output).substr(0, first_line(output).find(';'));
  if (job.empty() || job.find_first_not_of("0123456789") != std::string::npos) {
    std::cerr << "error: sbatch answered \"" << first_line(output) << "\", not a job id\n";
    return 1;
  }
  if (!io::write_file_atomically(f.slurm("job_id"), job + "\n", error)) std::cerr << "error: " << error << "\n";
  if (!a.quiet) {
    std::cout << "submitted Slurm job " << job << ": " << todo.size() << " runs in " << shards << " array tasks of up to "
              << shard_size << "\n" << std::flush;
  }
  if (a.no_wait) {
    if (!a.quiet) std::cout << "'ehpt sweep --status " << f.dir << "' shows the progress and merges the results\n";
    return 0;
  }
  const double t0 = now_s();
  const bool tty = !a.quiet && isatty(STDERR_FILENO);
  double shown = 0.0;
  for (;;) {
    if (!nap(2.0, stop)) {
      std::string cancel_reason, cancel_output;
      const std::string scancel = io::find_program("scancel");
      if (!scancel.empty()) (void)io::capture_program({scancel, job}, cancel_output, kSlurmCommandTimeout_s, cancel_reason);
      std::cerr << "\ninterrupted: Slurm job " << job << " cancelled; runs that ended are kept\n";
      return 128 + stop.load();
    }
    const std::string state = job_state(job, job_name(f), error);
    const std::size_t ended = count_recorded(f, ids);
    if (tty) {
      std::cerr << "\r\033[K[" << ended << "/" << ids.size() << "] job " << job << " " << (state.empty() ? "done" : state)
                << ", " << duration_text(now_s() - t0) << std::flush;
    } else if (!a.quiet && now_s() - shown > 30.0) {
      shown = now_s();
      std::cerr << "[" << ended << "/" << ids.size() << "] job " << job << " " << state << "\n";
    }
    if (state.empty()) break;
  }
  if (tty) std::cerr << "\n";
  return 0;
}

// An array task: the I-th of N parts of DIR/slurm/queue.txt, each run checked against its
// queued id (a file changed since the submission would make it another run).
int run_shard(const Args& a, const std::atomic<int>& stop) {
  Plan plan;
  std::vector<std::string> errors;
  if (!hil::load_campaign(a.campaign, plan.campaign, errors)) {
    for (const std::string& e : errors) std::cerr << e << "\n";
    return 2;
  }
  const Folder f{absolute_folder(a.out_dir)};
  std::string theirs, why;
  if (!sweep_campaign_of(f.dir, theirs, why) || theirs != plan.campaign.path) {
    std::cerr << "error: " << (why.empty() ? f.dir + " is the sweep of " + theirs : why) << "\n";
    return 1;
  }
  std::string queue, reason;
  if (!io::read_text_file(f.slurm("queue.txt"), queue, reason)) {
    std::cerr << "error: " << f.slurm("queue.txt") << ": " << reason << "\n";
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
      std::cerr << "error: " << f.slurm("queue.txt") << ":" << line_no << ": not \"INDEX RUN_ID\"; the queue is damaged\n";
      return 1;
    }
    entries.emplace_back(static_cast<std::uint64_t>(index), line.substr(sp + 1));
  }
  const std::size_t n = entries.size(), parts = static_cast<std::size_t>(a.shard_count);
  const std::size_t per = (n + parts - 1) / parts;
  const std::size_t begin = std::min(n, static_cast<std::size_t>(a.shard_index) * per), end = std::min(n, begin + per);
  const std::uint64_t total = hil::campaign_run_count(plan.campaign);
  std::vector<std::size_t> todo;
  for (std::size_t e = begin; e < end; ++e) {
    // plain names, not a structured binding: clang 14 cannot capture one in a lambda
    const std::uint64_t index = entries[e].first;
    const std::string& id = entries[e].second;
    // the campaign or a file changed since the submission: the queued run is not the run at
    // that index any more. Nothing is recorded (it stays pending for the next sweep).
    const auto changed = [&] {
      std::cerr << "run " << index << " (" << id << "): the campaign or its files changed since the job was "
                << "submitted; not run (run the sweep again)\n";
    };
    if (index >= total) {
      changed();
      continue;
    }
    hil::CampaignRun r = hil::campaign_run(plan.campaign, index);
    std::vector<std::string> sets;
    for (const CampaignOverride& o : r.overrides) sets.push_back(o.set_text());
    hil::Scenario sc;
    std::vector<std::string> load_errors;
    (void)hil::load_scenario(plan.campaign.scenarios[r.scenario].path, sets, sc, load_errors);
    PlannedRun p{index, r.scenario, std::move(r.overrides), ""};
    p.id = hil::run_id(sc.inputs, p.overrides);
    if (p.id != id) {
      changed();
      continue;
    }
    if (done(f, id, read_outcome(f, id))) continue;
    todo.push_back(plan.runs.size());
    plan.runs.push_back(std::move(p));
  }
  const char* cpus = std::getenv("SLURM_CPUS_PER_TASK");
  std::int64_t jobs = a.jobs;
  if (jobs == 0 && (cpus == nullptr || !whole_number(cpus, 1, 4096, jobs))) jobs = 1;
  const Counts c = run_pool(plan, todo, f, static_cast<int>(jobs), true, stop);
  if (!a.quiet) std::cerr << "shard " << a.shard_index << "/" << a.shard_count << ": " << c.ok << " ok, " << c.failed << " failed\n";
  return stop.load() != 0 ? 128 + stop.load() : 0;
}

void print_tally(const Tally& t, const Folder& f, bool quiet) {
  if (quiet) return;
  std::cout << t.ok + t.failed + t.pending << " runs: " << t.ok << " ok, " << t.failed << " failed, " << t.pending
            << " not done\nresults       " << f.dir << "/results.csv, " << f.dir << "/results.jsonl\n" << std::flush;
}

int exit_code_of(const Tally& t) { return t.pending > 0 ? 4 : t.failed > 0 ? 3 : 0; }

int cmd_status(const Args& a) {
  const Folder f{absolute_folder(a.status_dir)};
  std::string campaign, why;
  if (!sweep_campaign_of(f.dir, campaign, why)) {
    std::cerr << "error: " << why << "\n";
    return 1;
  }
  Plan plan;
  if (const int rc = plan_campaign(campaign, plan, isatty(STDERR_FILENO)); rc != 0) {
    std::cerr << "(--status plans the campaign " << campaign << " as it is now, from " << f.dir << "/sweep.json)\n";
    return rc;
  }
  std::string job, reason, error;
  std::string state;
  if (io::read_text_file(f.slurm("job_id"), job, reason)) {
    job = first_line(job);
    state = job_state(job, job_name(f), error);
    std::cout << "Slurm job " << job << ": " << (state.empty() ? "no longer queued" : state == "?" ? "unknown (" + error + ")" : state)
              << "\n";
  }
  Tally t;
  if (!merge(plan, f, t, error)) {
    std::cerr << "error: " << error << "\n";
    return 1;
  }
  std::cout << "campaign      " << campaign << "\n";
  print_tally(t, f, false);
  if (!state.empty()) return 5;  // queued, running or unknown: the counts so far
  return exit_code_of(t);
}

}  // namespace

bool is_sweep_folder(const std::string& dir) {
  std::string campaign, why;
  return sweep_campaign_of(dir, campaign, why);
}

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
  if (a.shard) return run_shard(a, stop);

  std::string sbatch;
  if (a.executor == "slurm") {
    if (const int rc = check_slurm(a, sbatch); rc != 0) return rc;
  }
  Plan plan;
  if (const int rc = plan_campaign(a.campaign, plan, !a.quiet && isatty(STDERR_FILENO)); rc != 0) return rc;
  const Folder f{absolute_folder(a.out_dir)};
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
  if (!open_folder(f.dir, plan.campaign.path, error)) {
    std::cerr << "error: " << error << "\n";
    return 1;
  }
  if (job_is_live(f, a.executor == "local")) return 1;
  std::vector<std::size_t> todo;
  std::size_t done_before = 0, failed_before = 0;
  for (std::size_t i = 0; i < plan.runs.size(); ++i) {
    const Outcome o = read_outcome(f, plan.runs[i].id);
    if (done(f, plan.runs[i].id, o)) {
      ++done_before;
    } else if (failed(o) && !a.retry_failed) {
      ++failed_before;
    } else {
      todo.push_back(i);
    }
  }
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
    rc = submit_and_wait(a, sbatch, plan, todo, f, stop);
    if (rc != 0 || a.no_wait) return rc;
  } else if (!todo.empty()) {
    const int jobs = a.jobs > 0 ? a.jobs : usable_cpus();
    const Counts c = run_pool(plan, todo, f, jobs, a.quiet, stop);
    if (stop.load() != 0) {
      if (!a.quiet) std::cerr << "interrupted: " << c.stopped << " runs stopped; they run again next time\n";
      rc = 128 + stop.load();
    }
  }
  Tally t;
  if (!merge(plan, f, t, error)) {
    std::cerr << "error: " << error << "\n";
    return 1;
  }
  print_tally(t, f, a.quiet);
  return rc != 0 ? rc : exit_code_of(t);
}
