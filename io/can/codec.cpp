// SPDX-License-Identifier: BSD-3-Clause
#include "io/can/codec.hpp"

#include <algorithm>
#include <cmath>
#include <type_traits>

namespace ehpt::io::can {

namespace {

// The raw limits of a signal: its [min, max] in raw units (rounded like an encoded value, so
// that a saturated value decodes as in range, whatever the factor's binary representation).
std::int64_t raw_min(const SignalSpec& s) { return static_cast<std::int64_t>(std::llround((s.min - s.offset) / s.factor)); }
std::int64_t raw_max(const SignalSpec& s) { return static_cast<std::int64_t>(std::llround((s.max - s.offset) / s.factor)); }

// A message field bound to its signal, resolved at compile time (a misspelt name does not
// compile: the static_asserts below).
template <class Msg, class T = double>
struct Field {
  const SignalSpec* signal;
  T Msg::*member;
};
template <class Msg, class T = double>
constexpr Field<Msg, T> field(std::uint32_t id, std::string_view name, T Msg::*member) {
  return {find_signal(id, name), member};
}
template <class Msg, class T, std::size_t N>
constexpr bool all_resolved(const Field<Msg, T> (&fields)[N]) {
  for (const auto& f : fields) {
    if (f.signal == nullptr) return false;
  }
  return true;
}

using msgs::EvCommand;
using msgs::EvSensors;
using msgs::PsdCommand;
using msgs::PsdSensors;
using msgs::ShevCommand;
using msgs::ShevSensors;

constexpr Field<PsdSensors> kPsdSensorFields[] = {
    field(kPsdSensors1, "driverRequest", &PsdSensors::driverRequest),
    field(kPsdSensors1, "speed_m_s", &PsdSensors::speed_m_s),
    field(kPsdSensors1, "batSOC", &PsdSensors::batSOC),
    field(kPsdSensors2, "iceW_rad_s", &PsdSensors::iceW_rad_s),
    field(kPsdSensors2, "icePowDel_W", &PsdSensors::icePowDel_W),
    field(kPsdSensors2, "genW_rad_s", &PsdSensors::genW_rad_s),
    field(kPsdSensors3, "genPowDel_W", &PsdSensors::genPowDel_W),
    field(kPsdSensors3, "genTauLim_Nm", &PsdSensors::genTauLim_Nm),
    field(kPsdSensors3, "motW_rad_s", &PsdSensors::motW_rad_s),
    field(kPsdSensors4, "motPowDelA_W", &PsdSensors::motPowDelA_W),
    field(kPsdSensors4, "motPowDelB_W", &PsdSensors::motPowDelB_W),
    field(kPsdSensors4, "motPowDelAB_W", &PsdSensors::motPowDelAB_W),
    field(kPsdSensors5, "motTauLim_Nm", &PsdSensors::motTauLim_Nm),
    field(kPsdSensors5, "batPowDel_W", &PsdSensors::batPowDel_W),
    field(kPsdSensors5, "battery_voltage_V", &PsdSensors::battery_voltage_V),
    field(kPsdSensors6, "battery_current_A", &PsdSensors::battery_current_A),
};
static_assert(all_resolved(kPsdSensorFields));

constexpr Field<EvSensors> kEvSensorFields[] = {
    field(kEvSensors1, "driverRequest_Nm", &EvSensors::driverRequest_Nm),
    field(kEvSensors1, "speed_m_s", &EvSensors::speed_m_s),
    field(kEvSensors1, "batSOC", &EvSensors::batSOC),
    field(kEvSensors2, "driveW_rad_s", &EvSensors::driveW_rad_s),
    field(kEvSensors2, "driveTauLim_Nm", &EvSensors::driveTauLim_Nm),
    field(kEvSensors2, "drivePowDel_W", &EvSensors::drivePowDel_W),
    field(kEvSensors3, "batPowDel_W", &EvSensors::batPowDel_W),
    field(kEvSensors3, "battery_voltage_V", &EvSensors::battery_voltage_V),
    field(kEvSensors3, "battery_current_A", &EvSensors::battery_current_A),
};
static_assert(all_resolved(kEvSensorFields));

constexpr Field<ShevSensors> kShevSensorFields[] = {
    field(kShevSensors1, "driverRequest_Nm", &ShevSensors::driverRequest_Nm),
    field(kShevSensors1, "speed_m_s", &ShevSensors::speed_m_s),
    field(kShevSensors1, "batSOC", &ShevSensors::batSOC),
    field(kShevSensors2, "driveW_rad_s", &ShevSensors::driveW_rad_s),
    field(kShevSensors2, "driveTauLim_Nm", &ShevSensors::driveTauLim_Nm),
    field(kShevSensors2, "drivePowDc_W", &ShevSensors::drivePowDc_W),
    field(kShevSensors3, "gensetW_rad_s", &ShevSensors::gensetW_rad_s),
    field(kShevSensors3, "gensetPowDc_W", &ShevSensors::gensetPowDc_W),
    field(kShevSensors3, "batPowDel_W", &ShevSensors::batPowDel_W),
    field(kShevSensors4, "battery_voltage_V", &ShevSensors::battery_voltage_V),
    field(kShevSensors4, "battery_current_A", &ShevSensors::battery_current_A),
};
static_assert(all_resolved(kShevSensorFields));

constexpr Field<PsdCommand> kPsdCommandFields[] = {
    field(kPsdCommand1, "icePowRef_W", &PsdCommand::icePowRef_W),
    field(kPsdCommand1, "iceTauRef_Nm", &PsdCommand::iceTauRef_Nm),
    field(kPsdCommand2, "genTauRef_Nm", &PsdCommand::genTauRef_Nm),
    field(kPsdCommand2, "motTauRef_Nm", &PsdCommand::motTauRef_Nm),
};
static_assert(all_resolved(kPsdCommandFields));
constexpr Field<PsdCommand, bool> kPsdCommandFlags[] = {field(kPsdCommand1, "iceON", &PsdCommand::iceON)};
static_assert(all_resolved(kPsdCommandFlags));

constexpr Field<EvCommand> kEvCommandFields[] = {field(kEvCommand, "driveTauRef_Nm", &EvCommand::driveTauRef_Nm)};
static_assert(all_resolved(kEvCommandFields));

constexpr Field<ShevCommand> kShevCommandFields[] = {
    field(kShevCommand, "driveTauRef_Nm", &ShevCommand::driveTauRef_Nm),
    field(kShevCommand, "gensetPowRef_W", &ShevCommand::gensetPowRef_W),
};
static_assert(all_resolved(kShevCommandFields));
constexpr Field<ShevCommand, bool> kShevCommandFlags[] = {field(kShevCommand, "gensetON", &ShevCommand::gensetON)};
static_assert(all_resolved(kShevCommandFlags));

constexpr const SignalSpec* kStatusStep = find_signal(kPlantStatus, "step");
constexpr const SignalSpec* kStatusFault = find_signal(kPlantStatus, "fault");
constexpr const SignalSpec* kStatusLocked = find_signal(kPlantStatus, "locked");
constexpr const SignalSpec* kStatusTimeout = find_signal(kPlantStatus, "ecuTimeout");
constexpr bool found(const SignalSpec* s) { return s != nullptr; }
static_assert(found(kStatusStep) && found(kStatusFault) && found(kStatusLocked) && found(kStatusTimeout));

constexpr SignalSpec kCounter = detail::counter();
constexpr SignalSpec kSampleStep = detail::sample_step();

// The start of a frame of the contract: id, 8 bytes, its counter.
std::uint64_t start_frame(std::uint32_t id, TxCounters& tx) {
  std::uint64_t bits = 0;
  put_raw(bits, kCounter, tx.take(id));
  return bits;
}
Frame finish_frame(std::uint32_t id, std::uint64_t bits) {
  Frame f;
  f.id = id;
  set_payload(f, bits);
  return f;
}

// Encodes the fields of one frame (those whose signal belongs to id); returns saturations.
template <class Msg, class T, std::size_t N>
int put_fields(std::uint64_t& bits, std::uint32_t id, const Msg& m, const Field<Msg, T> (&fields)[N]) {
  int saturated = 0;
  const MessageSpec* spec = find_message(id);
  for (const auto& f : fields) {
    if (f.signal < spec->signals.data() || f.signal >= spec->signals.data() + spec->signals.size()) continue;
    const Raw r = to_raw(*f.signal, static_cast<double>(m.*f.member));
    put_raw(bits, *f.signal, r.value);
    saturated += r.saturated ? 1 : 0;
  }
  return saturated;
}
template <class Msg, class T, std::size_t N>
void get_fields(const Frame& frame, Msg& m, const Field<Msg, T> (&fields)[N]) {
  const MessageSpec* spec = find_message(frame.id);
  if (spec == nullptr) return;
  const std::uint64_t bits = payload(frame);
  for (const auto& f : fields) {
    if (f.signal < spec->signals.data() || f.signal >= spec->signals.data() + spec->signals.size()) continue;
    const double v = to_physical(*f.signal, get_raw(bits, *f.signal));
    if constexpr (std::is_same_v<T, bool>) {
      m.*f.member = v != 0.0;
    } else {
      m.*f.member = v;
    }
  }
}

int encode_status(const PlantStatus& st, TxCounters& tx, Frame& out) {
  std::uint64_t bits = start_frame(kPlantStatus, tx);
  put_raw(bits, *kStatusStep, st.step);
  const Raw fault = to_raw(*kStatusFault, st.fault);
  put_raw(bits, *kStatusFault, fault.value);
  put_raw(bits, *kStatusLocked, st.locked ? 1 : 0);
  put_raw(bits, *kStatusTimeout, st.ecu_timeout ? 1 : 0);
  out = finish_frame(kPlantStatus, bits);
  return fault.saturated ? 1 : 0;
}

template <class Msg, std::size_t N, std::size_t M>
int encode_sensors(const Msg& s, const PlantStatus& st, TxCounters& tx, const std::array<std::uint32_t, N>& ids,
                   std::span<Frame, N> out, const Field<Msg> (&fields)[M]) {
  int saturated = 0;
  for (std::size_t i = 0; i + 1 < N; ++i) {
    std::uint64_t bits = start_frame(ids[i], tx);
    saturated += put_fields(bits, ids[i], s, fields);
    out[i] = finish_frame(ids[i], bits);
  }
  saturated += encode_status(st, tx, out[N - 1]);  // the last frame: the sample is complete
  return saturated;
}

}  // namespace

std::uint64_t payload(const Frame& f) {
  std::uint64_t bits = 0;
  for (int i = 7; i >= 0; --i) bits = (bits << 8) | f.data[static_cast<std::size_t>(i)];
  return bits;
}

void set_payload(Frame& f, std::uint64_t bits) {
  f.len = 8;
  for (std::size_t i = 0; i < 8; ++i) f.data[i] = static_cast<std::uint8_t>(bits >> (8 * i));
}

Raw to_raw(const SignalSpec& s, double physical) {
  if (std::isnan(physical)) return {std::clamp<std::int64_t>(0, raw_min(s), raw_max(s)), true};
  Raw r;
  if (physical < s.min) {
    physical = s.min;
    r.saturated = true;
  } else if (physical > s.max) {
    physical = s.max;
    r.saturated = true;
  }
  r.value = std::clamp(static_cast<std::int64_t>(std::llround((physical - s.offset) / s.factor)), raw_min(s), raw_max(s));
  return r;
}

double to_physical(const SignalSpec& s, std::int64_t raw) { return static_cast<double>(raw) * s.factor + s.offset; }

void put_raw(std::uint64_t& bits, const SignalSpec& s, std::int64_t raw) {
  const std::uint64_t mask = s.length >= 64 ? ~0ULL : (1ULL << s.length) - 1;
  bits &= ~(mask << s.start_bit);
  bits |= (static_cast<std::uint64_t>(raw) & mask) << s.start_bit;
}

std::int64_t get_raw(std::uint64_t bits, const SignalSpec& s) {
  const std::uint64_t mask = s.length >= 64 ? ~0ULL : (1ULL << s.length) - 1;
  const std::uint64_t u = (bits >> s.start_bit) & mask;
  if (s.is_signed && s.length < 64 && (u >> (s.length - 1)) != 0) {
    return static_cast<std::int64_t>(u | ~mask);  // sign-extend
  }
  return static_cast<std::int64_t>(u);
}

bool raw_in_range(const SignalSpec& s, std::int64_t raw) { return raw >= raw_min(s) && raw <= raw_max(s); }

std::uint8_t TxCounters::take(std::uint32_t id) {
  const int i = message_index(id);
  if (i < 0) return 0;
  const std::uint8_t c = next_[static_cast<std::size_t>(i)];
  next_[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>((c + 1) & 0x0F);
  return c;
}

int encode(const msgs::PsdSensors& s, const PlantStatus& st, TxCounters& tx, std::span<Frame, kPsdSensorIds.size()> out) {
  return encode_sensors(s, st, tx, kPsdSensorIds, out, kPsdSensorFields);
}
int encode(const msgs::EvSensors& s, const PlantStatus& st, TxCounters& tx, std::span<Frame, kEvSensorIds.size()> out) {
  return encode_sensors(s, st, tx, kEvSensorIds, out, kEvSensorFields);
}
int encode(const msgs::ShevSensors& s, const PlantStatus& st, TxCounters& tx,
           std::span<Frame, kShevSensorIds.size()> out) {
  return encode_sensors(s, st, tx, kShevSensorIds, out, kShevSensorFields);
}
int encode(const msgs::PsdCommand& c, TxCounters& tx, std::span<Frame, kPsdCommandIds.size()> out) {
  int saturated = 0;
  for (std::size_t i = 0; i < kPsdCommandIds.size(); ++i) {
    std::uint64_t bits = start_frame(kPsdCommandIds[i], tx);
    put_raw(bits, kSampleStep, c.stamp.step & 0xFFFF);
    saturated += put_fields(bits, kPsdCommandIds[i], c, kPsdCommandFields);
    saturated += put_fields(bits, kPsdCommandIds[i], c, kPsdCommandFlags);
    out[i] = finish_frame(kPsdCommandIds[i], bits);
  }
  return saturated;
}
int encode(const msgs::EvCommand& c, TxCounters& tx, std::span<Frame, kEvCommandIds.size()> out) {
  std::uint64_t bits = start_frame(kEvCommand, tx);
  put_raw(bits, kSampleStep, c.stamp.step & 0xFFFF);
  const int saturated = put_fields(bits, kEvCommand, c, kEvCommandFields);
  out[0] = finish_frame(kEvCommand, bits);
  return saturated;
}

int encode(const msgs::ShevCommand& c, TxCounters& tx, std::span<Frame, kShevCommandIds.size()> out) {
  std::uint64_t bits = start_frame(kShevCommand, tx);
  put_raw(bits, kSampleStep, c.stamp.step & 0xFFFF);
  int saturated = put_fields(bits, kShevCommand, c, kShevCommandFields);
  saturated += put_fields(bits, kShevCommand, c, kShevCommandFlags);
  out[0] = finish_frame(kShevCommand, bits);
  return saturated;
}

const char* reject_name(Reject r) {
  switch (r) {
    case Reject::kNone: return "none";
    case Reject::kUnknownId: return "unknown_id";
    case Reject::kWrongLength: return "wrong_length";
    case Reject::kBadCounter: return "bad_counter";
    case Reject::kOutOfRange: return "out_of_range";
    case Reject::kStale: return "stale";
  }
  return "?";
}

Reject check_frame(const Frame& f, std::span<const std::uint32_t> accepted_ids) {
  bool ours = false;
  for (std::uint32_t id : accepted_ids) ours = ours || id == f.id;
  ours = ours && !f.extended;  // the contract's ids are all standard ones
  const MessageSpec* spec = ours ? find_message(f.id) : nullptr;
  if (spec == nullptr) return Reject::kUnknownId;
  if (f.len != spec->dlc) return Reject::kWrongLength;
  const std::uint64_t bits = payload(f);
  for (const SignalSpec& s : spec->signals) {
    if (!raw_in_range(s, get_raw(bits, s))) return Reject::kOutOfRange;
  }
  return Reject::kNone;
}

std::uint32_t command_age_steps(const Frame& command, std::uint32_t sample_step) {
  const auto echo = static_cast<std::uint32_t>(get_raw(payload(command), kSampleStep));
  return (sample_step - echo) & 0xFFFF;
}

int counter_step(int last_counter, int counter) {
  if (last_counter < 0) return 1;
  const int delta = (counter - last_counter) & 0x0F;
  return delta >= 1 && delta <= kMaxCounterJump ? delta : 0;
}

void apply(const Frame& f, msgs::PsdSensors& s) { get_fields(f, s, kPsdSensorFields); }
void apply(const Frame& f, msgs::EvSensors& s) { get_fields(f, s, kEvSensorFields); }
void apply(const Frame& f, msgs::PsdCommand& c) {
  get_fields(f, c, kPsdCommandFields);
  get_fields(f, c, kPsdCommandFlags);
}
void apply(const Frame& f, msgs::EvCommand& c) { get_fields(f, c, kEvCommandFields); }
void apply(const Frame& f, msgs::ShevSensors& s) { get_fields(f, s, kShevSensorFields); }
void apply(const Frame& f, msgs::ShevCommand& c) {
  get_fields(f, c, kShevCommandFields);
  get_fields(f, c, kShevCommandFlags);
}
void apply(const Frame& f, PlantStatus& st) {
  if (f.id != kPlantStatus) return;
  const std::uint64_t bits = payload(f);
  st.step = static_cast<std::uint32_t>(get_raw(bits, *kStatusStep));
  st.fault = static_cast<unsigned>(get_raw(bits, *kStatusFault));
  st.locked = get_raw(bits, *kStatusLocked) != 0;
  st.ecu_timeout = get_raw(bits, *kStatusTimeout) != 0;
}

FrameFilter::FrameFilter(std::span<const std::uint32_t> accepted_ids) {
  for (std::uint32_t id : accepted_ids) {
    if (count_ < ids_.size()) ids_[count_++] = id;
  }
  last_counter_.fill(-1);
}

Reject FrameFilter::accept(const Frame& f, const Freshness* freshness) {
  Reject r = check_frame(f, std::span<const std::uint32_t>(ids_.data(), count_));
  if (r == Reject::kNone && freshness != nullptr && find_signal(f.id, "sampleStep") != nullptr &&
      command_age_steps(f, freshness->sample_step) > freshness->max_age_steps) {
    r = Reject::kStale;
  }
  std::size_t slot = 0;
  while (r == Reject::kNone && ids_[slot] != f.id) ++slot;
  if (r == Reject::kNone) {
    const int counter = static_cast<int>(get_raw(payload(f), kCounter));
    const int step = counter_step(last_counter_[slot], counter);
    if (step == 0) {
      r = Reject::kBadCounter;
      last_counter_[slot] = counter;  // the next in order is heard (a repeat changes nothing)
    } else {
      stats_.lost += step - 1;
      last_counter_[slot] = counter;
    }
  }
  switch (r) {
    case Reject::kNone: ++stats_.accepted; break;
    case Reject::kUnknownId: ++stats_.unknown_id; break;
    case Reject::kWrongLength: ++stats_.wrong_length; break;
    case Reject::kBadCounter: ++stats_.bad_counter; break;
    case Reject::kOutOfRange: ++stats_.out_of_range; break;
    case Reject::kStale: ++stats_.stale; break;
  }
  return r;
}

void FrameFilter::resync() { last_counter_.fill(-1); }

}  // namespace ehpt::io::can
