// SPDX-License-Identifier: BSD-3-Clause
// ECU tests (docs/testing.md): each fault kind's exact effect on the value it targets, the
// faults_active column, the edges of every expectation window, and the load-time rules for
// [[fault]] and [[expect]]. Sensor faults are seen by an ECU outside the simulation (the
// samples it reads); command faults by the plant's own echo of the command it integrates from.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numeric>

#include "hil/config/config.hpp"
#include "hil/run/batch.hpp"
#include "hil/run/simulation.hpp"
#include "test_plants.hpp"

namespace fs = std::filesystem;

namespace ehpt::hil {
namespace {

// The samples an outside ECU reads from the EV on NEDC over 3 s (300 samples at 10 ms), with a
// constant torque command so that every sensor value moves; faults as --fault texts.
std::vector<msgs::EvSensors> ev_samples(const std::vector<std::string>& faults) {
  Scenario sc;
  std::vector<std::string> errors;
  EXPECT_TRUE(load_scenario(test::source_path("scenarios/ev_nedc.toml"), {"solver.duration_s=3"}, faults, sc, errors))
      << (errors.empty() ? "" : errors[0]);
  SimulationOptions opt;
  opt.external_ecu = true;
  auto sim = make_simulation(sc, opt);
  std::vector<msgs::EvSensors> out;
  while (!sim->finished()) {
    msgs::EvSensors s;
    EXPECT_TRUE(sim->read_sensors(s));
    out.push_back(s);
    msgs::EvCommand c;
    c.stamp = s.stamp;
    c.driveTauRef_Nm = 80.0;
    sim->write_command(c);
    sim->step(10);
  }
  return out;
}

constexpr int kAt = 100, kUntil = 200;  // at_s = 1, until_s = 2: samples 100 .. 199

class SensorFault : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { healthy_ = new std::vector<msgs::EvSensors>(ev_samples({})); }
  static void TearDownTestSuite() { delete healthy_; }
  static const std::vector<msgs::EvSensors>& healthy() { return *healthy_; }
  static std::vector<msgs::EvSensors>* healthy_;
};
std::vector<msgs::EvSensors>* SensorFault::healthy_ = nullptr;

// Outside [kAt, kUntil) every sample is the healthy one, bit for bit.
void expect_healthy_outside(const std::vector<msgs::EvSensors>& f, const std::vector<msgs::EvSensors>& h) {
  ASSERT_EQ(f.size(), h.size());
  for (std::size_t k = 0; k < f.size(); ++k) {
    if (static_cast<int>(k) >= kAt && static_cast<int>(k) < kUntil) continue;
    ASSERT_EQ(f[k].speed_m_s, h[k].speed_m_s) << k;
    ASSERT_EQ(f[k].driveW_rad_s, h[k].driveW_rad_s) << k;
  }
}

TEST_F(SensorFault, HealthySamplesMoveSoThatAFaultCanBeSeen) {
  ASSERT_EQ(healthy().size(), 301u);
  EXPECT_NE(healthy()[kAt].speed_m_s, healthy()[kAt + 1].speed_m_s);
  EXPECT_GT(healthy()[kUntil].speed_m_s, healthy()[kAt].speed_m_s);
}

TEST_F(SensorFault, StuckHoldsTheValueOfItsFirstSampleFromAtSUntilUntilS) {
  const auto f = ev_samples({"kind=stuck target=speed_m_s at_s=1 until_s=2"});
  expect_healthy_outside(f, healthy());
  for (int k = kAt; k < kUntil; ++k) ASSERT_EQ(f[k].speed_m_s, healthy()[kAt].speed_m_s) << k;
  EXPECT_EQ(f[kAt - 1].speed_m_s, healthy()[kAt - 1].speed_m_s);
  EXPECT_EQ(f[kAt].driveW_rad_s, healthy()[kAt].driveW_rad_s);  // the other fields untouched
}

TEST_F(SensorFault, OffsetGainFixedQuantiseDriftAreExact) {
  const auto off = ev_samples({"kind=offset target=speed_m_s offset=0.5 at_s=1 until_s=2"});
  const auto gain = ev_samples({"kind=gain target=speed_m_s gain=1.5 at_s=1 until_s=2"});
  const auto fixed = ev_samples({"kind=fixed target=speed_m_s value=-3 at_s=1 until_s=2"});
  const auto quant = ev_samples({"kind=quantise target=speed_m_s step=0.25 at_s=1 until_s=2"});
  const auto drift = ev_samples({"kind=drift target=speed_m_s rate=2 at_s=1 until_s=2"});
  for (const auto* f : {&off, &gain, &fixed, &quant, &drift}) expect_healthy_outside(*f, healthy());
  for (int k = kAt; k < kUntil; ++k) {
    const double v = healthy()[k].speed_m_s;
    ASSERT_EQ(off[k].speed_m_s, v + 0.5) << k;
    ASSERT_EQ(gain[k].speed_m_s, v * 1.5) << k;
    ASSERT_EQ(fixed[k].speed_m_s, -3.0) << k;
    ASSERT_EQ(quant[k].speed_m_s, std::round(v / 0.25) * 0.25) << k;
    ASSERT_DOUBLE_EQ(drift[k].speed_m_s, v + 2.0 * (k - kAt) * 0.01) << k;
  }
}

TEST_F(SensorFault, DelayGivesTheSampleDelaySEarlier) {
  const auto f = ev_samples({"kind=delay target=speed_m_s delay_s=0.05 at_s=1 until_s=2"});
  expect_healthy_outside(f, healthy());
  for (int k = kAt; k < kUntil; ++k) ASSERT_EQ(f[k].speed_m_s, healthy()[k - 5].speed_m_s) << k;
}

TEST_F(SensorFault, IntermittentActsForItsDutyOfEveryPeriod) {
  // period 0.1 s, duty 0.3: 30 steps (3 samples) of every 100 read value
  const auto f = ev_samples({"kind=intermittent target=speed_m_s period_s=0.1 duty=0.3 value=7 at_s=1 until_s=2"});
  expect_healthy_outside(f, healthy());
  for (int k = kAt; k < kUntil; ++k) {
    const bool on = (k - kAt) % 10 < 3;
    ASSERT_EQ(f[k].speed_m_s, on ? 7.0 : healthy()[k].speed_m_s) << k;
  }
}

TEST_F(SensorFault, NoiseIsSeededZeroMeanWithItsSigmaAndTheSameEveryRun) {
  const auto a = ev_samples({"kind=noise target=speed_m_s sigma=0.2 seed=7 at_s=0"});
  const auto b = ev_samples({"kind=noise target=speed_m_s sigma=0.2 seed=7 at_s=0"});
  const auto c = ev_samples({"kind=noise target=speed_m_s sigma=0.2 seed=8 at_s=0"});
  double sum = 0.0, sq = 0.0;
  int differ = 0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    ASSERT_EQ(a[k].speed_m_s, b[k].speed_m_s);
    const double e = a[k].speed_m_s - healthy()[k].speed_m_s;
    sum += e;
    sq += e * e;
    differ += a[k].speed_m_s != c[k].speed_m_s ? 1 : 0;
  }
  const double n = static_cast<double>(a.size());
  EXPECT_NEAR(sum / n, 0.0, 0.04);            // 3 sigma / sqrt(301) = 0.035
  EXPECT_NEAR(std::sqrt(sq / n), 0.2, 0.03);
  EXPECT_EQ(differ, static_cast<int>(a.size()));  // another seed, another stream
}

