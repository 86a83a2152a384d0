// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Map-based electric drive (inverter + machine), MODELS.md §1 (one flange) and §2 (two flanges).
// Paper: P15 §3 "MBOneFlange", "MBTwoFlange", Figs. 10-13.
//
// Seen from outside: a rotor inertia J, a torque that follows the request within torque,
// power and speed limits, and a DC power drawn that is the mechanical power corrected by an
// efficiency map (or a loss formula). The rotor speed is a state of whatever mechanical
// system the drive is bolted to, so this file holds only pure functions of (request, speed).
//
// Limiter (§1.3), with w = |speed|, w_base = P_max / tau_max, alpha = limit_ramp_fraction:
//   w <  w_base                      state 0   tau_lim = tau_max
//   w >= w_base                      state 1   tau_lim = P_max / w
//   w_max < w < (1 + alpha) w_max    state 2   tau_lim = (P_max / w_max)(1 - (w - w_max)/(alpha w_max))
//   w >= (1 + alpha) w_max           state 3   tau_lim = 0
//   tau = clamp(tau_ref, -tau_lim, +tau_lim),  limiting = |tau - tau_ref| > 1e-15
// |speed| is used (V16), so a drive turning backwards is limited the same way.
//
// Efficiency (§1.4): P_mech = tau * speed;
//   eta = Map(|tau| / tau_max, |speed| / w_max)   bilinear, torque = row axis, linear extrapolation
//   P_dc = P_mech / eta  when P_mech > 0 (motoring);  P_dc = P_mech * eta  otherwise.
//   eta is floored at 0.01 before dividing.
// Loss formula (§1.5, V2/V3 form): Tu = |tau|/tau_max, Wu = |speed|/w_max,
//   loss_pu = A + bT Tu^2 + bW Wu^2 + bP (Tu Wu)^2,  eta = Tu Wu / (Tu Wu + loss_pu).
// Ideal: eta = 1 (the SMEHV/V2 default map [0,0,1;0,1,1;1,1,1]). Constant: one eta everywhere
// (the library's Level 1 genset generator, constGenEfficiency x that map).
//
// The DC interface is an ideal constant-power load (§1.6 recommendation); the battery node
// is solved algebraically in battery_rc.hpp.

#include <algorithm>
#include <cmath>
#include <string>

#include "plant/problems.hpp"
#include "plant/table.hpp"

namespace ehpt::plant {

inline constexpr double kEfficiencyFloor = 0.01;  // §1.4: avoid dividing by ~0 outside the map

enum class DriveLossModel { kIdeal, kMap, kFormula, kConstant };

struct LossFormula {
  double a = 0.006;   // constant losses, per unit of tau_max * w_max
  double b_t = 0.05;  // torque-squared coefficient
  double b_w = 0.02;  // speed-squared coefficient
  double b_p = 0.05;  // (torque * speed)-squared coefficient
};

struct MapDriveParams {
  double torque_max_Nm = 80.0;
  double power_max_W = 22000.0;
  double speed_max_rad_s = 3000.0;
  double inertia_kgm2 = 0.25;
  double limit_ramp_fraction = 0.10;  // alpha of §1.3 (V3's OneFlange uses 0.05)
  DriveLossModel loss_model = DriveLossModel::kIdeal;
  Table2d efficiency_map;             // per unit; rows torque/tau_max, columns speed/w_max
  LossFormula loss_formula;
  double efficiency = 1.0;            // kConstant: one efficiency everywhere (the library's Level 1
                                      // genset: constGenEfficiency), in (0, 1]
};

void validate(const MapDriveParams& p, const std::string& at, Problems& problems);
// Legal but surprising settings, reported as warnings: w_max < P_max / tau_max makes the
// limit jump from tau_max up to P_max / w_max at w_max, state 0 -> 2 directly (§1.3 quirk,
// reproduced as in the library).
void warn(const MapDriveParams& p, const std::string& at, Problems& warnings);

struct TorqueLimit {
  double torque_Nm = 0.0;  // yH of §1.3 (>= 0); the lower limit is -torque_Nm
  int state = 0;           // 0 torque, 1 power, 2 speed ramp, 3 over speed
};

struct DriveOperatingPoint {
  double torque_Nm = 0.0;      // applied to the rotor
  double limit_Nm = 0.0;       // yH, bus genTauLim / motTauLim
  int limit_state = 0;
  bool limiting = false;
  double power_mech_W = 0.0;   // torque * speed
  double power_dc_W = 0.0;     // drawn from the DC bus (< 0 when generating)
  double efficiency = 1.0;
};

// The drive's equations with the constants they need computed once.
class MapDrive {
 public:
  MapDrive() = default;
  explicit MapDrive(const MapDriveParams& params);
  const MapDriveParams& params() const { return p_; }

