// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// What a vehicle kind is made of (start-up only): its entry in the table of hil/kinds/registry.cpp
// {name, reader, factory, signals}, and the helpers the kinds share. One file per kind in
// hil/kinds/ defines its entry.

#include <memory>
#include <optional>
#include <span>
#include <typeinfo>
#include <string_view>
#include <vector>

#include "hil/run/codec_ecu.hpp"
#include "hil/config/config_components.hpp"
#include "hil/run/simulation_of.hpp"
#include "hil/config/test_reader.hpp"
#include "hil/config/vehicle_kinds.hpp"
#include "msgs/fields.hpp"
#include "plant/drive_rigs.hpp"  // Trapezoid
#include "plant/genset.hpp"
#include "solvers/integrators.hpp"

namespace ehpt::hil::kinds {

using namespace detail;

// A vehicle kind, defined in its own file as `extern const VehicleKind kind_<name>{...}` and
// listed in the build by one line, ehpt_kind_file(<file> <name>...) in CMakeLists.txt, which
// generates the table (all_kinds()). Nothing else names a kind: load_scenario finds its reader by
// `kind`, make_simulation and scenario_signals find it by the type of its parameters.
struct VehicleKind {
  std::string_view name;            // `kind` in the vehicle file
  const std::type_info* params;     // what its reader puts into Scenario::plant
  ReadKind read;
  std::unique_ptr<Simulation> (*make)(const Scenario&, const SimulationOptions&);
  std::vector<SignalInfo> (*signals)(const Scenario&);
};

// Every kind, in the order of their build lines (generated: <build>/generated/kinds_table.cpp).
std::span<const VehicleKind* const> all_kinds();

// One kind: its plant (and ECU) from the scenario, with the scenario's solver.
template <class Plant, class Controller = NoController>
inline std::unique_ptr<Simulation> simulate(const Scenario& sc, const SimulationOptions& opt,
                                     std::unique_ptr<Plant> plant, std::unique_ptr<Controller> controller,
                                     double fuel_density_kg_m3 = 0.0) {
  if constexpr (!std::is_same_v<Controller, NoController> && !is_codec_ecu<Controller> &&
                requires { CanFramesOf<typename Plant::Sensors>::kCount; }) {
    // every built-in ECU of a family with CAN frames talks through the codec seam (a
    // pass-through unless ecu.codec = "can"); a family without them runs its ECU directly, and
    // its reader refuses ecu.codec = "can"
    return simulate(sc, opt, std::move(plant),
                    std::make_unique<CodecEcu<Controller>>(std::move(controller), sc.ecu_codec == EcuCodec::kCan),
                    fuel_density_kg_m3);
  }
  if (sc.solver.kind == SolverKind::kRk4) {
    return std::make_unique<SimulationOf<Plant, solvers::Rk4<Plant>, Controller>>(
        sc, opt, std::move(plant), std::move(controller), fuel_density_kg_m3);
  }
  return std::make_unique<SimulationOf<Plant, solvers::ImplicitEuler<Plant>, Controller>>(
      sc, opt, std::move(plant), std::move(controller), fuel_density_kg_m3);
}

template <class Plant>
inline std::vector<SignalInfo> signals_of(const Plant& plant) {
  std::vector<SignalInfo> out;
  for (const auto& s : plant.signals()) out.push_back({s.name, s.meaning});
  return out;
}

// A vehicle with a driver needs a cycle; a rig has none.
void need_cycle(const KindInput& in, Context& ctx);
void no_cycle(const KindInput& in, const char* what, Context& ctx);
std::optional<double> cycle_length(const plant::PropDriverParams& d);
// A rig's trapezoid profile (plant::Trapezoid): offset_<unit>, amplitude_<unit>, start_s,
// rising_s*, width_s, falling_s*, period_s (1e6); unit "Nm", "rad_s", "W".
plant::Trapezoid read_trapezoid(Reader r, const std::string& unit);
// The series hybrid's genset (plant::GensetParams): gear_ratio, throttle_per_rad_s,
// gms_limits_torque (default: ice.on_off), opti_speed_table or opti_speed_rad_s, [ice],
// [generator].
plant::GensetParams read_genset(Reader r, Context& ctx);
// The EVs' built-in ECU, the driver-follower: an optional [ecu] table with its timing.
void read_follower_ecu(Reader r, EcuTiming& timing, Context& ctx);

}  // namespace ehpt::hil::kinds