// A triggered fault acts from the sample after its condition first held on the outputs.
TEST_F(SensorFault, WhenStartsAtTheStepAfterTheConditionFirstHolds) {
  const auto f = ev_samples({"kind=fixed target=driveW_rad_s value=0 when=\"speed_m_s>1\""});
  int first = -1;
  for (std::size_t k = 0; k < f.size(); ++k) {
    if (f[k].driveW_rad_s == 0.0 && healthy()[k].driveW_rad_s != 0.0 && first < 0) first = static_cast<int>(k);
  }
  ASSERT_GT(first, 0);
  // the healthy speed crossed 1 m/s between the sample before and this one (at a step in between)
  EXPECT_LE(healthy()[first - 1].speed_m_s, 1.0 + 0.1);
  for (std::size_t k = static_cast<std::size_t>(first); k < f.size(); ++k) ASSERT_EQ(f[k].driveW_rad_s, 0.0);
  for (int k = 0; k < first; ++k) ASSERT_EQ(f[k].driveW_rad_s, healthy()[k].driveW_rad_s);
}

// A run of psecu2 with its built-in ECU, every step recorded: the columns named.
MemoryRun psecu2(const std::vector<std::string>& faults, const std::vector<std::string>& columns, double duration_s = 30) {
  Scenario sc;
  std::vector<std::string> errors;
  std::string list = "[";
  for (const auto& c : columns) list += (list.size() > 1 ? ",\"" : "\"") + c + "\"";
  std::vector<std::string> sets = {"solver.duration_s=" + std::to_string(duration_s), "output.decimation=1",
                                   "output.signals=" + list + "]"};
  EXPECT_TRUE(load_scenario(test::source_path("scenarios/psecu2_nedc.toml"), sets, faults, sc, errors))
      << (errors.empty() ? "" : errors[0]);
  return run_in_memory(sc);
}

TEST(CommandFault, SaturateClampsTheCommandThePlantGetsAndFaultsActiveMarksTheSteps) {
  const auto h = psecu2({}, {"time_s", "genTauRef_Nm"});
  const auto f = psecu2({"kind=saturate target=genTauRef_Nm limit=5 at_s=10 until_s=20"}, {"time_s", "genTauRef_Nm"});
  ASSERT_EQ(f.columns.back(), "faults_active");
  const std::size_t w = f.columns.size();
  ASSERT_EQ(f.rows.size() / w, h.rows.size() / 2);
  double biggest = 0.0;
  for (std::size_t r = 0; r < f.rows.size() / w; ++r) {
    const double t = f.rows[r * w], tau = f.rows[r * w + 1], bits = f.rows[r * w + 2];
    const bool in = r >= 10000 && r < 20000;  // steps of [10, 20) s
    ASSERT_EQ(bits, in ? 1.0 : 0.0) << t;
    if (r < 10000) {
      ASSERT_EQ(tau, h.rows[r * 2 + 1]) << t;  // before: the same run
    }
    if (r == 10000) {
      ASSERT_EQ(tau, std::clamp(h.rows[r * 2 + 1], -5.0, 5.0));  // the ECU's command there, clamped
    }
    if (in) {
      ASSERT_LE(std::abs(tau), 5.0) << t;
      biggest = std::max(biggest, std::abs(h.rows[r * 2 + 1]));
    }
  }
  EXPECT_GT(biggest, 5.0);  // the healthy command went past the limit: the clamp acted
}

