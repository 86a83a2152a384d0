// SPDX-License-Identifier: BSD-3-Clause
// `ehpt bench`: the timing and determinism suite (targets/bench/bench.hpp). Everything it runs
// outside its own process is this binary (/proc/self/exe) or cyclictest, started with an
// argument vector (never a shell), in a process group of its own, waited for with a
// deadline and ended (SIGINT, then SIGKILL) on a timeout or a stop signal.
//
// Layout of the output folder (default bench-out):
//   bench.json, bench.txt     everything measured; the table as printed
//   logs/                     stdout and stderr of every program started (*.out, *.err)
//   batch_1, batch_2          ehpt run ev_sort1 (the determinism runs, S seconds)
//   batch_can                 the same through the CAN codec (reference of socketcand)
//   realtime                  ehpt run ev_sort1 --realtime (section c), S seconds
//   lockstep_socketcand       ehpt plant --lockstep + ehpt ecu over socketcand on 127.0.0.1
//   lockstep_lcm              the same over LCM udpm in a private network namespace
//   wallclock_socketcand      ehpt plant (wall clock) + ehpt ecu over socketcand
//   replay                    ehpt replay of wallclock_socketcand (when the build has it)
// The folder is made fresh, or must be empty or an earlier bench (bench.json with our format
// line and nothing but the names above); the run folders inside follow ehpt's own rules.

#include "targets/bench/bench.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <net/if.h>
#include <net/route.h>
#include <sched.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/utsname.h>
#include <sys/wait.h>
#include <netinet/in.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "hil/config/config.hpp"
#include "hil/reference/cvode_reference.hpp"
#include "hil/diag/provenance.hpp"
#include "hil/run/realtime.hpp"
#include "hil/config/scenario.hpp"
#include "hil/run/simulation.hpp"
#include "io/json_value.hpp"
#include "io/number_format.hpp"
#include "io/output_dir.hpp"
#include "io/process.hpp"
#include "io/text_file.hpp"

const char* const kBenchHelp =
    "usage: ehpt bench [--quick] [--out DIR] [--cpu N] [--priority P] [--rt-seconds S] [--quiet]\n"
    "\n"
    "The timing and determinism benchmark, in one run on this machine; prints a table and\n"
    "writes DIR/bench.json (and the runs it made, under DIR). Figures are reported next to\n"
    "their targets, never asserted.\n"
    "  (a) ns per step of ev_nedc, evpm_nedc, evam_nedc, psecu2_nedc x rk4, implicit-euler at\n"
    "      1 ms, in this process (median of 3 whole runs, min and max; --quick: 1)\n"
    "  (b) the real-time factor of each vehicle on its cycle (from a)\n"
    "  (c) wake-up latency of 'ehpt run ev_sort1 --realtime' next to cyclictest's (rt-tests),\n"
    "      same period (1 ms), priority, CPU and duration; overruns; peak RSS\n"
    "  (d) heap allocations after start-up (malloc level) of a batch run, the real-time run and\n"
    "      'ehpt plant' in lockstep and on the wall clock over socketcand and LCM\n"
    "  (e) the trajectory hash across pacers: as fast as possible (twice), real time, lockstep\n"
    "      over socketcand and over LCM udpm (in a private network namespace), and the replay\n"
    "      of a wall-clock session ('ehpt replay', when this build has it)\n"
    "  (f) RK4 at 1 ms against the CVODE reference (BDF, rtol 1e-8): final SOC, fuel and\n"
    "      distance differences, wall-time ratio\n"
    "  --quick          a short version (under a minute): one repetition, 5 s of real time,\n"
    "                   the first 400 s of the cycles in (f)\n"
    "  --out DIR        output folder (default bench-out): made fresh, or empty, or an\n"
    "                   earlier bench; anything else is refused\n"
    "  --cpu N          the CPU of (c) (default: the last one this process may use)\n"
    "  --priority P     SCHED_FIFO priority of (c), 1..99 (default 80)\n"
    "  --rt-seconds S   duration of (c) and of the determinism runs, 1..3600 whole seconds\n"
    "                   (default 60; --quick: 5)\n"
    "  --quiet          no progress lines and no table (bench.json and bench.txt are written)\n"
    "Exit codes: 0 every section ran (one that cannot run here says why), 1 usage or output\n"
    "error, 3 a run failed or runs that must be bit-identical are not, 130 Ctrl-C (bench.json\n"
    "holds what was done).\n";

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// ---- stop signals -----------------------------------------------------------------------

std::atomic<int> g_stop{0};
extern "C" void on_bench_signal(int sig) { g_stop.store(sig); }

void install_bench_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_bench_signal;
  sigemptyset(&sa.sa_mask);
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) sigaction(sig, &sa, nullptr);
}

bool stopping() { return g_stop.load() != 0; }

// ---- small helpers ----------------------------------------------------------------------

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

void sleep_s(double s) {
  timespec ts{static_cast<time_t>(s), static_cast<long>((s - std::floor(s)) * 1e9)};
  ::nanosleep(&ts, nullptr);  // a signal cuts it short: the callers look at g_stop
}

bool write_stdout(const std::string& text) {
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(STDOUT_FILENO, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      std::fprintf(stderr, "error: cannot write to standard output: %s\n", n < 0 ? std::strerror(errno) : "no progress");
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  return true;
}

std::string fmt(const char* f, double v) {
  if (!std::isfinite(v)) return "-";
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

std::string read_small_file(const std::string& path) {
  std::string text, reason;
  if (!ehpt::io::read_text_file(path, text, reason, 16u << 20)) return "";
  return text;
}

// The last non-empty line of a text file (a child's stderr), at most 300 characters.
std::string last_line(const std::string& path) {
  std::istringstream in(read_small_file(path));
  std::string line, last;
  while (std::getline(in, line)) {
    if (line.find_first_not_of(" \t\r") != std::string::npos) last = line;
  }
  if (last.size() > 300) last = last.substr(0, 300) + "...";
  return last;
}

std::string trim(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ' ')) s.pop_back();
  return s;
}

// An executable file named name in $PATH or the usual system folders; "" if none.
std::string find_program(const std::string& name) {
  std::vector<std::string> dirs;
  if (const char* path = std::getenv("PATH")) {
    std::istringstream in(path);
    std::string d;
    while (std::getline(in, d, ':')) {
      if (!d.empty()) dirs.push_back(d);
    }
  }
  for (const char* d : {"/usr/local/sbin", "/usr/local/bin", "/usr/sbin", "/usr/bin", "/sbin", "/bin"}) dirs.push_back(d);
  for (const std::string& d : dirs) {
    const std::string p = d + "/" + name;
    struct stat st {};
    if (p[0] == '/' && ::stat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode) && ::access(p.c_str(), X_OK) == 0) return p;
  }
  return "";
}

// ---- reading JSON (the sub-runs' summary.json, an earlier bench.json): io/json_value.hpp ---

using Json = ehpt::io::JsonValue;

// a.b.c through nested objects; nullptr if a part is missing
const Json* json_at(const Json& j, std::string_view path) {
  const Json* v = &j;
  while (v != nullptr && !path.empty()) {
    const auto dot = path.find('.');
    v = v->find(path.substr(0, dot));
    path = dot == std::string_view::npos ? std::string_view() : path.substr(dot + 1);
  }
  return v;
}

// The number at path, NaN if it is missing or not a number.
double json_num(const Json& j, std::string_view path) {
  const Json* v = json_at(j, path);
  double x = NAN;
  return v != nullptr && v->kind == Json::Kind::kNumber && ehpt::io::parse_number(v->text, x) ? x : NAN;
}

std::string json_str(const Json& j, std::string_view path) {
  const Json* v = json_at(j, path);
  return v != nullptr && v->kind == Json::Kind::kString ? v->text : std::string();
}

bool read_json(const std::string& path, Json& out) {
  const std::string text = read_small_file(path);
  std::string error;
  return !text.empty() && ehpt::io::parse_json(text, out, error);
}

// ---- child processes --------------------------------------------------------------------

struct Outcome {
  bool started = false;
  int code = -1;  // exit status, 128 + N for signal N
  bool timed_out = false, stopped = false;
  std::string why;  // when it did not start, or what went wrong
  double wall_s = 0.0;
  bool ok() const { return started && !timed_out && !stopped && code == 0; }
};

// One program started by the bench. Its own process group (group = true) lets end() reach
// whatever it started; the destructor ends and reaps it whatever happens (an exception too).
class Child {
 public:
  Child() = default;
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;
  ~Child() {
    if (pid_ > 0) end();
  }

  bool start(const std::vector<std::string>& argv, const std::string& out, const std::string& err, std::string& why,
             bool group = true) {
    group_ = group;
    t0_ = Clock::now();
    pid_ = ehpt::io::start_program(argv, out, err, group, why);
    return pid_ > 0;
  }
  // Adopts a process made otherwise (fork), already in its own group when group is true.
  void adopt(pid_t pid, bool group) {
    pid_ = pid;
    group_ = group;
    t0_ = Clock::now();
  }
  // True when it has ended (code set); never blocks.
  bool poll(int& code) {
    if (pid_ <= 0) return true;
    int status = 0;
    const pid_t r = ::waitpid(pid_, &status, WNOHANG);
    if (r == 0) return false;
    if (r < 0 && errno == EINTR) return false;
    code = r < 0 ? -1 : WIFEXITED(status) ? WEXITSTATUS(status) : WIFSIGNALED(status) ? 128 + WTERMSIG(status) : -1;
    pid_ = -1;
    return true;
  }

