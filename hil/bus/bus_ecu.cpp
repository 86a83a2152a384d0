// SPDX-License-Identifier: BSD-3-Clause
#include "hil/bus/bus_ecu.hpp"

#include <memory>
#include <ostream>
#include <variant>

#include "ecu/ev_follower.hpp"
#include "ecu/psd_ecu.hpp"
#include "ecu/shev_ems.hpp"
#include "hil/bus/bus_family.hpp"
#include "hil/run/pacer.hpp"
#include "io/can/codec.hpp"
#ifndef EHPT_BUS_NO_LCM  // an FMU's library (CMakeLists.txt: ehpt_fmu_core) speaks CAN only, without liblcm
#include "hil/bus/bus_wire_lcm.hpp"
#include "io/lcm/lcm_codec.hpp"
#endif

namespace ehpt::hil {

namespace {

using io::can::Frame;

std::int64_t now_ns() { return SteadyClock{}.now_ns(); }

// The ECU's side of the CAN contract: a sample is complete when PlantStatus arrives after
// every sensor frame; the command goes out as its frames.
template <class Sensors>
class CanEcuWire {
  using F = BusFamily<Sensors>;

 public:
  using Command = typename F::Command;
  CanEcuWire(io::can::Transport& bus, double h_s) : bus_(bus), h_s_(h_s), filter_(F::kCanSensorIds) {}

  bool has_peer() const { return bus_.has_peer(); }
  void wait(std::int64_t ns) { bus_.wait(ns); }

  // on_sample(sensors) for each complete sample; true if anything of the plant's came in
  template <class OnSample>
  bool receive(OnSample&& on_sample) {
    bool heard = false;
    Frame buf[64];
    // until a receive comes back short: the transport had no more (Transport::receive)
    for (std::size_t k = std::size(buf); k == std::size(buf);) {
      k = bus_.receive(buf);
      for (std::size_t i = 0; i < k; ++i) {
        const Frame& f = buf[i];
        if (filter_.accept(f) != io::can::Reject::kNone) continue;
        heard = true;
        if (f.id != io::can::kPlantStatus) {
          io::can::apply(f, sensors_);
          for (std::size_t j = 0; j + 1 < F::kCanSensorIds.size(); ++j) {
            if (F::kCanSensorIds[j] == f.id) mask_ |= 1u << j;
          }
          continue;
        }
        io::can::PlantStatus status;
        io::can::apply(f, status);
        if (mask_ != kAllSensors) {  // joined mid-sample, or frames lost: wait for a whole one
          ++incomplete_;
          mask_ = 0;
          continue;
        }
        mask_ = 0;
        sensors_.fault = status.fault;
        sensors_.locked = status.locked;
        sensors_.stamp = msgs::Stamp{static_cast<double>(status.step) * h_s_, status.step, sequence_++};
        on_sample(sensors_);
      }
    }
    return heard;
  }

  // the command's stamp.step is the sample it answers (sampleStep)
  std::int64_t send_command(const Command& c) {
    std::array<Frame, F::kCanCommandIds.size()> frames;
    const int saturated = io::can::encode(c, tx_, frames);
    bus_.cork();  // the command's frames leave together (Transport::cork)
    for (const Frame& out : frames) bus_.send(out);
    bus_.uncork();
    return saturated;
  }

  std::int64_t incomplete() const { return incomplete_; }
  std::int64_t rejected() const {
    const io::can::RxStats& rx = filter_.stats();
    return rx.unknown_id + rx.wrong_length + rx.bad_counter + rx.out_of_range;
  }

  void summary(std::ostream& log) const {
    const io::can::RxStats& rx = filter_.stats();
    const io::can::TransportCounters& tc = bus_.counters();
    log << "frames in " << tc.frames_in << ", out " << tc.frames_out << ", rejected "
        << rx.unknown_id + rx.wrong_length + rx.bad_counter + rx.out_of_range << ", incomplete samples "
        << incomplete_;
  }

 private:
  static constexpr unsigned kAllSensors = (1u << (F::kCanSensorIds.size() - 1)) - 1;  // all but PlantStatus
  io::can::Transport& bus_;
  double h_s_;
  io::can::FrameFilter filter_;
  io::can::TxCounters tx_;
  Sensors sensors_{};
  unsigned mask_ = 0;
  std::uint32_t sequence_ = 0;
  std::int64_t incomplete_ = 0;
};

#ifndef EHPT_BUS_NO_LCM
// The ECU's side over LCM: one message per sample, one per command. It follows one plant
// session (the first it hears, or a new one once the followed plant has been silent for
// kSessionSilence_ns: a restarted plant) and names it in every command; samples of other
// plants on the same URL and prefix are counted and left unanswered.
template <class Sensors>
class LcmEcuWire {
  using SensorsMsg = typename io::lcm::LcmTypesOf<Sensors>::SensorsMsg;
  using CommandMsg = typename io::lcm::LcmTypesOf<Sensors>::CommandMsg;

