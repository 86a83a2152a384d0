// SPDX-License-Identifier: BSD-3-Clause
#include "plant/pm_drive.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>


namespace ehpt::plant {

namespace {

constexpr int kMaxIterations = 60;

double torque_of(const PmDriveParams& p, double id, double iq) {
  return 1.5 * p.pole_pairs * (p.psi_pm_Wb * iq + (p.Ld_H - p.Lq_H) * id * iq);
}

void voltages(const PmDriveParams& p, double we, double id, double iq, double& vd, double& vq) {
  vd = p.Rs_Ohm * id - we * p.Lq_H * iq;
  vq = p.Rs_Ohm * iq + we * (p.psi_pm_Wb + p.Ld_H * id);
}

// MTPA: the (Id, Iq) of least current for torque t (Newton in Iq; isotropic: Id = 0).
void mtpa(const PmDriveParams& p, double t, double warm_iq, double& id, double& iq, PmOperatingPoint& op) {
  const double dL = p.Lq_H - p.Ld_H;
  const double k = 1.5 * p.pole_pairs;
  iq = t / (k * p.psi_pm_Wb);
  id = 0.0;
  if (std::abs(dL) < 1e-12 * std::max(p.Ld_H, p.Lq_H) || t == 0.0) return;
  const auto id_of = [&](double q) { return (p.psi_pm_Wb - std::sqrt(p.psi_pm_Wb * p.psi_pm_Wb + 4 * dL * dL * q * q)) / (2 * dL); };
  // warm start only if it has the right sign (the torque's)
  double q = warm_iq != 0.0 && (warm_iq > 0) == (t > 0) ? warm_iq : iq;
  bool done = false;
  for (int i = 0; i < kMaxIterations && !done; ++i) {
    ++op.iterations;
    const double d = id_of(q);
    const double root = std::sqrt(p.psi_pm_Wb * p.psi_pm_Wb + 4 * dL * dL * q * q);
    const double dd_dq = -2 * dL * q / root;
    const double f = k * q * (p.psi_pm_Wb - dL * d) - t;
    const double df = k * ((p.psi_pm_Wb - dL * d) - dL * q * dd_dq);
    const double step = f / df;
    q -= step;
    done = std::abs(step) <= 1e-12 * (1.0 + std::abs(q));
  }
  op.converged = op.converged && done;
  iq = q;
  id = id_of(q);
}

// |V|^2 - U^2 along the torque curve Iq(Id) of torque t.
double voltage_excess(const PmDriveParams& p, double we, double t, double id, double U) {
  const double iq = t / (1.5 * p.pole_pairs * (p.psi_pm_Wb - (p.Lq_H - p.Ld_H) * id));
  double vd = 0.0, vq = 0.0;
  voltages(p, we, id, iq, vd, vq);
  return vd * vd + vq * vq - U * U;
}

// Flux weakening for torque t: Id in [lo, hi] with |V| = U (Illinois regula falsi). False if
// the bracket holds no solution (t not reachable).
bool weaken(const PmDriveParams& p, double we, double t, double hi, double U, double& id, PmOperatingPoint& op) {
  double lo = -p.psi_pm_Wb / p.Ld_H;
  double g_lo = voltage_excess(p, we, t, lo, U), g_hi = voltage_excess(p, we, t, hi, U);
  if (g_lo > 0.0) return false;  // even the deepest weakening leaves |V| above the limit
  int side = 0;
  for (int i = 0; i < kMaxIterations; ++i) {
    ++op.iterations;
    id = (lo * g_hi - hi * g_lo) / (g_hi - g_lo);
    const double g = voltage_excess(p, we, t, id, U);
    if (std::abs(g) <= 1e-12 * U * U || std::abs(hi - lo) <= 1e-13 * (1.0 + std::abs(lo))) return true;
    if ((g > 0) == (g_hi > 0)) {
      hi = id;
      g_hi = g;
      if (side == 1) g_lo *= 0.5;  // Illinois: the stale end is halved
      side = 1;
    } else {
      lo = id;
      g_lo = g;
      if (side == -1) g_hi *= 0.5;
      side = -1;
    }
  }
  op.converged = false;
  return true;
}

}  // namespace

void validate(const PmDriveParams& p, const std::string& at, Problems& problems) {
  const std::size_t before = problems.size();
  const auto positive = [&](const char* field, double v) {
    if (!(std::isfinite(v) && v > 0.0)) problems.add(at + "." + field, number_text(v), "must be a finite number > 0");
  };
  if (p.pole_pairs < 1 || p.pole_pairs > 100) {
    problems.add(at + ".pole_pairs", std::to_string(p.pole_pairs), "must be a whole number in [1, 100]");
  }
  positive("psi_pm_Wb", p.psi_pm_Wb);
  positive("Ld_H", p.Ld_H);
  positive("Lq_H", p.Lq_H);
  positive("U_max_rms_V", p.U_max_rms_V);
  positive("I_lim_rms_A", p.I_lim_rms_A);
  if (!(std::isfinite(p.Rs_Ohm) && p.Rs_Ohm >= 0.0)) {
    problems.add(at + ".Rs_Ohm", number_text(p.Rs_Ohm), "must be a finite number >= 0");
  }
  if (!(std::isfinite(p.k_inv_W_per_A) && p.k_inv_W_per_A >= 0.0)) {
    problems.add(at + ".k_inv_W_per_A", number_text(p.k_inv_W_per_A), "must be a finite number >= 0");
  }
  positive("inertia_kgm2", p.inertia_kgm2);
  positive("speed_max_rad_s", p.speed_max_rad_s);
  if (problems.size() == before) {
    // the machine must be able to turn at its top speed without exceeding its current
    const double i0_A = pm_no_load_current_rms_A(p, p.speed_max_rad_s);
    if (i0_A > p.I_lim_rms_A) {
      problems.add(at + ".I_lim_rms_A", number_text(p.I_lim_rms_A),
                   "is below the no-load current flux weakening needs at speed_max_rad_s (" + number_text(i0_A) +
                       " A rms = (psi_pm_Wb - sqrt 2 U_max_rms_V / (pole_pairs speed_max_rad_s)) / Ld_H / sqrt 2)");
    }
  }
}

double pm_no_load_current_rms_A(const PmDriveParams& p, double speed_rad_s) {
  const double we = p.pole_pairs * std::abs(speed_rad_s);
  if (we <= 0.0) return 0.0;
  // at no load (Iq = 0, Rs Id small) |V| = we (psi + Ld Id) = sqrt 2 U_max
  const double id_A = (p.psi_pm_Wb - std::sqrt(2.0) * p.U_max_rms_V / we) / p.Ld_H;
  return std::max(id_A, 0.0) / std::sqrt(2.0);
}

double pm_torque_at_current_limit_Nm(const PmDriveParams& p) {
  const double i = std::sqrt(2.0) * p.I_lim_rms_A;
  const double dL = p.Lq_H - p.Ld_H;
  double id = 0.0;
  if (std::abs(dL) >= 1e-12 * std::max(p.Ld_H, p.Lq_H)) {
    id = (p.psi_pm_Wb - std::sqrt(p.psi_pm_Wb * p.psi_pm_Wb + 8.0 * dL * dL * i * i)) / (4.0 * dL);
  }
  return torque_of(p, id, std::sqrt(std::max(i * i - id * id, 0.0)));
}

double pm_voltage_limit_V(const PmDriveParams& p, double u_dc_V) {
  return std::min(std::max(u_dc_V, 0.0) / std::sqrt(3.0), std::sqrt(2.0) * p.U_max_rms_V);
}

PmCurrents pm_mtpa(const PmDriveParams& p, double torque_Nm) {
  PmOperatingPoint op;
  PmCurrents c;
  mtpa(p, torque_Nm, 0.0, c.id_A, c.iq_A, op);
  c.converged = op.converged;
  c.iterations = op.iterations;
  return c;
}

double pm_voltage_excess_V2(const PmDriveParams& p, const PmCurrents& c, double speed_rad_s, double u_dc_V) {
  double vd = 0.0, vq = 0.0;
  voltages(p, p.pole_pairs * speed_rad_s, c.id_A, c.iq_A, vd, vq);
  const double U = pm_voltage_limit_V(p, u_dc_V);
  return vd * vd + vq * vq - U * U;
}

namespace {

PmOperatingPoint operating_point(const PmDriveParams& p, double torque_ref_Nm, double speed_rad_s, double u_dc_V,
                                 double warm_iq_A, const PmCurrents* mtpa_of_ref) {
  PmOperatingPoint op;
  const double we = p.pole_pairs * speed_rad_s;
  const double U = pm_voltage_limit_V(p, u_dc_V);
  const double k = 1.5 * p.pole_pairs, dL = p.Lq_H - p.Ld_H;
  // The currents for torque t within the voltage: MTPA, or flux weakening when MTPA's |V|
  // is above U. False if t is beyond reach at this speed.
  const auto currents_for = [&](double t, double warm_iq, double& id, double& iq, bool& weakening) {
    if (mtpa_of_ref != nullptr && t == torque_ref_Nm) {  // the caller has it (the same solve)
      id = mtpa_of_ref->id_A;
      iq = mtpa_of_ref->iq_A;
      op.converged = op.converged && mtpa_of_ref->converged;
      op.iterations += mtpa_of_ref->iterations;
    } else {
      mtpa(p, t, warm_iq, id, iq, op);
    }
    double vd = 0.0, vq = 0.0;
    voltages(p, we, id, iq, vd, vq);
    weakening = vd * vd + vq * vq > U * U;
    if (!weakening) return true;
    if (!weaken(p, we, t, id, U, id, op)) return false;
    iq = t / (k * (p.psi_pm_Wb - dL * id));
    return true;
  };
  // The largest |torque| <= |t| (same sign) for which fits(t') holds, bisection on the torque;
  // fits(0) is assumed. Returns 0 if nothing but 0 fits.
  const auto largest_torque = [&](double t, auto fits) {
    double reach = 0.0, miss = t;
    for (int i = 0; i < kMaxIterations; ++i) {
      ++op.iterations;
      const double mid = 0.5 * (reach + miss);
      (fits(mid) ? reach : miss) = mid;
      if (std::abs(miss - reach) <= 1e-10 * (1.0 + std::abs(t))) break;
    }
    return reach;
  };

  double t = torque_ref_Nm, id = 0.0, iq = 0.0;
  if (!currents_for(t, warm_iq_A, id, iq, op.weakening)) {
    // not reachable: the largest torque that is (flux weakening has priority over torque)
    op.voltage_limited = true;
    t = largest_torque(t, [&](double tt) {
      double a = 0.0, b = 0.0;
      bool w = false;
      return currents_for(tt, 0.0, a, b, w);
    });
    currents_for(t, 0.0, id, iq, op.weakening);
  }
  // Current limit. The voltage keeps its priority: the torque gives way, to the largest one
  // whose MTPA or weakening currents fit (MTPA at the limit below base speed, the corner of
  // the current circle and the voltage ellipse above it). Not §9.1's "keep Id, cut Iq":
  // that keeps the weakening Id of the torque that does not fit, deeper than the smaller
  // torque needs; measured on SmaAllSpeeds it drops the torque from 230 to 99 N m between
  // 100 and 120 rad/s and back to 220 N m at 130 rad/s.
  const double i_max2 = 2.0 * p.I_lim_rms_A * p.I_lim_rms_A;
  if (id * id + iq * iq > i_max2 && t != 0.0) {
    // On the current circle Id = -I sin(b), Iq = +-I cos(b): MTPA at the limit (b_m) if its
    // voltage fits, else the corner |V(b)| = U on (b_m, pi/2], Illinois in b (the voltage
    // falls as b grows); pi/2 (all current in Id) still too high: overload, below.
    const double i_pk = std::sqrt(i_max2), sign = t > 0.0 ? 1.0 : -1.0;
    double id_m = 0.0;
    if (std::abs(dL) >= 1e-12 * std::max(p.Ld_H, p.Lq_H)) {
      id_m = (p.psi_pm_Wb - std::sqrt(p.psi_pm_Wb * p.psi_pm_Wb + 8.0 * dL * dL * i_max2)) / (4.0 * dL);
    }
    const auto excess = [&](double b) {
      double vd = 0.0, vq = 0.0;
      voltages(p, we, -i_pk * std::sin(b), sign * i_pk * std::cos(b), vd, vq);
      return vd * vd + vq * vq - U * U;
    };
    double lo = std::asin(std::clamp(-id_m / i_pk, 0.0, 1.0)), hi = 0.5 * std::numbers::pi;
    double g_lo = excess(lo), g_hi = excess(hi), b = lo;
    bool fits = g_lo <= 0.0;
    if (!fits && g_hi <= 0.0) {
      fits = true;
      int side = 0;
      for (int i = 0; i < kMaxIterations; ++i) {
        ++op.iterations;
        b = (lo * g_hi - hi * g_lo) / (g_hi - g_lo);
        const double g = excess(b);
        if (std::abs(g) <= 1e-12 * U * U || hi - lo <= 1e-14) break;
        if (g > 0.0) {
          lo = b;
          g_lo = g;
          if (side == -1) g_hi *= 0.5;  // Illinois: the stale end is halved
          side = -1;
        } else {
          hi = b;
          g_hi = g;
          if (side == 1) g_lo *= 0.5;
          side = 1;
        }
        if (i + 1 == kMaxIterations) op.converged = false;
      }
    }
    if (fits) {
      op.current_limited = true;
      op.weakening = b > std::asin(std::clamp(-id_m / i_pk, 0.0, 1.0));
      id = -i_pk * std::sin(b);
      iq = sign * i_pk * std::cos(b);
    }
  }
  // even no load needs more current than the limit to hold the voltage: beyond the
  // machine's speed (validate() checks speed_max_rad_s); the currents are kept and flagged
  op.overload = id * id + iq * iq > i_max2 * (1.0 + 1e-9);
  double vd = 0.0, vq = 0.0;
  voltages(p, we, id, iq, vd, vq);
  op.id_A = id;
  op.iq_A = iq;
  op.vd_V = vd;
  op.vq_V = vq;
  op.torque_Nm = torque_of(p, id, iq);
  const double i2 = id * id + iq * iq;
  op.p_dc_W = op.torque_Nm * speed_rad_s + 1.5 * p.Rs_Ohm * i2 + p.k_inv_W_per_A * std::sqrt(i2 / 2.0);
  return op;
}

}  // namespace

PmOperatingPoint pm_operating_point(const PmDriveParams& p, double torque_ref_Nm, double speed_rad_s, double u_dc_V,
                                    double warm_iq_A) {
  return operating_point(p, torque_ref_Nm, speed_rad_s, u_dc_V, warm_iq_A, nullptr);
}

PmOperatingPoint pm_operating_point(const PmDriveParams& p, double torque_ref_Nm, double speed_rad_s, double u_dc_V,
                                    const PmCurrents& mtpa_of_ref) {
  return operating_point(p, torque_ref_Nm, speed_rad_s, u_dc_V, 0.0, &mtpa_of_ref);
}

}  // namespace ehpt::plant
