// SPDX-License-Identifier: BSD-3-Clause
// PMDrive's operating point (plant/pm_drive.hpp, MODELS.md §9.1, P15 eqs. 1-2): checked
// against the equations themselves, not against the code's own numbers.
#include "plant/pm_drive.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace ehpt::plant {
namespace {

// the MSL default machine (isotropic) and the anisotropic SmaAllSpeeds variant, u_DC = 300 V
PmDriveParams isotropic() { return PmDriveParams{}; }
PmDriveParams anisotropic() {
  PmDriveParams p;
  p.Ld_H = 2e-3;
  p.Lq_H = 4e-3;
  return p;
}

double amplitude(const PmOperatingPoint& op) { return std::hypot(op.id_A, op.iq_A); }
double voltage(const PmOperatingPoint& op) { return std::hypot(op.vd_V, op.vq_V); }

TEST(PmDrive, VoltageLimitIsTheSmallerOfDcAndMachine) {
  EXPECT_NEAR(pm_voltage_limit_V(isotropic(), 200.0), 200.0 / std::sqrt(3.0), 1e-12);  // 115.5 V (tutorial)
  EXPECT_NEAR(pm_voltage_limit_V(isotropic(), 300.0), 100.0 * std::sqrt(2.0), 1e-12);
}

TEST(PmDrive, IsotropicBelowBaseSpeedIsPureQAxisCurrent) {
  const PmDriveParams p = isotropic();
  const PmOperatingPoint op = pm_operating_point(p, 100.0, 50.0, 300.0);
  EXPECT_EQ(op.id_A, 0.0);
  EXPECT_NEAR(op.iq_A, 100.0 / (1.5 * 2 * 0.5055), 1e-9);
  EXPECT_NEAR(op.torque_Nm, 100.0, 1e-9);
  EXPECT_FALSE(op.weakening);
  EXPECT_TRUE(op.converged);
}

TEST(PmDrive, AnisotropicMtpaMeetsEquationOneAndTheTorque) {
  const PmDriveParams p = anisotropic();
  for (double t : {10.0, 60.0, 150.0, -80.0}) {
    const PmOperatingPoint op = pm_operating_point(p, t, 20.0, 300.0);
    ASSERT_FALSE(op.weakening) << t;
    EXPECT_NEAR(op.torque_Nm, t, 1e-9 * std::abs(t)) << t;
    // P15 eq. 1 with Id = -I sin g, Iq = I cos g
    const double I = amplitude(op), g = std::atan2(-op.id_A, std::abs(op.iq_A));
    const double residual = -p.psi_pm_Wb * std::sin(g) + (p.Lq_H - p.Ld_H) * I * std::cos(2 * g);
    EXPECT_NEAR(residual, 0.0, 1e-9) << t;
    EXPECT_LT(op.id_A, 0.0) << t;  // reluctance torque: negative Id helps
  }
}

TEST(PmDrive, MtpaIsTheLeastCurrentForTheTorque) {
  const PmDriveParams p = anisotropic();
  const double t = 120.0;
  const PmOperatingPoint op = pm_operating_point(p, t, 20.0, 300.0);
  // scan the gamma angle: for each, the current amplitude that gives t (quadratic in I)
  double best = 1e300;
  for (int k = 0; k < 20000; ++k) {
    const double g = 1.5 * k / 20000.0;  // 0 .. 86 degrees
    const double a = 0.5 * (p.Lq_H - p.Ld_H) * std::sin(2 * g), b = p.psi_pm_Wb * std::cos(g);
    const double c = -t / (1.5 * p.pole_pairs);
    const double I = a > 1e-15 ? (-b + std::sqrt(b * b - 4 * a * c)) / (2 * a) : -c / b;
    best = std::min(best, I);
  }
  EXPECT_LE(amplitude(op), best + 1e-9);
  EXPECT_GT(amplitude(op), best - 1e-3);  // and the scan finds it too
}

// The check: gamma > 0 when Lq > Ld, equal to a brute-force maximisation of torque per
// ampere within 1e-6 rad. At the drive's current amplitude I, scan gamma for the largest
// T(gamma) = 1.5 pp (psi I cos g + (Lq - Ld) I^2 sin 2g / 2), then narrow the best cell by
// ternary search (T is unimodal there) to 1e-12 rad.
TEST(PmDrive, MtpaGammaIsTheBruteForceMaximumOfTorquePerAmpere) {
  for (const PmDriveParams& p : {anisotropic(), isotropic()}) {
    for (double t : {20.0, 120.0, 200.0}) {
      const PmOperatingPoint op = pm_operating_point(p, t, 20.0, 300.0);
      ASSERT_FALSE(op.current_limited || op.weakening) << t;
      const double I = amplitude(op), gamma = std::atan2(-op.id_A, op.iq_A);
      const auto torque = [&](double g) {
        return 1.5 * p.pole_pairs * (p.psi_pm_Wb * I * std::cos(g) + 0.5 * (p.Lq_H - p.Ld_H) * I * I * std::sin(2 * g));
      };
      int best = 0;
      constexpr int kCells = 100000;
      const double cell = 0.5 * M_PI / kCells;
      for (int k = 1; k <= kCells; ++k) {
        if (torque(k * cell) > torque(best * cell)) best = k;
      }
      double lo = std::max(0.0, (best - 1) * cell), hi = std::min(0.5 * M_PI, (best + 1) * cell);
      while (hi - lo > 1e-12) {
        const double a = lo + (hi - lo) / 3, b = hi - (hi - lo) / 3;
        (torque(a) < torque(b) ? lo : hi) = torque(a) < torque(b) ? a : b;
      }
      EXPECT_NEAR(gamma, 0.5 * (lo + hi), 1e-6) << t;
      if (p.Lq_H > p.Ld_H) {
        EXPECT_GT(gamma, 0.01) << t;  // reluctance torque pays for a negative Id
      } else {
        EXPECT_EQ(gamma, 0.0) << t;
      }
    }
  }
}

TEST(PmDrive, FluxWeakeningHoldsTheVoltageAtItsLimitWithTheTorque) {
  for (const PmDriveParams& p : {isotropic(), anisotropic()}) {
    const double U = pm_voltage_limit_V(p, 300.0);
    // the speed at which the MTPA point reaches U for 50 N m, and well above it
    const PmOperatingPoint low = pm_operating_point(p, 50.0, 60.0, 300.0);
    ASSERT_FALSE(low.weakening);
    const PmOperatingPoint op = pm_operating_point(p, 50.0, 160.0, 300.0);
    ASSERT_TRUE(op.weakening);
    EXPECT_FALSE(op.voltage_limited);
    EXPECT_NEAR(voltage(op), U, 1e-9 * U);
    EXPECT_NEAR(op.torque_Nm, 50.0, 1e-9 * 50.0);
    EXPECT_LT(op.id_A, low.id_A - 1.0);  // weakened: more negative d-axis current
    // the full-flux (MTPA) point at this speed would need more than the limit: why it is needed
    const double iq = 50.0 / (1.5 * p.pole_pairs * p.psi_pm_Wb);
    const double we = p.pole_pairs * 160.0;
    EXPECT_GT(std::hypot(-we * p.Lq_H * iq, we * p.psi_pm_Wb), U);
  }
}

TEST(PmDrive, TheSwitchToFluxWeakeningIsContinuous) {
  const PmDriveParams p = anisotropic();
  // find the switch speed by bisection on the flag, then compare both sides
  double lo = 10.0, hi = 400.0;
  for (int i = 0; i < 80; ++i) {
    const double mid = 0.5 * (lo + hi);
    (pm_operating_point(p, 80.0, mid, 300.0).weakening ? hi : lo) = mid;
  }
  const PmOperatingPoint a = pm_operating_point(p, 80.0, lo, 300.0), b = pm_operating_point(p, 80.0, hi, 300.0);
  EXPECT_FALSE(a.weakening);
  EXPECT_TRUE(b.weakening);
  EXPECT_NEAR(a.id_A, b.id_A, 1e-4);
  EXPECT_NEAR(a.iq_A, b.iq_A, 1e-4);
}

TEST(PmDrive, RegenerationMirrorsMotoringAtStandstill) {
  const PmDriveParams p = anisotropic();
  const PmOperatingPoint m = pm_operating_point(p, 90.0, 0.0, 300.0), g = pm_operating_point(p, -90.0, 0.0, 300.0);
  EXPECT_NEAR(g.id_A, m.id_A, 1e-9);
  EXPECT_NEAR(g.iq_A, -m.iq_A, 1e-9);
  EXPECT_NEAR(g.torque_Nm, -90.0, 1e-9);
}

// The largest torque on the current circle |I| = I_max whose voltage fits, by brute force.
double best_torque_on_the_circle(const PmDriveParams& p, double w, double U) {
  const double i_peak = std::sqrt(2.0) * p.I_lim_rms_A;
  double best_Nm = 0.0;
  for (int k = 0; k <= 200000; ++k) {
    const double beta = 0.5 * M_PI * k / 200000.0;  // Id = -I sin(beta), Iq = I cos(beta)
    const double id = -i_peak * std::sin(beta), iq = i_peak * std::cos(beta);
    const double vd = p.Rs_Ohm * id - p.pole_pairs * w * p.Lq_H * iq;
    const double vq = p.Rs_Ohm * iq + p.pole_pairs * w * (p.psi_pm_Wb + p.Ld_H * id);
    if (std::hypot(vd, vq) <= U) {
      best_Nm = std::max(best_Nm, 1.5 * p.pole_pairs * (p.psi_pm_Wb * iq + (p.Ld_H - p.Lq_H) * id * iq));
    }
  }
  return best_Nm;
}

// Below base speed the current limit gives MTPA at the limit; in flux weakening the corner
// of the current circle and the voltage ellipse. Either way: the largest torque with
// |I| <= I_max and |V| <= U_lim (brute force along the circle), the voltage never above it.
TEST(PmDrive, TheCurrentLimitGivesTheLargestTorqueWithinCurrentAndVoltage) {
  const PmDriveParams p = anisotropic();
  const double U = pm_voltage_limit_V(p, 300.0), i_peak = std::sqrt(2.0) * p.I_lim_rms_A;
  for (double w : {10.0, 120.0, 300.0}) {  // MTPA; weakening; deep weakening (Id of 250 N m alone > I_max)
    const double t = w < 50 ? 400.0 : 250.0;
    const PmOperatingPoint op = pm_operating_point(p, t, w, 300.0);
    EXPECT_TRUE(op.current_limited) << w;
    EXPECT_FALSE(op.overload) << w;
    EXPECT_EQ(op.weakening, w > 50) << w;
    EXPECT_NEAR(amplitude(op), i_peak, 1e-6 * i_peak) << w;
    EXPECT_LE(amplitude(op), i_peak * (1 + 1e-12)) << w;
    EXPECT_LE(voltage(op), U * (1 + 1e-9)) << w;
    const double best_Nm = best_torque_on_the_circle(p, w, U);
    ASSERT_GT(best_Nm, 10.0) << w;
    EXPECT_NEAR(op.torque_Nm, best_Nm, 1e-4 * best_Nm) << w;
  }
  // below base speed that is MTPA at the limit, pm_torque_at_current_limit_Nm (closed form)
  EXPECT_NEAR(pm_operating_point(p, 400.0, 10.0, 300.0).torque_Nm, pm_torque_at_current_limit_Nm(p), 1e-6);
}

TEST(PmDrive, AnUnreachableTorqueGivesTheLargestReachableOneWithinTheVoltage) {
  PmDriveParams p = isotropic();
  p.I_lim_rms_A = 1e4;  // only the voltage limits here
  const double U = pm_voltage_limit_V(p, 300.0);
  const PmOperatingPoint op = pm_operating_point(p, 400.0, 300.0, 300.0);
  EXPECT_TRUE(op.voltage_limited);
  EXPECT_LT(op.torque_Nm, 400.0);
  EXPECT_GT(op.torque_Nm, 0.0);
  EXPECT_NEAR(voltage(op), U, 1e-6 * U);  // at the edge: a little more torque would not fit
  const PmOperatingPoint more = pm_operating_point(p, op.torque_Nm * 1.01, 300.0, 300.0);
  EXPECT_TRUE(more.voltage_limited);
}

TEST(PmDrive, PowersBalance) {
  const PmDriveParams p = anisotropic();
  for (double w : {30.0, 160.0}) {
    const PmOperatingPoint op = pm_operating_point(p, 70.0, w, 300.0);
    const double i2 = op.id_A * op.id_A + op.iq_A * op.iq_A;
    // the machine's terminal power = shaft power + copper losses (dq, amplitude-invariant)
    const double p_ac = 1.5 * (op.vd_V * op.id_A + op.vq_V * op.iq_A);
    EXPECT_NEAR(p_ac, op.torque_Nm * w + 1.5 * p.Rs_Ohm * i2, 1e-9 * std::abs(p_ac));
    EXPECT_NEAR(op.p_dc_W, p_ac + p.k_inv_W_per_A * std::sqrt(i2 / 2), 1e-9 * std::abs(p_ac));
  }
}

// SmaAllSpeeds (MODELS.md §11.6): speed imposed 0 -> 317 rad/s, 300 N m asked, I_lim 100 A
// rms, U_max 100 V rms, u_DC 300 V. Expected: the current held at 100 A rms; the voltage rises
// linearly, then clamps at 100 V rms; the torque stays below 300 N m; the active power rises,
// peaks and falls; the reactive power crosses zero at the active-power peak.
TEST(PmDrive, SmaAllSpeedsAsTheLibraryTestShows) {
  const PmDriveParams p = anisotropic();
  const double i_peak = std::sqrt(2.0) * 100.0, u_peak = std::sqrt(2.0) * 100.0;
  double p_max = -1.0, w_at_p_max = 0.0, w_q_zero = -1.0, q_before = 0.0, w_clamp = -1.0;
  double v20 = 0.0, v90 = 0.0;
  for (int k = 1; k <= 3170; ++k) {
    const double w = 0.1 * k;
    const PmOperatingPoint op = pm_operating_point(p, 300.0, w, 300.0);
    ASSERT_TRUE(op.converged) << w;
    EXPECT_NEAR(amplitude(op), i_peak, 1e-6 * i_peak) << w;  // current held at 100 A rms
    EXPECT_LT(op.torque_Nm, 300.0) << w;
    EXPECT_LE(voltage(op), u_peak * (1 + 1e-12)) << w;
    const double active_W = 1.5 * (op.vd_V * op.id_A + op.vq_V * op.iq_A);
    const double reactive_var = 1.5 * (op.vq_V * op.id_A - op.vd_V * op.iq_A);
    if (active_W > p_max) {
      p_max = active_W;
      w_at_p_max = w;
    }
    if (k > 1 && w_q_zero < 0 && (reactive_var > 0) != (q_before > 0)) w_q_zero = w;
    q_before = reactive_var;
    if (w_clamp < 0 && voltage(op) > u_peak * (1 - 1e-9)) w_clamp = w;
    if (k == 200) v20 = voltage(op);
    if (k == 900) v90 = voltage(op);
    if (k > 900 && w_clamp < 0) {
      // below the clamp the currents are fixed, the voltage rises on a straight line (the
      // Rs I part is 6 V of 141, at right angles to most of the rest)
      EXPECT_NEAR(voltage(op), v20 + (v90 - v20) * (w - 20.0) / 70.0, 0.01 * u_peak) << w;
    }
  }
  // the clamp: base speed of the 100 A rms MTPA point, well inside the sweep
  EXPECT_GT(w_clamp, 50.0);
  EXPECT_LT(w_clamp, 150.0);
  // the active power peaks inside the sweep, then falls
  EXPECT_GT(w_at_p_max, w_clamp);
  EXPECT_LT(w_at_p_max, 310.0);
  const PmOperatingPoint end = pm_operating_point(p, 300.0, 317.0, 300.0);
  EXPECT_LT(1.5 * (end.vd_V * end.id_A + end.vq_V * end.iq_A), 0.95 * p_max);
  // the reactive power crosses zero where the active power peaks (unity power factor: at
  // constant |V| and |I| the active power 1.5 |V||I| cos(phi) is largest where phi = 0)
  ASSERT_GT(w_q_zero, 0.0);
  EXPECT_NEAR(w_q_zero, w_at_p_max, 0.03 * w_at_p_max);
}

TEST(PmDrive, ACurrentLimitBelowTheNoLoadCurrentAtTopSpeedIsNamed) {
  PmDriveParams p = anisotropic();
  // at 317 rad/s, holding 141 V needs Id = (0.5055 - 141.42 / 634) / 2e-3 = 141.2 A peak
  EXPECT_NEAR(pm_no_load_current_rms_A(p, 317.0), (0.5055 - std::sqrt(2.0) * 100.0 / 634.0) / 2e-3 / std::sqrt(2.0), 1e-9);
  EXPECT_EQ(pm_no_load_current_rms_A(p, 100.0), 0.0);  // below base speed: none
  // above the rated speed holding the voltage needs more than the limit even at no load:
  // flagged as overload (the currents are what the voltage needs)
  const PmOperatingPoint beyond = pm_operating_point(p, 50.0, 400.0, 300.0);
  EXPECT_TRUE(beyond.overload);
  EXPECT_GE(std::abs(beyond.id_A), std::sqrt(2.0) * pm_no_load_current_rms_A(p, 400.0));  // more with torque
  EXPECT_FALSE(pm_operating_point(p, 50.0, 317.0, 300.0).overload);
  Problems ok;
  validate(p, "drive", ok);
  EXPECT_TRUE(ok.empty());
  p.I_lim_rms_A = 90.0;
  Problems problems;
  validate(p, "drive", problems);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems.list()[0].field, "drive.I_lim_rms_A");
  EXPECT_EQ(problems.list()[0].value, "90");
}

