// SPDX-License-Identifier: BSD-3-Clause
// drive_rig: TestMBOneFlange / TestTwoFlange (MODELS.md §11.1, §11.3).
#include "hil/kinds/kind.hpp"

#include "plant/drive_rigs.hpp"

namespace ehpt::hil::kinds {

namespace {

plant::DriveRigParams read_rig(Reader& root, Context& ctx) {
  plant::DriveRigParams p;
  const std::int64_t flanges = root.integer("flanges", 1);
  if (flanges != 1 && flanges != 2) {
    ctx.error(ctx.where["flanges"], "flanges", std::to_string(flanges), "must be 1 or 2");
  }
  p.two_flange = flanges == 2;
  p.dc_voltage_V = root.number("dc_voltage_V", p.dc_voltage_V);
  p.drive = read_drive(root.sub("drive"), ctx);
  {
    Reader r = root.sub("load");
    p.load_inertia_kgm2 = r.number("inertia_kgm2", p.load_inertia_kgm2);
    p.speed_initial_rad_s = r.number("speed_initial_rad_s", p.speed_initial_rad_s);
    p.load_torque_nominal_Nm = r.number("torque_nominal_Nm", p.load_torque_nominal_Nm);
    p.load_speed_nominal_rad_s = r.number("speed_nominal_rad_s", p.load_speed_nominal_rad_s);
    p.flange_a_torque_Nm = r.number("flange_a_torque_Nm", p.flange_a_torque_Nm);
    r.finish();
  }
  p.request_Nm = read_trapezoid(root.sub("request"), "Nm");
  return p;
}

KindRead read_drive_rig_kind(Reader& vr, const KindInput& in, Scenario& out, Problems& problems, Problems& warnings,
                             Context& ctx) {
  no_cycle(in, "a drive rig", ctx);
  plant::DriveRigParams p = read_rig(vr, ctx);
  vr.finish();
  plant::validate(p, problems);
  if (problems.empty()) plant::warn(p.drive, "drive", warnings);
  check_signals(plant::DriveRig(p).signals(), out.output.signals, ctx);
  check_test_targets_of(plant::DriveRig(p).signals(), out, ctx);
  out.plant = std::move(p);
  return {};
}

}  // namespace

// drive_rig: TestMBOneFlange / TestTwoFlange
extern const VehicleKind kind_drive_rig{
    "drive_rig", &typeid(plant::DriveRigParams), read_drive_rig_kind,
    [](const Scenario& sc, const SimulationOptions& opt) {
      return simulate(sc, opt, std::make_unique<plant::DriveRig>(sc.plant.get<plant::DriveRigParams>()),
                      std::unique_ptr<NoController>());
    },
    [](const Scenario& sc) { return signals_of(plant::DriveRig(sc.plant.get<plant::DriveRigParams>())); }};


}  // namespace ehpt::hil::kinds
