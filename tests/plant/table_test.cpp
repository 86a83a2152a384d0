// SPDX-License-Identifier: BSD-3-Clause
#include "plant/table.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

namespace ehpt::plant {
namespace {

TEST(Table1d, InterpolatesLinearlyAndExtrapolates) {
  const Table1d lin({0.0, 1.0, 3.0}, {0.0, 2.0, 6.0}, Extrapolation::kLinear);
  EXPECT_DOUBLE_EQ(lin(0.5), 1.0);
  EXPECT_DOUBLE_EQ(lin(2.0), 4.0);
  EXPECT_DOUBLE_EQ(lin(4.0), 8.0);    // last two points
  EXPECT_DOUBLE_EQ(lin(-1.0), -2.0);  // first two points
  const Table1d hold({0.0, 1.0, 3.0}, {0.0, 2.0, 6.0}, Extrapolation::kHold);
  EXPECT_DOUBLE_EQ(hold(4.0), 6.0);
  EXPECT_DOUBLE_EQ(hold(-1.0), 0.0);
}

TEST(Table1d, RepeatedStampIsAStepTakingTheLaterRow) {
  // NEDC-like gear change: same time twice
  const Table1d t({0.0, 10.0, 10.0, 20.0}, {0.0, 5.0, 7.0, 7.0}, Extrapolation::kHold);
  EXPECT_DOUBLE_EQ(t(9.999999), 5.0 * 9.999999 / 10.0);
  EXPECT_DOUBLE_EQ(t(10.0), 7.0);
  EXPECT_DOUBLE_EQ(t(15.0), 7.0);
  EXPECT_TRUE(std::isfinite(t(10.0)));
}

TEST(Table1d, IndexedLookupMatchesBruteForceEverywhere) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> step(0.0, 3.0);
  std::vector<double> x{0.0}, y{1.0};
  for (int i = 0; i < 300; ++i) {
    x.push_back(x.back() + (i % 17 == 5 ? 0.0 : step(rng)));  // some repeats, not at the ends
    y.push_back(std::sin(0.1 * i));
  }
  const Table1d t(x, y, Extrapolation::kLinear);
  std::uniform_real_distribution<double> u(-5.0, x.back() + 5.0);
  for (int k = 0; k < 20000; ++k) {
    const double q = u(rng);
    // reference: last i with x[i] <= q, within [0, n-2]
    std::size_t i = 0;
    while (i + 2 < x.size() && x[i + 1] <= q) ++i;
    const double dx = x[i + 1] - x[i];
    const double ref = dx > 0.0 ? y[i] + (y[i + 1] - y[i]) / dx * (q - x[i]) : y[i + 1];
    ASSERT_NEAR(t(q), ref, 1e-12) << "at " << q;
  }
}

TEST(Table1d, ValidateNamesRowAndProblem) {
  Problems p;
  validate(Table1d({0.0, 2.0, 1.0}, {0.0, 0.0, 0.0}, Extrapolation::kHold), "driver.cycle", true, p);
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p.list()[0].field, "driver.cycle");
  EXPECT_EQ(p.list()[0].row, 2);
  EXPECT_EQ(p.list()[0].column, 0);  // the axis
  EXPECT_EQ(p.list()[0].value, "1");
  Problems q;
  validate(Table1d({0.0, 1.0}, {0.0, std::nan("")}, Extrapolation::kHold), "road.slope", false, q);
  ASSERT_EQ(q.size(), 1u);
  EXPECT_EQ(q.list()[0].row, 1);
  EXPECT_EQ(q.list()[0].column, 1);  // the values
  EXPECT_EQ(q.list()[0].value, "nan");
  Problems r;
  validate(Table1d({0.0}, {0.0}, Extrapolation::kHold), "x", false, r);
  EXPECT_EQ(r.size(), 1u);
}