 public:
  using Command = typename BusFamily<Sensors>::Command;
  LcmEcuWire(io::lcm::LcmBus& bus, const std::string& prefix, std::string& error)
      : bus_(bus), command_channel_(prefix + "ECU_COMMAND") {
    out_.resize(static_cast<std::size_t>(CommandMsg{}.getEncodedSize()));
    ok_ = bus_.subscribe(prefix + "PLANT_STATUS", &LcmEcuWire::on_message, this, error);
  }
  bool ok() const { return ok_; }
  bool has_peer() const { return true; }
  void wait(std::int64_t ns) { bus_.wait(ns); }

  template <class OnSample>
  bool receive(OnSample&& on_sample) {
    const std::int64_t before = bus_.counters().received;
    bus_.handle_now();
    for (std::size_t i = 0; i < pending_count_; ++i) on_sample(pending_[i]);
    pending_count_ = 0;
    return bus_.counters().received != before;
  }

  std::int64_t send_command(const Command& c) {
    CommandMsg m{};
    io::lcm::to_lcm(c, lcm_utime_now(), m);
    m.session = session_;
    const int n = m.encode(out_.data(), 0, static_cast<int>(out_.size()));
    if (n > 0) bus_.publish(command_channel_.c_str(), out_.data(), n);
    return 0;
  }

  void summary(std::ostream& log) const {
    log << "messages in " << bus_.counters().received << ", out " << bus_.counters().published << ", malformed "
        << malformed_ << ", dropped " << dropped_ << ", other plant sessions' samples ignored " << foreign_;
  }

 private:
  static void on_message(const void* data, int size, void* user) {
    auto* self = static_cast<LcmEcuWire*>(user);
    SensorsMsg m{};
    if (m.decode(data, 0, size) != size) {
      ++self->malformed_;
      return;
    }
    const std::int64_t t = now_ns();
    if (m.session != self->session_) {
      if (self->session_ != 0 && t - self->heard_ns_ < kSessionSilence_ns) {
        ++self->foreign_;  // another plant on this URL and prefix: never answered with our state
        return;
      }
      self->session_ = m.session;  // the first plant heard, or the followed one restarted
    }
    self->heard_ns_ = t;
    if (self->pending_count_ == self->pending_.size()) {  // more samples in one drain than it holds
      ++self->dropped_;
      return;
    }
    Sensors s{};
    io::lcm::from_lcm(m, s);
    s.stamp.sequence = self->sequence_++;
    self->pending_[self->pending_count_++] = s;
  }

  io::lcm::LcmBus& bus_;
  std::string command_channel_;
  std::vector<std::uint8_t> out_;
  bool ok_ = false;
  std::array<Sensors, 16> pending_{};
  std::size_t pending_count_ = 0;
  std::uint32_t sequence_ = 0;
  std::int64_t malformed_ = 0, dropped_ = 0, foreign_ = 0;
  static constexpr std::int64_t kSessionSilence_ns = 1'000'000'000;
  std::int64_t session_ = 0, heard_ns_ = 0;  // the followed plant session, when it was last heard
};
#endif

// Every complete sample that has come in, answered; true if anything of the plant's came.
template <class Wire, class Controller, class Command>
bool answer(Controller& ecu, Wire& wire, Command& command, BusEcuResult& res) {
  return wire.receive([&](const auto& sensors) {
    ecu.update(sensors, command);
    command.stamp = sensors.stamp;  // the sample it answers
    res.saturated += wire.send_command(command);
    ++res.samples;
  });
}

template <class Wire, class Controller>
BusEcuResult serve(Controller& ecu, Wire& wire, const BusEcuOptions& opt, const std::atomic<int>* stop,
                   std::ostream& log) {
  using Command = typename Wire::Command;
  BusEcuResult res;
  Command command{};
  std::int64_t last_frame_ns = now_ns();
  bool heard = false;
  for (;;) {
    if (stop != nullptr && stop->load() != 0) {
      res.exit_code = 128 + stop->load();
      res.why_stopped = "stopped by a signal";
      break;
    }
    if (!wire.has_peer()) {
      res.why_stopped = "the plant closed the connection";
      break;
    }
    if (opt.max_samples > 0 && res.samples >= opt.max_samples) {
      res.why_stopped = "answered the samples asked for";
      break;
    }
    if (now_ns() - last_frame_ns > static_cast<std::int64_t>(opt.idle_timeout_s * 1e9)) {
      res.why_stopped = heard ? "the plant went quiet" : "no plant on the bus";
      break;
    }
    wire.wait(100'000'000);
    if (answer(ecu, wire, command, res)) {
      last_frame_ns = now_ns();
      heard = true;
    }
  }
  log << "ecu           " << res.samples << " samples answered (" << res.why_stopped << "); ";
  wire.summary(log);
  log << ", saturated signals " << res.saturated << "\n";
  return res;
}

// The scenario's built-in ECU over a wire made by make_wire(family tag).
template <class MakeWire>
BusEcuResult serve_scenario(const Scenario& sc, MakeWire&& make_wire, const BusEcuOptions& opt,
                            const std::atomic<int>* stop, std::ostream& log) {
  const auto go = [&](auto& controller, auto& wire) {
    if constexpr (requires { wire->ok(); }) {
      if (!wire->ok()) {
        BusEcuResult res;
        res.exit_code = 2;
        res.why_stopped = "cannot subscribe";
        return res;
      }
    }
    return serve(controller, *wire, opt, stop, log);
  };
  if (const auto* e = sc.ecu.get_if<ecu::PsdEcuParams>()) {
    ecu::PsdEcu controller(*e, e->period_s);
    auto wire = make_wire(msgs::PsdSensors{});
    return go(controller, wire);
  }
  if (const auto* e = sc.ecu.get_if<ecu::ShevEmsParams>()) {
    ecu::ShevEms controller(*e, e->period_s);
    auto wire = make_wire(msgs::ShevSensors{});
    return go(controller, wire);
  }
  ecu::EvFollower follower;
  auto wire = make_wire(msgs::EvSensors{});
  return go(follower, wire);
}

template <class Sensors, class Controller>
class CanEcuNodeOf final : public CanEcuNode {
 public:
  CanEcuNodeOf(Controller controller, io::can::Transport& bus, double h_s)
      : controller_(std::move(controller)), wire_(bus, h_s) {}
  void poll() override { answer(controller_, wire_, command_, res_); }
  std::int64_t samples_answered() const override { return res_.samples; }
  void report(io::JsonObject& out) const override {
    out.integer("samples_answered", res_.samples);
    out.integer("incomplete_samples", wire_.incomplete());
    out.integer("frames_rejected", wire_.rejected());
    out.integer("saturated_signals", res_.saturated);
  }

