// SPDX-License-Identifier: BSD-3-Clause
#include "targets/fmu/fmu_description.hpp"

#include <cstdio>
#include <map>

#include "ecu/psd_ecu.hpp"
#include "ecu/shev_ems.hpp"
#include "hil/run/simulation.hpp"
#include "io/can/ls_bus.hpp"
#include "io/junit.hpp"  // xml_escape
#include "msgs/fields.hpp"

namespace ehpt::fmu {

namespace {

struct UnitRow {
  const char* suffix;
  const char* unit;
  // SI base-unit exponents kg, m, s, A, rad (what the names use), and a factor to SI
  int kg, m, s, A, rad;
  double factor;
};

// The most specific suffix first: _Nm_s_rad before _rad, _g_kWh before _g.
constexpr UnitRow kUnits[] = {
    {"_Nm_s_rad", "N.m.s/rad", 1, 2, -1, 0, -1, 1.0},
    {"_g_kWh", "g/(kW.h)", 0, -2, 2, 0, 0, 1e-3 / 3.6e6},
    {"_kg_m3", "kg/m3", 1, -3, 0, 0, 0, 1.0},
    {"_J_kg", "J/kg", 0, 2, -2, 0, 0, 1.0},
    {"_Nm_W", "N.m/W", 0, 0, 1, 0, 0, 1.0},
    {"_rad_s", "rad/s", 0, 0, -1, 0, 1, 1.0},
    {"_m_s2", "m/s2", 0, 1, -2, 0, 0, 1.0},
    {"_m_s", "m/s", 0, 1, -1, 0, 0, 1.0},
    {"_g_s", "g/s", 1, 0, -1, 0, 0, 1e-3},
    {"_kgm2", "kg.m2", 1, 2, 0, 0, 0, 1.0},
    {"_kmh", "km/h", 0, 1, -1, 0, 0, 1.0 / 3.6},
    {"_Ohm", "Ohm", 1, 2, -3, -2, 0, 1.0},
    {"_Nm", "N.m", 1, 2, -2, 0, 0, 1.0},
    {"_rad", "rad", 0, 0, 0, 0, 1, 1.0},
    {"_Wh", "W.h", 1, 2, -2, 0, 0, 3600.0},
    {"_Ah", "A.h", 0, 0, 1, 1, 0, 3600.0},
    {"_m2", "m2", 0, 2, 0, 0, 0, 1.0},
    {"_kg", "kg", 1, 0, 0, 0, 0, 1.0},
    {"_W", "W", 1, 2, -3, 0, 0, 1.0},
    {"_V", "V", 1, 2, -3, -1, 0, 1.0},
    {"_A", "A", 0, 0, 0, 1, 0, 1.0},
    {"_J", "J", 1, 2, -2, 0, 0, 1.0},
    {"_N", "N", 1, 1, -2, 0, 0, 1.0},
    {"_m", "m", 0, 1, 0, 0, 0, 1.0},
    {"_s", "s", 0, 0, 1, 0, 0, 1.0},
    {"_g", "g", 1, 0, 0, 0, 0, 1e-3},
};

const UnitRow* unit_row(std::string_view name) {
  for (const UnitRow& u : kUnits) {
    const std::string_view sfx = u.suffix;
    if (name.size() > sfx.size() && name.substr(name.size() - sfx.size()) == sfx) return &u;
  }
  return nullptr;
}

std::string number(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string unit_definitions(const Description& d) {
  std::map<std::string, const UnitRow*> units;
  for (const Variable& v : d.variables) {
    if (v.unit.empty()) continue;
    for (const UnitRow& u : kUnits) {
      if (v.unit == u.unit) units.emplace(v.unit, &u);
    }
  }
  std::string x;
  if (units.empty()) return x;
  x += "  <UnitDefinitions>\n";
  for (const auto& [name, u] : units) {
    x += "    <Unit name=\"" + io::xml_escape(name) + "\"><BaseUnit";
    if (u->kg != 0) x += " kg=\"" + std::to_string(u->kg) + "\"";
    if (u->m != 0) x += " m=\"" + std::to_string(u->m) + "\"";
    if (u->s != 0) x += " s=\"" + std::to_string(u->s) + "\"";
    if (u->A != 0) x += " A=\"" + std::to_string(u->A) + "\"";
    if (u->rad != 0) x += " rad=\"" + std::to_string(u->rad) + "\"";
    if (u->factor != 1.0) x += " factor=\"" + number(u->factor) + "\"";
    x += "/></Unit>\n";
  }
  x += "  </UnitDefinitions>\n";
  return x;
}

}  // namespace

std::string fmi_unit(std::string_view field_unit) {
  if (field_unit == "Nm") return "N.m";
  return std::string(field_unit);
}

namespace {

const char* kind_text(msgs::FieldKind k) {
  switch (k) {
    case msgs::FieldKind::kFraction:
      return " (per unit)";
    case msgs::FieldKind::kFlag:
      return " (true/false)";
    case msgs::FieldKind::kBits:
      return " (bit set: plant fault bits)";
    case msgs::FieldKind::kQuantity:
      break;
  }
  return "";
}

template <class Sensors, class Command>
void add_message_fields(Description& d, std::uint32_t& vr) {
  const auto& sensors = msgs::FieldTable<Sensors>::kFields;
  for (std::size_t i = 0; i < sensors.size(); ++i) {
    Variable v;
    v.vr = vr++;
    v.name = "sensors." + std::string(sensors[i].name);
    v.unit = fmi_unit(sensors[i].unit);
    v.description = "sensor message field " + std::string(sensors[i].name) + kind_text(sensors[i].kind) +
                    ", sampled at the communication point as an ECU reads it (sensor faults applied)";
    v.type = sensors[i].kind == msgs::FieldKind::kFlag ? Type::kBoolean : Type::kFloat64;
    v.source = Source::kSensor;
    v.index = static_cast<int>(i);
    d.variables.push_back(v);
  }
  const auto& command = msgs::FieldTable<Command>::kFields;
  for (std::size_t i = 0; i < command.size(); ++i) {
    Variable v;
    v.vr = vr++;
    v.name = "command." + std::string(command[i].name);
    v.unit = fmi_unit(command[i].unit);
    v.description = "command message field " + std::string(command[i].name) + kind_text(command[i].kind) +
                    ", acting from the start of each doStep";
    v.causality = Causality::kInput;
    v.type = command[i].kind == msgs::FieldKind::kFlag ? Type::kBoolean : Type::kFloat64;
    v.source = Source::kCommand;
    v.index = static_cast<int>(i);
    v.start = 0.0;  // the safe command: no torque, no power, engine off
    d.variables.push_back(v);
  }
}

}  // namespace

std::string unit_of(std::string_view signal_name) {
  const UnitRow* u = unit_row(signal_name);
  return u != nullptr ? u->unit : "";
}

namespace {

// The CAN terminal's four variables (FMI-LS-BUS §4.3: Rx_Data clocked by Rx_Clock, both inputs;
// Tx_Data an output clocked by Tx_Clock, a triggered output clock).
void add_bus_terminal(Description& d, std::uint32_t& vr) {
  static const char* const names[] = {"Rx_Data", "Rx_Clock", "Tx_Data", "Tx_Clock"};
  static const char* const what[] = {
      "CAN frames in: FMI-LS-BUS CAN operations (CAN Transmit of the contract's frames, Bus Error, Status)",
      "ticks when Rx_Data holds operations (triggered input clock)",
      "CAN frames out: FMI-LS-BUS CAN operations (CAN Transmit of the contract's frames; Format Error for an operation refused)",
      "ticks when Tx_Data holds operations, at the end of a doStep or in Event Mode (triggered output clock)"};
  for (int m = kRxData; m <= kTxClock; ++m) {
    Variable v;
    v.vr = vr++;
    v.name = std::string(kBusTerminal) + "." + names[m];
    v.description = what[m];
    v.causality = m == kRxData || m == kRxClock ? Causality::kInput : Causality::kOutput;
    v.type = m == kRxData || m == kTxData ? Type::kBinary : Type::kClock;
    v.source = Source::kBus;
    v.index = m;
    d.variables.push_back(v);
  }
  Variable n;
  n.vr = vr++;
  n.name = kBusNotificationsName;
  n.description = "the importer's bus sends Confirm, Arbitration Lost and Bus Error operations (set before "
                  "initialization); this FMU never waits for them, so either value is right";
  n.causality = Causality::kStructuralParameter;
  n.type = Type::kBoolean;
  n.source = Source::kBus;
  n.index = kBusNotifications;
  d.variables.push_back(n);
}

}  // namespace

Description describe(const hil::Scenario& sc, EcuMode ecu, const std::vector<std::pair<std::string, double>>& numbers,
                     Role role) {
  Description d;
  d.ecu = ecu;
  d.role = role;
  d.family = sc.ecu.holds<ecu::PsdEcuParams>()    ? MessageFamily::kPsd
             : sc.ecu.holds<ecu::ShevEmsParams>() ? MessageFamily::kShev
                                                  : MessageFamily::kEv;
  d.model_name = sc.name;
  d.description = sc.description;
  d.step_s = sc.solver.step_s;
  d.stop_s = static_cast<double>(sc.solver.steps) * sc.solver.step_s;
  Variable time;
  time.vr = 0;
  time.name = "time";
  time.unit = "s";
  time.description = "simulation time";
  time.causality = Causality::kIndependent;
  time.source = Source::kTime;
  d.variables.push_back(time);
  std::uint32_t vr = 1;
  if (role == Role::kEcu) {  // the ECU alone: its terminal is all it has
    d.model_name = sc.name + "_ecu";
    d.description = "the built-in ECU of " + sc.name + " on an FMI-LS-BUS CAN terminal";
    add_bus_terminal(d, vr);
    return d;
  }
  const std::vector<hil::SignalInfo> signals = hil::scenario_signals(sc);
  for (std::size_t i = 0; i < signals.size(); ++i) {
    if (signals[i].name == "time_s") continue;  // FMI's independent variable
    Variable v;
    v.vr = vr++;
    v.name = std::string(signals[i].name);
    v.unit = unit_of(signals[i].name);
    v.source = Source::kSignal;
    v.description = std::string(signals[i].meaning);
    v.index = static_cast<int>(i);
    d.variables.push_back(v);
  }
  if (ecu == EcuMode::kBus) add_bus_terminal(d, vr);
  if (ecu == EcuMode::kNone) {
    switch (d.family) {
      case MessageFamily::kPsd: add_message_fields<msgs::PsdSensors, msgs::PsdCommand>(d, vr); break;
      case MessageFamily::kShev: add_message_fields<msgs::ShevSensors, msgs::ShevCommand>(d, vr); break;
      case MessageFamily::kEv: add_message_fields<msgs::EvSensors, msgs::EvCommand>(d, vr); break;
    }
  }
  for (const auto& [key, value] : numbers) {
    if (key.rfind("vehicle.", 0) != 0) continue;  // the vehicle's; the solver and output are the FMU's own
    Variable v;
    v.vr = vr++;
    v.name = key;
    v.unit = unit_of(key);
    v.description = "the vehicle's " + key.substr(8) + " (--set " + key + "), checked when initialization ends";
    v.causality = Causality::kParameter;
    v.source = Source::kParameter;
    v.start = value;
    d.variables.push_back(v);
  }
  return d;
}

std::string model_description_3(const Description& d, const std::string& model_identifier, const std::string& token,
                                const std::string& generation_tool) {
  using io::xml_escape;
  std::string x = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  x += "<fmiModelDescription fmiVersion=\"3.0\" modelName=\"" + xml_escape(d.model_name) + "\" instantiationToken=\"" +
       xml_escape(token) + "\" description=\"" + xml_escape(d.description) + "\" generationTool=\"" +
       xml_escape(generation_tool) + "\" variableNamingConvention=\"flat\">\n";
  // no early return, no intermediate update: what the SIL Kit importer accepts; Event Mode only
  // with a bus terminal (FMI-LS-BUS needs it for its clocks), whose session a saved state
  // does not hold; a serialised state only with the built-in ECU (fmu_instance.hpp: SavedState)
  const bool bus = d.ecu == EcuMode::kBus;
  x += "  <CoSimulation modelIdentifier=\"" + xml_escape(model_identifier) +
       "\" canHandleVariableCommunicationStepSize=\"true\" fixedInternalStepSize=\"" + number(d.step_s) +
       "\" canBeInstantiatedOnlyOncePerProcess=\"false\" canGetAndSetFMUState=\"" + (bus ? "false" : "true") +
       "\" canSerializeFMUState=\"" + (d.ecu == EcuMode::kBuiltin ? "true" : "false") + "\""
       " providesIntermediateUpdate=\"false\" mightReturnEarlyFromDoStep=\"false\""
       " canReturnEarlyAfterIntermediateUpdate=\"false\" hasEventMode=\"" + (bus ? "true" : "false") + "\"/>\n";
  x += unit_definitions(d);
  x += "  <DefaultExperiment startTime=\"0\" stopTime=\"" + number(d.stop_s) + "\" stepSize=\"" + number(d.step_s) +
       "\"/>\n";
  x += "  <ModelVariables>\n";
  for (const Variable& v : d.variables) {
    if (v.source == Source::kBus && v.index != kBusNotifications) {
      const std::uint32_t clock = v.vr + 1;  // Rx_Data's clock follows it, as Tx_Data's does
      if (v.type == Type::kBinary) {
        x += "    <Binary name=\"" + xml_escape(v.name) + "\" valueReference=\"" + std::to_string(v.vr) +
             "\" description=\"" + xml_escape(v.description) + "\" causality=\"" +
             (v.causality == Causality::kInput ? "input" : "output") + "\" variability=\"discrete\" clocks=\"" +
             std::to_string(clock) + "\" mimeType=\"" + xml_escape(io::can::ls_bus::kMimeType) + "\" maxSize=\"" +
             std::to_string(kBusBufferBytes) + "\"" +
             (v.causality == Causality::kInput ? "><Start value=\"\"/></Binary>\n" : "/>\n");
      } else {
        x += "    <Clock name=\"" + xml_escape(v.name) + "\" valueReference=\"" + std::to_string(v.vr) +
             "\" description=\"" + xml_escape(v.description) + "\" causality=\"" +
             (v.causality == Causality::kInput ? "input" : "output") +
             "\" variability=\"discrete\" intervalVariability=\"triggered\"/>\n";
      }
      continue;
    }
    const bool boolean = v.type == Type::kBoolean;
    x += std::string("    <") + (boolean ? "Boolean" : "Float64") + " name=\"" + xml_escape(v.name) +
         "\" valueReference=\"" + std::to_string(v.vr) + "\"";
    if (!v.description.empty()) x += " description=\"" + xml_escape(v.description) + "\"";
    // a Boolean is discrete; the sensor message changes only at the ECU's samples
    const char* variability = boolean || v.source == Source::kSensor ? "discrete" : "continuous";
    switch (v.causality) {
      case Causality::kIndependent:
        x += " causality=\"independent\" variability=\"continuous\"";
        break;
      case Causality::kOutput:
        x += std::string(" causality=\"output\" variability=\"") + variability + "\"";
        break;
      case Causality::kInput:
        x += std::string(" causality=\"input\" variability=\"") + (boolean ? "discrete" : "continuous") + "\" start=\"" +
             (boolean ? (v.start != 0.0 ? "true" : "false") : number(v.start)) + "\"";
        break;
      case Causality::kParameter:
        x += " causality=\"parameter\" variability=\"fixed\" start=\"" + number(v.start) + "\"";
        break;
      case Causality::kStructuralParameter:
        x += std::string(" causality=\"structuralParameter\" variability=\"fixed\" start=\"") +
             (v.start != 0.0 ? "true" : "false") + "\"";
        break;
    }
    if (!v.unit.empty() && !boolean) x += " unit=\"" + xml_escape(v.unit) + "\"";
    x += "/>\n";
  }
  x += "  </ModelVariables>\n  <ModelStructure>\n";
  for (const Variable& v : d.variables) {
    if (v.causality == Causality::kOutput) x += "    <Output valueReference=\"" + std::to_string(v.vr) + "\"/>\n";
  }
  x += "  </ModelStructure>\n</fmiModelDescription>\n";
  return x;
}

std::string terminals_and_icons(const Description& d) {
  using io::xml_escape;
  std::string x = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<fmiTerminalsAndIcons fmiVersion=\"3.0\">\n  <Terminals>\n";
  x += std::string("    <Terminal name=\"") + kBusTerminal +
       "\" terminalKind=\"org.fmi-ls-bus.network-terminal\" matchingRule=\"org.fmi-ls-bus.transceiver\""
       " description=\"CAN: the frames of ehpt's contract (extra/org.fmi-standard.fmi-ls-bus/ehpt.dbc)\">\n";
  for (const Variable& v : d.variables) {
    if (v.source != Source::kBus || v.index == kBusNotifications) continue;
    x += "      <TerminalMemberVariable variableName=\"" + xml_escape(v.name) + "\" memberName=\"" +
         xml_escape(v.name.substr(v.name.find('.') + 1)) + "\" variableKind=\"signal\"/>\n";
  }
  return x + "    </Terminal>\n  </Terminals>\n</fmiTerminalsAndIcons>\n";
}

std::string ls_bus_manifest() {
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<fmiLayeredStandardManifest xmlns:fmi-ls=\"http://fmi-standard.org/fmi-ls-manifest\"\n"
         "    fmi-ls:fmi-ls-name=\"org.fmi-standard.fmi-ls-bus\" fmi-ls:fmi-ls-version=\"1.0.0\"\n"
         "    fmi-ls:fmi-ls-description=\"FMI-LS-BUS Network Abstraction (Low-Cut) for CAN\"\n"
         "    isBusSimulationFMU=\"false\"/>\n";
}

}  // namespace ehpt::fmu

namespace ehpt::fmu {

std::string model_description_2(const Description& d, const std::string& model_identifier, const std::string& guid,
                                const std::string& generation_tool) {
  using io::xml_escape;
  std::string x = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  x += "<fmiModelDescription fmiVersion=\"2.0\" modelName=\"" + xml_escape(d.model_name) + "\" guid=\"" +
       xml_escape(guid) + "\" description=\"" + xml_escape(d.description) + "\" generationTool=\"" +
       xml_escape(generation_tool) + "\" variableNamingConvention=\"flat\">\n";
  x += "  <CoSimulation modelIdentifier=\"" + xml_escape(model_identifier) +
       "\" canHandleVariableCommunicationStepSize=\"true\" canInterpolateInputs=\"false\""
       " canRunAsynchronuously=\"false\" canBeInstantiatedOnlyOncePerProcess=\"false\""
       " canNotUseMemoryManagementFunctions=\"true\" canGetAndSetFMUstate=\"true\" canSerializeFMUstate=\"" +
       (d.ecu == EcuMode::kBuiltin ? "true" : "false") + "\"/>\n";
  x += unit_definitions(d);
  x += "  <DefaultExperiment startTime=\"0\" stopTime=\"" + number(d.stop_s) + "\" stepSize=\"" + number(d.step_s) +
       "\"/>\n";
  x += "  <ModelVariables>\n";
  // FMI 2.0 numbers the ScalarVariables from 1 in document order (ModelStructure refers to them)
  std::vector<std::size_t> index_of(d.variables.size(), 0);
  std::size_t index = 0;
  for (const Variable& v : d.variables) {
    if (v.causality == Causality::kIndependent) continue;  // FMI 2.0 co-simulation: time is the master's
    index_of[v.vr] = ++index;
    const bool boolean = v.type == Type::kBoolean;
    x += "    <ScalarVariable name=\"" + xml_escape(v.name) + "\" valueReference=\"" + std::to_string(v.vr) + "\"";
    if (!v.description.empty()) x += " description=\"" + xml_escape(v.description) + "\"";
    const char* variability = boolean || v.source == Source::kSensor ? "discrete" : "continuous";
    if (v.causality == Causality::kParameter) {
      x += " causality=\"parameter\" variability=\"fixed\" initial=\"exact\"><Real start=\"" + number(v.start) + "\"" +
           (v.unit.empty() ? "" : " unit=\"" + xml_escape(v.unit) + "\"") + "/>";
    } else if (v.causality == Causality::kInput) {
      x += std::string(" causality=\"input\" variability=\"") + (boolean ? "discrete" : "continuous") + "\">";
      x += boolean ? std::string("<Boolean start=\"") + (v.start != 0.0 ? "true" : "false") + "\"/>"
                   : "<Real start=\"" + number(v.start) + "\"" + (v.unit.empty() ? "" : " unit=\"" + xml_escape(v.unit) + "\"") + "/>";
    } else {
      x += std::string(" causality=\"output\" variability=\"") + variability + "\" initial=\"calculated\">";
      x += boolean ? std::string("<Boolean/>") : "<Real" + (v.unit.empty() ? std::string() : " unit=\"" + xml_escape(v.unit) + "\"") + "/>";
    }
    x += "</ScalarVariable>\n";
  }
  x += "  </ModelVariables>\n  <ModelStructure>\n    <Outputs>\n";
  for (const Variable& v : d.variables) {
    if (v.causality == Causality::kOutput) x += "      <Unknown index=\"" + std::to_string(index_of[v.vr]) + "\"/>\n";
  }
  // every output is calculated at initialization: each is an initial unknown
  x += "    </Outputs>\n    <InitialUnknowns>\n";
  for (const Variable& v : d.variables) {
    if (v.causality == Causality::kOutput) x += "      <Unknown index=\"" + std::to_string(index_of[v.vr]) + "\"/>\n";
  }
  x += "    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n";
  return x;
}

}  // namespace ehpt::fmu
