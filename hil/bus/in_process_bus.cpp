// SPDX-License-Identifier: BSD-3-Clause
#include "hil/bus/in_process_bus.hpp"

#include <algorithm>
#include <utility>

#include "hil/bus/bus_binding.hpp"
#include "hil/bus/bus_ecu.hpp"
#include "io/can/memory_bus.hpp"

namespace ehpt::hil {

namespace {

constexpr int kPlantSide = 0, kEcuSide = 1;

// Owns the bus, the ECU and the plant (in that order: each refers to what comes before it) and
// is the plant to the batch.
class InProcessBus final : public ExternalDriver {
 public:
  InProcessBus() = default;

  bool make(const Scenario& sc, const BusPlantOptions& opt, std::string& error) {
    ecu_ = make_can_ecu_node(sc, bus_.end(kEcuSide));
    std::vector<std::string> errors;
    std::optional<Binding> binding = default_binding(bus_family(sc), sc.ecu_timing.period_s, errors);
    if (!ecu_ || !binding) {
      error = errors.empty() ? sc.name + ": no built-in ECU to run on the bus" : errors.front();
      return false;
    }
    // the plant's receive and wait let the ECU answer what has come
    bus_.set_pump(kPlantSide, [](void* node) { static_cast<CanEcuNode*>(node)->poll(); }, ecu_.get());
    plant_ = make_bus_plant(sc, bus_.end(kPlantSide), opt, std::move(*binding), error);
    return plant_ != nullptr;
  }

  bool open(const io::OutputDir& dir, std::string& error) override { return plant_->open(dir, error); }
  void discard_files() override { plant_->discard_files(); }
  void start(Simulation& sim, const std::atomic<int>* stop) override { plant_->start(sim, stop); }
  bool realtime_capable(std::string& why) const override {
    why = "its bus faults run the built-in ECU over an in-process CAN bus in lockstep, which keeps no real-time "
          "period: run it without --realtime, or with the ECU on a real bus (ehpt plant FILE --bus socketcan:vcan0 "
          "and ehpt ecu)";
    return false;
  }
  bool flush(std::string& error) override { return plant_->flush(error); }
  bool finish(std::string& error) override { return plant_->finish(error); }
  void report(io::JsonObject& summary, std::string& text) const override {
    plant_->report(summary, text);
    io::JsonObject e;
    ecu_->report(e);
    summary.object("ecu_in_process", e);
  }
  CommandSource command_source() const override {
    return {"in_process_bus", "built-in ECU over an in-process CAN bus (bus faults), lockstep", {}};
  }
  std::vector<std::string> degraded_reasons() const override { return plant_->degraded_reasons(); }
  bool takes_bus_faults() const override { return true; }
  LinkFigures link_figures() const override { return plant_->link_figures(); }

 private:
  io::can::MemoryBus bus_;
  std::unique_ptr<CanEcuNode> ecu_;
  std::unique_ptr<ExternalDriver> plant_;
};

}  // namespace

bool has_bus_faults(const Scenario& sc) {
  return std::any_of(sc.faults.begin(), sc.faults.end(), [](const FaultSpec& f) { return f.side == FaultSide::kBus; });
}

std::unique_ptr<ExternalDriver> make_in_process_bus(const Scenario& sc, BusPlantOptions opt, std::string& error) {
  std::string why;
  if (!can_run_on_bus(sc, why)) {
    error = "bus faults run the built-in ECU over an in-process CAN bus, and " + why;
    return nullptr;
  }
  opt.lockstep = true;
  opt.realtime = false;
  // the ECU answers within the plant's own receive: a command that is not there at once never comes
  opt.lockstep_wait_s = 0.0;
  opt.peer_wait_s = 0.0;
  opt.log_interface = "mem0";
  opt.asc_log = false;
  auto driver = std::make_unique<InProcessBus>();
  if (!driver->make(sc, opt, error)) return nullptr;
  return driver;
}

}  // namespace ehpt::hil
