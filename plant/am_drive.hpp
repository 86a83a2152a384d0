// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// AMDrive and AMDrivePU: the quasi-stationary induction-machine drive, MODELS.md §9.2 (P15 §2:
// AMDrive = "uContrGen" + QSAsma + lossF). Pure functions of (slip or torque request, rotor
// speed): the machine's electrical state has no dynamics at a vehicle's time scale, so each
// call solves the per-phase equivalent circuit algebraically (complex rms phasors, no
// allocation). The rotor speed is a state of the mechanics the drive is bolted to:
// J dw_m/dt = T_e + tau_ext, with J = inertia_kgm2 added by the vehicle.
//
// QSAsma, per phase, rms phasors, E real ("behind R1"), pp pole pairs (§9.2):
//   w_e = pp w_m + dWe                      stator electrical frequency, dWe the slip frequency
//   Z2  = R2 w_e/dWe + j w_e L2             (= R2/s + j X2,  s = dWe / w_e)
//   Zp  = j w_e Lm || Z2,   I1 = E / (j w_e L1 + Zp),   I2 = I1 j w_e Lm / (j w_e Lm + Z2)
//   T_e = 3 pp |I2|^2 R2 / dWe               (air-gap power / synchronous mechanical speed)
//   U1  = E + R1 I1                          (terminal phase voltage)
//   P_abs = T_e w_m + 3 R1 |I1|^2 + 3 R2 |I2|^2   (= 3 Re(U1 conj I1))
// Evaluated divided by w_e ("flux form"), so that neither w_e -> 0 nor dWe -> 0 divides by
// zero (§9.2's guard: the rotor branch as an admittance):
//   Psi = E / w_e  (rms phase V s: K_uf sign(w_e) up to base frequency, then U_base / w_e)
//   Y2  = dWe / (R2 + j dWe L2)   (= w_e / Z2),    Yp = -j / Lm + Y2   (= w_e / Zp)
//   I1  = Psi / (j L1 + 1/Yp),   Vm = I1 / Yp  (air-gap voltage / w_e),   I2 = Vm Y2
//   T_e = 3 pp |Vm|^2 R2 dWe / (R2^2 + dWe^2 L2^2)
// Below base frequency Psi is constant, so the torque and the currents depend on dWe alone,
// not on the speed (what U/f control is for).
//
// uContrGen (P15) and lossF:
//   slip limiter  dWe := clamp(dWe, -dWe_lim, +dWe_lim),  dWe_lim = R2 / (L1 + L2): the peak
//                 of the simplified circuit (Lm -> inf) T_e = 3 pp Psi^2 R2 dWe /
//                 (R2^2 + dWe^2 (L1 + L2)^2); beyond it the torque would fall.
//   U/f           E = K_uf |w_e|, K_uf = U_base / w_e_base, for |w_e| <= w_e_base; E = U_base
//                 above (weakening: Psi = U_base / |w_e| falls with the frequency). The cap is
//                 on E; the terminal voltage |U1| exceeds it by up to R1 |I1| (P15's U/f on E).
//   losses        P_dc = P_abs + k_inv |I1|   (inverter loss per A rms of stator current)
//
// TorqueToDW (ControlLogic of V2/V3, §9.2, adapted to the QS drive). ControlLogic works in
// mechanical units: slip speed y = Omega0 - Omega (mechanical rad/s) and Kw (rms phase V per
// mechanical rad/s). Here dWe = pp y and Kw = pp K_uf; with L_stray = L1 + L2 its torque law
//   T* = 3 R_r y Kw^2 / ((pp y L_stray)^2 + R_r^2)
// is the simplified circuit above, T* = 3 pp Psi^2 R2 dWe / (R2^2 + dWe^2 L^2), L = L1 + L2.
// Because E is behind R1, the full circuit has exactly this form too: the Thevenin equivalent
// of E behind j w_e L1 with j w_e Lm across is purely reactive,
//   Psi_th = Psi Lm / (L1 + Lm),   L = L1 Lm / (L1 + Lm) + L2,
// and ehpt uses these (with Lm -> inf they are ControlLogic's; with the MSL machine, L1 + L2
// and Psi would give 6.7 % less torque than T* at small slip). §9.2's small root, written
// without its cancellation for small T*, both signs:
//   dWe = 2 T* R2 / (3 pp Psi_th^2 + sqrt(9 pp^2 Psi_th^4 - 4 T*^2 L^2))       (0 for T* = 0)
// Up to base frequency this gives T_e = T* to rounding. Above it Psi = U_base / |w_e| depends
// on dWe (ControlLogic takes w_e ~ pp w_m, which misses T* by ~2 dWe / w_e): ehpt starts from
// the root at Psi(pp w_m) and solves |T_e(dWe)| = |T*| by Illinois regula falsi (bracketed, at
// most 60 iterations, |residual| <= 1e-13 |T*|), so T_e = T* there too (to ~1e-12:
// rounding of the circuit vs its Thevenin form).
// Reachable maximum (ControlLogic's tauIsMax): the largest |T_e| on the side of T* within the
// slip limiter. That is the torque at the limiter (the Thevenin peak R2 / L lies 1.7 % beyond
// it, 0.015 % higher), except above base frequency when |w_e| grows with the slip (motoring):
// the falling flux moves the peak below the limiter (to 0.78 dWe_lim, 3.8 % above the
// limiter's torque at w_m = 160 rad/s with the MSL machine), found by bisection on the sign of
//   d ln|T_e| / d|dWe| = (R2^2 - dWe^2 L^2) / (|dWe| (R2^2 + dWe^2 L^2)) - 2 s / w_e
// (s = sign of dWe; the last term only above base frequency). If |T*| >= the maximum, dWe is
// its slip and at_max is set. ControlLogic's minimum frequency omega_min and wmMax are not
// needed (the flux form has no 1/w_e, P15's AMDrive has no speed limit), nor its R_s
// compensation (E is the controlled quantity).
//
// Current limit (ehpt's choice: §9.2 has none): when |I1| > I_max at the slip above, |dWe| is
// reduced until |I1| = I_max (Illinois regula falsi on |I1|^2 - I_max^2 over [0, |dWe|], at
// most 60 iterations, ending on the side |I1| <= I_max). Above the no-load current |I1| grows
// monotonically with |dWe| up to the limiter (above base frequency, motoring, it first dips a
// little below the no-load value as the flux falls; checked for the MSL machine over
// |w_m| <= 1000 rad/s, both signs), so the crossing is unique and |T_e| there
// is the largest within the current. It needs I_max above the no-load current, which
// validate() checks at base voltage and frequency, where it is largest:
//   I0 = Psi_base / (L1 + Lm) = U_base / (w_e_base (L1 + Lm))
// (E is behind R1, so R1 does not enter: |j w_e_base (L1 + Lm) + R1| would give an I0 smaller
// by 5e-5 with the MSL machine, and an I_max between the two could never be met.)
//
// AMDrivePU (§9.2 recommendation; P15 keeps the p.u. data and varies only S_nom):
//   S_base = S_nom,  V_base = rated rms phase voltage,  w_base = 2 pi f_nom,
//   Z_base = 3 V_base^2 / S_base,  L_base = Z_base / w_base,  I_base = S_base / (3 V_base),
//   R = r Z_base,  L = x L_base,  J = 2 H S_base / (w_base / pp)^2,  I_max = i_max I_base,
//   k_inv = k_inv_pu S_base / I_base  (k_inv_pu: inverter loss at rated current, p.u. of S_nom),
//   U_base = V_base and w_e_base = w_base (the U/f rule's base is the rated point).
// Doubling S_nom at equal p.u. data halves every impedance: at the same p.u. slip and speed the
// currents and the torque double, the slip limit and the voltages stay.

