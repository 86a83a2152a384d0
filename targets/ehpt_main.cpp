// SPDX-License-Identifier: BSD-3-Clause
// ehpt: command-line entry point. Batch (as fast as possible) runs of scenario files, and the
// plant and its ECU on a CAN bus.
//   ehpt run SCENARIO [--out DIR] [--set key=value ...] [--plot] [--quiet]
//   ehpt plant SCENARIO --bus SPEC [--lockstep] [--out DIR] [--set key=value ...]
//   ehpt ecu SCENARIO --bus SPEC [--set key=value ...]
//   ehpt list [--dir DIR]
//   ehpt signals SCENARIO
//   ehpt plot DIR
// Exit codes: 0 ok, 1 usage / output / system error (out of memory), 2 bad input (nothing
// was run), 3 run-time fault (outputs kept), 128 + N stopped by signal N (130 SIGINT,
// 143 SIGTERM, 129 SIGHUP; outputs so far kept and committed).

#include <fcntl.h>   // AT_FDCWD
#include <stdio.h>   // renameat2, RENAME_NOREPLACE
#include <stdlib.h>  // mkdtemp
#include <sys/prctl.h>  // PR_SET_PDEATHSIG
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <cmath>
#include <iostream>
#include <sstream>
#include <variant>
#include <new>
#include <string>
#include <system_error>
#include <vector>

#include "ecu/psd_ecu.hpp"
#include "hil/run/batch.hpp"
#include "hil/bus/bus_ecu.hpp"
#include "hil/bus/bus_plant.hpp"
#include "hil/config/config.hpp"
#include "hil/diag/provenance.hpp"
#include "hil/config/scenario.hpp"
#include "hil/bus/replay.hpp"
#include "hil/run/simulation.hpp"
#include "io/can/bus_spec.hpp"
#include "io/can/contract.hpp"
#include "io/lcm/lcm_bus.hpp"
#include "io/output_dir.hpp"
#include "io/number_format.hpp"
#include "io/process.hpp"
#include "targets/bench.hpp"
#include "targets/sweep.hpp"
#include "io/text_file.hpp"

namespace fs = std::filesystem;

namespace {

// the number of the signal that asked us to stop (lock-free atomic: safe in a handler)
std::atomic<int> g_stop{0};
static_assert(std::atomic<int>::is_always_lock_free);
extern "C" void on_stop_signal(int sig) { g_stop.store(sig); }

// SIGINT, SIGTERM and SIGHUP end a run cleanly (outputs kept and committed); SIGPIPE is
// ignored so that a closed pipe on stdout is a write error we report, not a silent death.
void install_signal_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) sigaction(sig, &sa, nullptr);
  std::signal(SIGPIPE, SIG_IGN);
}

