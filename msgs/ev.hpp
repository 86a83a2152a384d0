// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Messages of the battery-electric vehicle (MBEV, MODELS.md §10.3). The driver (PropDriver)
// is part of the plant, as the person at the wheel; the ECU turns the driver's request into
// the drive's torque reference (the built-in ECU, ecu::EvFollower, passes it on).

#include <cmath>

#include "msgs/stamp.hpp"

namespace ehpt::msgs {

// Plant -> ECU, sampled at the start of an ECU period.
struct EvSensors {
  Stamp stamp;
  double driverRequest_Nm = 0.0;   // driver's torque request at the drive shaft
  double speed_m_s = 0.0;          // vehicle speed
  double driveW_rad_s = 0.0;       // drive shaft speed
  double driveTauLim_Nm = 0.0;     // max torque the drive can deliver at its speed (yH)
  double drivePowDel_W = 0.0;      // mechanical power the drive delivers (torque x speed)
  double batSOC = 0.0;             // battery state of charge
  double batPowDel_W = 0.0;        // battery terminal power
  double battery_voltage_V = 0.0;  // terminal voltage
  double battery_current_A = 0.0;  // terminal current, > 0 discharging
  unsigned fault = 0;              // plant::Fault bits
  bool locked = false;             // vehicle held at standstill
};

// ECU -> plant, held until the next command applies.
struct EvCommand {
  Stamp stamp;
  double driveTauRef_Nm = 0.0;  // torque asked of the drive (the limiter may cut it)
};

// Every number of the command is finite (msgs/psd.hpp all_finite: why).
inline bool all_finite(const EvCommand& c) { return std::isfinite(c.driveTauRef_Nm); }

}  // namespace ehpt::msgs
