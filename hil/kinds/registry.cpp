// SPDX-License-Identifier: BSD-3-Clause
// The vehicle kinds as one table (all_kinds(), generated from the build lines
// ehpt_kind_file(...) in CMakeLists.txt; each kind is defined in hil/kinds/<file>.cpp). This is
// the only place that maps a vehicle file's `kind` and a scenario's parameters to a kind;
// load_scenario, the CLI and the batch runner go through it. A new kind is one file in
// hil/kinds/ and its build line.
#include <stdexcept>
#include <string>

#include "hil/config/scenario.hpp"
#include "hil/kinds/kind.hpp"

namespace ehpt::hil {

namespace {

using kinds::VehicleKind;

const VehicleKind& kind_of(const Scenario& sc) {
  for (const VehicleKind* k : kinds::all_kinds()) {
    if (sc.plant.type() == *k->params) return *k;
  }
  // only a Scenario that load_scenario did not fill (a caller's bug): say which
  throw std::logic_error("scenario '" + sc.name + "' holds no vehicle of a known kind (kind \"" + sc.kind + "\")");
}

}  // namespace

std::unique_ptr<Simulation> make_simulation(const Scenario& sc, const SimulationOptions& options) {
  return kind_of(sc).make(sc, options);
}

std::unique_ptr<Simulation> load_simulation(const std::string& scenario, const std::vector<std::string>& overrides,
                                            const SimulationOptions& options, std::vector<std::string>& errors) {
  std::string reason;
  const std::string path = resolve_scenario(scenario, reason);
  if (path.empty()) {
    errors.push_back(scenario + ": " + reason);
    return nullptr;
  }
  Scenario sc;
  std::vector<std::string> problems;
  if (!load_scenario(path, overrides, sc, problems)) {
    errors.insert(errors.end(), problems.begin(), problems.end());
    return nullptr;
  }
  return make_simulation(sc, options);
}

std::vector<SignalInfo> scenario_signals(const Scenario& sc) { return kind_of(sc).signals(sc); }

namespace detail {

ReadKind find_kind_reader(std::string_view name) {
  for (const VehicleKind* k : kinds::all_kinds()) {
    if (k->name == name) return k->read;
  }
  return nullptr;
}

std::string kind_names() {
  std::string names;
  const auto kinds = kinds::all_kinds();
  const std::size_t n = kinds.size();
  for (std::size_t i = 0; i < n; ++i) {
    names += (i == 0 ? "" : i + 1 == n ? " or " : ", ") + ("\"" + std::string(kinds[i]->name) + "\"");
  }
  return names;
}

}  // namespace detail

}  // namespace ehpt::hil