// Writes text to stdout now. False (and a message on stderr) if it cannot: a full disk,
// a closed pipe. Plain write(2), so that the reason is known.
bool out(const std::string& text) {
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(STDOUT_FILENO, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      std::cerr << "error: cannot write to standard output: " << (n < 0 ? std::strerror(errno) : "no progress") << "\n";
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  return true;
}

const char* kMainHelp =
    "ehpt - electric and hybrid power-train plant models (SIL/HIL)\n"
    "\n"
    "usage: ehpt <command> [options]\n"
    "\n"
    "commands:\n"
    "  run SCENARIO     run a scenario as fast as possible; writes timeseries.csv and summary.json\n"
    "  list             list the scenarios (name and description)\n"
    "  signals SCENARIO list the output signals of the scenario's vehicle, with units\n"
    "  plot DIR         draw PNG figures from a run's output folder (needs /usr/bin/python3 + matplotlib)\n"
    "  plant SCENARIO   run the scenario's plant on a CAN bus, its ECU outside (--bus)\n"
    "  ecu SCENARIO     run the scenario's built-in ECU as its own process on a CAN bus\n"
    "  bench            the timing and determinism benchmark; a table and bench.json (--quick: < 1 min)\n"
    "  replay RUN_DIR   run a recorded 'ehpt plant' session again, offline, bit for bit\n"
    "  sweep CAMPAIGN   run a campaign (scenarios x parameters) locally or as a Slurm job array;\n"
    "                   merged results.csv and results.jsonl\n"
    "\n"
    "  --version        the version, the git description of the build, the compiler and flags\n"
    "\n"
    "'ehpt <command> --help' gives the options of a command.\n"
    "Exit codes: 0 ok, 1 usage, output or system error, 2 bad input (nothing run), 3 run-time\n"
    "fault (outputs kept), 128+N stopped by signal N: 130 Ctrl-C, 143 SIGTERM, 129 SIGHUP\n"
    "(outputs so far kept).\n";

const char* kRunHelp =
    "usage: ehpt run SCENARIO [--out DIR] [--set key=value ...] [--plot] [--quiet]\n"
    "                [--realtime [--period T] [--cpu N] [--priority P]]\n"
    "\n"
    "SCENARIO is a .toml file, or a name from 'ehpt list' (e.g. ev_nedc).\n"
    "  --out DIR        output folder (default out/<scenario name>); written as\n"
    "                   DIR.partial-<pid> and renamed to DIR when complete. An existing DIR\n"
    "                   is replaced only if it is empty or an earlier ehpt run holding only\n"
    "                   the files its ehpt-manifest.txt lists; a second run with the same\n"
    "                   --out stops at once (exit 1)\n"
    "  --set key=value  override a scenario key, repeatable (the last one of a key wins).\n"
    "                   Values are TOML; bare words are text. The scenario's own keys:\n"
    "                     --set solver.method=implicit-euler   (rk4 | implicit-euler)\n"
    "                     --set solver.step_s=0.002 --set solver.duration_s=100\n"
    "                     --set output.interval_s=0.01         (or output.decimation=N)\n"
    "                     --set 'output.signals=[\"speed_m_s\",\"soc\"]'  ('ehpt signals')\n"
    "                     --set output.timeseries=false        (summary.json only)\n"
    "                     --set cycle_periodic=true            (repeat the cycle)\n"
    "                   Vehicle keys: 'vehicle.', the vehicle file's table, the key:\n"
    "                     --set vehicle.battery.soc_initial=0.6\n"
    "                     --set vehicle.vehicle.mass_kg=1800   (the file's [vehicle] table)\n"
    "                     --set vehicle.ecu.soc_ref=0.62\n"
    "                   Every key of the scenario and vehicle files: docs/scenarios.md\n"
    "  --plot           draw the figures into DIR (as 'ehpt plot DIR'; needs timeseries.csv,\n"
    "                   refused with output.timeseries=false); a failed plot keeps the run\n"
    "                   and exits 1\n"
    "  --quiet          print nothing but errors\n"
    "  --realtime       run in real time, the built-in ECU closing the loop (timing studies\n"
    "                   without a bus): one tick per period on absolute CLOCK_MONOTONIC\n"
    "                   deadlines, SCHED_FIFO, memory locked; rows go to a writer thread. A tick\n"
    "                   that overruns skips the ticks it missed (counted, never caught up).\n"
    "                   summary.json \"realtime\": overruns, wake-up latency p50/p99/p99.9/max,\n"
    "                   compute and IO p50/p99/max. Without root it warns and runs SCHED_OTHER\n"
    "  --period T       the tick: 1ms, 500us, 0.002s or 0.002 (seconds); a whole number of\n"
    "                   solver steps (default: one step, solver.step_s)\n"
    "  --cpu N          pin the real-time loop to CPU N\n"
    "  --priority P     SCHED_FIFO priority 1..99 (default 80)\n"
    "\n"
    "Every problem in the scenario, vehicle, cycle or map files is listed as\n"
    "'file:line: field = value: expectation', and nothing runs (exit 2).\n";

const char* kPlantHelp =
    "usage: ehpt plant SCENARIO --bus SPEC [--lockstep] [--out DIR] [--set key=value ...]\n"
    "                  [--command-timeout-s T] [--lockstep-wait-s W] [--ecu-wait-s S] [--quiet]\n"
    "                  [--realtime [--period T] [--cpu N] [--priority P]]\n"
    "\n"
    "Runs the scenario's plant without its built-in ECU: an ECU on the bus reads the sensor\n"
    "frames and sends the command frames of io/can/ehpt.dbc (one sample per ECU period,\n"
    "vehicle.ecu.period_s, default 0.01 s). Writes timeseries.csv and summary.json as\n"
    "'ehpt run' does, plus bus.log (every frame in and out, candump -L format) and the bus\n"
    "figures in summary.json (\"bus\").\n"
    "  --bus SPEC       socketcan:IFACE (e.g. socketcan:vcan0), or socketcand:HOST:PORT (the\n"
    "                   plant listens there; python-can's socketcand interface and 'ehpt ecu'\n"
    "                   connect), or lcm:URL (lcm:udpm://239.255.76.67:7667?ttl=0, lcm:memq://)\n"
    "  --lcm-prefix P   LCM channels P + PLANT_STATUS and P + ECU_COMMAND (default EHPT_)\n"
    "  --lockstep       advance one ECU period only after the ECU's command for it has arrived\n"
    "                   (deterministic SIL); default: wall clock (real time, latest command)\n"
    "  --command-timeout-s T  a command older than T puts the plant in its safe state (torques\n"
    "                   zero, engine ON/OFF held, ecuTimeout in PlantStatus); default 3 ECU periods\n"
    "  --lockstep-wait-s W    lockstep: wall time to wait for a command before going on\n"
    "                   without one (it then ages towards the timeout); default 1\n"
    "  --ecu-wait-s S   wall time to wait for an ECU to connect before t = 0; default 60\n"
    "  --realtime, --period, --cpu, --priority  the real-time loop, as for 'ehpt run' (instead\n"
    "                   of the plain wall clock; not with --lockstep)\n"
    "  --out, --set, --quiet  as for 'ehpt run'\n"
    "A fault holds the run (reported in PlantStatus) and ends it with exit 3.\n";

const char* kEcuHelp =
    "usage: ehpt ecu SCENARIO --bus SPEC [--set key=value ...] [--idle-timeout-s S]\n"
    "                [--max-samples N] [--quiet]\n"
    "\n"
    "Runs the scenario's built-in ECU (MBecu1, MBecu1soc, MBecu2, the EV's follower) as its\n"
    "own process: for each PlantStatus frame it computes one command from that sample's sensor\n"
    "frames and sends it. Stops when the plant closes the connection (socketcand), after S\n"
    "seconds without a frame from the plant (default 10), or after N samples.\n"
    "  --bus SPEC       socketcan:IFACE, socketcand:HOST:PORT (connects to 'ehpt plant'), or\n"
    "                   lcm:URL (lcm:udpm://239.255.76.67:7667?ttl=0)\n"
    "  --lcm-prefix P   LCM channel prefix (default EHPT_)\n";

const char* kReplayHelp =
    "usage: ehpt replay RUN_DIR [--out DIR] [--quiet]\n"
    "\n"
    "Runs a recorded bus session again, offline and as fast as possible. Every 'ehpt plant'\n"
    "session (wall clock, real time or lockstep) writes inputs.log into its output folder:\n"
    "each command the plant applied, with the step it acted from. The replay loads the same\n"
    "scenario with the same --set overrides, applies those commands at those steps and\n"
    "writes timeseries.csv and summary.json like 'ehpt run'. It compares its trajectory_hash\n"
    "with the session's summary.json: equal means bit for bit the same trajectory (exit 0);\n"
    "a difference (the scenario's files changed since) is exit 1.\n"
    "  RUN_DIR          the session's output folder (or its inputs.log)\n"
    "  --out DIR        output folder (default out/<scenario name>_replay)\n"
    "  --quiet          print nothing but errors\n";

const char* kListHelp =
    "usage: ehpt list [--dir DIR]\n"
    "Lists the scenarios (name and description) in DIR, else in the first of these folders\n"
    "that exists (where 'ehpt run NAME' looks names up too): $EHPT_SCENARIOS, ./scenarios,\n"
    "<prefix>/share/ehpt/scenarios for an installed ehpt (/usr/share/ehpt/scenarios from the\n"
    "Debian package), the source tree's scenarios/ for an ehpt run from its build folder.\n";

const char* kSignalsHelp =
    "usage: ehpt signals SCENARIO\n"
    "Lists the columns timeseries.csv can hold for the scenario's vehicle (choose them with\n"
    "[output] signals = [...] in the scenario). Units are the name's suffix.\n";

const char* kPlotHelp =
    "usage: ehpt plot DIR\n"
    "Draws PNG figures (speed, torques and limiter state, powers, SOC, locked flag) from\n"
    "DIR/timeseries.csv into DIR with plot.py under /usr/bin/python3 (matplotlib). plot.py\n"
    "is taken from $EHPT_TOOLS_DIR, else <prefix>/libexec/ehpt for an installed ehpt\n"
    "(/usr/libexec/ehpt from the Debian package), else the source tree's tools/ for an ehpt\n"
    "run from its build folder. A figure replaces a file of the same name only if DIR's\n"
    "ehpt-manifest.txt lists it.\n"
    "On a sweep folder ('ehpt sweep --out DIR'): fuel (or battery Wh/km) against final SOC,\n"
    "one panel per scenario, coloured by each swept parameter (sweep_*.png).\n";

// The list and plot helps end with where this ehpt looks (build folder or installed).
std::string list_help() {
  const std::string dir = ehpt::hil::scenarios_dir();
  return std::string(kListHelp) + "This ehpt: " +
         (dir.empty() ? "no scenarios folder found (looked in " + ehpt::hil::scenarios_search_text() + ")"
                      : (dir == "scenarios" ? "./scenarios" : dir)) +
         "\n";
}

std::string plot_help() {
  const std::string tools = ehpt::hil::tools_dir();
  return std::string(kPlotHelp) + "This ehpt: " + (tools.empty() ? "no plot tool found" : tools + "/plot.py") + "\n";
}

bool wants_help(const std::vector<std::string>& args) {
  for (const auto& a : args) {
    if (a == "--help" || a == "-h") return true;
  }
  return false;
}

// Draws the figures of the run in src_dir into out_dir with the plot tool (no shell: an
// argument vector), naming them as if in shown_dir. True on success.
bool run_plot_tool(const std::string& src_dir, const std::string& out_dir, const std::string& shown_dir, bool quiet) {
  // a folder named "-x" must not be taken for an option
  const auto safe = [](const std::string& p) { return !p.empty() && p[0] == '-' ? "./" + p : p; };
  const std::string tools = ehpt::hil::tools_dir();
  if (tools.empty()) {
    std::cerr << "error: plotting failed: no plot tool found (not installed in <prefix>/libexec/ehpt next to this "
                 "ehpt; set EHPT_TOOLS_DIR to the folder of plot.py)\n";
    return false;
  }
  std::vector<std::string> argv = {"/usr/bin/python3", tools + "/plot.py", safe(src_dir),
                                   "--out-dir", safe(out_dir), "--as", shown_dir};
  if (quiet) argv.push_back("--quiet");
  std::string reason;
  const int rc = ehpt::io::run_program(argv, reason);
  if (rc == 0) return true;
  if (rc < 0) {
    std::cerr << "error: plotting failed: cannot start " << reason << "\n";
  } else {
    std::cerr << "error: plotting failed (the plot tool exited with " << rc << ")\n";
  }
  return false;
}

// `ehpt plot DIR`: draw into a private folder inside DIR, then move each figure into DIR.
// An existing file is replaced only if DIR is an ehpt run whose manifest lists it.
int plot_existing(const std::string& dir, bool quiet) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    std::cerr << "error: " << dir << ": not a folder (give a run's output folder)\n";
    return 1;
  }
  // the folder's lock: no run may commit into it, and no other plot update its manifest,
  // while the figures move in
  ehpt::io::DirLock lock;
  std::string error;
  if (!lock.acquire(dir, error)) {
    std::cerr << "error: " << error << "\n";
    return 1;
  }
  std::vector<std::string> listed;
  std::string why;
  const bool ehpt_run = ehpt::io::is_earlier_run(dir, listed, why);
  // a sweep folder's figures (sweep_*.png, from results.csv) are ehpt's too
  const bool sweep = is_sweep_folder(dir);
  std::string tmpl = dir + "/.ehpt-plot-XXXXXX";
  if (::mkdtemp(tmpl.data()) == nullptr) {
    std::cerr << "error: " << dir << ": cannot create a temporary folder: " << std::strerror(errno) << "\n";
    return 1;
  }
  const std::string tmp = tmpl;  // ours: made by mkdtemp in this process
  bool ok = run_plot_tool(dir, tmp, dir, quiet);
  std::vector<std::string> moved;
  std::error_code list_ec;
  for (fs::directory_iterator it(tmp, list_ec), end; ok && !list_ec && it != end; it.increment(list_ec)) {
    const std::string name = it->path().filename().string();
    const std::string target = dir + "/" + name;
    const bool ours = (ehpt_run && std::find(listed.begin(), listed.end(), name) != listed.end()) ||
                      (sweep && name.starts_with("sweep_") && name.ends_with(".png"));
    // a listed figure of ours is replaced; any other name only if it is free (no replace)
    const bool renamed = ours ? ::rename(it->path().c_str(), target.c_str()) == 0
                              : ::renameat2(AT_FDCWD, it->path().c_str(), AT_FDCWD, target.c_str(), RENAME_NOREPLACE) == 0;
    if (!renamed) {
      if (errno == EEXIST) {
        std::cerr << "error: " << target << ": exists and is not a figure ehpt made; kept, the new figure is not written\n";
      } else {
        std::cerr << "error: " << target << ": " << std::strerror(errno) << "\n";
      }
      ok = false;
      continue;
    }
    moved.push_back(name);
  }
  if (list_ec) {
    std::cerr << "error: " << tmp << ": " << list_ec.message() << "\n";
    ok = false;
  }
  fs::remove_all(tmp, ec);
  if (ehpt_run && !moved.empty() && !ehpt::io::add_to_manifest(dir, moved, error)) {
    std::cerr << "error: " << error << "\n";
    ok = false;
  }
  return ok ? 0 : 1;
}

