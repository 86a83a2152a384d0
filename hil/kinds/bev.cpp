// SPDX-License-Identifier: BSD-3-Clause
// bev: the map-based EV (MODELS.md §10.3) with its built-in ECU, the driver-follower.
#include "hil/kinds/kind.hpp"

#include "ecu/ev_follower.hpp"
#include "plant/bev_plant.hpp"

namespace ehpt::hil::kinds {

namespace {

plant::BevParams read_bev(Reader& root, const FileRef& cycle, bool periodic, Context& ctx) {
  plant::BevParams p;
  p.body = read_body(root.sub("vehicle"));
  p.road = read_road(root.sub("road"), ctx);
  p.drive = read_drive(root.sub("drive"), ctx);
  p.battery = read_battery(root.sub("battery"));
  p.driver = read_driver(root.sub("driver"));
  p.brake = read_brake(root.sub("brake"));
  if (!cycle.empty()) p.driver.cycle_m_s = load_cycle(cycle, "driver.cycle", periodic, ctx);
  return p;
}

KindRead read_bev_kind(Reader& vr, const KindInput& in, Scenario& out, Problems& problems, Problems& warnings,
                       Context& ctx) {
  need_cycle(in, ctx);
  plant::BevParams p = read_bev(vr, in.cycle, in.cycle_periodic, ctx);
  read_follower_ecu(vr.sub("ecu"), out.ecu_timing, ctx);
  vr.finish();
  out.ecu = ecu::EvFollowerParams{};
  plant::validate(p, problems);
  if (problems.empty()) plant::warn(p.drive, "drive", warnings);
  check_signals(plant::BevPlant::kSignals, out.output.signals, ctx);
  check_test_targets_of(plant::BevPlant::kSignals, msgs::kEvSensorFieldTable, msgs::kEvCommandFieldTable,
                        plant_fault_targets<plant::BevPlant>(p.battery), out, ctx);
  KindRead r{cycle_length(p.driver), false, true};
  out.plant = std::move(p);
  return r;
}

}  // namespace

// bev: the map-based EV with its driver-follower ECU
extern const VehicleKind kind_bev{
    "bev", &typeid(plant::BevParams), read_bev_kind,
    [](const Scenario& sc, const SimulationOptions& opt) {
      return simulate(sc, opt, std::make_unique<plant::BevPlant>(sc.plant.get<plant::BevParams>()),
                      std::make_unique<ecu::EvFollower>());
    },
    [](const Scenario& sc) { return signals_of(plant::BevPlant(sc.plant.get<plant::BevParams>())); }};


}  // namespace ehpt::hil::kinds
