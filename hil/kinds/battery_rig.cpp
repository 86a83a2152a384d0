// SPDX-License-Identifier: BSD-3-Clause
// battery_rig: Batt1 (MODELS.md §6) on a current / power profile.
#include "hil/kinds/kind.hpp"

#include "plant/battery_rig.hpp"

namespace ehpt::hil::kinds {

namespace {

plant::BatteryRigParams read_battery_rig(Reader& root, Context& ctx) {
  plant::BatteryRigParams p;
  p.battery = read_battery(root.sub("battery"));
  for (Reader& r : root.table_array("profile")) {
    plant::BatterySegment s;
    const bool current = r.has("current_A"), power = r.has("power_W");
    if (current == power) {
      ctx.error(r.where(), r.name(), "", "give either current_A or power_W (> 0 discharge, < 0 charge)");
    }
    s.kind = power ? plant::BatterySegment::Kind::kPower : plant::BatterySegment::Kind::kCurrent;
    s.value = power ? r.number("power_W", 0.0) : r.number("current_A", 0.0);
    if (current && power) r.find("current_A");  // reported above, not also unknown
    s.duration_s = r.required_number("duration_s");
    r.finish();
    p.profile.push_back(s);
  }
  return p;
}


KindRead read_battery_rig_kind(Reader& vr, const KindInput& in, Scenario& out, Problems& problems, Problems&,
                               Context& ctx) {
  no_cycle(in, "a battery rig", ctx);
  plant::BatteryRigParams p = read_battery_rig(vr, ctx);
  vr.finish();
  plant::validate(p, problems);
  KindRead r;
  if (problems.empty()) {
    double end_s = 0.0;
    for (const plant::BatterySegment& seg : p.profile) end_s += seg.duration_s;
    r.length_s = end_s;
  } else {
    r.length_unknown = true;  // the profile's problem was reported: its length is unknown
  }
  check_signals(plant::BatteryRig::kSignals, out.output.signals, ctx);
  check_test_targets_of(plant::BatteryRig::kSignals, out, ctx);
  out.plant = std::move(p);
  return r;
}

}  // namespace

// battery_rig: Batt1 on a current / power profile
extern const VehicleKind kind_battery_rig{
    "battery_rig", &typeid(plant::BatteryRigParams), read_battery_rig_kind,
    [](const Scenario& sc, const SimulationOptions& opt) {
      return simulate(sc, opt,
                      std::make_unique<plant::BatteryRig>(sc.plant.get<plant::BatteryRigParams>()),
                      std::unique_ptr<NoController>());
    },
    [](const Scenario& sc) { return signals_of(plant::BatteryRig(sc.plant.get<plant::BatteryRigParams>())); }};


}  // namespace ehpt::hil::kinds
