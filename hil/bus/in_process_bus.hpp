// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The built-in ECU over a CAN bus inside this process, for a run whose scenario has bus faults
// (hil/bus/bus_faults.hpp: they act on frames) and no ECU outside: `ehpt run`, `ehpt test`
// without --bus, a sweep. The plant is `ehpt plant --lockstep`'s (hil/bus/bus_plant.hpp), the
// ECU `ehpt ecu`'s (hil/bus/bus_ecu.hpp), both on ehpt's own contract (io/can/ehpt.dbc), the
// frames passed in memory (io/can/memory_bus.hpp) in the run's own thread: the ECU answers a
// sample when the plant looks for its command. So the session is the one `ehpt test FILE --bus
// socketcand:... --ecu-cmd ehpt ecu {test} --bus {bus}` gives, bit for bit, without a socket or
// a second process, and deterministic. Its output folder has bus.log and inputs.log as a
// bus session's (`ehpt replay` reads it), and summary.json's "bus" the ECU's side too
// ("ecu_in_process").

#include <memory>
#include <string>

#include "hil/bus/bus_plant.hpp"

namespace ehpt::hil {

// True if the scenario has a bus fault (a fault on a CAN frame).
bool has_bus_faults(const Scenario& sc);

// The driver; nullptr and a reason if the scenario cannot run on the bus (a rig, an ECU latency)
// or its bus faults do not fit ehpt's contract. opt: scenario_path and overrides for inputs.log
// (lockstep, the waits and the log interface are this bus's own).
std::unique_ptr<ExternalDriver> make_in_process_bus(const Scenario& sc, BusPlantOptions opt, std::string& error);

}  // namespace ehpt::hil
