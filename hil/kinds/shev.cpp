// SPDX-License-Identifier: BSD-3-Clause
// shev: the series hybrid (MODELS.md §5.5, §10.6) with its EMS: PowerFilt (SHEVpowerFilt),
// PowerFiltSoc (SHEVpowerFiltSoc) or ShevEMS (SHEV_OO).
#include "hil/kinds/kind.hpp"

#include "ecu/shev_ems.hpp"
#include "plant/shev_plant.hpp"

namespace ehpt::hil::kinds {

namespace {

ecu::ShevEmsParams read_shev_ems(Reader r, EcuTiming& timing, Context& ctx) {
  ecu::ShevEmsParams p;
  const std::string kind = r.text("kind", "");
  if (kind == "PowerFilt") {
    p.kind = ecu::ShevEmsKind::kPowerFilt;
  } else if (kind == "PowerFiltSoc") {
    p.kind = ecu::ShevEmsKind::kPowerFiltSoc;
  } else if (kind == "ShevEMS") {
    p.kind = ecu::ShevEmsKind::kShevEms;
  } else {
    ctx.error(ctx.where[r.field("kind")], r.field("kind"), "\"" + kind + "\"",
              "must be \"PowerFilt\", \"PowerFiltSoc\" or \"ShevEMS\"");
  }
  read_ecu_timing(r, timing);
  p.power_filter_s = r.required_number("power_filter_s");
  p.power_filter_initial_W = r.required_number("power_filter_initial_W");
  p.power_max_W = r.required_number("power_max_W");
  // PowerFilt has no SOC loop and the first two no ON/OFF: their keys would do nothing
  if (p.kind == ecu::ShevEmsKind::kPowerFilt) {
    p.soc_gain_W = 0.0;
    for (const char* key : {"soc_ref", "soc_gain_W"}) {
      if (r.find(key) != nullptr) {  // find: the key's line, and not also "unknown"
        ctx.error(ctx.where[r.field(key)], r.field(key), "(set)",
                  "PowerFilt has no SOC loop: use kind = \"PowerFiltSoc\", or remove the key");
      }
    }
  } else {
    p.soc_ref = r.required_number("soc_ref");
    p.soc_gain_W = r.required_number("soc_gain_W");
  }
  if (p.kind == ecu::ShevEmsKind::kShevEms) {
    p.on_W = r.required_number("on_W");
    p.off_W = r.required_number("off_W");
  } else {
    for (const char* key : {"on_W", "off_W"}) {
      if (r.find(key) != nullptr) {
        ctx.error(ctx.where[r.field(key)], r.field(key), "(set)",
                  "only ShevEMS switches the genset on and off: use kind = \"ShevEMS\", or remove the key");
      }
    }
  }
  r.finish();
  return p;
}

plant::ShevParams read_shev(Reader& root, const FileRef& cycle, bool periodic, Context& ctx) {
  plant::ShevParams p;
  p.body = read_body(root.sub("vehicle"));
  p.road = read_road(root.sub("road"), ctx);
  p.brake = read_brake(root.sub("brake"));
  p.driver = read_driver(root.sub("driver"));
  p.battery = read_battery(root.sub("battery"));
  p.drive = read_drive(root.sub("drive"), ctx);
  p.genset = read_genset(root.sub("genset"), ctx);
  if (!cycle.empty()) p.driver.cycle_m_s = load_cycle(cycle, "driver.cycle", periodic, ctx);
  return p;
}

KindRead read_shev_kind(Reader& vr, const KindInput& in, Scenario& out, Problems& problems, Problems& warnings,
                        Context& ctx) {
  need_cycle(in, ctx);
  plant::ShevParams p = read_shev(vr, in.cycle, in.cycle_periodic, ctx);
  ecu::ShevEmsParams e = read_shev_ems(vr.sub("ecu"), out.ecu_timing, ctx);
  vr.finish();
  ecu::validate(e, "ecu", problems);
  plant::validate(p, problems);
  if (problems.empty()) {
    plant::warn(p.drive, "drive", warnings);
    plant::warn(p.genset.generator, "genset.generator", warnings);
    if (e.kind == ecu::ShevEmsKind::kShevEms && !p.genset.ice.on_off) {
      warnings.add("genset.ice.on_off", "false",
                   "ShevEMS switches the genset off through gensetON, which this genset ignores: when OFF only "
                   "gensetPowRef = 0, and the engine keeps turning and burning fuel");
    }
  }
  check_signals(plant::ShevPlant::kSignals, out.output.signals, ctx);
  check_test_targets_of(plant::ShevPlant::kSignals, msgs::kShevSensorFieldTable, msgs::kShevCommandFieldTable,
                        plant_fault_targets<plant::ShevPlant>(p.battery), out, ctx);
  KindRead r{cycle_length(p.driver), false, true};
  // the EMS filter steps with the ECU period load_scenario settles on
  r.set_ecu_period = [](Scenario& s, double period_s) { s.ecu.get<ecu::ShevEmsParams>().period_s = period_s; };
  out.plant = std::move(p);
  out.ecu = std::move(e);
  return r;
}

}  // namespace

// shev: the series hybrid with its EMS
extern const VehicleKind kind_shev{
    "shev", &typeid(plant::ShevParams), read_shev_kind,
    [](const Scenario& sc, const SimulationOptions& opt) {
      const auto& p = sc.plant.get<plant::ShevParams>();
      const auto& e = sc.ecu.get<ecu::ShevEmsParams>();
      return simulate(sc, opt, std::make_unique<plant::ShevPlant>(p), std::make_unique<ecu::ShevEms>(e, e.period_s),
                      p.genset.ice.fuel_density_kg_m3);
    },
    [](const Scenario& sc) { return signals_of(plant::ShevPlant(sc.plant.get<plant::ShevParams>())); }};

}  // namespace ehpt::hil::kinds