  // Waits until it ends, timeout_s passes or a stop signal comes (then it is ended).
  Outcome wait(double timeout_s) {
    Outcome o;
    o.started = true;
    while (true) {
      if (poll(o.code)) break;
      if (stopping()) {
        o.stopped = true;
        o.code = end();
        break;
      }
      if (seconds_since(t0_) > timeout_s) {
        o.timed_out = true;
        o.why = "no end after " + fmt("%.0f", timeout_s) + " s: stopped";
        o.code = end();
        break;
      }
      // 100 polls a second at first (short runs), then 10: little noise beside (c)
      sleep_s(seconds_since(t0_) < 1.0 ? 0.01 : 0.1);
    }
    o.wall_s = seconds_since(t0_);
    return o;
  }

  // SIGINT (ehpt commits what it has, cyclictest prints), 3 s, then SIGKILL; reaps it.
  int end() {
    int code = -1;
    if (pid_ <= 0) return code;
    signal_it(SIGINT);
    for (int i = 0; i < 300; ++i) {
      if (poll(code)) return code;
      sleep_s(0.01);
    }
    signal_it(SIGKILL);
    for (int i = 0; i < 500; ++i) {
      if (poll(code)) return code;
      sleep_s(0.01);
    }
    pid_ = -1;  // unkillable (D state): give up on it rather than hang the bench
    return code;
  }

 private:
  void signal_it(int sig) {
    if (group_) {
      ::killpg(pid_, sig);
    } else {
      ::kill(pid_, sig);
    }
  }
  pid_t pid_ = -1;
  bool group_ = true;
  Clock::time_point t0_;
};

// Runs argv to its end (bounded): stdout, stderr into logs/NAME.out and .err.
Outcome run_child(const std::vector<std::string>& argv, const std::string& logs, const std::string& name,
                  double timeout_s) {
  Child c;
  Outcome o;
  if (!c.start(argv, logs + "/" + name + ".out", logs + "/" + name + ".err", o.why)) return o;
  o = c.wait(timeout_s);
  if (!o.ok() && o.why.empty()) {
    const std::string line = last_line(logs + "/" + name + ".err");
    o.why = (o.stopped ? std::string("stopped") : "exit " + std::to_string(o.code)) + (line.empty() ? "" : ": " + line);
  }
  return o;
}

// ---- the machine ------------------------------------------------------------------------

std::string loadavg() {
  std::istringstream in(read_small_file("/proc/loadavg"));
  std::string a, b, c;
  in >> a >> b >> c;
  return a.empty() ? "unknown" : a + " " + b + " " + c;
}

std::string cpu_model() {
  std::istringstream in(read_small_file("/proc/cpuinfo"));
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) return trim(line.substr(line.find_first_not_of(" \t", colon + 1)));
    }
  }
  return "unknown";
}

std::string kernel() {
  utsname u{};
  if (::uname(&u) != 0) return "unknown";
  return std::string(u.sysname) + " " + u.release + " " + u.version + " " + u.machine;
}

int allowed_cpus(int& last) {
  cpu_set_t set;
  CPU_ZERO(&set);
  last = -1;
  if (::sched_getaffinity(0, sizeof set, &set) != 0) return 0;
  for (int c = 0; c < CPU_SETSIZE; ++c) {
    if (CPU_ISSET(c, &set)) last = c;
  }
  return CPU_COUNT(&set);
}

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  ::gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

// ---- the output folder ------------------------------------------------------------------

constexpr const char* kBenchFormat = "ehpt bench, version 1";
// The scenario of (c), (d) and (e): the map EV on Sort1, which moves from t = 0 (NEDC stands
// still for its first 11 s, so a 5 s run would compare trajectories of a car at rest).
constexpr const char* kRtScenario = "ev_sort1";
const std::vector<std::string> kRunDirs = {"batch_1",  "batch_2", "batch_can", "realtime", "lockstep_socketcand",
                                           "lockstep_lcm", "wallclock_socketcand", "replay"};

bool all_digits(std::string_view s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

// Names ehpt itself leaves beside a run folder when stopped hard: NAME.partial-PID,
// NAME.ehpt-lock (and its .tmp-PID), FILE.tmp-PID of an atomic write.
bool leftover_of(const std::string& entry, const std::string& name) {
  if (entry.rfind(name + ".", 0) != 0) return false;
  const std::string rest = entry.substr(name.size() + 1);
  if (rest.rfind("partial-", 0) == 0) return all_digits(rest.substr(8));
  if (rest == "ehpt-lock") return true;
  if (rest.rfind("ehpt-lock.tmp-", 0) == 0) return all_digits(rest.substr(14));
  if (rest.rfind("tmp-", 0) == 0) return all_digits(rest.substr(4));
  return false;
}

// Whether DIR (an existing folder) holds an earlier bench and nothing else; why_not if not.
bool is_earlier_bench(const std::string& dir, std::string& why_not) {
  Json j;
  struct stat st {};
  if (::lstat((dir + "/bench.json").c_str(), &st) != 0 || !S_ISREG(st.st_mode) || !read_json(dir + "/bench.json", j) ||
      json_str(j, "format") != kBenchFormat) {
    why_not = "it is not empty and not an earlier ehpt bench (no bench.json of ours)";
    return false;
  }
  std::vector<std::string> foreign;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    const fs::file_status s = it->symlink_status(ec);
    const bool is_dir = fs::is_directory(s), is_file = fs::is_regular_file(s);
    bool ours = false;
    if (is_file && (name == "bench.json" || name == "bench.txt" || leftover_of(name, "bench.json") ||
                    leftover_of(name, "bench.txt"))) {
      ours = true;
    } else if (is_dir && name == "logs") {
      ours = true;
      for (fs::directory_iterator l(it->path(), ec), lend; !ec && l != lend; l.increment(ec)) {
        const std::string n = l->path().filename().string();
        const bool log = n.size() > 4 && (n.ends_with(".out") || n.ends_with(".err"));
        if (!fs::is_regular_file(l->symlink_status(ec)) || !log) foreign.push_back("logs/" + n);
      }
    } else {
      for (const std::string& r : kRunDirs) {
        if (is_dir && name == r) {
          std::vector<std::string> files;
          std::string why;
          ours = true;
          if (!ehpt::io::is_earlier_run(it->path().string(), files, why)) foreign.push_back(name + "/ (" + why + ")");
        } else if (leftover_of(name, r)) {
          ours = true;
        }
      }
    }
    if (!ours) foreign.push_back(name + (is_dir ? "/" : ""));
  }
  if (ec) {
    why_not = "cannot list it: " + ec.message();
    return false;
  }
  if (!foreign.empty()) {
    why_not = "an earlier bench, but it holds what ehpt bench did not write: ";
    for (std::size_t i = 0; i < foreign.size() && i < 5; ++i) why_not += (i ? ", " : "") + foreign[i];
    if (foreign.size() > 5) why_not += " and " + std::to_string(foreign.size() - 5) + " more";
    return false;
  }
  return true;
}

// May DIR be used? "" if yes (exists = it is there already), else the one-line reason.
std::string check_out_dir(const std::string& dir, bool& exists) {
  struct stat st {};
  exists = false;
  if (::lstat(dir.c_str(), &st) != 0) {
    if (errno != ENOENT) return dir + ": " + std::strerror(errno);
    // made by mkdir later: its parent must be a folder already (no parents are made)
    std::string parent = fs::path(dir).parent_path().string();
    if (parent.empty()) parent = ".";
    if (::stat(parent.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
      return dir + ": its parent " + parent + " is not a folder (" + ehpt::io::describe_path(parent) + "); choose another --out";
    }
    return "";
  }
  exists = true;
  if (S_ISLNK(st.st_mode)) return dir + ": a symbolic link; give a folder of its own (--out)";
  if (!S_ISDIR(st.st_mode)) return dir + ": exists and is " + ehpt::io::describe_path(dir) + ", not a folder; choose another --out";
  std::error_code ec;
  if (fs::is_empty(dir, ec) && !ec) return "";
  std::string why;
  if (!is_earlier_bench(dir, why)) return dir + ": " + why + "; nothing was touched: choose another --out";
  return "";
}

// ---- options ----------------------------------------------------------------------------

struct Options {
  bool quick = false, quiet = false;
  std::string out = "bench-out";
  int cpu = -1, priority = 80, rt_seconds = 0;
  std::vector<std::string> args;
};

bool parse_whole(const std::string& option, const std::string& text, int lo, int hi, int& out) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || end == nullptr || *end != '\0' || errno != 0 || v < lo || v > hi) {
    std::fprintf(stderr, "%s %s: must be a whole number from %d to %d\n", option.c_str(), text.c_str(), lo, hi);
    return false;
  }
  out = static_cast<int>(v);
  return true;
}