 private:
  Controller controller_;
  CanEcuWire<Sensors> wire_;
  typename BusFamily<Sensors>::Command command_{};
  BusEcuResult res_;
};

}  // namespace

std::unique_ptr<CanEcuNode> make_can_ecu_node(const Scenario& sc, io::can::Transport& bus) {
  if (const auto* e = sc.ecu.get_if<ecu::PsdEcuParams>()) {
    return std::make_unique<CanEcuNodeOf<msgs::PsdSensors, ecu::PsdEcu>>(ecu::PsdEcu(*e, e->period_s), bus,
                                                                        sc.solver.step_s);
  }
  if (const auto* e = sc.ecu.get_if<ecu::ShevEmsParams>()) {
    return std::make_unique<CanEcuNodeOf<msgs::ShevSensors, ecu::ShevEms>>(ecu::ShevEms(*e, e->period_s), bus,
                                                                          sc.solver.step_s);
  }
  if (sc.ecu.holds<ecu::EvFollowerParams>()) {
    return std::make_unique<CanEcuNodeOf<msgs::EvSensors, ecu::EvFollower>>(ecu::EvFollower{}, bus, sc.solver.step_s);
  }
  return nullptr;
}

bool has_bus_ecu(const Scenario& sc, std::string& why) {
  if (sc.ecu.holds<ecu::PsdEcuParams>() || sc.ecu.holds<ecu::EvFollowerParams>() ||
      sc.ecu.holds<ecu::ShevEmsParams>()) {
    return true;
  }
  why = sc.name + ": its vehicle (" + sc.vehicle_path + ")" +
        (sc.ecu.empty() ? " has no built-in ECU to run on the bus"
                        : "'s ECU has no messages in the bus contract yet: it cannot run on the bus");
  return false;
}

BusEcuResult run_bus_ecu(const Scenario& sc, io::can::Transport& bus, const BusEcuOptions& opt,
                         const std::atomic<int>* stop, std::ostream& log) {
  return serve_scenario(
      sc,
      [&](auto tag) {
        using S = decltype(tag);
        return std::make_unique<CanEcuWire<S>>(bus, sc.solver.step_s);
      },
      opt, stop, log);
}

#ifndef EHPT_BUS_NO_LCM
BusEcuResult run_bus_ecu(const Scenario& sc, io::lcm::LcmBus& bus, const std::string& prefix,
                         const BusEcuOptions& opt, const std::atomic<int>* stop, std::ostream& log) {
  std::string error;
  BusEcuResult res = serve_scenario(
      sc,
      [&](auto tag) {
        using S = decltype(tag);
        return std::make_unique<LcmEcuWire<S>>(bus, prefix, error);
      },
      opt, stop, log);
  if (!error.empty()) log << "error: " << error << "\n";
  return res;
}
#endif

}  // namespace ehpt::hil
