// SPDX-License-Identifier: BSD-3-Clause
// pm_drive_test, am_drive_test: TestPMDrive / TestAMDrive, the quasi-static drives next to
// their time-domain references (MODELS.md §9, §11.6; plant/machine_test_rigs.hpp).
#include "hil/kinds/kind.hpp"

#include "plant/machine_test_rigs.hpp"

namespace ehpt::hil::kinds {

namespace {

// A trapezoid whose levels carry a unit suffix: [speed] offset_rad_s ..., [request] offset_Nm ...

KindRead read_pm_test(Reader& vr, const KindInput& in, Scenario& out, Problems& problems, Problems&, Context& ctx) {
  no_cycle(in, "a machine test rig", ctx);
  plant::PmDriveTestParams p;
  p.u_dc_V = vr.number("u_dc_V", p.u_dc_V);
  p.current_filter_s = vr.number("current_filter_s", p.current_filter_s);
  p.machine = read_pm_drive(vr.sub("machine"));
  p.speed_rad_s = read_trapezoid(vr.sub("speed"), "rad_s");
  p.request_Nm = read_trapezoid(vr.sub("request"), "Nm");
  vr.finish();
  plant::validate(p, problems);
  check_signals(plant::PmDriveTest::kSignals, out.output.signals, ctx);
  check_test_targets_of(plant::PmDriveTest::kSignals, out, ctx);
  out.plant = std::move(p);
  return {};
}

KindRead read_am_test(Reader& vr, const KindInput& in, Scenario& out, Problems& problems, Problems&, Context& ctx) {
  no_cycle(in, "a machine test rig", ctx);
  plant::AmDriveTestParams p;
  p.machine = read_am_drive(vr.sub("machine"));
  p.speed_rad_s = read_trapezoid(vr.sub("speed"), "rad_s");
  p.request_Nm = read_trapezoid(vr.sub("request"), "Nm");
  vr.finish();
  plant::validate(p, problems);
  check_signals(plant::AmDriveTest::kSignals, out.output.signals, ctx);
  check_test_targets_of(plant::AmDriveTest::kSignals, out, ctx);
  out.plant = std::move(p);
  return {};
}

}  // namespace

// pm_drive_test: TestPMDrive (SmaAllSpeeds-like), PMDrive vs a current-fed time-domain PMSM
extern const VehicleKind kind_pm_drive_test{
    "pm_drive_test", &typeid(plant::PmDriveTestParams), read_pm_test,
    [](const Scenario& sc, const SimulationOptions& opt) {
      return simulate(sc, opt,
                      std::make_unique<plant::PmDriveTest>(sc.plant.get<plant::PmDriveTestParams>()),
                      std::unique_ptr<NoController>());
    },
    [](const Scenario& sc) {
      return signals_of(plant::PmDriveTest(sc.plant.get<plant::PmDriveTestParams>()));
    }};

// am_drive_test: TestAMDrive, AMDrive vs a U/f-fed time-domain squirrel-cage machine
extern const VehicleKind kind_am_drive_test{
    "am_drive_test", &typeid(plant::AmDriveTestParams), read_am_test,
    [](const Scenario& sc, const SimulationOptions& opt) {
      return simulate(sc, opt,
                      std::make_unique<plant::AmDriveTest>(sc.plant.get<plant::AmDriveTestParams>()),
                      std::unique_ptr<NoController>());
    },
    [](const Scenario& sc) {
      return signals_of(plant::AmDriveTest(sc.plant.get<plant::AmDriveTestParams>()));
    }};

}  // namespace ehpt::hil::kinds
