// SPDX-License-Identifier: BSD-3-Clause
#include "hil/config/config_components.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <string_view>

namespace ehpt::hil::detail {

namespace {

// Plausibility bands (docs/scenarios.md, "Plausibility warnings"): a value outside is most
// likely a unit or a typo and gets a warning, never an error. Wide enough for a scooter to a
// truck; every shipped vehicle is well inside (tests/hil/config_test.cpp checks both).
struct Band {
  double lo, hi;
};
constexpr Band kMassBand{50.0, 60000.0};             // kg: a light quadricycle .. a 60 t truck
constexpr Band kWheelRadiusBand{0.1, 1.5};           // m
constexpr Band kGearRatioBand{0.2, 50.0};            // final drive, machine / wheel speed
constexpr Band kCellCapacityBand{0.1, 1000.0};       // Ah of one cell
constexpr Band kCellResistanceBand{1e-5, 1.0};       // Ohm of one cell
constexpr Band kCellCapacitanceBand{1.0, 1e7};       // F of one cell's RC branch
constexpr Band kCellsSeriesBand{1.0, 1000.0};        // cells in series (a 1000 V pack of 1.2 V cells: 833)
constexpr Band kStringsParallelBand{1.0, 1000.0};    // strings in parallel
constexpr Band kFrontalAreaBand{0.3, 15.0};          // m^2
constexpr Band kDragCoefficientBand{0.1, 1.5};
constexpr Band kRollingCoefficientBand{0.001, 0.05};
constexpr Band kDriveTorqueBand{1.0, 20000.0};       // N m, a drive's (or an engine's) peak torque
constexpr Band kDrivePowerBand{500.0, 2e6};          // W, a drive's peak power
constexpr Band kDriveSpeedBand{10.0, 5000.0};        // rad/s, a drive's top speed (48 000 rpm)
constexpr Band kRotorInertiaBand{1e-4, 50.0};        // kg m^2
constexpr Band kMachineVoltageBand{5.0, 2000.0};     // V rms, a machine's rated voltage
constexpr Band kMachineCurrentBand{1.0, 5000.0};     // A rms, a machine's current limit

void plausible_drive_rating(Reader& r, double torque_Nm, double power_W, double speed_rad_s) {
  r.plausible("torque_max_Nm", torque_Nm, kDriveTorqueBand.lo, kDriveTorqueBand.hi, "N m", "a drive's peak torque");
  r.plausible("power_max_W", power_W, kDrivePowerBand.lo, kDrivePowerBand.hi, "W", "a drive's peak power");
  r.plausible("speed_max_rad_s", speed_rad_s, kDriveSpeedBand.lo, kDriveSpeedBand.hi, "rad/s", "a drive's top speed");
}

}  // namespace

plant::MapDriveParams read_drive(Reader r, Context& ctx) {
  plant::MapDriveParams p;
  p.torque_max_Nm = r.required_number("torque_max_Nm");
  p.power_max_W = r.required_number("power_max_W");
  p.speed_max_rad_s = r.required_number("speed_max_rad_s");
  p.inertia_kgm2 = r.required_number("inertia_kgm2");
  p.limit_ramp_fraction = r.number("limit_ramp_fraction", p.limit_ramp_fraction);
  const std::string model = r.text("loss_model", "ideal");
  if (model == "ideal") {
    p.loss_model = plant::DriveLossModel::kIdeal;
  } else if (model == "map") {
    p.loss_model = plant::DriveLossModel::kMap;
    const FileRef map = r.path("efficiency_map", true);
    if (!map.empty()) p.efficiency_map = load_map(map, r.field("efficiency_map"), ctx);
  } else if (model == "constant") {
    p.loss_model = plant::DriveLossModel::kConstant;
    p.efficiency = r.required_number("efficiency");
  } else if (model == "formula") {
    p.loss_model = plant::DriveLossModel::kFormula;
    Reader f = r.sub("loss_formula");
    p.loss_formula.a = f.number("a", p.loss_formula.a);
    p.loss_formula.b_t = f.number("b_t", p.loss_formula.b_t);
    p.loss_formula.b_w = f.number("b_w", p.loss_formula.b_w);
    p.loss_formula.b_p = f.number("b_p", p.loss_formula.b_p);
    f.finish();
  } else {
    ctx.error(ctx.where[r.field("loss_model")], r.field("loss_model"), "\"" + model + "\"",
              "must be \"ideal\", \"map\", \"formula\" or \"constant\"");
  }
  if (model != "map" && r.has("efficiency_map")) r.path("efficiency_map", false);  // allowed, unused
  if (model != "formula" && r.has("loss_formula")) r.sub("loss_formula");
  if (model != "constant" && r.has("efficiency")) r.number("efficiency", 0.0);  // allowed, unused (as efficiency_map)
  plausible_drive_rating(r, p.torque_max_Nm, p.power_max_W, p.speed_max_rad_s);
  r.plausible("inertia_kgm2", p.inertia_kgm2, kRotorInertiaBand.lo, kRotorInertiaBand.hi, "kg m^2", "a rotor's inertia");
  r.finish();
  return p;
}

plant::PmDriveParams read_pm_drive(Reader r) {
  plant::PmDriveParams p;
  p.pole_pairs = r.small_integer("pole_pairs", p.pole_pairs, 1, 100);
  p.psi_pm_Wb = r.required_number("psi_pm_Wb");
  p.Ld_H = r.required_number("Ld_H");
  p.Lq_H = r.required_number("Lq_H");
  p.Rs_Ohm = r.required_number("Rs_Ohm");
  p.U_max_rms_V = r.required_number("U_max_rms_V");
  p.I_lim_rms_A = r.required_number("I_lim_rms_A");
  p.k_inv_W_per_A = r.number("k_inv_W_per_A", p.k_inv_W_per_A);
  p.inertia_kgm2 = r.required_number("inertia_kgm2");
  p.speed_max_rad_s = r.required_number("speed_max_rad_s");
  r.plausible("U_max_rms_V", p.U_max_rms_V, kMachineVoltageBand.lo, kMachineVoltageBand.hi, "V rms",
              "a machine's rated voltage");
  r.plausible("I_lim_rms_A", p.I_lim_rms_A, kMachineCurrentBand.lo, kMachineCurrentBand.hi, "A rms",
              "a machine's current limit");
  r.plausible("speed_max_rad_s", p.speed_max_rad_s, kDriveSpeedBand.lo, kDriveSpeedBand.hi, "rad/s",
              "a drive's top speed");
  r.plausible("inertia_kgm2", p.inertia_kgm2, kRotorInertiaBand.lo, kRotorInertiaBand.hi, "kg m^2", "a rotor's inertia");
  r.finish();
  return p;
}

plant::AmDriveParams read_am_drive(Reader r) {
  plant::AmDriveParams p;
  p.pole_pairs = r.small_integer("pole_pairs", p.pole_pairs, 1, 100);
  p.R1_Ohm = r.required_number("R1_Ohm");
  p.R2_Ohm = r.required_number("R2_Ohm");
  p.L1_H = r.required_number("L1_H");
  p.L2_H = r.required_number("L2_H");
  p.Lm_H = r.required_number("Lm_H");
  p.inertia_kgm2 = r.required_number("inertia_kgm2");
  p.U_base_rms_V = r.required_number("U_base_rms_V");
  p.w_e_base_rad_s = r.required_number("w_e_base_rad_s");
  p.I_max_rms_A = r.required_number("I_max_rms_A");
  p.k_inv_W_per_A = r.number("k_inv_W_per_A", p.k_inv_W_per_A);
  r.plausible("U_base_rms_V", p.U_base_rms_V, kMachineVoltageBand.lo, kMachineVoltageBand.hi, "V rms",
              "a machine's rated voltage");
  r.plausible("I_max_rms_A", p.I_max_rms_A, kMachineCurrentBand.lo, kMachineCurrentBand.hi, "A rms",
              "a machine's current limit");
  r.plausible("inertia_kgm2", p.inertia_kgm2, kRotorInertiaBand.lo, kRotorInertiaBand.hi, "kg m^2", "a rotor's inertia");
  r.finish();
  return p;
}

plant::BatteryRcParams read_battery(Reader r) {
  plant::BatteryRcParams p;
  p.cell_capacity_Ah = r.number("cell_capacity_Ah", p.cell_capacity_Ah);
  p.cell_emf_min_V = r.number("cell_emf_min_V", p.cell_emf_min_V);
  p.cell_emf_max_V = r.number("cell_emf_max_V", p.cell_emf_max_V);
  p.soc_min = r.number("soc_min", p.soc_min);
  p.soc_max = r.number("soc_max", p.soc_max);
  p.soc_initial = r.number("soc_initial", p.soc_initial);
  p.cell_current_max_A = r.opt_number("cell_current_max_A");
  p.r0_cell_Ohm = r.opt_number("r0_cell_Ohm");
  p.r1_cell_Ohm = r.opt_number("r1_cell_Ohm");
  p.c1_cell_F = r.opt_number("c1_cell_F");
  p.efficiency = r.number("efficiency", p.efficiency);
  p.cell_current_efficiency_A = r.opt_number("cell_current_efficiency_A");
  // a pack of more than 100 000 cells in either direction is a typo, not a battery
  p.cells_series = r.small_integer("cells_series", p.cells_series, 1, 100000);
  p.strings_parallel = r.small_integer("strings_parallel", p.strings_parallel, 1, 100000);
  r.plausible("cell_capacity_Ah", p.cell_capacity_Ah, kCellCapacityBand.lo, kCellCapacityBand.hi, "Ah",
              "a cell's capacity");
  for (const char* key : {"r0_cell_Ohm", "r1_cell_Ohm"}) {
    const std::optional<double>& v = std::string_view(key) == "r0_cell_Ohm" ? p.r0_cell_Ohm : p.r1_cell_Ohm;
    if (v) r.plausible(key, *v, kCellResistanceBand.lo, kCellResistanceBand.hi, "Ohm", "a cell's resistance");
  }
  if (p.c1_cell_F) {
    r.plausible("c1_cell_F", *p.c1_cell_F, kCellCapacitanceBand.lo, kCellCapacitanceBand.hi, "F",
                "a cell's RC capacitance");
  }
  r.plausible("cells_series", p.cells_series, kCellsSeriesBand.lo, kCellsSeriesBand.hi, "", "cells in series");
  r.plausible("strings_parallel", p.strings_parallel, kStringsParallelBand.lo, kStringsParallelBand.hi, "",
              "strings in parallel");
  r.finish();
  return p;
}

plant::RoadLoadParams read_road(Reader r, Context& ctx) {
  plant::RoadLoadParams p;
  const std::string form = r.text("form", "coefficients");
  static constexpr std::array<std::string_view, 4> kCoefficientKeys = {"rolling_coefficient", "air_density_kg_m3",
                                                                       "frontal_area_m2", "drag_coefficient"};
  static constexpr std::array<std::string_view, 3> kCoastDownKeys = {"f0_N", "f1_N_s_m", "f2_N_s2_m2"};
  // the keys of the other form are ignored with a warning, so that `--set road.form=...`
  // can switch forms on a vehicle file that gives the other one
  const auto ignore = [&](const auto& keys) {
    for (std::string_view key : keys) {
      if (!r.has(key)) continue;
      const toml::node* n = r.find(key);
      ctx.warn(ctx.where[r.field(key)], r.field(key), n != nullptr ? node_text(*n) : "",
               "ignored: road.form is \"" + form + "\"");
    }
  };
  if (form == "coefficients") {
    p.form = plant::RoadLoadForm::kCoefficients;
    p.rolling_coefficient = r.required_number("rolling_coefficient");
    p.air_density_kg_m3 = r.number("air_density_kg_m3", p.air_density_kg_m3);
    p.frontal_area_m2 = r.required_number("frontal_area_m2");
    p.drag_coefficient = r.required_number("drag_coefficient");
    ignore(kCoastDownKeys);
  } else if (form == "coast-down") {
    p.form = plant::RoadLoadForm::kCoastDown;
    p.f0_N = r.required_number("f0_N");
    p.f1_N_s_m = r.number("f1_N_s_m", 0.0);
    p.f2_N_s2_m2 = r.required_number("f2_N_s2_m2");
    ignore(kCoefficientKeys);
  } else {
    ctx.error(ctx.where[r.field("form")], r.field("form"), "\"" + form + "\"",
              "must be \"coefficients\" or \"coast-down\"");
    // the keys of both forms are known: no follow-on "unknown key"
    for (std::string_view key : kCoefficientKeys) r.find(key);
    for (std::string_view key : kCoastDownKeys) r.find(key);
  }
  if (p.form == plant::RoadLoadForm::kCoefficients) {
    r.plausible("frontal_area_m2", p.frontal_area_m2, kFrontalAreaBand.lo, kFrontalAreaBand.hi, "m^2",
                "a vehicle's frontal area");
    r.plausible("drag_coefficient", p.drag_coefficient, kDragCoefficientBand.lo, kDragCoefficientBand.hi, "",
                "a drag coefficient");
    r.plausible("rolling_coefficient", p.rolling_coefficient, kRollingCoefficientBand.lo, kRollingCoefficientBand.hi,
                "", "a rolling resistance coefficient");
  }
  const FileRef slope = r.path("slope_table", false);
  if (!slope.empty()) p.slope_rad = load_curve(slope, r.field("slope"), ctx);
  r.finish();
  return p;
}

plant::VehicleBodyParams read_body(Reader r) {
  plant::VehicleBodyParams b;
  b.mass_kg = r.required_number("mass_kg");
  b.wheel_radius_m = r.required_number("wheel_radius_m");
  b.gear_ratio = r.required_number("gear_ratio");
  b.speed_initial_m_s = r.number("speed_initial_m_s", 0.0);
  r.plausible("mass_kg", b.mass_kg, kMassBand.lo, kMassBand.hi, "kg", "a vehicle's mass");
  r.plausible("wheel_radius_m", b.wheel_radius_m, kWheelRadiusBand.lo, kWheelRadiusBand.hi, "m", "a wheel's radius");
  r.plausible("gear_ratio", b.gear_ratio, kGearRatioBand.lo, kGearRatioBand.hi, "", "a final drive's gear ratio");
  r.finish();
  return b;
}

plant::PropDriverParams read_driver(Reader r) {
  plant::PropDriverParams d;
  d.gain = r.required_number("gain");
  d.request_max = r.number("request_max", d.request_max);
  d.request_min = r.number("request_min", -d.request_max);
  r.finish();
  return d;
}

plant::BrakeParams read_brake(Reader r) {
  plant::BrakeParams b;
  b.enabled = r.flag("enabled", b.enabled);
  b.library_gain = r.flag("library_gain", b.library_gain);
  b.after_rotor_inertia = r.flag("after_rotor_inertia", b.after_rotor_inertia);
  r.finish();
  return b;
}

plant::MapIceParams read_ice(Reader r, Context& ctx) {
  plant::MapIceParams p;
  const std::string input = r.text("input", "power");
  if (input == "power") {
    p.input = plant::IceInput::kPower;
  } else if (input == "torque") {
    p.input = plant::IceInput::kTorque;
  } else {
    ctx.error(ctx.where[r.field("input")], r.field("input"), "\"" + input + "\"", "must be \"power\" or \"torque\"");
  }
  p.inertia_kgm2 = r.number("inertia_kgm2", p.inertia_kgm2);
  p.speed_initial_rad_s = r.number("speed_initial_rad_s", p.speed_initial_rad_s);
  p.control_gain_Nm_W = r.number("control_gain_Nm_W", p.control_gain_Nm_W);
  p.fuel_lhv_J_kg = r.number("fuel_lhv_J_kg", p.fuel_lhv_J_kg);
  p.fuel_density_kg_m3 = r.number("fuel_density_kg_m3", p.fuel_density_kg_m3);
  p.on_off = r.flag("on_off", false);
  const FileRef curve = r.path("torque_max_table", !r.has("torque_max_Nm"));
  if (!curve.empty()) p.torque_max_Nm = load_curve(curve, r.field("torque_max"), ctx);
  // a constant instead of a table (the library's Level 1 genset: maxIceTau = 1.1 maxTau)
  if (r.has("torque_max_Nm")) {
    const double t_Nm = r.number("torque_max_Nm", 0.0);
    if (!curve.empty()) {
      ctx.error(ctx.where[r.field("torque_max_Nm")], r.field("torque_max_Nm"), plant::number_text(t_Nm),
                "give either torque_max_table or torque_max_Nm, not both");
    } else if (!(t_Nm > 0.0) || !std::isfinite(t_Nm)) {
      ctx.error(ctx.where[r.field("torque_max_Nm")], r.field("torque_max_Nm"), plant::number_text(t_Nm),
                "must be a finite number > 0 (the engine's maximum torque at every speed)");
    }
    p.torque_max_Nm = plant::Table1d({0.0, 1.0}, {t_Nm, t_Nm}, plant::Extrapolation::kHold);
  }
  r.plausible("inertia_kgm2", p.inertia_kgm2, kRotorInertiaBand.lo, kRotorInertiaBand.hi, "kg m^2",
              "an engine's inertia");
  if (!p.torque_max_Nm.empty()) {
    // the engine's rating: the peak of its torque curve
    double peak_Nm = 0.0;
    for (const double t : p.torque_max_Nm.y()) peak_Nm = std::max(peak_Nm, t);
    if (std::isfinite(peak_Nm) && peak_Nm > 0.0 && (peak_Nm < kDriveTorqueBand.lo || peak_Nm > kDriveTorqueBand.hi)) {
      const bool constant = curve.empty();  // torque_max_Nm: the key's own line
      ctx.warn(constant ? ctx.where[r.field("torque_max_Nm")] : curve.path,
               constant ? r.field("torque_max_Nm") : r.field("torque_max"), plant::number_text(peak_Nm) + " N m (its peak)",
               "outside the plausible band [" + plant::number_text(kDriveTorqueBand.lo) + ", " +
                   plant::number_text(kDriveTorqueBand.hi) + "] N m of an engine's peak torque (a unit or a typo? " +
                   "it runs as given)");
    }
  }
  const FileRef sfc = r.path("sfc_map", !r.has("sfc_g_kWh"));
  if (!sfc.empty()) p.sfc_g_kWh = load_map(sfc, r.field("sfc_map"), ctx);
  // a constant specific consumption (the library's Level 1 genset: constFuelConsumption)
  if (r.has("sfc_g_kWh")) {
    const double sfc_g_kWh = r.number("sfc_g_kWh", 0.0);
    if (!sfc.empty()) {
      ctx.error(ctx.where[r.field("sfc_g_kWh")], r.field("sfc_g_kWh"), plant::number_text(sfc_g_kWh),
                "give either sfc_map or sfc_g_kWh, not both");
    } else if (!(sfc_g_kWh > 0.0) || !std::isfinite(sfc_g_kWh)) {
      ctx.error(ctx.where[r.field("sfc_g_kWh")], r.field("sfc_g_kWh"), plant::number_text(sfc_g_kWh),
                "must be a finite number > 0 (the specific consumption at every point)");
    }
    p.sfc_g_kWh = plant::Table2d({0.0, 1.0}, {0.0, 1.0}, {sfc_g_kWh, sfc_g_kWh, sfc_g_kWh, sfc_g_kWh});
  }
  r.finish();
  return p;
}

// The timing every built-in ECU has: its period and its latency (whole numbers of steps).
void read_ecu_timing(Reader& r, EcuTiming& t) {
  t.period_s = r.number("period_s", t.period_s);
  t.latency_s = r.number("latency_s", t.latency_s);
  t.codec = r.text("codec", t.codec);
}

}  // namespace ehpt::hil::detail