TEST(CommandFault, NoStartKeepsTheEngineOffAndLossZeroesTheMotor) {
  const auto h = psecu2({}, {"iceON", "icePowRef_W"}, 300);
  const auto f = psecu2({"kind=no_start at_s=0"}, {"iceON", "icePowRef_W"}, 300);
  double on = 0.0;
  for (std::size_t r = 0; r < h.rows.size() / 2; ++r) on += h.rows[r * 2];
  ASSERT_GT(on, 0.0);  // the healthy engine ran
  for (std::size_t r = 0; r < f.rows.size() / 3; ++r) {
    ASSERT_EQ(f.rows[r * 3], 0.0) << r;
    ASSERT_EQ(f.rows[r * 3 + 1], 0.0) << r;
  }
  // NEDC cruises at 15 km/h from 15 s to 23 s: the motor holds the speed
  const auto healthy = psecu2({}, {"motTauRef_Nm"});
  const auto loss = psecu2({"kind=loss target=motTauRef_Nm at_s=16 until_s=17"}, {"motTauRef_Nm"});
  double healthy_max = 0.0;
  for (std::size_t r = 16000; r < 17000; ++r) {
    ASSERT_EQ(loss.rows[r * 2], 0.0) << r;
    ASSERT_EQ(loss.rows[r * 2 + 1], 1.0) << r;
    healthy_max = std::max(healthy_max, std::abs(healthy.rows[r]));
  }
  EXPECT_GT(healthy_max, 1.0);
  EXPECT_EQ(loss.rows[15999 * 2], healthy.rows[15999]);
  EXPECT_NE(loss.rows[17000 * 2 + 20], 0.0);  // the ECU's command again after until_s
}

// A triggered command fault acts from the step after its condition first held, to the step.
TEST(CommandFault, WhenActsFromTheStepAfterItsConditionFirstHeld) {
  const auto f = psecu2({"kind=fixed target=motTauRef_Nm value=0 when=\"time_s>=5\""}, {"time_s", "motTauRef_Nm"}, 8);
  const std::size_t w = f.columns.size();
  ASSERT_EQ(w, 3u);
  for (std::size_t r = 0; r < f.rows.size() / w; ++r) {
    ASSERT_EQ(f.rows[r * w + 2], r >= 5001 ? 1.0 : 0.0) << "step " << r;  // time_s >= 5 first at step 5000
    if (r >= 5001) {
      ASSERT_EQ(f.rows[r * w + 1], 0.0) << "step " << r;
    }
  }
}

TEST(CommandFault, AFaultedRunIsTheSameBitForBitEveryTime) {
  const std::vector<std::string> fault = {"kind=noise target=motTauRef_Nm sigma=20 seed=3 at_s=2"};
  const auto a = psecu2(fault, {"speed_m_s", "soc"});
  const auto b = psecu2(fault, {"speed_m_s", "soc"});
  ASSERT_EQ(a.rows, b.rows);
  const auto h = psecu2({}, {"speed_m_s", "soc"});
  ASSERT_EQ(a.rows.size() / 3, h.rows.size() / 2);
  EXPECT_NE(a.rows[a.rows.size() - 2], h.rows[h.rows.size() - 1]);  // the final SOC: the noise did something
}

// An ECU outside the simulation (the Python module, a bus port) and the built-in one are the
// same discrete-time system under command faults too: the sensors of a sample are read with
// the command in force until then, whichever ECU computes the next one. A delay, which changes
// the command the plant gets at every step, is where a difference would show.
TEST(CommandFault, AnOutsideEcuSeesTheSameFaultedPlantAsTheBuiltInOne) {
  for (const char* period : {"vehicle.ecu.period_s=0", "vehicle.ecu.period_s=0.01"}) {
    const std::vector<std::string> sets = {"solver.duration_s=40", period};
    const std::vector<std::string> faults = {"kind=delay target=driveTauRef_Nm delay_s=0.05 at_s=0",
                                             "kind=noise target=driveW_rad_s sigma=3 at_s=12 until_s=30",
                                             // what the follower reads: a sample taken before the fault began would show
                                             "kind=offset target=driverRequest_Nm offset=15 at_s=12 until_s=30"};
    Scenario sc;
    std::vector<std::string> errors;
    ASSERT_TRUE(load_scenario(test::source_path("scenarios/ev_sort1.toml"), sets, faults, sc, errors)) << errors[0];
    auto built_in = make_simulation(sc, {});
    while (!built_in->finished()) built_in->run();
    SimulationOptions opt;
    opt.external_ecu = true;
    auto outside = make_simulation(sc, opt);
    const std::int64_t ratio = sc.solver.ecu_ratio;
    while (!outside->finished()) {
      msgs::EvSensors s;
      ASSERT_TRUE(outside->read_sensors(s));
      msgs::EvCommand c;
      c.stamp = s.stamp;
      c.driveTauRef_Nm = s.driverRequest_Nm;  // what ecu::EvFollower does
      outside->write_command(c);
      outside->step(ratio);
    }
    const auto a = built_in->outputs(), b = outside->outputs();
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i], b[i]) << period << ": output " << i;
    EXPECT_GT(b[3], 50.0);  // distance_m: it drove
  }
}