// 0 parsed; else the exit code (1).
int parse_options(const std::vector<std::string>& args, Options& o) {
  o.args = args;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    const bool takes_value = a == "--out" || a == "--cpu" || a == "--priority" || a == "--rt-seconds";
    if (takes_value && i + 1 >= args.size()) {
      std::fprintf(stderr, "%s needs a value (ehpt bench --help)\n", a.c_str());
      return 1;
    }
    if (a == "--quick") {
      o.quick = true;
    } else if (a == "--quiet") {
      o.quiet = true;
    } else if (a == "--out") {
      o.out = args[++i];
      if (o.out.empty()) {
        std::fprintf(stderr, "--out needs a folder name (got an empty one)\n");
        return 1;
      }
    } else if (a == "--cpu") {
      if (!parse_whole(a, args[++i], 0, 4095, o.cpu)) return 1;
      std::string allowed;
      if (!ehpt::hil::cpu_allowed(o.cpu, allowed)) {
        std::fprintf(stderr, "--cpu %d: not a CPU this process may run on (%s)\n", o.cpu, allowed.c_str());
        return 1;
      }
    } else if (a == "--priority") {
      if (!parse_whole(a, args[++i], 1, 99, o.priority)) return 1;
    } else if (a == "--rt-seconds") {
      if (!parse_whole(a, args[++i], 1, 3600, o.rt_seconds)) return 1;
    } else {
      std::fprintf(stderr, "%s: %s (ehpt bench --help)\n", a.c_str(),
                   !a.empty() && a[0] == '-' ? "unknown option" : "ehpt bench takes no scenario");
      return 1;
    }
  }
  return 0;
}

// ---- figures ----------------------------------------------------------------------------

struct Spread {
  double median = NAN, min = NAN, max = NAN;
};

Spread spread(std::vector<double> v) {
  Spread s;
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  s.median = n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  s.min = v.front();
  s.max = v.back();
  return s;
}

ehpt::io::JsonObject spread_json(const Spread& s) {
  ehpt::io::JsonObject j;
  j.number("median", s.median);
  j.number("min", s.min);
  j.number("max", s.max);
  return j;
}

// A fixed-width table; align holds one letter per column: 'l' left, 'r' right.
std::string table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows,
                  const std::string& align) {
  std::vector<std::size_t> w(header.size(), 0);
  for (std::size_t c = 0; c < header.size(); ++c) w[c] = header[c].size();
  for (const auto& r : rows) {
    for (std::size_t c = 0; c < r.size() && c < w.size(); ++c) w[c] = std::max(w[c], r[c].size());
  }
  const auto line = [&](const std::vector<std::string>& r) {
    std::string s;
    for (std::size_t c = 0; c < w.size(); ++c) {
      const std::string cell = c < r.size() ? r[c] : "";
      const std::string pad(w[c] - std::min(w[c], cell.size()), ' ');
      s += (c ? "  " : "") + (c < align.size() && align[c] == 'l' ? cell + pad : pad + cell);
    }
    while (!s.empty() && s.back() == ' ') s.pop_back();
    return s + "\n";
  };
  std::string s = line(header);
  for (const auto& r : rows) s += line(r);
  return s;
}

// ---- (a), (b): speed in this process ----------------------------------------------------

struct SpeedRun {
  std::string scenario, solver, error;
  double duration_s = 0.0;
  std::int64_t steps = 0;
  Spread ns_per_step, wall_s;
  double realtime_factor = NAN;
  double target_ns = NAN;  // the target, where it gives one
};

// Loads a scenario with overrides; "" or every problem on one line.
std::string load(const std::string& name, const std::vector<std::string>& sets, ehpt::hil::Scenario& sc) {
  std::string reason;
  const std::string path = ehpt::hil::resolve_scenario(name, reason);
  if (path.empty()) return name + ": " + reason;
  std::vector<std::string> errors;
  if (!ehpt::hil::load_scenario(path, sets, sc, errors)) {
    std::string s;
    for (const auto& e : errors) s += (s.empty() ? "" : "; ") + e;
    return s;
  }
  return "";
}

// One whole run through the facade; wall time of the stepping alone (start-up excluded).
// False (why) on a fault or a stop.
bool timed_run(const ehpt::hil::Scenario& sc, double& wall_s, ehpt::hil::RunFigures* figures, std::string& why) {
  ehpt::hil::SimulationOptions so;
  const std::unique_ptr<ehpt::hil::Simulation> sim = ehpt::hil::make_simulation(sc, so);
  const auto t0 = Clock::now();
  while (!sim->finished() && !stopping()) {
    sim->run(&g_stop);
    sim->clear_rows();
  }
  wall_s = seconds_since(t0);
  if (stopping()) {
    why = "stopped";
    return false;
  }
  if (sim->stats().fault != 0) {
    why = "fault at t = " + ehpt::io::number_text(sim->stats().fault_time_s) + " s";
    return false;
  }
  if (figures != nullptr) *figures = sim->figures();
  return true;
}

SpeedRun measure_speed(const std::string& scenario, const std::string& solver, double duration_s, int reps) {
  SpeedRun r;
  r.scenario = scenario;
  r.solver = solver;
  std::vector<std::string> sets = {"solver.method=" + solver, "solver.step_s=0.001"};
  if (duration_s > 0.0) sets.push_back("solver.duration_s=" + ehpt::io::number_text(duration_s));
  ehpt::hil::Scenario sc;
  r.error = load(scenario, sets, sc);
  if (!r.error.empty()) return r;
  r.steps = sc.solver.steps;
  r.duration_s = static_cast<double>(sc.solver.steps) * sc.solver.step_s;
  std::vector<double> ns, walls;
  for (int k = 0; k < reps; ++k) {
    double wall = 0.0;
    if (!timed_run(sc, wall, nullptr, r.error)) return r;
    walls.push_back(wall);
    ns.push_back(1e9 * wall / static_cast<double>(r.steps));
  }
  r.ns_per_step = spread(ns);
  r.wall_s = spread(walls);
  r.realtime_factor = r.duration_s / r.wall_s.median;
  return r;
}

// ---- (f): CVODE ---------------------------------------------------------------------------

struct CvodeRow {
  std::string scenario, error;
  double duration_s = 0.0;
  ehpt::hil::RunFigures rk4, cv;
  Spread rk4_wall, cv_wall;
  ehpt::hil::ReferenceResult ref;
};

double rel_pct(std::optional<double> a, std::optional<double> b) {
  if (!a || !b || *b == 0.0) return NAN;
  return 100.0 * (*a - *b) / std::abs(*b);
}

CvodeRow measure_cvode(const std::string& scenario, double duration_s, int reps) {
  CvodeRow r;
  r.scenario = scenario;
  std::vector<std::string> sets = {"solver.method=rk4", "solver.step_s=0.001"};
  if (duration_s > 0.0) sets.push_back("solver.duration_s=" + ehpt::io::number_text(duration_s));
  ehpt::hil::Scenario sc;
  r.error = load(scenario, sets, sc);
  if (!r.error.empty()) return r;
  r.duration_s = static_cast<double>(sc.solver.steps) * sc.solver.step_s;
  std::vector<double> rk, cv;
  for (int k = 0; k < reps && r.error.empty(); ++k) {
    double wall = 0.0;
    if (timed_run(sc, wall, &r.rk4, r.error)) rk.push_back(wall);
  }
  for (int k = 0; k < reps && r.error.empty() && !stopping(); ++k) {
    std::string why;
    if (!ehpt::hil::run_cvode_reference(sc, ehpt::hil::ReferenceOptions{}, r.ref, why)) {
      r.error = "CVODE: " + why;
    } else {
      cv.push_back(r.ref.wall_s);
      r.cv = r.ref.figures;
    }
  }
  if (stopping() && r.error.empty()) r.error = "stopped";
  r.rk4_wall = spread(rk);
  r.cv_wall = spread(cv);
  return r;
}

// ---- (c): cyclictest ----------------------------------------------------------------------

struct Latency {
  std::string status = "not run";  // "ok", or why not
  double p50 = NAN, p99 = NAN, p99_9 = NAN, max = NAN, mean = NAN;
  long long samples = 0, overflows = 0;
  std::string dma_latency;  // "0us" of cyclictest's "# /dev/cpu_dma_latency set to 0us", if it said so
};

// cyclictest -q -h: "NNNNNN CCCCCC" per 1 us bin, then "# Total:", "# Max Latencies:",
// "# Avg Latencies:", "# Histogram Overflows:". Quantiles are the upper edge of their bin
// (bin + 1 us), as ehpt's histogram reports the upper edge of its own.
bool parse_cyclictest(const std::string& text, Latency& l) {
  std::istringstream in(text);
  std::string line;
  std::vector<std::pair<long, long long>> bins;
  long long total_in_bins = 0;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] == '#') {
      const auto colon = line.find(':');
      const std::string value = colon == std::string::npos ? "" : trim(line.substr(colon + 1));
      if (line.rfind("# Max Latencies", 0) == 0) l.max = std::strtod(value.c_str(), nullptr);
      if (line.rfind("# Avg Latencies", 0) == 0) l.mean = std::strtod(value.c_str(), nullptr);
      if (line.rfind("# Histogram Overflows", 0) == 0) l.overflows = std::strtoll(value.c_str(), nullptr, 10);
      if (const auto at = line.find("cpu_dma_latency set to "); at != std::string::npos) {
        l.dma_latency = trim(line.substr(at + std::strlen("cpu_dma_latency set to ")));
      }
      continue;
    }
    long bin = 0;
    long long count = 0;
    if (std::sscanf(line.c_str(), "%ld %lld", &bin, &count) == 2 && count > 0) {
      bins.emplace_back(bin, count);
      total_in_bins += count;
    }
  }
  l.samples = total_in_bins + l.overflows;
  if (l.samples == 0) return false;
  const auto quantile = [&](double q) {
    const auto need = std::max<long long>(1, static_cast<long long>(std::ceil(q * static_cast<double>(l.samples))));
    long long seen = 0;
    for (const auto& [bin, count] : bins) {
      seen += count;
      if (seen >= need) return std::min(static_cast<double>(bin + 1), std::isfinite(l.max) ? l.max : 1e300);
    }
    return l.max;  // in the overflow: the largest seen
  };
  l.p50 = quantile(0.5);
  l.p99 = quantile(0.99);
  l.p99_9 = quantile(0.999);
  return true;
}

