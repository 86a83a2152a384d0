// SPDX-License-Identifier: BSD-3-Clause
// `ehpt bench`: the timing and determinism suite (targets/bench/bench.hpp). Everything it runs
// outside its own process is this binary (/proc/self/exe), cyclictest or a python-can ECU of
// the source tree (tools/pycan_ecu.py, examples/own_dbc/vcu_ecu.py), started with an
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
//   lockstep_socketcand_psecu2, lockstep_lcm_psecu2   the same two with PSecu2 (psecu2_nedc)
//   wallclock_socketcand      ehpt plant (wall clock) + ehpt ecu over socketcand
//   lockstep_pycan            ehpt plant --lockstep + tools/pycan_ecu.py (python-can), PSecu2
//   wallclock_pycan           the same on the wall clock
//   wallclock_own_dbc         ehpt plant --bus-map + examples/own_dbc/vcu_ecu.py, wall clock
//   realtime_own_dbc          the same in the real-time loop
//   replay                    ehpt replay of wallclock_socketcand (when the build has it)
// The folder is made fresh, or must be empty or an earlier bench (bench.json with our format
// line and nothing but the names above); the run folders inside follow ehpt's own rules.
//
// The parts, one file each: common (shared helpers), supervisor (the programs it starts),
// machine (its facts), folder (the output folder), state (what is measured), section_* (the
// sections), report (the table and bench.json); this file: the options and the order.

#include "targets/bench/bench.hpp"

#include "targets/bench/common.hpp"
#include "targets/bench/folder.hpp"
#include "targets/bench/machine.hpp"
#include "targets/bench/report.hpp"
#include "targets/bench/sections.hpp"

const char* const ehpt::cli::kBenchHelp =
    "usage: ehpt bench [--quick] [--out DIR] [--cpu N] [--priority P] [--rt-seconds S] [--quiet]\n"
    "\n"
    "The timing and determinism benchmark, in one run on this machine; prints a table and\n"
    "writes DIR/bench.json (and the runs it made, under DIR). Figures are reported next to\n"
    "their targets, never asserted.\n"
    "  (a) ns per step of ev_nedc, evpm_nedc, evam_nedc, psecu2_nedc x rk4, implicit-euler at\n"
    "      1 ms, in this process (median of 3 whole runs, min and max; --quick: 1), RK4's next\n"
    "      to the latency floor of a step (its battery's four dependent stage chains, timed here)\n"
    "  (b) the real-time factor of each vehicle on its cycle (from a)\n"
    "  (c) wake-up latency of 'ehpt run ev_sort1 --realtime' next to cyclictest's (rt-tests),\n"
    "      same period (1 ms), priority, CPU and duration; overruns; peak RSS\n"
    "  (d) heap allocations after start-up (malloc level) of a batch run, the real-time run and\n"
    "      'ehpt plant' in lockstep and on the wall clock over socketcand and LCM\n"
    "  (e) the trajectory hash across pacers: as fast as possible (twice), real time, lockstep\n"
    "      over socketcand and over LCM udpm (in a private network namespace), and the replay\n"
    "      of a wall-clock session ('ehpt replay', when this build has it)\n"
    "  the bus exchange: lockstep periods/s with 'ehpt ecu' (ev_sort1, psecu2_nedc) over\n"
    "      socketcand and LCM udpm against a TCP and a UDP ping-pong between two processes on\n"
    "      127.0.0.1 timed here (the transport's floor); rate and round trip of a stock python-can\n"
    "      ECU (tools/pycan_ecu.py); on the wall clock how far apart its two command frames of a\n"
    "      sample came; the own-DBC VCU (examples/own_dbc) on the wall clock and in real time:\n"
    "      stale samples and timeouts (python3-can, python3-canmatrix; said so when missing)\n"
    "  (f) RK4 at 1 ms against the CVODE reference (BDF, rtol 1e-12): each one's final-SOC and\n"
    "      distance error against RK4 at 0.1 ms, and their wall times\n"
    "  (g) planning a sweep of 100000 psecu2_nedc runs ('ehpt sweep CAMPAIGN --plan'): wall\n"
    "      time and peak memory\n"
    "  --quick          a short version (under a minute): one repetition, 5 s of real time,\n"
    "                   the first 400 s of the cycles in (f), 10000 runs in (g)\n"
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

namespace ehpt::bench {
namespace {

extern "C" void on_bench_signal(int sig) { g_stop.store(sig); }

void install_bench_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_bench_signal;
  sigemptyset(&sa.sa_mask);
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) sigaction(sig, &sa, nullptr);
}

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

}  // namespace
}  // namespace ehpt::bench

int ehpt::cli::cmd_bench(const std::vector<std::string>& args) {
  using namespace ehpt::bench;
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
      {{"lockstep_socketcand_psecu2", "lockstep, socketcand (psecu2_nedc)", "exchange"}},
      {{"lockstep_lcm_psecu2", "lockstep, LCM udpm (psecu2_nedc)", "exchange"}},
      {{"lockstep_pycan", "lockstep, socketcand, python-can ECU (psecu2_nedc)", "exchange"}},
      {{"wallclock_socketcand", "wall clock, socketcand", "wall_clock_session"}},
      {{"wallclock_pycan", "wall clock, socketcand, python-can ECU (psecu2_nedc)", "wall_clock_pycan"}},
      {{"wallclock_own_dbc", "wall clock, socketcand, own-DBC VCU (psecu2_nedc)", "own_dbc_wall_clock"}},
      {{"realtime_own_dbc", "real time, socketcand, own-DBC VCU (psecu2_nedc)", "own_dbc_realtime"}},
      {{"replay", "its replay (ehpt replay)", "wall_clock_session"}}};
  for (const auto& [name, label, group] : runs) {
    SubRun r;
    r.name = name;
    r.label = label;
    r.group = group;
    b.runs.push_back(r);
  }
  build_commit(b.commit, b.dirty);
  b.progress("ehpt bench" + std::string(b.opt.quick ? " --quick" : "") + " into " + b.opt.out + ": commit " + b.commit +
             ", load " + b.load_start);
  std::string text;
  // each section in turn; bench.json after each, so that a hard stop leaves what was done
  const std::vector<void (*)(Bench&)> sections = {section_speed, section_cvode, section_latency, section_runs,
                                                         section_plan};
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
