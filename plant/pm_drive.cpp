#include "plant/pm_drive.hpp"

#include <algorithm>
#include <cmath>


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
}

double pm_voltage_limit_V(const PmDriveParams& p, double u_dc_V) {
  return std::min(std::max(u_dc_V, 0.0) / std::sqrt(3.0), std::sqrt(2.0) * p.U_max_rms_V);
}

PmOperatingPoint pm_operating_point(const PmDriveParams& p, double torque_ref_Nm, double speed_rad_s, double u_dc_V,
                                    double warm_iq_A) {
  PmOperatingPoint op;
  const double we = p.pole_pairs * speed_rad_s;
  const double U = pm_voltage_limit_V(p, u_dc_V);
  double id = 0.0, iq = 0.0;
  mtpa(p, torque_ref_Nm, warm_iq_A, id, iq, op);
  double vd = 0.0, vq = 0.0;
  voltages(p, we, id, iq, vd, vq);
  double t = torque_ref_Nm;
  if (vd * vd + vq * vq > U * U) {
    op.weakening = true;
    const double id_mtpa = id;
    double w_id = id;
    if (!weaken(p, we, t, id_mtpa, U, w_id, op)) {
      // not reachable: the largest |torque| that is (bisection on the torque, same sign)
      op.voltage_limited = true;
      double reach = 0.0, miss = t;
      for (int i = 0; i < kMaxIterations; ++i) {
        ++op.iterations;
        const double mid = 0.5 * (reach + miss);
        double m_id = 0.0, m_iq = 0.0;
        mtpa(p, mid, 0.0, m_id, m_iq, op);
        double a = 0.0, b = 0.0;
        voltages(p, we, m_id, m_iq, a, b);
        const bool ok = a * a + b * b <= U * U || voltage_excess(p, we, mid, -p.psi_pm_Wb / p.Ld_H, U) <= 0.0;
        (ok ? reach : miss) = mid;
        if (std::abs(miss - reach) <= 1e-9 * (1.0 + std::abs(t))) break;
      }
      t = reach;
      mtpa(p, t, 0.0, id, iq, op);
      voltages(p, we, id, iq, vd, vq);
      w_id = id;
      if (vd * vd + vq * vq > U * U) weaken(p, we, t, id, U, w_id, op);
    }
    id = w_id;
    iq = t / (1.5 * p.pole_pairs * (p.psi_pm_Wb - (p.Lq_H - p.Ld_H) * id));
  }
  // current limit, priority to flux weakening: Id kept, |Iq| cut
  const double i_max2 = 2.0 * p.I_lim_rms_A * p.I_lim_rms_A;
  if (id * id + iq * iq > i_max2) {
    if (id * id >= i_max2) {
      op.overload = true;
    } else {
      op.current_limited = true;
      iq = std::copysign(std::sqrt(i_max2 - id * id), iq);
    }
  }
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

}  // namespace ehpt::plant
