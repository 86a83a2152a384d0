#include "hil/bus_plant.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <span>

#include "hil/histogram.hpp"
#include "hil/pacer.hpp"
#include "hil/simulation.hpp"
#include "io/can/candump_log.hpp"
#include "io/can/codec.hpp"
#include "io/number_format.hpp"
#include "io/text_file.hpp"

namespace ehpt::hil {

namespace {

using io::can::Frame;

double wall_time_s() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// The bus side of each vehicle family: its frames and its safe command.
template <class Sensors>
struct Family;
template <>
struct Family<msgs::PsdSensors> {
  using Command = msgs::PsdCommand;
  static constexpr const auto& kSensorIds = io::can::kPsdSensorIds;
  static constexpr const auto& kCommandIds = io::can::kPsdCommandIds;
  // references to zero; the engine's ON/OFF stays as it was: a stale frame cannot switch it
  static void make_safe(Command& c) {
    c.icePowRef_W = 0.0;
    c.iceTauRef_Nm = 0.0;
    c.genTauRef_Nm = 0.0;
    c.motTauRef_Nm = 0.0;
  }
};
template <>
struct Family<msgs::EvSensors> {
  using Command = msgs::EvCommand;
  static constexpr const auto& kSensorIds = io::can::kEvSensorIds;
  static constexpr const auto& kCommandIds = io::can::kEvCommandIds;
  static void make_safe(Command& c) { c.driveTauRef_Nm = 0.0; }
};

// bus.log is written when this much is buffered (and between chunks)
constexpr std::size_t kLogFlushBytes = 1 << 20;

template <class Sensors>
class BusPlant final : public ExternalDriver {
  using F = Family<Sensors>;
  using Command = typename F::Command;

 public:
  BusPlant(const Scenario& sc, io::can::Transport& bus, const BusPlantOptions& opt)
      : bus_(bus),
        opt_(opt),
        h_s_(sc.solver.step_s),
        ratio_(sc.solver.ecu_ratio),
        period_s_(sc.ecu_timing.period_s),
        timeout_s_(opt.command_timeout_s > 0.0 ? opt.command_timeout_s : 3.0 * sc.ecu_timing.period_s),
        timeout_steps_(static_cast<std::int64_t>(std::floor(timeout_s_ / sc.solver.step_s + 1e-9))),
        filter_(F::kCommandIds),
        pacer_(clock_, std::max<std::int64_t>(1, static_cast<std::int64_t>(sc.solver.step_s * 1e9))) {
    log_buf_.reserve(2 * kLogFlushBytes);
  }

  bool open(const io::OutputDir& dir, std::string& error) override { return log_.open(dir.file("bus.log"), error); }

  void advance(Simulation& sim, std::int64_t max_steps, const std::atomic<int>* stop) override {
    if (!started_) {
      started_ = true;
      wait_for_peer(stop);
      first_command(sim, stop);
      if (!opt_.lockstep) pacer_.wait_for_step(0);
    }
    const std::int64_t end = std::min(sim.total_steps(), sim.step_index() + max_steps);
    while (!sim.finished() && sim.step_index() <= end) {
      if (stop != nullptr && stop->load(std::memory_order_relaxed) != 0) return;
      const std::int64_t n = sim.step_index();
      if (opt_.lockstep) {
        if (n % ratio_ == 0 && n != last_sample_) {
          send_sample(sim, n);
          wait_for_command(sim, n, stop);
        }
        check_staleness(sim, n);
        std::int64_t k = std::min({ratio_ - n % ratio_, sim.total_steps() - n, std::max<std::int64_t>(end - n, 0)});
        // a command that times out within this period does so at its step, not the next sample
        if (!safe_ && timeout_step() > n) k = std::min(k, timeout_step() - n);
        sim.step(k);
        if (k == 0 && !sim.finished()) return;  // the chunk is full: the rows go out first
      } else {
        drain(sim, n);
        if (n % ratio_ == 0 && n != last_sample_) send_sample(sim, n);
        check_staleness(sim, n);
        if (n >= end && n < sim.total_steps()) return;
        sim.step(n < sim.total_steps() ? 1 : 0);
        pacer_.wait_for_step(sim.step_index());
        period_error_.record(clock_.now_ns() - pacer_.last_deadline_ns());
      }
      if (log_buf_.size() > kLogFlushBytes) write_log(log_error_);  // flush() reports a failure
    }
  }

