// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The CAN side of the bus plant (hil/bus/bus_plant.cpp): a sample goes out as the frames of
// io/can/ehpt.dbc, a command comes in as its frames, checked by the codec's rules; every frame
// in and out goes to bus.log (candump -L) and, if asked, to bus.asc (Vector ASC, with each
// frame's direction). Run phase: no allocation (fixed buffers).

#include <array>
#include <cstdint>
#include <ctime>
#include <span>
#include <string>
#include <vector>

#include "hil/bus/bus_family.hpp"
#include "io/can/asc_log.hpp"
#include "io/can/candump_log.hpp"
#include "io/can/codec.hpp"
#include "io/can/transport.hpp"
#include "io/handoff_buffer.hpp"
#include "io/output_dir.hpp"
#include "io/text_file.hpp"

namespace ehpt::hil {

template <class Sensors>
class CanWire {
  using F = BusFamily<Sensors>;

 public:
  using Command = typename F::Command;

  CanWire(io::can::Transport& bus, std::string log_interface, bool asc = false)
      : bus_(bus),
        log_interface_(std::move(log_interface)),
        filter_(F::kCanCommandIds),
        log_buf_(kLogFlushBytes),
        asc_(asc),
        asc_buf_(asc ? kLogFlushBytes : 1) {
    line_.reserve(96 + log_interface_.size());  // one candump (or ASC) line: never more
  }

  // The real-time loop: bus.log is written by its writer thread (background_flush), never by
  // the loop; otherwise by the loop itself once 1 MB has gathered, and between chunks.
  void set_background_writer(bool on) { background_ = on; }
  // The writer thread: the buffer the loop handed over, if any.
  void background_flush() {
    log_buf_.take_handed([&](std::string_view t) { write_log(t); });
    if (asc_) asc_buf_.take_handed([&](std::string_view t) { write_asc(t); });
  }

  bool open(const io::OutputDir& dir, std::string& error) {
    if (!log_.open(dir.file("bus.log"), error)) return false;
    if (!asc_) return true;
    if (!asc_log_.open(dir.file("bus.asc"), error)) return false;
    asc_start_s_ = wall_time_s();
    asc_buf_.append(io::can::asc_header(asc_start_s_));
    return true;
  }
  // After the last step: the ASC log's last line.
  void finish() {
    if (asc_) asc_buf_.append(io::can::asc_footer());
  }
  bool has_peer() const { return bus_.has_peer(); }
  void wait(std::int64_t timeout_ns) { bus_.wait(timeout_ns); }
  std::string describe() const { return bus_.describe(); }

  // Before t = 0: what comes in is logged, counted (rejected.before_start) and dropped: no
  // sample has gone out that it could answer.
  void idle() {
    io::can::Frame buf[64];
    while (const std::size_t k = bus_.receive(buf)) {
      log_frames(std::span<const io::can::Frame>(buf, k), true);
      before_start_ += static_cast<std::int64_t>(k);
    }
  }

  // The sensors, then PlantStatus (the end of the sample); returns signals saturated.
  int send_sample(const Sensors& s, std::int64_t step, bool ecu_timeout) {
    const io::can::PlantStatus status{static_cast<std::uint32_t>(step), s.fault, s.locked, ecu_timeout};
    std::array<io::can::Frame, F::kCanSensorIds.size()> frames;
    const int saturated = io::can::encode(s, status, tx_, frames);
    for (const auto& f : frames) bus_.send(f);
    log_frames(frames, false);
    received_mask_ = 0;  // a command for this sample: all its frames after these
    return saturated;
  }

  // Everything received: logged, checked (freshness against the newest sample), applied;
  // on_command(command) for each complete one.
  template <class OnCommand>
  void receive(std::int64_t sample_step, std::int64_t max_age_steps, OnCommand&& on_command) {
    const io::can::Freshness fresh{static_cast<std::uint32_t>(sample_step),
                                   static_cast<std::uint32_t>(std::min<std::int64_t>(max_age_steps, 0xFFFF))};
    io::can::Frame buf[64];
    while (const std::size_t k = bus_.receive(buf)) {
      log_frames(std::span<const io::can::Frame>(buf, k), true);
      for (std::size_t i = 0; i < k; ++i) {
        if (filter_.accept(buf[i], &fresh) != io::can::Reject::kNone) continue;
        io::can::apply(buf[i], incoming_);
        for (std::size_t j = 0; j < F::kCanCommandIds.size(); ++j) {
          if (F::kCanCommandIds[j] == buf[i].id) received_mask_ |= 1u << j;
        }
        if (received_mask_ == (1u << F::kCanCommandIds.size()) - 1) {
          received_mask_ = 0;
          on_command(incoming_);
        }
      }
    }
  }

  // The stream went stale (safe state): a restarted ECU starts its counters anew.
  void resync() {
    filter_.resync();
    received_mask_ = 0;
  }

