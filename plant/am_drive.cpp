// SPDX-License-Identifier: BSD-3-Clause
#include "plant/am_drive.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <complex>
#include <limits>

namespace ehpt::plant {

namespace {

using Complex = std::complex<double>;

// a / b without the C99 Annex G rescaling of std::complex's operator/ (__divdc3, a library
// call: measured 30 % of an EvAm_bat step). The circuit's values are finite and of moderate
// size (ohms, henries, volt-seconds), so the plain formula loses nothing.
inline Complex divide(Complex a, Complex b) { return a * std::conj(b) / std::norm(b); }

constexpr int kMaxIterations = 60;

// E / |w_e| (rms phase V s): K_uf up to base frequency, U_base / |w_e| above (E capped)
double flux_Vs(const AmDriveParams& p, double w_e) {
  const double w = std::abs(w_e);
  return w > p.w_e_base_rad_s ? p.U_base_rms_V / w : p.U_base_rms_V / p.w_e_base_rad_s;
}

struct Circuit {
  Complex i1, i2;  // rms phasors, A
  double torque_Nm = 0.0;
};

// QSAsma divided by w_e, for the signed flux psi = E / w_e (header comment): the rotor branch
// as an admittance, so dWe = 0 and w_e = 0 need no special case
Circuit solve_circuit(const AmDriveParams& p, double psi, double dwe) {
  const Complex y2 = divide(dwe, Complex(p.R2_Ohm, dwe * p.L2_H));  // w_e / Z2
  const Complex zp = divide(1.0, Complex(0.0, -1.0 / p.Lm_H) + y2);  // Zp / w_e
  Circuit c;
  c.i1 = divide(psi, Complex(0.0, p.L1_H) + zp);
  const Complex vm = c.i1 * zp;  // air-gap voltage / w_e
  c.i2 = vm * y2;
  // 3 pp |I2|^2 R2 / dWe with |I2|^2 = |Vm|^2 dWe^2 / (R2^2 + dWe^2 L2^2): no 1/dWe
  c.torque_Nm = 3.0 * p.pole_pairs * std::norm(vm) * p.R2_Ohm * dwe /
                (p.R2_Ohm * p.R2_Ohm + dwe * dwe * p.L2_H * p.L2_H);
  return c;
}

// |I1|^2 at slip dwe; the flux's sign only turns the phasor
double stator_current_sq(const AmDriveParams& p, double dwe, double w_sync) {
  return std::norm(solve_circuit(p, flux_Vs(p, w_sync + dwe), dwe).i1);
}

// the Thevenin equivalent seen by the rotor branch: E behind j w_e L1 with j w_e Lm across,
// purely reactive because E is behind R1 (header comment)
struct Thevenin {
  double ratio = 0.0;  // Psi_th / Psi = Lm / (L1 + Lm)
  double L_H = 0.0;    // L1 Lm / (L1 + Lm) + L2
};
Thevenin thevenin(const AmDriveParams& p) {
  const double ratio = p.Lm_H / (p.L1_H + p.Lm_H);
  return {ratio, p.L1_H * ratio + p.L2_H};
}

// T_e at slip x from the Thevenin form: the circuit's torque, in real arithmetic
double thevenin_torque(const AmDriveParams& p, const Thevenin& th, double x, double w_sync) {
  const double psi = th.ratio * flux_Vs(p, w_sync + x);
  const double r2 = p.R2_Ohm * p.R2_Ohm;
  return 3.0 * p.pole_pairs * psi * psi * p.R2_Ohm * x / (r2 + x * x * th.L_H * th.L_H);
}

// d ln|T_e| / d|dWe| on side s (+1 motoring dWe > 0, -1 braking) at |dWe| = u: the rotor
// branch's term, less twice the flux's fall with |w_e| above base frequency
double torque_log_slope(const AmDriveParams& p, const Thevenin& th, double u, double s, double w_sync) {
  const double r2 = p.R2_Ohm * p.R2_Ohm, l2 = th.L_H * th.L_H;
  const double branch = (r2 - u * u * l2) / (u * (r2 + u * u * l2));
  const double w_e = w_sync + s * u;
  return std::abs(w_e) > p.w_e_base_rad_s ? branch - 2.0 * s / w_e : branch;
}

// the slip of the largest |T_e| on side s within the limiter: the limiter itself unless the
// falling flux (above base frequency, |w_e| growing with the slip) brings the peak below it;
// then bisection on the slope's sign (one change; a kink at base frequency is bracketed too)
double max_torque_slip(const AmDriveParams& p, const Thevenin& th, double s, double w_sync) {
  const double lim = am_slip_limit_rad_s(p);
  if (torque_log_slope(p, th, lim, s, w_sync) >= 0.0) return s * lim;
  double lo = 0.0, hi = lim;
  for (int i = 0; i < kMaxIterations && hi - lo > 1e-15 * lim; ++i) {
    const double mid = 0.5 * (lo + hi);
    (torque_log_slope(p, th, mid, s, w_sync) > 0.0 ? lo : hi) = mid;
  }
  return s * lo;
}

// Illinois regula falsi on f over [lo, hi] with f(lo) <= 0 < f(hi): the bracket it ends with
// and its last estimate. Stops when |f(x)| <= tol_f (and f(x) <= 0 if feasible_only, so that
// lo is then within tolerance) or the bracket is narrower than tol_x.
struct Bracket {
  double lo, hi, last;
};
template <class F>
Bracket illinois(const F& f, double lo, double f_lo, double hi, double f_hi, double tol_f, double tol_x,
                 bool feasible_only) {
  double x = lo;
  int side = 0;
  for (int i = 0; i < kMaxIterations && std::abs(hi - lo) > tol_x; ++i) {
    x = (lo * f_hi - hi * f_lo) / (f_hi - f_lo);
    const double fx = f(x);
    if (fx <= 0.0) {
      lo = x;
      f_lo = fx;
      if (side == -1) f_hi *= 0.5;  // the stale end is halved
      side = -1;
    } else {
      hi = x;
      f_hi = fx;
      if (side == 1) f_lo *= 0.5;
      side = 1;
    }
    if (std::abs(fx) <= tol_f && (fx <= 0.0 || !feasible_only)) break;
  }
  return {lo, hi, x};
}

// short text for a computed bound in a message
std::string short_text(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, 5);
  return std::string(buf, r.ptr);
}

bool finite_positive(double v) { return std::isfinite(v) && v > 0.0; }

void check_pole_pairs(int pole_pairs, const std::string& at, Problems& problems) {
  if (pole_pairs < 1 || pole_pairs > 100) {
    problems.add(at + ".pole_pairs", std::to_string(pole_pairs), "must be a whole number in [1, 100]");
  }
}

}  // namespace

