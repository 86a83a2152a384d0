#pragma once
// The bus of the power-split hybrid (MODELS.md §0.5; P15 §5.2): the one struct the ECU and the
// plant exchange. The plant writes the sensor half (PsdPlant::sense), the ECU the command
// half (PsdEcu::update); the plant reads only the command half. A CAN or LCM codec will
// carry exactly these fields, so an external ECU can replace the built-in one without
// touching the plant. SI units; names as in the library, with the unit appended.

namespace ehpt::plant {

struct PsdBus {
  // ---- plant -> ECU ----
  double driverRequest = 0.0;   // driver's torque request, per unit (PropDriver tauRef, -1.8..1.8)
  double iceW_rad_s = 0.0;      // engine speed
  double icePowDel_W = 0.0;     // power at the engine flange, after its inertia
  double genW_rad_s = 0.0;      // gen (sun) speed
  double genPowDel_W = 0.0;     // power gen delivers at its flange
  double genTauLim_Nm = 0.0;    // max torque gen can deliver at its speed
  double motW_rad_s = 0.0;      // mot (ring) speed
  double motPowDelA_W = 0.0;    // power mot delivers through flange A (ring side)
  double motPowDelB_W = 0.0;    // power mot delivers through flange B (final gear) = traction power
  double motPowDelAB_W = 0.0;   // A + B
  double motTauLim_Nm = 0.0;    // max torque mot can deliver at its speed
  double batSOC = 0.0;          // battery state of charge
  double batPowDel_W = 0.0;     // battery terminal power
  // ---- ECU -> plant ----
  double icePowRef_W = 0.0;     // power the engine is asked to deliver (power-input engine)
  double iceTauRef_Nm = 0.0;    // torque the engine is asked to deliver (torque-input engine, P15 MBice)
  double genTauRef_Nm = 0.0;    // torque asked of gen
  double motTauRef_Nm = 0.0;    // torque asked of mot
  bool iceON = true;            // engine on (ON/OFF engines only)
};

}  // namespace ehpt::plant
