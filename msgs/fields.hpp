// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The fields of each message by name, with their unit: what a bus binding (a user's DBC signal
// bound to a plant input or output, hil/bus/bus_binding.hpp) refers to. The names are the
// members' names. Pure tables of function pointers: no allocation, usable in the step loop.

#include <array>
#include <string_view>

#include "msgs/ev.hpp"
#include "msgs/psd.hpp"
#include "msgs/shev.hpp"

namespace ehpt::msgs {

// How a field's number is read: a physical quantity in the SI unit `unit`, a fraction (per
// unit: SOC, the driver's request), a flag (0 or 1) or a bit set (plant::Fault).
enum class FieldKind { kQuantity, kFraction, kFlag, kBits };

template <class M>
struct Field {
  std::string_view name;
  FieldKind kind;
  std::string_view unit;  // SI unit of a kQuantity ("rad/s", "m/s", "W", "Nm", "V", "A"); "" otherwise
  double (*get)(const M&);
  void (*set)(M&, double);
};

#define EHPT_FIELD(M, member, kind, unit)                                            \
  Field<M> {                                                                          \
    #member, kind, unit, [](const M& m) { return static_cast<double>(m.member); },    \
        [](M& m, double v) { m.member = static_cast<decltype(m.member)>(v); }         \
  }
#define EHPT_FLAG(M, member)                                                          \
  Field<M> {                                                                          \
    #member, FieldKind::kFlag, "", [](const M& m) { return m.member ? 1.0 : 0.0; },   \
        [](M& m, double v) { m.member = v != 0.0; }                                   \
  }

inline constexpr std::array<Field<PsdSensors>, 18> kPsdSensorFieldTable = {{
    EHPT_FIELD(PsdSensors, driverRequest, FieldKind::kFraction, ""),
    EHPT_FIELD(PsdSensors, speed_m_s, FieldKind::kQuantity, "m/s"),
    EHPT_FIELD(PsdSensors, iceW_rad_s, FieldKind::kQuantity, "rad/s"),
    EHPT_FIELD(PsdSensors, icePowDel_W, FieldKind::kQuantity, "W"),
    EHPT_FIELD(PsdSensors, genW_rad_s, FieldKind::kQuantity, "rad/s"),
    EHPT_FIELD(PsdSensors, genPowDel_W, FieldKind::kQuantity, "W"),
    EHPT_FIELD(PsdSensors, genTauLim_Nm, FieldKind::kQuantity, "Nm"),
    EHPT_FIELD(PsdSensors, motW_rad_s, FieldKind::kQuantity, "rad/s"),
    EHPT_FIELD(PsdSensors, motPowDelA_W, FieldKind::kQuantity, "W"),
    EHPT_FIELD(PsdSensors, motPowDelB_W, FieldKind::kQuantity, "W"),
    EHPT_FIELD(PsdSensors, motPowDelAB_W, FieldKind::kQuantity, "W"),
    EHPT_FIELD(PsdSensors, motTauLim_Nm, FieldKind::kQuantity, "Nm"),
    EHPT_FIELD(PsdSensors, batSOC, FieldKind::kFraction, ""),
    EHPT_FIELD(PsdSensors, batPowDel_W, FieldKind::kQuantity, "W"),
    EHPT_FIELD(PsdSensors, battery_voltage_V, FieldKind::kQuantity, "V"),
    EHPT_FIELD(PsdSensors, battery_current_A, FieldKind::kQuantity, "A"),
    EHPT_FIELD(PsdSensors, fault, FieldKind::kBits, ""),
    EHPT_FLAG(PsdSensors, locked),
}};

inline constexpr std::array<Field<PsdCommand>, 5> kPsdCommandFieldTable = {{
    EHPT_FIELD(PsdCommand, icePowRef_W, FieldKind::kQuantity, "W"),
    EHPT_FIELD(PsdCommand, iceTauRef_Nm, FieldKind::kQuantity, "Nm"),
    EHPT_FIELD(PsdCommand, genTauRef_Nm, FieldKind::kQuantity, "Nm"),
    EHPT_FIELD(PsdCommand, motTauRef_Nm, FieldKind::kQuantity, "Nm"),
    EHPT_FLAG(PsdCommand, iceON),
}};

inline constexpr std::array<Field<EvSensors>, 11> kEvSensorFieldTable = {{
    EHPT_FIELD(EvSensors, driverRequest_Nm, FieldKind::kQuantity, "Nm"),
    EHPT_FIELD(EvSensors, speed_m_s, FieldKind::kQuantity, "m/s"),
    EHPT_FIELD(EvSensors, driveW_rad_s, FieldKind::kQuantity, "rad/s"),
    EHPT_FIELD(EvSensors, driveTauLim_Nm, FieldKind::kQuantity, "Nm"),
    EHPT_FIELD(EvSensors, drivePowDel_W, FieldKind::kQuantity, "W"),
    EHPT_FIELD(EvSensors, batSOC, FieldKind::kFraction, ""),
    EHPT_FIELD(EvSensors, batPowDel_W, FieldKind::kQuantity, "W"),
    EHPT_FIELD(EvSensors, battery_voltage_V, FieldKind::kQuantity, "V"),
    EHPT_FIELD(EvSensors, battery_current_A, FieldKind::kQuantity, "A"),
    EHPT_FIELD(EvSensors, fault, FieldKind::kBits, ""),
    EHPT_FLAG(EvSensors, locked),
}};

inline constexpr std::array<Field<EvCommand>, 1> kEvCommandFieldTable = {{
    EHPT_FIELD(EvCommand, driveTauRef_Nm, FieldKind::kQuantity, "Nm"),
}};

inline constexpr std::array<Field<ShevSensors>, 13> kShevSensorFieldTable = {{
    EHPT_FIELD(ShevSensors, driverRequest_Nm, FieldKind::kQuantity, "Nm"),
    EHPT_FIELD(ShevSensors, speed_m_s, FieldKind::kQuantity, "m/s"),
    EHPT_FIELD(ShevSensors, driveW_rad_s, FieldKind::kQuantity, "rad/s"),
    EHPT_FIELD(ShevSensors, driveTauLim_Nm, FieldKind::kQuantity, "Nm"),
    EHPT_FIELD(ShevSensors, drivePowDc_W, FieldKind::kQuantity, "W"),
    EHPT_FIELD(ShevSensors, gensetW_rad_s, FieldKind::kQuantity, "rad/s"),
    EHPT_FIELD(ShevSensors, gensetPowDc_W, FieldKind::kQuantity, "W"),
    EHPT_FIELD(ShevSensors, batSOC, FieldKind::kFraction, ""),
    EHPT_FIELD(ShevSensors, batPowDel_W, FieldKind::kQuantity, "W"),
    EHPT_FIELD(ShevSensors, battery_voltage_V, FieldKind::kQuantity, "V"),
    EHPT_FIELD(ShevSensors, battery_current_A, FieldKind::kQuantity, "A"),
    EHPT_FIELD(ShevSensors, fault, FieldKind::kBits, ""),
    EHPT_FLAG(ShevSensors, locked),
}};

inline constexpr std::array<Field<ShevCommand>, 3> kShevCommandFieldTable = {{
    EHPT_FIELD(ShevCommand, driveTauRef_Nm, FieldKind::kQuantity, "Nm"),
    EHPT_FIELD(ShevCommand, gensetPowRef_W, FieldKind::kQuantity, "W"),
    EHPT_FLAG(ShevCommand, gensetON),
}};

#undef EHPT_FIELD
#undef EHPT_FLAG

// The tables by message type.
template <class M>
struct FieldTable;
template <>
struct FieldTable<PsdSensors> {
  static constexpr const auto& kFields = kPsdSensorFieldTable;
};
template <>
struct FieldTable<PsdCommand> {
  static constexpr const auto& kFields = kPsdCommandFieldTable;
};
template <>
struct FieldTable<EvSensors> {
  static constexpr const auto& kFields = kEvSensorFieldTable;
};
template <>
struct FieldTable<EvCommand> {
  static constexpr const auto& kFields = kEvCommandFieldTable;
};

template <>
struct FieldTable<ShevSensors> {
  static constexpr const auto& kFields = kShevSensorFieldTable;
};
template <>
struct FieldTable<ShevCommand> {
  static constexpr const auto& kFields = kShevCommandFieldTable;
};

}  // namespace ehpt::msgs
