// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// One instance of an ehpt FMU, without FMI's C types (targets/fmu/fmi3_export.cpp maps the
// calls): the scenario in the FMU's resources/ loaded at instantiation (may allocate; its
// problems logged with the same messages as `ehpt run`), the simulation built when
// initialization ends, then doStep: whole plant steps of the same runner `ehpt run` uses,
// nothing allocated. Several instances in one process share nothing.
//
// The FMU's resources/ehpt-fmu.txt says which scenario it is and its token:
//   # ehpt fmu 1
//   token <the instantiationToken of modelDescription.xml>
//   scenario <its path inside resources/>
//   set <key=value>            (each `ehpt fmu --set`, in order)
//   fault <spec>               (each `ehpt fmu --fault`, in order)
//   ecu none                   (--ecu none: the importer is the ECU)
//   bus ls-bus                 (--bus ls-bus: the ECU is on the FMU's CAN terminal)
//   role ecu                   (--role ecu: the FMU is the scenario's built-in ECU on it)
//
// With a bus terminal the FMU has FMI 3.0's Event Mode (FMI-LS-BUS): the plant sends a
// sample's sensor frames (Tx_Data, Tx_Clock ticking) at the end of the doStep that reached the
// ECU sample, and applies the latest command that has come (Rx_Data, Rx_Clock), with the bus
// plant's timeout and safe state (hil/bus/bus_plant.hpp: event_mode); the ECU FMU answers each
// complete sample in its Event Mode, as `ehpt ecu` does. Connected directly, each command comes
// in its sample's Event Mode: the lockstep bus session, bit for bit.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hil/config/config.hpp"
#include "hil/run/simulation.hpp"
#include "io/can/ls_bus.hpp"
#include "msgs/ev.hpp"
#include "msgs/psd.hpp"
#include "msgs/shev.hpp"
#include "targets/fmu/fmu_description.hpp"

namespace ehpt::fmu {

inline constexpr const char* kManifestName = "ehpt-fmu.txt";

// How the instance reports (FMI's status words: 0 OK, 1 Warning, 2 Discard, 3 Error, 4 Fatal).
struct Log {
  void (*write)(void* context, int status, const char* category, const char* message) = nullptr;
  void* context = nullptr;
  void operator()(int status, const char* category, const std::string& message) const {
    if (write != nullptr) write(context, status, category, message.c_str());
  }
};

// Which standard's functions call in: the names its messages give the calls.
enum class Fmi { k2, k3 };

// The message values of an FMU without its ECU (--ecu none), of whichever family it speaks.
struct Messages {
  msgs::EvSensors ev_sensors{};
  msgs::PsdSensors psd_sensors{};
  msgs::ShevSensors shev_sensors{};
  msgs::EvCommand ev_command{};
  msgs::PsdCommand psd_command{};
  msgs::ShevCommand shev_command{};
};

// An FMU state (fmi3GetFMUState): everything an instance needs to go on from a point. A
// serialised one (fmi3SerializeFMUState) holds the way there instead: the scenario's settings
// (the parameters and stop time the instance had) and the plant step, with a digest of the
// outputs there. The run is deterministic, so fmi3SetFMUState of a deserialised state runs
// the simulation again to that step, in this process or another, and checks the digest. Only
// with the built-in ECU: without it the state depends on inputs the FMU does not keep.
struct SavedState {
  std::unique_ptr<hil::SimulationState> sim;
  std::vector<double> values;
  Messages messages;
  int state = 0;
  double stop_s = 0.0;
  std::int64_t step = 0;           // the plant step it is at
  std::vector<std::string> sets;   // the stop time's and the changed parameters' --set overrides
  std::uint64_t digest = 0;        // of the time and every output there
  std::string bytes;               // the serialised form (made once, by the first size query)
};

}  // namespace ehpt::fmu
namespace ehpt::hil {
class ExternalDriver;
class CanEcuNode;
}  // namespace ehpt::hil
namespace ehpt::fmu {

class Instance {
 public:
  ~Instance();
  // nullptr if the resources do not hold a loadable scenario or the token (FMI 2: the guid) is
  // not theirs (logged).
  static std::unique_ptr<Instance> make(const std::string& resource_dir, const std::string& token, Log log,
                                        Fmi fmi = Fmi::k3);

