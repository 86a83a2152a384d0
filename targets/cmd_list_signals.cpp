// SPDX-License-Identifier: BSD-3-Clause
// `ehpt list` (the scenarios) and `ehpt signals` (a scenario's output columns).
#include <algorithm>
#include <iostream>

#include "ecu/ev_follower.hpp"
#include "ecu/psd_ecu.hpp"
#include "ecu/shev_ems.hpp"
#include "hil/bus/bus_binding.hpp"
#include "hil/bus/bus_plant.hpp"
#include "hil/config/scenario.hpp"
#include "msgs/fields.hpp"
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
    "usage: ehpt signals SCENARIO [--fault-targets [--bus-map FILE]]\n"
    "Lists the columns timeseries.csv can hold for the scenario's vehicle (choose them with\n"
    "[output] signals = [...] in the scenario). Units are the name's suffix. These are what an\n"
    "[[expect]] bounds (docs/testing.md).\n"
    "  --fault-targets  the fields of the vehicle's sensor and command messages instead (the\n"
    "                   DBC's signal names): what a [[fault]]'s target names; and the bus\n"
    "                   messages a bus fault's target names (drop, delay, corrupt, ...: ehpt's\n"
    "                   own contract, or with --bus-map FILE that binding's DBC messages)\n";

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

int cmd_signals(const std::vector<std::string>& args_in) {
  std::vector<std::string> args = args_in;
  const auto flag = std::find(args.begin(), args.end(), "--fault-targets");
  const bool targets = flag != args.end();
  if (targets) args.erase(flag);
  std::string bus_map;
  if (const auto m = std::find(args.begin(), args.end(), "--bus-map"); targets && m != args.end()) {
    if (m + 1 == args.end()) {
      std::cerr << "--bus-map needs a binding file (docs/bus.md)\n";
      return 2;
    }
    bus_map = *(m + 1);
    args.erase(m, m + 2);
  }
  if (wants_help(args) || args.size() != 1) {
    if (args.size() != 1) {
      std::cerr << kSignalsHelp;
      return 1;
    }
    return out(kSignalsHelp) ? 0 : 1;
  }
  ehpt::hil::Scenario sc;
  if (const int rc = load(args[0], {}, sc); rc != 0) return rc;
  if (!targets) return out(signal_lines(ehpt::hil::scenario_signals(sc))) ? 0 : 1;
  std::string text;
  const auto fields = [&](const char* title, const auto& table) {
    text += std::string(title) + "\n";
    for (const auto& f : table) {
      if (f.name == "fault" || f.name == "locked") continue;  // status bits: not a value to fault
      const char* kind = f.kind == ehpt::msgs::FieldKind::kFraction ? "fraction"
                         : f.kind == ehpt::msgs::FieldKind::kFlag   ? "flag (0 or 1)"
                                                                    : "";
      text += "  " + std::string(f.name) + std::string(f.name.size() < 22 ? 22 - f.name.size() : 1, ' ') +
              (f.unit.empty() ? std::string(kind) : std::string(f.unit)) + "\n";
    }
  };
  if (sc.ecu.holds<ehpt::ecu::PsdEcuParams>()) {
    fields("sensor message (the plant to its ECU; a sensor fault's target)", ehpt::msgs::kPsdSensorFieldTable);
    fields("command message (the ECU to the plant; a command fault's target)", ehpt::msgs::kPsdCommandFieldTable);
  } else if (sc.ecu.holds<ehpt::ecu::EvFollowerParams>()) {
    fields("sensor message (the plant to its ECU; a sensor fault's target)", ehpt::msgs::kEvSensorFieldTable);
    fields("command message (the ECU to the plant; a command fault's target)", ehpt::msgs::kEvCommandFieldTable);
  } else if (sc.ecu.holds<ehpt::ecu::ShevEmsParams>()) {
    fields("sensor message (the plant to its ECU; a sensor fault's target)", ehpt::msgs::kShevSensorFieldTable);
    fields("command message (the ECU to the plant; a command fault's target)", ehpt::msgs::kShevCommandFieldTable);
  } else {
    std::cerr << args[0] << ": this vehicle has no ECU messages (a rig): nothing to fault\n";
    return 2;
  }
  // the frames a bus fault acts on: the bound contract's messages (hil/bus/bus_faults.hpp)
  std::vector<std::string> errors;
  const std::string family = ehpt::hil::bus_family(sc);
  const std::optional<ehpt::hil::Binding> binding =
      bus_map.empty() ? ehpt::hil::default_binding(family, sc.ecu_timing.period_s, errors)
                      : ehpt::hil::load_binding(bus_map, family, sc.ecu_timing.period_s, errors);
  if (!binding) {
    for (const std::string& e : errors) std::cerr << e << "\n";
    return 2;
  }
  const auto messages = [&](const char* title, const std::vector<ehpt::hil::BoundMessage>& list) {
    text += std::string(title) + "\n";
    for (const ehpt::hil::BoundMessage& m : list) {
      bool counter = false;
      for (const auto& b : m.signals) counter = counter || b.role == ehpt::hil::BoundRole::kCounter;
      const std::string& name = m.message->name;
      text += "    " + name + std::string(name.size() < 20 ? 20 - name.size() : 1, ' ') +
              std::to_string(m.message->size_bytes) + " bytes" + (counter ? ", counter" : "") + (m.e2e ? ", E2E" : "") + "\n";
    }
  };
  text += "bus (" + binding->file + "; a bus fault's target; \"bus\" for bus_off)\n";
  messages("  sent by the plant", binding->send);
  messages("  sent by the ECU", binding->receive);
  return out(text) ? 0 : 1;
}

}  // namespace ehpt::cli