  // Between chunks (and at the end, with no writer thread running): bus.log; false if a
  // write failed or text was dropped (the log is then incomplete).
  bool flush(std::string& error) {
    log_buf_.take_all([&](std::string_view t) { write_log(t); });
    if (asc_) {
      asc_buf_.take_all([&](std::string_view t) { write_asc(t); });
      if (log_error_.empty() && asc_buf_.dropped_bytes() > 0) {
        log_error_ = "bus.asc: " + std::to_string(asc_buf_.dropped_bytes()) + " bytes dropped (the writer fell behind)";
      }
    }
    if (log_error_.empty() && log_buf_.dropped_bytes() > 0) {
      log_error_ = "bus.log: " + std::to_string(log_buf_.dropped_bytes()) + " bytes dropped (the writer fell behind)";
    }
    if (!log_error_.empty()) {
      error = log_error_;
      return false;
    }
    return true;
  }

  // The wire's figures into summary.json's "bus"; rejected: their total.
  void report(io::JsonObject& b, std::int64_t& rejected) const {
    const io::can::TransportCounters& tc = bus_.counters();
    const io::can::RxStats& rx = filter_.stats();
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
    rej.integer("before_start", before_start_);
    b.object("rejected", rej);
    b.integer("frames_lost", rx.lost);
    b.integer("send_dropped", tc.send_dropped);
    b.integer("slow_client_drops", tc.slow_drops);
    b.integer("error_frames", tc.error_frames);
    b.integer("peers_connected", tc.peers_connected);
    b.integer("peers_lost", tc.peers_lost);
    b.integer("peers_refused", tc.peers_refused);
    b.integer("peers_evicted", tc.peers_evicted);
    rejected = rx.unknown_id + rx.wrong_length + rx.bad_counter + rx.out_of_range + rx.stale + tc.rx_malformed + before_start_;
  }
  // Why the bus itself degraded the session (ExternalDriver::degraded_reasons).
  void degraded_reasons(std::vector<std::string>& why) const {
    const io::can::TransportCounters& tc = bus_.counters();
    // CAN error frames degrade the session; socketcand's protocol errors are other clients'
    // (a port probe, a stray tool) and are counted, not held against the session
    if (tc.error_frames > 0 && bus_.describe().rfind("socketcand:", 0) != 0) {
      why.push_back(std::to_string(tc.error_frames) + " error frames on the bus");
    }
    if (tc.send_dropped > 0) {
      why.push_back(std::to_string(tc.send_dropped) + " frames the plant could not send (no ECU connected, or one too slow)");
    }
  }
  std::int64_t messages_in() const { return bus_.counters().frames_in; }
  std::int64_t messages_out() const { return bus_.counters().frames_out; }
  static constexpr const char* kUnit = "frames";

 private:
  // bus.log is written when this much is buffered (and between chunks)
  static constexpr std::size_t kLogFlushBytes = 1 << 20;

  static double wall_time_s() {
    timespec ts{};
    clock_gettime(CLOCK_REALTIME, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
  }
  // Every frame in and out; a full buffer is written out by the loop (also while a lockstep
  // wait takes in a flood) or handed to the writer thread. A failure is kept for flush().
  void log_frames(std::span<const io::can::Frame> frames, bool rx) {
    const double t = wall_time_s();
    for (const auto& f : frames) {
      line_.clear();
      io::can::append_candump_line(line_, t, log_interface_, f);
      log_buf_.append(line_);
      if (asc_) {
        line_.clear();
        io::can::append_asc_line(line_, t - asc_start_s_, f, rx);
        asc_buf_.append(line_);
      }
      if (!background_ && (log_buf_.wants_writer() || (asc_ && asc_buf_.wants_writer()))) background_flush();
    }
  }
  // Whoever writes (the loop or the writer thread, never both at once); after a failure
  // nothing more is written: bus.log is incomplete and the error says so.
  void write_log(std::string_view text) {
    if (log_error_.empty() && !text.empty()) log_.write(text, log_error_);
  }
  void write_asc(std::string_view text) {
    if (log_error_.empty() && !text.empty()) asc_log_.write(text, log_error_);
  }

  io::can::Transport& bus_;
  std::string log_interface_;
  io::can::FrameFilter filter_;
  io::can::TxCounters tx_;
  Command incoming_{};
  unsigned received_mask_ = 0;
  std::int64_t before_start_ = 0;  // frames that came before t = 0 (idle)
  io::TextFileWriter log_;
  io::HandoffBuffer log_buf_;
  std::string line_;       // one candump line (reserved)
  bool background_ = false;
  std::string log_error_;  // the first failed write of bus.log or bus.asc (or the bytes dropped)
  bool asc_ = false;       // bus.asc too
  io::TextFileWriter asc_log_;
  io::HandoffBuffer asc_buf_;
  double asc_start_s_ = 0.0;  // wall time of the ASC log's start (its lines count from it)
};

}  // namespace ehpt::hil