  // Run phase: pure functions, no allocation.
  TorqueLimit torque_limit(double speed_rad_s) const;
  double efficiency(double torque_Nm, double speed_rad_s) const;
  DriveOperatingPoint operate(double torque_request_Nm, double speed_rad_s) const;
  // Derated (a plant fault, plant/health.hpp): the request clamped to gain x the limiter's bound
  // of the healthy point; the efficiency map still reads |tau| / tau_max of the machine as built.
  DriveOperatingPoint derated(const DriveOperatingPoint& healthy, double torque_request_Nm, double speed_rad_s,
                              double gain) const {
    const double bound_Nm = gain * healthy.limit_Nm;
    const double tau_Nm = std::clamp(torque_request_Nm, -bound_Nm, bound_Nm);
    DriveOperatingPoint op = tau_Nm == torque_request_Nm ? healthy : operate(tau_Nm, speed_rad_s);
    op.limit_Nm = bound_Nm;
    op.limiting = std::abs(op.torque_Nm - torque_request_Nm) > 1e-15;
    return op;
  }

 private:
  MapDriveParams p_;
  double base_speed_rad_s_ = 0.0;  // P_max / tau_max
  double inv_torque_max_ = 0.0, inv_speed_max_ = 0.0, inv_ramp_rad_s_ = 0.0;
  double power_over_speed_max_Nm_ = 0.0;
};

// Bus view of a one-flange drive ("gen", §0.5) and of a two-flange drive ("mot", §2.4):
// the names a bus will carry, in SI units.
struct GenBus {
  double genTauRef_Nm = 0.0;
  double genPowDel_W = 0.0;  // power at the flange, after the rotor inertia
  double genW_rad_s = 0.0;
  double genTauLim_Nm = 0.0;
};
struct MotBus {
  double motTauRef_Nm = 0.0;
  double motPowDelA_W = 0.0;   // delivered through flange A
  double motPowDelB_W = 0.0;   // delivered through flange B
  double motPowDelAB_W = 0.0;  // A + B = tau * w - J w dw/dt
  double motW_rad_s = 0.0;
  double motTauLim_Nm = 0.0;
};

// ---- run phase, inline so the plant's derivative function can be optimised as a whole ----

[[gnu::always_inline]] inline TorqueLimit MapDrive::torque_limit(double speed_rad_s) const {
  const double w = std::abs(speed_rad_s);
  if (w > p_.speed_max_rad_s) {
    const double ramp = (w - p_.speed_max_rad_s) * inv_ramp_rad_s_;
    if (ramp < 1.0) return {power_over_speed_max_Nm_ * (1.0 - ramp), 2};
    return {0.0, 3};
  }
  if (w < base_speed_rad_s_) return {p_.torque_max_Nm, 0};
  return {p_.power_max_W / w, 1};
}
[[gnu::always_inline]] inline double MapDrive::efficiency(double torque_Nm, double speed_rad_s) const {
  switch (p_.loss_model) {
    case DriveLossModel::kIdeal:
      return 1.0;
    case DriveLossModel::kMap: {
      const double eta = p_.efficiency_map(std::abs(torque_Nm) * inv_torque_max_, std::abs(speed_rad_s) * inv_speed_max_);
      return std::max(eta, kEfficiencyFloor);
    }
    case DriveLossModel::kConstant:
      return p_.efficiency;
    case DriveLossModel::kFormula: {
      const double tu = std::abs(torque_Nm) * inv_torque_max_;
      const double wu = std::abs(speed_rad_s) * inv_speed_max_;
      const double pu = tu * wu;
      const LossFormula& f = p_.loss_formula;
      const double loss_pu = f.a + f.b_t * tu * tu + f.b_w * wu * wu + f.b_p * pu * pu;
      // at zero torque or speed P_mech = 0 as well: report eta = 1 there (no power flows)
      if (pu == 0.0) return 1.0;
      return std::max(pu / (pu + loss_pu), kEfficiencyFloor);
    }
  }
  return 1.0;
}
[[gnu::always_inline]] inline DriveOperatingPoint MapDrive::operate(double torque_request_Nm, double speed_rad_s) const {
  const TorqueLimit lim = torque_limit(speed_rad_s);
  const double torque_Nm = std::clamp(torque_request_Nm, -lim.torque_Nm, lim.torque_Nm);
  const double power_mech_W = torque_Nm * speed_rad_s;
  const double eta = efficiency(torque_Nm, speed_rad_s);
  // motoring: losses added; generating: losses subtracted (§1.4)
  const double power_dc_W = power_mech_W > 0.0 ? power_mech_W / eta : power_mech_W * eta;
  return {.torque_Nm = torque_Nm,
          .limit_Nm = lim.torque_Nm,
          .limit_state = lim.state,
          .limiting = std::abs(torque_Nm - torque_request_Nm) > 1e-15,
          .power_mech_W = power_mech_W,
          .power_dc_W = power_dc_W,
          .efficiency = eta};
}

}  // namespace ehpt::plant
