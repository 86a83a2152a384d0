// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Messages of the series hybrid (SHEV, MODELS.md §10.6): a traction drive on the DC bus, fed by
// the battery and by a genset (engine + generator with its own genset manager, the library's
// Genset / GensetOO). The driver (PropDriver) is part of the plant, as in the EV; the ECU is the
// energy management (EMS): it passes the driver's request to the drive and asks the genset for
// a DC power, and, with an ON/OFF genset, switches it on and off.

#include <cmath>

#include "msgs/stamp.hpp"

namespace ehpt::msgs {

// Plant -> ECU, sampled at the start of an ECU period.
struct ShevSensors {
  Stamp stamp;
  double driverRequest_Nm = 0.0;   // driver's torque request at the drive shaft
  double speed_m_s = 0.0;          // vehicle speed
  double driveW_rad_s = 0.0;       // drive shaft speed
  double driveTauLim_Nm = 0.0;     // max torque the drive can deliver at its speed (yH)
  double drivePowDc_W = 0.0;       // DC power the drive draws (the library's drivePow, the EMS's input)
  double gensetW_rad_s = 0.0;      // genset (engine) shaft speed
  double gensetPowDc_W = 0.0;      // DC power the genset delivers to the bus (> 0 generating)
  double batSOC = 0.0;             // battery state of charge
  double batPowDel_W = 0.0;        // battery terminal power
  double battery_voltage_V = 0.0;  // terminal voltage
  double battery_current_A = 0.0;  // terminal current, > 0 discharging
  unsigned fault = 0;              // plant::Fault bits
  bool locked = false;             // vehicle held at standstill
};

// ECU -> plant, held until the next command applies.
struct ShevCommand {
  Stamp stamp;
  double driveTauRef_Nm = 0.0;   // torque asked of the drive (the limiter may cut it)
  double gensetPowRef_W = 0.0;   // power asked of the genset (its GMS: < 0 is taken as 0)
  bool gensetON = true;          // genset on (ON/OFF gensets only; a plain genset always runs)
};

// Every number of the command is finite (msgs/psd.hpp all_finite: why).
inline bool all_finite(const ShevCommand& c) { return std::isfinite(c.driveTauRef_Nm) && std::isfinite(c.gensetPowRef_W); }

}  // namespace ehpt::msgs