TEST(Table2d, BilinearIsExactForBilinearFunctionsAndExtrapolatesLinearly) {
  const auto f = [](double a, double b) { return 1.0 + 2.0 * a - 3.0 * b + 0.5 * a * b; };
  const std::vector<double> u1{0.0, 0.25, 0.5, 1.0}, u2{0.0, 1.0, 2.5};
  std::vector<double> v;
  for (double a : u1)
    for (double b : u2) v.push_back(f(a, b));
  const Table2d t(u1, u2, v);
  for (double a : {0.0, 0.1, 0.3, 0.77, 1.0, 1.3, -0.2})
    for (double b : {0.0, 0.4, 1.7, 2.5, 3.0, -1.0}) EXPECT_NEAR(t(a, b), f(a, b), 1e-12) << a << "," << b;
  Problems p;
  validate(Table2d({0.0, 1.0}, {1.0, 0.5}, {1, 1, 1, 1}), "drive.efficiency_map", p);
  EXPECT_EQ(p.size(), 1u);
}

}  // namespace
TEST(Table1d, PeriodicRepeatsTheTableOverItsSpan) {
  // a cycle of 10 s: 0 -> 10 m/s at 5 s -> 0 at 10 s
  const Table1d t({0.0, 5.0, 10.0}, {0.0, 10.0, 0.0}, Extrapolation::kPeriodic);
  EXPECT_EQ(t(2.5), 5.0);
  EXPECT_EQ(t(10.0), 0.0);   // the end starts the next period
  EXPECT_EQ(t(12.5), 5.0);
  EXPECT_EQ(t(25.0), 10.0);
  EXPECT_NEAR(t(1e6 + 7.5), 5.0, 1e-9);
  EXPECT_EQ(t(-2.5), 5.0);   // before the start: the previous period
  const Table1d hold({0.0, 5.0, 10.0}, {0.0, 10.0, 2.0}, Extrapolation::kHold);
  EXPECT_EQ(hold(12.5), 2.0);
}

// The periodic wrap without fmod gives fmod's bits: for spans whose multiples are exact (a
// cycle of 1180 s, 150 s, 1800.5 s) and spans whose are not (149.9 s, 0.1 s: fmod itself), at
// random times up to 2e6 s, at exact multiples of the span and one ulp either side of them,
// and at times before the start.
TEST(Table1d, ThePeriodicWrapGivesTheBitsOfFmod) {
  std::mt19937_64 rng(26);
  int checked = 0;
  for (const double x0 : {0.0, 3.0, 0.25}) {
    for (const double span : {1180.0, 150.0, 1800.5, 149.9, 0.1, 1.0, 3600.0 * 24.0}) {
      std::vector<double> x, y;
      for (int i = 0; i <= 10; ++i) {
        x.push_back(i == 10 ? x0 + span : x0 + span * i / 10.0);
        y.push_back(std::sin(1.0 + i));
      }
      const Table1d periodic(x, y, Extrapolation::kPeriodic);
      const Table1d hold(x, y, Extrapolation::kHold);
      const auto reference = [&](double u) {  // what the table did with fmod
        double k = std::fmod(u - x.front(), x.back() - x.front());
        if (k < 0.0) k += x.back() - x.front();
        return hold(x.front() + k);
      };
      std::vector<double> us;
      std::uniform_real_distribution<double> any(x0, x0 + 2e6);
      for (int i = 0; i < 2000; ++i) us.push_back(any(rng));
      for (int n = 1; n < 200000; n = n * 3 + 1) {
        const double at = x0 + n * (x.back() - x.front());
        us.insert(us.end(), {at, std::nextafter(at, 0.0), std::nextafter(at, 1e300), at + 0.5 * span});
      }
      us.insert(us.end(), {x0 - 0.3 * span, x0 - 7.5 * span, x.back()});
      for (const double u : us) {
        const double a = periodic(u), b = reference(u);
        ASSERT_EQ(std::memcmp(&a, &b, sizeof a), 0) << "span " << span << " x0 " << x0 << " u " << u;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 40000);
}

}  // namespace ehpt::plant