int load(const std::string& name, const std::vector<std::string>& sets, ehpt::hil::Scenario& sc) {
  std::string reason;
  const std::string path = ehpt::hil::resolve_scenario(name, reason);
  if (path.empty()) {
    // a hostile name can be very long: print its start
    const std::string shown = name.size() <= 200 ? name : name.substr(0, 80) + "... (" + std::to_string(name.size()) + " characters)";
    std::cerr << shown << ": " << reason << "\n";
    return 2;
  }
  std::vector<std::string> errors;
  if (!ehpt::hil::load_scenario(path, sets, sc, errors)) {
    for (const auto& e : errors) std::cerr << e << "\n";
    std::cerr << errors.size() << (errors.size() == 1 ? " problem" : " problems") << "; nothing was run.\n";
    return 2;
  }
  return 0;
}

// The real-time options of 'ehpt run' and 'ehpt plant'.
struct RealtimeArgs {
  bool realtime = false, tuned = false;  // tuned: --period, --cpu or --priority given
  ehpt::hil::RealtimeOptions opt;
};

// A duration: "1ms", "500us", "2s" or plain seconds; (0, 10 s].
bool parse_period(const std::string& text, double& seconds) {
  std::string number = text;
  double unit = 1.0;
  for (const auto& [suffix, scale] : {std::pair<const char*, double>{"us", 1e-6}, {"ms", 1e-3}, {"s", 1.0}}) {
    const std::string sfx = suffix;
    if (number.size() > sfx.size() && number.compare(number.size() - sfx.size(), sfx.size(), sfx) == 0) {
      number.resize(number.size() - sfx.size());
      unit = scale;
      break;
    }
  }
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(number.c_str(), &end);
  if (number.empty() || end == nullptr || *end != '\0' || errno != 0 || !std::isfinite(v) || v <= 0.0 ||
      v * unit > 10.0 || v * unit < 1e-6) {
    std::cerr << "--period " << text << ": must be a duration between 1us and 10s (1ms, 500us, 0.002s, 0.002)\n";
    return false;
  }
  seconds = v * unit;
  return true;
}

