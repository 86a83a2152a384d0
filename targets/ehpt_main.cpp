// ehpt: command-line entry point. Batch (as fast as possible) runs of scenario files.
//   ehpt run SCENARIO [--out DIR] [--set key=value ...] [--plot] [--quiet]
//   ehpt list [--dir DIR]
//   ehpt signals SCENARIO
//   ehpt plot DIR

#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include "hil/batch.hpp"
#include "hil/config.hpp"
#include "hil/scenario.hpp"

namespace {

std::atomic<bool> g_stop{false};
extern "C" void on_sigint(int) { g_stop.store(true); }

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
    "\n"
    "'ehpt <command> --help' gives the options of a command.\n"
    "Exit codes: 0 ok, 1 usage or output error, 2 bad input (nothing run), 3 run-time fault\n"
    "(outputs kept), 130 interrupted (outputs so far kept).\n";

const char* kRunHelp =
    "usage: ehpt run SCENARIO [--out DIR] [--set key=value ...] [--plot] [--quiet]\n"
    "\n"
    "SCENARIO is a .toml file, or a name from 'ehpt list' (e.g. ev_nedc).\n"
    "  --out DIR        output folder (default out/<scenario name>); written as DIR.partial\n"
    "                   and renamed to DIR when complete\n"
    "  --set key=value  override a scenario key, repeatable. Vehicle keys take the prefix\n"
    "                   'vehicle.': --set vehicle.battery.soc_initial=0.6\n"
    "                   --set solver.method=implicit-euler --set solver.step_s=0.002\n"
    "                   --set output.interval_s=0.01 --set solver.duration_s=100\n"
    "  --plot           draw the figures after the run (as 'ehpt plot DIR')\n"
    "  --quiet          print nothing but errors\n"
    "\n"
    "Every problem in the scenario, vehicle, cycle or map files is listed as\n"
    "'file:line: field = value: expectation', and nothing runs (exit 2).\n";

const char* kListHelp =
    "usage: ehpt list [--dir DIR]\n"
    "Lists the scenarios in DIR (default: $EHPT_SCENARIOS, ./scenarios, or the source tree's).\n";

const char* kSignalsHelp =
    "usage: ehpt signals SCENARIO\n"
    "Lists the columns timeseries.csv can hold for the scenario's vehicle (choose them with\n"
    "[output] signals = [...] in the scenario). Units are the name's suffix.\n";

const char* kPlotHelp =
    "usage: ehpt plot DIR\n"
    "Draws PNG figures (speed, torques and limiter state, powers, SOC, locked flag) from\n"
    "DIR/timeseries.csv into DIR, with tools/plot.py under /usr/bin/python3.\n";

bool wants_help(const std::vector<std::string>& args) {
  for (const auto& a : args) {
    if (a == "--help" || a == "-h") return true;
  }
  return false;
}

int plot(const std::string& dir, bool quiet) {
  const std::string script = ehpt::hil::tools_dir() + "/plot.py";
  const std::string cmd = "/usr/bin/python3 '" + script + "' '" + dir + "'" + (quiet ? " --quiet" : "");
  const int rc = std::system(cmd.c_str());
  if (rc != 0) {
    std::cerr << "error: plotting failed (" << cmd << ")\n";
    return 1;
  }
  return 0;
}

int load(const std::string& name, const std::vector<std::string>& sets, ehpt::hil::Scenario& sc) {
  const std::string path = ehpt::hil::resolve_scenario(name);
  if (path.empty()) {
    std::cerr << name << ": no such scenario file or name (see 'ehpt list')\n";
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

int cmd_run(const std::vector<std::string>& args) {
  if (wants_help(args)) {
    std::cout << kRunHelp;
    return 0;
  }
  std::string scenario, out;
  std::vector<std::string> sets;
  bool do_plot = false, quiet = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if ((a == "--out" || a == "--set") && i + 1 >= args.size()) {
      std::cerr << a << " needs a value\n" << kRunHelp;
      return 1;
    }
    if (a == "--out") {
      out = args[++i];
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
  if (!quiet) {
    for (const auto& w : sc.warnings) std::cerr << "warning: " << w << "\n";
  }
  if (out.empty()) out = "out/" + sc.name;

  std::signal(SIGINT, on_sigint);
  std::signal(SIGTERM, on_sigint);
  ehpt::hil::BatchOptions opt;
  opt.out_dir = out;
  opt.progress = !quiet && isatty(STDERR_FILENO);
  opt.stop = &g_stop;
  const ehpt::hil::BatchResult r = ehpt::hil::run_batch(sc, opt, std::cerr);
  if (!quiet) {
    std::cout << r.summary_text;
    if (r.exit_code != 1) std::cout << "outputs       " << out << "/timeseries.csv, " << out << "/summary.json\n";
  }
  if (r.exit_code == 1) return 1;
  std::cout << std::flush;  // the summary before the plot tool's lines
  if (do_plot) {
    const int prc = plot(out, quiet);
    if (prc != 0 && r.exit_code == 0) return prc;
  }
  return r.exit_code;
}

int cmd_list(const std::vector<std::string>& args) {
  if (wants_help(args)) {
    std::cout << kListHelp;
    return 0;
  }
  std::string dir = ehpt::hil::scenarios_dir();
  if (args.size() == 2 && args[0] == "--dir") dir = args[1];
  const auto list = ehpt::hil::list_scenarios(dir);
  if (list.empty()) {
    std::cerr << dir << ": no scenarios (*.toml)\n";
    return 1;
  }
  std::size_t width = 0;
  for (const auto& s : list) width = std::max(width, s.name.size());
  for (const auto& s : list) std::cout << s.name << std::string(width + 2 - s.name.size(), ' ') << s.description << "\n";
  return 0;
}

template <class Signals>
void print_signals(const Signals& signals) {
  for (const auto& s : signals) {
    std::cout << s.name << std::string(s.name.size() < 24 ? 24 - s.name.size() : 1, ' ') << s.meaning << "\n";
  }
}

int cmd_signals(const std::vector<std::string>& args) {
  if (wants_help(args) || args.size() != 1) {
    std::cout << kSignalsHelp;
    return args.size() == 1 ? 0 : 1;
  }
  ehpt::hil::Scenario sc;
  if (const int rc = load(args[0], {}, sc); rc != 0) return rc;
  if (const auto* p = std::get_if<ehpt::plant::BevParams>(&sc.plant)) {
    print_signals(ehpt::plant::BevPlant(*p).signals());
  } else if (const auto* q = std::get_if<ehpt::plant::PsdParams>(&sc.plant)) {
    print_signals(ehpt::plant::PsdPlant(*q).signals());
  } else {
    print_signals(ehpt::plant::DriveRig(std::get<ehpt::plant::DriveRigParams>(sc.plant)).signals());
  }
  return 0;
}

int cmd_plot(const std::vector<std::string>& args) {
  if (wants_help(args) || args.size() != 1) {
    std::cout << kPlotHelp;
    return args.size() == 1 ? 0 : 1;
  }
  return plot(args[0], false);
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty()) {
    std::cerr << kMainHelp;
    return 1;
  }
  const std::string cmd = args[0];
  args.erase(args.begin());
  if (cmd == "--help" || cmd == "-h" || cmd == "help") {
    std::cout << kMainHelp;
    return 0;
  }
  if (cmd == "run") return cmd_run(args);
  if (cmd == "list") return cmd_list(args);
  if (cmd == "signals") return cmd_signals(args);
  if (cmd == "plot") return cmd_plot(args);
  std::cerr << "unknown command '" << cmd << "'\n\n" << kMainHelp;
  return 1;
}
