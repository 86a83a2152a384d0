// SPDX-License-Identifier: BSD-3-Clause
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
// Current limit (PmsmAllFluxLimI, §9.1), with priority to flux weakening: if the point above
// needs |I| > sqrt 2 I_lim, the torque gives way to the largest one within both limits: MTPA
// at the limit if its voltage fits (below base speed), else the corner of the current circle
// and the voltage ellipse (Illinois along the circle). Not §9.1's algebraic "keep Id, cut Iq"
// (see the .cpp: it is not continuous in speed). If even all the current in Id cannot hold the
// voltage (above speed_max_rad_s, which validate() checks), overload is flagged and the
// currents are kept.
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
  double inertia_kgm2 = 0.29;    // rotor (MSL default machine)
  // Highest rotor speed the drive is rated for: at it, holding |V| = U_max at no load takes
  // |Id| = (psi - sqrt 2 U_max / (pp w_max)) / Ld, which must fit in the current limit.
  // 317 rad/s is SmaAllSpeeds' end speed (§11.6), where that current is 99.6 A rms.
  double speed_max_rad_s = 317.0;
};

// The no-load current (rms) that flux weakening needs to hold |V| at the set voltage at
// speed w (0 below base speed).
double pm_no_load_current_rms_A(const PmDriveParams& p, double speed_rad_s);

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

// MTPA torque at the current limit (|I| = sqrt 2 I_lim): the most the drive gives below base
// speed. MTPA at current I: Id = (psi - sqrt(psi^2 + 8 dL^2 I^2)) / (4 dL), Iq = sqrt(I^2 - Id^2).
double pm_torque_at_current_limit_Nm(const PmDriveParams& p);

// The peak phase-voltage limit for a DC voltage.
double pm_voltage_limit_V(const PmDriveParams& p, double u_dc_V);

// Pure: the operating point for torque request T*, rotor speed wm and DC voltage. warm_iq_A:
// a start for MTPA's Newton (0: its own, T* / (1.5 pp psi)); the result depends on it only
// within the tolerance, so a caller that wants bit-identical runs passes none.
PmOperatingPoint pm_operating_point(const PmDriveParams& p, double torque_ref_Nm, double speed_rad_s, double u_dc_V,
                                    double warm_iq_A = 0.0);

// MTPA currents of a torque (no limits; they do not depend on the speed), and the same
// operating point as above with them given: a vehicle holds T* over an ECU period and solves
// MTPA once for all the evaluations of that period (bit for bit the same result).
struct PmCurrents {
  double id_A = 0.0, iq_A = 0.0;  // peak
  bool converged = true;
  int iterations = 0;
};
PmCurrents pm_mtpa(const PmDriveParams& p, double torque_Nm);
PmOperatingPoint pm_operating_point(const PmDriveParams& p, double torque_ref_Nm, double speed_rad_s, double u_dc_V,
                                    const PmCurrents& mtpa_of_ref);
// |V|^2 - U_lim^2 at the currents c and this speed (peak V^2): > 0 where they need weakening.
double pm_voltage_excess_V2(const PmDriveParams& p, const PmCurrents& c, double speed_rad_s, double u_dc_V);

}  // namespace ehpt::plant