// A whole number in [lo, hi].
bool parse_int(const std::string& option, const std::string& text, int lo, int hi, int& out) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || end == nullptr || *end != '\0' || errno != 0 || v < lo || v > hi) {
    std::cerr << option << " " << text << ": must be a whole number from " << lo << " to " << hi << "\n";
    return false;
  }
  out = static_cast<int>(v);
  return true;
}

// Consumes a real-time option at args[i] (and its value). kNotRealtime: not one of them;
// 0: taken; 1: a missing or bad value (usage, as every option).
constexpr int kNotRealtime = -1;
int parse_realtime_arg(const std::vector<std::string>& args, std::size_t& i, RealtimeArgs& rt, const char* help) {
  const std::string& o = args[i];
  if (o == "--realtime") {
    rt.realtime = true;
    return 0;
  }
  if (o != "--period" && o != "--cpu" && o != "--priority") return kNotRealtime;
  if (i + 1 >= args.size()) {
    std::cerr << o << " needs a value\n" << help;
    return 1;
  }
  rt.tuned = true;
  const std::string& v = args[++i];
  if (o == "--period") return parse_period(v, rt.opt.period_s) ? 0 : 1;
  if (o == "--priority") return parse_int(o, v, 1, 99, rt.opt.priority) ? 0 : 1;
  if (!parse_int(o, v, 0, 4095, rt.opt.cpu)) return 1;
  std::string allowed;
  if (!ehpt::hil::cpu_allowed(rt.opt.cpu, allowed)) {
    std::cerr << "--cpu " << v << ": not a CPU this process may run on (" << allowed << ")\n";
    return 1;
  }
  return 0;
}

// After loading: the period fits the scenario's step. 0 or the exit code.
int check_realtime(const RealtimeArgs& rt, const ehpt::hil::Scenario& sc) {
  if (!rt.realtime) {
    if (rt.tuned) {
      std::cerr << "--period, --cpu and --priority belong to --realtime\n";
      return 1;
    }
    return 0;
  }
  if (rt.opt.period_s > 0.0) {
    const double ratio = rt.opt.period_s / sc.solver.step_s;
    if (std::abs(ratio - std::round(ratio)) > 1e-9 * ratio || std::round(ratio) < 1.0) {
      std::cerr << "--period " << ehpt::io::number_text(rt.opt.period_s) << " s: must be a whole number of solver steps (solver.step_s = "
                << ehpt::io::number_text(sc.solver.step_s) << " s)\n";
      return 2;
    }
  }
  return 0;
}

