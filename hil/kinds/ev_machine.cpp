// SPDX-License-Identifier: BSD-3-Clause
// ev_pm, ev_am: the EVs with machine-physics drives (MODELS.md §10.1, §10.2) and the EV's
// built-in ECU, the driver-follower. The same messages as the map-based EV, so they run with
// the follower, over CAN and over LCM alike.
#include "hil/kinds/kind.hpp"

#include <algorithm>
#include <cmath>

#include "ecu/ev_follower.hpp"
#include "plant/ev_machine_plant.hpp"

namespace ehpt::hil::kinds {

namespace {

template <class Drive, class ReadDrive>
KindRead read_machine_ev(Reader& vr, const KindInput& in, Scenario& out, Problems& problems, Problems& warnings,
                         Context& ctx, ReadDrive read_machine) {
  need_cycle(in, ctx);
  plant::EvMachineParams<Drive> p;
  p.body = read_body(vr.sub("vehicle"));
  p.road = read_road(vr.sub("road"), ctx);
  p.drive = read_machine(vr.sub("drive"), ctx);
  p.battery = read_battery(vr.sub("battery"));
  p.driver = read_driver(vr.sub("driver"));
  p.brake = read_brake(vr.sub("brake"));
  if (!in.cycle.empty()) p.driver.cycle_m_s = load_cycle(in.cycle, "driver.cycle", in.cycle_periodic, ctx);
  read_follower_ecu(vr.sub("ecu"), out.ecu_timing, ctx);
  vr.finish();
  out.ecu = ecu::EvFollowerParams{};
  plant::validate(p, problems);
  if constexpr (requires { p.drive.speed_max_rad_s; }) {
    if (problems.empty() && !p.driver.cycle_m_s.empty()) {
      // a cycle faster than the drive is rated for runs, but not as the cycle says
      double top_m_s = 0.0;
      for (const double v : p.driver.cycle_m_s.y()) top_m_s = std::max(top_m_s, std::abs(v));
      const double top_rad_s = top_m_s * p.body.gear_ratio / p.body.wheel_radius_m;
      if (top_rad_s > p.drive.speed_max_rad_s) {
        warnings.add("drive.speed_max_rad_s", plant::number_text(p.drive.speed_max_rad_s),
                     "the cycle's top speed (" + plant::number_text(top_m_s) + " m/s) turns the rotor at " +
                         plant::number_text(top_rad_s) + " rad/s: above the rating the drive cannot hold its torque");
      }
    }
  }
  check_signals(plant::EvMachinePlant<Drive>::kSignals, out.output.signals, ctx);
  check_test_targets_of(plant::EvMachinePlant<Drive>::kSignals, msgs::kEvSensorFieldTable, msgs::kEvCommandFieldTable,
                        plant_fault_targets<plant::EvMachinePlant<Drive>>(p.battery), out, ctx);
  KindRead r{cycle_length(p.driver), false, true};
  out.plant = std::move(p);
  return r;
}

template <class Drive>
std::unique_ptr<Simulation> make_machine_ev(const Scenario& sc, const SimulationOptions& opt) {
  using P = plant::EvMachinePlant<Drive>;
  return simulate(sc, opt, std::make_unique<const P>(sc.plant.get<typename P::Params>()),
                  std::make_unique<ecu::EvFollower>());
}

template <class Drive>
std::vector<SignalInfo> machine_ev_signals(const Scenario& sc) {
  using P = plant::EvMachinePlant<Drive>;
  return signals_of(P(sc.plant.get<typename P::Params>()));
}

// [drive] of an ev_am vehicle: the machine in SI units (AMDrive), or with per_unit = true in
// p.u. of S_nom (AMDrivePU, base in plant/am_drive.hpp), checked in its own fields and then
// converted to SI.
plant::AmDriveParams read_am_drive_any(Reader r, Problems& problems, bool& per_unit) {
  per_unit = r.flag("per_unit", false);
  if (!per_unit) return read_am_drive(r);
  plant::AmDrivePuParams pu;
  pu.S_nom_VA = r.required_number("S_nom_VA");
  pu.V_nom_rms_V = r.required_number("V_nom_rms_V");
  pu.f_nom_Hz = r.required_number("f_nom_Hz");
  pu.pole_pairs = r.small_integer("pole_pairs", pu.pole_pairs, 1, 100);
  pu.r1_pu = r.required_number("r1_pu");
  pu.r2_pu = r.required_number("r2_pu");
  pu.x1_pu = r.required_number("x1_pu");
  pu.x2_pu = r.required_number("x2_pu");
  pu.xm_pu = r.required_number("xm_pu");
  pu.H_s = r.required_number("H_s");
  pu.I_max_pu = r.required_number("I_max_pu");
  pu.k_inv_pu = r.number("k_inv_pu", pu.k_inv_pu);
  r.finish();
  const std::size_t before = problems.size();
  plant::validate(pu, "drive", problems);
  return problems.size() == before ? plant::am_params_from_pu(pu) : plant::AmDriveParams{};
}

}  // namespace

// ev_am: EvAm_bat, the EV with AMDrive (U/f, slip from the torque request, slip limiter)
extern const VehicleKind kind_ev_am{
    "ev_am", &typeid(plant::EvAmParams),
    [](Reader& vr, const KindInput& in, Scenario& out, Problems& problems, Problems& warnings, Context& ctx) {
      bool per_unit = false;
      Problems found;
      const KindRead read = read_machine_ev<plant::AmMachine>(
          vr, in, out, found, warnings, ctx, [&](Reader r, Context&) { return read_am_drive_any(r, found, per_unit); });
      // a p.u. file sets the U/f base voltage as V_nom_rms_V: name the field the file has
      for (const plant::Problem& f : found.list()) {
        const std::string field = per_unit && f.field == "drive.U_base_rms_V" ? "drive.V_nom_rms_V" : f.field;
        if (f.row >= 0) {
          problems.add_cell(field, static_cast<std::size_t>(f.row), f.column, f.value, f.expected);
        } else {
          problems.add(field, f.value, f.expected);
        }
      }
      return read;
    },
    make_machine_ev<plant::AmMachine>, machine_ev_signals<plant::AmMachine>};

// ev_pm: EvPm_bat, the EV with PMDrive (MTPA, flux weakening, current limit)
extern const VehicleKind kind_ev_pm{
    "ev_pm", &typeid(plant::EvPmParams),
    [](Reader& vr, const KindInput& in, Scenario& out, Problems& problems, Problems& warnings, Context& ctx) {
      return read_machine_ev<plant::PmMachine>(vr, in, out, problems, warnings, ctx,
                                               [](Reader r, Context&) { return read_pm_drive(r); });
    },
    make_machine_ev<plant::PmMachine>, machine_ev_signals<plant::PmMachine>};

}  // namespace ehpt::hil::kinds
