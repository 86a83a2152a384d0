// SPDX-License-Identifier: BSD-3-Clause
#include "plant/machine_test_rigs.hpp"

#include <algorithm>
#include <cmath>

namespace ehpt::plant {

namespace {

constexpr double kSqrt2 = 1.4142135623730951;
// "no limit" for the full-flux reference: far above any voltage or current of a machine
constexpr double kUnlimited = 1e12;

// A trapezoid whose level keys carry a unit (offset_rad_s, amplitude_Nm): its problems are
// reported under the key names of the vehicle file, so that they get a file and line.
void validate_profile(const Trapezoid& tr, const std::string& at, const std::string& unit, Problems& problems) {
  Problems own;
  validate(tr, at, own);
  for (Problem q : own.list()) {
    if (q.field == at + ".offset" || q.field == at + ".amplitude") q.field += "_" + unit;
    problems.add(q.field, q.value, q.expected);
  }
}

// Both extremes of a trapezoid's level.
double profile_max(const Trapezoid& tr) { return std::max(tr.offset, tr.offset + tr.amplitude); }
double profile_min(const Trapezoid& tr) { return std::min(tr.offset, tr.offset + tr.amplitude); }

}  // namespace

void validate(const PmDriveTestParams& p, Problems& problems) {
  validate(p.machine, "machine", problems);
  problems.require_positive("u_dc_V", p.u_dc_V);
  if (!(std::isfinite(p.current_filter_s) && p.current_filter_s > 0.0)) {
    problems.add("current_filter_s", number_text(p.current_filter_s), "must be a finite number > 0");
  }
  validate_profile(p.speed_rad_s, "speed", "rad_s", problems);
  validate_profile(p.request_Nm, "request", "Nm", problems);
  // beyond its rated speed the drive cannot hold its voltage within the current limit
  const double w_max = std::max(std::abs(profile_max(p.speed_rad_s)), std::abs(profile_min(p.speed_rad_s)));
  if (std::isfinite(w_max) && w_max > p.machine.speed_max_rad_s) {
    problems.add("speed.amplitude_rad_s", number_text(p.speed_rad_s.amplitude),
                 "takes the speed to " + number_text(w_max) + " rad/s, beyond machine.speed_max_rad_s = " +
                     number_text(p.machine.speed_max_rad_s));
  }
}

const std::array<Signal<PmDriveTest::Outputs>, 24> PmDriveTest::kSignals = {{
    {"time_s", &Outputs::time_s, "simulation time"},
    {"speed_rad_s", &Outputs::speed_rad_s, "imposed rotor speed"},
    {"torque_ref_Nm", &Outputs::torque_ref_Nm, "torque request T*"},
    {"qs_id_A", &Outputs::qs_id_A, "quasi-static drive: d-axis current, peak"},
    {"qs_iq_A", &Outputs::qs_iq_A, "quasi-static drive: q-axis current, peak"},
    {"qs_v_peak_V", &Outputs::qs_v_peak_V, "quasi-static drive: |V| = sqrt(Vd^2 + Vq^2), peak phase voltage"},
    {"qs_v_rms_V", &Outputs::qs_v_rms_V, "quasi-static drive: phase voltage, rms (|V| / sqrt 2)"},
    {"qs_i_rms_A", &Outputs::qs_i_rms_A, "quasi-static drive: phase current, rms"},
    {"qs_torque_Nm", &Outputs::qs_torque_Nm, "quasi-static drive: torque delivered"},
    {"weakening", &Outputs::weakening, "1 in flux weakening (|V| held at U_lim)"},
    {"current_limited", &Outputs::current_limited, "1 when the current limit cuts Iq"},
    {"voltage_limited", &Outputs::voltage_limited, "1 when T* is not reachable at this speed"},
    {"v_lim_peak_V", &Outputs::v_lim_peak_V, "voltage limit U_lim = min(u_dc / sqrt 3, sqrt 2 U_max), peak"},
    {"full_flux_v_peak_V", &Outputs::full_flux_v_peak_V,
     "|V| the delivered torque would need with MTPA currents only (no flux weakening), peak"},
    {"det_v_a_V", &Outputs::det_v_a_V, "detailed PMSM: phase-a voltage v_alpha"},
    {"det_i_a_A", &Outputs::det_i_a_A, "detailed PMSM: phase-a current i_alpha (filtered)"},
    {"det_v_peak_V", &Outputs::det_v_peak_V, "detailed PMSM: space-phasor voltage |v_ab| (peak phase voltage)"},
    {"det_id_A", &Outputs::det_id_A, "detailed PMSM: d-axis current (rotor frame)"},
    {"det_iq_A", &Outputs::det_iq_A, "detailed PMSM: q-axis current (rotor frame)"},
    {"det_torque_Nm", &Outputs::det_torque_Nm, "detailed PMSM: electromagnetic torque 1.5 pp psi x i"},
    {"det_power_W", &Outputs::det_power_W, "detailed PMSM: electrical power in, 1.5 v.i"},
    {"det_magnetic_energy_J", &Outputs::det_magnetic_energy_J, "detailed PMSM: 0.75 (Ld Id^2 + Lq Iq^2)"},
    {"fault", &Outputs::fault, "fault bits (8 non-finite, 16 drive solve did not converge)"},
}};

PmDriveTest::PmDriveTest(const PmDriveTestParams& params) : p_(params), full_flux_(params.machine) {
  const PmDriveParams& m = p_.machine;
  pmsm_ = PmsmParams{m.pole_pairs, m.psi_pm_Wb, m.Ld_H, m.Lq_H, m.Rs_Ohm, p_.current_filter_s};
  full_flux_.U_max_rms_V = kUnlimited;
  full_flux_.I_lim_rms_A = kUnlimited;
}

// Run phase: no allocation. Always inlined, so that each caller computes only what it uses.
[[gnu::always_inline]] inline PmDriveTest::Eval PmDriveTest::evaluate(double t_s, const State& x) const {
  Eval e{};
  e.speed_rad_s = trapezoid(p_.speed_rad_s, t_s);
  e.torque_ref_Nm = trapezoid(p_.request_Nm, t_s);
  // the quasi-static drive's currents, turned into phase-current references at th_e
  e.op = pm_operating_point(p_.machine, e.torque_ref_Nm, e.speed_rad_s, p_.u_dc_V);
  const double theta = x[kTheta];
  const Vec2 i_ref = rotate(theta, Vec2(e.op.id_A, e.op.iq_A));
  e.machine = pmsm_current_fed(pmsm_, theta, p_.machine.pole_pairs * e.speed_rad_s, Vec2(x[kIalpha], x[kIbeta]), i_ref);
  return e;
}

void PmDriveTest::derivatives(double t_s, const State& x, const Modes&, const Inputs&, State& dx) const {
  const Eval e = evaluate(t_s, x);
  dx[kIalpha] = e.machine.di_dt_A_s[0];
  dx[kIbeta] = e.machine.di_dt_A_s[1];
  dx[kTheta] = p_.machine.pole_pairs * e.speed_rad_s;
  dx[kElectricalJ] = e.machine.power_el_W;
  dx[kMechanicalJ] = e.machine.torque_Nm * e.speed_rad_s;
  dx[kCopperJ] = e.machine.copper_loss_W;
}

void PmDriveTest::outputs(double t_s, const State& x, const Modes&, const Inputs&, Outputs& y) const {
  const Eval e = evaluate(t_s, x);
  const PmOperatingPoint& op = e.op;
  y.time_s = t_s;
  y.speed_rad_s = e.speed_rad_s;
  y.torque_ref_Nm = e.torque_ref_Nm;
  y.qs_id_A = op.id_A;
  y.qs_iq_A = op.iq_A;
  y.qs_v_peak_V = std::hypot(op.vd_V, op.vq_V);
  y.qs_v_rms_V = y.qs_v_peak_V / kSqrt2;
  y.qs_i_rms_A = std::hypot(op.id_A, op.iq_A) / kSqrt2;
  y.qs_torque_Nm = op.torque_Nm;
  y.weakening = op.weakening ? 1.0 : 0.0;
  y.current_limited = op.current_limited ? 1.0 : 0.0;
  y.voltage_limited = op.voltage_limited ? 1.0 : 0.0;
  y.v_lim_peak_V = pm_voltage_limit_V(p_.machine, p_.u_dc_V);
  // the same torque with MTPA currents only: no voltage or current limit
  const PmOperatingPoint mtpa = pm_operating_point(full_flux_, op.torque_Nm, e.speed_rad_s, kUnlimited, op.iq_A);
  y.full_flux_v_peak_V = std::hypot(mtpa.vd_V, mtpa.vq_V);
  y.det_v_a_V = e.machine.v_V[0];
  y.det_i_a_A = x[kIalpha];
  y.det_v_peak_V = e.machine.v_V.norm();
  y.det_id_A = e.machine.i_dq_A[0];
  y.det_iq_A = e.machine.i_dq_A[1];
  y.det_torque_Nm = e.machine.torque_Nm;
  y.det_power_W = e.machine.power_el_W;
  y.det_magnetic_energy_J = e.machine.magnetic_energy_J;
  unsigned fault = x.allFinite() ? kFaultNone : kFaultNonFinite;
  if (!op.converged || !mtpa.converged) fault |= kFaultDriveSolve;
  y.fault = fault;
}

EnergyAudit PmDriveTest::audit(const State& x0, const State& x) const {
  const auto magnetic_J = [&](const State& s) {
    return pmsm_current_fed(pmsm_, s[kTheta], 0.0, Vec2(s[kIalpha], s[kIbeta]), Vec2(s[kIalpha], s[kIbeta]))
        .magnetic_energy_J;
  };
  const double el_J = x[kElectricalJ] - x0[kElectricalJ];
  const double mech_J = x[kMechanicalJ] - x0[kMechanicalJ];
  const double cu_J = x[kCopperJ] - x0[kCopperJ];
  const double stored_J = magnetic_J(x) - magnetic_J(x0);
  EnergyAudit a;
  a.sources_J = el_J;
  a.scale_J = std::max(std::abs(el_J), std::abs(mech_J) + cu_J);
  a.residual_J = el_J - (mech_J + cu_J + stored_J);
  a.terms = {{"electrical_in_J", el_J},
             {"mechanical_out_J", mech_J},
             {"copper_losses_J", cu_J},
             {"magnetic_energy_change_J", stored_J}};
  return a;
}

void validate(const AmDriveTestParams& p, Problems& problems) {
  validate(p.machine, "machine", problems);
  validate_profile(p.speed_rad_s, "speed", "rad_s", problems);
  validate_profile(p.request_Nm, "request", "Nm", problems);
}

const std::array<Signal<AmDriveTest::Outputs>, 19> AmDriveTest::kSignals = {{
    {"time_s", &Outputs::time_s, "simulation time"},
    {"speed_rad_s", &Outputs::speed_rad_s, "imposed rotor speed"},
    {"torque_ref_Nm", &Outputs::torque_ref_Nm, "torque request T*"},
    {"qs_w_e_rad_s", &Outputs::qs_w_e_rad_s, "quasi-stationary drive: stator electrical angular frequency"},
    {"qs_slip_rad_s", &Outputs::qs_slip_rad_s, "quasi-stationary drive: slip frequency w_e - pp w_m (electrical)"},
    {"qs_u1_rms_V", &Outputs::qs_u1_rms_V, "quasi-stationary drive: terminal phase voltage U1, rms"},
    {"qs_i1_rms_A", &Outputs::qs_i1_rms_A, "quasi-stationary drive: stator phase current I1, rms"},
    {"qs_torque_Nm", &Outputs::qs_torque_Nm, "quasi-stationary drive: torque"},
    {"weakening", &Outputs::weakening, "1 above base frequency (E capped at U_base)"},
    {"current_limited", &Outputs::current_limited, "1 when the slip is reduced to hold I1 <= I_max"},
    {"torque_at_max", &Outputs::torque_at_max, "1 when T* is at or beyond the reachable maximum"},
    {"det_v_a_V", &Outputs::det_v_a_V, "detailed machine: phase-a voltage sqrt 2 U1 cos th_s"},
    {"det_i_a_A", &Outputs::det_i_a_A, "detailed machine: phase-a stator current i_alpha"},
    {"det_v_peak_V", &Outputs::det_v_peak_V, "detailed machine: space-phasor voltage |v_ab| (peak phase voltage)"},
    {"det_i_peak_A", &Outputs::det_i_peak_A, "detailed machine: space-phasor stator current |i_s,ab| (peak)"},
    {"det_torque_Nm", &Outputs::det_torque_Nm, "detailed machine: electromagnetic torque 1.5 pp psi_s x i_s"},
    {"det_power_W", &Outputs::det_power_W, "detailed machine: electrical power in, 1.5 v.i"},
    {"det_magnetic_energy_J", &Outputs::det_magnetic_energy_J, "detailed machine: 0.75 (psi_s.i_s + psi_r.i_r)"},
    {"fault", &Outputs::fault, "fault bits (8 non-finite)"},
}};

AmDriveTest::AmDriveTest(const AmDriveTestParams& params) : p_(params) {
  const AmDriveParams& m = p_.machine;
  im_ = InductionMachineParams{m.pole_pairs, m.R1_Ohm, m.R2_Ohm, m.L1_H, m.L2_H, m.Lm_H};
}

// Run phase: no allocation. Always inlined, so that each caller computes only what it uses.
[[gnu::always_inline]] inline AmDriveTest::Eval AmDriveTest::evaluate(double t_s, const State& x) const {
  Eval e{};
  e.speed_rad_s = trapezoid(p_.speed_rad_s, t_s);
  e.torque_ref_Nm = trapezoid(p_.request_Nm, t_s);
  // the quasi-stationary drive's terminal voltage and frequency, as a sine source
  e.op = am_operating_point(p_.machine, e.torque_ref_Nm, e.speed_rad_s);
  const double theta = x[kTheta];
  e.v_V = kSqrt2 * e.op.u1_rms_V * Vec2(std::cos(theta), std::sin(theta));
  e.machine = induction_voltage_fed(im_, p_.machine.pole_pairs * e.speed_rad_s, x.segment<2>(kPsiS),
                                    x.segment<2>(kPsiR), e.v_V);
  return e;
}

void AmDriveTest::derivatives(double t_s, const State& x, const Modes&, const Inputs&, State& dx) const {
  const Eval e = evaluate(t_s, x);
  dx.segment<2>(kPsiS) = e.machine.dpsi_s_V;
  dx.segment<2>(kPsiR) = e.machine.dpsi_r_V;
  dx[kTheta] = e.op.w_e_rad_s;
  dx[kElectricalJ] = e.machine.power_el_W;
  dx[kMechanicalJ] = e.machine.torque_Nm * e.speed_rad_s;
  dx[kCopperJ] = e.machine.copper_loss_W;
}

void AmDriveTest::outputs(double t_s, const State& x, const Modes&, const Inputs&, Outputs& y) const {
  const Eval e = evaluate(t_s, x);
  const AmOperatingPoint& op = e.op;
  y.time_s = t_s;
  y.speed_rad_s = e.speed_rad_s;
  y.torque_ref_Nm = e.torque_ref_Nm;
  y.qs_w_e_rad_s = op.w_e_rad_s;
  y.qs_slip_rad_s = op.slip_rad_s;
  y.qs_u1_rms_V = op.u1_rms_V;
  y.qs_i1_rms_A = op.i1_rms_A;
  y.qs_torque_Nm = op.torque_Nm;
  y.weakening = op.weakening ? 1.0 : 0.0;
  y.current_limited = op.current_limited ? 1.0 : 0.0;
  y.torque_at_max = op.torque_at_max ? 1.0 : 0.0;
  y.det_v_a_V = e.v_V[0];
  y.det_i_a_A = e.machine.i_s_A[0];
  y.det_v_peak_V = e.v_V.norm();
  y.det_i_peak_A = e.machine.i_s_A.norm();
  y.det_torque_Nm = e.machine.torque_Nm;
  y.det_power_W = e.machine.power_el_W;
  y.det_magnetic_energy_J = e.machine.magnetic_energy_J;
  y.fault = x.allFinite() ? kFaultNone : kFaultNonFinite;
}

EnergyAudit AmDriveTest::audit(const State& x0, const State& x) const {
  const auto magnetic_J = [&](const State& s) {
    return induction_voltage_fed(im_, 0.0, s.segment<2>(kPsiS), s.segment<2>(kPsiR), Vec2::Zero()).magnetic_energy_J;
  };
  const double el_J = x[kElectricalJ] - x0[kElectricalJ];
  const double mech_J = x[kMechanicalJ] - x0[kMechanicalJ];
  const double cu_J = x[kCopperJ] - x0[kCopperJ];
  const double stored_J = magnetic_J(x) - magnetic_J(x0);
  EnergyAudit a;
  a.sources_J = el_J;
  a.scale_J = std::max(std::abs(el_J), std::abs(mech_J) + cu_J);
  a.residual_J = el_J - (mech_J + cu_J + stored_J);
  a.terms = {{"electrical_in_J", el_J},
             {"mechanical_out_J", mech_J},
             {"copper_losses_J", cu_J},
             {"magnetic_energy_change_J", stored_J}};
  return a;
}

}  // namespace ehpt::plant
