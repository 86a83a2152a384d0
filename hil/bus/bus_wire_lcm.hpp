// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The LCM side of the bus plant (hil/bus/bus_plant.cpp): a sample goes out as one message on
// <prefix>PLANT_STATUS (sensors and status, doubles), a command comes in as one message on
// <prefix>ECU_COMMAND. A command is taken if it decodes, answers a sample no older than the
// freshness allows (lockstep: the current one), names this plant's session (another plant's
// command on the same URL and prefix is counted as foreign), and is newer than the last one
// taken (a repeat or a replay is refused). Sessions are recorded with lcm-logger (no bus.log).
// Run phase: ehpt allocates nothing (fixed buffers); liblcm's own per-message copy is
// outside the plant's step (see io/lcm/lcm_bus.hpp).

#include <array>
#include <chrono>
#include <random>
#include <cstdint>
#include <string>
#include <vector>

#include "hil/bus/bus_family.hpp"
#include "io/lcm/lcm_bus.hpp"
#include "io/lcm/lcm_codec.hpp"
#include "io/output_dir.hpp"

namespace ehpt::hil {

// A plant session's id: random (two plants started in the same microsecond, from the same
// scenario, still differ), positive and non-zero (0 is what an ECU that does not copy it sends).
inline std::int64_t new_lcm_session_id() {
  std::random_device rd;
  for (;;) {
    const std::uint64_t v = (static_cast<std::uint64_t>(rd()) << 32) ^ static_cast<std::uint64_t>(rd());
    const auto id = static_cast<std::int64_t>(v >> 1);
    if (id != 0) return id;
  }
}

inline std::int64_t lcm_utime_now() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

template <class Sensors>
class LcmWire {
  using F = BusFamily<Sensors>;
  using SensorsMsg = typename io::lcm::LcmTypesOf<Sensors>::SensorsMsg;
  using CommandMsg = typename io::lcm::LcmTypesOf<Sensors>::CommandMsg;

 public:
  using Command = typename F::Command;
  static constexpr const char* kUnit = "messages";

  // Start-up: subscribes to the command channel (ok() false and error set if it cannot).
  LcmWire(io::lcm::LcmBus& bus, const std::string& prefix)
      : bus_(bus),
        status_channel_(prefix + "PLANT_STATUS"),
        command_channel_(prefix + "ECU_COMMAND"),
        session_(new_lcm_session_id()) {
    out_.resize(static_cast<std::size_t>(SensorsMsg{}.getEncodedSize()));
    ok_ = bus_.subscribe(command_channel_, &LcmWire::on_message, this, error_);
  }

  bool open(const io::OutputDir&, std::string& error) {
    if (!ok_) error = error_;
    return ok_;
  }
  bool has_peer() const { return true; }  // LCM has no connections: t = 0 waits for a first command
  void wait(std::int64_t timeout_ns) { bus_.wait(timeout_ns); }
  std::string describe() const { return "lcm:" + bus_.url(); }
  void idle() {
    bus_.handle_now();
    pending_count_ = 0;
  }

  int send_sample(const Sensors& s, std::int64_t, bool ecu_timeout) {
    SensorsMsg m{};
    io::lcm::to_lcm(s, lcm_utime_now(), ecu_timeout, m);
    m.session = session_;
    const int n = m.encode(out_.data(), 0, static_cast<int>(out_.size()));
    if (n > 0) bus_.publish(status_channel_.c_str(), out_.data(), n);
    return 0;  // doubles: nothing saturates
  }

  template <class OnCommand>
  void receive(std::int64_t /*now_step*/, std::int64_t sample_step, std::int64_t max_age_steps, OnCommand&& on_command) {
    sample_step_ = sample_step;
    max_age_steps_ = max_age_steps;
    bus_.handle_now();  // on_message runs for each message that has arrived
    for (std::size_t i = 0; i < pending_count_; ++i) on_command(pending_[i]);
    pending_count_ = 0;
  }