  bool flush(std::string& error) override {
    if (!log_error_.empty()) {  // an earlier write in the chunk failed: bus.log is incomplete
      error = log_error_;
      return false;
    }
    return write_log(error);
  }

  void report(io::JsonObject& summary, std::string& text) const override {
    const io::can::TransportCounters& tc = bus_.counters();
    const io::can::RxStats& rx = filter_.stats();
    io::JsonObject b;
    b.text("transport", bus_.describe());
    b.text("pacing", opt_.lockstep ? "lockstep" : "wall_clock");
    b.number("ecu_period_s", period_s_);
    b.number("command_timeout_s", timeout_s_);
    b.integer("frames_in", tc.frames_in);
    b.integer("frames_out", tc.frames_out);
    b.integer("frames_accepted", rx.accepted);
    io::JsonObject rej;
    rej.integer("unknown_id", rx.unknown_id);
    rej.integer("wrong_length", rx.wrong_length);
    rej.integer("bad_counter", rx.bad_counter);
    rej.integer("out_of_range", rx.out_of_range);
    rej.integer("stale", rx.stale);
    rej.integer("malformed", tc.rx_malformed);
    b.object("rejected", rej);
    b.integer("frames_lost", rx.lost);
    b.integer("send_dropped", tc.send_dropped);
    b.integer("error_frames", tc.error_frames);
    b.integer("commands_applied", commands_applied_);
    b.integer("stale_samples", stale_samples_);
    b.integer("timeouts", timeouts_);
    b.number("safe_state_time_s", static_cast<double>(safe_steps()) * h_s_);
    b.number("longest_command_gap_s", static_cast<double>(longest_gap_steps_) * h_s_);
    b.integer("saturated_signals", saturated_);
    b.integer("peers_connected", tc.peers_connected);
    b.integer("peers_lost", tc.peers_lost);
    io::JsonObject timing;
    const MicrosecondHistogram& hist = opt_.lockstep ? round_trip_ : period_error_;
    timing.number("p50", hist.quantile_us(0.5));
    timing.number("p99", hist.quantile_us(0.99));
    timing.number("max", hist.max_us());
    timing.integer("count", hist.count());
    if (opt_.lockstep) {
      b.integer("lockstep_waits_timed_out", waits_timed_out_);
      b.object("round_trip_us", timing);
    } else {
      b.integer("missed_ticks", pacer_.missed_ticks());
      b.object("period_error_us", timing);
    }
    summary.object("bus", b);

    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "bus           %s, %s: %lld frames in, %lld out, %lld rejected; %lld commands, %lld stale samples, "
                  "%lld timeouts (%.3f s in the safe state), longest command gap %.3f s\n",
                  bus_.describe().c_str(), opt_.lockstep ? "lockstep" : "wall clock",
                  static_cast<long long>(tc.frames_in), static_cast<long long>(tc.frames_out),
                  static_cast<long long>(rx.unknown_id + rx.wrong_length + rx.bad_counter + rx.out_of_range + rx.stale +
                                         tc.rx_malformed),
                  static_cast<long long>(commands_applied_), static_cast<long long>(stale_samples_),
                  static_cast<long long>(timeouts_), static_cast<double>(safe_steps()) * h_s_,
                  static_cast<double>(longest_gap_steps_) * h_s_);
    text += buf;
    std::snprintf(buf, sizeof buf, "bus timing    %s p50 %.0f us, p99 %.0f us, max %.0f us\n",
                  opt_.lockstep ? "round trip" : "period error", hist.quantile_us(0.5), hist.quantile_us(0.99),
                  hist.max_us());
    text += buf;
  }

 private:
  // steps spent in the safe state (up to the last one seen, if still in it)
  std::int64_t safe_steps() const { return safe_steps_ + (safe_ ? last_step_ - safe_since_step_ : 0); }

