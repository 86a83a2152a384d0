// SPDX-License-Identifier: BSD-3-Clause
// AMDrive's operating point (plant/am_drive.hpp, MODELS.md §9.2): checked against the
// textbook closed forms of the equivalent circuit and the literal phasor equations of §9.2,
// written out here independently of the code's flux form.
#include "plant/am_drive.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

namespace ehpt::plant {
namespace {

using C = std::complex<double>;

AmDriveParams msl() { return AmDriveParams{}; }  // the MSL default machine
AmDriveParams unlimited_current() {
  AmDriveParams p;
  p.I_max_rms_A = 1e6;
  return p;
}
double slip_limit(const AmDriveParams& p) { return p.R2_Ohm / (p.L1_H + p.L2_H); }
// the U/f rule on E, written out
double emf(const AmDriveParams& p, double w_e) {
  return std::min(p.U_base_rms_V / p.w_e_base_rad_s * std::abs(w_e), p.U_base_rms_V);
}
double relative(double a, double b) { return std::abs(a - b) / std::max(std::abs(b), 1e-300); }

// Textbook torque (any machines text, "Thevenin form"): the rotor sees the Thevenin
// equivalent of E behind jX1 with jXm across (R1 is outside: E is behind it),
//   T = 3 pp / w_e |V_th|^2 (R2/s) / ((R_th + R2/s)^2 + (X_th + X2)^2)
double textbook_torque(const AmDriveParams& p, double dwe, double speed) {
  const double w_e = p.pole_pairs * speed + dwe;
  const double x1 = w_e * p.L1_H, x2 = w_e * p.L2_H, xm = w_e * p.Lm_H;
  const C v_th = emf(p, w_e) * C(0, xm) / C(0, x1 + xm);
  const C z_th = C(0, x1) * C(0, xm) / C(0, x1 + xm);
  const double r2_s = p.R2_Ohm * w_e / dwe;
  const double a = z_th.real() + r2_s, b = z_th.imag() + x2;
  return 3.0 * p.pole_pairs / w_e * std::norm(v_th) * r2_s / (a * a + b * b);
}

// §9.2's equations literally (impedances at w_e, E the real reference): needs w_e, dWe != 0
struct Phasors {
  C i1, i2, u1;
};
Phasors literal_circuit(const AmDriveParams& p, double dwe, double speed) {
  const double w_e = p.pole_pairs * speed + dwe;
  const double e = emf(p, w_e);
  const C z2(p.R2_Ohm * w_e / dwe, w_e * p.L2_H);
  const C zm(0, w_e * p.Lm_H);
  const C zp = zm * z2 / (zm + z2);
  Phasors ph;
  ph.i1 = e / (C(0, w_e * p.L1_H) + zp);
  ph.i2 = ph.i1 * zm / (zm + z2);
  ph.u1 = e + p.R1_Ohm * ph.i1;
  return ph;
}

std::vector<double> slip_sweep(const AmDriveParams& p) {
  std::vector<double> s;
  for (int k = -20; k <= 20; ++k) {
    if (k != 0) s.push_back(slip_limit(p) * k / 20.0);
  }
  s.push_back(0.01);  // tiny slips, both signs (the guarded rotor branch)
  s.push_back(-1e-4);
  return s;
}

// ---------------------------------------------------------------------------------------------
// QSAsma

TEST(AmDrive, TorqueSlipCurveMatchesTheTheveninClosedForm) {
  const AmDriveParams p = msl();
  // below base, at base, in weakening (w_e up to 800 rad/s); negative slips: generating
  for (double speed : {5.0, 40.0, 130.0, 157.0, 200.0, 400.0}) {
    for (double dwe : slip_sweep(p)) {
      const AmOperatingPoint op = am_from_slip(p, dwe, speed);
      const double t = textbook_torque(p, dwe, speed);
      EXPECT_LT(relative(op.torque_Nm, t), 1e-9) << speed << " " << dwe << ": " << op.torque_Nm << " vs " << t;
      EXPECT_EQ(op.torque_Nm > 0, dwe > 0) << speed << " " << dwe;
    }
  }
  // zero slip: no rotor current, no torque (and no division by zero)
  const AmOperatingPoint idle = am_from_slip(p, 0.0, 100.0);
  EXPECT_EQ(idle.torque_Nm, 0.0);
  EXPECT_EQ(idle.i2_rms_A, 0.0);
  // below base the flux is constant: the torque depends on the slip alone (U/f)
  for (double speed : {0.0, 30.0, 120.0}) {
    EXPECT_LT(relative(am_from_slip(p, 25.0, speed).torque_Nm, am_from_slip(p, 25.0, 60.0).torque_Nm), 1e-12);
  }
}

TEST(AmDrive, SimplifiedCircuitAndItsPeakAtTheSlipLimit) {
  AmDriveParams p = msl();
  p.Lm_H = 1e9;  // Lm -> inf: L1 and L2 in series (§9.2)
  const double l = p.L1_H + p.L2_H, lim = slip_limit(p);
  for (double speed : {20.0, 100.0, 300.0}) {
    for (double dwe : slip_sweep(p)) {
      const double w_e = p.pole_pairs * speed + dwe, psi = emf(p, w_e) / w_e;
      const double t = 3.0 * p.pole_pairs * psi * psi * p.R2_Ohm * dwe / (p.R2_Ohm * p.R2_Ohm + dwe * dwe * l * l);
      EXPECT_LT(relative(am_from_slip(p, dwe, speed).torque_Nm, t), 1e-9) << speed << " " << dwe;
    }
  }
  // the peak 3 pp Psi^2 / (2 (L1 + L2)) is reached at the limiter, and less below it
  const double speed = 50.0, psi = p.U_base_rms_V / p.w_e_base_rad_s;
  const double peak = 3.0 * p.pole_pairs * psi * psi / (2.0 * l);
  EXPECT_LT(relative(am_from_slip(p, lim, speed).torque_Nm, peak), 1e-9);
  EXPECT_LT(am_from_slip(p, 0.95 * lim, speed).torque_Nm, peak * (1 - 1e-4));
  EXPECT_LT(relative(am_from_slip(p, -lim, speed).torque_Nm, -peak), 1e-9);
}

TEST(AmDrive, SlipLimiterCutsToR2OverL1PlusL2KeepingTheSign) {
  const AmDriveParams p = msl();
  const double lim = slip_limit(p);  // 61.73 rad/s
  const AmOperatingPoint up = am_from_slip(p, 2.0 * lim, 80.0);
  EXPECT_EQ(up.slip_rad_s, lim);
  EXPECT_TRUE(up.slip_limited);
  EXPECT_EQ(up.torque_Nm, am_from_slip(p, lim, 80.0).torque_Nm);
  EXPECT_EQ(up.w_e_rad_s, p.pole_pairs * 80.0 + lim);
  const AmOperatingPoint down = am_from_slip(p, -3.0 * lim, 80.0);
  EXPECT_EQ(down.slip_rad_s, -lim);
  EXPECT_TRUE(down.slip_limited);
  EXPECT_LT(down.torque_Nm, 0.0);
  const AmOperatingPoint inside = am_from_slip(p, 0.5 * lim, 80.0);
  EXPECT_EQ(inside.slip_rad_s, 0.5 * lim);
  EXPECT_FALSE(inside.slip_limited);
  EXPECT_FALSE(am_from_slip(p, lim, 80.0).slip_limited);  // at the bound: nothing cut
  EXPECT_EQ(am_slip_limit_rad_s(p), lim);
  // the current limit's own entry (a vehicle feeding dWe as P15 does) clamps to the limiter
  // first: where the current allows it, a slip beyond the limiter comes back at the limiter
  AmDriveParams roomy = p;
  roomy.I_max_rms_A = 1e6;
  bool limited = true;
  EXPECT_EQ(am_slip_within_current(roomy, 3.0 * lim, 80.0, limited), lim);
  EXPECT_FALSE(limited);
  EXPECT_EQ(am_slip_within_current(roomy, -1.5 * lim, 80.0, limited), -lim);
}

TEST(AmDrive, PowersBalance) {
  const AmDriveParams p = msl();
  struct Point {
    double dwe, speed;
  };
  // motoring, generating, standstill, weakening both ways, reverse rotation, plugging (w_e < 0
  // while the slip is positive) and a point where w_e is tiny
  for (const Point& pt : std::vector<Point>{{20, 50},
                                             {-20, 50},
                                             {40, 0},
                                             {-40, 0},
                                             {30, 300},
                                             {-30, 300},
                                             {-25, -80},
                                             {25, -80},
                                             {50, -20},
                                             {10, -4.9}}) {
    const AmOperatingPoint op = am_from_slip(p, pt.dwe, pt.speed);
    const Phasors ph = literal_circuit(p, pt.dwe, pt.speed);
    const double p_term = 3.0 * std::real(ph.u1 * std::conj(ph.i1));
    const double i1 = std::abs(ph.i1), i2 = std::abs(ph.i2);
    const double copper = 3.0 * (p.R1_Ohm * i1 * i1 + p.R2_Ohm * i2 * i2);
    const double scale = std::abs(p_term) + copper;
    const std::string at = std::to_string(pt.dwe) + " " + std::to_string(pt.speed);
    EXPECT_LT(relative(op.i1_rms_A, i1), 1e-9) << at;
    EXPECT_LT(relative(op.i2_rms_A, i2), 1e-9) << at;
    EXPECT_LT(relative(op.u1_rms_V, std::abs(ph.u1)), 1e-9) << at;
    // P_abs (mechanical + copper, as P15 states it) is the terminal power 3 Re(U1 conj I1)
    EXPECT_NEAR(op.power_abs_W, p_term, 1e-9 * scale) << at;
    EXPECT_NEAR(op.power_mech_W, op.torque_Nm * pt.speed, 1e-12 * scale) << at;
    // and the DC side pays the copper and inverter losses on top of the shaft power
    EXPECT_NEAR(op.power_dc_W - op.power_mech_W, copper + p.k_inv_W_per_A * i1, 1e-9 * scale) << at;
  }
  // generating at speed: the machine returns power even after its losses
  EXPECT_LT(am_from_slip(p, -20.0, 100.0).power_dc_W, 0.0);
}

TEST(AmDrive, UfRuleBelowBaseCapAbove) {
  const AmDriveParams p = msl();
  const double k_uf = p.U_base_rms_V / p.w_e_base_rad_s;
  for (double speed : {0.0, 30.0, 100.0, 140.0, -60.0}) {
    const AmOperatingPoint op = am_from_slip(p, 10.0, speed);
    const double w_e = p.pole_pairs * speed + 10.0;
    ASSERT_LE(std::abs(w_e), p.w_e_base_rad_s);
    EXPECT_EQ(op.w_e_rad_s, w_e);
    EXPECT_NEAR(op.emf_rms_V, k_uf * std::abs(w_e), 1e-12 * p.U_base_rms_V) << speed;
    EXPECT_FALSE(op.weakening) << speed;
  }
  for (double speed : {160.0, 250.0, 500.0, -300.0}) {
    const AmOperatingPoint op = am_from_slip(p, 10.0, speed);
    EXPECT_EQ(op.emf_rms_V, p.U_base_rms_V) << speed;
    EXPECT_TRUE(op.weakening) << speed;
  }
  // the terminal voltage carries the R1 drop on top of E
  const AmOperatingPoint heavy = am_from_slip(p, 40.0, 250.0);
  EXPECT_GT(heavy.u1_rms_V, heavy.emf_rms_V);
  EXPECT_LE(heavy.u1_rms_V, heavy.emf_rms_V + p.R1_Ohm * heavy.i1_rms_A * (1 + 1e-12));
}

// ---------------------------------------------------------------------------------------------
// TorqueToDW

TEST(AmDrive, SlipForTorqueIsSection92sRootInElectricalUnits) {
  // with Lm -> inf the circuit is ControlLogic's: T* = 3 R_r y Kw^2 / ((pp y L_stray)^2 + R_r^2),
  // y mechanical slip speed, Kw = U_base / (w_e_base / pp), L_stray = L1 + L2; dWe = pp y
  AmDriveParams p = unlimited_current();
  p.Lm_H = 1e9;
  const double kw = p.U_base_rms_V / (p.w_e_base_rad_s / p.pole_pairs), l = p.L1_H + p.L2_H, r = p.R2_Ohm;
  const int pp = p.pole_pairs;
  for (double t : {5.0, 50.0, 200.0, 400.0, -120.0}) {
    const double root = std::sqrt(9 * r * r * kw * kw * kw * kw - 4 * t * t * pp * pp * l * l * r * r);
    const double y = (3 * r * kw * kw - root) / (2 * t * pp * pp * l * l);
    bool at_max = true;
    const double dwe = am_slip_for_torque(p, t, 60.0, at_max);
    EXPECT_FALSE(at_max) << t;
    EXPECT_LT(relative(dwe, pp * y), 1e-9) << t;
  }
}

TEST(AmDrive, TorqueRequestIsDeliveredAtEverySpeed) {
  // Tolerance 1e-9: E is behind R1, so the Thevenin reduction that the closed form uses is exact
  // (not the Lm -> inf approximation, which would miss by 6.7 %), and above base frequency the
  // flux's dependence on the slip is solved for (to 1e-13), not estimated from pp w_m.
  const AmDriveParams p = unlimited_current();
  for (double speed : {0.0, 40.0, 150.0, 157.0, 250.0, 400.0, -100.0, -300.0}) {
    const double reach = am_torque_limit_Nm(p, speed);
    for (double f : {0.02, 0.3, 0.7, 0.97}) {
      for (double sign : {1.0, -1.0}) {
        const double t = sign * f * reach;
        const AmOperatingPoint op = am_operating_point(p, t, speed);
        EXPECT_LT(relative(op.torque_Nm, t), 1e-9) << speed << " " << t << ": " << op.torque_Nm;
        EXPECT_FALSE(op.torque_at_max) << speed << " " << t;
        EXPECT_FALSE(op.current_limited) << speed << " " << t;
        EXPECT_LE(std::abs(op.slip_rad_s), slip_limit(p)) << speed << " " << t;
      }
    }
  }
}

TEST(AmDrive, ZeroRequestZeroSlipZeroTorque) {
  const AmDriveParams p = msl();
  for (double speed : {0.0, 80.0, 300.0, -50.0}) {
    bool at_max = true;
    EXPECT_EQ(am_slip_for_torque(p, 0.0, speed, at_max), 0.0);
    EXPECT_FALSE(at_max);
    const AmOperatingPoint op = am_operating_point(p, 0.0, speed);
    EXPECT_EQ(op.slip_rad_s, 0.0);
    EXPECT_EQ(op.torque_Nm, 0.0);
    EXPECT_EQ(op.power_mech_W, 0.0);
    EXPECT_GT(op.power_dc_W, 0.0);  // the magnetising current still costs copper and inverter loss
  }
  // no-load current below base frequency: Psi / (L1 + Lm)
  const AmOperatingPoint idle = am_operating_point(p, 0.0, 80.0);
  EXPECT_LT(relative(idle.i1_rms_A, p.U_base_rms_V / p.w_e_base_rad_s / (p.L1_H + p.Lm_H)), 1e-12);
}

TEST(AmDrive, NegativeRequestRegenerates) {
  const AmDriveParams p = msl();
  for (double speed : {60.0, 140.0, 300.0}) {
    const AmOperatingPoint op = am_operating_point(p, -50.0, speed);
    EXPECT_LT(relative(op.torque_Nm, -50.0), 1e-9) << speed;
    EXPECT_LT(op.slip_rad_s, 0.0) << speed;
    EXPECT_LT(op.power_mech_W, 0.0) << speed;
    EXPECT_LT(op.power_dc_W, 0.0) << speed;  // net power back to the DC bus
    EXPECT_GT(op.power_dc_W, op.power_mech_W) << speed;  // less than the shaft gives: losses
  }
}

TEST(AmDrive, RequestBeyondReachGetsTheLargestTorque) {
  const AmDriveParams p = unlimited_current();
  const double lim = slip_limit(p);
  // below base: the limiter's slip; above base, motoring: the peak moves below the limiter
  for (double speed : {50.0, 160.0, 300.0}) {
    double best = 0.0;
    for (int k = 1; k <= 4000; ++k) best = std::max(best, am_from_slip(p, lim * k / 4000.0, speed).torque_Nm);
    const AmOperatingPoint op = am_operating_point(p, 1e4, speed);
    EXPECT_TRUE(op.torque_at_max) << speed;
    EXPECT_TRUE(op.slip_limited) << speed;
    EXPECT_GE(op.torque_Nm, best * (1 - 1e-9)) << speed;  // the scan finds nothing larger
    EXPECT_LT(op.torque_Nm, best * (1 + 1e-6)) << speed;
    EXPECT_LT(relative(op.torque_Nm, am_torque_limit_Nm(p, speed)), 1e-9) << speed;
    if (speed > 100.0) {
      EXPECT_LT(op.slip_rad_s, 0.99 * lim) << speed;
      EXPECT_GT(op.torque_Nm, am_from_slip(p, lim, speed).torque_Nm * 1.001) << speed;
    } else {
      EXPECT_EQ(op.slip_rad_s, lim) << speed;
    }
    // at the maximum: flagged (tauIsMax: "at or above"); a little above it: the maximum
    const double limit = am_torque_limit_Nm(p, speed);
    EXPECT_TRUE(am_operating_point(p, limit, speed).torque_at_max) << speed;
    const AmOperatingPoint above = am_operating_point(p, 1.005 * limit, speed);
    EXPECT_TRUE(above.torque_at_max) << speed;
    EXPECT_LT(relative(above.torque_Nm, limit), 1e-9) << speed;
    // just below the maximum: delivered, not flagged
    const AmOperatingPoint near = am_operating_point(p, 0.999 * op.torque_Nm, speed);
    EXPECT_FALSE(near.torque_at_max) << speed;
    EXPECT_LT(relative(near.torque_Nm, 0.999 * op.torque_Nm), 1e-9) << speed;
  }
  // braking at speed: the flux grows with the slip, the limiter's slip is the maximum
  const AmOperatingPoint brake = am_operating_point(p, -1e4, 300.0);
  EXPECT_TRUE(brake.torque_at_max);
  EXPECT_EQ(brake.slip_rad_s, -lim);
}

// ---------------------------------------------------------------------------------------------
// Current limit and the ECU's torque limit

TEST(AmDrive, CurrentLimitHoldsTheStatorCurrent) {
  const AmDriveParams p = msl();  // I_max 250 A: below the 351 A of the limiter's slip up to ~190 rad/s
  const AmDriveParams free = unlimited_current();
  int acted = 0, idle = 0;
  for (double speed = -320.0; speed <= 320.0; speed += 20.0) {
    for (double t = -600.0; t <= 600.0; t += 25.0) {
      const AmOperatingPoint op = am_operating_point(p, t, speed);
      const AmOperatingPoint unl = am_operating_point(free, t, speed);
      // never above, not by a bit: the solve ends on the feasible side
      EXPECT_LE(op.i1_rms_A, p.I_max_rms_A) << speed << " " << t;
      EXPECT_EQ(op.current_limited, unl.i1_rms_A > p.I_max_rms_A) << speed << " " << t;
      if (op.current_limited) {
        ++acted;
        EXPECT_GT(op.i1_rms_A, p.I_max_rms_A * (1 - 1e-9)) << speed << " " << t;  // held at the limit
        EXPECT_LT(std::abs(op.slip_rad_s), std::abs(unl.slip_rad_s)) << speed << " " << t;
        EXPECT_LT(std::abs(op.torque_Nm), std::abs(unl.torque_Nm)) << speed << " " << t;
        EXPECT_EQ(op.torque_Nm > 0, t > 0) << speed << " " << t;
      } else {
        ++idle;
        EXPECT_EQ(op.torque_Nm, unl.torque_Nm) << speed << " " << t;
      }
    }
  }
  EXPECT_GT(acted, 50);
  EXPECT_GT(idle, 50);
}

TEST(AmDrive, TorqueLimitIsWhatASaturatedRequestGets) {
  const AmDriveParams p = msl();
  for (double speed : {0.0, 50.0, 150.0, 250.0, -120.0}) {
    const double limit = am_torque_limit_Nm(p, speed);
    const double up = am_operating_point(p, 1e4, speed).torque_Nm;
    const double down = am_operating_point(p, -1e4, speed).torque_Nm;
    EXPECT_LT(relative(std::min(up, -down), limit), 1e-9) << speed;
    for (double sign : {1.0, -1.0}) {
      const AmOperatingPoint op = am_operating_point(p, sign * 0.99 * limit, speed);
      EXPECT_LT(relative(op.torque_Nm, sign * 0.99 * limit), 1e-9) << speed << " " << sign;
    }
  }
  // the current limit dominates at low speed (250 A < 351 A at the limiter's slip)
  EXPECT_TRUE(am_operating_point(p, 1e4, 50.0).current_limited);
  EXPECT_LT(am_torque_limit_Nm(p, 50.0), am_torque_limit_Nm(unlimited_current(), 50.0) * 0.99);
}

// ---------------------------------------------------------------------------------------------
// AMDrivePU

// the p.u. data of an SI machine on the base of the header (written out here)
AmDrivePuParams per_unit(const AmDriveParams& si, double s_nom_VA, double v_nom_V, double f_nom_Hz) {
  const double w = 2.0 * std::numbers::pi * f_nom_Hz, z = 3.0 * v_nom_V * v_nom_V / s_nom_VA;
  const double i_base = s_nom_VA / (3.0 * v_nom_V), w_m = w / si.pole_pairs;
  AmDrivePuParams pu;
  pu.S_nom_VA = s_nom_VA;
  pu.V_nom_rms_V = v_nom_V;
  pu.f_nom_Hz = f_nom_Hz;
  pu.pole_pairs = si.pole_pairs;
  pu.r1_pu = si.R1_Ohm / z;
  pu.r2_pu = si.R2_Ohm / z;
  pu.x1_pu = w * si.L1_H / z;
  pu.x2_pu = w * si.L2_H / z;
  pu.xm_pu = w * si.Lm_H / z;
  pu.H_s = 0.5 * si.inertia_kgm2 * w_m * w_m / s_nom_VA;
  pu.I_max_pu = si.I_max_rms_A / i_base;
  pu.k_inv_pu = si.k_inv_W_per_A * i_base / s_nom_VA;
  return pu;
}

void expect_same(const AmDriveParams& a, const AmDriveParams& b, const std::string& at) {
  EXPECT_EQ(a.pole_pairs, b.pole_pairs) << at;
  EXPECT_LT(relative(a.R1_Ohm, b.R1_Ohm), 1e-12) << at;
  EXPECT_LT(relative(a.R2_Ohm, b.R2_Ohm), 1e-12) << at;
  EXPECT_LT(relative(a.L1_H, b.L1_H), 1e-12) << at;
  EXPECT_LT(relative(a.L2_H, b.L2_H), 1e-12) << at;
  EXPECT_LT(relative(a.Lm_H, b.Lm_H), 1e-12) << at;
  EXPECT_LT(relative(a.inertia_kgm2, b.inertia_kgm2), 1e-12) << at;
  EXPECT_LT(relative(a.U_base_rms_V, b.U_base_rms_V), 1e-12) << at;
  EXPECT_LT(relative(a.w_e_base_rad_s, b.w_e_base_rad_s), 1e-12) << at;
  EXPECT_LT(relative(a.I_max_rms_A, b.I_max_rms_A), 1e-12) << at;
  EXPECT_LT(relative(a.k_inv_W_per_A, b.k_inv_W_per_A), 1e-12) << at;
}

TEST(AmDrivePu, PerUnitDataOfTheMslMachineGiveItBack) {
  const AmDriveParams si = msl();
  // its rated 30 kVA (Z_base = 1 Ohm), and 40 kVA (Z_base = 0.75 Ohm: a misplaced base shows)
  for (double s_nom : {30000.0, 40000.0}) {
    const AmDrivePuParams pu = per_unit(si, s_nom, 100.0, 50.0);
    Problems problems;
    validate(pu, "drive", problems);
    EXPECT_TRUE(problems.empty()) << s_nom;
    expect_same(am_params_from_pu(pu), si, std::to_string(s_nom));
  }
  // the p.u. defaults are the SI defaults
  expect_same(am_params_from_pu(AmDrivePuParams{}), si, "defaults");
}

TEST(AmDrivePu, DoublingSnomDoublesTheTorqueAtTheSamePerUnitPoint) {
  AmDrivePuParams small;
  small.S_nom_VA = 20000.0;
  AmDrivePuParams big = small;
  big.S_nom_VA = 40000.0;
  const AmDriveParams a = am_params_from_pu(small), b = am_params_from_pu(big);
  EXPECT_EQ(a.w_e_base_rad_s, b.w_e_base_rad_s);  // same p.u. slip = same dWe
  EXPECT_LT(relative(am_slip_limit_rad_s(b), am_slip_limit_rad_s(a)), 1e-12);
  for (double speed : {0.0, 60.0, 250.0}) {
    for (double dwe : {-30.0, 5.0, 40.0}) {
      const AmOperatingPoint x = am_from_slip(a, dwe, speed), y = am_from_slip(b, dwe, speed);
      EXPECT_LT(relative(y.torque_Nm, 2.0 * x.torque_Nm), 1e-12) << speed << " " << dwe;
      EXPECT_LT(relative(y.i1_rms_A, 2.0 * x.i1_rms_A), 1e-12) << speed << " " << dwe;
      EXPECT_LT(relative(y.u1_rms_V, x.u1_rms_V), 1e-12) << speed << " " << dwe;
    }
    // through TorqueToDW and the current limit too: twice the request, same slip
    const AmOperatingPoint x = am_operating_point(a, 90.0, speed), y = am_operating_point(b, 180.0, speed);
    EXPECT_LT(relative(y.torque_Nm, 2.0 * x.torque_Nm), 1e-9) << speed;
    EXPECT_LT(relative(y.slip_rad_s, x.slip_rad_s), 1e-9) << speed;
    EXPECT_LT(relative(am_torque_limit_Nm(b, speed), 2.0 * am_torque_limit_Nm(a, speed)), 1e-9) << speed;
  }
}

// ---------------------------------------------------------------------------------------------
// validate

const Problem* find(const Problems& problems, const std::string& field) {
  for (const Problem& p : problems.list()) {
    if (p.field == field) return &p;
  }
  return nullptr;
}

TEST(AmDriveValidate, DefaultsAreValid) {
  Problems problems;
  validate(AmDriveParams{}, "drive", problems);
  validate(AmDrivePuParams{}, "drive", problems);
  EXPECT_TRUE(problems.empty());
}

TEST(AmDriveValidate, EachBadFieldIsNamedWithItsValue) {
  AmDriveParams p;
  p.L1_H = 0.0;
  p.R2_Ohm = -0.01;
  p.pole_pairs = 0;
  p.Lm_H = std::nan("");
  p.k_inv_W_per_A = -1.0;
  Problems problems;
  validate(p, "vehicle.drive", problems);
  ASSERT_EQ(problems.size(), 5u);
  const std::vector<std::pair<std::string, std::string>> expected = {
      {"vehicle.drive.L1_H", "0"}, {"vehicle.drive.R2_Ohm", "-0.01"}, {"vehicle.drive.pole_pairs", "0"},
      {"vehicle.drive.Lm_H", "nan"}, {"vehicle.drive.k_inv_W_per_A", "-1"}};
  for (const auto& [field, value] : expected) {
    const Problem* found = find(problems, field);
    ASSERT_NE(found, nullptr) << field;
    EXPECT_EQ(found->value, value) << field;
  }
  AmDriveParams q;
  q.pole_pairs = 101;
  Problems more;
  validate(q, "d", more);
  ASSERT_EQ(more.size(), 1u);
  EXPECT_EQ(more.list()[0].field, "d.pole_pairs");
}

TEST(AmDriveValidate, CurrentLimitBelowTheNoLoadCurrentIsRejectedWithTheReason) {
  // I0 = 100 V / (314.16 rad/s x 9.549 mH) = 33.334 A
  AmDriveParams p;
  p.I_max_rms_A = 30.0;
  Problems problems;
  validate(p, "drive", problems);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems.list()[0].field, "drive.I_max_rms_A");
  EXPECT_EQ(problems.list()[0].value, "30");
  EXPECT_NE(problems.list()[0].expected.find("no-load"), std::string::npos) << problems.list()[0].expected;
  EXPECT_NE(problems.list()[0].expected.find("33.334 A"), std::string::npos) << problems.list()[0].expected;
  // between |j X0 + R1| and X0: with E behind R1 the no-load current is U / X0, still too much
  p.I_max_rms_A = 33.3335;
  Problems between;
  validate(p, "drive", between);
  EXPECT_EQ(between.size(), 1u);
  p.I_max_rms_A = 33.34;
  Problems above;
  validate(p, "drive", above);
  EXPECT_TRUE(above.empty());
  // and then the limit holds even with no slip left to give: the no-load current fits
  EXPECT_LE(am_operating_point(p, 100.0, 50.0).i1_rms_A, 33.34 * (1 + 1e-12));
}

TEST(AmDriveValidate, PerUnitFieldsAreNamedWithTheirValues) {
  AmDrivePuParams p;
  p.xm_pu = 0.0;
  p.r1_pu = -1.0;
  p.S_nom_VA = std::numeric_limits<double>::infinity();
  p.pole_pairs = 0;
  Problems problems;
  validate(p, "drive", problems);
  ASSERT_EQ(problems.size(), 4u);
  EXPECT_EQ(find(problems, "drive.xm_pu")->value, "0");
  EXPECT_EQ(find(problems, "drive.r1_pu")->value, "-1");
  EXPECT_EQ(find(problems, "drive.S_nom_VA")->value, "inf");
  EXPECT_EQ(find(problems, "drive.pole_pairs")->value, "0");
  // 1 / (x1 + xm) = 0.33334 p.u. of no-load current
  AmDrivePuParams q;
  q.I_max_pu = 0.3;
  Problems low;
  validate(q, "drive", low);
  ASSERT_EQ(low.size(), 1u);
  EXPECT_EQ(low.list()[0].field, "drive.I_max_pu");
  EXPECT_EQ(low.list()[0].value, "0.3");
  EXPECT_NE(low.list()[0].expected.find("no-load"), std::string::npos);
  q.I_max_pu = 0.34;  // above 1 / (x1 + xm), below 1 / xm: the leakage counts
  Problems fits;
  validate(q, "drive", fits);
  EXPECT_TRUE(fits.empty());
}

}  // namespace
}  // namespace ehpt::plant
