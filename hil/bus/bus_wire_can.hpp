// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The CAN side of the bus plant (hil/bus/bus_plant.cpp), driven by a binding (hil/bus/bus_binding.hpp):
// a sample goes out as the binding's [[send]] messages, a command comes in as its [[receive]]
// messages; ehpt's own contract (io/can/ehpt.dbc) is the default binding. Every frame in and
// out goes to bus.log (candump -L) and, if asked, to bus.asc (Vector ASC, with each frame's
// direction). Run phase: no allocation (the binding's tables are fixed at load).
//
// The rules, the codec's (io/can/codec.hpp) for every binding:
//   encode: physical value -> clamp to the signal's [min, max] (counted as saturated) ->
//           raw = round((value - offset) / factor), half away from zero -> bits;
//   receive, in this order: unknown id (not a bound message, or the other frame format),
//           wrong length, E2E (bad_crc: CRC or data id; bad_counter: its alive counter), a
//           bound signal outside its [min, max] (out_of_range), an echo older than allowed
//           (stale), a rolling counter that repeated or jumped (bad_counter). A rejected frame
//           changes nothing.
//   a command is complete when every received field has come since the last sample (lockstep,
//   or a binding with an echo: per sample), or since the last resync (wall clock without an
//   echo: the latest value of each signal, as a cyclic ECU sends them); a message older than
//   its timeout puts the plant in its safe state (message_timed_out).
//
// Bus faults (hil/bus/bus_faults.hpp) act on the frames between the plant and the wire: a
// sent frame as it leaves, a received one before the rules see it; bus.log has the frames as
// they went on (sent) and as the plant's rules got them (received). In lockstep, a sample is
// intact when no fault acted on its frames or on the sample's before (else the ECU may or may
// not answer it: the plant does not wait, and a late answer is stale), and resolved when every frame of its command has
// come from the ECU, whatever the faults then did to them (the plant need not wait longer).

#include <array>
#include <cstdint>
#include <ctime>
#include <span>
#include <string>
#include <vector>

#include "hil/bus/bus_binding.hpp"
#include "hil/bus/bus_faults.hpp"
#include "hil/bus/bus_family.hpp"
#include "hil/run/latency_histogram.hpp"
#include "hil/run/pacer.hpp"
#include "io/can/asc_log.hpp"
#include "io/can/candump_log.hpp"
#include "io/can/codec.hpp"
#include "io/can/socketcan.hpp"
#include "io/can/transport.hpp"
#include "io/handoff_buffer.hpp"
#include "io/output_dir.hpp"
#include "io/text_file.hpp"
#include "msgs/fields.hpp"

namespace ehpt::hil {

template <class Sensors>
class CanWire {
  using F = BusFamily<Sensors>;

 public:
  using Command = typename F::Command;

  // step_s: the plant's step; lockstep: commands per sample; command_timeout_s: the plant's
  // (for received messages whose binding gives none and that have no cycle time)
  CanWire(io::can::Transport& bus, Binding binding, double step_s, bool lockstep, double command_timeout_s,
          std::string log_interface, bool asc = false)
      : bus_(bus),
        binding_(std::move(binding)),
        step_s_(step_s),
        per_sample_(lockstep || binding_.echo),
        log_interface_(std::move(log_interface)),
        log_buf_(kLogFlushBytes),
        asc_(asc),
        asc_buf_(asc ? kLogFlushBytes : 1) {
    line_.reserve(96 + log_interface_.size());  // one candump (or ASC) line: never more
    head_.reserve(32 + log_interface_.size());
    tx_.resize(binding_.send.size());
    for (std::size_t i = 0; i < tx_.size(); ++i) {  // unbound signals: their start values, once
      const io::can::DbcMessage& m = *binding_.send[i].message;
      for (const io::can::DbcSignal& sig : m.signals) {
        if (sig.start_value_raw && sig.value_type == io::can::SignalValueType::kInteger) {
          // the DBC's raw number, any size: through the codec's rule, clamped into what is allowed
          bool clamped = false;
          const std::uint64_t raw = io::can::encode_codec_rule(
              sig, io::can::codec_raw_range(sig), *sig.start_value_raw * sig.factor + sig.offset, clamped);
          io::can::insert_raw(sig, raw, std::span<std::uint8_t>(tx_[i].start.data(), static_cast<std::size_t>(m.size_bytes)));
        }
      }
    }
    rx_.resize(binding_.receive.size());
    for (std::size_t j = 0; j < rx_.size(); ++j) {
      const double t = binding_.receive[j].timeout_s > 0.0 ? binding_.receive[j].timeout_s : command_timeout_s;
      rx_[j].timeout_steps = static_cast<std::int64_t>(std::floor(t / step_s + 1e-9));
      if (!per_sample_) timeout_s_ = std::max(timeout_s_, t);  // per sample: the plant's timeout alone
    }
    for (const auto& [field, value] : binding_.unbound) Fields<Command>()[static_cast<std::size_t>(field)].set(incoming_, value);
    for (std::size_t j = 0; j < rx_.size(); ++j) {  // resolution (bus faults): each message's fields and echo
      for (const BoundSignal& b : binding_.receive[j].signals) {
        if (b.role == BoundRole::kField) rx_[j].field_bits |= b.mask_bit;
        if (b.role == BoundRole::kEcho) rx_[j].echo = b.signal;
      }
    }
  }

