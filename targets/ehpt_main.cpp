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
// was run), 3 run-time fault (outputs kept), 4 degraded bus session, 128 + N stopped by signal N (130 SIGINT,
// 143 SIGTERM, 129 SIGHUP; outputs so far kept and committed).
//
// One file per command: targets/cmd_*.cpp, targets/bench/ (ehpt bench), targets/cmd_sweep.cpp;
// what they share is in targets/cli.hpp. This file installs the signal handlers and dispatches.

#include <sys/prctl.h>  // PR_SET_PDEATHSIG
#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <new>
#include <string>
#include <vector>

#include "hil/diag/provenance.hpp"
#include "targets/bench/bench.hpp"
#include "targets/cli.hpp"
#include "targets/cmd_sweep.hpp"

namespace {

using namespace ehpt::cli;

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
    "  dbc FILE.dbc     check a DBC as ehpt reads it, list its messages, decode frames with it\n"
    "  fmu SCENARIO     the scenario as an FMI 3.0 co-simulation FMU (its vehicle and built-in ECU)\n"
    "  test PATH...     run ECU test files (faults, expectations): a verdict table and JUnit XML\n"
    "  sweep CAMPAIGN   run a campaign (scenarios x parameters) locally or as a Slurm job array;\n"
    "                   merged results.csv and results.jsonl\n"
    "\n"
    "  --version        the version, the git description of the build, the compiler and flags\n"
    "\n"
    "'ehpt <command> --help' gives the options of a command.\n"
    "Exit codes: 0 ok, 1 usage, output or system error, 2 bad input (nothing run), 3 run-time\n"
    "fault (outputs kept), 4 a degraded bus session (no ECU, timeouts, bus errors; outputs\n"
    "kept), 5 an expectation failed ('ehpt run' of a test; outputs kept), 128+N stopped by\n"
    "signal N: 130 Ctrl-C, 143 SIGTERM, 129 SIGHUP (outputs so far kept).\n";

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
  if (cmd == "dbc") return cmd_dbc(args);
  if (cmd == "fmu") return cmd_fmu(args);
  if (cmd == "test") return cmd_test(args);
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
