// SPDX-License-Identifier: BSD-3-Clause
// The table of vehicle kinds: one entry each, defined in hil/kinds/<kind>.cpp
// {name, reader, factory, signals}. This is the only place that maps a vehicle file's `kind`
// and a scenario's parameters to C++ types; load_scenario, the CLI and the batch runner go
// through it. A new kind is one file in hil/kinds/ and one line here.
#include <string>

#include "hil/kinds/kind.hpp"
#include "hil/config/scenario.hpp"
#include "plant/battery_rig.hpp"
#include "plant/bev_plant.hpp"
#include "plant/drive_rigs.hpp"
#include "plant/ev_machine_plant.hpp"
#include "plant/machine_test_rigs.hpp"
#include "plant/psd_plant.hpp"

namespace ehpt::hil {

namespace {

using kinds::VehicleKind;

const VehicleKind* const kKinds[] = {&kinds::kBev, &kinds::kPsd, &kinds::kDriveRig, &kinds::kBatteryRig,
                                     &kinds::kEvPm, &kinds::kEvAm, &kinds::kPmDriveTest, &kinds::kAmDriveTest};

const VehicleKind& kind_of(const Scenario& sc) {
  struct Pick {
    const VehicleKind& operator()(const plant::BevParams&) const { return kinds::kBev; }
    const VehicleKind& operator()(const plant::PsdParams&) const { return kinds::kPsd; }
    const VehicleKind& operator()(const plant::DriveRigParams&) const { return kinds::kDriveRig; }
    const VehicleKind& operator()(const plant::BatteryRigParams&) const { return kinds::kBatteryRig; }
    const VehicleKind& operator()(const plant::EvPmParams&) const { return kinds::kEvPm; }
    const VehicleKind& operator()(const plant::EvAmParams&) const { return kinds::kEvAm; }
    const VehicleKind& operator()(const plant::PmDriveTestParams&) const { return kinds::kPmDriveTest; }
    const VehicleKind& operator()(const plant::AmDriveTestParams&) const { return kinds::kAmDriveTest; }
  };
  return std::visit(Pick{}, sc.plant);
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
  for (const VehicleKind* k : kKinds) {
    if (k->name == name) return k->read;
  }
  return nullptr;
}

std::string kind_names() {
  std::string names;
  const std::size_t n = std::size(kKinds);
  for (std::size_t i = 0; i < n; ++i) {
    names += (i == 0 ? "" : i + 1 == n ? " or " : ", ") + ("\"" + std::string(kKinds[i]->name) + "\"");
  }
  return names;
}

}  // namespace detail

}  // namespace ehpt::hil