void validate(const AmDriveParams& p, const std::string& at, Problems& problems) {
  check_pole_pairs(p.pole_pairs, at, problems);
  problems.require_positive(at + ".R1_Ohm", p.R1_Ohm);
  problems.require_positive(at + ".R2_Ohm", p.R2_Ohm);
  problems.require_positive(at + ".L1_H", p.L1_H);
  problems.require_positive(at + ".L2_H", p.L2_H);
  problems.require_positive(at + ".Lm_H", p.Lm_H);
  problems.require_positive(at + ".U_base_rms_V", p.U_base_rms_V);
  problems.require_positive(at + ".w_e_base_rad_s", p.w_e_base_rad_s);
  problems.require_positive(at + ".I_max_rms_A", p.I_max_rms_A);
  // zero inertia is allowed: a vehicle may lump the rotor into its own mass
  problems.require_non_negative(at + ".inertia_kgm2", p.inertia_kgm2);
  problems.require_non_negative(at + ".k_inv_W_per_A", p.k_inv_W_per_A);
  // the current limit must leave room for the magnetising current (largest at base frequency)
  if (finite_positive(p.U_base_rms_V) && finite_positive(p.w_e_base_rad_s) && finite_positive(p.L1_H) &&
      finite_positive(p.Lm_H) && finite_positive(p.I_max_rms_A)) {
    const double i0 = p.U_base_rms_V / (p.w_e_base_rad_s * (p.L1_H + p.Lm_H));
    if (!(p.I_max_rms_A > i0)) {
      problems.add(at + ".I_max_rms_A", number_text(p.I_max_rms_A),
                   "must be above the no-load (magnetising) current " + short_text(i0) +
                       " A = U_base_rms_V / (w_e_base_rad_s (L1_H + Lm_H)): the machine draws it at "
                       "zero slip, so no slip could hold the current limit");
    }
  }
}

double am_slip_limit_rad_s(const AmDriveParams& p) { return p.R2_Ohm / (p.L1_H + p.L2_H); }