int cmd_run(const std::vector<std::string>& args) {
  if (wants_help(args)) return out(kRunHelp) ? 0 : 1;
  std::string scenario, out_dir;
  std::vector<std::string> sets;
  bool do_plot = false, quiet = false;
  RealtimeArgs rt;
  for (std::size_t i = 0; i < args.size(); ++i) {
    if (const int rc = parse_realtime_arg(args, i, rt, kRunHelp); rc != kNotRealtime) {
      if (rc == 0) continue;
      return rc;
    }
    const std::string& a = args[i];
    if ((a == "--out" || a == "--set") && i + 1 >= args.size()) {
      std::cerr << a << " needs a value\n" << kRunHelp;
      return 1;
    }
    if (a == "--out") {
      out_dir = args[++i];
      if (out_dir.empty()) {
        std::cerr << "--out needs a folder name (got an empty one)\n";
        return 1;
      }
    } else if (a == "--set") {
      sets.push_back(args[++i]);
    } else if (a == "--plot") {
      do_plot = true;
    } else if (a == "--quiet") {
      quiet = true;
    } else if (!a.empty() && a[0] == '-') {
      std::cerr << "unknown option " << a << "\n" << kRunHelp;
      return 1;
    } else if (scenario.empty()) {
      scenario = a;
    } else {
      std::cerr << "one scenario per run (got " << scenario << " and " << a << ")\n";
      return 1;
    }
  }
  if (scenario.empty()) {
    std::cerr << kRunHelp;
    return 1;
  }
  ehpt::hil::Scenario sc;
  if (const int rc = load(scenario, sets, sc); rc != 0) return rc;
  if (const int rc = check_realtime(rt, sc); rc != 0) return rc;
  if (do_plot && !sc.output.timeseries) {
    // refused before the run: the figures are drawn from timeseries.csv, which it would not write
    std::cerr << "error: --plot draws its figures from timeseries.csv, but output.timeseries = false (the scenario "
                 "or a --set) writes none: drop --plot, or drop output.timeseries = false "
                 "(--set output.timeseries=true); nothing was run.\n";
    return 2;
  }
  if (!quiet) {
    for (const auto& w : sc.warnings) std::cerr << "warning: " << w << "\n";
  }
  if (out_dir.empty()) out_dir = "out/" + sc.name;

  ehpt::hil::BatchOptions opt;
  if (rt.realtime) opt.realtime = &rt.opt;
  opt.out_dir = out_dir;
  opt.progress = !quiet && isatty(STDERR_FILENO);
  opt.stop_signal = &g_stop;
  if (do_plot) {
    // drawn into the temporary folder, so the figures are part of the committed run
    opt.before_commit = [&](const std::string& dir) { return run_plot_tool(dir, dir, out_dir, quiet); };
  }
  const ehpt::hil::BatchResult r = ehpt::hil::run_batch(sc, opt, std::cerr);
  if (!quiet) {
    for (const auto& w : r.warnings) std::cerr << "warning: " << w << "\n";
  }
  bool printed = true;
  if (!quiet) {
    std::string text = r.summary_text;
    if (!r.results_dir.empty()) {
      text += "outputs       " + (sc.output.timeseries ? r.results_dir + "/timeseries.csv, " : std::string()) +
              r.results_dir + "/summary.json\n";
    }
    printed = out(text);
  }
  if (r.exit_code != 0) return r.exit_code;
  return printed && !r.after_failed ? 0 : 1;
}

// A positive, finite number of seconds (or a count) from the command line.
bool parse_positive(const std::string& option, const std::string& text, double& out) {
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end == nullptr || *end != '\0' || errno != 0 || !std::isfinite(v) || v <= 0.0 || v > 1e9) {
    std::cerr << option << " " << text << ": must be a positive number (at most 1e9)\n";
    return false;
  }
  out = v;
  return true;
}

// The options 'ehpt plant' and 'ehpt ecu' share, and theirs.
struct BusArgs {
  std::string scenario, out_dir, bus, lcm_prefix = "EHPT_";
  std::vector<std::string> sets;
  bool lockstep = false, quiet = false;
  double command_timeout_s = 0.0, lockstep_wait_s = 1.0, ecu_wait_s = 60.0, idle_timeout_s = 10.0, max_samples = 0.0;
  // --bus, checked: an LCM URL, or a CAN transport
  bool lcm = false;
  std::string lcm_url;
  ehpt::io::can::BusSpec spec;
  RealtimeArgs rt;
};

// 0: parsed; else the exit code.
int parse_bus_args(const std::vector<std::string>& args, bool plant, const char* help, BusArgs& a) {
  for (std::size_t i = 0; i < args.size(); ++i) {
    if (plant) {
      if (const int rc = parse_realtime_arg(args, i, a.rt, help); rc != kNotRealtime) {
        if (rc == 0) continue;
        return rc;
      }
    }
    const std::string& o = args[i];
    const bool takes_value = o == "--bus" || o == "--set" || o == "--lcm-prefix" || (plant && (o == "--out" || o == "--command-timeout-s" ||
                                                                        o == "--lockstep-wait-s" || o == "--ecu-wait-s")) ||
                             (!plant && (o == "--idle-timeout-s" || o == "--max-samples"));
    if (takes_value && i + 1 >= args.size()) {
      std::cerr << o << " needs a value\n" << help;
      return 1;
    }
    if (o == "--bus") {
      a.bus = args[++i];
    } else if (o == "--set") {
      a.sets.push_back(args[++i]);
    } else if (o == "--lcm-prefix") {
      a.lcm_prefix = args[++i];
      if (a.lcm_prefix.size() > 100 || a.lcm_prefix.find_first_of(" \t\n") != std::string::npos) {
        std::cerr << "--lcm-prefix: at most 100 characters, no spaces\n";
        return 1;
      }
    } else if (plant && o == "--out") {
      a.out_dir = args[++i];
      if (a.out_dir.empty()) {
        std::cerr << "--out needs a folder name (got an empty one)\n";
        return 1;
      }
    } else if (plant && o == "--lockstep") {
      a.lockstep = true;
    } else if (plant && o == "--command-timeout-s") {
      if (!parse_positive(o, args[++i], a.command_timeout_s)) return 1;
    } else if (plant && o == "--lockstep-wait-s") {
      if (!parse_positive(o, args[++i], a.lockstep_wait_s)) return 1;
    } else if (plant && o == "--ecu-wait-s") {
      if (!parse_positive(o, args[++i], a.ecu_wait_s)) return 1;
    } else if (!plant && o == "--idle-timeout-s") {
      if (!parse_positive(o, args[++i], a.idle_timeout_s)) return 1;
    } else if (!plant && o == "--max-samples") {
      if (!parse_positive(o, args[++i], a.max_samples) || a.max_samples != std::floor(a.max_samples)) {
        std::cerr << "--max-samples must be a whole number\n";
        return 1;
      }
    } else if (o == "--quiet") {
      a.quiet = true;
    } else if (!o.empty() && o[0] == '-') {
      std::cerr << "unknown option " << o << "\n" << help;
      return 1;
    } else if (a.scenario.empty()) {
      a.scenario = o;
    } else {
      std::cerr << "one scenario per run (got " << a.scenario << " and " << o << ")\n";
      return 1;
    }
  }
  if (a.scenario.empty() || a.bus.empty()) {
    std::cerr << (a.scenario.empty() ? "a scenario is needed\n" : "--bus is needed\n") << help;
    return 1;
  }
  a.lcm = a.bus.rfind("lcm:", 0) == 0;
  std::string error;
  if (a.lcm ? !ehpt::io::lcm::parse_lcm_spec(a.bus, a.lcm_url, error)
            : !ehpt::io::can::parse_bus_spec(a.bus, a.spec, error)) {
    std::cerr << error << "\n";
    return 1;
  }
  return 0;
}