// ---- (d), (e): the sub-runs ---------------------------------------------------------------

struct SubRun {
  std::string name;       // folder under DIR
  std::string label;      // what it is, for the table
  std::string group;      // runs of one group must have the same trajectory hash
  std::string status = "not run";  // "ok", "not run: why", "failed: why", "not available in this build"
  std::string hash;
  std::optional<long long> allocations;
  bool allocations_reported = false;
  double peak_rss_MB = NAN;
  double wall_s = NAN;
  bool ok() const { return status == "ok"; }
  bool failed() const { return status.rfind("failed", 0) == 0; }
};

// Reads DIR/name/summary.json written by this bench (not an earlier one).
bool read_summary(const std::string& dir, std::time_t since, Json& j, std::string& why) {
  const std::string path = dir + "/summary.json";
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    why = path + ": " + std::strerror(errno);
    return false;
  }
  if (st.st_mtime + 1 < since) {
    why = path + ": older than this bench";
    return false;
  }
  if (!read_json(path, j)) {
    why = path + ": not readable JSON";
    return false;
  }
  return true;
}

void take_summary(SubRun& r, const Json& j) {
  r.hash = json_str(j, "trajectory_hash");
  const double allocations = json_num(j, "heap_allocations_after_startup");
  r.allocations_reported = std::isfinite(allocations);
  if (r.allocations_reported) r.allocations = static_cast<long long>(allocations);
  r.peak_rss_MB = json_num(j, "peak_rss_MB");
  r.status = "ok";
}

// A free TCP port on 127.0.0.1 (bound to port 0, then released).
int free_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  int port = -1;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) == 0) {
    port = ntohs(a.sin_port);
  }
  ::close(fd);
  return port;
}

// Whether something listens on 127.0.0.1:port (/proc/net/tcp: no probe connection, which
// the plant would count as a peer).
bool listening(int port) {
  std::istringstream in(read_small_file("/proc/net/tcp"));
  char want[32];
  std::snprintf(want, sizeof want, "0100007F:%04X", port);
  char any[32];
  std::snprintf(any, sizeof any, "00000000:%04X", port);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream f(line);
    std::string slot, local, remote, state;
    f >> slot >> local >> remote >> state;
    if ((local == want || local == any) && state == "0A") return true;
  }
  return false;
}

// ---- the LCM run in a private network namespace -------------------------------------------

// Brings lo up and routes multicast (224.0.0.0/4) to it: `ip link set lo up; ip route add
// 224.0.0.0/4 dev lo`, by ioctl. "" or what failed.
std::string loopback_multicast() {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return std::string("socket: ") + std::strerror(errno);
  ifreq ifr{};
  std::strncpy(ifr.ifr_name, "lo", IFNAMSIZ - 1);
  std::string error;
  if (::ioctl(fd, SIOCGIFFLAGS, &ifr) != 0) {
    error = std::string("lo: SIOCGIFFLAGS: ") + std::strerror(errno);
  } else {
    ifr.ifr_flags = static_cast<short>(ifr.ifr_flags | IFF_UP | IFF_RUNNING);
    if (::ioctl(fd, SIOCSIFFLAGS, &ifr) != 0) error = std::string("lo: cannot bring it up: ") + std::strerror(errno);
  }
  if (error.empty()) {
    rtentry rt{};
    sockaddr_in dst{}, mask{};
    dst.sin_family = mask.sin_family = AF_INET;
    dst.sin_addr.s_addr = htonl(0xE0000000u);   // 224.0.0.0
    mask.sin_addr.s_addr = htonl(0xF0000000u);  // /4
    std::memcpy(&rt.rt_dst, &dst, sizeof dst);
    std::memcpy(&rt.rt_genmask, &mask, sizeof mask);
    rt.rt_flags = RTF_UP;
    char dev[] = "lo";
    rt.rt_dev = dev;
    if (::ioctl(fd, SIOCADDRT, &rt) != 0 && errno != EEXIST) {
      error = std::string("route 224.0.0.0/4 dev lo: ") + std::strerror(errno);
    }
  }
  ::close(fd);
  return error;
}

// The only network interface here is lo (a fresh namespace): nothing can leave the machine.
bool only_loopback(std::string& seen) {
  struct if_nameindex* list = ::if_nameindex();
  if (list == nullptr) return false;
  bool only = true;
  for (struct if_nameindex* i = list; i->if_index != 0; ++i) {
    seen += (seen.empty() ? "" : ", ") + std::string(i->if_name);
    if (std::strcmp(i->if_name, "lo") != 0) only = false;
  }
  ::if_freenameindex(list);
  return only;
}

// The forked child: a new network namespace holding only lo, then ehpt plant --lockstep and
// ehpt ecu over LCM udpm (ttl=0) there. Never returns. Exit 77: no namespace here (stderr
// says why); else the plant's exit code, or 1.
[[noreturn]] void lcm_in_netns(const std::vector<std::string>& plant, const std::vector<std::string>& ecu,
                               const std::string& logs, double timeout_s) {
  if (::unshare(CLONE_NEWNET) != 0) {
    std::fprintf(stderr, "unshare(CLONE_NEWNET): %s (needs root or user namespaces)\n", std::strerror(errno));
    std::fflush(stderr);
    ::_exit(77);
  }
  std::string seen;
  if (!only_loopback(seen)) {
    std::fprintf(stderr, "the new network namespace has interfaces other than lo (%s): LCM not run\n", seen.c_str());
    std::fflush(stderr);
    ::_exit(1);
  }
  const std::string error = loopback_multicast();
  if (!error.empty()) {
    std::fprintf(stderr, "%s\n", error.c_str());
    std::fflush(stderr);
    ::_exit(77);
  }
  int code = 1;
  {
    Child p, e;
    std::string why;
    // in this process's group: the bench ends the whole group
    if (!p.start(plant, logs + "/lockstep_lcm_plant.out", logs + "/lockstep_lcm_plant.err", why, false)) {
      std::fprintf(stderr, "%s\n", why.c_str());
    } else if (!e.start(ecu, logs + "/lockstep_lcm_ecu.out", logs + "/lockstep_lcm_ecu.err", why, false)) {
      std::fprintf(stderr, "%s\n", why.c_str());
    } else {
      const Outcome po = p.wait(timeout_s);
      const Outcome eo = e.wait(30.0);
      code = po.code;
      if (po.code != 0) {
        std::fprintf(stderr, "ehpt plant: %s\n", po.why.empty() ? ("exit " + std::to_string(po.code)).c_str() : po.why.c_str());
      } else if (eo.code != 0) {
        std::fprintf(stderr, "ehpt ecu: exit %d\n", eo.code);
        code = 1;
      }
    }
  }
  std::fflush(stderr);
  ::_exit(code < 0 ? 1 : code);
}

// ---- the bench ----------------------------------------------------------------------------

struct Bench {
  Options opt;
  std::string exe, dir, logs;
  std::time_t started_at = 0;
  Clock::time_point t0;
  int cpu = -1, seconds = 0, reps = 1, nproc = 0;
  double cvode_s = 0.0;   // (f): 0 the whole cycle, else its first cvode_s seconds
  double wall_clock_s = 0.0;  // the wall-clock socketcand session
  std::string commit = "unknown", load_start, load_end, date;
  bool dirty = false;
  std::string status = "complete";
  bool any_failed = false;

  std::string speed_status = "not run";
  std::vector<SpeedRun> speed;
  std::string cvode_status = "not run";
  std::vector<CvodeRow> cvode;
  std::string latency_status = "not run";
  Latency cyclictest, rt_loop;
  std::string rt_scheduler;
  long long overruns = -1, missed_ticks = -1, ticks = -1;
  std::vector<std::string> rt_warnings;
  std::vector<SubRun> runs;
  bool replay_available = false;

  SubRun& run(const std::string& name) {
    for (auto& r : runs) {
      if (r.name == name) return r;
    }
    throw std::logic_error("no sub-run " + name);
  }

  void progress(const std::string& line) const {
    if (!opt.quiet) std::fprintf(stderr, "bench [%5.1f s] %s\n", seconds_since(t0), line.c_str());
  }
  std::vector<std::string> duration_set(double s) const { return {"--set", "solver.duration_s=" + ehpt::io::number_text(s)}; }
};

void fail(Bench& b, SubRun& r, const std::string& why) {
  r.status = "failed: " + why;
  b.any_failed = true;
}

// The commit this binary was built from (`git describe --dirty` at build time), if any.
void find_commit(Bench& b) {
  std::string git(ehpt::hil::build_info().git);
  const std::string suffix = "-dirty";
  b.dirty = git.size() > suffix.size() && git.compare(git.size() - suffix.size(), suffix.size(), suffix) == 0;
  if (b.dirty) git.resize(git.size() - suffix.size());
  b.commit = git;
}

