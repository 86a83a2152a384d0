// SPDX-License-Identifier: BSD-3-Clause
#include "hil/bus/bus_faults.hpp"

#include <algorithm>
#include <cmath>

#include "hil/config/scenario.hpp"
#include "io/can/e2e.hpp"
#include "io/number_format.hpp"

namespace ehpt::hil {

namespace {

// Lost frames a delay may hold per direction: every frame of the longest delay, with room.
constexpr std::size_t kMinRing = 64;

std::uint64_t splitmix(std::uint64_t& state) {  // FaultInjector's NoiseSource, the same stream
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

const io::can::DbcSignal* counter_of(const BoundMessage& m) {
  for (const BoundSignal& b : m.signals) {
    if (b.role == BoundRole::kCounter) return b.signal;
  }
  return nullptr;
}

}  // namespace

bool BusFaults::resolve(const std::vector<FaultSpec>& faults, const Binding& binding, double step_s,
                        std::int64_t ecu_ratio, bool error_frames_ok, BusFaults& out,
                        std::vector<std::string>& errors) {
  out = BusFaults{};
  std::vector<std::string> names;
  for (const BoundMessage& m : binding.send) names.push_back(m.message->name);
  for (const BoundMessage& m : binding.receive) names.push_back(m.message->name);
  std::int64_t longest_delay = 0;
  const std::size_t errors_before = errors.size();
  for (std::size_t i = 0; i < faults.size(); ++i) {
    const FaultSpec& s = faults[i];
    if (s.side != FaultSide::kBus) continue;
    const std::string label = s.where + ": fault[" + std::to_string(i) + "] (kind = \"" +
                              fault_effect_name(s.effect) + "\", target = \"" + s.target + "\")";
    // sample 0 is how the plant finds its ECU (sent again until answered): never faulted
    const double first_s = step_s * static_cast<double>(std::max<std::int64_t>(1, ecu_ratio));
    if (!s.has_when && s.at_s < first_s * (1.0 - 1e-9)) {
      errors.push_back(label + ": at_s = " + io::number_text(s.at_s) + ": a bus fault starts at the ECU's second sample (at_s >= " +
                       io::number_text(first_s) + " s) or later: sample 0 is the plant's first exchange, how it finds "
                       "its ECU, and is never faulted");
      continue;
    }
    if (s.effect == FaultEffect::kErrorFrames && !error_frames_ok) {
      errors.push_back(label + ": CAN error frames need a bus that carries them: SocketCAN (--bus socketcan:vcan0); "
                       "socketcand's protocol has none (bus_off silences the bus on any CAN transport)");
      continue;
    }
    Fault x;
    x.effect = s.effect;
    x.bit = 1ull << i;
    x.kind = fault_effect_name(s.effect);
    x.name = s.target;
    x.ecu_ratio = std::max<std::int64_t>(1, ecu_ratio);
    if (s.effect == FaultEffect::kErrorFrames) {  // frames of their own, once per sample
      x.whole_bus = true;
      out.faults_.push_back(x);
      out.bits_ |= x.bit;
      continue;
    }
    if (s.effect == FaultEffect::kBusOff) {  // every message, both ways
      x.whole_bus = true;
      x.error_edges = error_frames_ok;
      x.direction = Direction::kTx;
      out.faults_.push_back(x);
      x.direction = Direction::kRx;
      out.faults_.push_back(x);
      out.bits_ |= x.bit;
      continue;
    }
    const BoundMessage* m = nullptr;
    for (std::size_t j = 0; j < binding.send.size() && m == nullptr; ++j) {
      if (binding.send[j].message->name == s.target) {
        m = &binding.send[j];
        x.direction = Direction::kTx;
        x.message = j;
      }
    }
    for (std::size_t j = 0; j < binding.receive.size() && m == nullptr; ++j) {
      if (binding.receive[j].message->name == s.target) {
        m = &binding.receive[j];
        x.direction = Direction::kRx;
        x.message = j;
      }
    }
    if (m == nullptr) {
      const std::string near = closest_name(s.target, names);
      std::string list;
      for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
      errors.push_back(label + ": no message of that name in " + binding.file + " (" + list + ")" +
                       (near.empty() ? "" : "; did you mean \"" + near + "\"?"));
      continue;
    }
    const int size = m->message->size_bytes;
    x.counter = counter_of(*m);
    x.e2e = m->e2e ? &*m->e2e : nullptr;
    switch (s.effect) {
      case FaultEffect::kDrop:
        x.probability = s.probability;
        x.pattern = s.pattern;
        x.rng = s.seed;
        break;
      case FaultEffect::kCorrupt:
        if (s.byte >= size) {
          errors.push_back(label + ": byte = " + std::to_string(s.byte) + " is outside the frame (" + m->message->name +
                           " has " + std::to_string(size) + " bytes: 0 .. " + std::to_string(size - 1) + ")");
        }
        x.byte = s.byte;
        x.mask = s.mask;
        break;
      case FaultEffect::kBadCrc:
        if (x.e2e == nullptr) {
          errors.push_back(label + ": " + m->message->name + " has no E2E protection in " + binding.file +
                           ", so it has no CRC to spoil (corrupt a byte instead)");
        } else {
          x.crc_byte = x.e2e->crc_byte;
        }
        break;
      case FaultEffect::kCounterFreeze:
      case FaultEffect::kCounterJump:
        if (x.counter == nullptr && x.e2e == nullptr) {
          errors.push_back(label + ": " + m->message->name + " carries no counter in " + binding.file +
                           " (neither `counter` nor E2E protection)");
        }
        x.jump = s.jump;
        break;
      case FaultEffect::kDelay: {
        const double samples = s.delay_s / (step_s * static_cast<double>(x.ecu_ratio));
        x.delay_steps = static_cast<std::int64_t>(std::llround(samples)) * x.ecu_ratio;  // whole (checked at load)
        longest_delay = std::max(longest_delay, x.delay_steps / x.ecu_ratio);
        break;
      }
      case FaultEffect::kPeriod:
        x.period_samples =
            std::max<std::int64_t>(1, std::llround(s.period_s / (step_s * static_cast<double>(x.ecu_ratio))));
        break;
      default: break;
    }
    out.bits_ |= x.bit;
    out.faults_.push_back(std::move(x));
  }
  // a delayed frame waits in its direction's ring: every frame of the longest delay (each
  // message once per sample, twice if duplicated too), fixed here
  const std::size_t per_sample = 2 * std::max(binding.send.size(), binding.receive.size()) + 2;
  const std::size_t slots = std::max(kMinRing, static_cast<std::size_t>(longest_delay + 1) * per_sample);
  for (DirState& d : out.dir_) d.ring.slots.resize(longest_delay > 0 ? slots : 1);
  return errors.size() == errors_before;
}

bool BusFaults::drops(Fault& x) {
  if (!x.pattern.empty()) {
    const bool lost = x.pattern[x.pattern_pos] == '1';
    x.pattern_pos = (x.pattern_pos + 1) % x.pattern.size();
    return lost;
  }
  if (x.probability >= 1.0) return true;
  const double u = static_cast<double>(splitmix(x.rng) >> 11) * 0x1.0p-53;  // [0, 1)
  return u < x.probability;
}

bool BusFaults::rewrite_counter(Fault& x, io::can::Frame& f) {
  const std::span<std::uint8_t> data(f.data.data(), f.len);
  if (x.counter != nullptr) {
    const std::uint64_t mask = io::can::raw_mask(x.counter->length);
    const std::uint64_t raw = io::can::extract_raw(*x.counter, data);
    if (x.effect == FaultEffect::kCounterFreeze) {
      if (x.frozen < 0) x.frozen = static_cast<std::int64_t>(raw);
      io::can::insert_raw(*x.counter, static_cast<std::uint64_t>(x.frozen), data);
    } else {
      io::can::insert_raw(*x.counter, (raw + static_cast<std::uint64_t>(x.jump)) & mask, data);
    }
  }
  if (x.e2e != nullptr) {  // the sender's counter is wrong, its CRC right: the receiver sees a sequence error
    const int at = x.e2e->counter_bit;
    const std::size_t byte = static_cast<std::size_t>(at / 8);
    const int shift = at % 8;
    const int modulo = io::can::e2e_counter_modulo(*x.e2e);
    const int c = (data[byte] >> shift) & 0xF;
    int next = c;
    if (x.effect == FaultEffect::kCounterFreeze) {
      if (x.frozen_e2e < 0) x.frozen_e2e = c;
      next = static_cast<int>(x.frozen_e2e);
    } else {
      next = (c + x.jump) % modulo;
    }
    io::can::e2e_protect(*x.e2e, data, static_cast<std::uint8_t>(next));
  }
  return true;
}

void BusFaults::report(io::JsonObject& bus) const {
  std::vector<io::JsonObject> list;
  for (std::size_t i = 0; i < faults_.size(); ++i) {
    const Fault& x = faults_[i];
    if (x.whole_bus && x.direction == Direction::kRx) continue;  // bus_off: one entry (its Tx one)
    std::int64_t frames = x.frames;
    if (x.effect == FaultEffect::kBusOff && i + 1 < faults_.size()) frames += faults_[i + 1].frames;  // both ways
    io::JsonObject o;
    o.text("kind", x.kind);
    o.text("message", x.name);
    o.text("direction", x.effect == FaultEffect::kErrorFrames ? "error_frames"
                        : x.whole_bus                          ? "both"
                        : x.direction == Direction::kTx        ? "plant_to_ecu"
                                                               : "ecu_to_plant");
    o.integer("frames", frames);
    list.push_back(o);
  }
  bus.objects("faults", list);
  bus.integer("fault_frames_lost_full_ring", dir_[0].ring_overflow + dir_[1].ring_overflow);
}

}  // namespace ehpt::hil
