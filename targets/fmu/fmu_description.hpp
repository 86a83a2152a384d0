// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// What an ehpt FMU is made of, as a pure function of a loaded scenario: its variables (value
// references, names, units, causality) and its modelDescription.xml. `ehpt fmu` writes the
// description from it and the FMU's library (targets/fmu/fmu_instance.hpp) answers by the same
// table, so the two cannot disagree. FMI 3.0 co-simulation (fmi-standard.org).

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "hil/config/config.hpp"

namespace ehpt::fmu {

enum class Causality { kIndependent, kOutput, kInput, kParameter, kStructuralParameter };
enum class Type { kFloat64, kBoolean, kBinary, kClock };
// Where a variable's value comes from: the time, a plant signal (every step), a field of the
// sensor message the ECU reads at its samples, or (an input) a field of the command message.
// A parameter is a number of the scenario (a --set key: "vehicle.vehicle.mass_kg"), set before
// initialization ends, when the scenario is loaded again with it (and checked as `ehpt run`
// checks it).
// A bus variable (--bus ls-bus) is a member of the FMU's CAN terminal (index: BusMember).
enum class Source { kTime, kSignal, kSensor, kCommand, kParameter, kBus };

// Whose ECU drives the plant: the scenario's built-in one, the importer (--ecu none: the
// command message's fields are inputs, the sensor message's outputs), or an ECU on the FMU's
// FMI-LS-BUS CAN terminal (--bus ls-bus: the frames of ehpt's contract, io/can/ehpt.dbc).
enum class EcuMode { kBuiltin, kNone, kBus };

// What the FMU is: the plant (with its ECU as EcuMode says), or (--bus ls-bus --role ecu) the
// scenario's built-in ECU alone on a CAN terminal, as `ehpt ecu` is on a bus.
enum class Role { kPlant, kEcu };

// The members of an FMI-LS-BUS bus terminal (FMI-LS-BUS §4.3), in value-reference order, and
// the CAN network parameter every Network FMU declares (§4.4.1): whether it relies on Confirm,
// Arbitration Lost and Bus Error operations (this FMU never does; either value is taken).
enum BusMember { kRxData = 0, kRxClock = 1, kTxData = 2, kTxClock = 3, kBusNotifications = 4 };
inline constexpr const char* kBusNotificationsName = "org.fmi_standard.fmi_ls_bus.Can_BusNotifications";
inline constexpr const char* kBusTerminal = "CAN";  // the terminal's name, the variables' prefix
inline constexpr std::size_t kBusBufferBytes = 4096;  // Tx_Data and Rx_Data at most (maxSize)

struct Variable {
  std::uint32_t vr = 0;      // valueReference: 0 is time; the signals from 1, then sensors, commands
  std::string name;          // a signal as in `ehpt signals` (time_s is FMI's "time"); a message
                             // field as sensors.<field> or command.<field>
  std::string unit;          // "" without unit
  std::string description;
  Causality causality = Causality::kOutput;
  Type type = Type::kFloat64;
  Source source = Source::kSignal;
  int index = -1;            // in signals(), or in the message's field table (msgs/fields.hpp)
  double start = 0.0;        // an input's start value (the safe command: 0, engine off), a parameter's
};

// Whose messages a vehicle speaks (with --ecu none they are the FMU's inputs and outputs).
enum class MessageFamily { kEv, kPsd, kShev };

struct Description {
  EcuMode ecu = EcuMode::kBuiltin;
  Role role = Role::kPlant;
  MessageFamily family = MessageFamily::kEv;
  std::string model_name;     // the scenario's name
  std::string description;    // the scenario's
  double step_s = 0.0;        // the plant step: fixedInternalStepSize
  double stop_s = 0.0;        // the scenario's duration: DefaultExperiment stopTime
  std::vector<Variable> variables;  // variables[i].vr == i
};

// ecu = kNone needs a vehicle with bus messages (hil::can_run_on_bus' rule); the caller checks.
// numbers: hil::scenario_numbers of the scenario; those of the vehicle ("vehicle.*") become
// parameters.
// role = kEcu: time and the terminal only (ecu must be kBus).
Description describe(const hil::Scenario& sc, EcuMode ecu = EcuMode::kBuiltin,
                     const std::vector<std::pair<std::string, double>>& numbers = {}, Role role = Role::kPlant);

// With a bus terminal (ecu kBus): terminalsAndIcons/terminalsAndIcons.xml's text (FMI 3.0 §2.4.9; the
// terminal of FMI-LS-BUS §4.3) and the layered standard's manifest (extra/org.fmi-standard.
// fmi-ls-bus/fmi-ls-manifest.xml); FMI 3.0 only.
std::string terminals_and_icons(const Description& d);
std::string ls_bus_manifest();

// The SI unit of a signal name's suffix (speed_m_s -> "m/s"); "" for a quantity without one
// (soc, iceON, driverRequest).
std::string unit_of(std::string_view signal_name);

// The FMI unit of a message field's unit ("Nm" -> "N.m"); "" for none.
std::string fmi_unit(std::string_view field_unit);

// modelDescription.xml (FMI 3.0, co-simulation); token: the instantiationToken the library
// checks; generation_tool: "ehpt VERSION".
std::string model_description_3(const Description& d, const std::string& model_identifier, const std::string& token,
                                const std::string& generation_tool);
// The same as FMI 2.0 (co-simulation; ScalarVariable, the guid, ModelStructure by index); time
// is FMI 2.0's own (no variable).
std::string model_description_2(const Description& d, const std::string& model_identifier, const std::string& guid,
                                const std::string& generation_tool);

}  // namespace ehpt::fmu