// --- expectations: window edges, on time_s itself (its value at step n is n h) ---

fs::path temp_dir() {
  const fs::path d = fs::temp_directory_path() / ("ehpt_expect_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

// A test file over ev_nedc (3 s) with the given tables; its verdict.
TestVerdict verdict(const std::string& tables, std::vector<std::string>* load_errors = nullptr) {
  const fs::path file = temp_dir() / "t.toml";
  std::ofstream(file) << "scenario = \"" << test::source_path("scenarios/ev_nedc.toml") << "\"\n"
                      << "[solver]\nduration_s = 3\n" << tables;
  Scenario sc;
  std::vector<std::string> errors;
  if (!load_scenario(file.string(), {}, sc, errors)) {
    if (load_errors != nullptr) *load_errors = errors;
    return {};
  }
  EXPECT_EQ(load_errors, nullptr) << "loaded, but errors were expected";
  return run_in_memory(sc).test;
}

bool passes(const std::string& expect) {
  const TestVerdict v = verdict("[[expect]]\n" + expect + "\n");
  EXPECT_TRUE(v.present);
  EXPECT_EQ(v.expectations.size(), 1u);
  return v.present && v.passed;
}

TEST(Expect, AlwaysIsInclusiveAtBothEdgesOfItsWindow) {
  EXPECT_TRUE(passes("signal = \"time_s\"\nmax = 2.0\nfrom_s = 0\nto_s = 2.0"));
  EXPECT_FALSE(passes("signal = \"time_s\"\nmax = 2.0\nfrom_s = 0\nto_s = 2.001"));
  EXPECT_TRUE(passes("signal = \"time_s\"\nmin = 1.0\nfrom_s = 1.0"));
  EXPECT_FALSE(passes("signal = \"time_s\"\nmin = 1.0\nfrom_s = 0.999"));
  const TestVerdict v = verdict("[[expect]]\nsignal = \"time_s\"\nmax = 2.0\n");
  ASSERT_EQ(v.expectations.size(), 1u);
  EXPECT_FALSE(v.passed);
  EXPECT_DOUBLE_EQ(v.expectations[0].time_s, 2.001);  // the first step past the bound
  EXPECT_DOUBLE_EQ(v.expectations[0].value, 2.001);
}

TEST(Expect, AtEndJudgesTheLastStepOnly) {
  EXPECT_TRUE(passes("signal = \"time_s\"\nvalue = 3\ntol = 0\nwindow = \"at_end\""));
  EXPECT_FALSE(passes("signal = \"time_s\"\nmax = 2.999\nwindow = \"at_end\""));
  const TestVerdict v = verdict("[[expect]]\nsignal = \"time_s\"\nmin = -1\nmax = 3.5\n");
  ASSERT_EQ(v.expectations.size(), 1u);
  EXPECT_TRUE(v.passed);  // a passing window says where it came closest to its bound
  EXPECT_DOUBLE_EQ(v.expectations[0].time_s, 3.0);
  EXPECT_NE(v.expectations[0].message.find("held; closest time_s = 3 at t = 3 s"), std::string::npos)
      << v.expectations[0].message;
}

TEST(Expect, EventuallyNeedsOneStepInsideItsWindow) {
  EXPECT_TRUE(passes("signal = \"time_s\"\nmin = 2.5\nwindow = \"eventually\"\nto_s = 2.5"));
  EXPECT_FALSE(passes("signal = \"time_s\"\nmin = 2.5\nwindow = \"eventually\"\nto_s = 2.499"));
  const TestVerdict v = verdict("[[expect]]\nsignal = \"time_s\"\nmin = 2.5\nwindow = \"eventually\"\nto_s = 2.0\n");
  ASSERT_EQ(v.expectations.size(), 1u);
  EXPECT_DOUBLE_EQ(v.expectations[0].value, 2.0);  // the closest it came
}

TEST(Expect, NearIsWithinTolOnBothSidesAndOtherSignalsWork) {
  EXPECT_TRUE(passes("signal = \"time_s\"\nvalue = 1.5\ntol = 0.5\nfrom_s = 1\nto_s = 2"));
  EXPECT_FALSE(passes("signal = \"time_s\"\nvalue = 1.5\ntol = 0.5\nfrom_s = 0.999\nto_s = 2"));
  EXPECT_FALSE(passes("signal = \"time_s\"\nvalue = 1.5\ntol = 0.5\nfrom_s = 1\nto_s = 2.001"));
  EXPECT_TRUE(passes("signal = \"time_s\"\nother = \"time_s\"\ntol = 0"));
}

TEST(Expect, RateLimitIsPerSecond) {
  EXPECT_TRUE(passes("signal = \"time_s\"\nrate_max = 1.000001"));
  EXPECT_FALSE(passes("signal = \"time_s\"\nrate_max = 0.999999"));
}

TEST(Expect, WithinCountsFromTheFaultsStartOrEnd) {
  const std::string fault = "[[fault]]\nname = \"f\"\nkind = \"offset\"\ntarget = \"speed_m_s\"\noffset = 1\nat_s = 1\nuntil_s = 2\n";
  const auto one = [&](const std::string& expect) {
    const TestVerdict v = verdict(fault + "[[expect]]\n" + expect + "\n");
    return v.passed;
  };
  EXPECT_TRUE(one("signal = \"time_s\"\nmin = 1.5\nwindow = \"within\"\nafter = \"f.start\"\nwithin_s = 0.5"));
  EXPECT_FALSE(one("signal = \"time_s\"\nmin = 1.5\nwindow = \"within\"\nafter = \"f.start\"\nwithin_s = 0.499"));
  EXPECT_TRUE(one("signal = \"time_s\"\nmin = 2.25\nwindow = \"within\"\nafter = \"f.end\"\nwithin_s = 0.25"));
  EXPECT_FALSE(one("signal = \"time_s\"\nmin = 2.25\nwindow = \"within\"\nafter = \"f.end\"\nwithin_s = 0.249"));
  // a condition as the event; one that never holds is a failure, not a pass
  EXPECT_TRUE(one("signal = \"time_s\"\nmin = 1.2\nwindow = \"within\"\nafter = \"time_s >= 1\"\nwithin_s = 0.2"));
  const TestVerdict never = verdict(fault + "[[expect]]\nsignal = \"time_s\"\nmin = 0\nwindow = \"within\"\n"
                                            "after = \"time_s > 99\"\nwithin_s = 1\n");
  EXPECT_FALSE(never.passed);
  ASSERT_EQ(never.expectations.size(), 1u);
  EXPECT_NE(never.expectations[0].message.find("did not happen"), std::string::npos) << never.expectations[0].message;
}

// Times far past any step (1e300 s) are "never", not an overflow of the step count.
TEST(Expect, FarTimesAreNeverNotAnOverflow) {
  EXPECT_TRUE(passes("signal = \"time_s\"\nmax = 3\nto_s = 1e300"));
  const std::string fault = "[[fault]]\nname = \"f\"\nkind = \"offset\"\ntarget = \"speed_m_s\"\noffset = 1\nat_s = 1\nuntil_s = 1e300\n";
  EXPECT_TRUE(verdict(fault + "[[expect]]\nsignal = \"time_s\"\nmin = 2\nwindow = \"within\"\nafter = \"f.start\"\n"
                              "within_s = 1e300\n").passed);
}

TEST(Expect, FiguresAtTheEndAndExpectFailTurnsTheVerdict) {
  // the EV stands for NEDC's first 11 s: its SOC only falls (the inverter's magnetising draw)
  EXPECT_TRUE(passes("figure = \"soc_delta\"\nmax = 0"));
  EXPECT_FALSE(passes("figure = \"soc_delta\"\nmin = 0.001"));
  EXPECT_TRUE(passes("figure = \"distance_m\"\nmax = 0.001"));
  // the built-in ECU has no link to time out: 0 timeouts, 0 s in a safe state (over a bus:
  // tests/targets/bus_faults_e2e_test.py)
  EXPECT_TRUE(passes("figure = \"ecu_timeouts\"\nvalue = 0\ntol = 0"));
  EXPECT_FALSE(passes("figure = \"ecu_timeouts\"\nmin = 1"));
  EXPECT_TRUE(passes("figure = \"safe_state_s\"\nmax = 0"));
  EXPECT_FALSE(passes("figure = \"safe_state_s\"\nmin = 0.001"));
  const TestVerdict x = verdict("[test]\nexpect_fail = true\n[[expect]]\nfigure = \"distance_m\"\nmin = 100\n");
  EXPECT_TRUE(x.passed);
  EXPECT_FALSE(x.all_held);
  const TestVerdict y = verdict("[test]\nexpect_fail = true\n[[expect]]\nfigure = \"distance_m\"\nmax = 100\n");
  EXPECT_FALSE(y.passed);  // written to fail, but it held
  // ... and says so where a failure is read (ehpt run --quiet, a sweep's message, results.csv)
  EXPECT_EQ(y.first_failure, "written to fail (expect_fail = true), but every expectation held");
}

// --- load-time rules: each one named with file:line and a hint ---

std::string first_error(const std::string& tables) {
  std::vector<std::string> errors;
  verdict(tables, &errors);
  return errors.empty() ? "" : errors[0];
}

TEST(FaultRules, EachImpossibleFaultIsALoadErrorWithItsLine) {
  const auto has = [](const std::string& e, const std::string& what) {
    EXPECT_NE(e.find(what), std::string::npos) << e << "\n  (wanted: " << what << ")";
    EXPECT_NE(e.find("t.toml:"), std::string::npos) << e;
  };
  has(first_error("[[fault]]\nkind = \"stuk\"\ntarget = \"speed_m_s\"\n"), "did you mean \"stuck\"");
  has(first_error("[[fault]]\nkind = \"stuck\"\ntarget = \"sped_m_s\"\n"), "did you mean \"speed_m_s\"");
  has(first_error("[[fault]]\nkind = \"stuck\"\n"), "target: missing");
  has(first_error("[[fault]]\nkind = \"offset\"\ntarget = \"speed_m_s\"\n"), "needs offset");
  has(first_error("[[fault]]\nkind = \"offset\"\ntarget = \"speed_m_s\"\noffset = 1\nsigma = 2\n"), "not a parameter of kind = \"offset\"");
  has(first_error("[[fault]]\nkind = \"noise\"\ntarget = \"speed_m_s\"\nsigma = 0\n"), "sigma = 0: must be a finite number > 0");
  has(first_error("[[fault]]\nkind = \"stuck\"\ntarget = \"speed_m_s\"\nat_s = 2\nuntil_s = 2\n"), "must be later than at_s");
  has(first_error("[[fault]]\nkind = \"stuck\"\ntarget = \"speed_m_s\"\nat_s = -1\n"), "at_s = -1");
  has(first_error("[[fault]]\nkind = \"stuck\"\ntarget = \"speed_m_s\"\nat_s = 5\n"), "after the run's end");
  has(first_error("[[fault]]\nkind = \"intermittent\"\ntarget = \"speed_m_s\"\nperiod_s = 0.1\nduty = 1\n"), "duty = 1: must be in (0, 1)");
  has(first_error("[[fault]]\nkind = \"delay\"\ntarget = \"speed_m_s\"\ndelay_s = 0.015\n"), "whole multiple");
  has(first_error("[[fault]]\nkind = \"no_start\"\n"), "no_start");
  has(first_error("[[fault]]\nkind = \"stuck\"\ntarget = \"speed_m_s\"\nwhen = \"speed_m_s >> 3\"\n"), "expected SIGNAL < NUMBER");
  has(first_error("[[fault]]\nname = \"a\"\nkind = \"stuck\"\ntarget = \"speed_m_s\"\n[[fault]]\nname = \"a\"\nkind = \"stuck\"\ntarget = \"batSOC\"\n"),
      "another fault has this name");
  std::string many;
  for (int i = 0; i < 33; ++i) many += "[[fault]]\nkind = \"stuck\"\ntarget = \"speed_m_s\"\n";
  has(first_error(many), "more than 32 faults");
}

TEST(ExpectRules, EachImpossibleExpectationIsALoadErrorWithItsLine) {
  const auto has = [](const std::string& e, const std::string& what) { EXPECT_NE(e.find(what), std::string::npos) << e; };
  has(first_error("[[expect]]\nsignal = \"time_s\"\n"), "missing: a bound");
  has(first_error("[[expect]]\nsignal = \"tme_s\"\nmax = 1\n"), "did you mean \"time_s\"");
  has(first_error("[[expect]]\nsignal = \"time_s\"\nmin = 2\nmax = 1\n"), "nothing could pass");
  has(first_error("[[expect]]\nsignal = \"time_s\"\nvalue = 1\n"), "need tol");
  has(first_error("[[expect]]\nsignal = \"time_s\"\nvalue = 1\ntol = -0.1\n"), "tol = -0.1");
  has(first_error("[[expect]]\nsignal = \"time_s\"\nmax = 1\nwindow = \"sometimes\"\n"), "unknown window");
  has(first_error("[[expect]]\nfigure = \"soc_end\"\nmin = 0\nwindow = \"always\"\n"), "a figure is checked at the end");
  has(first_error("[[expect]]\nfigure = \"soc_ned\"\nmin = 0\n"), "did you mean \"soc_end\"");
  has(first_error("[[expect]]\nsignal = \"time_s\"\nmax = 1\nwindow = \"within\"\nwithin_s = 1\n"), "needs the event");
  has(first_error("[[expect]]\nsignal = \"time_s\"\nmax = 1\nwindow = \"within\"\nafter = \"nofault.start\"\nwithin_s = 1\n"),
      "no fault is named \"nofault\"");
  has(first_error("[[expect]]\nsignal = \"time_s\"\nmax = 1\nfrom_s = 5\n"), "after the run's end");
  has(first_error("[[expect]]\nsignal = \"time_s\"\nmax = 1\nto_s = 0.5\nfrom_s = 1\n"), "must be >= from_s");
  has(first_error("[[expect]]\nsignal = \"time_s\"\nrate_max = 1\nwindow = \"eventually\"\n"), "a rate limit holds always");
}

// Every other rule of [[fault]], [[expect]], --fault and a test file's scenario = ..., one each
// (docs/validation-rules.md: each planted, each caught).
bool any_error(const std::string& tables, const std::string& what, const std::vector<std::string>& faults = {},
               const char* base = "scenarios/ev_nedc.toml") {
  const fs::path file = temp_dir() / "t.toml";
  std::ofstream(file) << "scenario = \"" << test::source_path(base) << "\"\n[solver]\nduration_s = 3\n" << tables;
  Scenario sc;
  std::vector<std::string> errors;
  load_scenario(file.string(), {}, faults, sc, errors);
  for (const auto& e : errors) {
    if (e.find(what) != std::string::npos) return true;
  }
  ADD_FAILURE() << "no error with \"" << what << "\"; got " << (errors.empty() ? "none" : errors[0]);
  return false;
}

// Bus faults: every reader rule (the message itself is checked on the binding:
// tests/hil/bus_faults_test.cpp). The base is an EV: EvSensors1..3, EvCommand.
TEST(FaultRules, BusFaultRules) {
  const std::string drop = "[[fault]]\nkind = \"drop\"\ntarget = \"EvCommand\"\n";
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"drop\"\n", "missing: the message whose frames it acts on"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"bus_off\"\ntarget = \"EvCommand\"\n", "acts on the whole bus"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"drop\"\ntarget = \"bus\"\n", "acts on one message's frames"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"corrupt\"\ntarget = \"EvCommand\"\nbyte = 64\n", "must be a byte of the frame"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"corrupt\"\ntarget = \"EvCommand\"\nbyte = -1\n", "must be a byte of the frame"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"corrupt\"\ntarget = \"EvCommand\"\nmask = 0\n", "mask = 0: must be 1 .. 255"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"corrupt\"\ntarget = \"EvCommand\"\nmask = 256\n", "must be 1 .. 255"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"counter_jump\"\ntarget = \"EvCommand\"\njump = 0\n", "jump = 0: must be a whole number 1 .. 65535"));
  EXPECT_TRUE(any_error(drop + "probability = 0\n", "probability = 0: must be in (0, 1]"));
  EXPECT_TRUE(any_error(drop + "probability = 1.5\n", "must be in (0, 1]"));
  EXPECT_TRUE(any_error(drop + "pattern = \"0120\"\n", "must be 1 .. 1000 characters of 0 and 1"));
  EXPECT_TRUE(any_error(drop + "pattern = \"000\"\n", "at least one 1"));
  EXPECT_TRUE(any_error(drop + "pattern = \"01\"\nprobability = 0.5\n", "give probability or pattern, not both"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"period\"\ntarget = \"EvCommand\"\nperiod_s = 0.015\n",
                        "must be a whole multiple of the ECU period"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"period\"\ntarget = \"EvCommand\"\nperiod_s = 0.01\n", "at least two"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"period\"\ntarget = \"EvCommand\"\nperiod_s = 1e5\n", "more than 1e6 samples"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"delay\"\ntarget = \"EvCommand\"\ndelay_s = 0.015\n",
                        "delayed by whole ECU periods"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"delay\"\ntarget = \"EvCommand\"\ndelay_s = 20\n", "frames wait in a ring"));
  // a delay on a typo of a field is named as one, not taken for a message
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"delay\"\ntarget = \"sped_m_s\"\ndelay_s = 0.01\n", "did you mean \"speed_m_s\""));
  // pattern from --fault is text (0011 is no number), so its own rule judges it
  EXPECT_TRUE(any_error("", "give probability or pattern, not both", {"kind=drop target=EvCommand pattern=0011 probability=0.5"}));
}