  // The scenario's bus faults on this wire's binding (BusFaults::resolve), before the run.
  void set_faults(BusFaults faults) { faults_ = std::move(faults); }
  static constexpr bool kTakesBusFaults = true;
  bool has_faults() const { return !faults_.empty(); }
  // The faults acting at the exchange about to happen (FaultInjector::mask, this step's).
  // True if a bus fault acts.
  bool set_fault_mask(std::uint64_t mask) {
    fault_mask_ = mask & faults_.bits();
    return fault_mask_ != 0;
  }
  // Lockstep: whether the last sample's frames went out untouched by a fault.
  bool sample_intact() const { return sample_intact_; }
  // Lockstep: whether every frame of the last sample's command has come (before the faults).
  bool sample_resolved() const { return (arrived_mask_ & binding_.complete_mask) == binding_.complete_mask; }

  // Cyclic: the command timeout the plant applies to the command as a whole, the longest
  // message timeout (each message also has its own, message_timed_out); per sample: 0 (the
  // plant's own).
  double command_timeout_s() const { return timeout_s_; }
  const Binding& binding() const { return binding_; }

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
  // A run into memory: bus.log (and bus.asc) not written.
  void discard_files() {
    log_.discard();
    asc_log_.discard();
    no_log_ = true;  // nor formatted: the text was two thirds of such a run's time
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

  // The [[send]] messages due at this sample, in the binding's order (ehpt's contract: the
  // sensors, then PlantStatus, the end of the sample); returns signals saturated.
  int send_sample(const Sensors& s, std::int64_t step, bool ecu_timeout) {
    int saturated = 0;
    const auto emit = [&](const io::can::Frame& out) {
      bus_.send(out);
      log_frames(std::span<const io::can::Frame>(&out, 1), false);
    };
    bool intact = true;
    bus_.cork();  // the sample's frames leave together (Transport::cork), at the end
    if (!faults_.empty()) {  // error frames, then frames held from earlier samples that are due now
      faults_.error_frames(fault_mask_, [&](io::can::ErrorFrame kind) {
        if (bus_.send_error(kind)) log_error_frame(kind);
      });
      faults_.release(BusFaults::Direction::kTx, step, emit);
      faults_.release_held(BusFaults::Direction::kTx, fault_mask_, emit);
    }
    for (std::size_t i = 0; i < binding_.send.size(); ++i) {
      const BoundMessage& m = binding_.send[i];
      TxState& tx = tx_[i];
      if (!per_sample_ && m.cycle_ms > 0 && tx.last_step >= 0 &&
          static_cast<double>(step - tx.last_step) * step_s_ < m.cycle_ms * 1e-3 - 0.5 * step_s_) {
        continue;  // not due: a cyclic message goes out at its own cycle on the plant's clock
      }
      tx.last_step = step;
      io::can::Frame f;
      f.id = m.message->id;
      f.extended = m.message->extended;
      f.len = static_cast<std::uint8_t>(m.message->size_bytes);
      f.data = tx.start;
      const std::span<std::uint8_t> data(f.data.data(), f.len);
      for (const BoundSignal& b : m.signals) {
        const std::uint64_t mask = io::can::raw_mask(b.signal->length);
        switch (b.role) {
          case BoundRole::kField: {
            const double v = Fields<Sensors>()[static_cast<std::size_t>(b.field)].get(s);
            bool sat = false;
            io::can::insert_raw(*b.signal, io::can::encode_codec_rule(*b.signal, b.raw, b.to_si == 1.0 ? v : v / b.to_si, sat),
                                data);
            saturated += sat ? 1 : 0;
            break;
          }
          case BoundRole::kPlantStep:
            io::can::insert_raw(*b.signal, static_cast<std::uint64_t>(step) & mask, data);
            break;
          case BoundRole::kEcuTimeout:
            io::can::insert_raw(*b.signal, ecu_timeout ? 1u : 0u, data);
            break;
          case BoundRole::kCounter:
            io::can::insert_raw(*b.signal, tx.counter & mask, data);
            ++tx.counter;
            break;
          case BoundRole::kEcho:
            break;
        }
      }
      if (m.e2e) {
        io::can::e2e_protect(*m.e2e, data, static_cast<std::uint8_t>(tx.e2e_counter));
        tx.e2e_counter = (tx.e2e_counter + 1) % static_cast<unsigned>(io::can::e2e_counter_modulo(*m.e2e));
      }
      if (faults_.empty()) {
        emit(f);
      } else if (!faults_.process(BusFaults::Direction::kTx, i, f, step, fault_mask_, emit)) {
        intact = false;
      }
    }
    bus_.uncork();
    // the sample after a faulted one too: its first frame after a gap (or a counter put back)
    // may be refused by the ECU's counter rule, and then the ECU does not answer
    sample_intact_ = intact && previous_intact_;
    previous_intact_ = intact;
    if (per_sample_) {  // a command for this sample: all its frames after these
      received_mask_ = 0;
      arrived_mask_ = 0;
    }
    return saturated;
  }

  // Everything received: logged, checked (an echo against the newest sample), applied;
  // on_command(command) for each complete one. now_step: the plant's step (message ages).
  template <class OnCommand>
  void receive(std::int64_t now_step, std::int64_t sample_step, std::int64_t max_age_steps, OnCommand&& on_command) {
    io::can::Frame buf[64];
    std::int64_t t_ns = 0;  // when the batch was read (per sample)
    // one frame as the plant's rules get it (after the faults, if any)
    const auto take = [&](const io::can::Frame& f) {
      if (!faults_.empty()) log_frames(std::span<const io::can::Frame>(&f, 1), true);
      const bool first = received_mask_ == 0;
      if (!accept(f, now_step, sample_step, max_age_steps)) return;
      if (per_sample_ && first && received_mask_ != 0) first_frame_ns_ = t_ns;
      if ((received_mask_ & binding_.complete_mask) != binding_.complete_mask) return;
      if (per_sample_) {
        received_mask_ = 0;
        command_spread_.record(t_ns - first_frame_ns_);
      }
      on_command(incoming_);
    };
    if (!faults_.empty()) {  // frames delayed to this step, a frame held back by a reorder that ended
      t_ns = per_sample_ ? clock_.now_ns() : 0;
      faults_.release(BusFaults::Direction::kRx, now_step, take);
      faults_.release_held(BusFaults::Direction::kRx, fault_mask_, take);
    }
    // until a receive comes back short: the transport had no more (Transport::receive)
    for (std::size_t k = std::size(buf); k == std::size(buf);) {
      k = bus_.receive(buf);
      if (k == 0) break;
      if (faults_.empty()) log_frames(std::span<const io::can::Frame>(buf, k), true);
      t_ns = per_sample_ ? clock_.now_ns() : 0;
      for (std::size_t i = 0; i < k; ++i) {
        if (faults_.empty()) {
          take(buf[i]);
          continue;
        }
        const std::size_t j = receive_index(buf[i]);
        if (j == binding_.receive.size()) {  // no bound message: no fault acts on it
          take(buf[i]);
          continue;
        }
        note_arrival(j, buf[i], sample_step);
        faults_.process(BusFaults::Direction::kRx, j, buf[i], now_step, fault_mask_, take);
      }
    }
  }

  // Wall clock without an echo: whether a received message is older than its timeout at step
  // n (the plant then goes to its safe state and calls resync). Counted per message.
  bool message_timed_out(std::int64_t n) {
    if (per_sample_) return false;  // the command as a whole (the plant's timeout)
    bool out = false;
    for (RxState& r : rx_) {
      if (r.last_step >= 0 && n - r.last_step > r.timeout_steps) {
        ++r.timeouts;
        r.last_step = -1;  // counted once; it must come again
        out = true;
      }
    }
    return out;
  }
  // Whether the ECU left this sample without a fresh command: per sample, no command since the
  // last one; cyclic, a received message older than 1.5 of its cycles (of ECU periods: period_steps).
  bool sample_stale(std::int64_t n, bool command_since_sample, std::int64_t period_steps) const {
    if (per_sample_) return !command_since_sample;
    for (std::size_t j = 0; j < rx_.size(); ++j) {
      const int cycle_ms = binding_.receive[j].cycle_ms;
      const double cycle_steps = cycle_ms > 0 ? cycle_ms * 1e-3 / step_s_ : static_cast<double>(period_steps);
      if (rx_[j].last_step < 0 || static_cast<double>(n - rx_[j].last_step) > 1.5 * cycle_steps) return true;
    }
    return false;
  }

  // The stream went stale (safe state): a restarted ECU starts its counters anew.
  void resync() {
    for (RxState& r : rx_) {
      r.last_counter = -1;
      r.e2e.reset();
    }
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
    RxCounts total;
    total.unknown_id = unknown_id_;
    io::JsonObject messages;
    for (std::size_t j = 0; j < rx_.size(); ++j) {
      const RxCounts& c = rx_[j].counts;
      total.add(c);
      io::JsonObject m;
      m.integer("accepted", c.accepted);
      m.integer("wrong_length", c.wrong_length);
      m.integer("bad_crc", c.bad_crc);
      m.integer("bad_counter", c.bad_counter);
      m.integer("out_of_range", c.out_of_range);
      m.integer("stale", c.stale);
      m.integer("lost", c.lost);
      m.integer("timed_out", rx_[j].timeouts);
      messages.object(binding_.receive[j].message->name, m);
    }
    b.text("binding", binding_.file);
    b.text("dbc", binding_.dbc.file);
    b.integer("frames_in", tc.frames_in);
    b.integer("frames_out", tc.frames_out);
    b.integer("frames_accepted", total.accepted);
    io::JsonObject rej;
    rej.integer("unknown_id", total.unknown_id);
    rej.integer("wrong_length", total.wrong_length);
    rej.integer("bad_crc", total.bad_crc);
    rej.integer("bad_counter", total.bad_counter);
    rej.integer("out_of_range", total.out_of_range);
    rej.integer("stale", total.stale);
    rej.integer("malformed", tc.rx_malformed);
    rej.integer("before_start", before_start_);
    b.object("rejected", rej);
    b.object("messages_received", messages);
    if (per_sample_) {  // how far apart a sample's command frames came (Nagle made it a period)
      io::JsonObject spread;
      spread.number("p50", static_cast<double>(command_spread_.quantile_ns(0.5)) * 1e-3);
      spread.number("p99", static_cast<double>(command_spread_.quantile_ns(0.99)) * 1e-3);
      spread.number("max", static_cast<double>(command_spread_.max_ns()) * 1e-3);
      spread.integer("count", command_spread_.count());
      b.object("command_frames_spread_us", spread);
    }
    b.integer("frames_lost", total.lost);
    b.integer("send_dropped", tc.send_dropped);
    b.integer("slow_client_drops", tc.slow_drops);
    b.integer("error_frames", tc.error_frames);
    b.integer("peers_connected", tc.peers_connected);
    b.integer("peers_lost", tc.peers_lost);
    b.integer("peers_refused", tc.peers_refused);
    b.integer("peers_evicted", tc.peers_evicted);
    if (!faults_.empty()) faults_.report(b);
    rejected = total.unknown_id + total.wrong_length + total.bad_crc + total.bad_counter + total.out_of_range +
               total.stale + tc.rx_malformed + before_start_;
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

  template <class M>
  static constexpr const auto& Fields() {
    return msgs::FieldTable<M>::kFields;
  }
  // One received frame through the rules (the header's order); true if accepted (its fields
  // are then in incoming_ and their bits in received_mask_).
  std::size_t receive_index(const io::can::Frame& f) const {
    std::size_t j = 0;
    while (j < binding_.receive.size() &&
           (binding_.receive[j].message->id != f.id || binding_.receive[j].message->extended != f.extended)) {
      ++j;
    }
    return j;
  }
  // Resolution (bus faults, per sample): a frame of message j as the ECU sent it, before the
  // faults: if it answers this sample (its echo, or none to tell), its fields have come.
  void note_arrival(std::size_t j, const io::can::Frame& f, std::int64_t sample_step) {
    if (!per_sample_ || f.len != binding_.receive[j].message->size_bytes) return;
    if (const io::can::DbcSignal* echo = rx_[j].echo) {
      const std::uint64_t raw = io::can::extract_raw(*echo, std::span<const std::uint8_t>(f.data.data(), f.len));
      if (raw != (static_cast<std::uint64_t>(sample_step) & io::can::raw_mask(echo->length))) return;
    }
    arrived_mask_ |= rx_[j].field_bits;
  }
  bool accept(const io::can::Frame& f, std::int64_t now_step, std::int64_t sample_step, std::int64_t max_age_steps) {
    const std::size_t j = receive_index(f);
    if (j == binding_.receive.size()) {
      ++unknown_id_;
      return false;
    }
    const BoundMessage& m = binding_.receive[j];
    RxState& r = rx_[j];
    if (f.len != m.message->size_bytes) {
      ++r.counts.wrong_length;
      return false;
    }
    const std::span<const std::uint8_t> data(f.data.data(), f.len);
    if (m.e2e) {
      const io::can::E2eResult e = io::can::e2e_check(*m.e2e, data, r.e2e);
      if (e == io::can::E2eResult::kBadCrc || e == io::can::E2eResult::kBadDataId) {
        ++r.counts.bad_crc;
        return false;
      }
      if (e != io::can::E2eResult::kOk) {
        ++r.counts.bad_counter;
        return false;
      }
    }
    for (const BoundSignal& b : m.signals) {  // every bound signal in range first (the codec's order)
      if (!io::can::is_present(*m.message, *b.signal, data)) continue;
      if (b.signal->value_type != io::can::SignalValueType::kInteger) {
        const double v = io::can::decode(*b.signal, data);
        if (!std::isfinite(v) || (b.signal->has_range() && (v < b.signal->min || v > b.signal->max))) {
          ++r.counts.out_of_range;
          return false;
        }
        continue;
      }
      const std::int64_t raw = io::can::raw_to_int(*b.signal, io::can::extract_raw(*b.signal, data));
      if (raw < b.raw.lo || raw > b.raw.hi) {
        ++r.counts.out_of_range;
        return false;
      }
    }
    int counter = -1, counter_mask = 0;
    for (const BoundSignal& b : m.signals) {
      if (b.role == BoundRole::kEcho) {
        const std::uint64_t raw = io::can::extract_raw(*b.signal, data);
        const std::uint64_t mask = io::can::raw_mask(b.signal->length);
        const std::uint64_t age = (static_cast<std::uint64_t>(sample_step) - raw) & mask;
        if (age > static_cast<std::uint64_t>(std::min<std::int64_t>(max_age_steps, static_cast<std::int64_t>(mask)))) {
          ++r.counts.stale;
          return false;
        }
      }
      if (b.role == BoundRole::kCounter) {  // at most 16 bits (checked at load)
        counter = static_cast<int>(io::can::extract_raw(*b.signal, data));
        counter_mask = static_cast<int>(io::can::raw_mask(b.signal->length));
      }
    }
    if (counter >= 0) {  // the codec's counter rule (io/can/codec.hpp counter_step), mod 2^length
      if (r.last_counter >= 0) {
        const int delta = (counter - r.last_counter) & counter_mask;
        if (delta < 1 || delta > io::can::kMaxCounterJump) {
          r.last_counter = counter;  // the next in order is heard (the codec's rule)
          ++r.counts.bad_counter;
          return false;
        }
        r.counts.lost += delta - 1;
      }
      r.last_counter = counter;
    }
    ++r.counts.accepted;
    r.last_step = now_step;
    for (const BoundSignal& b : m.signals) {
      if (b.role != BoundRole::kField || !io::can::is_present(*m.message, *b.signal, data)) continue;
      const double v = io::can::decode(*b.signal, data);
      Fields<Command>()[static_cast<std::size_t>(b.field)].set(incoming_, b.to_si == 1.0 ? v : v * b.to_si);
      received_mask_ |= b.mask_bit;
    }
    return true;
  }

  // An error frame the plant put on the bus, in bus.log as candump -L writes one (bus.asc
  // leaves them out: its error-frame lines name a channel's own errors).
  void log_error_frame(io::can::ErrorFrame kind) {
    if (no_log_) return;
    std::uint32_t id = 0;
    std::array<std::uint8_t, 8> data{};
    io::can::error_frame_bits(kind, id, data);
    line_.clear();
    io::can::append_candump_error_line(line_, wall_time_s(), log_interface_, id, data);
    log_buf_.append(line_);
    if (!background_ && log_buf_.wants_writer()) background_flush();
  }

  static double wall_time_s() {
    timespec ts{};
    clock_gettime(CLOCK_REALTIME, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
  }
  // Every frame in and out; a full buffer is written out by the loop (also while a lockstep
  // wait takes in a flood) or handed to the writer thread. A failure is kept for flush().
  void log_frames(std::span<const io::can::Frame> frames, bool rx) {
    if (no_log_) return;
    const double t = wall_time_s();
    // the head "(time) interface" once per microsecond: a sample's frames share it
    if (const std::int64_t us = io::can::candump_time_us(t); us != head_us_) {
      head_.clear();
      io::can::append_candump_head(head_, t, log_interface_);
      head_us_ = us;
    }
    for (const auto& f : frames) {
      line_.assign(head_);
      io::can::append_candump_body(line_, f);
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

  struct TxState {
    std::int64_t last_step = -1;  // the step it last went out
    std::uint64_t counter = 0;    // its rolling counter's next value
    unsigned e2e_counter = 0;     // its E2E alive counter's next value
    std::array<std::uint8_t, 8> start{};  // its payload before the bound signals: start values of the others
  };
  struct RxCounts {
    std::int64_t accepted = 0, unknown_id = 0, wrong_length = 0, bad_crc = 0, bad_counter = 0, out_of_range = 0,
                 stale = 0, lost = 0;
    void add(const RxCounts& o) {
      accepted += o.accepted;
      wrong_length += o.wrong_length;
      bad_crc += o.bad_crc;
      bad_counter += o.bad_counter;
      out_of_range += o.out_of_range;
      stale += o.stale;
      lost += o.lost;
    }
  };
  struct RxState {
    int last_counter = -1;  // the rolling counter of the last accepted frame; -1: none (start, resync)
    io::can::E2eReceiver e2e;
    std::int64_t last_step = -1;  // the plant step it was last accepted at
    std::int64_t timeout_steps = 0;
    std::int64_t timeouts = 0;
    RxCounts counts;
    std::uint64_t field_bits = 0;               // its fields' bits in the completion mask
    const io::can::DbcSignal* echo = nullptr;   // its kEcho signal, if any
  };

  io::can::Transport& bus_;
  Binding binding_;
  double step_s_;
  bool per_sample_;        // a command is complete per sample (lockstep, or an echo)
  // From the first frame of a sample's command to the one that completes it, as read by the
  // plant (its resolution: how often the plant drains, every step in wall clock).
  SteadyClock clock_;
  std::int64_t first_frame_ns_ = 0;
  LatencyHistogram command_spread_;
  double timeout_s_ = 0.0;  // the longest received message's timeout
  std::vector<TxState> tx_;
  std::vector<RxState> rx_;
  std::int64_t unknown_id_ = 0;
  std::string log_interface_;
  Command incoming_{};
  std::uint64_t received_mask_ = 0;
  BusFaults faults_;               // the scenario's bus faults (none: frames pass untouched)
  std::uint64_t fault_mask_ = 0;   // the bus faults acting at this exchange
  bool sample_intact_ = true, previous_intact_ = true;
  std::uint64_t arrived_mask_ = 0;  // the fields of this sample's command that came (before faults)
  std::int64_t before_start_ = 0;  // frames that came before t = 0 (idle)
  io::TextFileWriter log_;
  io::HandoffBuffer log_buf_;
  std::string line_;       // one candump line (reserved)
  std::string head_;       // its head, "(time) interface" (reserved), at head_us_
  std::int64_t head_us_ = -1;
  bool background_ = false;
  bool no_log_ = false;     // a run into memory: bus.log neither written nor formatted
  std::string log_error_;  // the first failed write of bus.log or bus.asc (or the bytes dropped)
  bool asc_ = false;       // bus.asc too
  io::TextFileWriter asc_log_;
  io::HandoffBuffer asc_buf_;
  double asc_start_s_ = 0.0;  // wall time of the ASC log's start (its lines count from it)
};

}  // namespace ehpt::hil
