// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// What each vehicle family brings to a bus (CAN or LCM): its messages, its CAN frames, its
// safe command.

#include "io/can/contract.hpp"
#include "msgs/ev.hpp"
#include "msgs/psd.hpp"
#include "msgs/shev.hpp"

namespace ehpt::hil {

template <class Sensors>
struct BusFamily;

template <>
struct BusFamily<msgs::PsdSensors> {
  using Command = msgs::PsdCommand;
  static constexpr const char* kFamily = "psd";  // in inputs.log
  static constexpr const auto& kCanSensorIds = io::can::kPsdSensorIds;
  static constexpr const auto& kCanCommandIds = io::can::kPsdCommandIds;
  // references to zero; the engine's ON/OFF stays as it was: a stale message cannot switch it
  static void make_safe(Command& c) {
    c.icePowRef_W = 0.0;
    c.iceTauRef_Nm = 0.0;
    c.genTauRef_Nm = 0.0;
    c.motTauRef_Nm = 0.0;
  }
};

template <>
struct BusFamily<msgs::EvSensors> {
  using Command = msgs::EvCommand;
  static constexpr const char* kFamily = "ev";
  static constexpr const auto& kCanSensorIds = io::can::kEvSensorIds;
  static constexpr const auto& kCanCommandIds = io::can::kEvCommandIds;
  static void make_safe(Command& c) { c.driveTauRef_Nm = 0.0; }
};

template <>
struct BusFamily<msgs::ShevSensors> {
  using Command = msgs::ShevCommand;
  static constexpr const char* kFamily = "shev";
  static constexpr const auto& kCanSensorIds = io::can::kShevSensorIds;
  static constexpr const auto& kCanCommandIds = io::can::kShevCommandIds;
  // the drive's and the genset's references to zero (the genset's GMS idles it at zero power);
  // gensetON stays as it was: a stale message cannot start or stop the engine
  static void make_safe(Command& c) {
    c.driveTauRef_Nm = 0.0;
    c.gensetPowRef_W = 0.0;
  }
};

}  // namespace ehpt::hil
