// SPDX-License-Identifier: BSD-3-Clause
#include "targets/fmu/fmu_instance.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <fstream>

#include "hil/bus/bus_binding.hpp"
#include "hil/bus/bus_ecu.hpp"
#include "hil/bus/bus_plant.hpp"
#include "hil/run/batch.hpp"  // fault_text
#include "io/number_format.hpp"
#include "msgs/fields.hpp"

namespace ehpt::fmu {

namespace {

constexpr int kWarning = 1, kDiscard = 2, kError = 3;
// the steps one run() of the runner may take (its row buffer); a longer doStep loops
constexpr std::int64_t kChunkSteps = 100000;

std::string trimmed(std::string s) {
  while (!s.empty() && (s.back() == '\r' || s.back() == ' ')) s.pop_back();
  return s;
}

const char* type_name(Type t) {
  static const char* const names[] = {"Float64", "Boolean", "Binary", "Clock"};
  return names[static_cast<int>(t)];
}

}  // namespace

Instance::Instance(hil::Scenario sc, std::string scenario_path, std::vector<std::string> sets, EcuMode ecu, Role role,
                   Log log, Fmi fmi, const std::vector<std::pair<std::string, double>>& numbers)
    : sc_(std::move(sc)),
      scenario_path_(std::move(scenario_path)),
      sets_(std::move(sets)),
      log_(log),
      description_(describe(sc_, ecu, numbers, role)),
      ecu_(ecu),
      fmi_(fmi) {
  values_.assign(description_.variables.size(), 0.0);
  for (const Variable& v : description_.variables) {
    values_[v.vr] = v.start;
    if (v.source == Source::kSignal) signal_vrs_.emplace_back(v.vr, static_cast<std::size_t>(v.index));
    if (v.source == Source::kSensor) sensor_vrs_.emplace_back(v.vr, static_cast<std::size_t>(v.index));
    if (v.source == Source::kCommand) command_vrs_.emplace_back(v.vr, static_cast<std::size_t>(v.index));
  }
}

Instance::~Instance() = default;

const char* Instance::name(Call c) const {
  static const char* const fmi3[] = {"fmi3EnterInitializationMode", "fmi3ExitInitializationMode", "fmi3DoStep",
                                     "fmi3GetFloat64", "fmi3GetBoolean", "fmi3SetFloat64", "fmi3SetBoolean",
                                     "fmi3Terminate", "fmi3Reset", "fmi3GetFMUState", "fmi3SetFMUState"};
  static const char* const fmi2[] = {"fmi2EnterInitializationMode", "fmi2ExitInitializationMode", "fmi2DoStep",
                                     "fmi2GetReal", "fmi2GetBoolean", "fmi2SetReal", "fmi2SetBoolean",
                                     "fmi2Terminate", "fmi2Reset", "fmi2GetFMUstate", "fmi2SetFMUstate"};
  return (fmi_ == Fmi::k3 ? fmi3 : fmi2)[static_cast<int>(c)];
}

std::unique_ptr<Instance> Instance::make(const std::string& resource_dir, const std::string& token, Log log, Fmi fmi) {
  std::string dir = resource_dir;
  if (!dir.empty() && dir.back() != '/') dir += '/';
  const std::string manifest = dir + kManifestName;
  std::ifstream in(manifest);
  if (!in) {
    log(kError, "logStatusError", manifest + ": cannot read it (is resourcePath this FMU's resources folder?)");
    return nullptr;
  }
  std::string line, own_token, scenario;
  std::vector<std::string> sets, faults;
  EcuMode ecu = EcuMode::kBuiltin;
  Role role = Role::kPlant;
  while (std::getline(in, line)) {
    line = trimmed(line);
    if (line.rfind("token ", 0) == 0) own_token = line.substr(6);
    if (line.rfind("scenario ", 0) == 0) scenario = line.substr(9);
    if (line.rfind("set ", 0) == 0) sets.push_back(line.substr(4));
    if (line.rfind("fault ", 0) == 0) faults.push_back(line.substr(6));
    if (line == "ecu none") ecu = EcuMode::kNone;
    if (line == "bus ls-bus") ecu = EcuMode::kBus;
    if (line == "role ecu") role = Role::kEcu;
  }
  if (role == Role::kEcu && ecu != EcuMode::kBus) {
    log(kError, "logStatusError", manifest + ": 'role ecu' without 'bus ls-bus' (the FMU is damaged)");
    return nullptr;
  }
  if (own_token.empty() || scenario.empty()) {
    log(kError, "logStatusError", manifest + ": no 'token' or 'scenario' line (the FMU is damaged)");
    return nullptr;
  }
  if (token != own_token) {
    log(kError, "logStatusError",
        std::string(fmi == Fmi::k3 ? "instantiationToken" : "guid") + " \"" + token + "\" is not this FMU's (\"" + own_token +
            "\"): the modelDescription.xml and the resources are of different FMUs");
    return nullptr;
  }
  hil::Scenario sc;
  std::vector<std::string> errors;
  std::vector<std::pair<std::string, double>> numbers;  // the parameters, as ehpt fmu described them
  if (!hil::load_scenario(dir + scenario, sets, faults, sc, errors) ||
      !hil::scenario_numbers(dir + scenario, sets, numbers, errors)) {
    for (const std::string& e : errors) log(kError, "logStatusError", e);
    return nullptr;
  }
  std::unique_ptr<Instance> made(new Instance(std::move(sc), dir + scenario, std::move(sets), ecu, role, log, fmi, numbers));
  made->token_ = own_token;
  made->faults_ = std::move(faults);
  return made;
}

bool Instance::fail(const std::string& message) {
  log_(kError, "logStatusError", message);
  state_ = State::kError;
  return false;
}

bool Instance::in(State s, const char* call) {
  if (state_ == s) return true;
  static const char* const names[] = {"Instantiated", "Initialization Mode", "Step Mode", "Event Mode", "Terminated",
                                      "an error"};
  return fail(std::string(call) + " called in " + names[static_cast<int>(state_)] + " (FMI's calling sequence)");
}

bool Instance::enter_initialization(bool stop_defined, double start_s, double stop_s) {
  if (!in(State::kInstantiated, name(Call::kEnterInitialization))) return false;
  if (!std::isfinite(start_s) || start_s != 0.0) {
    return fail("startTime = " + io::number_text(start_s) + ": an ehpt FMU starts at 0 s (its cycle's start)");
  }
  stop_s_ = description_.stop_s;
  if (stop_defined) {
    if (!std::isfinite(stop_s) || stop_s <= 0.0) return fail("stopTime = " + io::number_text(stop_s) + ": must be > 0 s");
    if (stop_s != stop_s_) {  // the scenario again, with the importer's stop time
      stop_set_ = "solver.duration_s=" + io::number_text(stop_s);
      if (!reload(name(Call::kEnterInitialization))) return false;
      stop_s_ = static_cast<double>(sc_.solver.steps) * sc_.solver.step_s;
    }
  }
  state_ = State::kInitialization;
  return true;
}

namespace {
// f(sensors, command, sensor field table, command field table) of the description's family
template <class F>
void with_messages(MessageFamily family, Messages& m, F&& f) {
  switch (family) {
    case MessageFamily::kPsd: f(m.psd_sensors, m.psd_command, msgs::kPsdSensorFieldTable, msgs::kPsdCommandFieldTable); return;
    case MessageFamily::kShev:
      f(m.shev_sensors, m.shev_command, msgs::kShevSensorFieldTable, msgs::kShevCommandFieldTable);
      return;
    case MessageFamily::kEv: f(m.ev_sensors, m.ev_command, msgs::kEvSensorFieldTable, msgs::kEvCommandFieldTable); return;
  }
}
}  // namespace

void Instance::refresh_outputs() {
  const std::span<const double> y = sim_->outputs();
  for (const auto& [vr, i] : signal_vrs_) values_[vr] = y[i];
  if (ecu_ != EcuMode::kNone) return;
  with_messages(description_.family, messages_, [&](auto& sensors, auto&, const auto& sensor_table, const auto&) {
    sim_->read_sensors(sensors);
    for (const auto& [vr, i] : sensor_vrs_) values_[vr] = sensor_table[i].get(sensors);
  });
}

void Instance::apply_inputs() {
  with_messages(description_.family, messages_,
                [&](auto& sensors, auto& command, const auto&, const auto& command_table) {
                  for (const auto& [vr, i] : command_vrs_) command_table[i].set(command, values_[vr]);
                  command.stamp = sensors.stamp;  // the sample it answers
                  sim_->write_command(command);
                });
}

bool Instance::reload(const char* call) {
  std::vector<std::string> sets = sets_;
  if (!stop_set_.empty()) sets.push_back(stop_set_);
  std::string changed;
  for (const Variable& v : description_.variables) {
    const double now = values_[v.vr];
    if (v.source != Source::kParameter || std::memcmp(&now, &v.start, sizeof now) == 0) continue;
    sets.push_back(v.name + "=" + io::number_text(now));  // shortest round trip: the value exactly
    changed += (changed.empty() ? "" : ", ") + v.name + " = " + io::number_text(now);
  }
  std::vector<std::string> errors;
  hil::Scenario sc;
  if (!hil::load_scenario(scenario_path_, sets, faults_, sc, errors)) {
    for (const std::string& e : errors) log_(kError, "logStatusError", e);
    return fail(std::string(call) + ": the scenario does not load with " +
                (changed.empty() ? std::string("the importer's stop time") : "the parameters set (" + changed + ")") +
                " (the problems above)");
  }
  sc_ = std::move(sc);
  return true;
}

bool Instance::exit_initialization() {
  if (!in(State::kInitialization, name(Call::kExitInitialization))) return false;
  // parameters the importer changed: the scenario loaded again with them, checked as ehpt run does
  bool changed = false;
  for (const Variable& v : description_.variables) {
    const double now = values_[v.vr];
    changed = changed || (v.source == Source::kParameter && std::memcmp(&now, &v.start, sizeof now) != 0);
  }
  if (changed && !reload(name(Call::kExitInitialization))) return false;
  if (description_.role == Role::kEcu) {  // the ECU alone: no plant to build
    ecu_steps_ = sc_.solver.steps;
    if (!make_bus(name(Call::kExitInitialization))) return false;
    state_ = State::kEvent;  // FMI 3.0 co-simulation with eventModeUsed: Event Mode follows initialization
    return true;
  }
  hil::SimulationOptions opt;
  opt.columns = {0};  // the runner records time only: the FMU's outputs are read at each point
  opt.chunk_steps = kChunkSteps;
  opt.external_ecu = ecu_ != EcuMode::kBuiltin;
  sim_ = hil::make_simulation(sc_, opt);
  if (!sim_) return fail(sc_.name + ": the simulation cannot be built");
  if (has_bus() && !make_bus(name(Call::kExitInitialization))) return false;
  if (has_bus()) publish_tx();  // sample 0: Tx_Clock ticks in the Event Mode that follows
  refresh_outputs();
  state_ = has_bus() ? State::kEvent : State::kStep;
  return true;
}

bool Instance::make_bus(const char* call) {
  terminal_ = std::make_unique<io::can::ls_bus::LsBusTerminal>(kBusBufferBytes);
  tx_out_.assign(kBusBufferBytes, 0);
  tx_out_.clear();  // its capacity stays: get_binary copies into it without allocating
  std::string why;
  if (description_.role == Role::kEcu) {
    if (!hil::has_bus_ecu(sc_, why)) return fail(std::string(call) + ": " + why);
    ecu_node_ = hil::make_can_ecu_node(sc_, *terminal_);
    return ecu_node_ ? true : fail(std::string(call) + ": " + sc_.name + ": no built-in ECU to put on the bus");
  }
  std::vector<std::string> errors;
  std::optional<hil::Binding> binding = hil::default_binding(hil::bus_family(sc_), sc_.ecu_timing.period_s, errors);
  if (!binding) return fail(std::string(call) + ": " + (errors.empty() ? std::string("no binding") : errors.front()));
  hil::BusPlantOptions opt;
  opt.event_mode = true;  // the command of a sample comes in the Event Mode after the doStep that reached it
  opt.lockstep_wait_s = 0.0;
  opt.peer_wait_s = 0.0;
  opt.log_interface = "fmi-ls-bus";
  opt.scenario_path = scenario_path_;
  bus_plant_ = hil::make_bus_plant(sc_, *terminal_, opt, std::move(*binding), why);
  if (!bus_plant_) return fail(std::string(call) + ": " + why);
  bus_plant_->discard_files();  // an FMU writes no files: its figures are logged at terminate
  bus_plant_->start(*sim_, nullptr);
  if (!bus_plant_->flush(why)) return fail(std::string(call) + ": " + why);  // e.g. the plant not on its port
  return true;
}

bool Instance::do_step(double current_s, double step_s, double& reached_s, bool& stopped, bool& event) {
  stopped = false;
  event = false;
  if (!in(State::kStep, name(Call::kDoStep))) return false;
  const double h = sc_.solver.step_s;
  const std::int64_t now = sim_ ? sim_->step_index() : ecu_step_;
  const std::int64_t total = sim_ ? sim_->total_steps() : ecu_steps_;
  const double now_s = sim_ ? sim_->time_s() : static_cast<double>(ecu_step_) * h;
  reached_s = now_s;
  // the importer's grid must be the plant's: whole steps, within a small tolerance
  if (!std::isfinite(current_s) || std::abs(current_s - now_s) > 1e-9 * std::max(1.0, std::abs(now_s))) {
    return fail(std::string(name(Call::kDoStep)) + ": currentCommunicationPoint = " + io::number_text(current_s) + " s, but the FMU is at " +
                io::number_text(now_s) + " s");
  }
  if (!std::isfinite(step_s) || step_s <= 0.0) {
    return fail(std::string(name(Call::kDoStep)) + ": communicationStepSize = " + io::number_text(step_s) + ": must be > 0");
  }
  const double steps = step_s / h;
  const double whole = std::nearbyint(steps);
  if (whole < 1.0 || std::abs(steps - whole) > 1e-6 || whole > 9.0e15) {
    return fail(std::string(name(Call::kDoStep)) + ": communicationStepSize = " + io::number_text(step_s) + " s is not a whole number of plant steps (" +
                io::number_text(h) + " s): use a multiple of it");
  }
  const std::int64_t n = static_cast<std::int64_t>(whole);
  if (n > total - now) {
    return fail(std::string(name(Call::kDoStep)) + ": to " + io::number_text(now_s + step_s) + " s, past the stop time " + io::number_text(stop_s_) +
                " s (" + (fmi_ == Fmi::k3 ? "stopTime of fmi3EnterInitializationMode" : "stopTime of fmi2SetupExperiment") +
                " sets it)");
  }
  if (description_.role == Role::kEcu) {  // the ECU's time: it acts in Event Mode only
    ecu_step_ += n;
    reached_s = static_cast<double>(ecu_step_) * h;
    event = publish_tx() || tx_clock_;  // what it has not handed over yet (an importer that skipped a tick)
    return true;
  }
  if (has_bus()) {  // a sample's frames go out when a doStep ends on it: no doStep may pass one
    const std::int64_t ratio = sc_.solver.ecu_ratio;
    const std::int64_t next = (now / ratio + 1) * ratio;
    if (now + n > next) {
      return fail(std::string(name(Call::kDoStep)) + ": from " + io::number_text(now_s) + " s to " +
                  io::number_text(now_s + step_s) + " s passes the ECU sample at " +
                  io::number_text(static_cast<double>(next) * h) + " s: the bus's frames go out at communication points, "
                  "so each ECU sample (every " + io::number_text(sc_.ecu_timing.period_s) + " s) must be one "
                  "(a communicationStepSize that divides the ECU period)");
    }
  }
  if (ecu_ == EcuMode::kNone) apply_inputs();  // the inputs act over this step
  std::int64_t left = n;
  while (left > 0 && !sim_->finished()) {
    const std::int64_t k = sim_->step(std::min(left, kChunkSteps));
    sim_->clear_rows();
    if (k <= 0) break;
    left -= k;
  }
  if (bus_plant_) bus_plant_->send_ahead();  // it stopped at a sample: its frames go out now
  event = publish_tx() || tx_clock_;  // a tick now, or one the importer has not fetched
  refresh_outputs();
  reached_s = sim_->time_s();
  if (left > 0) {  // the plant stopped on a fault (FaultPolicy::kStop), as ehpt run does
    stopped = true;
    state_ = State::kTerminated;
    log_(kDiscard, "logStatusDiscard",
         sc_.name + ": the plant stopped on a fault at t = " + io::number_text(sim_->stats().fault_time_s) + " s: " +
             hil::fault_text(sim_->stats().fault) + " (the output 'fault' has its bits)");
  }
  return true;
}

template <class T>
bool Instance::get_values(const char* call, Type type, const std::uint32_t* vrs, std::size_t n, T* values,
                          std::size_t n_values) {
  if (state_ == State::kError) return false;
  if (n != n_values || (n > 0 && (vrs == nullptr || values == nullptr))) {
    return fail(std::string(call) + ": " + std::to_string(n) + " value references but room for " +
                std::to_string(n_values) + " values (every variable is a scalar)");
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (vrs[i] >= values_.size()) {
      return fail(std::string(call) + ": value reference " + std::to_string(vrs[i]) + " is not one of this FMU's (0 .. " +
                  std::to_string(values_.size() - 1) + ")");
    }
    const Variable& v = description_.variables[vrs[i]];
    if (v.type != type) {
      return fail(std::string(call) + ": " + v.name + " (value reference " + std::to_string(v.vr) + ") is a " +
                  type_name(v.type) + " variable");
    }
    const double x = v.source == Source::kTime ? (sim_ ? sim_->time_s() : static_cast<double>(ecu_step_) * sc_.solver.step_s)
                                               : values_[vrs[i]];
    if constexpr (std::is_same_v<T, bool>) {
      values[i] = x != 0.0;
    } else {
      values[i] = x;
    }
  }
  return true;
}

template <class T>
bool Instance::set_values(const char* call, Type type, const std::uint32_t* vrs, std::size_t n, const T* values,
                          std::size_t n_values) {
  if (state_ != State::kInstantiated && state_ != State::kInitialization && state_ != State::kStep) {
    return in(State::kStep, call);
  }
  if (n != n_values || (n > 0 && (vrs == nullptr || values == nullptr))) {
    return fail(std::string(call) + ": " + std::to_string(n) + " value references but " + std::to_string(n_values) +
                " values (every variable is a scalar)");
  }
  // all checked before any is applied: a refused call changes nothing
  for (std::size_t i = 0; i < n; ++i) {
    if (vrs[i] >= values_.size()) {
      return fail(std::string(call) + ": value reference " + std::to_string(vrs[i]) + " is not one of this FMU's");
    }
    const Variable& v = description_.variables[vrs[i]];
    if (v.causality == Causality::kParameter && state_ == State::kStep) {
      return fail(std::string(call) + ": " + v.name + " is a fixed parameter: set it before " +
                  name(Call::kExitInitialization));
    }
    if (v.causality == Causality::kStructuralParameter && state_ != State::kInstantiated) {
      return fail(std::string(call) + ": " + v.name + " is a structural parameter: set it before " +
                  name(Call::kEnterInitialization));
    }
    if (v.causality != Causality::kInput && v.causality != Causality::kParameter &&
        v.causality != Causality::kStructuralParameter) {
      return fail(std::string(call) + ": " + v.name + " is an output" +
                  (ecu_ == EcuMode::kBuiltin ? " (this FMU has no inputs: its built-in ECU drives the plant; "
                                               "`ehpt fmu --ecu none` makes the command fields inputs)"
                                             : ""));
    }
    if (v.type != type) {
      return fail(std::string(call) + ": " + v.name + " is a " + type_name(v.type) + " variable");
    }
    if constexpr (std::is_floating_point_v<T>) {
      if (!std::isfinite(values[i])) {
        return fail(std::string(call) + ": " + v.name + " = " + io::number_text(values[i]) +
                    ": not a finite number (refused, not applied)");
      }
    }
  }
  for (std::size_t i = 0; i < n; ++i) values_[vrs[i]] = static_cast<double>(values[i]);
  return true;
}

bool Instance::get_float64(const std::uint32_t* vrs, std::size_t n, double* values, std::size_t n_values) {
  return get_values(name(Call::kGetReal), Type::kFloat64, vrs, n, values, n_values);
}
bool Instance::get_boolean(const std::uint32_t* vrs, std::size_t n, bool* values, std::size_t n_values) {
  return get_values(name(Call::kGetBoolean), Type::kBoolean, vrs, n, values, n_values);
}
bool Instance::set_float64(const std::uint32_t* vrs, std::size_t n, const double* values, std::size_t n_values) {
  return set_values(name(Call::kSetReal), Type::kFloat64, vrs, n, values, n_values);
}
bool Instance::set_boolean(const std::uint32_t* vrs, std::size_t n, const bool* values, std::size_t n_values) {
  return set_values(name(Call::kSetBoolean), Type::kBoolean, vrs, n, values, n_values);
}

bool Instance::get_state(std::unique_ptr<SavedState>& out) {
  if (has_bus()) {
    return fail(std::string(name(Call::kGetState)) + ": not with a bus terminal (canGetAndSetFMUState = false): the "
                "bus session (command timeouts, the frames' counters) is not in a saved state");
  }
  if (state_ != State::kStep && state_ != State::kTerminated) return in(State::kStep, name(Call::kGetState));
  if (!out) out = std::make_unique<SavedState>();
  out->sim = sim_->save_state();
  if (!out->sim) return fail(std::string(name(Call::kGetState)) + ": this simulation cannot save its state");
  out->values = values_;
  out->messages = messages_;
  out->state = static_cast<int>(state_);
  out->stop_s = stop_s_;
  // the way here, for a serialised state: the settings the simulation was built with, the step
  out->step = sim_->step_index();
  out->sets.clear();
  if (!stop_set_.empty()) out->sets.push_back(stop_set_);
  for (const Variable& v : description_.variables) {
    const double now = values_[v.vr];
    if (v.source == Source::kParameter && std::memcmp(&now, &v.start, sizeof now) != 0) {
      out->sets.push_back(v.name + "=" + io::number_text(now));
    }
  }
  out->digest = outputs_digest();
  out->bytes.clear();
  return true;
}

std::uint64_t Instance::outputs_digest() const {
  std::uint64_t h = 14695981039346656037ull;  // FNV-1a over the bytes of the doubles
  const auto mix = [&](double x) {
    unsigned char b[sizeof x];
    std::memcpy(b, &x, sizeof x);
    for (const unsigned char c : b) h = (h ^ c) * 1099511628211ull;
  };
  mix(sim_ ? sim_->time_s() : 0.0);
  for (const auto& [vr, i] : signal_vrs_) mix(values_[vr]);
  return h;
}

bool Instance::serialize(SavedState& saved) {
  const char* call = fmi_ == Fmi::k3 ? "fmi3SerializeFMUState" : "fmi2SerializeFMUstate";
  if (ecu_ != EcuMode::kBuiltin) {
    return fail(std::string(call) + ": not for an FMU without its built-in ECU (canSerializeFMUState = false): its state "
                "depends on the inputs the importer gave, which the FMU does not keep; fmi3GetFMUState works");
  }
  if (!saved.bytes.empty()) return true;
  std::string b = "ehpt-fmu-state 1\ntoken " + token_ + "\nstep " + std::to_string(saved.step) + "\nstate " +
                  std::to_string(saved.state) + "\ndigest " + std::to_string(saved.digest) + "\n";
  for (const std::string& set : saved.sets) b += "set " + set + "\n";
  saved.bytes = std::move(b);
  return true;
}

bool Instance::deserialize(const std::uint8_t* bytes, std::size_t n, std::unique_ptr<SavedState>& out) {
  const char* call = fmi_ == Fmi::k3 ? "fmi3DeserializeFMUState" : "fmi2DeSerializeFMUstate";
  if (ecu_ != EcuMode::kBuiltin) {
    return fail(std::string(call) + ": not for an FMU without its built-in ECU (canSerializeFMUState = false)");
  }
  if (bytes == nullptr || n == 0 || n > (1u << 20)) {
    return fail(std::string(call) + ": " + std::to_string(n) + " bytes: not a serialised state of an ehpt FMU");
  }
  const std::string text(reinterpret_cast<const char*>(bytes), n);
  auto s = std::make_unique<SavedState>();
  std::size_t at = 0;
  int line_no = 0;
  bool magic = false, token = false, step = false, state = false, digest = false;
  while (at < text.size()) {
    const std::size_t end = text.find('\n', at);
    const std::string line = text.substr(at, end == std::string::npos ? std::string::npos : end - at);
    at = end == std::string::npos ? text.size() : end + 1;
    ++line_no;
    const auto whole = [&](const std::string& v, std::int64_t lo, std::int64_t hi, std::int64_t& x) {
      char* stop = nullptr;
      errno = 0;
      const long long y = std::strtoll(v.c_str(), &stop, 10);
      if (v.empty() || *stop != '\0' || errno != 0 || y < lo || y > hi) return false;
      x = y;
      return true;
    };
    bool ok = true;
    std::int64_t x = 0;
    if (line_no == 1) {
      ok = magic = line == "ehpt-fmu-state 1";
    } else if (line.rfind("token ", 0) == 0) {
      ok = token = line.substr(6) == token_;
      if (!ok) return fail(std::string(call) + ": a state of another FMU (token " + line.substr(6) + ", this one " + token_ + ")");
    } else if (line.rfind("step ", 0) == 0) {
      ok = step = whole(line.substr(5), 0, std::numeric_limits<std::int64_t>::max(), s->step);
    } else if (line.rfind("state ", 0) == 0) {
      ok = state = whole(line.substr(6), static_cast<int>(State::kStep), static_cast<int>(State::kTerminated), x) &&
                   x != static_cast<int>(State::kEvent);
      s->state = static_cast<int>(x);
    } else if (line.rfind("digest ", 0) == 0) {
      char* stop = nullptr;
      errno = 0;
      const std::string v = line.substr(7);
      s->digest = std::strtoull(v.c_str(), &stop, 10);
      ok = digest = !v.empty() && v[0] != '-' && *stop == '\0' && errno == 0;
    } else if (line.rfind("set ", 0) == 0) {
      s->sets.push_back(line.substr(4));
    } else {
      ok = false;
    }
    if (!ok) return fail(std::string(call) + ": line " + std::to_string(line_no) + " (\"" + line.substr(0, 60) + "\") is not a serialised state's");
  }
  if (!(magic && token && step && state && digest)) {
    return fail(std::string(call) + ": incomplete (it needs the lines ehpt-fmu-state, token, step, state, digest)");
  }
  s->bytes = text;
  out = std::move(s);
  return true;
}

bool Instance::restore_by_rerun(const SavedState& saved) {
  const char* call = name(Call::kSetState);
  std::vector<std::string> sets = sets_;
  std::string stop_set;
  std::vector<std::pair<std::uint32_t, double>> parameters;
  for (const std::string& set : saved.sets) {
    sets.push_back(set);
    const std::size_t eq = set.find('=');
    const std::string key = set.substr(0, eq);
    if (key == "solver.duration_s") {
      stop_set = set;
      continue;
    }
    const auto v = std::find_if(description_.variables.begin(), description_.variables.end(),
                                [&](const Variable& x) { return x.source == Source::kParameter && x.name == key; });
    char* stop = nullptr;
    const double value = eq == std::string::npos ? NAN : std::strtod(set.c_str() + eq + 1, &stop);
    if (v == description_.variables.end() || !std::isfinite(value) || *stop != '\0') {
      return fail(std::string(call) + ": the state sets \"" + set + "\", not a parameter of this FMU");
    }
    parameters.emplace_back(v->vr, value);
  }
  hil::Scenario sc;
  std::vector<std::string> errors;
  if (!hil::load_scenario(scenario_path_, sets, faults_, sc, errors)) {
    for (const std::string& e : errors) log_(kError, "logStatusError", e);
    return fail(std::string(call) + ": the state's scenario does not load (the problems above)");
  }
  hil::SimulationOptions opt;
  opt.columns = {0};
  opt.chunk_steps = kChunkSteps;
  std::unique_ptr<hil::Simulation> sim = hil::make_simulation(sc, opt);
  if (!sim || saved.step > sim->total_steps()) {
    return fail(std::string(call) + ": step " + std::to_string(saved.step) + " is past this scenario's end");
  }
  std::int64_t left = saved.step;  // the way there: the same steps, so the same state (the run is deterministic)
  while (left > 0 && !sim->finished()) {
    const std::int64_t k = sim->step(std::min(left, kChunkSteps));
    sim->clear_rows();
    if (k <= 0) break;
    left -= k;
  }
  sc_ = std::move(sc);
  sim_ = std::move(sim);
  stop_set_ = stop_set;
  stop_s_ = static_cast<double>(sc_.solver.steps) * sc_.solver.step_s;
  for (const Variable& v : description_.variables) {
    if (v.source == Source::kParameter) values_[v.vr] = v.start;
  }
  for (const auto& [vr, value] : parameters) values_[vr] = value;
  refresh_outputs();
  if (left > 0 || outputs_digest() != saved.digest) {
    return fail(std::string(call) + ": the state does not run again to the same point (" +
                (left > 0 ? "the plant stopped " + std::to_string(left) + " steps before it" : std::string("its outputs differ")) +
                "): a state of another build or a damaged one");
  }
  state_ = static_cast<State>(saved.state);
  return true;
}

bool Instance::set_state(const SavedState& saved) {
  if (has_bus()) return fail(std::string(name(Call::kSetState)) + ": not with a bus terminal (canGetAndSetFMUState = false)");
  if (state_ != State::kStep && state_ != State::kTerminated) return in(State::kStep, name(Call::kSetState));
  if (!saved.sim && !saved.bytes.empty()) return restore_by_rerun(saved);  // a deserialised state
  if (!saved.sim || saved.values.size() != values_.size() || !sim_->restore_state(*saved.sim)) {
    return fail(std::string(name(Call::kSetState)) + ": not a state of this FMU");
  }
  values_ = saved.values;
  messages_ = saved.messages;
  state_ = static_cast<State>(saved.state);
  stop_s_ = saved.stop_s;
  return true;
}

bool Instance::terminate() {
  if (state_ == State::kTerminated) return true;  // after a plant fault ended it (Discard): the importer's terminate
  if (state_ != State::kStep && state_ != State::kEvent && state_ != State::kInitialization) {
    return in(State::kStep, name(Call::kTerminate));
  }
  state_ = State::kTerminated;
  if (bus_plant_) {  // the session's figures, and why it did not do what a session must (a Warning)
    io::JsonObject summary;
    std::string text;
    bus_plant_->report(summary, text);
    while (!text.empty() && text.back() == '\n') text.pop_back();
    log_(0, "logEvents", text);
    for (const std::string& why : bus_plant_->degraded_reasons()) {
      degraded_ = true;
      log_(kWarning, "logStatusWarning", sc_.name + ": the bus session is degraded: " + why);
    }
  }
  if (ecu_node_ && ecu_node_->samples_answered() == 0) {  // an ECU that never heard its plant did not do its job
    degraded_ = true;
    log_(kWarning, "logStatusWarning",
         sc_.name + ": the ECU's bus session is degraded: no plant: not one complete sample came, none answered");
  }
  return true;
}

bool Instance::reset() {
  bus_plant_.reset();  // each refers to what follows: the driver to the simulation, both to the terminal
  ecu_node_.reset();
  sim_.reset();
  terminal_.reset();
  rx_clock_ = rx_came_ = degraded_ = tx_clock_ = false;
  tx_out_.clear();
  ecu_step_ = 0;
  std::vector<std::string> errors;
  hil::Scenario sc;
  if (!hil::load_scenario(scenario_path_, sets_, faults_, sc, errors)) {
    for (const std::string& e : errors) log_(kError, "logStatusError", e);
    return fail(std::string(name(Call::kReset)) + ": the scenario no longer loads");
  }
  sc_ = std::move(sc);
  stop_set_.clear();
  for (const Variable& v : description_.variables) values_[v.vr] = v.start;
  messages_ = {};
  state_ = State::kInstantiated;
  return true;
}

// --- Event Mode and the bus terminal (FMI 3.0 §3.2.x, FMI-LS-BUS §4) ---

bool Instance::enter_event_mode() {
  if (!has_bus()) return fail("fmi3EnterEventMode: this FMU has no Event Mode (hasEventMode = false)");
  if (!in(State::kStep, "fmi3EnterEventMode")) return false;
  state_ = State::kEvent;
  return true;
}

bool Instance::enter_step_mode() {
  if (!has_bus()) return fail("fmi3EnterStepMode: this FMU has no Event Mode (Step Mode follows initialization)");
  if (!in(State::kEvent, "fmi3EnterStepMode")) return false;
  rx_clock_ = false;  // an input clock ticks for one Event Mode
  // a sample whose command did not come in the Event Mode: the plant goes on without it (a
  // late command), as the next doStep would, so the outputs here are those of this point
  if (sim_ && !sim_->finished() && sim_->exchange_now()) refresh_outputs();
  state_ = State::kStep;
  return true;
}

// Tx_Data as FMI-LS-BUS's triggered Tx_Clock hands it over: the operations sent since the last
// tick become its value (after what an importer has not fetched yet, if it skipped a tick), and
// Tx_Clock is active until fmi3GetClock reports it, once. The value stays the same for every
// fmi3GetBinary until the next tick, so an importer may read it once per connection. True if
// there were new operations (a tick now).
bool Instance::publish_tx() {
  if (!terminal_) return false;
  const std::span<const std::uint8_t> tx = terminal_->tx();
  if (tx.empty()) return false;
  if (!tx_clock_) tx_out_.clear();  // the last value was fetched: a new one
  if (tx_out_.size() + tx.size() > tx_out_.capacity()) {
    ++tx_dropped_;
    log_(kWarning, "logStatusWarning",
         "CAN.Tx_Data: " + std::to_string(tx.size()) + " bytes of operations dropped: the importer did not fetch the " +
             std::to_string(tx_out_.size()) + " before them (Tx_Clock ticked and fmi3GetClock never reported it)");
  } else {
    tx_out_.insert(tx_out_.end(), tx.begin(), tx.end());  // within its capacity: no allocation
  }
  terminal_->clear_tx();
  tx_clock_ = true;
  return true;
}

bool Instance::update_discrete_states(bool& need_update) {
  need_update = false;
  if (!has_bus()) return fail("fmi3UpdateDiscreteStates: this FMU has no Event Mode");
  if (!in(State::kEvent, "fmi3UpdateDiscreteStates")) return false;
  if (!rx_came_) return true;
  rx_came_ = false;
  if (ecu_node_) {
    ecu_node_->poll();  // each complete sample answered: its command frames in Tx_Data
  } else {
    // the command of the sample the plant stopped at: applied, and the outputs there with it
    if (!sim_->finished()) sim_->exchange_now();
    refresh_outputs();
  }
  // new operations (the ECU's commands, a Format Error): Tx_Clock ticks, and the importer is
  // asked to go round once more, to hand them on
  need_update = publish_tx();
  return true;
}

const Variable* Instance::bus_variable(const char* call, std::uint32_t vr, Type type) {
  if (vr >= description_.variables.size()) {
    fail(std::string(call) + ": value reference " + std::to_string(vr) + " is not one of this FMU's");
    return nullptr;
  }
  const Variable& v = description_.variables[vr];
  if (v.type != type) {
    fail(std::string(call) + ": " + v.name + " (value reference " + std::to_string(vr) + ") is a " + type_name(v.type) +
         " variable" + (has_bus() ? "" : " (this FMU has no Binary or Clock variable: `ehpt fmu --bus ls-bus` gives a CAN terminal)"));
    return nullptr;
  }
  return &v;
}

bool Instance::get_clock(const std::uint32_t* vrs, std::size_t n, bool* active) {
  if (state_ == State::kError) return false;
  for (std::size_t i = 0; i < n; ++i) {
    const Variable* v = bus_variable("fmi3GetClock", vrs[i], Type::kClock);
    if (v == nullptr) return false;
    if (v->index == kTxClock) {
      active[i] = tx_clock_;
      tx_clock_ = false;  // reported once per tick (its value, Tx_Data, stays until the next)
    } else {
      active[i] = rx_clock_;
    }
  }
  return true;
}

bool Instance::set_clock(const std::uint32_t* vrs, std::size_t n, const bool* active) {
  if (state_ == State::kError) return false;
  for (std::size_t i = 0; i < n; ++i) {
    const Variable* v = bus_variable("fmi3SetClock", vrs[i], Type::kClock);
    if (v == nullptr) return false;
    if (v->index != kRxClock) return fail("fmi3SetClock: " + v->name + " is an output clock (the FMU ticks it)");
    if (!in(State::kEvent, "fmi3SetClock")) return false;
    rx_clock_ = active[i];
  }
  return true;
}

bool Instance::get_binary(const std::uint32_t* vrs, std::size_t n, std::size_t* sizes, const std::uint8_t** values,
                          std::size_t n_values) {
  if (state_ == State::kError) return false;
  if (n != n_values) return fail("fmi3GetBinary: " + std::to_string(n) + " value references but room for " + std::to_string(n_values) + " values");
  for (std::size_t i = 0; i < n; ++i) {
    const Variable* v = bus_variable("fmi3GetBinary", vrs[i], Type::kBinary);
    if (v == nullptr) return false;
    if (v->index != kTxData) return fail("fmi3GetBinary: " + v->name + " is an input");
    sizes[i] = tx_out_.size();  // the last tick's operations (publish_tx), the same at every call
    values[i] = tx_out_.data();
  }
  return true;
}

bool Instance::set_binary(const std::uint32_t* vrs, std::size_t n, const std::size_t* sizes,
                          const std::uint8_t* const* values, std::size_t n_values) {
  if (state_ == State::kError) return false;
  if (n != n_values) return fail("fmi3SetBinary: " + std::to_string(n) + " value references but " + std::to_string(n_values) + " values");
  for (std::size_t i = 0; i < n; ++i) {
    const Variable* v = bus_variable("fmi3SetBinary", vrs[i], Type::kBinary);
    if (v == nullptr) return false;
    if (v->index != kRxData) return fail("fmi3SetBinary: " + v->name + " is an output");
    if (!in(State::kEvent, "fmi3SetBinary")) return false;
    if (sizes[i] > kBusBufferBytes || (sizes[i] > 0 && values[i] == nullptr)) {
      return fail("fmi3SetBinary: " + v->name + " of " + std::to_string(sizes[i]) + " bytes (maxSize " +
                  std::to_string(kBusBufferBytes) + ")");
    }
    const io::can::ls_bus::RxCounts c = terminal_->take_rx({values[i], sizes[i]});
    if (c.malformed > 0) {
      log_(kWarning, "logStatusWarning",
           v->name + ": " + std::to_string(c.malformed) + " operation(s) that are not FMI-LS-BUS CAN (" +
               std::to_string(sizes[i]) + " bytes): ignored, each answered by a Format Error in Tx_Data");
    }
    rx_came_ = true;
  }
  return true;
}

}  // namespace ehpt::fmu