// (a), (b)
void section_speed(Bench& b) {
  const std::vector<std::string> vehicles = {"ev_nedc", "evpm_nedc", "evam_nedc", "psecu2_nedc"};
  b.progress("(a, b) speed: 4 vehicles x 2 solvers at 1 ms, " + std::to_string(b.reps) +
             " whole cycle(s) each (about " + std::to_string(b.reps * 6 + 1) + " s)");
  // warm-up, not measured: the first run of a process pays for cold caches and page faults
  {
    ehpt::hil::Scenario sc;
    double wall = 0.0;
    std::string why;
    if (load("ev_nedc", {"solver.duration_s=100"}, sc).empty()) timed_run(sc, wall, nullptr, why);
  }
  for (const auto& v : vehicles) {
    for (const char* solver : {"rk4", "implicit-euler"}) {
      if (stopping()) return;
      SpeedRun r = measure_speed(v, solver, 0.0, b.reps);
      if (std::string(solver) == "rk4" && v == "psecu2_nedc") r.target_ns = 150.0;
      if (std::string(solver) == "rk4" && v == "ev_nedc") r.target_ns = 100.0;
      if (r.error == "stopped") return;
      if (!r.error.empty()) b.any_failed = true;
      b.speed.push_back(r);
    }
  }
  b.speed_status = "ok";
}

// (f)
void section_cvode(Bench& b) {
  const double d = b.cvode_s;
  b.progress("(f) CVODE reference vs RK4: ev_nedc, psecu2_nedc" +
             (d > 0 ? " (first " + fmt("%.0f", d) + " s)" : std::string()) + ", " + std::to_string(b.reps) +
             " run(s) each (about " + fmt("%.0f", b.reps * (d > 0 ? d / 1184.0 : 1.0) * 3.5 + 0.5) + " s)");
  for (const char* s : {"ev_nedc", "psecu2_nedc"}) {
    if (stopping()) return;
    CvodeRow r = measure_cvode(s, d, b.reps);
    if (r.error == "stopped") return;
    if (!r.error.empty()) b.any_failed = true;
    b.cvode.push_back(r);
  }
  b.cvode_status = "ok";
}

// (c)
void section_latency(Bench& b) {
  b.progress("(c) wake-up latency at 1 ms, SCHED_FIFO " + std::to_string(b.opt.priority) + ", CPU " +
             std::to_string(b.cpu) + ": cyclictest, then ehpt run --realtime, " + std::to_string(b.seconds) +
             " s each (about " + std::to_string(2 * b.seconds + 2) + " s)");
  const std::string cyclictest = find_program("cyclictest");
  if (cyclictest.empty()) {
    b.cyclictest.status = "cyclictest not found (Debian package rt-tests)";
  } else {
    const Outcome o = run_child({cyclictest, "-m", "-p", std::to_string(b.opt.priority), "-i", "1000", "-a",
                                 std::to_string(b.cpu), "-t1", "-q", "-D", std::to_string(b.seconds), "-h", "5000"},
                                b.logs, "cyclictest", b.seconds + 30.0);
    if (o.stopped) return;
    // an outside tool that cannot run here (not root, no SCHED_FIFO) is said, not a failure
    if (!o.ok()) {
      b.cyclictest.status = "cyclictest failed: " + o.why;
    } else if (!parse_cyclictest(read_small_file(b.logs + "/cyclictest.out"), b.cyclictest)) {
      b.cyclictest.status = "cyclictest printed no histogram (logs/cyclictest.out)";
    } else {
      b.cyclictest.status = "ok";
    }
  }
  if (stopping()) return;
  SubRun& r = b.run("realtime");
  std::vector<std::string> argv = {b.exe, "run", kRtScenario, "--realtime", "--period", "1ms", "--cpu", std::to_string(b.cpu),
                                   "--priority", std::to_string(b.opt.priority), "--out", b.dir + "/realtime", "--quiet"};
  for (const auto& a : b.duration_set(b.seconds)) argv.push_back(a);
  const Outcome o = run_child(argv, b.logs, "realtime", b.seconds + 60.0);
  r.wall_s = o.wall_s;
  Json j;
  std::string why;
  if (o.stopped) {
    r.status = "stopped";
    return;
  }
  if (!o.ok()) {
    fail(b, r, o.why);
    b.rt_loop.status = r.status;
  } else if (!read_summary(b.dir + "/realtime", b.started_at, j, why)) {
    fail(b, r, why);
    b.rt_loop.status = r.status;
  } else {
    take_summary(r, j);
    Latency& l = b.rt_loop;
    l.p50 = json_num(j, "realtime.wakeup_latency_us.p50");
    l.p99 = json_num(j, "realtime.wakeup_latency_us.p99");
    l.p99_9 = json_num(j, "realtime.wakeup_latency_us.p99_9");
    l.max = json_num(j, "realtime.wakeup_latency_us.max");
    l.mean = json_num(j, "realtime.wakeup_latency_us.mean");
    l.samples = static_cast<long long>(json_num(j, "realtime.ticks"));
    l.status = std::isfinite(l.p99) ? "ok" : "failed: no realtime figures in realtime/summary.json";
    b.ticks = l.samples;
    b.overruns = static_cast<long long>(json_num(j, "realtime.overruns"));
    b.missed_ticks = static_cast<long long>(json_num(j, "realtime.missed_ticks"));
    b.rt_scheduler = json_str(j, "realtime.scheduler");
    if (const Json* w = json_at(j, "realtime.setup_warnings"); w != nullptr) {
      for (const auto& i : w->items) b.rt_warnings.push_back(i.text);
    }
  }
  b.latency_status = "ok";
}

// ehpt run (the map EV on Sort1) as fast as possible, S seconds, into DIR/name.
void batch_run(Bench& b, const std::string& name, const std::vector<std::string>& extra) {
  SubRun& r = b.run(name);
  std::vector<std::string> argv = {b.exe, "run", kRtScenario, "--out", b.dir + "/" + name, "--quiet"};
  for (const auto& a : b.duration_set(b.seconds)) argv.push_back(a);
  for (const auto& a : extra) argv.push_back(a);
  const Outcome o = run_child(argv, b.logs, name, 120.0 + b.seconds);
  r.wall_s = o.wall_s;
  Json j;
  std::string why;
  if (o.stopped) {
    r.status = "stopped";
    return;
  }
  if (!o.ok()) return fail(b, r, o.why);
  if (!read_summary(b.dir + "/" + name, b.started_at, j, why)) return fail(b, r, why);
  take_summary(r, j);
}

// ehpt plant + ehpt ecu over socketcand on 127.0.0.1 (lockstep, or the wall clock).
void socketcand_run(Bench& b, const std::string& name, bool lockstep, double seconds) {
  SubRun& r = b.run(name);
  const auto t0 = Clock::now();
  for (int attempt = 0; attempt < 3 && !stopping(); ++attempt) {
    const int port = free_port();
    if (port <= 0) return fail(b, r, "no free TCP port on 127.0.0.1");
    const std::string bus = "socketcand:127.0.0.1:" + std::to_string(port);
    std::vector<std::string> plant = {b.exe, "plant", kRtScenario, "--bus", bus, "--out", b.dir + "/" + name, "--quiet",
                                      "--ecu-wait-s", "30"};
    if (lockstep) plant.push_back("--lockstep");
    std::vector<std::string> ecu = {b.exe, "ecu", kRtScenario, "--bus", bus, "--quiet", "--idle-timeout-s", "10"};
    for (const auto& a : b.duration_set(seconds)) {
      plant.push_back(a);
      ecu.push_back(a);
    }
    Child p, e;
    std::string why;
    if (!p.start(plant, b.logs + "/" + name + "_plant.out", b.logs + "/" + name + "_plant.err", why)) return fail(b, r, why);
    // until it listens (or ends: a port taken meanwhile is tried again)
    int code = 0;
    bool ended = false;
    const auto w0 = Clock::now();
    while (!listening(port) && !stopping() && seconds_since(w0) < 20.0) {
      if ((ended = p.poll(code))) break;
      sleep_s(0.02);
    }
    if (stopping()) {
      r.status = "stopped";
      return;
    }
    if (ended || !listening(port)) {
      const std::string line = last_line(b.logs + "/" + name + "_plant.err");
      if (ended && line.find("port in use") != std::string::npos) continue;
      return fail(b, r, "the plant does not listen on " + bus + (line.empty() ? "" : ": " + line));
    }
    if (!e.start(ecu, b.logs + "/" + name + "_ecu.out", b.logs + "/" + name + "_ecu.err", why)) return fail(b, r, why);
    const Outcome po = p.wait(120.0 + 2.0 * seconds);
    const Outcome eo = e.wait(30.0);
    r.wall_s = seconds_since(t0);
    if (po.stopped || eo.stopped) {
      r.status = "stopped";
      return;
    }
    if (po.code != 0 || po.timed_out) {
      const std::string line = last_line(b.logs + "/" + name + "_plant.err");
      return fail(b, r, "ehpt plant: " + (po.why.empty() ? "exit " + std::to_string(po.code) : po.why) +
                            (line.empty() ? "" : ": " + line));
    }
    if (eo.code != 0 || eo.timed_out) {
      const std::string line = last_line(b.logs + "/" + name + "_ecu.err");
      return fail(b, r, "ehpt ecu: exit " + std::to_string(eo.code) + (line.empty() ? "" : ": " + line));
    }
    Json j;
    if (!read_summary(b.dir + "/" + name, b.started_at, j, why)) return fail(b, r, why);
    return take_summary(r, j);
  }
  if (!stopping()) fail(b, r, "no free port after 3 attempts");
}

