// SPDX-License-Identifier: BSD-3-Clause
// `ehpt list` (the scenarios) and `ehpt signals` (a scenario's output columns).
#include <algorithm>
#include <iostream>

#include "hil/config/scenario.hpp"
#include "hil/run/simulation.hpp"
#include "targets/cli.hpp"

namespace ehpt::cli {

namespace {

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

// The help ends with where this ehpt looks (build folder or installed).
std::string list_help() {
  const std::string dir = ehpt::hil::scenarios_dir();
  return std::string(kListHelp) + "This ehpt: " +
         (dir.empty() ? "no scenarios folder found (looked in " + ehpt::hil::scenarios_search_text() + ")"
                      : (dir == "scenarios" ? "./scenarios" : dir)) +
         "\n";
}

std::string signal_lines(const std::vector<ehpt::hil::SignalInfo>& signals) {
  std::string text;
  for (const auto& s : signals) {
    text += std::string(s.name) + std::string(s.name.size() < 24 ? 24 - s.name.size() : 1, ' ') +
            std::string(s.meaning) + "\n";
  }
  return text;
}

}  // namespace

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

}  // namespace ehpt::cli
