// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Messages of the power-split hybrid (MODELS.md §0.5; P15 §5.2): names as in the library's
// bus ("Conn"), with the unit appended.

#include <cmath>

#include "msgs/stamp.hpp"

namespace ehpt::msgs {

// Plant -> ECU, sampled at the start of an ECU period.
struct PsdSensors {
  Stamp stamp;
  double driverRequest = 0.0;      // driver's torque request, per unit (PropDriver tauRef, -1.8..1.8)
  double speed_m_s = 0.0;          // vehicle speed
  double iceW_rad_s = 0.0;         // engine speed
  double icePowDel_W = 0.0;        // power at the engine flange, after its inertia
  double genW_rad_s = 0.0;         // gen (sun) speed
  double genPowDel_W = 0.0;        // power gen delivers at its flange
  double genTauLim_Nm = 0.0;       // max torque gen can deliver at its speed
  double motW_rad_s = 0.0;         // mot (ring) speed
  double motPowDelA_W = 0.0;       // power mot delivers through flange A (ring side)
  double motPowDelB_W = 0.0;       // power mot delivers through flange B (final gear) = traction power
  double motPowDelAB_W = 0.0;      // A + B
  double motTauLim_Nm = 0.0;       // max torque mot can deliver at its speed
  double batSOC = 0.0;             // battery state of charge
  double batPowDel_W = 0.0;        // battery terminal power
  double battery_voltage_V = 0.0;  // terminal voltage
  double battery_current_A = 0.0;  // terminal current, > 0 discharging
  unsigned fault = 0;              // plant::Fault bits
  bool locked = false;             // vehicle held at standstill
};

// ECU -> plant, held until the next command applies.
struct PsdCommand {
  Stamp stamp;
  double icePowRef_W = 0.0;   // power the engine is asked to deliver (power-input engine)
  double iceTauRef_Nm = 0.0;  // torque the engine is asked to deliver (torque-input engine, P15 MBice)
  double genTauRef_Nm = 0.0;  // torque asked of gen
  double motTauRef_Nm = 0.0;  // torque asked of mot
  bool iceON = true;          // engine on (ON/OFF engines only)
};

// Every number of the command is finite: a command with a NaN or an infinity is refused by
// each way in (LCM, the Python module; CAN cannot carry one), never applied.
inline bool all_finite(const PsdCommand& c) {
  return std::isfinite(c.icePowRef_W) && std::isfinite(c.iceTauRef_Nm) && std::isfinite(c.genTauRef_Nm) &&
         std::isfinite(c.motTauRef_Nm);
}

}  // namespace ehpt::msgs
