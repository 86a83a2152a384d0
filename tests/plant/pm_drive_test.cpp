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

TEST(PmDrive, TheCurrentLimitCutsIqAndKeepsIdForFluxWeakening) {
  const PmDriveParams p = anisotropic();
  PmDriveParams unlimited = p;
  unlimited.I_lim_rms_A = 1e6;
  for (double w : {10.0, 120.0}) {  // MTPA, and flux weakening
    const double t = w < 50 ? 400.0 : 300.0;  // beyond the 141 A peak either way (187 A at 120 rad/s)
    const PmOperatingPoint free = pm_operating_point(unlimited, t, w, 300.0);
    const PmOperatingPoint op = pm_operating_point(p, t, w, 300.0);
    ASSERT_FALSE(free.voltage_limited) << w;
    EXPECT_EQ(free.weakening, w > 50) << w;
    EXPECT_TRUE(op.current_limited) << w;
    EXPECT_NEAR(amplitude(op), std::sqrt(2.0) * p.I_lim_rms_A, 1e-9) << w;
    EXPECT_EQ(op.id_A, free.id_A) << w;  // priority to flux weakening: Id as it was
    EXPECT_LT(op.torque_Nm, t) << w;
    EXPECT_GT(op.torque_Nm, 0.0) << w;  // (99 N m at 120 rad/s: the weakening Id for 300 N m stays)
    EXPECT_LE(voltage(op), pm_voltage_limit_V(p, 300.0) * (1 + 1e-9)) << w;
  }
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
