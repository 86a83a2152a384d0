// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The built-in ECU as a bus ECU sees the plant: with ecu.codec = "can", the sensor message is
// encoded into the contract's frames and decoded again before the ECU reads it, and its
// command likewise before the plant gets it (io/can/codec.hpp). That is exactly what happens
// when the same ECU runs as its own process on the bus (`ehpt ecu`) in lockstep, so this
// in-process run is the bus run's reference, bit for bit. Without the codec it is a plain
// pass-through.

#include <array>
#include <cstdint>
#include <memory>

#include "io/can/codec.hpp"

namespace ehpt::hil {

// The frames of each message (for the encode/decode round trip).
template <class Msg>
struct CanFramesOf;
template <>
struct CanFramesOf<msgs::PsdSensors> {
  static constexpr std::size_t kCount = io::can::kPsdSensorIds.size();
};
template <>
struct CanFramesOf<msgs::EvSensors> {
  static constexpr std::size_t kCount = io::can::kEvSensorIds.size();
};
template <>
struct CanFramesOf<msgs::ShevSensors> {
  static constexpr std::size_t kCount = io::can::kShevSensorIds.size();
};
template <>
struct CanFramesOf<msgs::PsdCommand> {
  static constexpr std::size_t kCount = io::can::kPsdCommandIds.size();
};
template <>
struct CanFramesOf<msgs::EvCommand> {
  static constexpr std::size_t kCount = io::can::kEvCommandIds.size();
};
template <>
struct CanFramesOf<msgs::ShevCommand> {
  static constexpr std::size_t kCount = io::can::kShevCommandIds.size();
};

// What an ECU process decodes from the plant's frames: the sensor message with its fault and
// locked bits from PlantStatus. The stamp is not on the bus beyond PlantStatus.step; the
// receiver rebuilds it (ehpt ecu: time = step * h), and the built-in ECUs do not read it.
template <class Sensors>
Sensors through_can(const Sensors& in, io::can::TxCounters& tx, std::int64_t& saturated) {
  std::array<io::can::Frame, CanFramesOf<Sensors>::kCount> frames;
  const io::can::PlantStatus status{static_cast<std::uint32_t>(in.stamp.step), in.fault, in.locked, false};
  saturated += io::can::encode(in, status, tx, frames);
  Sensors out{};
  io::can::PlantStatus got;
  for (const auto& f : frames) {
    io::can::apply(f, out);
    io::can::apply(f, got);
  }
  out.fault = got.fault;
  out.locked = got.locked;
  out.stamp = in.stamp;
  return out;
}

// The command as the plant decodes it: every field is on the bus.
template <class Command>
void command_through_can(Command& c, io::can::TxCounters& tx, std::int64_t& saturated) {
  std::array<io::can::Frame, CanFramesOf<Command>::kCount> frames;
  saturated += io::can::encode(c, tx, frames);
  const msgs::Stamp stamp = c.stamp;
  for (const auto& f : frames) io::can::apply(f, c);
  c.stamp = stamp;
}

template <class Controller>
class CodecEcu {
 public:
  CodecEcu(std::unique_ptr<Controller> inner, bool through_can) : inner_(std::move(inner)), through_can_(through_can) {}
  // A copy owns a copy of the ECU (a saved simulation state: Simulation::save_state); assigning
  // one copies into the ECU already owned.
  CodecEcu(const CodecEcu& o)
      : inner_(o.inner_ ? std::make_unique<Controller>(*o.inner_) : nullptr),
        through_can_(o.through_can_),
        tx_(o.tx_),
        saturated_(o.saturated_) {}
  CodecEcu& operator=(const CodecEcu& o) {
    if (this == &o) return *this;
    if (!o.inner_) {
      inner_.reset();
    } else if (inner_) {
      *inner_ = *o.inner_;
    } else {
      inner_ = std::make_unique<Controller>(*o.inner_);
    }
    through_can_ = o.through_can_;
    tx_ = o.tx_;
    saturated_ = o.saturated_;
    return *this;
  }
  CodecEcu(CodecEcu&&) = default;
  CodecEcu& operator=(CodecEcu&&) = default;

  // Run phase (no allocation).
  template <class Sensors, class Command>
  void update(const Sensors& sensors, Command& command) {
    if (!through_can_) {
      inner_->update(sensors, command);
      return;
    }
    const Sensors decoded = through_can(sensors, tx_, saturated_);
    inner_->update(decoded, command);
    command.stamp = sensors.stamp;  // the sample it answers (sampleStep), as `ehpt ecu` sends it
    command_through_can(command, tx_, saturated_);
  }
  std::int64_t saturated_signals() const { return saturated_; }

 private:
  std::unique_ptr<Controller> inner_;
  bool through_can_;
  io::can::TxCounters tx_;
  std::int64_t saturated_ = 0;
};

template <class T>
inline constexpr bool is_codec_ecu = false;
template <class C>
inline constexpr bool is_codec_ecu<CodecEcu<C>> = true;

}  // namespace ehpt::hil
