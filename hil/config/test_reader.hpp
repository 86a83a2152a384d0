// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Reading [test], [[fault]] and [[expect]] (hil/config/test_spec.hpp) from a scenario's layers
// and from --fault texts (start-up only). What needs the vehicle (which message a target is
// in, which outputs exist) is checked by its kind's reader through check_test_targets.

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "hil/config/config_reader.hpp"
#include "hil/config/test_spec.hpp"

namespace ehpt::hil::detail {

// Every problem into ctx with file:line. layers: the scenario's, highest first (a test file
// over the scenario it names); arrays of faults and expectations add up from the lowest layer
// to the highest, then the --fault texts ("kind=stuck target=batSOC at_s=10": key=value
// pairs, each value TOML).
void read_tests(const std::vector<Layer>& layers, Reader& sc, const std::vector<std::string>& fault_args,
                Scenario& out, Context& ctx);

// The most faults one run takes (each one bit of the faults_active column).
inline constexpr std::size_t kMaxFaults = 32;
// The longest delay, in samples or steps (a delay keeps its history at start-up).
inline constexpr double kMaxDelaySamples = 1e6;
// The longest delay of a message's frames, in ECU periods (they wait in a ring of frames).
inline constexpr double kMaxBusDelaySamples = 1000;

// The summary figures an expectation may check at the end of a run.
std::span<const std::string_view> expect_figures();

// What a plant fault may act on in this vehicle: its pack (strings_parallel > 0) and its
// machines, in the plant's kMachines order (plant/health.hpp). Empty: no plant faults.
struct PlantFaultTargets {
  int strings_parallel = 0;  // 0: no pack
  std::vector<std::string_view> machines;
};

// A plant's: its pack and its kMachines.
template <class Plant, class BatteryParams>
PlantFaultTargets plant_fault_targets(const BatteryParams& battery) {
  return {battery.strings_parallel, std::vector<std::string_view>(Plant::kMachines.begin(), Plant::kMachines.end())};
}

// The vehicle's part: each fault's target is a field of its sensor or command message, or a
// component of the plant (their side, and a derating's machine, set in out.faults); each
// expectation's signals and conditions name its outputs. sensors/commands: the message's
// field names (empty: the vehicle has no ECU messages).
void check_test_targets(std::span<const std::string_view> outputs, std::span<const std::string_view> sensors,
                        std::span<const std::string_view> commands, const PlantFaultTargets& plant, Scenario& out,
                        Context& ctx);

// The same from the plant's signal table and the messages' field tables (msgs/fields.hpp).
template <class Signals, class SensorFields, class CommandFields>
void check_test_targets_of(const Signals& signals, const SensorFields& sensors, const CommandFields& commands,
                           const PlantFaultTargets& plant, Scenario& out, Context& ctx) {
  std::vector<std::string_view> o, s, c;
  for (const auto& x : signals) o.push_back(x.name);
  for (const auto& x : sensors) s.push_back(x.name);
  for (const auto& x : commands) c.push_back(x.name);
  check_test_targets(o, s, c, plant, out, ctx);
}
template <class Signals>
void check_test_targets_of(const Signals& signals, Scenario& out, Context& ctx) {
  std::vector<std::string_view> o;
  for (const auto& x : signals) o.push_back(x.name);
  check_test_targets(o, {}, {}, {}, out, ctx);
}

// After the run's length is known: windows and times that fall after its end are errors.
void check_test_times(Scenario& out, Context& ctx);

// "soc_1 < 0.3" -> condition; false and why if it is not one.
bool parse_condition(const std::string& text, SignalCondition& out, std::string& why);

}  // namespace ehpt::hil::detail
