// SPDX-License-Identifier: BSD-3-Clause
// psd: the power-split hybrid (MODELS.md §4, §10.4) with MBecu1 / MBecu1soc / MBecu2.
#include "hil/kinds/kind.hpp"

#include "ecu/psd_ecu.hpp"
#include "plant/psd_plant.hpp"

namespace ehpt::hil::kinds {

namespace {

ecu::PsdEcuParams read_psd_ecu(Reader r, EcuTiming& timing, Context& ctx) {
  ecu::PsdEcuParams p;
  const std::string kind = r.text("kind", "");
  if (kind == "MBecu1") {
    p.kind = ecu::PsdEcuKind::kMBecu1;
  } else if (kind == "MBecu1soc") {
    p.kind = ecu::PsdEcuKind::kMBecu1soc;
  } else if (kind == "MBecu2") {
    p.kind = ecu::PsdEcuKind::kMBecu2;
  } else {
    ctx.error(ctx.where[r.field("kind")], r.field("kind"), "\"" + kind + "\"",
              "must be \"MBecu1\", \"MBecu1soc\" or \"MBecu2\"");
  }
  read_ecu_timing(r, timing);
  p.max_torque_request_Nm = r.number("max_torque_request_Nm", p.max_torque_request_Nm);
  p.power_filter_s = r.number("power_filter_s", p.power_filter_s);
  p.gen_loop_gain_Nm_s_rad = r.required_number("gen_loop_gain_Nm_s_rad");
  p.gen_filter_s = r.number("gen_filter_s", p.gen_filter_s);
  p.gen_torque_max_Nm = r.number("gen_torque_max_Nm", p.gen_torque_max_Nm);
  p.ice_speed_min_rad_s = r.number("ice_speed_min_rad_s", p.ice_speed_min_rad_s);
  const FileRef table = r.path("power_to_speed_table", true);
  if (!table.empty()) {
    p.power_to_speed_rad_s = load_curve(table, r.field("power_to_speed"), ctx);
    // PowToW extrapolates linearly beyond its ends (§5.1)
    p.power_to_speed_rad_s = plant::Table1d(p.power_to_speed_rad_s.x(), p.power_to_speed_rad_s.y(),
                                            plant::Extrapolation::kLinear);
  }
  p.soc_ref = r.number("soc_ref", p.soc_ref);
  // MBecu1 has no SOC loop (PsdEcu ignores the gain); the others need it
  p.soc_loop_gain_W = p.kind == ecu::PsdEcuKind::kMBecu1 ? r.number("soc_loop_gain_W", 0.0)
                                                           : r.required_number("soc_loop_gain_W");
  p.on_threshold_W = r.number("on_threshold_W", p.on_threshold_W);
  p.off_threshold_W = r.number("off_threshold_W", p.off_threshold_W);
  p.ice_off_speed_ref_rad_s = r.number("ice_off_speed_ref_rad_s", p.ice_off_speed_ref_rad_s);
  r.finish();
  return p;
}

plant::PsdParams read_psd(Reader& root, const FileRef& cycle, bool periodic, Context& ctx) {
  plant::PsdParams p;
  p.body = read_body(root.sub("vehicle"));
  p.road = read_road(root.sub("road"), ctx);
  p.brake = read_brake(root.sub("brake"));
  p.driver = read_driver(root.sub("driver"));
  p.battery = read_battery(root.sub("battery"));
  p.ice = read_ice(root.sub("ice"), ctx);
  p.gen = read_drive(root.sub("gen"), ctx);
  p.mot = read_drive(root.sub("mot"), ctx);
  {
    Reader r = root.sub("planetary");
    p.ring_sun_ratio = r.number("ring_sun_ratio", p.ring_sun_ratio);
    r.finish();
  }
  if (!cycle.empty()) p.driver.cycle_m_s = load_cycle(cycle, "driver.cycle", periodic, ctx);
  return p;
}

KindRead read_psd_kind(Reader& vr, const KindInput& in, Scenario& out, Problems& problems, Problems& warnings,
                       Context& ctx) {
  need_cycle(in, ctx);
  plant::PsdParams p = read_psd(vr, in.cycle, in.cycle_periodic, ctx);
  ecu::PsdEcuParams e = read_psd_ecu(vr.sub("ecu"), out.ecu_timing, ctx);
  vr.finish();
  ecu::validate(e, "ecu", problems);
  plant::validate(p, problems);
  if (problems.empty()) {
    plant::warn(p.gen, "gen", warnings);
    plant::warn(p.mot, "mot", warnings);
    if (e.kind == ecu::PsdEcuKind::kMBecu2 && !p.ice.on_off) {
      warnings.add("ice.on_off", "false",
                   "MBecu2 stops the engine through iceON, which this engine ignores: when OFF only "
                   "icePowRef = 0, and the power loop may still give torque and burn fuel");
    }
    if (p.ice.input == plant::IceInput::kTorque) {
      warnings.add("ice.input", "\"torque\"",
                   "the built-in ECUs send icePowRef, not iceTauRef: with them this engine gives no torque");
    }
  }
  check_signals(plant::PsdPlant::kSignals, out.output.signals, ctx);
  check_test_targets_of(plant::PsdPlant::kSignals, msgs::kPsdSensorFieldTable, msgs::kPsdCommandFieldTable,
                        plant_fault_targets<plant::PsdPlant>(p.battery), out, ctx);
  KindRead r{cycle_length(p.driver), false, true};
  // MBecu's filters and integrators step with the ECU period load_scenario settles on
  r.set_ecu_period = [](Scenario& s, double period_s) { s.ecu.get<ecu::PsdEcuParams>().period_s = period_s; };
  out.plant = std::move(p);
  out.ecu = std::move(e);
  return r;
}

}  // namespace

// psd: the power-split hybrid with MBecu1 / MBecu1soc / MBecu2
extern const VehicleKind kind_psd{
    "psd", &typeid(plant::PsdParams), read_psd_kind,
    [](const Scenario& sc, const SimulationOptions& opt) {
      const auto& p = sc.plant.get<plant::PsdParams>();
      const auto& e = sc.ecu.get<ecu::PsdEcuParams>();
      return simulate(sc, opt, std::make_unique<plant::PsdPlant>(p), std::make_unique<ecu::PsdEcu>(e, e.period_s),
                      p.ice.fuel_density_kg_m3);
    },
    [](const Scenario& sc) { return signals_of(plant::PsdPlant(sc.plant.get<plant::PsdParams>())); }};


}  // namespace ehpt::hil::kinds