#include <numbers>
#include <string>

#include "plant/problems.hpp"

namespace ehpt::plant {

struct AmDriveParams {           // defaults: the MSL default induction machine (§9.2)
  int pole_pairs = 2;
  double R1_Ohm = 0.03;          // stator resistance
  double R2_Ohm = 0.04;          // rotor resistance (referred to the stator)
  double L1_H = 3.240e-4;        // stator leakage
  double L2_H = 3.240e-4;        // rotor leakage (referred to the stator)
  double Lm_H = 9.225e-3;        // magnetising
  double inertia_kgm2 = 0.29;    // rotor (used by the vehicle's mechanics, not here)
  double U_base_rms_V = 100.0;   // phase rms E at base frequency (U/f rule, capped above it)
  double w_e_base_rad_s = 2.0 * std::numbers::pi * 50.0;  // base electrical angular frequency
  double I_max_rms_A = 250.0;    // inverter current limit (stator rms); slip reduced to respect it
  double k_inv_W_per_A = 4.0;    // inverter loss per A rms of stator current (V16 Inverter/lossF)
};

// Every problem, each with field and value: R, L, U_base, w_e_base, I_max not finite > 0,
// pole_pairs outside [1, 100], inertia or k_inv not finite >= 0, I_max not above the no-load
// current I0 (checked once the fields it needs are valid).
void validate(const AmDriveParams& p, const std::string& at, Problems& problems);

struct AmOperatingPoint {
  double torque_Nm = 0;          // electromagnetic torque
  double slip_rad_s = 0;         // dWe = w_e - pp w_m after the limiters (electrical rad/s)
  double w_e_rad_s = 0;          // stator electrical angular frequency
  double emf_rms_V = 0;          // E, behind R1
  double u1_rms_V = 0;           // |U1| terminal phase voltage, rms
  double i1_rms_A = 0, i2_rms_A = 0;  // stator, rotor (referred) current, rms
  double power_mech_W = 0;       // T_e w_m
  double power_abs_W = 0;        // P_abs: absorbed by the machine (= 3 Re(U1 conj I1))
  double loss_copper_W = 0;      // 3 R1 |I1|^2 + 3 R2 |I2|^2
  double loss_inverter_W = 0;    // k_inv |I1|
  double power_dc_W = 0;         // P_dc = P_abs + k_inv |I1|
  bool slip_limited = false;     // |dWe| cut to R2/(L1+L2) (P15's limiter); am_operating_point:
                                 // as torque_at_max (slip held at the torque curve's maximum)
  bool torque_at_max = false;    // TorqueToDW: |T*| at or above the reachable maximum (tauIsMax)
  bool current_limited = false;  // slip reduced to hold |I1| <= I_max
  bool weakening = false;        // above base frequency (E capped)
};

// Run phase: no allocation. All are pure functions of their arguments.

// The slip limiter's bound R2 / (L1 + L2), electrical rad/s.
double am_slip_limit_rad_s(const AmDriveParams& p);

// AMDrive proper (P15): slip-frequency input dWe (electrical rad/s; > 0 motoring), rotor speed
// w_m. Slip limiter, U/f, QSAsma, lossF; no current limit (see am_operating_point).
AmOperatingPoint am_from_slip(const AmDriveParams& p, double dWe_rad_s, double speed_rad_s);

// TorqueToDW: the dWe that asks for torque T* (within +-dWe_lim); at_max when |T*| is at or
// beyond the torque at the limiter.
double am_slip_for_torque(const AmDriveParams& p, double torque_ref_Nm, double speed_rad_s, bool& at_max);

// The current limit alone: dWe (clamped to the limiter) reduced in magnitude until
// |I1| <= I_max; limited tells whether it had to.
double am_slip_within_current(const AmDriveParams& p, double dWe_rad_s, double speed_rad_s, bool& limited);

// The drive as a vehicle uses it: torque request -> dWe -> current limit -> operating point.
// slip_limited is set with torque_at_max (the request needed the limiter's slip or more).
AmOperatingPoint am_operating_point(const AmDriveParams& p, double torque_ref_Nm, double speed_rad_s);

// Largest |torque| the drive can give at this speed (for the ECU's driveTauLim sensor): the
// smaller of the motoring and braking limits (slip limiter, then current limit). They differ
// above base frequency, where braking (lower |w_e|) has the larger flux; one sensor serves both.
double am_torque_limit_Nm(const AmDriveParams& p, double speed_rad_s);

// AMDrivePU: the same drive from per-unit data and S_nom (base in the header comment).
// Defaults: the MSL machine of AmDriveParams on S_nom = 30 kVA (3 x 100 V x 100 A), where
// Z_base = 1 Ohm.
struct AmDrivePuParams {
  double S_nom_VA = 30000.0;     // nominal apparent power, three phases: the p.u. power base
  double V_nom_rms_V = 100.0;    // rated phase voltage, rms (V_base; also the U/f base)
  double f_nom_Hz = 50.0;        // rated frequency (w_base = 2 pi f_nom; also the U/f base)
  int pole_pairs = 2;
  double r1_pu = 0.03;           // stator resistance
  double r2_pu = 0.04;           // rotor resistance
  double x1_pu = 2.0 * std::numbers::pi * 50.0 * 3.240e-4;  // stator leakage reactance at f_nom
  double x2_pu = 2.0 * std::numbers::pi * 50.0 * 3.240e-4;  // rotor leakage reactance at f_nom
  double xm_pu = 2.0 * std::numbers::pi * 50.0 * 9.225e-3;  // magnetising reactance at f_nom
  double H_s = 0.29 * (std::numbers::pi * 50.0) * (std::numbers::pi * 50.0) / (2.0 * 30000.0);  // inertia constant
  double I_max_pu = 2.5;         // current limit, p.u. of I_base = S_nom / (3 V_nom)
  double k_inv_pu = 4.0 * 100.0 / 30000.0;  // inverter loss at rated current, p.u. of S_nom
};

// As for AmDriveParams, with the p.u. fields' names; I_max_pu must exceed 1 / (x1_pu + xm_pu).
void validate(const AmDrivePuParams& p, const std::string& at, Problems& problems);

// Start-up: the SI parameters (the p.u. data must be valid).
AmDriveParams am_params_from_pu(const AmDrivePuParams& p);

}  // namespace ehpt::plant