  void resync() { last_step_ = -1; }
  // Bus faults act on CAN frames: an LCM session refuses them (bus_faults_refused), so no
  // fault ever acts on its messages.
  static constexpr bool kTakesBusFaults = false;
  bool has_faults() const { return false; }
  bool set_fault_mask(std::uint64_t) { return false; }
  bool sample_intact() const { return true; }
  bool sample_resolved() const { return false; }
  // one message is the whole command: the plant's own timeout and staleness rule
  bool message_timed_out(std::int64_t) { return false; }
  bool sample_stale(std::int64_t, bool command_since_sample, std::int64_t) const { return !command_since_sample; }
  double command_timeout_s() const { return 0.0; }  // a restarted ECU's first command is taken as it is
  bool flush(std::string&) { return true; }
  void finish() {}
  void set_background_writer(bool) {}  // no log of its own (lcm-logger records LCM)
  void background_flush() {}

  void report(io::JsonObject& b, std::int64_t& rejected) const {
    b.integer("messages_in", bus_.counters().received);
    b.integer("messages_out", bus_.counters().published);
    b.integer("session", session_);
    b.integer("messages_accepted", accepted_);
    io::JsonObject rej;
    rej.integer("malformed", malformed_);
    rej.integer("stale", stale_);
    rej.integer("repeated", repeated_);
    rej.integer("non_finite", non_finite_);
    rej.integer("foreign", foreign_);
    b.object("rejected", rej);
    b.integer("send_dropped", bus_.counters().publish_failed);
    rejected = malformed_ + stale_ + repeated_ + non_finite_ + foreign_;
  }
  // Why the bus itself degraded the session (ExternalDriver::degraded_reasons).
  void degraded_reasons(std::vector<std::string>& why) const {
    if (bus_.counters().publish_failed > 0) {
      why.push_back(std::to_string(bus_.counters().publish_failed) + " messages the plant could not publish");
    }
    if (foreign_ > 0) {  // another plant shares the URL and prefix: its ECU may be confused by ours
      why.push_back(std::to_string(foreign_) +
                    " commands named another plant session on this URL and prefix (ignored): give each plant its "
                    "own --lcm-prefix");
    }
  }
  std::int64_t messages_in() const { return bus_.counters().received; }
  std::int64_t messages_out() const { return bus_.counters().published; }

 private:
  static void on_message(const void* data, int size, void* user) {
    auto* self = static_cast<LcmWire*>(user);
    CommandMsg m{};
    if (m.decode(data, 0, size) != size) {
      ++self->malformed_;
      return;
    }
    if (m.session != self->session_) {  // another plant's ECU on this URL and prefix (or none copied)
      ++self->foreign_;
      return;
    }
    // the sample it answers: no older than allowed, not ahead of the newest one sent
    if (m.step > self->sample_step_ || m.step < self->sample_step_ - self->max_age_steps_) {
      ++self->stale_;
      return;
    }
    if (m.step <= self->last_step_) {  // the same sample again, or an older one: a repeat
      ++self->repeated_;
      return;
    }
    if (self->pending_count_ == self->pending_.size()) {
      ++self->stale_;  // more fresh commands in one drain than the buffer holds: this one waits no more
      return;
    }
    Command c{};
    io::lcm::from_lcm(m, c);
    if (!msgs::all_finite(c)) {  // +inf, -inf, NaN: never applied (CAN cannot carry one at all)
      ++self->non_finite_;
      return;
    }
    self->last_step_ = m.step;
    ++self->accepted_;
    self->pending_[self->pending_count_++] = c;
  }

  io::lcm::LcmBus& bus_;
  std::string status_channel_, command_channel_;
  std::int64_t session_;
  std::vector<std::uint8_t> out_;
  bool ok_ = false;
  std::string error_;
  std::int64_t sample_step_ = 0, max_age_steps_ = 0, last_step_ = -1;
  std::array<Command, 16> pending_{};
  std::size_t pending_count_ = 0;
  std::int64_t accepted_ = 0, malformed_ = 0, stale_ = 0, repeated_ = 0, non_finite_ = 0, foreign_ = 0;
};

}  // namespace ehpt::hil