void lcm_run(Bench& b) {
  SubRun& r = b.run("lockstep_lcm");
  const std::string bus = "lcm:udpm://239.255.76.67:7667?ttl=0";
  std::vector<std::string> plant = {b.exe, "plant", kRtScenario, "--bus", bus, "--lockstep", "--out", b.dir + "/lockstep_lcm",
                                    "--quiet", "--ecu-wait-s", "30"};
  std::vector<std::string> ecu = {b.exe, "ecu", kRtScenario, "--bus", bus, "--quiet", "--idle-timeout-s", "2"};
  for (const auto& a : b.duration_set(b.seconds)) {
    plant.push_back(a);
    ecu.push_back(a);
  }
  const std::string err = b.logs + "/lockstep_lcm.err";
  const double timeout_s = 120.0 + 2.0 * b.seconds;
  // fork, then a new network namespace in the child: only safe while this process has one
  // thread (it has: nothing here starts one; checked, not assumed)
  if (read_small_file("/proc/self/status").find("\nThreads:\t1\n") == std::string::npos) {
    r.status = "not run: the bench process has more than one thread (fork is not safe)";
    return;
  }
  std::fflush(stdout);
  std::fflush(stderr);
  const pid_t pid = ::fork();
  if (pid < 0) return fail(b, r, std::string("fork: ") + std::strerror(errno));
  if (pid == 0) {
    ::setpgid(0, 0);
    const int fd = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd >= 0) {
      ::dup2(fd, STDERR_FILENO);
      ::close(fd);
    }
    lcm_in_netns(plant, ecu, b.logs, timeout_s);
  }
  ::setpgid(pid, pid);  // also from here, so that killpg works at once
  Child c;
  c.adopt(pid, true);
  const Outcome o = c.wait(timeout_s + 40.0);
  r.wall_s = o.wall_s;
  if (o.stopped) {
    r.status = "stopped";
    return;
  }
  if (o.code == 77) {
    r.status = "not run: " + last_line(err);
    return;
  }
  if (o.code != 0 || o.timed_out) {
    const std::string line = last_line(err);
    return fail(b, r, (o.timed_out ? o.why : "exit " + std::to_string(o.code)) + (line.empty() ? "" : ": " + line));
  }
  Json j;
  std::string why;
  if (!read_summary(b.dir + "/lockstep_lcm", b.started_at, j, why)) return fail(b, r, why);
  take_summary(r, j);
}

void replay_run(Bench& b) {
  SubRun& r = b.run("replay");
  // this build has it when `ehpt replay --help` says so
  Child probe;
  std::string why;
  b.replay_available = probe.start({b.exe, "replay", "--help"}, "/dev/null", "/dev/null", why) && probe.wait(10.0).ok();
  if (!b.replay_available) {
    r.status = "not available in this build";
    return;
  }
  if (!b.run("wallclock_socketcand").ok()) {
    r.status = "not run: the wall-clock session failed";
    return;
  }
  const Outcome o = run_child({b.exe, "replay", b.dir + "/wallclock_socketcand", "--out", b.dir + "/replay", "--quiet"},
                              b.logs, "replay", 300.0);
  r.wall_s = o.wall_s;
  if (o.stopped) {
    r.status = "stopped";
    return;
  }
  // exit 1: the replay ran and its hash differs (the comparison below reports it)
  Json j;
  if ((o.code == 0 || o.code == 1) && read_summary(b.dir + "/replay", b.started_at, j, why)) return take_summary(r, j);
  fail(b, r, o.why.empty() ? why : o.why);
}

// (d), (e)
void section_runs(Bench& b) {
  b.progress("(d, e) determinism and allocations: " + std::string(kRtScenario) + ", " + std::to_string(b.seconds) +
             " s as fast as possible (x3), lockstep over socketcand and LCM; a " + fmt("%.0f", b.wall_clock_s) +
             " s wall-clock session over socketcand and its replay (about " + fmt("%.0f", b.wall_clock_s + 5.0) + " s)");
  batch_run(b, "batch_1", {});
  if (!stopping()) batch_run(b, "batch_2", {});
  if (!stopping()) batch_run(b, "batch_can", {"--set", "vehicle.ecu.codec=can"});
  if (!stopping()) socketcand_run(b, "lockstep_socketcand", true, b.seconds);
  if (!stopping()) lcm_run(b);
  if (!stopping()) socketcand_run(b, "wallclock_socketcand", false, b.wall_clock_s);
  if (!stopping()) replay_run(b);
}

// ---- the report -----------------------------------------------------------------------------

struct Group {
  std::string name, meaning;
  std::vector<std::string> members;
};

const std::vector<Group>& groups() {
  static const std::vector<Group> g = {
      {"built_in_ecu", "the built-in ECU, no codec: as fast as possible, real time, lockstep over LCM (doubles)",
       {"batch_1", "batch_2", "realtime", "lockstep_lcm"}},
      {"can_codec", "the ECU's signals through the CAN codec: in process, and lockstep over socketcand",
       {"batch_can", "lockstep_socketcand"}},
      {"wall_clock_session", "a wall-clock bus session and its replay (its own trajectory: command timing differs)",
       {"wallclock_socketcand", "replay"}},
  };
  return g;
}

// Whether the group's runs that ran agree; compared: how many hashes were compared.
bool group_equal(const Bench& b, const Group& g, int& compared) {
  std::string first;
  compared = 0;
  bool equal = true;
  for (const auto& m : g.members) {
    for (const auto& r : b.runs) {
      if (r.name != m || !r.ok() || r.hash.empty()) continue;
      ++compared;
      if (first.empty()) first = r.hash;
      if (r.hash != first) equal = false;
    }
  }
  return equal;
}

bool all_equal(const Bench& b) {
  for (const auto& g : groups()) {
    int n = 0;
    if (!group_equal(b, g, n)) return false;
  }
  return true;
}

// The run through the CAN codec differs from the plain one: the codec quantises what the
// ECU sees and sends, so equal hashes there would mean nothing moved (a vacuous comparison).
bool groups_distinct(const Bench& b) {
  std::string plain, can;
  for (const auto& r : b.runs) {
    if (r.name == "batch_1" && r.ok()) plain = r.hash;
    if (r.name == "batch_can" && r.ok()) can = r.hash;
  }
  return !plain.empty() && !can.empty() && plain != can;
}

std::string target_mark(bool met) { return met ? "met" : "NOT met"; }

