#pragma once
// PMDrive: the quasi-static permanent-magnet synchronous machine drive, MODELS.md §9.1
// (P15 §2, eqs. 1-2, Fig. 5). Pure functions of (torque request, speed, DC voltage): the
// drive's electrical state has no dynamics at the time scale of a vehicle, so each step
// solves its operating point algebraically (bounded Newton / regula falsi, warm-started, no
// allocation). The rotor speed is a state of the mechanics the drive is bolted to.
//
// Machine (dq, amplitude-invariant Park, peak phase values), pp pole pairs, we = pp wm:
//   Vd = Rs Id - we Lq Iq,   Vq = Rs Iq + we (psi + Ld Id)
//   Te = 1.5 pp (psi Iq + (Ld - Lq) Id Iq)
// Control (AtomicPmsm, P15 eqs. 1-2), dL = Lq - Ld, U_lim = min(u_dc / sqrt 3, sqrt 2 U_max):
//   1. MTPA: 0 = -psi sin g + dL I cos 2g (Id = -I sin g, Iq = I cos g) with Te = T*;
//      in (Id, Iq): Id = (psi - sqrt(psi^2 + 4 dL^2 Iq^2)) / (2 dL), Newton in Iq.
//   2. |V| <= U_lim: done. Else flux weakening: |V(Id, Iq(Id))| = U_lim with
//      Iq(Id) = T* / (1.5 pp (psi - dL Id)), Id bracketed in [-psi/Ld, Id_MTPA].
//   3. No Id in the bracket meets the voltage: T* is not reachable at this speed: the largest
//      reachable torque (bisection on T*), voltage_limited set (flux weakening has priority).
// Current limit (PmsmAllFluxLimI, algebraic form, §9.1 recommendation): if Id^2 + Iq^2 >
// 2 I_lim^2 (I_lim rms), keep Id and cut |Iq| to sqrt(2 I_lim^2 - Id^2): priority to flux
// weakening; if Id alone exceeds it, overload is flagged and both are kept.
// Losses and DC power: P_dc = Te wm + 1.5 Rs I^2 + k_inv I_rms (I = sqrt(Id^2 + Iq^2)).

#include <string>

#include "plant/problems.hpp"

namespace ehpt::plant {

struct PmDriveParams {
  int pole_pairs = 2;
  double psi_pm_Wb = 0.5055;     // PM flux linkage, peak per phase (MSL default machine)
  double Ld_H = 9.549e-4;
  double Lq_H = 9.549e-4;
  double Rs_Ohm = 0.03;
  double U_max_rms_V = 100.0;    // phase voltage limit, rms
  double I_lim_rms_A = 100.0;    // current limit, rms
  double k_inv_W_per_A = 4.0;    // inverter loss per A rms (V16 Inverter, §9.1)
};

void validate(const PmDriveParams& p, const std::string& at, Problems& problems);

struct PmOperatingPoint {
  double id_A = 0.0, iq_A = 0.0;  // peak
  double vd_V = 0.0, vq_V = 0.0;  // peak
  double torque_Nm = 0.0;         // electromagnetic torque delivered
  double p_dc_W = 0.0;            // drawn from the DC bus
  bool weakening = false;         // flux weakening active (|V| = U_lim)
  bool voltage_limited = false;   // T* not reachable at this speed: the largest reachable one
  bool current_limited = false;   // |Iq| cut to the current limit
  bool overload = false;          // Id alone beyond the current limit
  bool converged = true;          // every iteration met its tolerance (else a fault flag)
  int iterations = 0;
};

// The peak phase-voltage limit for a DC voltage.
double pm_voltage_limit_V(const PmDriveParams& p, double u_dc_V);

// Pure: the operating point for torque request T*, rotor speed wm and DC voltage. warm_iq_A:
// the last step's MTPA Iq (a start for Newton; 0 if none).
PmOperatingPoint pm_operating_point(const PmDriveParams& p, double torque_ref_Nm, double speed_rad_s, double u_dc_V,
                                    double warm_iq_A = 0.0);

}  // namespace ehpt::plant