// A vehicle solves MTPA once per command and hands it in (pm_mtpa): the same operating point,
// bit for bit, as the solve from scratch, over MTPA, flux weakening, the voltage limit, the
// current limit and regeneration.
TEST(PmDrive, GivenMtpaCurrentsGiveTheSameOperatingPointBitForBit) {
  const PmDriveParams p = anisotropic();
  int compared = 0;
  for (double t = -320.0; t <= 320.0; t += 7.3) {
    const PmCurrents c = pm_mtpa(p, t);
    for (double w = 0.0; w <= 330.0; w += 11.0) {
      const PmOperatingPoint a = pm_operating_point(p, t, w, 300.0), b = pm_operating_point(p, t, w, 300.0, c);
      ASSERT_EQ(a.id_A, b.id_A) << t << " " << w;
      ASSERT_EQ(a.iq_A, b.iq_A) << t << " " << w;
      ASSERT_EQ(a.torque_Nm, b.torque_Nm) << t << " " << w;
      ASSERT_EQ(a.p_dc_W, b.p_dc_W) << t << " " << w;
      ASSERT_EQ(a.weakening, b.weakening);
      ASSERT_EQ(a.current_limited, b.current_limited);
      ++compared;
    }
  }
  EXPECT_GT(compared, 2500);
}

TEST(PmDrive, ImpossibleMachineDataIsNamed) {
  PmDriveParams p;
  p.Ld_H = 0.0;
  p.psi_pm_Wb = -1.0;
  p.pole_pairs = 0;
  Problems problems;
  validate(p, "drive", problems);
  ASSERT_EQ(problems.size(), 3u);
}

}  // namespace
}  // namespace ehpt::plant