std::string report_text(const Bench& b) {
  std::string s;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "ehpt bench%s: commit %s%s, %s\nmachine: %d CPUs (%s), %s\nload average: %s at the start, %s at the end\n",
                b.opt.quick ? " --quick" : "", b.commit.c_str(), b.dirty ? " (with uncommitted changes)" : "", b.date.c_str(),
                b.nproc, cpu_model().c_str(), kernel().c_str(), b.load_start.c_str(),
                b.load_end.empty() ? "-" : b.load_end.c_str());
  s += buf;
  const std::string each = std::to_string(b.reps) + " whole run" + (b.reps > 1 ? "s" : "") + " each";

  // (a), (b)
  s += "\n(a, b) speed in this process, h = 1 ms, " + each + (b.reps > 1 ? " (median; min..max)" : "") + "\n";
  std::vector<std::vector<std::string>> rows;
  for (const auto& r : b.speed) {
    if (!r.error.empty()) {
      rows.push_back({r.scenario, r.solver, "-", "-", "-", "", "-", "", "", "failed: " + r.error});
      continue;
    }
    std::string ratio, ratio_target;
    for (const auto& q : b.speed) {
      if (r.solver == "implicit-euler" && q.scenario == r.scenario && q.solver == "rk4" && q.error.empty()) {
        ratio = fmt("%.2f", r.ns_per_step.median / q.ns_per_step.median);
        ratio_target = "<= 2.5";
      }
    }
    rows.push_back({r.scenario, r.solver, fmt("%.0f", r.duration_s), fmt("%.1f", r.ns_per_step.median),
                    fmt("%.1f", r.ns_per_step.min) + ".." + fmt("%.1f", r.ns_per_step.max),
                    std::isfinite(r.target_ns) ? "<= " + fmt("%.0f", r.target_ns) : "", fmt("%.0f", r.realtime_factor),
                    ratio, ratio_target, ""});
  }
  s += table({"vehicle", "solver", "sim s", "ns/step", "min..max", "target", "x real time", "IE/RK4", "target", ""}, rows,
             "llrrrrrrrl");
  if (b.speed_status != "ok") s += "  " + b.speed_status + "\n";

  // (c)
  s += "\n(c) wake-up latency, period 1 ms, SCHED_FIFO priority " + std::to_string(b.opt.priority) + ", CPU " +
       std::to_string(b.cpu) + ", " + std::to_string(b.seconds) + " s each (" + kRtScenario + " for ehpt)\n";
  if (b.latency_status != "ok") {
    s += "  " + b.latency_status + "\n";
  } else {
    const auto lat_row = [](const std::string& who, const Latency& l) -> std::vector<std::string> {
      if (l.status != "ok") return {who, "-", "-", "-", "-", "-", l.status};
      return {who, fmt("%.1f", l.p50), fmt("%.1f", l.p99), fmt("%.1f", l.p99_9), fmt("%.1f", l.max),
              std::to_string(l.samples), ""};
    };
    s += table({"source", "p50 us", "p99 us", "p99.9 us", "max us", "wake-ups", ""},
               {lat_row("cyclictest", b.cyclictest), lat_row("ehpt run --realtime", b.rt_loop)}, "lrrrrrl");
    std::vector<std::vector<std::string>> t;
    if (b.cyclictest.status == "ok" && b.rt_loop.status == "ok") {
      const double ratio = b.rt_loop.p99 / b.cyclictest.p99;
      t.push_back({"p99 ehpt / cyclictest", fmt("%.2f", ratio), "<= 1.2", target_mark(ratio <= 1.2)});
    } else {
      t.push_back({"p99 ehpt / cyclictest", "-", "<= 1.2", ""});
    }
    if (b.rt_loop.status == "ok") {
      t.push_back({"overruns (ticks missed)", std::to_string(b.overruns) + " (" + std::to_string(b.missed_ticks) + ")",
                   "0 over 60 s",
                   b.overruns != 0 ? "NOT met" : b.seconds >= 60 ? "met" : "0 in " + std::to_string(b.seconds) + " s"});
      for (const auto& r : b.runs) {
        if (r.name == "realtime") {
          t.push_back({"peak RSS MB", fmt("%.1f", r.peak_rss_MB), "<= 16", target_mark(r.peak_rss_MB <= 16.0)});
        }
      }
      t.push_back({"scheduler", b.rt_scheduler, "", ""});
    }
    s += table({"figure", "value", "target", ""}, t, "lrrl");
    for (const auto& w : b.rt_warnings) s += "  warning (real-time set-up): " + w + "\n";
    if (!b.cyclictest.dma_latency.empty()) {
      s += "  note: cyclictest set /dev/cpu_dma_latency to " + b.cyclictest.dma_latency +
           " while it ran (no deep C-states); ehpt's loop does the same (summary.json realtime.cpu_dma_latency_zero)\n";
    }
  }

  // (d)
  s += "\n(d) heap allocations after start-up (malloc level, the whole process over the whole loop, bus IO and CSV\n"
       "    included) and peak RSS, from each run's summary.json\n";
  rows.clear();
  const std::vector<std::pair<std::string, std::string>> alloc_rows = {
      {"batch_1", "ehpt run (as fast as possible)"},
      {"realtime", "ehpt run --realtime"},
      {"lockstep_socketcand", "ehpt plant --lockstep, socketcand"},
      {"wallclock_socketcand", "ehpt plant (wall clock), socketcand"},
      {"lockstep_lcm", "ehpt plant --lockstep, LCM udpm"},
      {"replay", "ehpt replay"}};
  for (const auto& [name, label] : alloc_rows) {
    for (const auto& r : b.runs) {
      if (r.name != name) continue;
      if (!r.ok()) {
        rows.push_back({label, "-", "-", "", r.status});
      } else {
        rows.push_back({label, r.allocations ? std::to_string(*r.allocations) : "-", fmt("%.1f", r.peak_rss_MB), "<= 16",
                        r.allocations ? "" : "not counted (a binary without the allocation hooks)"});
      }
    }
  }
  rows.push_back({"ehpt ecu (the ECU's process)", "-", "-", "", "not reported (ehpt ecu writes no summary)"});
  s += table({"process", "allocations", "peak RSS MB", "target", ""}, rows, "lrrrl");

  // (e)
  s += "\n(e) determinism: " + std::string(kRtScenario) + ", " + std::to_string(b.seconds) + " s (the wall-clock session " +
       fmt("%.0f", b.wall_clock_s) + " s); trajectory_hash: FNV-1a over every recorded value\n";
  rows.clear();
  for (const auto& g : groups()) {
    int n = 0;
    const bool eq = group_equal(b, g, n);
    bool first = true;
    for (const auto& m : g.members) {
      for (const auto& r : b.runs) {
        if (r.name != m) continue;
        rows.push_back({first ? g.name : "", r.label, r.ok() ? r.hash : "-",
                        first ? (n < 2 ? "nothing to compare" : eq ? "yes" : "NO") : "", r.ok() ? "" : r.status});
        first = false;
      }
    }
  }
  s += table({"group", "run", "hash", "equal", ""}, rows, "lllll");
  s += "SocketCAN (vcan0): not run (needs the vcan guest: tools/vcan-vm.sh)\n";
  s += std::string("all equal: ") + (all_equal(b) ? "yes" : "NO") +
       " (a wall-clock bus session is compared with its own replay only: its command timing differs)\n";
  const bool distinct = groups_distinct(b);
  s += std::string("the CAN codec's quantisation changes the trajectory (a check that the runs moved): ") +
       (distinct ? "yes" : "NO") + "\n";

  // (f)
  s += "\n(f) RK4 at 1 ms against CVODE (BDF, rtol 1e-8), " + each + (b.reps > 1 ? " (median wall time)" : "") +
       "; differences RK4 - CVODE\n";
  rows.clear();
  for (const auto& r : b.cvode) {
    if (!r.error.empty()) {
      rows.push_back({r.scenario, "-", "-", "-", "-", "-", "", "-", "-", "-", "", "failed: " + r.error});
      continue;
    }
    const double dsoc = r.rk4.soc_end && r.cv.soc_end ? *r.rk4.soc_end - *r.cv.soc_end : NAN;
    const double dfuel = rel_pct(r.rk4.fuel_g, r.cv.fuel_g);
    rows.push_back({r.scenario, fmt("%.0f", r.duration_s), fmt("%.2e", dsoc), fmt("%.5f", rel_pct(r.rk4.soc_end, r.cv.soc_end)),
                    std::isfinite(dfuel) ? fmt("%.5f", dfuel) : "-", fmt("%.5f", rel_pct(r.rk4.distance_m, r.cv.distance_m)),
                    "<= 0.1", fmt("%.3f", r.rk4_wall.median), fmt("%.3f", r.cv_wall.median),
                    fmt("%.1f", r.cv_wall.median / r.rk4_wall.median), ">= 20", ""});
  }
  s += table({"scenario", "sim s", "dSOC", "dSOC %", "dfuel %", "ddist %", "target %", "RK4 s", "CVODE s", "CVODE/RK4",
              "target", ""},
             rows, "lrrrrrrrrrrl");
  if (b.cvode_status != "ok") s += "  " + b.cvode_status + "\n";
  std::snprintf(buf, sizeof buf, "\nbench %s in %.1f s; outputs in %s (bench.json, bench.txt, logs/)\n", b.status.c_str(),
                seconds_since(b.t0), b.opt.out.c_str());
  s += buf;
  return s;
}

ehpt::io::JsonObject run_json(const SubRun& r) {
  ehpt::io::JsonObject j;
  j.text("run", r.label);
  j.text("status", r.status);
  if (r.ok()) {
    j.text("trajectory_hash", r.hash);
    if (r.allocations) {
      j.integer("heap_allocations_after_startup", *r.allocations);
    } else {
      j.null("heap_allocations_after_startup");
    }
    j.number("peak_rss_MB", r.peak_rss_MB);
  }
  j.number("wall_time_s", r.wall_s);
  return j;
}

ehpt::io::JsonObject latency_json(const Latency& l) {
  ehpt::io::JsonObject j;
  j.text("status", l.status);
  if (l.status == "ok") {
    j.number("p50", l.p50);
    j.number("p99", l.p99);
    j.number("p99_9", l.p99_9);
    j.number("max", l.max);
    j.number("mean", l.mean);
    j.integer("samples", l.samples);
    if (!l.dma_latency.empty()) j.text("cpu_dma_latency", l.dma_latency);
  }
  return j;
}