  void wait_for_peer(const std::atomic<int>* stop) {
    const std::int64_t deadline = clock_.now_ns() + static_cast<std::int64_t>(opt_.peer_wait_s * 1e9);
    while (!bus_.has_peer() && clock_.now_ns() < deadline) {
      if (stop != nullptr && stop->load() != 0) return;
      bus_.wait(10'000'000);
      Frame buf[64];
      while (std::size_t k = bus_.receive(buf)) log_frames(std::span<const Frame>(buf, k));  // nothing is ours yet
    }
  }

  // t = 0 waits for the ECU's first command (both pacers): sample 0 is sent again every
  // lockstep_wait_s until it answers, up to peer_wait_s (an ECU on SocketCAN may start after
  // the plant: there is no connection to wait for). A silence after that is a timeout.
  void first_command(Simulation& sim, const std::atomic<int>* stop) {
    const std::int64_t deadline = clock_.now_ns() + static_cast<std::int64_t>(opt_.peer_wait_s * 1e9);
    for (;;) {
      send_sample(sim, 0);
      if (wait_for_command(sim, 0, stop, false)) return;
      if (clock_.now_ns() > deadline || (stop != nullptr && stop->load() != 0)) return;
    }
  }

  void log_frames(std::span<const Frame> frames) {
    const double t = wall_time_s();
    for (const Frame& f : frames) io::can::append_candump_line(log_buf_, t, opt_.log_interface, f);
  }

  bool write_log(std::string& error) {
    if (!error.empty()) {  // failed before: bus.log is incomplete, keep memory bounded
      log_buf_.clear();
      return false;
    }
    if (log_buf_.empty()) return true;
    const bool ok = log_.write(log_buf_, error);
    log_buf_.clear();
    return ok;
  }

  // The sensors at t_n, then PlantStatus (the end of the sample).
  void send_sample(Simulation& sim, std::int64_t n) {
    if (last_sample_ >= 0 && last_sample_ != n && !command_since_sample_) ++stale_samples_;
    command_since_sample_ = false;
    last_sample_ = n;
    Sensors s;
    sim.read_sensors(s);
    const io::can::PlantStatus status{static_cast<std::uint32_t>(n), s.fault, s.locked, safe_};
    std::array<Frame, F::kSensorIds.size()> frames;
    saturated_ += io::can::encode(s, status, tx_, frames);
    for (const Frame& f : frames) bus_.send(f);
    log_frames(frames);
    received_mask_ = 0;  // a command for this sample: all its frames after these
    sent_ns_ = clock_.now_ns();
  }

  // Until the command of the sample is complete (true), or the wait runs out.
  bool wait_for_command(Simulation& sim, std::int64_t n, const std::atomic<int>* stop, bool count = true) {
    const std::int64_t deadline = sent_ns_ + static_cast<std::int64_t>(opt_.lockstep_wait_s * 1e9);
    for (;;) {
      if (drain(sim, n)) {
        round_trip_.record(clock_.now_ns() - sent_ns_);
        return true;
      }
      const std::int64_t left = deadline - clock_.now_ns();
      if (left <= 0 || (stop != nullptr && stop->load() != 0)) {
        waits_timed_out_ += count ? 1 : 0;
        return false;
      }
      bus_.wait(std::min<std::int64_t>(left, 50'000'000));
    }
  }

  // Everything received: checked, logged, applied; a complete command goes to the plant.
  // True if one did.
  bool drain(Simulation& sim, std::int64_t n) {
    bool applied = false;
    Frame buf[64];
    while (const std::size_t k = bus_.receive(buf)) {
      log_frames(std::span<const Frame>(buf, k));
      for (std::size_t i = 0; i < k; ++i) {
        // lockstep: the command of this sample only; wall clock: one no older than the timeout
        const io::can::Freshness fresh{static_cast<std::uint32_t>(std::max<std::int64_t>(last_sample_, 0)),
                                       opt_.lockstep ? 0u : static_cast<std::uint32_t>(std::min<std::int64_t>(timeout_steps_, 0xFFFF))};
        if (filter_.accept(buf[i], &fresh) != io::can::Reject::kNone) continue;
        io::can::apply(buf[i], incoming_);
        for (std::size_t j = 0; j < F::kCommandIds.size(); ++j) {
          if (F::kCommandIds[j] == buf[i].id) received_mask_ |= 1u << j;
        }
        if (received_mask_ == (1u << F::kCommandIds.size()) - 1) {
          received_mask_ = 0;
          apply_command(sim, n);
          applied = true;
        }
      }
    }
    return applied;
  }

