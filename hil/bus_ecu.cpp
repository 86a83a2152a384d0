#include "hil/bus_ecu.hpp"

#include <chrono>
#include <memory>
#include <ostream>
#include <variant>

#include "ecu/ev_follower.hpp"
#include "ecu/psd_ecu.hpp"
#include "hil/pacer.hpp"
#include "io/can/codec.hpp"

namespace ehpt::hil {

namespace {

using io::can::Frame;

std::int64_t now_ns() { return SteadyClock{}.now_ns(); }

template <class Sensors>
struct EcuFamily;
template <>
struct EcuFamily<msgs::PsdSensors> {
  using Command = msgs::PsdCommand;
  static constexpr const auto& kSensorIds = io::can::kPsdSensorIds;
  static constexpr const auto& kCommandIds = io::can::kPsdCommandIds;
};
template <>
struct EcuFamily<msgs::EvSensors> {
  using Command = msgs::EvCommand;
  static constexpr const auto& kSensorIds = io::can::kEvSensorIds;
  static constexpr const auto& kCommandIds = io::can::kEvCommandIds;
};

template <class Sensors, class Controller>
BusEcuResult serve(Controller& ecu, double h_s, io::can::Transport& bus, const BusEcuOptions& opt,
                   const std::atomic<int>* stop, std::ostream& log) {
  using F = EcuFamily<Sensors>;
  using Command = typename F::Command;
  BusEcuResult res;
  io::can::FrameFilter filter(F::kSensorIds);
  io::can::TxCounters tx;
  Sensors sensors{};
  Command command{};
  unsigned mask = 0;
  constexpr unsigned kAllSensors = (1u << (F::kSensorIds.size() - 1)) - 1;  // every frame but PlantStatus
  std::uint32_t sequence = 0;
  std::int64_t last_frame_ns = now_ns();
  bool heard = false;
  Frame buf[64];
  for (;;) {
    if (stop != nullptr && stop->load() != 0) {
      res.exit_code = 128 + stop->load();
      res.why_stopped = "stopped by a signal";
      break;
    }
    if (!bus.has_peer()) {
      res.why_stopped = "the plant closed the connection";
      break;
    }
    if (opt.max_samples > 0 && res.samples >= opt.max_samples) {
      res.why_stopped = "answered the samples asked for";
      break;
    }
    const std::int64_t quiet_ns = now_ns() - last_frame_ns;
    if (quiet_ns > static_cast<std::int64_t>(opt.idle_timeout_s * 1e9)) {
      res.why_stopped = heard ? "the plant went quiet" : "no plant on the bus";
      break;
    }
    bus.wait(100'000'000);
    while (const std::size_t k = bus.receive(buf)) {
      for (std::size_t i = 0; i < k; ++i) {
        const Frame& f = buf[i];
        if (filter.accept(f) != io::can::Reject::kNone) continue;
        last_frame_ns = now_ns();
        heard = true;
        if (f.id != io::can::kPlantStatus) {
          io::can::apply(f, sensors);
          for (std::size_t j = 0; j + 1 < F::kSensorIds.size(); ++j) {
            if (F::kSensorIds[j] == f.id) mask |= 1u << j;
          }
          continue;
        }
        io::can::PlantStatus status;
        io::can::apply(f, status);
        if (mask != kAllSensors) {  // joined mid-sample, or frames lost: wait for a whole one
          ++res.incomplete;
          mask = 0;
          continue;
        }
        mask = 0;
        sensors.fault = status.fault;
        sensors.locked = status.locked;
        sensors.stamp = msgs::Stamp{static_cast<double>(status.step) * h_s, status.step, sequence++};
        ecu.update(sensors, command);
        command.stamp = sensors.stamp;  // the sample it answers: sampleStep on the bus
        std::array<Frame, F::kCommandIds.size()> frames;
        res.saturated += io::can::encode(command, tx, frames);
        for (const Frame& out : frames) bus.send(out);
        ++res.samples;
      }
    }
  }
  const io::can::RxStats& rx = filter.stats();
  const io::can::TransportCounters& tc = bus.counters();
  log << "ecu           " << res.samples << " samples answered (" << res.why_stopped << "); frames in "
      << tc.frames_in << ", out " << tc.frames_out << ", rejected "
      << rx.unknown_id + rx.wrong_length + rx.bad_counter + rx.out_of_range << ", incomplete samples "
      << res.incomplete << ", saturated signals " << res.saturated << "\n";
  return res;
}

}  // namespace

bool has_bus_ecu(const Scenario& sc, std::string& why) {
  if (std::holds_alternative<ecu::PsdEcuParams>(sc.ecu) || std::holds_alternative<ecu::EvFollowerParams>(sc.ecu)) {
    return true;
  }
  why = sc.name + ": its vehicle (" + sc.vehicle_path + ") has no built-in ECU to run on the bus";
  return false;
}

BusEcuResult run_bus_ecu(const Scenario& sc, io::can::Transport& bus, const BusEcuOptions& opt,
                         const std::atomic<int>* stop, std::ostream& log) {
  const double h = sc.solver.step_s;
  if (const auto* e = std::get_if<ecu::PsdEcuParams>(&sc.ecu)) {
    ecu::PsdEcu controller(*e, e->period_s);
    return serve<msgs::PsdSensors>(controller, h, bus, opt, stop, log);
  }
  ecu::EvFollower follower;
  return serve<msgs::EvSensors>(follower, h, bus, opt, stop, log);
}

}  // namespace ehpt::hil