// A good bus fault loads with its parameters, on the bus side.
TEST(FaultRules, BusFaultsLoadWithTheirParameters) {
  const fs::path file = temp_dir() / "bus.toml";
  std::ofstream(file) << "scenario = \"" << test::source_path("scenarios/ev_nedc.toml") << "\"\n[solver]\nduration_s = 3\n"
                      << "[[fault]]\nkind = \"corrupt\"\ntarget = \"EvCommand\"\nbyte = 3\nmask = 0x10\n"
                      << "[[fault]]\nkind = \"delay\"\ntarget = \"EvSensors2\"\ndelay_s = 0.02\n"
                      << "[[fault]]\nkind = \"bus_off\"\nat_s = 1\nuntil_s = 2\n";
  Scenario sc;
  std::vector<std::string> errors;
  ASSERT_TRUE(load_scenario(file.string(), {}, {"kind=drop target=EvSensors1 pattern=0011 seed=5"}, sc, errors))
      << (errors.empty() ? "" : errors[0]);
  ASSERT_EQ(sc.faults.size(), 4u);
  for (const FaultSpec& f : sc.faults) EXPECT_EQ(f.side, FaultSide::kBus) << f.target;
  EXPECT_EQ(sc.faults[0].byte, 3);
  EXPECT_EQ(sc.faults[0].mask, 0x10);
  EXPECT_EQ(sc.faults[1].effect, FaultEffect::kDelay);
  EXPECT_DOUBLE_EQ(sc.faults[1].delay_s, 0.02);
  EXPECT_EQ(sc.faults[2].target, "bus");
  EXPECT_EQ(sc.faults[3].pattern, "0011");
  EXPECT_EQ(sc.faults[3].seed, 5u);
  // and a run without a bus refuses them, naming the first
  const std::string why = bus_faults_refused(sc, nullptr);
  EXPECT_NE(why.find("bus.toml:4: kind = \"corrupt\" on EvCommand acts on CAN frames"), std::string::npos) << why;
  sc.faults.erase(sc.faults.begin(), sc.faults.begin() + 3);
  sc.faults.erase(sc.faults.begin());
  EXPECT_EQ(bus_faults_refused(sc, nullptr), "");
}

