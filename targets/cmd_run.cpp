// SPDX-License-Identifier: BSD-3-Clause
// `ehpt run`: a scenario as fast as possible (or in real time with --realtime), its outputs,
// and optionally its figures.
#include <unistd.h>

#include <filesystem>
#include <iostream>
#include <memory>

#include "hil/bus/in_process_bus.hpp"
#include "hil/run/batch.hpp"
#include "targets/cli.hpp"

namespace ehpt::cli {

namespace {

const char* kRunHelp =
    "usage: ehpt run SCENARIO [--out DIR] [--set key=value ...] [--fault SPEC ...] [--plot]\n"
    "                [--quiet]\n"
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

    "  --fault SPEC     add a fault, repeatable: a [[fault]] table as key=value pairs on one\n"
    "                   line, --fault \"kind=stuck target=batSOC at_s=300\" (docs/testing.md;\n"
    "                   timeseries.csv gets a faults_active column). A scenario with [[expect]]\n"
    "                   tables prints its verdict; an expectation that fails exits 5. Bus\n"
    "                   faults (on frames: drop, delay, ...) put the built-in ECU on an\n"
    "                   in-process CAN bus (lockstep; bus.log, inputs.log, \"bus\" in summary.json)\n"
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

}  // namespace

int cmd_run(const std::vector<std::string>& args) {
  if (wants_help(args)) return out(kRunHelp) ? 0 : 1;
  std::string scenario, out_dir;
  std::vector<std::string> sets, faults;
  bool do_plot = false, quiet = false;
  RealtimeArgs rt;
  for (std::size_t i = 0; i < args.size(); ++i) {
    if (const int rc = parse_realtime_arg(args, i, rt, kRunHelp); rc != kNotRealtime) {
      if (rc == 0) continue;
      return rc;
    }
    const std::string& a = args[i];
    if ((a == "--out" || a == "--set" || a == "--fault") && i + 1 >= args.size()) {
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
    } else if (a == "--fault") {
      faults.push_back(args[++i]);
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
  if (const int rc = load(scenario, sets, sc, faults); rc != 0) return rc;
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
  const bool expect_figures = !sc.expects.empty() && sc.output.timeseries;
  if (do_plot || expect_figures) {
    // drawn into the temporary folder, so the figures are part of the committed run; a test's
    // failed expectations get a figure each (its summary.json is there already)
    opt.before_commit = [&, do_plot, expect_figures](const std::string& dir) {
      bool ok = !do_plot || run_plot_tool(dir, dir, out_dir, quiet);
      if (expect_figures) ok = run_expect_figures(dir, quiet) && ok;
      return ok;
    };
  }
  // bus faults act on frames: the built-in ECU then runs over an in-process CAN bus
  std::unique_ptr<ehpt::hil::ExternalDriver> bus;
  if (ehpt::hil::has_bus_faults(sc)) {
    ehpt::hil::BusPlantOptions bo;
    std::error_code path_ec;
    bo.scenario_path = std::filesystem::absolute(sc.path, path_ec).string();
    bo.overrides = sets;
    bo.faults = faults;
    std::string error;
    bus = ehpt::hil::make_in_process_bus(sc, bo, error);
    if (!bus) {
      std::cerr << "error: " << error << "\nnothing was run.\n";
      return 2;
    }
    opt.driver = bus.get();
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
  if (quiet && r.exit_code == ehpt::hil::kExitExpectationFailed) {
    // the one line a quiet run says about its exit 5 (a sweep's message, an ehpt test log)
    std::cerr << "test failed: " << r.test.first_failure << "\n";
  }
  if (r.exit_code != 0) return r.exit_code;
  return printed && !r.after_failed ? 0 : 1;
}

}  // namespace ehpt::cli
