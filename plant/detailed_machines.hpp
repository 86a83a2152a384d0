// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Time-domain ("detailed") machine models: the references the quasi-stationary drives of
// MODELS.md §9 are compared with (P15 §2 compares its quasi-stationary drives with time-domain
// machine models; issue 10 item 3). They resolve every electrical period, so they
// cost hundreds of steps per period where the drives of plant/pm_drive.hpp and
// plant/am_drive.hpp cost one algebraic solve per step.
//
// Frame and scaling: stator-fixed alpha-beta, amplitude-invariant Clarke transform, so a
// balanced set x_a = X cos(th), x_b = X cos(th - 2 pi/3), ... maps to x_alpha = X cos th,
// x_beta = X sin th: phase a is x_alpha, the space-phasor length |x_ab| is the PEAK phase value
// (rms = |x_ab| / sqrt 2 in steady state), and power is 1.5 v.i. Park: x_dq = R(-th) x_ab,
// R(th) = [cos -sin; sin cos], J = R(pi/2); "a x b" is the scalar a_alpha b_beta - a_beta b_alpha.
//
// PMSM, current fed (the MSL test harness of §11.6: each phase current follows its
// reference through a first-order filter, T_f = 20 us, the machine's voltage is whatever the
// currents need). States: the filtered currents i_ab; the electrical angle th_e is the rig's
// (d th_e/dt = w_e = pp w_m, speed imposed).
//   di_ab/dt = (i_ref,ab - i_ab) / T_f,          i_ref,ab = R(th_e) [Id*, Iq*]
//   psi_ab   = R(th_e) diag(Ld, Lq) R(-th_e) i_ab + psi_pm [cos th_e, sin th_e]
//   v_ab     = Rs i_ab + d psi_ab/dt
//   T_e      = 1.5 pp (psi_ab x i_ab)
// d psi_ab/dt is analytic, not differenced: in the rotor frame (i_dq = R(-th) i_ab,
// di_dq/dt = R(-th) di_ab/dt - w_e J i_dq) it is v_dq = Rs i_dq + diag(Ld,Lq) di_dq/dt
// + w_e J psi_dq with psi_dq = diag(Ld,Lq) i_dq + [psi_pm, 0], i.e. the §9.1 equations
//   Vd = Rs Id + Ld dId/dt - w_e Lq Iq,   Vq = Rs Iq + Lq dIq/dt + w_e (psi_pm + Ld Id)
// that reduce to the drive's steady-state ones when dI/dt = 0; v_ab = R(th_e) v_dq.
// Steady state of the filter: a reference turning at w_e reaches the machine as
// i_dq = I*_dq / (1 + j w_e T_f) (dq as a complex number): lagging by atan(w_e T_f)
// (0.73 deg at 634 rad/s), which is why the detailed torque and voltage differ slightly
// from the quasi-static ones (the test tolerances are derived from it).
// Power balance: 1.5 v.i = 1.5 Rs |i|^2 + dW/dt + T_e w_m, W = 0.75 (Ld Id^2 + Lq Iq^2).
//
// Squirrel-cage induction machine, voltage fed (MSL AIM_SquirrelCage without core and
// friction losses; the T circuit of §9.2: R1, L1 stator leakage, Lm, L2 rotor leakage, R2).
// States: the stator and rotor flux linkages psi_s, psi_r (alpha-beta, the rotor's referred
// to the stator); rotor speed imposed, w_r = pp w_m (electrical).
//   d psi_s/dt = v_s - R1 i_s
//   d psi_r/dt = -R2 i_r + w_r J psi_r                 (short-circuited cage seen from the stator)
//   psi_s = Ls i_s + Lm i_r,  psi_r = Lm i_s + Lr i_r,  Ls = L1 + Lm,  Lr = L2 + Lm
//   i_s = (Lr psi_s - Lm psi_r) / D,  i_r = (Ls psi_r - Lm psi_s) / D,  D = Ls Lr - Lm^2
//   T_e = 1.5 pp (psi_s x i_s)   (= -1.5 pp (psi_r x i_r))
// Steady state at stator frequency w_e is exactly the per-phase circuit of §9.2 with slip
// frequency w_e - w_r (peak phasors; rms = peak / sqrt 2), so fed with the drive's U1 and w_e
// the detailed torque converges to the quasi-static one.
// Power balance: 1.5 v_s.i_s = 1.5 (R1 |i_s|^2 + R2 |i_r|^2) + dW/dt + T_e w_m,
// W = 0.75 (psi_s.i_s + psi_r.i_r).
// Fluxes are the states (not currents): the derivatives are then explicit, with no matrix
// to invert per evaluation.