TEST(FaultRules, EveryOtherFaultRule) {
  const std::string f = "[[fault]]\nkind = \"stuck\"\ntarget = \"speed_m_s\"\n";
  EXPECT_TRUE(any_error("[[fault]]\ntarget = \"speed_m_s\"\n", "kind: missing"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"no_start\"\ntarget = \"speed_m_s\"\n", "acts on the engine: leave target out"));
  EXPECT_TRUE(any_error(f + "until_s = 2\nduration_s = 1\n", "give until_s or duration_s, not both"));
  EXPECT_TRUE(any_error(f + "duration_s = 0\n", "duration_s = 0: must be > 0 s"));
  EXPECT_TRUE(any_error(f + "at_s = 1\nwhen = \"speed_m_s > 1\"\n", "give at_s or when, not both"));
  EXPECT_TRUE(any_error(f + "when = \"speed_m_s > 1\"\nduration_s = 1\n", "ends at until_s, an absolute time"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"noise\"\ntarget = \"speed_m_s\"\nsigma = 1\nseed = -1\n", "seed = -1: must be >= 0"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"offset\"\ntarget = \"speed_m_s\"\noffset = inf\n", "offset = inf: must be a finite number"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"saturate\"\ntarget = \"driveTauRef_Nm\"\nlimit = -1\n", "limit = -1: must be a finite number >= 0"));
  EXPECT_TRUE(any_error(f + "when = \"sped_m_s > 1\"\n", "when = \"sped_m_s\": not an output of this vehicle"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"stuck\"\ntarget = \"locked\"\n", "status bits are not a sensor value"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"delay\"\ntarget = \"driveTauRef_Nm\"\ndelay_s = 0.0005\n",
                        "must be a whole multiple of the plant step"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"delay\"\ntarget = \"speed_m_s\"\ndelay_s = 20000\n", "more than 1e6 samples"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"intermittent\"\ntarget = \"speed_m_s\"\nperiod_s = 0.0015\n",
                        "period_s = 0.0015: must be a whole multiple of the plant step"));
  EXPECT_TRUE(any_error("[[fault]]\nkind = \"intermittent\"\ntarget = \"speed_m_s\"\nperiod_s = 1e300\n", "more than 1e10 steps"));
  // a rig has no ECU messages
  EXPECT_TRUE(any_error(f, "this vehicle has no ECU messages to fault", {}, "scenarios/battery_cc_discharge.toml"));
  // --fault texts
  EXPECT_TRUE(any_error("", "one fault per --fault, on one line", {"kind=stuck\ntarget=speed_m_s"}));
  EXPECT_TRUE(any_error("", "expected key=value", {"stuck target=speed_m_s"}));
  EXPECT_TRUE(any_error("", "not a fault key", {"Kind=stuck target=speed_m_s"}));
  EXPECT_TRUE(any_error("", "kind is given twice", {"kind=stuck kind=fixed target=speed_m_s"}));
  // a test file's scenario
  EXPECT_TRUE(any_error("", "no_such_scenario': no such scenario file or name", {}, "no_such_scenario"));
  const fs::path base = temp_dir() / "base.toml";
  std::ofstream(base) << "scenario = \"ev_nedc\"\n";
  const fs::path file = temp_dir() / "t2.toml";
  std::ofstream(file) << "scenario = \"" << base.string() << "\"\n";
  Scenario sc;
  std::vector<std::string> errors;
  EXPECT_FALSE(load_scenario(file.string(), {}, sc, errors));
  ASSERT_FALSE(errors.empty());
  EXPECT_NE(errors[0].find("names another scenario itself"), std::string::npos) << errors[0];
}

