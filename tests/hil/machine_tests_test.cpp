// SPDX-License-Identifier: BSD-3-Clause
// TestPMDrive and TestAMDrive end to end: the shipped scenarios (scenarios/test_pm_drive.toml,
// scenarios/test_am_drive.toml) loaded and run through the library's Simulation facade, as
// `ehpt run` does, and the paper's comparisons checked on the recorded rows. The tolerances
// are those of tests/plant/detailed_machines_test.cpp (derived there), plus what a run on a
// ramp and a sampled record add, stated at each use.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "hil/config/config.hpp"
#include "hil/run/simulation.hpp"
#include "test_plants.hpp"

namespace ehpt::hil {
namespace {

constexpr double kSqrt2 = 1.4142135623730951;

// A whole run's rows, every signal, by name.
struct Record {
  double h_s = 0.0;
  std::map<std::string, std::vector<double>> col;
  plant::EnergyAudit audit;
  RunStats stats;

  std::size_t row_at(double t_s) const {
    const std::vector<double>& t = col.at("time_s");
    std::size_t best = 0;
    for (std::size_t i = 0; i < t.size(); ++i) {
      if (std::abs(t[i] - t_s) < std::abs(t[best] - t_s)) best = i;
    }
    return best;
  }
  double at(const std::string& name, double t_s) const { return col.at(name)[row_at(t_s)]; }
  // the mean of a * b over the rows in (t0, t1]
  double mean_product(const std::string& a, const std::string& b, double t0_s, double t1_s) const {
    const std::vector<double>& t = col.at("time_s");
    double sum = 0.0;
    int n = 0;
    for (std::size_t i = 0; i < t.size(); ++i) {
      if (t[i] > t0_s && t[i] <= t1_s) {
        sum += col.at(a)[i] * col.at(b)[i];
        ++n;
      }
    }
    return sum / n;
  }
  // the largest |signal| over the rows in (t0, t1]
  double max_abs(const std::string& name, double t0_s, double t1_s) const {
    const std::vector<double>& t = col.at("time_s");
    double m = 0.0;
    for (std::size_t i = 0; i < t.size(); ++i) {
      if (t[i] > t0_s && t[i] <= t1_s) m = std::max(m, std::abs(col.at(name)[i]));
    }
    return m;
  }
};

Record run(const std::string& scenario) {
  Record r;
  const Scenario sc = test::load(test::source_path(scenario));
  r.h_s = sc.solver.step_s;
  const auto sim = make_simulation(sc, SimulationOptions{});  // every signal, the scenario's interval
  const auto signals = sim->signals();
  std::vector<double> rows;
  while (!sim->finished()) {
    sim->run();
    rows.insert(rows.end(), sim->rows().begin(), sim->rows().end());
    sim->clear_rows();
  }
  for (std::size_t c = 0; c < signals.size(); ++c) {
    std::vector<double>& v = r.col[std::string(signals[c].name)];
    for (std::size_t i = c; i < rows.size(); i += signals.size()) v.push_back(rows[i]);
  }
  r.audit = sim->audit();
  r.stats = sim->stats();
  return r;
}

// Numerical dissipation of implicit Euler: a state turning at w_e loses w_e^2 h W per second
// (W its stored magnetic energy) to the rectangle rule; the audit's residual is that, summed.
double predicted_residual_J(const Record& r, const std::vector<double>& w_e) {
  const std::vector<double>& t = r.col.at("time_s");
  const std::vector<double>& W = r.col.at("det_magnetic_energy_J");
  double sum = 0.0;
  for (std::size_t i = 1; i < t.size(); ++i) sum += w_e[i] * w_e[i] * r.h_s * W[i] * (t[i] - t[i - 1]);
  return sum;
}

TEST(MachineScenarios, TestPMDrive) {
  const Record r = run("scenarios/test_pm_drive.toml");
  ASSERT_EQ(r.stats.fault, 0u);
  EXPECT_EQ(r.stats.newton_failures, 0);
  ASSERT_NEAR(r.col.at("time_s").back(), 10.0, 1e-9);
  const double U_lim = 100.0 * kSqrt2, T_f = 20e-6, L = 4e-3, Rs = 0.03, dt = 5e-4;
  struct Point {
    double t_s;
    bool weakening, current_limited;
  };
  // MTPA at 150 N m; weakening at 150 N m; weakening at the current limit (T* not reachable);
  // the same while the request falls; no load at 317 rad/s (twice: the state is periodic)
  for (const Point& pt : {Point{2.0, false, false}, Point{3.5, true, false}, Point{5.0, true, true},
                          Point{6.0, true, true}, Point{9.0, true, false}, Point{9.9, true, false}}) {
    SCOPED_TRACE(testing::Message() << "t = " << pt.t_s << " s");
    const std::size_t i = r.row_at(pt.t_s);
    const auto at = [&](const char* name) { return r.col.at(name)[i]; };
    EXPECT_EQ(at("weakening"), pt.weakening ? 1.0 : 0.0);
    EXPECT_EQ(at("current_limited"), pt.current_limited ? 1.0 : 0.0);
    const double w_e = 2 * at("speed_rad_s"), I = std::hypot(at("qs_id_A"), at("qs_iq_A"));
    const double psi = std::hypot(0.5055 + 2e-3 * at("qs_id_A"), L * at("qs_iq_A"));
    // on the ramps the drive's currents move (speed 45 rad/s^2, torque 150 N m/s): the detailed
    // voltage carries L dI*/dt, which the quasi-static one leaves out
    const double dI_dt = std::hypot(r.col.at("qs_id_A")[i + 1] - r.col.at("qs_id_A")[i - 1],
                                    r.col.at("qs_iq_A")[i + 1] - r.col.at("qs_iq_A")[i - 1]) / (2 * dt);
    const double tol_V = 1.1 * ((Rs + w_e * L) * I * w_e * T_f + w_e * L * I * w_e * r.h_s / 2) + L * dI_dt;
    const double tol_T = 1.1 * 1.5 * 2 * (psi + L * I) * I * w_e * T_f;
    // quasi-static rms voltage = detailed peak / sqrt 2; torques agree
    EXPECT_NEAR(at("det_v_peak_V") / kSqrt2, at("qs_v_rms_V"), tol_V / kSqrt2);
    EXPECT_NEAR(at("det_torque_Nm"), at("qs_torque_Nm"), tol_T);
    if (pt.weakening) {
      EXPECT_NEAR(at("qs_v_peak_V"), U_lim, 1e-9 * U_lim);
      EXPECT_NEAR(at("det_v_peak_V"), U_lim, tol_V);
      EXPECT_GT(at("full_flux_v_peak_V"), 1.25 * U_lim);  // why flux weakening is needed
    } else {
      EXPECT_NEAR(at("full_flux_v_peak_V"), at("qs_v_peak_V"), 1e-9 * U_lim);
    }
  }
  // on the last plateau (317 rad/s, no load, 9-10 s) the sampled phase voltage: its largest
  // sample is the space phasor's length, less at most 1 - cos(w_e dt / 2) = 1.25 % for a
  // sample falling between two crests
  const double peak = r.at("det_v_peak_V", 10.0), w_e = 2 * 317.0;
  const double sampled = r.max_abs("det_v_a_V", 9.0, 10.0);
  EXPECT_LE(sampled, peak * (1 + 1e-9));
  EXPECT_GE(sampled, peak * std::cos(w_e * dt / 2));
  EXPECT_NEAR(sampled / kSqrt2, r.at("qs_v_rms_V", 10.0), 0.0125 * peak / kSqrt2 + 0.01 * U_lim);
  // phase a is the alpha axis of both voltage and current: three times phase a's mean power is
  // the machine's 1.5 v.i; the mean of 2000 samples over 100 periods keeps part of the 2 w_e
  // ripple (amplitude V I / 2): 3 % of it
  const double p_a = r.mean_product("det_v_a_V", "det_i_a_A", 9.0, 10.0);
  const double I_a = r.max_abs("det_i_a_A", 9.0, 10.0);
  EXPECT_NEAR(3 * p_a, r.at("det_power_W", 10.0), 0.03 * peak * I_a / 2);
  // the energy audit is open by the integrator's numerical dissipation, and by nothing else
  std::vector<double> w(r.col.at("speed_rad_s"));
  for (double& x : w) x *= 2;
  const double predicted = predicted_residual_J(r, w);
  EXPECT_GT(predicted, 100.0);
  EXPECT_NEAR(r.audit.residual_J, predicted, 0.03 * predicted);
}

TEST(MachineScenarios, TestAMDrive) {
  const Record r = run("scenarios/test_am_drive.toml");
  ASSERT_EQ(r.stats.fault, 0u);
  EXPECT_EQ(r.stats.newton_failures, 0);
  ASSERT_NEAR(r.col.at("time_s").back(), 16.0, 1e-9);
  const double R2 = 0.04, L12 = 2 * 3.240e-4, dt = 1e-3;
  struct Point {
    double t_s, torque_Nm;
    bool weakening;
  };
  // the ends of the four plateaus, each >= 1 s (45 slowest electrical time constants, 22 ms)
  // after the last change of speed or request: 50 and 200 N m at 100 rad/s, then at 200 rad/s
  for (const Point& pt : {Point{2.0, 50.0, false}, Point{7.0, 200.0, false}, Point{11.0, 50.0, true},
                          Point{16.0, 200.0, true}}) {
    SCOPED_TRACE(testing::Message() << "t = " << pt.t_s << " s");
    const auto at = [&](const char* name) { return r.at(name, pt.t_s); };
    EXPECT_EQ(at("weakening"), pt.weakening ? 1.0 : 0.0);
    EXPECT_NEAR(at("qs_torque_Nm"), pt.torque_Nm, 1e-6 * pt.torque_Nm);
    const double w_e = at("qs_w_e_rad_s"), V = kSqrt2 * at("qs_u1_rms_V"), eps = w_e * w_e * r.h_s / 2;
    // the sine source: |v_ab| = sqrt 2 U1; its sampled crest over the plateau's last 0.5 s
    // within 1 - cos(w_e dt / 2) (2.4 % at 436 rad/s)
    EXPECT_NEAR(at("det_v_peak_V"), V, 1e-12 * V);
    const double v_sampled = r.max_abs("det_v_a_V", pt.t_s - 0.5, pt.t_s);
    EXPECT_LE(v_sampled, V * (1 + 1e-12));
    EXPECT_GE(v_sampled, V * std::cos(w_e * dt / 2));
    // torques and currents (tolerances derived in detailed_machines_test.cpp)
    const double tol_T = 1.1 * (L12 * w_e * w_e * r.h_s / R2 + w_e * r.h_s) * pt.torque_Nm;
    const double tol_I = 1.1 * eps * (V / w_e) / R2;
    EXPECT_NEAR(at("det_torque_Nm"), at("qs_torque_Nm"), tol_T);
    EXPECT_NEAR(at("det_i_peak_A") / kSqrt2, at("qs_i1_rms_A"), tol_I / kSqrt2);
    // the sampled phase current's crest: the detailed I1 within the same tolerance and sampling
    const double i_sampled = r.max_abs("det_i_a_A", pt.t_s - 0.5, pt.t_s);
    EXPECT_LE(i_sampled, at("det_i_peak_A") * (1 + 1e-6));
    EXPECT_GE(i_sampled, at("det_i_peak_A") * std::cos(w_e * dt / 2));
    // phase a is the alpha axis of both voltage and current: three times phase a's mean power
    // is the machine's 1.5 v.i; the mean of 500 samples over 16-35 periods keeps part of the
    // 2 w_e ripple (amplitude V I / 2): 3 % of it (1.3 % measured)
    const double p_a = r.mean_product("det_v_a_V", "det_i_a_A", pt.t_s - 0.5, pt.t_s);
    EXPECT_NEAR(3 * p_a, at("det_power_W"), 0.03 * V * at("det_i_peak_A") / 2);
  }
  // the energy audit is open by the integrator's numerical dissipation, and by nothing else
  // (the start from zero flux included)
  const double predicted = predicted_residual_J(r, r.col.at("qs_w_e_rad_s"));
  EXPECT_GT(predicted, 50.0);
  EXPECT_NEAR(r.audit.residual_J, predicted, 0.03 * predicted);
}

// Bad rig data is reported with where it came from, field and value, before anything runs; the
// profiles' level keys carry their unit (offset_rad_s), and so do their messages, which name
// each key as the user wrote it (`vehicle.speed.offset_rad_s` on the command line).
TEST(MachineScenarios, ProblemsNameTheFieldTheValueAndWhereItCameFrom) {
  Scenario sc;
  std::vector<std::string> errors;
  EXPECT_FALSE(load_scenario(test::source_path("scenarios/test_pm_drive.toml"),
                             {"vehicle.speed.amplitude_rad_s=400", "vehicle.request.rising_s=0"}, sc, errors));
  std::vector<std::string> more;
  EXPECT_FALSE(load_scenario(test::source_path("scenarios/test_pm_drive.toml"), {"vehicle.speed.offset_rad_s=nan"},
                             sc, more));
  errors.insert(errors.end(), more.begin(), more.end());
  ASSERT_EQ(errors.size(), 3u);
  std::string all;
  for (const std::string& e : errors) all += e + "\n";
  EXPECT_NE(all.find("--set vehicle.speed.amplitude_rad_s=400: vehicle.speed.amplitude_rad_s = 400: takes the speed to 400 "
                     "rad/s, beyond machine.speed_max_rad_s = 317"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("--set vehicle.request.rising_s=0: vehicle.request.rising_s = 0: must be a finite number > 0"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("--set vehicle.speed.offset_rad_s=nan: vehicle.speed.offset_rad_s = nan: must be a finite number"),
            std::string::npos)
      << all;
  errors.clear();
  EXPECT_FALSE(load_scenario(test::source_path("scenarios/test_am_drive.toml"),
                             {"vehicle.machine.R2_Ohm=-1", "vehicle.machine.bogus=1"}, sc, errors));
  ASSERT_EQ(errors.size(), 2u);
  all = errors[0] + "\n" + errors[1];
  EXPECT_NE(all.find("machine.R2_Ohm = -1: must be a finite number > 0"), std::string::npos) << all;
  EXPECT_NE(all.find("machine.bogus: unknown key"), std::string::npos) << all;
}

}  // namespace
}  // namespace ehpt::hil