AmOperatingPoint am_from_slip(const AmDriveParams& p, double dWe_rad_s, double speed_rad_s) {
  AmOperatingPoint op;
  // P15's limiter (uContrGen): the peak of the simplified torque curve
  const double lim = am_slip_limit_rad_s(p);
  op.slip_limited = std::abs(dWe_rad_s) > lim;
  const double dwe = std::clamp(dWe_rad_s, -lim, lim);
  const double w_e = p.pole_pairs * speed_rad_s + dwe;
  // U/f on E, capped at the base voltage above base frequency
  op.weakening = std::abs(w_e) > p.w_e_base_rad_s;
  const double e = op.weakening ? p.U_base_rms_V : p.U_base_rms_V / p.w_e_base_rad_s * std::abs(w_e);
  const double flux = flux_Vs(p, w_e);
  // E is the real reference phasor; Psi = E / w_e carries w_e's sign
  const Circuit c = solve_circuit(p, w_e < 0.0 ? -flux : flux, dwe);
  const Complex u1 = e + p.R1_Ohm * c.i1;
  op.torque_Nm = c.torque_Nm;
  op.slip_rad_s = dwe;
  op.w_e_rad_s = w_e;
  op.emf_rms_V = e;
  op.u1_rms_V = std::sqrt(std::norm(u1));  // not std::abs: hypot is a library call
  // sqrt(norm), as the current limit computes it: |I1| <= I_max holds to the last bit
  op.i1_rms_A = std::sqrt(std::norm(c.i1));
  op.i2_rms_A = std::sqrt(std::norm(c.i2));
  // P_abs as P15 states it; it equals 3 Re(U1 conj I1) because the reactances absorb nothing
  op.power_mech_W = op.torque_Nm * speed_rad_s;
  op.loss_copper_W = 3.0 * (p.R1_Ohm * op.i1_rms_A * op.i1_rms_A + p.R2_Ohm * op.i2_rms_A * op.i2_rms_A);
  op.power_abs_W = op.power_mech_W + op.loss_copper_W;
  op.loss_inverter_W = p.k_inv_W_per_A * op.i1_rms_A;
  op.power_dc_W = op.power_abs_W + op.loss_inverter_W;
  return op;
}

double am_slip_for_torque(const AmDriveParams& p, double torque_ref_Nm, double speed_rad_s, bool& at_max) {
  at_max = false;
  if (torque_ref_Nm == 0.0 || std::isnan(torque_ref_Nm)) return torque_ref_Nm;  // no torque, no slip
  const Thevenin th = thevenin(p);
  const double s = torque_ref_Nm > 0.0 ? 1.0 : -1.0;
  const double t_ref = std::abs(torque_ref_Nm);
  const double w_sync = p.pole_pairs * speed_rad_s;
  // the bracket's far end: the limiter, or the torque peak below it (then the root is below
  // the peak; if T* is below the limiter's torque it is the only one in [0, limiter] anyway)
  double x_end = s * am_slip_limit_rad_s(p);
  double t_end = std::abs(thevenin_torque(p, th, x_end, w_sync));
  if (t_ref >= t_end) {
    x_end = max_torque_slip(p, th, s, w_sync);
    t_end = std::abs(thevenin_torque(p, th, x_end, w_sync));
    if (t_ref >= t_end) {
      at_max = true;  // tauIsMax: the largest torque there is
      return x_end;
    }
  }
  // §9.2's small root at the flux of slip 0: exact while the flux stays constant up to it
  const double psi = th.ratio * flux_Vs(p, w_sync);
  const double b = 3.0 * p.pole_pairs * psi * psi;
  const double disc = b * b - 4.0 * torque_ref_Nm * torque_ref_Nm * th.L_H * th.L_H;
  const auto excess = [&](double x) { return std::abs(thevenin_torque(p, th, x, w_sync)) - t_ref; };
  double lo = 0.0, f_lo = -t_ref, hi = x_end, f_hi = t_end - t_ref;
  const double tol_f = 1e-13 * t_ref;
  if (disc >= 0.0) {
    const double x0 = 2.0 * torque_ref_Nm * p.R2_Ohm / (b + std::sqrt(disc));
    if (std::abs(x0) < std::abs(x_end)) {
      const double f0 = excess(x0);
      if (std::abs(f0) <= tol_f) return x0;
      (f0 <= 0.0 ? lo : hi) = x0;
      (f0 <= 0.0 ? f_lo : f_hi) = f0;
    }
  }
  // above base frequency the flux follows the slip: regula falsi on |T_e(x)| = |T*|
  const double tol_x = 1e-15 * am_slip_limit_rad_s(p);
  return illinois(excess, lo, f_lo, hi, f_hi, tol_f, tol_x, false).last;
}