TEST(ExpectRules, EveryOtherExpectationRule) {
  const std::string e = "[[expect]]\nsignal = \"time_s\"\n";
  EXPECT_TRUE(any_error(e + "figure = \"soc_end\"\nmax = 1\n", "give either signal"));
  EXPECT_TRUE(any_error(e + "value = 1\nother = \"time_s\"\ntol = 1\n", "give value or other, not both"));
  EXPECT_TRUE(any_error(e + "max = 1\ntol = 1\n", "tol bounds"));
  EXPECT_TRUE(any_error(e + "min = -inf\n", "min = -inf: must be finite"));
  EXPECT_TRUE(any_error(e + "rate_max = -1\n", "rate_max = -1: must be a finite number >= 0 (per second)"));
  EXPECT_TRUE(any_error("[[expect]]\nfigure = \"soc_end\"\nrate_max = 1\n", "a figure takes min, max or value with tol"));
  EXPECT_TRUE(any_error(e + "max = 1\nwindow = \"at_end\"\nfrom_s = 1\n", "only windows always and eventually take from_s"));
  EXPECT_TRUE(any_error(e + "max = 1\nfrom_s = -1\n", "from_s = -1: must be a finite time >= 0 s"));
  EXPECT_TRUE(any_error(e + "max = 1\nwindow = \"within\"\nafter = \"time_s > 1\"\n", "needs within_s"));
  EXPECT_TRUE(any_error(e + "max = 1\nafter = \"time_s > 1\"\n", "only window = \"within\" takes after and within_s"));
  EXPECT_TRUE(any_error(e + "max = 1\nwindow = \"within\"\nafter = \"time_s ~ 1\"\nwithin_s = 1\n",
                        "or name a fault's start or end"));
  EXPECT_TRUE(any_error(e + "max = 1\nwindow = \"within\"\nafter = \"tme_s > 1\"\nwithin_s = 1\n",
                        "after = \"tme_s\": not an output of this vehicle"));
  EXPECT_TRUE(any_error(e + "max = 1\nother = \"tme_s\"\ntol = 1\n", "other = \"tme_s\": not an output"));
  EXPECT_TRUE(any_error(e + "name = \"a\"\nmax = 9\n" + e + "name = \"a\"\nmax = 9\n", "another expectation has this name"));
}

}  // namespace
}  // namespace ehpt::hil
