// The vehicle kinds: one entry each, registered once {name, reader, factory, signals}. This
// is the only place that reads a kind's vehicle file and turns a scenario's parameters into
// C++ types; load_scenario, the CLI and the batch runner go through this table.
#include <string_view>

#include "ecu/ev_follower.hpp"
#include "ecu/psd_ecu.hpp"
#include "hil/config_components.hpp"
#include "hil/scenario.hpp"
#include "hil/simulation_of.hpp"
#include "hil/vehicle_kinds.hpp"
#include "plant/battery_rig.hpp"
#include "plant/bev_plant.hpp"
#include "plant/drive_rigs.hpp"
#include "plant/psd_plant.hpp"
#include "solvers/integrators.hpp"

namespace ehpt::hil {

namespace {

// One kind: its plant (and ECU) from the scenario, with the scenario's solver.
template <class Plant, class Controller = NoController>
std::unique_ptr<Simulation> simulate(const Scenario& sc, const SimulationOptions& opt,
                                     std::unique_ptr<const Plant> plant, std::unique_ptr<Controller> controller,
                                     double fuel_density_kg_m3 = 0.0) {
  if (sc.solver.kind == SolverKind::kRk4) {
    return std::make_unique<SimulationOf<Plant, solvers::Rk4<Plant>, Controller>>(
        sc, opt, std::move(plant), std::move(controller), fuel_density_kg_m3);
  }
  return std::make_unique<SimulationOf<Plant, solvers::ImplicitEuler<Plant>, Controller>>(
      sc, opt, std::move(plant), std::move(controller), fuel_density_kg_m3);
}

template <class Plant>
std::vector<SignalInfo> signals_of(const Plant& plant) {
  std::vector<SignalInfo> out;
  for (const auto& s : plant.signals()) out.push_back({s.name, s.meaning});
  return out;
}

// ---- reading the kinds ------------------------------------------------------------------

using namespace detail;

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

// The EV's built-in ECU: the driver-follower; an optional [ecu] table sets its timing.
void read_ev_ecu(Reader r, EcuTiming& timing, Context& ctx) {
  const std::string kind = r.text("kind", "follower");
  if (kind != "follower") {
    ctx.error(ctx.where[r.field("kind")], r.field("kind"), "\"" + kind + "\"",
              "must be \"follower\" (the built-in ECU of the EV; an external one joins over a bus)");
  }
  read_ecu_timing(r, timing);
  r.finish();
}

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
  {
    Reader r = root.sub("request");
    plant::Trapezoid& t = p.request_Nm;
    t.offset = r.number("offset_Nm", 0.0);
    t.amplitude = r.number("amplitude_Nm", 0.0);
    t.start_s = r.number("start_s", 0.0);
    t.rising_s = r.required_number("rising_s");
    t.width_s = r.number("width_s", 0.0);
    t.falling_s = r.required_number("falling_s");
    t.period_s = r.number("period_s", 1e6);
    r.finish();
  }
  return p;
}

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


// A vehicle with a driver needs a cycle; a rig has none.
void need_cycle(const KindInput& in, Context& ctx) {
  if (in.cycle.empty()) ctx.error(in.scenario_path, "cycle", "", "missing (a vehicle with a driver needs a cycle file)");
}
void no_cycle(const KindInput& in, const char* what, Context& ctx) {
  if (!in.cycle.empty()) {
    ctx.error(in.cycle.where, "cycle", "\"" + in.cycle.written + "\"", std::string(what) + " has no driver: remove the cycle");
  }
}
std::optional<double> cycle_length(const plant::PropDriverParams& d) {
  if (d.cycle_m_s.empty()) return std::nullopt;
  return d.cycle_m_s.x().back();
}

KindRead read_bev_kind(Reader& vr, const KindInput& in, Scenario& out, Problems& problems, Problems& warnings,
                       Context& ctx) {
  need_cycle(in, ctx);
  plant::BevParams p = read_bev(vr, in.cycle, in.cycle_periodic, ctx);
  read_ev_ecu(vr.sub("ecu"), out.ecu_timing, ctx);
  vr.finish();
  out.ecu = ecu::EvFollowerParams{};
  plant::validate(p, problems);
  if (problems.empty()) plant::warn(p.drive, "drive", warnings);
  check_signals(plant::BevPlant::kSignals, out.output.signals, ctx);
  KindRead r{cycle_length(p.driver), false, true};
  out.plant = std::move(p);
  return r;
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
  KindRead r{cycle_length(p.driver), false, true};
  out.plant = std::move(p);
  out.ecu = std::move(e);
  return r;
}

KindRead read_drive_rig_kind(Reader& vr, const KindInput& in, Scenario& out, Problems& problems, Problems& warnings,
                             Context& ctx) {
  no_cycle(in, "a drive rig", ctx);
  plant::DriveRigParams p = read_rig(vr, ctx);
  vr.finish();
  plant::validate(p, problems);
  if (problems.empty()) plant::warn(p.drive, "drive", warnings);
  check_signals(plant::DriveRig(p).signals(), out.output.signals, ctx);
  out.plant = std::move(p);
  return {};
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
  out.plant = std::move(p);
  return r;
}

// ---- the table --------------------------------------------------------------------------

struct VehicleKind {
  std::string_view name;  // `kind` in the vehicle file
  ReadKind read;
  std::unique_ptr<Simulation> (*make)(const Scenario&, const SimulationOptions&);
  std::vector<SignalInfo> (*signals)(const Scenario&);
};

// bev: the map-based EV with its driver-follower ECU
const VehicleKind kBev{
    "bev", read_bev_kind,
    [](const Scenario& sc, const SimulationOptions& opt) {
      return simulate(sc, opt, std::make_unique<const plant::BevPlant>(std::get<plant::BevParams>(sc.plant)),
                      std::make_unique<ecu::EvFollower>());
    },
    [](const Scenario& sc) { return signals_of(plant::BevPlant(std::get<plant::BevParams>(sc.plant))); }};

// psd: the power-split hybrid with MBecu1 / MBecu1soc / MBecu2
const VehicleKind kPsd{
    "psd", read_psd_kind,
    [](const Scenario& sc, const SimulationOptions& opt) {
      const auto& p = std::get<plant::PsdParams>(sc.plant);
      const auto& e = std::get<ecu::PsdEcuParams>(sc.ecu);
      return simulate(sc, opt, std::make_unique<const plant::PsdPlant>(p), std::make_unique<ecu::PsdEcu>(e, e.period_s),
                      p.ice.fuel_density_kg_m3);
    },
    [](const Scenario& sc) { return signals_of(plant::PsdPlant(std::get<plant::PsdParams>(sc.plant))); }};

// drive_rig: TestMBOneFlange / TestTwoFlange
const VehicleKind kDriveRig{
    "drive_rig", read_drive_rig_kind,
    [](const Scenario& sc, const SimulationOptions& opt) {
      return simulate(sc, opt, std::make_unique<const plant::DriveRig>(std::get<plant::DriveRigParams>(sc.plant)),
                      std::unique_ptr<NoController>());
    },
    [](const Scenario& sc) { return signals_of(plant::DriveRig(std::get<plant::DriveRigParams>(sc.plant))); }};

// battery_rig: Batt1 on a current / power profile
const VehicleKind kBatteryRig{
    "battery_rig", read_battery_rig_kind,
    [](const Scenario& sc, const SimulationOptions& opt) {
      return simulate(sc, opt,
                      std::make_unique<const plant::BatteryRig>(std::get<plant::BatteryRigParams>(sc.plant)),
                      std::unique_ptr<NoController>());
    },
    [](const Scenario& sc) { return signals_of(plant::BatteryRig(std::get<plant::BatteryRigParams>(sc.plant))); }};

const VehicleKind* const kKinds[] = {&kBev, &kPsd, &kDriveRig, &kBatteryRig};

const VehicleKind& kind_of(const Scenario& sc) {
  struct Pick {
    const VehicleKind& operator()(const plant::BevParams&) const { return kBev; }
    const VehicleKind& operator()(const plant::PsdParams&) const { return kPsd; }
    const VehicleKind& operator()(const plant::DriveRigParams&) const { return kDriveRig; }
    const VehicleKind& operator()(const plant::BatteryRigParams&) const { return kBatteryRig; }
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
