// SPDX-License-Identifier: BSD-3-Clause
#include "plant/drive_rigs.hpp"

#include <cmath>

namespace ehpt::plant {

double trapezoid(const Trapezoid& tr, double t_s) {
  if (t_s < tr.start_s) return tr.offset;
  double tau = t_s - tr.start_s;
  if (tau >= tr.period_s) tau = std::fmod(tau, tr.period_s);  // fmod is slow; most runs are one period
  if (tau < tr.rising_s) return tr.offset + tr.amplitude * tau / tr.rising_s;
  if (tau < tr.rising_s + tr.width_s) return tr.offset + tr.amplitude;
  if (tau < tr.rising_s + tr.width_s + tr.falling_s) {
    return tr.offset + tr.amplitude * (1.0 - (tau - tr.rising_s - tr.width_s) / tr.falling_s);
  }
  return tr.offset;
}

void validate(const Trapezoid& tr, const std::string& at, Problems& problems) {
  problems.require_finite(at + ".offset", tr.offset);
  problems.require_finite(at + ".amplitude", tr.amplitude);
  problems.require_non_negative(at + ".start_s", tr.start_s);
  problems.require_positive(at + ".rising_s", tr.rising_s);
  problems.require_non_negative(at + ".width_s", tr.width_s);
  problems.require_positive(at + ".falling_s", tr.falling_s);
  if (!(tr.period_s >= tr.rising_s + tr.width_s + tr.falling_s)) {
    problems.add(at + ".period_s", number_text(tr.period_s), "must be >= rising_s + width_s + falling_s");
  }
}

void validate(const DriveRigParams& p, Problems& problems) {
  validate(p.drive, "drive", problems);
  problems.require_non_negative("load.inertia_kgm2", p.load_inertia_kgm2);
  problems.require_finite("load.speed_initial_rad_s", p.speed_initial_rad_s);
  problems.require_finite("load.torque_nominal_Nm", p.load_torque_nominal_Nm);
  problems.require_positive("load.speed_nominal_rad_s", p.load_speed_nominal_rad_s);
  problems.require_finite("load.flange_a_torque_Nm", p.flange_a_torque_Nm);
  problems.require_positive("dc_voltage_V", p.dc_voltage_V);
  validate(p.request_Nm, "request", problems);
}

namespace {
using O = DriveRig::Outputs;
constexpr std::array<Signal<O>, 14> kOneFlangeSignals = {{
    {"time_s", &O::time_s, "simulation time"},
    {"genTauRef_Nm", &O::tau_ref_Nm, "torque request (bus genTauRef)"},
    {"tauElectrical_Nm", &O::tau_Nm, "torque applied by the drive"},
    {"genTauLim_Nm", &O::tau_lim_Nm, "limiter bound yH (bus genTauLim)"},
    {"limit_state", &O::limit_state, "limiter state 0 torque, 1 power, 2 speed ramp, 3 over speed"},
    {"limitingTorque", &O::limiting, "1 when the limiter cuts the request"},
    {"genW_rad_s", &O::speed_rad_s, "shaft speed (bus genW)"},
    {"genPowDel_W", &O::pow_del_W, "power at the flange after the rotor inertia (bus genPowDel)"},
    {"power_mech_W", &O::power_mech_W, "torque x speed"},
    {"power_dc_W", &O::power_dc_W, "DC power drawn"},
    {"dc_current_A", &O::dc_current_A, "DC current from the ideal source"},
    {"efficiency", &O::efficiency, "drive efficiency from the map"},
    {"load_torque_Nm", &O::load_torque_Nm, "quadratic load torque on the shaft"},
    {"fault", &O::fault, "fault bits (8 non-finite)"},
}};
constexpr std::array<Signal<O>, 16> kTwoFlangeSignals = {{
    {"time_s", &O::time_s, "simulation time"},
    {"motTauRef_Nm", &O::tau_ref_Nm, "torque request (bus motTauRef)"},
    {"tauElectrical_Nm", &O::tau_Nm, "torque applied by the drive"},
    {"motTauLim_Nm", &O::tau_lim_Nm, "limiter bound yH (bus motTauLim)"},
    {"limit_state", &O::limit_state, "limiter state 0 torque, 1 power, 2 speed ramp, 3 over speed"},
    {"limitingTorque", &O::limiting, "1 when the limiter cuts the request"},
    {"motW_rad_s", &O::speed_rad_s, "shaft speed (bus motW)"},
    {"motPowDelA_W", &O::pow_del_a_W, "power delivered through flange A"},
    {"motPowDelB_W", &O::pow_del_b_W, "power delivered through flange B"},
    {"motPowDelAB_W", &O::pow_del_W, "A + B (bus motPowDelAB)"},
    {"power_mech_W", &O::power_mech_W, "torque x speed"},
    {"power_dc_W", &O::power_dc_W, "DC power drawn"},
    {"dc_current_A", &O::dc_current_A, "DC current from the ideal source"},
    {"efficiency", &O::efficiency, "drive efficiency from the map"},
    {"load_torque_Nm", &O::load_torque_Nm, "quadratic load torque on flange B"},
    {"fault", &O::fault, "fault bits (8 non-finite)"},
}};
}  // namespace

std::span<const Signal<DriveRig::Outputs>> DriveRig::signals() const {
  if (p_.two_flange) return kTwoFlangeSignals;
  return kOneFlangeSignals;
}

DriveRig::State DriveRig::initial_state() const {
  State x = State::Zero();
  x[kSpeed] = p_.speed_initial_rad_s;
  return x;
}

// Run phase: no allocation. Always inlined, so that each caller computes only what it uses.
[[gnu::always_inline]] inline DriveRig::Eval DriveRig::evaluate(double t_s, const State& x) const {
  Eval e{};
  const double w = x[kSpeed];
  e.tau_ref_Nm = trapezoid(p_.request_Nm, t_s);
  e.op = drive_.operate(e.tau_ref_Nm, w);
  const double wn = w / p_.load_speed_nominal_rad_s;
  e.load_Nm = p_.load_torque_nominal_Nm * wn * wn;
  const double flange_a_Nm = p_.two_flange ? p_.flange_a_torque_Nm : 0.0;
  e.accel_rad_s2 = (e.op.torque_Nm + e.load_Nm + flange_a_Nm) * inv_inertia_;
  return e;
}

void DriveRig::derivatives(double t_s, const State& x, const Modes&, const Inputs&, State& dx) const {
  const Eval e = evaluate(t_s, x);
  const double w = x[kSpeed];
  const double flange_a_Nm = p_.two_flange ? p_.flange_a_torque_Nm : 0.0;
  dx[kSpeed] = e.accel_rad_s2;
  dx[kDcJ] = e.op.power_dc_W;
  dx[kDriveLossJ] = e.op.power_dc_W - e.op.power_mech_W;
  dx[kLoadJ] = -(e.load_Nm + flange_a_Nm) * w;
}

void DriveRig::outputs(double t_s, const State& x, const Modes&, const Inputs&, Outputs& y) const {
  const Eval e = evaluate(t_s, x);
  const double w = x[kSpeed];
  y.time_s = t_s;
  y.tau_ref_Nm = e.tau_ref_Nm;
  y.tau_Nm = e.op.torque_Nm;
  y.tau_lim_Nm = e.op.limit_Nm;
  y.limit_state = e.op.limit_state;
  y.limiting = e.op.limiting ? 1.0 : 0.0;
  y.speed_rad_s = w;
  y.pow_del_W = (e.op.torque_Nm - p_.drive.inertia_kgm2 * e.accel_rad_s2) * w;
  y.pow_del_a_W = p_.two_flange ? -p_.flange_a_torque_Nm * w : 0.0;
  y.pow_del_b_W = y.pow_del_W - y.pow_del_a_W;
  y.power_mech_W = e.op.power_mech_W;
  y.power_dc_W = e.op.power_dc_W;
  y.dc_current_A = e.op.power_dc_W / p_.dc_voltage_V;
  y.efficiency = e.op.efficiency;
  y.load_torque_Nm = e.load_Nm;
  y.fault = x.allFinite() ? kFaultNone : kFaultNonFinite;
}

EnergyAudit DriveRig::audit(const State& x0, const State& x) const {
  const double dc_J = x[kDcJ] - x0[kDcJ];
  const double losses_J = x[kDriveLossJ] - x0[kDriveLossJ];
  const double load_J = x[kLoadJ] - x0[kLoadJ];
  const double kinetic_J = 0.5 * total_inertia_kgm2() * (x[kSpeed] * x[kSpeed] - x0[kSpeed] * x0[kSpeed]);
  EnergyAudit a;
  a.sources_J = dc_J;
  a.scale_J = std::abs(dc_J);
  a.residual_J = dc_J - (losses_J + load_J + kinetic_J);
  a.terms = {{"dc_source_out_J", dc_J},
             {"drive_losses_J", losses_J},
             {"load_work_J", load_J},
             {"kinetic_energy_change_J", kinetic_J}};
  return a;
}

}  // namespace ehpt::plant