// The ids a side of the contract accepts, by vehicle family.
std::span<const std::uint32_t> rx_ids(const ehpt::hil::Scenario& sc, bool plant) {
  namespace can = ehpt::io::can;
  const bool psd = sc.ecu.holds<ehpt::ecu::PsdEcuParams>();
  if (plant) return psd ? std::span<const std::uint32_t>(can::kPsdCommandIds) : std::span<const std::uint32_t>(can::kEvCommandIds);
  return psd ? std::span<const std::uint32_t>(can::kPsdSensorIds) : std::span<const std::uint32_t>(can::kEvSensorIds);
}

int cmd_plant(const std::vector<std::string>& args) {
  if (wants_help(args)) return out(kPlantHelp) ? 0 : 1;
  BusArgs a;
  if (const int rc = parse_bus_args(args, true, kPlantHelp, a); rc != 0) return rc;
  if (a.rt.realtime && a.lockstep) {
    std::cerr << "--realtime and --lockstep: lockstep waits for the ECU at every sample and cannot keep a "
                 "real-time period (use one or the other)\n";
    return 1;
  }
  ehpt::hil::Scenario sc;
  if (const int rc = load(a.scenario, a.sets, sc); rc != 0) return rc;
  if (const int rc = check_realtime(a.rt, sc); rc != 0) return rc;
  if (!a.quiet) {
    for (const auto& w : sc.warnings) std::cerr << "warning: " << w << "\n";
  }
  ehpt::hil::BusPlantOptions bo;
  bo.lockstep = a.lockstep;
  bo.realtime = a.rt.realtime;
  bo.command_timeout_s = a.command_timeout_s;
  bo.lockstep_wait_s = a.lockstep_wait_s;
  bo.peer_wait_s = a.ecu_wait_s;
  bo.log_interface = a.spec.interface_name;
  bo.lcm_prefix = a.lcm_prefix;
  std::error_code path_ec;
  bo.scenario_path = fs::absolute(sc.path, path_ec).string();
  bo.overrides = a.sets;
  std::string error, why;
  if (!ehpt::hil::can_run_on_bus(sc, why)) {
    std::cerr << "error: " << why << "\n";
    return 2;
  }
  // the bus first: a bus that cannot open leaves no output folder behind. The driver refers
  // to the bus: declared after it, destroyed before it.
  std::unique_ptr<ehpt::io::can::Transport> bus;
  std::unique_ptr<ehpt::io::lcm::LcmBus> lcm_bus;
  std::unique_ptr<ehpt::hil::ExternalDriver> driver;
  if (a.lcm) {
    lcm_bus = ehpt::io::lcm::LcmBus::open(a.lcm_url, error);
    if (!lcm_bus) {
      std::cerr << "error: " << error << "\n";
      return 2;
    }
    driver = ehpt::hil::make_bus_plant(sc, *lcm_bus, bo, why);
  } else {
    bus = ehpt::io::can::open_bus(a.spec, ehpt::io::can::BusRole::kPlant, rx_ids(sc, true), error);
    if (!bus) {
      std::cerr << "error: " << error << "\n";
      return 2;
    }
    driver = ehpt::hil::make_bus_plant(sc, *bus, bo, why);
  }
  if (!a.quiet) {
    std::cerr << "plant " << sc.name << " on " << a.bus
              << (a.lockstep ? " (lockstep)" : a.rt.realtime ? " (real time)" : " (wall clock)") << "; waiting for an ECU\n";
  }
  ehpt::hil::BatchOptions opt;
  opt.out_dir = a.out_dir.empty() ? "out/" + sc.name : a.out_dir;
  opt.progress = !a.quiet && isatty(STDERR_FILENO);
  opt.stop_signal = &g_stop;
  opt.driver = driver.get();
  if (a.rt.realtime) opt.realtime = &a.rt.opt;
  const ehpt::hil::BatchResult r = ehpt::hil::run_batch(sc, opt, std::cerr);
  if (!a.quiet) {
    for (const auto& w : r.warnings) std::cerr << "warning: " << w << "\n";
  }
  bool printed = true;
  if (!a.quiet) {
    std::string text = r.summary_text;
    if (!r.results_dir.empty()) {
      text += "outputs       " + r.results_dir + "/timeseries.csv, summary.json" + (a.lcm ? "" : ", bus.log") + "\n";
    }
    printed = out(text);
  }
  if (r.exit_code != 0) return r.exit_code;
  return printed ? 0 : 1;
}