double am_slip_within_current(const AmDriveParams& p, double dWe_rad_s, double speed_rad_s, bool& limited) {
  limited = false;
  const double lim = am_slip_limit_rad_s(p);
  const double x = std::clamp(dWe_rad_s, -lim, lim);
  const double w_sync = p.pole_pairs * speed_rad_s;
  const double i_max2 = p.I_max_rms_A * p.I_max_rms_A;
  const auto excess = [&](double d) { return stator_current_sq(p, d, w_sync) - i_max2; };
  const double f_x = excess(x);
  if (!(f_x > 0.0)) return x;
  limited = true;
  // |I1| at zero slip is the no-load current; validate() keeps it below I_max
  const double f_0 = excess(0.0);
  if (!(f_0 < 0.0)) return 0.0;
  // |I1| rises with |dWe| above the no-load current: one crossing; end on its feasible side
  return illinois(excess, 0.0, f_0, x, f_x, 1e-13 * i_max2, 1e-15 * lim, true).lo;
}

AmOperatingPoint am_operating_point(const AmDriveParams& p, double torque_ref_Nm, double speed_rad_s) {
  bool at_max = false, current_limited = false;
  const double dwe = am_slip_for_torque(p, torque_ref_Nm, speed_rad_s, at_max);
  AmOperatingPoint op = am_from_slip(p, am_slip_within_current(p, dwe, speed_rad_s, current_limited), speed_rad_s);
  op.torque_at_max = at_max;
  op.slip_limited = at_max;
  op.current_limited = current_limited;
  return op;
}

double am_torque_limit_Nm(const AmDriveParams& p, double speed_rad_s) {
  const Thevenin th = thevenin(p);
  const double w_sync = p.pole_pairs * speed_rad_s;
  double limit = std::numeric_limits<double>::infinity();
  for (const double s : {1.0, -1.0}) {
    bool current_limited = false;
    const double x = am_slip_within_current(p, max_torque_slip(p, th, s, w_sync), speed_rad_s, current_limited);
    limit = std::min(limit, std::abs(thevenin_torque(p, th, x, w_sync)));
  }
  return limit;
}

void validate(const AmDrivePuParams& p, const std::string& at, Problems& problems) {
  check_pole_pairs(p.pole_pairs, at, problems);
  problems.require_positive(at + ".S_nom_VA", p.S_nom_VA);
  problems.require_positive(at + ".V_nom_rms_V", p.V_nom_rms_V);
  problems.require_positive(at + ".f_nom_Hz", p.f_nom_Hz);
  problems.require_positive(at + ".r1_pu", p.r1_pu);
  problems.require_positive(at + ".r2_pu", p.r2_pu);
  problems.require_positive(at + ".x1_pu", p.x1_pu);
  problems.require_positive(at + ".x2_pu", p.x2_pu);
  problems.require_positive(at + ".xm_pu", p.xm_pu);
  problems.require_positive(at + ".I_max_pu", p.I_max_pu);
  problems.require_non_negative(at + ".H_s", p.H_s);
  problems.require_non_negative(at + ".k_inv_pu", p.k_inv_pu);
  // no-load current at rated voltage and frequency, p.u.: 1 / (x1 + xm)
  if (finite_positive(p.x1_pu) && finite_positive(p.xm_pu) && finite_positive(p.I_max_pu)) {
    const double i0 = 1.0 / (p.x1_pu + p.xm_pu);
    if (!(p.I_max_pu > i0)) {
      problems.add(at + ".I_max_pu", number_text(p.I_max_pu),
                   "must be above the no-load (magnetising) current " + short_text(i0) +
                       " p.u. = 1 / (x1_pu + xm_pu): the machine draws it at zero slip, so no slip "
                       "could hold the current limit");
    }
  }
}

AmDriveParams am_params_from_pu(const AmDrivePuParams& p) {
  const double w_base = 2.0 * std::numbers::pi * p.f_nom_Hz;
  const double z_base = 3.0 * p.V_nom_rms_V * p.V_nom_rms_V / p.S_nom_VA;
  const double l_base = z_base / w_base;
  const double i_base = p.S_nom_VA / (3.0 * p.V_nom_rms_V);
  const double w_m_base = w_base / p.pole_pairs;
  AmDriveParams si;
  si.pole_pairs = p.pole_pairs;
  si.R1_Ohm = p.r1_pu * z_base;
  si.R2_Ohm = p.r2_pu * z_base;
  si.L1_H = p.x1_pu * l_base;
  si.L2_H = p.x2_pu * l_base;
  si.Lm_H = p.xm_pu * l_base;
  // H = kinetic energy at synchronous speed / S_base
  si.inertia_kgm2 = 2.0 * p.H_s * p.S_nom_VA / (w_m_base * w_m_base);
  si.U_base_rms_V = p.V_nom_rms_V;
  si.w_e_base_rad_s = w_base;
  si.I_max_rms_A = p.I_max_pu * i_base;
  si.k_inv_W_per_A = p.k_inv_pu * p.S_nom_VA / i_base;
  return si;
}

}  // namespace ehpt::plant
