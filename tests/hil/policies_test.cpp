// The runner's policies, each on its own: Metrics, Recorder, FaultPolicy and the pacers'
// timing (on a fake clock).
#include <gtest/gtest.h>

#include <vector>

#include "ecu/ev_follower.hpp"
#include "hil/metrics.hpp"
#include "hil/pacer.hpp"
#include "hil/recorder.hpp"
#include "hil/runner.hpp"
#include "plant/bev_plant.hpp"
#include "solvers/integrators.hpp"
#include "test_plants.hpp"

namespace ehpt::hil {
namespace {

struct Y {
  double ref = 0, v = 0, locked = 0, on = 0, other = 0;
};
constexpr plant::MetricSources<Y> kAll{.speed_ref_m_s = &Y::ref, .speed_m_s = &Y::v, .locked = &Y::locked,
                                       .engine_on = &Y::on};

TEST(Metrics, SpeedErrorOverEveryGridPointInKmh) {
  Metrics<Y> m(kAll, 0.5);
  m.observe(0, {.ref = 10.0, .v = 10.0});
  m.observe(1, {.ref = 10.0, .v = 9.0});   // 3.6 km/h
  m.observe(2, {.ref = 10.0, .v = 12.0});  // -7.2 km/h
  EXPECT_EQ(m.totals().speed_samples, 3);
  EXPECT_DOUBLE_EQ(m.totals().speed_error_max_kmh, 7.2);
  EXPECT_DOUBLE_EQ(m.totals().speed_error_rms_kmh(), std::sqrt((3.6 * 3.6 + 7.2 * 7.2) / 3.0));
}

TEST(Metrics, LockedTimeCountsStepsThatEndLocked) {
  Metrics<Y> m(kAll, 0.25);
  for (int n = 0; n <= 8; ++n) m.observe(n, {.locked = (n <= 2 || n == 7) ? 1.0 : 0.0});
  EXPECT_DOUBLE_EQ(m.totals().locked_time_s, 3 * 0.25);  // steps ending at 1, 2 and 7; not t = 0
}

TEST(Metrics, EngineOnTimeAndStarts) {
  Metrics<Y> m(kAll, 1.0);
  // on at 0 and off at the end, so that counting the steps' ends instead of their starts
  // (or the other way round) gives a different time
  const std::vector<double> on = {1, 1, 0, 0, 1, 1, 1, 0, 0};  // on at 0 and 4: two starts
  for (std::size_t n = 0; n < on.size(); ++n) m.observe(static_cast<std::int64_t>(n), {.on = on[n]});
  EXPECT_EQ(m.totals().engine_starts, 2);
  // on during the steps that start at 0, 1, 4, 5, 6 (the last grid point starts no step)
  EXPECT_DOUBLE_EQ(m.totals().engine_on_time_s, 5.0);
}

TEST(Metrics, AVehicleWithoutASourceHasNoSuchMetric) {
  Metrics<Y> m(plant::MetricSources<Y>{}, 1.0);
  m.observe(0, {.ref = 5.0, .v = 0.0, .locked = 1.0, .on = 1.0});
  m.observe(1, {.ref = 5.0, .v = 0.0, .locked = 1.0, .on = 1.0});
  EXPECT_FALSE(m.totals().has_speed);
  EXPECT_FALSE(m.totals().has_engine);
  EXPECT_EQ(m.totals().speed_samples, 0);
  EXPECT_EQ(m.totals().engine_starts, 0);
  EXPECT_EQ(m.totals().locked_time_s, 0.0);
}

TEST(Recorder, RowsOfChosenColumnsEveryNthStepOncePerStepAndDropsWhatDoesNotFit) {
  const std::vector<plant::Signal<Y>> signals = {{"ref", &Y::ref, ""}, {"v", &Y::v, ""}, {"other", &Y::other, ""}};
  Recorder<Y> r(signals, {2, 1}, 3, 6);  // columns other, v; every 3rd step; room for 6/3 + 4 rows
  EXPECT_TRUE(r.due(0));
  EXPECT_FALSE(r.due(1));
  EXPECT_TRUE(r.due(3));
  r.record(0, {.v = 1.0, .other = 2.0});
  r.record(0, {.v = 9.0, .other = 9.0});  // once per step
  ASSERT_EQ(r.rows().size(), 2u);
  EXPECT_EQ(r.rows()[0], 2.0);
  EXPECT_EQ(r.rows()[1], 1.0);
  for (int n = 1; n <= 10; ++n) r.record(n, {});
  EXPECT_EQ(r.rows().size(), 2u * 6u);  // full
  EXPECT_EQ(r.dropped(), 5);
  r.clear();
  EXPECT_TRUE(r.rows().empty());
}

// A run whose SOC leaves its window: stop (batch) or hold on (HIL), the first fault recorded.
TEST(FaultPolicy, StopEndsTheRunHoldKeepsItGoing) {
  const test::ExpectFault expected;
  plant::BevParams p = test::mbev();
  p.battery.soc_min = 0.6999;
  const plant::BevPlant plant(p);
  using R = Runner<plant::BevPlant, solvers::Rk4<plant::BevPlant>, ecu::EvFollower>;
  ecu::EvFollower f1, f2;
  R stop(plant, 1e-3, 20000, 1000, {0}, 20000, &f1, 1, 0, nullptr, FaultPolicy::kStop);
  R hold(plant, 1e-3, 20000, 1000, {0}, 20000, &f2, 1, 0, nullptr, FaultPolicy::kHold);
  stop.run();
  hold.run();
  EXPECT_TRUE(stop.finished());
  EXPECT_LT(stop.step_index(), 20000);
  EXPECT_EQ(hold.step_index(), 20000);
  EXPECT_EQ(stop.stats().fault, plant::kFaultSocWindow);
  EXPECT_EQ(hold.stats().fault, plant::kFaultSocWindow);
  EXPECT_EQ(hold.stats().fault_step, stop.stats().fault_step);  // the first one, in both
  // counted: once where it stops, every grid point after it where it holds (SOC keeps falling)
  EXPECT_EQ(stop.stats().fault_steps, 1);
  EXPECT_EQ(hold.stats().fault_steps, 20000 - hold.stats().fault_step + 1);
}

TEST(Pacer, TickAfterIsTheNextTickOrSkipsTheMissedOnes) {
  // ticks every 10 ns from t = 100
  EXPECT_EQ(tick_after(0, 105, 100, 10).tick, 1);   // on time: the next tick
  EXPECT_EQ(tick_after(0, 105, 100, 10).missed, 0);
  EXPECT_EQ(tick_after(0, 110, 100, 10).tick, 1);   // exactly at the next tick: still it
  const NextTick late = tick_after(0, 135, 100, 10);  // ticks 1, 2, 3 passed during the step
  EXPECT_EQ(late.tick, 4);
  EXPECT_EQ(late.missed, 3);
}

// A clock that only moves when told: sleeping jumps to the deadline, a step costs `work`.
struct FakeClock {
  std::int64_t t = 1000;
  std::vector<std::int64_t> wakeups;
  std::int64_t now_ns() const { return t; }
  void sleep_until_ns(std::int64_t deadline) {
    if (deadline > t) t = deadline;
    wakeups.push_back(t);
  }
};

TEST(Pacer, WallClockKeepsThePeriodAndNeverCatchesUpInABurst) {
  FakeClock clock;
  WallClock<FakeClock> pacer(clock, 100);
  pacer.wait_for_step(0);  // start at t = 1000
  const std::vector<std::int64_t> work = {10, 10, 350, 10, 10};  // the third step overruns
  for (std::size_t n = 1; n <= work.size(); ++n) {
    clock.t += work[n - 1];
    pacer.wait_for_step(static_cast<std::int64_t>(n));
  }
  // due at 1100, 1200; the 350 ns step ends at 1550: ticks 3, 4 and 5 are skipped, it waits
  // for 1600; then on the grid again
  EXPECT_EQ(clock.wakeups, (std::vector<std::int64_t>{1100, 1200, 1600, 1700, 1800}));
  EXPECT_EQ(pacer.missed_ticks(), 3);
  AsFastAsPossible fast;
  fast.wait_for_step(5);  // never waits: nothing to check but that it exists for the runner
}

}  // namespace
}  // namespace ehpt::hil