  void apply_command(Simulation& sim, std::int64_t n) {
    applied_ = incoming_;
    sim.write_command(applied_);
    ++commands_applied_;
    command_since_sample_ = true;
    longest_gap_steps_ = std::max(longest_gap_steps_, n - last_command_step_);
    last_command_step_ = n;
    if (safe_) safe_steps_ += n - safe_since_step_;  // fresh commands end the safe state
    safe_ = false;
  }

  // The first step at which the held command is older than the timeout.
  std::int64_t timeout_step() const { return last_command_step_ + timeout_steps_ + 1; }

  void check_staleness(Simulation& sim, std::int64_t n) {
    last_step_ = n;
    if (safe_) {
      longest_gap_steps_ = std::max(longest_gap_steps_, n - last_command_step_);
      return;
    }
    if (n < timeout_step()) return;
    safe_ = true;
    safe_since_step_ = n;
    ++timeouts_;
    Command safe = applied_;
    F::make_safe(safe);
    sim.write_command(safe);
    filter_.resync();  // a restarted ECU starts its counters anew
    received_mask_ = 0;
  }

  io::can::Transport& bus_;
  BusPlantOptions opt_;
  double h_s_;
  std::int64_t ratio_;
  double period_s_, timeout_s_;
  std::int64_t timeout_steps_;
  io::can::FrameFilter filter_;
  io::can::TxCounters tx_;
  Command incoming_{}, applied_{};
  unsigned received_mask_ = 0;
  bool started_ = false, safe_ = false, command_since_sample_ = false;
  std::int64_t last_sample_ = -1, last_command_step_ = 0, sent_ns_ = 0;
  std::int64_t commands_applied_ = 0, stale_samples_ = 0, timeouts_ = 0, safe_steps_ = 0, longest_gap_steps_ = 0;
  std::int64_t saturated_ = 0, waits_timed_out_ = 0, safe_since_step_ = 0, last_step_ = 0;
  SteadyClock clock_;
  WallClock<SteadyClock> pacer_;
  MicrosecondHistogram round_trip_, period_error_;
  io::TextFileWriter log_;
  std::string log_buf_;
  std::string log_error_;  // the first failed write of bus.log within a chunk
};

}  // namespace

bool can_run_on_bus(const Scenario& sc, std::string& why) {
  if (!std::holds_alternative<plant::PsdParams>(sc.plant) && !std::holds_alternative<plant::BevParams>(sc.plant)) {
    why = sc.name + ": its vehicle (" + sc.vehicle_path +
          ") has no bus messages (the EV and the power-split hybrid talk to an ECU; the rigs do not)";
    return false;
  }
  if (sc.solver.ecu_latency_steps != 0) {
    why = sc.name + ": vehicle.ecu.latency_s = " + io::number_text(sc.ecu_timing.latency_s) +
          " belongs to the built-in ECU; on a bus the latency is the bus's own (set it to 0)";
    return false;
  }
  return true;
}

std::unique_ptr<ExternalDriver> make_bus_plant(const Scenario& sc, io::can::Transport& bus, const BusPlantOptions& opt,
                                               std::string& error) {
  if (!can_run_on_bus(sc, error)) return nullptr;
  if (std::holds_alternative<plant::PsdParams>(sc.plant)) return std::make_unique<BusPlant<msgs::PsdSensors>>(sc, bus, opt);
  return std::make_unique<BusPlant<msgs::EvSensors>>(sc, bus, opt);
}

}  // namespace ehpt::hil
