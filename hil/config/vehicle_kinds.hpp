// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Reading a vehicle file, kind by kind (start-up only; hil/kinds/registry.cpp holds the readers
// with the kinds' factories). load_scenario reads the scenario, finds the kind named by the
// vehicle file's `kind` and lets it read its tables into the Scenario.

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "hil/config/config.hpp"
#include "hil/config/config_reader.hpp"

namespace ehpt::hil::detail {

struct KindInput {
  const FileRef& cycle;           // the scenario's cycle (empty: none)
  bool cycle_periodic = false;
  const std::string& scenario_path;
};

struct KindRead {
  std::optional<double> length_s;  // the cycle's or the profile's length: the default duration
  bool length_unknown = false;     // its table or profile has a problem, reported already
  bool has_ecu = false;            // a built-in ECU: its period and latency are checked
  // where the ECU's parameters keep its period, once the timing is checked (nullptr: nowhere)
  void (*set_ecu_period)(Scenario& out, double period_s) = nullptr;
};

// Reads the kind's tables from the vehicle reader into out (plant and ECU parameters, ECU
// timing), validates them into problems and warnings. Returns what load_scenario needs.
using ReadKind = KindRead (*)(Reader& vehicle, const KindInput& in, Scenario& out, Problems& problems,
                              Problems& warnings, Context& ctx);

// The reader of a kind, nullptr if there is none of that name; and all names, for a message.
ReadKind find_kind_reader(std::string_view name);
std::string kind_names();

}  // namespace ehpt::hil::detail
