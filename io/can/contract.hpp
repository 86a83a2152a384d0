// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The bus contract in C++: every frame and signal of io/can/ehpt.dbc, as constant tables. A
// test (tests/io/can_codec_test.cpp) parses the DBC and compares every signal's start bit,
// length, byte order, sign, factor, offset, min, max and unit with these tables, so the two
// cannot drift apart. Signal names are the msgs/ field names.
//
// Layout rules of the contract: classic CAN, 11-bit ids, 8-byte frames, little-endian (Intel)
// signals, a 4-bit rolling counter at bits 60..63 of every frame. Per ECU period the plant
// sends its sensor frames and then PlantStatus (the end of the sample); the ECU answers with
// its command frames, each echoing the sample's step (sampleStep, mod 2^16).

#include <array>
#include <cstdint>
#include <span>
#include <string_view>

namespace ehpt::io::can {

struct SignalSpec {
  std::string_view name;
  int start_bit = 0;       // least significant bit, little-endian bit numbering
  int length = 0;          // bits
  bool is_signed = false;  // two's complement
  double factor = 1.0, offset = 0.0;
  double min = 0.0, max = 0.0;  // physical range: encode saturates to it, decode rejects outside
  std::string_view unit;
};

enum class Sender { kPlant, kEcu };

struct MessageSpec {
  std::string_view name;
  std::uint32_t id = 0;
  int dlc = 8;
  int cycle_time_ms = 10;  // GenMsgCycleTime
  Sender sender = Sender::kPlant;
  std::span<const SignalSpec> signals;
};

// Frame ids (decimal in the DBC).
inline constexpr std::uint32_t kPsdCommand1 = 0x110, kPsdCommand2 = 0x111, kEvCommand = 0x120, kShevCommand = 0x130;
inline constexpr std::uint32_t kPlantStatus = 0x200;
inline constexpr std::uint32_t kPsdSensors1 = 0x210, kPsdSensors2 = 0x211, kPsdSensors3 = 0x212,
                               kPsdSensors4 = 0x213, kPsdSensors5 = 0x214, kPsdSensors6 = 0x215;
inline constexpr std::uint32_t kEvSensors1 = 0x220, kEvSensors2 = 0x221, kEvSensors3 = 0x222;
inline constexpr std::uint32_t kShevSensors1 = 0x230, kShevSensors2 = 0x231, kShevSensors3 = 0x232,
                               kShevSensors4 = 0x233;

inline constexpr int kCounterStartBit = 60;
inline constexpr int kCounterBits = 4;
inline constexpr int kDefaultCycleTimeMs = 10;

namespace detail {
// the signal kinds the contract uses, so that each is defined once
constexpr SignalSpec counter() { return {"counter", kCounterStartBit, kCounterBits, false, 1, 0, 0, 15, ""}; }
constexpr SignalSpec power_W(std::string_view n, int at) { return {n, at, 20, true, 0.5, 0, -250000, 250000, "W"}; }
constexpr SignalSpec speed_rad_s(std::string_view n, int at) { return {n, at, 20, true, 0.01, 0, -5000, 5000, "rad/s"}; }
constexpr SignalSpec torque_Nm(std::string_view n, int at) { return {n, at, 20, true, 0.001, 0, -500, 500, "Nm"}; }
// the EV's driver request is a speed controller's output (gain 1000 N m per m/s; US06 asks
// for up to 11 800 N m of a 150 N m drive, the rest of a braking request goes to the friction
// brake): wide, at 0.1 N m
constexpr SignalSpec ev_request_Nm(std::string_view n, int at) { return {n, at, 20, true, 0.1, 0, -50000, 50000, "Nm"}; }
constexpr SignalSpec ev_torque_Nm(std::string_view n, int at) { return {n, at, 20, true, 0.01, 0, -5000, 5000, "Nm"}; }
constexpr SignalSpec vehicle_speed(int at) { return {"speed_m_s", at, 20, true, 0.0002, 0, -100, 100, "m/s"}; }
constexpr SignalSpec soc(int at) { return {"batSOC", at, 20, false, 1e-6, 0, 0, 1, ""}; }
constexpr SignalSpec voltage_V(int at) { return {"battery_voltage_V", at, 20, false, 0.001, 0, 0, 1000, "V"}; }
constexpr SignalSpec current_A(int at) { return {"battery_current_A", at, 20, true, 0.001, 0, -500, 500, "A"}; }
constexpr SignalSpec flag(std::string_view n, int at) { return {n, at, 1, false, 1, 0, 0, 1, ""}; }
// every command echoes the step of the sample it answers (its freshness)
constexpr SignalSpec sample_step() { return {"sampleStep", 44, 16, false, 1, 0, 0, 65535, ""}; }

inline constexpr SignalSpec kPsdCommand1Signals[] = {
    power_W("icePowRef_W", 0), torque_Nm("iceTauRef_Nm", 20), flag("iceON", 40), sample_step(), counter()};
inline constexpr SignalSpec kPsdCommand2Signals[] = {torque_Nm("genTauRef_Nm", 0), torque_Nm("motTauRef_Nm", 20),
                                                     sample_step(), counter()};
inline constexpr SignalSpec kEvCommandSignals[] = {ev_request_Nm("driveTauRef_Nm", 0), sample_step(), counter()};
// the series hybrid's: the bus's drive asks and gives up to 1000 N m, its driver up to 2000 N m
// (PropDriver yMax); the EMS's power reference is clamped to 200 kW
inline constexpr SignalSpec kShevCommandSignals[] = {ev_torque_Nm("driveTauRef_Nm", 0), power_W("gensetPowRef_W", 20),
                                                     flag("gensetON", 40), sample_step(), counter()};
inline constexpr SignalSpec kPlantStatusSignals[] = {
    {"step", 0, 32, false, 1, 0, 0, 4294967295.0, ""},
    {"fault", 32, 8, false, 1, 0, 0, 255, ""},
    flag("locked", 40),
    flag("ecuTimeout", 41),
    counter()};
inline constexpr SignalSpec kPsdSensors1Signals[] = {
    {"driverRequest", 0, 20, true, 1e-5, 0, -5, 5, ""}, vehicle_speed(20), soc(40), counter()};
inline constexpr SignalSpec kPsdSensors2Signals[] = {speed_rad_s("iceW_rad_s", 0), power_W("icePowDel_W", 20),
                                                     speed_rad_s("genW_rad_s", 40), counter()};
inline constexpr SignalSpec kPsdSensors3Signals[] = {power_W("genPowDel_W", 0), torque_Nm("genTauLim_Nm", 20),
                                                     speed_rad_s("motW_rad_s", 40), counter()};
inline constexpr SignalSpec kPsdSensors4Signals[] = {power_W("motPowDelA_W", 0), power_W("motPowDelB_W", 20),
                                                     power_W("motPowDelAB_W", 40), counter()};
inline constexpr SignalSpec kPsdSensors5Signals[] = {torque_Nm("motTauLim_Nm", 0), power_W("batPowDel_W", 20),
                                                     voltage_V(40), counter()};
inline constexpr SignalSpec kPsdSensors6Signals[] = {current_A(0), counter()};
inline constexpr SignalSpec kEvSensors1Signals[] = {ev_request_Nm("driverRequest_Nm", 0), vehicle_speed(20), soc(40),
                                                    counter()};
inline constexpr SignalSpec kEvSensors2Signals[] = {speed_rad_s("driveW_rad_s", 0), ev_torque_Nm("driveTauLim_Nm", 20),
                                                    power_W("drivePowDel_W", 40), counter()};
inline constexpr SignalSpec kEvSensors3Signals[] = {power_W("batPowDel_W", 0), voltage_V(20), current_A(40), counter()};
inline constexpr SignalSpec kShevSensors1Signals[] = {ev_torque_Nm("driverRequest_Nm", 0), vehicle_speed(20), soc(40),
                                                      counter()};
inline constexpr SignalSpec kShevSensors2Signals[] = {speed_rad_s("driveW_rad_s", 0), ev_torque_Nm("driveTauLim_Nm", 20),
                                                      power_W("drivePowDc_W", 40), counter()};
inline constexpr SignalSpec kShevSensors3Signals[] = {speed_rad_s("gensetW_rad_s", 0), power_W("gensetPowDc_W", 20),
                                                      power_W("batPowDel_W", 40), counter()};
inline constexpr SignalSpec kShevSensors4Signals[] = {voltage_V(0), current_A(20), counter()};
}  // namespace detail

inline constexpr MessageSpec kMessages[] = {
    {"PsdCommand1", kPsdCommand1, 8, 10, Sender::kEcu, detail::kPsdCommand1Signals},
    {"PsdCommand2", kPsdCommand2, 8, 10, Sender::kEcu, detail::kPsdCommand2Signals},
    {"EvCommand", kEvCommand, 8, 10, Sender::kEcu, detail::kEvCommandSignals},
    {"ShevCommand", kShevCommand, 8, 10, Sender::kEcu, detail::kShevCommandSignals},
    {"PlantStatus", kPlantStatus, 8, 10, Sender::kPlant, detail::kPlantStatusSignals},
    {"PsdSensors1", kPsdSensors1, 8, 10, Sender::kPlant, detail::kPsdSensors1Signals},
    {"PsdSensors2", kPsdSensors2, 8, 10, Sender::kPlant, detail::kPsdSensors2Signals},
    {"PsdSensors3", kPsdSensors3, 8, 10, Sender::kPlant, detail::kPsdSensors3Signals},
    {"PsdSensors4", kPsdSensors4, 8, 10, Sender::kPlant, detail::kPsdSensors4Signals},
    {"PsdSensors5", kPsdSensors5, 8, 10, Sender::kPlant, detail::kPsdSensors5Signals},
    {"PsdSensors6", kPsdSensors6, 8, 10, Sender::kPlant, detail::kPsdSensors6Signals},
    {"EvSensors1", kEvSensors1, 8, 10, Sender::kPlant, detail::kEvSensors1Signals},
    {"EvSensors2", kEvSensors2, 8, 10, Sender::kPlant, detail::kEvSensors2Signals},
    {"EvSensors3", kEvSensors3, 8, 10, Sender::kPlant, detail::kEvSensors3Signals},
    {"ShevSensors1", kShevSensors1, 8, 10, Sender::kPlant, detail::kShevSensors1Signals},
    {"ShevSensors2", kShevSensors2, 8, 10, Sender::kPlant, detail::kShevSensors2Signals},
    {"ShevSensors3", kShevSensors3, 8, 10, Sender::kPlant, detail::kShevSensors3Signals},
    {"ShevSensors4", kShevSensors4, 8, 10, Sender::kPlant, detail::kShevSensors4Signals},
};
inline constexpr std::size_t kMessageCount = std::size(kMessages);

// The message with this id, or nullptr.
constexpr const MessageSpec* find_message(std::uint32_t id) {
  for (const MessageSpec& m : kMessages) {
    if (m.id == id) return &m;
  }
  return nullptr;
}
// The index of a message in kMessages (its rolling counter's slot), or -1.
constexpr int message_index(std::uint32_t id) {
  for (std::size_t i = 0; i < kMessageCount; ++i) {
    if (kMessages[i].id == id) return static_cast<int>(i);
  }
  return -1;
}
// A signal of a message by name, or nullptr (start-up and constant expressions).
constexpr const SignalSpec* find_signal(std::uint32_t id, std::string_view name) {
  const MessageSpec* m = find_message(id);
  if (m == nullptr) return nullptr;
  for (const SignalSpec& s : m->signals) {
    if (s.name == name) return &s;
  }
  return nullptr;
}

// The frames of each direction, in sending order.
inline constexpr std::array<std::uint32_t, 7> kPsdSensorIds = {kPsdSensors1, kPsdSensors2, kPsdSensors3, kPsdSensors4,
                                                               kPsdSensors5, kPsdSensors6, kPlantStatus};
inline constexpr std::array<std::uint32_t, 4> kEvSensorIds = {kEvSensors1, kEvSensors2, kEvSensors3, kPlantStatus};
inline constexpr std::array<std::uint32_t, 5> kShevSensorIds = {kShevSensors1, kShevSensors2, kShevSensors3,
                                                                kShevSensors4, kPlantStatus};
inline constexpr std::array<std::uint32_t, 2> kPsdCommandIds = {kPsdCommand1, kPsdCommand2};
inline constexpr std::array<std::uint32_t, 1> kEvCommandIds = {kEvCommand};
inline constexpr std::array<std::uint32_t, 1> kShevCommandIds = {kShevCommand};

}  // namespace ehpt::io::can