int cmd_ecu(const std::vector<std::string>& args) {
  if (wants_help(args)) return out(kEcuHelp) ? 0 : 1;
  BusArgs a;
  if (const int rc = parse_bus_args(args, false, kEcuHelp, a); rc != 0) return rc;
  ehpt::hil::Scenario sc;
  if (const int rc = load(a.scenario, a.sets, sc); rc != 0) return rc;
  std::string error;
  if (!ehpt::hil::has_bus_ecu(sc, error)) {
    std::cerr << "error: " << error << "\n";
    return 2;
  }
  ehpt::hil::BusEcuOptions eo;
  eo.idle_timeout_s = a.idle_timeout_s;
  eo.max_samples = static_cast<std::int64_t>(a.max_samples);
  if (a.lcm) {
    const auto lcm_bus = ehpt::io::lcm::LcmBus::open(a.lcm_url, error);
    if (!lcm_bus) {
      std::cerr << "error: " << error << "\n";
      return 2;
    }
    std::ostringstream log;
    const ehpt::hil::BusEcuResult r = ehpt::hil::run_bus_ecu(sc, *lcm_bus, a.lcm_prefix, eo, &g_stop, log);
    if (!a.quiet && !out(log.str())) return 1;
    return r.exit_code;
  }
  const auto bus = ehpt::io::can::open_bus(a.spec, ehpt::io::can::BusRole::kEcu, rx_ids(sc, false), error);
  if (!bus) {
    std::cerr << "error: " << error << "\n";
    return 2;
  }
  std::ostringstream log;
  const ehpt::hil::BusEcuResult r = ehpt::hil::run_bus_ecu(sc, *bus, eo, &g_stop, log);
  if (!a.quiet && !out(log.str())) return 1;
  return r.exit_code;
}

// "key": "text" or "key": number from a summary.json (flat keys, the first match); "" if absent.
std::string summary_value(const std::string& json, const std::string& key) {
  const std::string k = "\"" + key + "\": ";
  const auto at = json.find(k);
  if (at == std::string::npos) return "";
  std::size_t b = at + k.size(), e = b;
  if (b < json.size() && json[b] == '"') {
    e = json.find('"', ++b);
  } else {
    while (e < json.size() && json[e] != ',' && json[e] != '\n' && json[e] != '}') ++e;
  }
  return e == std::string::npos ? "" : json.substr(b, e - b);
}

int cmd_replay(const std::vector<std::string>& args) {
  if (wants_help(args)) return out(kReplayHelp) ? 0 : 1;
  std::string source, out_dir;
  bool quiet = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--out") {
      if (i + 1 >= args.size() || args[i + 1].empty()) {
        std::cerr << "--out needs a folder name\n" << kReplayHelp;
        return 1;
      }
      out_dir = args[++i];
    } else if (args[i] == "--quiet") {
      quiet = true;
    } else if (!args[i].empty() && args[i][0] == '-') {
      std::cerr << "unknown option " << args[i] << "\n" << kReplayHelp;
      return 1;
    } else if (source.empty()) {
      source = args[i];
    } else {
      std::cerr << "one session per replay (got " << source << " and " << args[i] << ")\n";
      return 1;
    }
  }
  if (source.empty()) {
    std::cerr << kReplayHelp;
    return 1;
  }
  std::error_code ec;
  const bool is_dir = fs::is_directory(source, ec);
  const std::string log_path = is_dir ? source + "/" + ehpt::hil::kInputsLogName : source;
  const std::string session_dir = is_dir ? source : fs::path(source).parent_path().string();
  ehpt::hil::InputsLog log;
  std::vector<std::string> problems;
  if (!ehpt::hil::read_inputs_log(log_path, log, problems)) {
    for (const auto& p : problems) std::cerr << p << "\n";
    std::cerr << "nothing was run.\n";
    return 2;
  }
  // the session's own summary: how far it ran (an interrupted session stopped early) and its hash
  std::string session_summary, reason;
  const std::string summary_path = (session_dir.empty() ? std::string(".") : session_dir) + "/summary.json";
  if (!ehpt::io::read_text_file(summary_path, session_summary, reason)) {
    std::cerr << summary_path << ": " << reason << " (a session that did not end cleanly cannot be compared)\n";
    return 2;
  }
  const std::string recorded_hash = summary_value(session_summary, "trajectory_hash");
  const std::string steps_text = summary_value(session_summary, "steps");
  char* end = nullptr;
  const long long recorded_steps = std::strtoll(steps_text.c_str(), &end, 10);
  if (steps_text.empty() || *end != '\0' || recorded_steps < 0) {
    std::cerr << summary_path << ": no \"steps\" count\n";
    return 2;
  }
  std::vector<std::string> sets = log.overrides;
  ehpt::hil::Scenario sc;
  if (const int rc = load(log.scenario_path, sets, sc); rc != 0) return rc;
  if (recorded_steps < sc.solver.steps) {  // it ran this far: so does the replay
    sets.push_back("solver.duration_s=" + ehpt::io::number_text(static_cast<double>(recorded_steps) * sc.solver.step_s));
    if (const int rc = load(log.scenario_path, sets, sc); rc != 0) return rc;
  }
  std::string why;
  if (!ehpt::hil::can_run_on_bus(sc, why)) {  // a rig: no bus session can have been recorded on it
    std::cerr << log_path << ": " << why << "\n";
    return 2;
  }
  const bool psd = sc.ecu.holds<ehpt::ecu::PsdEcuParams>();
  if ((psd ? "psd" : "ev") != log.family) {
    std::cerr << log_path << ": its commands are of family '" << log.family << "' but " << log.scenario_path
              << " is a" << (psd ? " hybrid ('psd')" : "n EV ('ev')") << "\n";
    return 2;
  }
  const std::unique_ptr<ehpt::hil::ExternalDriver> driver = ehpt::hil::make_replay_driver(log, log_path);
  ehpt::hil::BatchOptions opt;
  opt.out_dir = out_dir.empty() ? "out/" + sc.name + "_replay" : out_dir;
  opt.progress = !quiet && isatty(STDERR_FILENO);
  opt.stop_signal = &g_stop;
  opt.driver = driver.get();
  const ehpt::hil::BatchResult r = ehpt::hil::run_batch(sc, opt, std::cerr);
  const std::string hash = summary_value(r.summary.str(), "trajectory_hash");
  const bool same = !recorded_hash.empty() && hash == recorded_hash;
  if (!quiet) {
    for (const auto& w : r.warnings) std::cerr << "warning: " << w << "\n";
    std::string text = r.summary_text;
    text += same ? "replay        bit-identical to the session in " + session_dir + " (trajectory_hash " + hash + ")\n"
                 : "replay        DIFFERS from the session in " + session_dir + ": trajectory_hash " + hash +
                       " here, " + (recorded_hash.empty() ? "none" : recorded_hash) + " there\n";
    if (!r.results_dir.empty()) text += "outputs       " + r.results_dir + "/timeseries.csv, summary.json\n";
    if (!out(text)) return 1;
  }
  if (r.exit_code != 0 && r.exit_code != 3) return r.exit_code;
  if (!same) {
    std::cerr << "error: the replay's trajectory differs from the session's (did the scenario's files change?)\n";
    return 1;
  }
  return r.exit_code;
}