std::string report_json(const Bench& b) {
  using ehpt::io::JsonObject;
  JsonObject j;
  j.text("format", kBenchFormat);
  j.text("status", b.status);
  j.text("mode", b.opt.quick ? "quick" : "full");
  std::string cmd = "ehpt bench";
  for (const auto& a : b.opt.args) cmd += " " + a;
  j.text("command", cmd);
  j.text("out_dir", b.dir);
  j.text("commit", b.commit);
  j.boolean("uncommitted_changes", b.dirty);
  j.text("date_utc", b.date);
  JsonObject m;
  m.integer("nproc", b.nproc);
  m.text("cpu_model", cpu_model());
  m.text("kernel", kernel());
  m.text("load_average_start", b.load_start);
  m.text("load_average_end", b.load_end);
  j.object("machine", m);
  j.number("wall_time_s", seconds_since(b.t0));

  JsonObject speed;
  speed.text("status", b.speed_status);
  speed.number("step_s", 0.001);
  speed.integer("repetitions", b.reps);
  JsonObject by_vehicle;
  std::map<std::string, JsonObject> vehicles;
  std::vector<std::string> order;
  for (const auto& r : b.speed) {
    if (vehicles.find(r.scenario) == vehicles.end()) order.push_back(r.scenario);
    JsonObject one;
    if (!r.error.empty()) {
      one.text("status", "failed: " + r.error);
    } else {
      one.text("status", "ok");
      one.number("duration_s", r.duration_s);
      one.integer("steps", r.steps);
      one.object("ns_per_step", spread_json(r.ns_per_step));
      one.object("wall_time_s", spread_json(r.wall_s));
      one.number("realtime_factor", r.realtime_factor);
      if (std::isfinite(r.target_ns)) one.number("target_ns_per_step", r.target_ns);
    }
    vehicles[r.scenario].object(r.solver, one);
  }
  for (const auto& v : order) {
    JsonObject& o = vehicles[v];
    const SpeedRun *rk = nullptr, *ie = nullptr;
    for (const auto& r : b.speed) {
      if (r.scenario == v && r.error.empty()) (r.solver == "rk4" ? rk : ie) = &r;
    }
    o.number("implicit_euler_over_rk4", rk && ie ? ie->ns_per_step.median / rk->ns_per_step.median : NAN);
    o.number("target_implicit_euler_over_rk4", 2.5);
    by_vehicle.object(v, o);
  }
  speed.object("vehicles", by_vehicle);
  j.object("speed", speed);

  JsonObject lat;
  lat.text("status", b.latency_status);
  lat.number("period_s", 0.001);
  lat.integer("priority", b.opt.priority);
  lat.integer("cpu", b.cpu);
  lat.integer("seconds", b.seconds);
  lat.object("cyclictest_us", latency_json(b.cyclictest));
  lat.object("ehpt_us", latency_json(b.rt_loop));
  lat.number("p99_ratio", b.cyclictest.status == "ok" && b.rt_loop.status == "ok" ? b.rt_loop.p99 / b.cyclictest.p99 : NAN);
  lat.number("target_p99_ratio", 1.2);
  if (b.rt_loop.status == "ok") {
    lat.integer("ticks", b.ticks);
    lat.integer("overruns", b.overruns);
    lat.integer("missed_ticks", b.missed_ticks);
    lat.text("scheduler", b.rt_scheduler);
  }
  lat.integer("target_overruns_over_60_s", 0);
  for (const auto& r : b.runs) {
    if (r.name == "realtime") lat.number("peak_rss_MB", r.peak_rss_MB);
  }
  lat.number("target_peak_rss_MB", 16.0);
  lat.strings("setup_warnings", b.rt_warnings);
  j.object("latency", lat);

  JsonObject runs;
  for (const auto& r : b.runs) runs.object(r.name, run_json(r));
  JsonObject ecu;
  ecu.text("status", "not reported (ehpt ecu writes no summary)");
  runs.object("ecu", ecu);
  j.object("runs", runs);

  JsonObject det;
  det.text("scenario", kRtScenario);
  det.number("duration_s", b.seconds);
  det.number("wall_clock_session_s", b.wall_clock_s);
  JsonObject gs;
  for (const auto& g : groups()) {
    JsonObject one;
    one.text("meaning", g.meaning);
    one.strings("runs", g.members);
    int n = 0;
    const bool eq = group_equal(b, g, n);
    one.integer("compared", n);
    one.boolean("equal", eq);
    gs.object(g.name, one);
  }
  det.object("groups", gs);
  det.text("socketcan", "not run (needs the vcan guest: tools/vcan-vm.sh)");
  det.text("replay", b.replay_available ? "available" : "not available in this build");
  det.boolean("all_equal", all_equal(b));
  det.boolean("can_codec_differs_from_plain", groups_distinct(b));
  j.object("determinism", det);

  JsonObject cv;
  cv.text("status", b.cvode_status);
  cv.number("rtol", ehpt::hil::ReferenceOptions{}.rtol);
  cv.integer("repetitions", b.reps);
  cv.number("target_wall_ratio", 20.0);
  cv.number("target_relative_difference_pct", 0.1);
  JsonObject rowsj;
  for (const auto& r : b.cvode) {
    JsonObject one;
    if (!r.error.empty()) {
      one.text("status", "failed: " + r.error);
      rowsj.object(r.scenario, one);
      continue;
    }
    one.text("status", "ok");
    one.number("duration_s", r.duration_s);
    const auto opt = [](std::optional<double> v) { return v ? *v : NAN; };
    one.number("soc_end_rk4", opt(r.rk4.soc_end));
    one.number("soc_end_cvode", opt(r.cv.soc_end));
    one.number("dsoc", opt(r.rk4.soc_end) - opt(r.cv.soc_end));
    one.number("dsoc_pct", rel_pct(r.rk4.soc_end, r.cv.soc_end));
    if (r.cv.fuel_g) {
      one.number("fuel_g_rk4", opt(r.rk4.fuel_g));
      one.number("fuel_g_cvode", opt(r.cv.fuel_g));
      one.number("dfuel_pct", rel_pct(r.rk4.fuel_g, r.cv.fuel_g));
    } else {
      one.null("dfuel_pct");
    }
    one.number("distance_m_rk4", opt(r.rk4.distance_m));
    one.number("distance_m_cvode", opt(r.cv.distance_m));
    one.number("ddistance_pct", rel_pct(r.rk4.distance_m, r.cv.distance_m));
    one.object("rk4_wall_s", spread_json(r.rk4_wall));
    one.object("cvode_wall_s", spread_json(r.cv_wall));
    one.number("wall_ratio", r.cv_wall.median / r.rk4_wall.median);
    one.integer("cvode_steps", r.ref.cvode_steps);
    one.integer("cvode_restarts", r.ref.restarts);
    one.integer("events_cvode", r.ref.events);
    rowsj.object(r.scenario, one);
  }
  cv.object("scenarios", rowsj);
  j.object("cvode", cv);
  return j.str() + "\n";
}

bool write_reports(Bench& b, bool with_text, std::string& text) {
  std::string error;
  if (!ehpt::io::write_file_atomically(b.dir + "/bench.json", report_json(b), error)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return false;
  }
  if (with_text) {
    text = report_text(b);
    if (!ehpt::io::write_file_atomically(b.dir + "/bench.txt", text, error)) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return false;
    }
  }
  return true;
}

}  // namespace

int cmd_bench(const std::vector<std::string>& args) {
  for (const auto& a : args) {
    if (a == "--help" || a == "-h") return write_stdout(kBenchHelp) ? 0 : 1;
  }
  Bench b;
  if (const int rc = parse_options(args, b.opt); rc != 0) return rc;
  int last_cpu = -1;
  b.nproc = allowed_cpus(last_cpu);
  b.cpu = b.opt.cpu >= 0 ? b.opt.cpu : last_cpu;
  if (b.cpu < 0) {
    std::fprintf(stderr, "error: cannot read this process's CPUs (sched_getaffinity)\n");
    return 1;
  }
  b.seconds = b.opt.rt_seconds > 0 ? b.opt.rt_seconds : b.opt.quick ? 5 : 60;
  b.reps = b.opt.quick ? 1 : 3;
  b.cvode_s = b.opt.quick ? 400.0 : 0.0;
  b.wall_clock_s = std::min(b.seconds, 10);
  b.exe = ehpt::io::self_executable();
  b.dir = b.opt.out;

  // the folder: checked before anything is made; locked; checked again under the lock
  bool exists = false;
  if (const std::string why = check_out_dir(b.dir, exists); !why.empty()) {
    std::fprintf(stderr, "error: %s\n", why.c_str());
    return 1;
  }
  ehpt::io::DirLock lock;
  std::string error;
  if (!lock.acquire(b.dir, error)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return 1;
  }
  if (const std::string why = check_out_dir(b.dir, exists); !why.empty()) {
    std::fprintf(stderr, "error: %s\n", why.c_str());
    return 1;
  }
  if (!exists && ::mkdir(b.dir.c_str(), 0777) != 0) {
    std::fprintf(stderr, "error: %s: cannot create the folder: %s\n", b.dir.c_str(), std::strerror(errno));
    return 1;
  }
  // the children get absolute paths: a folder named "-x" is never taken for an option
  std::error_code abs_ec;
  b.dir = fs::absolute(b.dir, abs_ec).lexically_normal().string();
  if (b.dir.size() > 1 && b.dir.back() == '/') b.dir.pop_back();
  b.logs = b.dir + "/logs";
  if (::mkdir(b.logs.c_str(), 0777) != 0 && errno != EEXIST) {
    std::fprintf(stderr, "error: %s: cannot create the folder: %s\n", b.logs.c_str(), std::strerror(errno));
    return 1;
  }
  install_bench_handlers();
  b.t0 = Clock::now();
  b.started_at = std::time(nullptr);
  b.date = utc_now();
  b.load_start = loadavg();
  const std::vector<std::array<const char*, 3>> runs = {
      {{"batch_1", "as fast as possible", "built_in_ecu"}},
      {{"batch_2", "as fast as possible, again", "built_in_ecu"}},
      {{"realtime", "real time (ehpt run --realtime)", "built_in_ecu"}},
      {{"lockstep_lcm", "lockstep, LCM udpm (unshare -n)", "built_in_ecu"}},
      {{"batch_can", "as fast as possible, CAN codec", "can_codec"}},
      {{"lockstep_socketcand", "lockstep, socketcand", "can_codec"}},
      {{"wallclock_socketcand", "wall clock, socketcand", "wall_clock_session"}},
      {{"replay", "its replay (ehpt replay)", "wall_clock_session"}}};
  for (const auto& [name, label, group] : runs) {
    SubRun r;
    r.name = name;
    r.label = label;
    r.group = group;
    b.runs.push_back(r);
  }
  find_commit(b);
  b.progress("ehpt bench" + std::string(b.opt.quick ? " --quick" : "") + " into " + b.opt.out + ": commit " + b.commit +
             ", load " + b.load_start);
  std::string text;
  // each section in turn; bench.json after each, so that a hard stop leaves what was done
  const std::vector<void (*)(Bench&)> sections = {section_speed, section_cvode, section_latency, section_runs};
  for (const auto section : sections) {
    if (stopping()) break;
    section(b);
    if (!write_reports(b, false, text)) return 1;
  }
  b.load_end = loadavg();
  if (stopping()) {
    b.status = "interrupted";
  } else if (b.any_failed || !all_equal(b)) {
    b.status = "complete, with failures";
  }
  if (!write_reports(b, true, text)) return 1;
  if (!b.opt.quiet && !write_stdout(text)) return 1;
  if (stopping()) return 128 + g_stop.load();
  return b.any_failed || !all_equal(b) ? 3 : 0;
}
