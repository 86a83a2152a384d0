// SPDX-License-Identifier: BSD-3-Clause
// The runner's policies, each on its own: Metrics, Recorder, FaultPolicy and the pacers'
// timing (on a fake clock).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <thread>
#include <vector>

#include "ecu/ev_follower.hpp"
#include "hil/run/latency_histogram.hpp"
#include "hil/run/row_queue.hpp"
#include "hil/run/trajectory_hash.hpp"
#include "hil/run/metrics.hpp"
#include "hil/run/pacer.hpp"
#include "hil/run/recorder.hpp"
#include "hil/run/runner.hpp"
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
  R stop(plant, {.total_steps = 20000, .decimation = 1000, .columns = {0}, .chunk_steps = 20000}, &f1);
  R hold(plant,
         {.total_steps = 20000, .decimation = 1000, .columns = {0}, .chunk_steps = 20000, .fault_policy = FaultPolicy::kHold},
         &f2);
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
}

// The real-time pacer on a fake clock: every wake-up lands `latency` after its deadline.
struct LateClock {
  std::int64_t t = 5000, latency = 0;
  std::vector<std::int64_t> deadlines;
  std::int64_t now_ns() const { return t; }
  void sleep_until_ns(std::int64_t deadline) {
    deadlines.push_back(deadline);
    if (deadline > t) t = deadline + latency;
  }
};

TEST(TickPacer, DeadlinesAreAbsoluteAndTheLatencyIsMeasuredFromThem) {
  LateClock clock;
  clock.latency = 7;
  TickTiming timing;
  TickPacer<LateClock> pacer(clock, 1000, timing);
  pacer.start();  // tick 0 at t = 5000
  for (int k = 1; k <= 50; ++k) {
    clock.t += 300;  // the tick's work
    ASSERT_TRUE(pacer.wait_next_tick());
  }
  // a late wake-up is not carried into the next deadline: still 5000 + k 1000
  ASSERT_EQ(clock.deadlines.size(), 50u);
  for (std::size_t k = 0; k < clock.deadlines.size(); ++k) {
    EXPECT_EQ(clock.deadlines[k], 5000 + 1000 * static_cast<std::int64_t>(k + 1));
  }
  EXPECT_EQ(timing.ticks, 51);
  EXPECT_EQ(timing.overruns, 0);
  EXPECT_EQ(timing.wakeup.count(), 51);   // tick 0 counts as on time
  EXPECT_EQ(timing.wakeup.max_ns(), 7);
  EXPECT_EQ(timing.wakeup.quantile_ns(0.5), 7);
}

TEST(TickPacer, AnOverrunSkipsTheMissedTicksCountsThemAndNeverBursts) {
  LateClock clock;
  TickTiming timing;
  TickPacer<LateClock> pacer(clock, 1000, timing);
  pacer.start();
  const std::vector<std::int64_t> work = {100, 100, 3500, 100, 999, 1000, 100};
  std::vector<std::int64_t> woke;
  for (const std::int64_t w : work) {
    clock.t += w;
    ASSERT_TRUE(pacer.wait_next_tick());
    woke.push_back(clock.t);
  }
  // 3500 ns from 7000 ends at 10500: ticks 3 (8000), 4 (9000) and 5 (10000) are skipped, the
  // loop waits for 11000; 999 ns fits; 1000 ns ends exactly on the next deadline (on time);
  // never two ticks without a sleep to their own deadline
  EXPECT_EQ(woke, (std::vector<std::int64_t>{6000, 7000, 11000, 12000, 13000, 14000, 15000}));
  EXPECT_EQ(timing.overruns, 1);
  EXPECT_EQ(timing.missed_ticks, 3);
  EXPECT_EQ(pacer.tick(), 10);
  for (std::size_t k = 1; k < woke.size(); ++k) EXPECT_GE(woke[k] - woke[k - 1], 1000);
}

TEST(TickPacer, AStopRaisedWhileSleepingEndsTheWaitWithoutATick) {
  // a clock whose sleep is cut short (a signal): the pacer sleeps again unless stop is set
  struct Interrupted {
    std::int64_t t = 0;
    int sleeps = 0;
    std::int64_t now_ns() const { return t; }
    void sleep_until_ns(std::int64_t deadline) {
      ++sleeps;
      t = sleeps == 1 ? deadline - 10 : deadline;  // the first sleep is interrupted
    }
  } clock;
  TickTiming timing;
  TickPacer<Interrupted> pacer(clock, 100, timing);
  pacer.start();
  EXPECT_TRUE(pacer.wait_next_tick());  // interrupted once, slept again: on time
  EXPECT_EQ(clock.sleeps, 2);
  std::atomic<int> stop{0};
  clock.sleeps = 0;
  stop = 2;
  EXPECT_FALSE(pacer.wait_next_tick(&stop));
  EXPECT_EQ(timing.ticks, 2);
}

