// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// A built-in ECU (MBecu1/MBecu1soc/MBecu2, the EV's follower) as its own process on the bus
// (`ehpt ecu`): it speaks the contract (io/can/ehpt.dbc) like any external ECU. Per sample it
// collects the plant's sensor frames; PlantStatus completes the sample; it then runs one
// update and sends its command frames. The same discrete-time system as the built-in ECU
// with ecu.codec = "can", so a lockstep bus run equals that in-process run bit for bit.

#include <atomic>
#include <cstdint>
#include <iosfwd>
#include <memory>
#include <string>

#include "hil/config/config.hpp"
#include "io/can/transport.hpp"
#include "io/json_writer.hpp"
#include "io/lcm/lcm_bus.hpp"

namespace ehpt::hil {

struct BusEcuOptions {
  double idle_timeout_s = 10.0;   // stop after this long without a frame from the plant
  std::int64_t max_samples = 0;   // stop after answering this many samples (0: no limit)
};

struct BusEcuResult {
  int exit_code = 0;          // 0: the plant went away or went quiet; 128 + N: signal N
  std::int64_t samples = 0;   // samples answered
  std::int64_t incomplete = 0;  // PlantStatus without every sensor frame of the sample
  std::int64_t saturated = 0;   // command signals saturated by the codec
  std::string why_stopped;
};

// True if the scenario's vehicle has a built-in ECU that can run on the bus; else a reason.
bool has_bus_ecu(const Scenario& sc, std::string& why);

BusEcuResult run_bus_ecu(const Scenario& sc, io::can::Transport& bus, const BusEcuOptions& opt,
                         const std::atomic<int>* stop, std::ostream& log);
// The same over LCM: <prefix>PLANT_STATUS in, <prefix>ECU_COMMAND out.
BusEcuResult run_bus_ecu(const Scenario& sc, io::lcm::LcmBus& bus, const std::string& prefix,
                         const BusEcuOptions& opt, const std::atomic<int>* stop, std::ostream& log);

// The same ECU served one poll at a time, in the caller's thread (hil/bus/in_process_bus.hpp):
// poll() answers every complete sample that has come in, and returns at once.
class CanEcuNode {
 public:
  virtual ~CanEcuNode() = default;
  virtual void poll() = 0;
  // its figures: samples answered, incomplete samples (frames a bus fault took), frames its
  // receive rules refused (a corrupt or counter-jumped frame), signals the codec saturated
  virtual void report(io::JsonObject& out) const = 0;
  virtual std::int64_t samples_answered() const = 0;
};
// The scenario's built-in ECU on bus (has_bus_ecu must hold; nullptr otherwise).
std::unique_ptr<CanEcuNode> make_can_ecu_node(const Scenario& sc, io::can::Transport& bus);

}  // namespace ehpt::hil
