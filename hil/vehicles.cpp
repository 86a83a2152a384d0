// The vehicle kinds: one entry each, with its factory and its signals. This is the only
// place that turns a scenario's parameters into C++ types; the CLI and the batch runner
// go through Simulation.
#include <string_view>

#include "ecu/ev_follower.hpp"
#include "ecu/psd_ecu.hpp"
#include "hil/simulation_of.hpp"
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

struct VehicleKind {
  std::unique_ptr<Simulation> (*make)(const Scenario&, const SimulationOptions&);
  std::vector<SignalInfo> (*signals)(const Scenario&);
};

// bev: the map-based EV with its driver-follower ECU
const VehicleKind kBev{
    [](const Scenario& sc, const SimulationOptions& opt) {
      return simulate(sc, opt, std::make_unique<const plant::BevPlant>(std::get<plant::BevParams>(sc.plant)),
                      std::make_unique<ecu::EvFollower>());
    },
    [](const Scenario& sc) { return signals_of(plant::BevPlant(std::get<plant::BevParams>(sc.plant))); }};

// psd: the power-split hybrid with MBecu1 / MBecu1soc / MBecu2
const VehicleKind kPsd{
    [](const Scenario& sc, const SimulationOptions& opt) {
      const auto& p = std::get<plant::PsdParams>(sc.plant);
      const auto& e = std::get<ecu::PsdEcuParams>(sc.ecu);
      return simulate(sc, opt, std::make_unique<const plant::PsdPlant>(p), std::make_unique<ecu::PsdEcu>(e, e.period_s),
                      p.ice.fuel_density_kg_m3);
    },
    [](const Scenario& sc) { return signals_of(plant::PsdPlant(std::get<plant::PsdParams>(sc.plant))); }};

// drive_rig: TestMBOneFlange / TestTwoFlange
const VehicleKind kDriveRig{
    [](const Scenario& sc, const SimulationOptions& opt) {
      return simulate(sc, opt, std::make_unique<const plant::DriveRig>(std::get<plant::DriveRigParams>(sc.plant)),
                      std::unique_ptr<NoController>());
    },
    [](const Scenario& sc) { return signals_of(plant::DriveRig(std::get<plant::DriveRigParams>(sc.plant))); }};

// battery_rig: Batt1 on a current / power profile
const VehicleKind kBatteryRig{
    [](const Scenario& sc, const SimulationOptions& opt) {
      return simulate(sc, opt,
                      std::make_unique<const plant::BatteryRig>(std::get<plant::BatteryRigParams>(sc.plant)),
                      std::unique_ptr<NoController>());
    },
    [](const Scenario& sc) { return signals_of(plant::BatteryRig(std::get<plant::BatteryRigParams>(sc.plant))); }};

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

std::vector<SignalInfo> scenario_signals(const Scenario& sc) { return kind_of(sc).signals(sc); }

}  // namespace ehpt::hil