TEST(LatencyHistogram, QuantilesAreWithinTheBinResolution) {
  // exact below 128 ns; above, each bin's upper edge is within 1/64 of every value in it
  for (std::int64_t v : {0LL, 1LL, 127LL, 128LL, 129LL, 1000LL, 25'000LL, 1'400'000LL, 1LL << 40}) {
    const int b = LatencyHistogram::bin_of(v);
    EXPECT_GE(LatencyHistogram::upper_edge(b), v) << v;
    EXPECT_LE(static_cast<double>(LatencyHistogram::upper_edge(b)), static_cast<double>(v) * (1.0 + 1.0 / 64) + 0.5) << v;
    if (b > 0) {
      EXPECT_LT(LatencyHistogram::upper_edge(b - 1), v) << v;
    }
  }
  EXPECT_LT(LatencyHistogram::bin_of(std::numeric_limits<std::int64_t>::max()), LatencyHistogram::kBins);
  LatencyHistogram small;  // 1 .. 100 ns: every value has its own bin, the quantiles are exact
  for (int v = 100; v >= 1; --v) small.record(v);
  EXPECT_EQ(small.quantile_ns(0.01), 1);
  EXPECT_EQ(small.quantile_ns(0.5), 50);
  EXPECT_EQ(small.quantile_ns(0.99), 99);
  EXPECT_EQ(small.quantile_ns(1.0), 100);
  EXPECT_DOUBLE_EQ(small.mean_ns(), 50.5);
  LatencyHistogram h;
  std::vector<std::int64_t> values;
  std::mt19937_64 rng(7);
  std::lognormal_distribution<double> dist(10.0, 1.0);  // around 22 us, a long tail
  for (int i = 0; i < 100000; ++i) values.push_back(static_cast<std::int64_t>(dist(rng)));
  for (const auto v : values) h.record(v);
  std::sort(values.begin(), values.end());
  for (const double q : {0.5, 0.99, 0.999}) {
    const auto exact = values[static_cast<std::size_t>(std::ceil(q * 100000)) - 1];
    EXPECT_GE(h.quantile_ns(q), exact) << q;
    EXPECT_LE(static_cast<double>(h.quantile_ns(q)), static_cast<double>(exact) * (1.0 + 1.0 / 64) + 1) << q;
  }
  EXPECT_EQ(h.max_ns(), values.back());
  EXPECT_EQ(h.quantile_ns(1.0), values.back());
  h.record(-5);  // a clock that went back: 0, not a crash
  EXPECT_EQ(h.count(), 100001);
}

TEST(RowQueue, RowsArriveInOrderAcrossThreadsAndAFullQueueDropsNotWaits) {
  RowQueue q(3, 8);
  std::vector<double> rows;
  for (int r = 0; r < 10; ++r) rows.insert(rows.end(), {double(r), double(r) + 0.5, -double(r)});
  EXPECT_EQ(q.push(rows), 2u);  // room for 8 of 10
  EXPECT_EQ(q.dropped(), 2);
  std::vector<double> got;
  EXPECT_EQ(q.pop_all([&](std::span<const double> row) { got.insert(got.end(), row.begin(), row.end()); }), 8u);
  EXPECT_EQ(got, std::vector<double>(rows.begin(), rows.begin() + 24));
  // a producer and a consumer thread: every row, in order, nothing dropped when it keeps up
  RowQueue big(2, 1024);
  constexpr int kRows = 200000;
  std::vector<double> seen;
  seen.reserve(2 * kRows);
  std::atomic<bool> done{false};
  std::thread consumer([&] {
    for (;;) {
      const bool last = done.load();
      big.pop_all([&](std::span<const double> row) { seen.insert(seen.end(), row.begin(), row.end()); });
      if (last) break;
    }
  });
  std::int64_t dropped = 0;
  for (int r = 0; r < kRows; ++r) {
    const double row[2] = {double(r), -double(r)};
    while (big.push(row) != 0) ++dropped;  // the test waits; the loop would count and go on
  }
  done = true;
  consumer.join();
  ASSERT_EQ(seen.size(), 2u * kRows);
  for (int r = 0; r < kRows; ++r) {
    ASSERT_EQ(seen[2 * static_cast<std::size_t>(r)], double(r));
    ASSERT_EQ(seen[2 * static_cast<std::size_t>(r) + 1], -double(r));
  }
  EXPECT_EQ(big.dropped(), dropped);
}

TEST(TrajectoryHash, SeesEveryBitAndTheOrder) {
  TrajectoryHash a, b, c, d;
  const double x[3] = {1.0, 2.0, 3.0};
  const double y[3] = {1.0, 2.0, std::nextafter(3.0, 4.0)};
  const double z[3] = {2.0, 1.0, 3.0};
  a.add(x);
  b.add(y);
  c.add(z);
  d.add(std::span<const double>(x, 1));
  d.add(std::span<const double>(x + 1, 2));  // in pieces: the same
  EXPECT_NE(a.value(), b.value());
  EXPECT_NE(a.value(), c.value());
  EXPECT_EQ(a.value(), d.value());
  EXPECT_EQ(a.hex().size(), 16u);
  EXPECT_EQ(TrajectoryHash().hex(), "cbf29ce484222325");  // FNV-1a's offset basis: nothing added
}

}  // namespace
}  // namespace ehpt::hil
