// SPDX-License-Identifier: BSD-3-Clause
#include "plant/detailed_machines.hpp"

namespace ehpt::plant {

namespace {

void positive(const std::string& field, double v, Problems& problems) {
  if (!(std::isfinite(v) && v > 0.0)) problems.add(field, number_text(v), "must be a finite number > 0");
}

void pole_pairs(const std::string& field, int pp, Problems& problems) {
  if (pp < 1 || pp > 100) problems.add(field, std::to_string(pp), "must be a whole number in [1, 100]");
}

}  // namespace

void validate(const PmsmParams& p, const std::string& at, Problems& problems) {
  pole_pairs(at + ".pole_pairs", p.pole_pairs, problems);
  positive(at + ".psi_pm_Wb", p.psi_pm_Wb, problems);
  positive(at + ".Ld_H", p.Ld_H, problems);
  positive(at + ".Lq_H", p.Lq_H, problems);
  if (!(std::isfinite(p.Rs_Ohm) && p.Rs_Ohm >= 0.0)) {
    problems.add(at + ".Rs_Ohm", number_text(p.Rs_Ohm), "must be a finite number >= 0");
  }
  positive(at + ".current_filter_s", p.current_filter_s, problems);
}

void validate(const InductionMachineParams& p, const std::string& at, Problems& problems) {
  pole_pairs(at + ".pole_pairs", p.pole_pairs, problems);
  if (!(std::isfinite(p.R1_Ohm) && p.R1_Ohm >= 0.0)) {
    problems.add(at + ".R1_Ohm", number_text(p.R1_Ohm), "must be a finite number >= 0");
  }
  positive(at + ".R2_Ohm", p.R2_Ohm, problems);  // 0 would be a synchronous cage: no torque
  positive(at + ".L1_H", p.L1_H, problems);
  positive(at + ".L2_H", p.L2_H, problems);
  positive(at + ".Lm_H", p.Lm_H, problems);
}

// Run phase: no allocation.
PmsmResponse pmsm_current_fed(const PmsmParams& p, double theta_e_rad, double w_e_rad_s, const Vec2& i_A,
                              const Vec2& i_ref_A) {
  PmsmResponse r;
  // the harness's filters
  r.di_dt_A_s = (i_ref_A - i_A) / p.current_filter_s;
  // rotor frame: currents, their derivative (the frame turns at w_e), flux linkage
  const Vec2 i_dq = rotate(-theta_e_rad, i_A);
  const Vec2 di_dq = rotate(-theta_e_rad, r.di_dt_A_s) - w_e_rad_s * Vec2(-i_dq[1], i_dq[0]);
  const Vec2 psi_dq(p.Ld_H * i_dq[0] + p.psi_pm_Wb, p.Lq_H * i_dq[1]);
  // v_dq = Rs i + L di/dt + w_e J psi, back to the stator frame
  const Vec2 v_dq(p.Rs_Ohm * i_dq[0] + p.Ld_H * di_dq[0] - w_e_rad_s * psi_dq[1],
                  p.Rs_Ohm * i_dq[1] + p.Lq_H * di_dq[1] + w_e_rad_s * psi_dq[0]);
  r.v_V = rotate(theta_e_rad, v_dq);
  r.i_dq_A = i_dq;
  // the cross product is rotation-invariant: psi_ab x i_ab = psi_dq x i_dq
  r.torque_Nm = 1.5 * p.pole_pairs * cross(psi_dq, i_dq);
  r.power_el_W = 1.5 * v_dq.dot(i_dq);
  r.copper_loss_W = 1.5 * p.Rs_Ohm * i_dq.squaredNorm();
  r.magnetic_energy_J = 0.75 * (p.Ld_H * i_dq[0] * i_dq[0] + p.Lq_H * i_dq[1] * i_dq[1]);
  return r;
}

// Run phase: no allocation.
InductionMachineResponse induction_voltage_fed(const InductionMachineParams& p, double w_r_rad_s, const Vec2& psi_s_Wb,
                                               const Vec2& psi_r_Wb, const Vec2& v_s_V) {
  InductionMachineResponse r;
  // currents from the flux linkages (the inductance matrix inverted in closed form)
  const double Ls = p.L1_H + p.Lm_H, Lr = p.L2_H + p.Lm_H;
  const double inv_D = 1.0 / (Ls * Lr - p.Lm_H * p.Lm_H);
  r.i_s_A = (Lr * psi_s_Wb - p.Lm_H * psi_r_Wb) * inv_D;
  r.i_r_A = (Ls * psi_r_Wb - p.Lm_H * psi_s_Wb) * inv_D;
  // stator and (short-circuited) rotor windings, the rotor's EMF of motion turning at w_r
  r.dpsi_s_V = v_s_V - p.R1_Ohm * r.i_s_A;
  r.dpsi_r_V = -p.R2_Ohm * r.i_r_A + w_r_rad_s * Vec2(-psi_r_Wb[1], psi_r_Wb[0]);
  r.torque_Nm = 1.5 * p.pole_pairs * cross(psi_s_Wb, r.i_s_A);
  r.power_el_W = 1.5 * v_s_V.dot(r.i_s_A);
  r.copper_loss_W = 1.5 * (p.R1_Ohm * r.i_s_A.squaredNorm() + p.R2_Ohm * r.i_r_A.squaredNorm());
  r.magnetic_energy_J = 0.75 * (psi_s_Wb.dot(r.i_s_A) + psi_r_Wb.dot(r.i_r_A));
  return r;
}

}  // namespace ehpt::plant