#include <cmath>
#include <string>

#include <Eigen/Core>

#include "plant/problems.hpp"

namespace ehpt::plant {

using Vec2 = Eigen::Vector2d;

// R(angle) x: a rotation of the plane (Park: rotate(-th, x_ab) = x_dq).
inline Vec2 rotate(double angle_rad, const Vec2& x) {
  const double c = std::cos(angle_rad), s = std::sin(angle_rad);
  return {c * x[0] - s * x[1], s * x[0] + c * x[1]};
}
inline double cross(const Vec2& a, const Vec2& b) { return a[0] * b[1] - a[1] * b[0]; }

struct PmsmParams {
  int pole_pairs = 2;
  double psi_pm_Wb = 0.5055;  // PM flux linkage, peak per phase
  double Ld_H = 9.549e-4;
  double Lq_H = 9.549e-4;
  double Rs_Ohm = 0.03;
  double current_filter_s = 20e-6;  // T_f of the harness's current filters (MSL tests: 20 us)
};
void validate(const PmsmParams& p, const std::string& at, Problems& problems);

struct PmsmResponse {
  Vec2 di_dt_A_s{0.0, 0.0};  // d i_ab / dt (the filters)
  Vec2 v_V{0.0, 0.0};        // terminal voltage, alpha-beta (v_a = v_alpha)
  Vec2 i_dq_A{0.0, 0.0};     // the currents in the rotor frame
  double torque_Nm = 0.0;
  double power_el_W = 0.0;         // 1.5 v.i, into the machine
  double copper_loss_W = 0.0;      // 1.5 Rs |i|^2
  double magnetic_energy_J = 0.0;  // 0.75 (Ld Id^2 + Lq Iq^2)
};

// Run phase, pure: the filters' derivatives and the machine's terminal quantities at
// electrical angle th_e and speed w_e, for filtered currents i_ab and references i_ref_ab.
PmsmResponse pmsm_current_fed(const PmsmParams& p, double theta_e_rad, double w_e_rad_s, const Vec2& i_A,
                              const Vec2& i_ref_A);

struct InductionMachineParams {
  int pole_pairs = 2;
  double R1_Ohm = 0.03;   // stator
  double R2_Ohm = 0.04;   // rotor, referred to the stator
  double L1_H = 3.240e-4; // stator leakage
  double L2_H = 3.240e-4; // rotor leakage
  double Lm_H = 9.225e-3; // magnetising (MSL default machine, §9.2)
};
void validate(const InductionMachineParams& p, const std::string& at, Problems& problems);

struct InductionMachineResponse {
  Vec2 dpsi_s_V{0.0, 0.0};  // d psi_s / dt (Wb/s = V)
  Vec2 dpsi_r_V{0.0, 0.0};
  Vec2 i_s_A{0.0, 0.0};     // stator current, alpha-beta (i_a = i_alpha)
  Vec2 i_r_A{0.0, 0.0};
  double torque_Nm = 0.0;
  double power_el_W = 0.0;         // 1.5 v_s.i_s
  double copper_loss_W = 0.0;      // 1.5 (R1 |i_s|^2 + R2 |i_r|^2)
  double magnetic_energy_J = 0.0;  // 0.75 (psi_s.i_s + psi_r.i_r)
};

// Run phase, pure: the flux derivatives and currents for stator voltage v_s and electrical
// rotor speed w_r = pp w_m.
InductionMachineResponse induction_voltage_fed(const InductionMachineParams& p, double w_r_rad_s, const Vec2& psi_s_Wb,
                                               const Vec2& psi_r_Wb, const Vec2& v_s_V);

}  // namespace ehpt::plant