  // The calling sequence (FMI 3.0 co-simulation, §4; FMI 2.0 §4.2.4 the same states): each
  // false is logged, and the instance is then in error (every later call but free fails).
  bool enter_initialization(bool stop_defined, double start_s, double stop_s);
  bool exit_initialization();
  // stopped: the plant stopped on a fault before the step's end (reached_s says where; logged;
  // FMI: fmi3Discard with terminateSimulation), as `ehpt run` ends with exit 3. event: Tx_Data
  // holds operations (a sample went out): the importer's Event Mode is due.
  bool do_step(double current_s, double step_s, double& reached_s, bool& stopped, bool& event);
  // Event Mode (a bus terminal only): entered after initialization and when the importer
  // handles a doStep's event; update_discrete_states takes what Rx_Data brought (the plant:
  // its command, the ECU: the samples it answers).
  bool has_bus() const { return description_.ecu == EcuMode::kBus; }
  bool enter_event_mode();
  // need_update: it sent operations (Tx_Clock ticked): the importer should hand them on and
  // call it again (discreteStatesNeedUpdate)
  bool update_discrete_states(bool& need_update);
  bool enter_step_mode();
  bool get_clock(const std::uint32_t* vrs, std::size_t n, bool* active);
  bool set_clock(const std::uint32_t* vrs, std::size_t n, const bool* active);
  // Tx_Data: the operations of the last tick (valid and unchanged until the next tick); Rx_Data's taken in
  bool get_binary(const std::uint32_t* vrs, std::size_t n, std::size_t* sizes, const std::uint8_t** values,
                  std::size_t n_values);
  bool set_binary(const std::uint32_t* vrs, std::size_t n, const std::size_t* sizes, const std::uint8_t* const* values,
                  std::size_t n_values);
  bool get_float64(const std::uint32_t* vrs, std::size_t n, double* values, std::size_t n_values);
  bool get_boolean(const std::uint32_t* vrs, std::size_t n, bool* values, std::size_t n_values);
  // Inputs (--ecu none: the command's fields) before or between steps; parameters (the
  // vehicle's numbers) before initialization ends, when the scenario is loaded again with them
  // and checked as `ehpt run` checks it. A value that is not finite is refused (as every
  // other way in refuses one) and not applied.
  bool set_float64(const std::uint32_t* vrs, std::size_t n, const double* values, std::size_t n_values);
  bool set_boolean(const std::uint32_t* vrs, std::size_t n, const bool* values, std::size_t n_values);
  bool terminate();
  // After terminate: a bus session that did not do what a session must (logged as Warnings:
  // the plant's no ECU or commands that timed out, the ECU's no plant): fmi3Terminate answers
  // fmi3Warning.
  bool degraded() const { return degraded_; }
  bool reset();
  // After initialization (Step Mode, or Terminated by a plant fault): the state now, into out
  // (reused if given); and back to one (of this FMU). The run then goes on bit for bit as it
  // did from there. They allocate (the state's copies), doStep does not.
  bool get_state(std::unique_ptr<SavedState>& out);
  bool set_state(const SavedState& saved);
  // A state as bytes (saved.bytes, made once) and back (a state of this FMU, its token checked;
  // a damaged one refused with what is wrong). Only with the built-in ECU.
  bool serialize(SavedState& saved);
  bool deserialize(const std::uint8_t* bytes, std::size_t n, std::unique_ptr<SavedState>& out);

  const Description& description() const { return description_; }

