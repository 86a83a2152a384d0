// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The plant on a CAN bus (`ehpt plant`): the scenario's vehicle without its built-in ECU; an
// ECU outside (another process, a python-can script, a real ECU) reads the sensor frames and
// sends the command frames of the contract (io/can/ehpt.dbc). Two pacers:
//   lockstep:   at each ECU sample the plant sends its sensors and waits for the ECU's
//               command for that sample before it advances one ECU period (deterministic SIL,
//               as fast as both sides go);
//   wall clock: the plant advances in real time (sleep until each step's deadline), sends its
//               sensors at each sample and applies the latest complete command when it
//               arrives, counting staleness.
// Safety (both): a command older than the timeout (default 3 ECU periods) puts the plant in
// its safe state: torque and power references zero, the engine's ON/OFF held as it was (a
// stale frame cannot switch it), ecuTimeout set in PlantStatus, counted; the next complete
// fresh command ends it. Frames that are not the contract's (unknown id, wrong length,
// repeated or jumping counter, a value outside its range) are counted and ignored. Nothing on
// the bus allocates or throws in the run phase.

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hil/run/batch.hpp"
#include "hil/config/config.hpp"
#include "hil/bus/bus_binding.hpp"
#include "io/can/transport.hpp"
#include "io/lcm/lcm_bus.hpp"

namespace ehpt::hil {

struct BusPlantOptions {
  bool lockstep = false;
  bool realtime = false;  // the batch's real-time loop paces it (start/exchange), not advance
  double command_timeout_s = 0.0;  // 0: 3 ECU periods
  // lockstep: how long (wall) the plant waits for the command of a sample before it goes on
  // without one (the command then ages like a late one on a real bus)
  double lockstep_wait_s = 1.0;
  double peer_wait_s = 60.0;  // wall time to wait for an ECU to connect before t = 0
  // an LS-BUS FMU (targets/fmu/): the commands come between steps, in the importer's Event
  // Mode. Start-up sends sample 0 without waiting; each later sample goes out at the end of the
  // doStep that reached it (ExternalDriver::send_ahead), and the exchange there takes what came
  // in the Event Mode after it, without waiting. Not lockstep: the latest complete fresh command
  // applies (as on the wall clock, in simulated time), so a bus simulation that delays frames
  // delays the commands instead of making every one stale; with a direct connection each
  // command comes in its sample's Event Mode and the run is the lockstep session's.
  bool event_mode = false;
  std::string log_interface = "can0";  // the interface name in bus.log lines
  bool asc_log = false;                // CAN: bus.asc (Vector ASC) too, beside bus.log
  std::string lcm_prefix = "EHPT_";    // LCM: channels <prefix>PLANT_STATUS, <prefix>ECU_COMMAND
  // inputs.log's header (hil/bus/session_log.hpp): what `ehpt replay` loads again
  std::string scenario_path;
  std::vector<std::string> overrides;
  std::vector<std::string> faults;  // the --fault one-offs, as given
};

// False and a one-line reason if the scenario cannot run on the bus (a rig without bus
// messages, an ECU latency the bus cannot honour).
bool can_run_on_bus(const Scenario& sc, std::string& why);
// "psd", "ev" or "shev": whose messages the scenario's plant speaks (a binding's family).
const char* bus_family(const Scenario& sc);
// The driver of `ehpt plant` over CAN, its frames those of the binding (default_binding for
// ehpt's own contract); nullptr and why if !can_run_on_bus or the binding is another family's.
std::unique_ptr<ExternalDriver> make_bus_plant(const Scenario& sc, io::can::Transport& bus,
                                               const BusPlantOptions& opt, Binding binding, std::string& error);
// The same over LCM (io/lcm/): one message per sample and per command, doubles.
std::unique_ptr<ExternalDriver> make_bus_plant(const Scenario& sc, io::lcm::LcmBus& bus,
                                               const BusPlantOptions& opt, std::string& error);

}  // namespace ehpt::hil