int cmd_list(const std::vector<std::string>& args) {
  if (wants_help(args)) return out(list_help()) ? 0 : 1;
  std::string dir = ehpt::hil::scenarios_dir();
  if (args.size() == 2 && args[0] == "--dir") {
    dir = args[1];
  } else if (!args.empty()) {
    std::cerr << list_help();
    return 1;
  }
  if (dir.empty()) {
    std::cerr << "error: no scenarios folder found (looked in " << ehpt::hil::scenarios_search_text()
              << "); give --dir DIR or set EHPT_SCENARIOS\n";
    return 1;
  }
  const auto list = ehpt::hil::list_scenarios(dir);
  if (list.empty()) {
    std::cerr << dir << ": no scenarios (*.toml)\n";
    return 1;
  }
  std::size_t width = 0;
  for (const auto& s : list) width = std::max(width, s.name.size());
  std::string text;
  for (const auto& s : list) text += s.name + std::string(width + 2 - s.name.size(), ' ') + s.description + "\n";
  return out(text) ? 0 : 1;
}

std::string signal_lines(const std::vector<ehpt::hil::SignalInfo>& signals) {
  std::string text;
  for (const auto& s : signals) {
    text += std::string(s.name) + std::string(s.name.size() < 24 ? 24 - s.name.size() : 1, ' ') +
            std::string(s.meaning) + "\n";
  }
  return text;
}

int cmd_signals(const std::vector<std::string>& args) {
  if (wants_help(args) || args.size() != 1) {
    if (args.size() != 1) {
      std::cerr << kSignalsHelp;
      return 1;
    }
    return out(kSignalsHelp) ? 0 : 1;
  }
  ehpt::hil::Scenario sc;
  if (const int rc = load(args[0], {}, sc); rc != 0) return rc;
  return out(signal_lines(ehpt::hil::scenario_signals(sc))) ? 0 : 1;
}

int cmd_plot(const std::vector<std::string>& args) {
  if (wants_help(args) || args.size() != 1) {
    if (args.size() != 1) {
      std::cerr << plot_help();
      return 1;
    }
    return out(plot_help()) ? 0 : 1;
  }
  return plot_existing(args[0], false);
}

int dispatch(std::vector<std::string> args) {
  if (args.empty()) {
    std::cerr << kMainHelp;
    return 1;
  }
  const std::string cmd = args[0];
  args.erase(args.begin());
  if (cmd == "--help" || cmd == "-h" || cmd == "help") return out(kMainHelp) ? 0 : 1;
  if (cmd == "--version" || cmd == "version") {
    if (!args.empty()) {
      std::cerr << "error: " << cmd << " takes no arguments (got '" << args[0] << "')\n";
      return 1;
    }
    return out(ehpt::hil::version_text()) ? 0 : 1;
  }
  if (cmd == "run") return cmd_run(args);
  if (cmd == "list") return cmd_list(args);
  if (cmd == "signals") return cmd_signals(args);
  if (cmd == "plot") return cmd_plot(args);
  if (cmd == "plant") return cmd_plant(args);
  if (cmd == "ecu") return cmd_ecu(args);
  if (cmd == "bench") return cmd_bench(args);
  if (cmd == "replay") return cmd_replay(args);
  if (cmd == "sweep") return cmd_sweep(args, g_stop);
  std::cerr << "unknown command '" << cmd << "'\n\n" << kMainHelp;
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  install_signal_handlers();
  // A run started by 'ehpt sweep' ends (SIGTERM: cleanly, as an interrupted run) when the sweep
  // dies, even by SIGKILL, instead of holding its folder's lock against the next sweep.
  if (const char* parent = std::getenv("EHPT_SWEEP_PID")) {
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (std::to_string(::getppid()) != parent) g_stop.store(SIGTERM);  // it died before prctl
  }
  // nothing escapes as an abort: out of memory and any other exception end with one line
  // (an output folder being written is removed by its destructor: it holds nothing useful)
  try {
    return dispatch(std::vector<std::string>(argv + 1, argv + argc));
  } catch (const std::bad_alloc&) {
    std::cerr << "error: out of memory\n";
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
  }
  return 1;
}