 private:
  enum class State { kInstantiated, kInitialization, kStep, kEvent, kTerminated, kError };
  enum class Call { kEnterInitialization, kExitInitialization, kDoStep, kGetReal, kGetBoolean, kSetReal, kSetBoolean,
                    kTerminate, kReset, kGetState, kSetState };
  Instance(hil::Scenario sc, std::string scenario_path, std::vector<std::string> sets, EcuMode ecu, Role role, Log log,
           Fmi fmi, const std::vector<std::pair<std::string, double>>& numbers);
  // the bus terminal's side: the plant's bus driver or the ECU, built when initialization ends
  bool make_bus(const char* call);
  // the terminal's new operations become Tx_Data's value and Tx_Clock ticks; true if there were any
  bool publish_tx();
  // the bus variable a value reference names, or fails (call's message)
  const Variable* bus_variable(const char* call, std::uint32_t vr, Type type);
  // the scenario with the manifest's overrides, the importer's stop time and its parameters
  bool reload(const char* call);
  const char* name(Call c) const;
  bool fail(const std::string& message);
  bool in(State s, const char* call);
  // the variables' values at the current point: signals, and (--ecu none) the sensor message
  void refresh_outputs();
  // the time and every output now, as one number (a serialised state's check)
  std::uint64_t outputs_digest() const;
  // set_state of a deserialised state: the scenario again, run to its step, the digest checked
  bool restore_by_rerun(const SavedState& saved);
  // the command from the inputs, to the simulation (--ecu none)
  void apply_inputs();
  template <class T>
  bool set_values(const char* call, Type type, const std::uint32_t* vrs, std::size_t n, const T* values,
                  std::size_t n_values);
  template <class T>
  bool get_values(const char* call, Type type, const std::uint32_t* vrs, std::size_t n, T* values, std::size_t n_values);

  hil::Scenario sc_;
  std::string token_;  // the instantiationToken (a serialised state names it)
  std::string scenario_path_;  // reloaded when the importer asks for another stop time
  std::vector<std::string> sets_;  // the manifest's overrides
  std::vector<std::string> faults_;  // the manifest's faults (ehpt fmu --fault), as --fault gives them
  std::string stop_set_;           // "solver.duration_s=..." when the importer asked for another stop time
  Log log_;
  Description description_;
  State state_ = State::kInstantiated;
  double stop_s_ = 0.0;
  std::unique_ptr<hil::Simulation> sim_;
  EcuMode ecu_;
  Fmi fmi_;
  std::vector<double> values_;   // every variable's value at the current point, by value reference
  // (value reference, index) of the signals, the sensor fields and the command fields: what
  // each step refreshes or applies, without walking the parameters
  std::vector<std::pair<std::uint32_t, std::size_t>> signal_vrs_, sensor_vrs_, command_vrs_;
  Messages messages_;  // --ecu none: the family's sensors read and command applied at each step
  // the bus terminal (ecu kBus): its Tx_Data as handed to the importer, whether Rx_Data came
  // since the last update, the plant's bus driver (hil/bus/bus_plant.hpp) or the ECU
  std::unique_ptr<io::can::ls_bus::LsBusTerminal> terminal_;
  std::vector<std::uint8_t> tx_out_;  // Tx_Data's value (capacity kBusBufferBytes, reserved)
  bool tx_clock_ = false;             // Tx_Clock ticked and fmi3GetClock has not reported it yet
  std::int64_t tx_dropped_ = 0;       // ticks whose operations did not fit behind unfetched ones
  bool rx_clock_ = false, rx_came_ = false;
  std::unique_ptr<hil::ExternalDriver> bus_plant_;
  std::unique_ptr<hil::CanEcuNode> ecu_node_;
  std::int64_t ecu_step_ = 0, ecu_steps_ = 0;  // the ECU FMU's time, in plant steps
  bool degraded_ = false;
};

}  // namespace ehpt::fmu
