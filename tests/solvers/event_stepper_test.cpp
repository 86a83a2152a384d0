// SPDX-License-Identifier: BSD-3-Clause
#include "solvers/event_stepper.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace ehpt::solvers {
namespace {

// A ball falling from 10 m; bounces with restitution e: y' = v, v' = -g; z = y.
struct Ball {
  static constexpr int kNumStates = 2;
  static constexpr int kNumCrossings = 1;
  using State = Eigen::Matrix<double, 2, 1>;
  struct Modes {
    int bounces = 0;
  };
  struct Inputs {};
  double g = 9.81, e = 0.5;
  void derivatives(double, const State& x, const Modes&, const Inputs&, State& dx) const { dx << x[1], -g; }
  void crossings(double, const State& x, const Modes&, const Inputs&, double* z) const { z[0] = x[0]; }
  void on_crossing(int, double, State& x, Modes& m, const Inputs&) const {
    x[0] = 0.0;
    x[1] = -e * x[1];
    ++m.bounces;
  }
};

TEST(EventStepper, LocatesTheImpactOfAFallingBodyWithinTolerance) {
  const Ball ball;
  for (double h : {1e-3, 1e-2, 0.1}) {
    Rk4<Ball> rk4(ball);
    EventStepper<Ball, Rk4<Ball>> stepper(ball, rk4, 0.0, h);
    Ball::State x(10.0, 0.0);
    Ball::Modes m;
    const double t1 = std::sqrt(2.0 * 10.0 / ball.g);
    const double v1 = ball.g * t1;
    const double t2 = t1 + 2.0 * ball.e * v1 / ball.g;  // second impact
    std::vector<double> impacts;
    for (std::int64_t n = 0; stepper.time_s(n) < t2 + 0.5; ++n) {
      const StepReport r = stepper.advance(n, x, m, {});
      if (r.events > 0) impacts.push_back(r.event_time_s);
      // the grid is t0 + n h whatever happens inside
      ASSERT_EQ(stepper.time_s(n + 1), static_cast<double>(n + 1) * h);
    }
    ASSERT_GE(impacts.size(), 2u) << h;
    EXPECT_NEAR(impacts[0], t1, 1e-6 * h) << h;
    EXPECT_NEAR(impacts[1], t2, 1e-6 * h) << h;
  }
}

// The runner hands the stepper dx/dt at the start of a step (it came with the outputs). The
// result must be the same bit for bit as without it, also in steps with an event, where the
// start value no longer holds after the mode switch (the bounce reverses v).
TEST(EventStepper, DerivativesGivenAtTheStartChangeNothingAcrossEvents) {
  const Ball ball;
  const double h = 0.01;
  Rk4<Ball> rk4_a(ball), rk4_b(ball);
  EventStepper<Ball, Rk4<Ball>> plain(ball, rk4_a, 0.0, h), given(ball, rk4_b, 0.0, h);
  Ball::State xa(10.0, 0.0), xb = xa;
  Ball::Modes ma, mb;
  int steps_with_events = 0;
  for (std::int64_t n = 0; n < 600; ++n) {
    Ball::State dx;
    ball.derivatives(given.time_s(n), xb, mb, {}, dx);
    const StepReport ra = plain.advance(n, xa, ma, {});
    const StepReport rb = given.advance(n, xb, mb, {}, &dx);
    steps_with_events += ra.events > 0 ? 1 : 0;
    ASSERT_EQ(ra.events, rb.events) << n;
    ASSERT_EQ(ra.event_time_s, rb.event_time_s) << n;
    ASSERT_EQ(xa[0], xb[0]) << n;
    ASSERT_EQ(xa[1], xb[1]) << n;
    ASSERT_EQ(ma.bounces, mb.bounces) << n;
  }
  EXPECT_GE(steps_with_events, 3);
}

TEST(EventStepper, ImplicitEulerLocatesEventsToo) {
  const Ball ball;
  ImplicitEuler<Ball> ie(ball);
  const double h = 1e-3;
  EventStepper<Ball, ImplicitEuler<Ball>> stepper(ball, ie, 0.0, h);
  Ball::State x(10.0, 0.0);
  Ball::Modes m;
  double first = -1.0;
  for (std::int64_t n = 0; n < 2000 && first < 0.0; ++n) {
    const StepReport r = stepper.advance(n, x, m, {});
    if (r.events > 0) first = r.event_time_s;
  }
  // first order: the trajectory itself is off by O(h); the event is where that trajectory hits
  EXPECT_NEAR(first, std::sqrt(2.0 * 10.0 / ball.g), 5e-3);
}

// Every mode is immediately invalid: the guard must stop and count chattering.
struct Chatter {
  static constexpr int kNumStates = 1;
  static constexpr int kNumCrossings = 1;
  using State = Eigen::Matrix<double, 1, 1>;
  struct Modes {
    int flips = 0;
  };
  struct Inputs {};
  void derivatives(double, const State&, const Modes&, const Inputs&, State& dx) const { dx[0] = 1.0; }
  void crossings(double, const State&, const Modes&, const Inputs&, double* z) const { z[0] = -1.0; }
  void on_crossing(int, double, State&, Modes& m, const Inputs&) const { ++m.flips; }
};

TEST(EventStepper, CapsEventsPerStepAndReportsChattering) {
  const Chatter plant;
  Rk4<Chatter> rk4(plant);
  EventStepper<Chatter, Rk4<Chatter>> stepper(plant, rk4, 0.0, 1e-3);
  Chatter::State x(0.0);
  Chatter::Modes m;
  const StepReport r = stepper.advance(0, x, m, {});
  EXPECT_TRUE(r.chattering);
  EXPECT_EQ(r.events, (EventStepper<Chatter, Rk4<Chatter>>::kMaxEventsPerStep));
  EXPECT_NEAR(x[0], 1e-3, 1e-15);  // the step is still completed
}

// A mode whose crossing starts at exactly zero and falls: invalid from the start.
struct StartsAtZero {
  static constexpr int kNumStates = 1;
  static constexpr int kNumCrossings = 1;
  using State = Eigen::Matrix<double, 1, 1>;
  struct Modes {
    int switched = 0;
    double at_s = -1.0;
  };
  struct Inputs {};
  void derivatives(double, const State&, const Modes& m, const Inputs&, State& dx) const {
    dx[0] = m.switched == 0 ? -1.0 : 0.0;
  }
  void crossings(double, const State& x, const Modes& m, const Inputs&, double* z) const {
    z[0] = m.switched == 0 ? x[0] : 1.0;
  }
  void on_crossing(int, double t, State&, Modes& m, const Inputs&) const {
    ++m.switched;
    m.at_s = t;
  }
};

TEST(EventStepper, ACrossingThatStartsAtZeroAndFallsFiresAtTheSegmentStart) {
  const StartsAtZero plant;
  Rk4<StartsAtZero> rk4(plant);
  EventStepper<StartsAtZero, Rk4<StartsAtZero>> stepper(plant, rk4, 0.0, 0.01);
  StartsAtZero::State x(0.0);
  StartsAtZero::Modes m;
  const StepReport r = stepper.advance(0, x, m, {});
  EXPECT_EQ(r.events, 1);
  EXPECT_EQ(m.at_s, 0.0);  // not one step late
  EXPECT_EQ(x[0], 0.0);    // the invalid mode never ran
}

// z = 1 - t reaches 0 exactly at t = 1, the end of step 7 with h = 0.125 (exact in binary).
struct Clock {
  static constexpr int kNumStates = 1;
  static constexpr int kNumCrossings = 1;
  using State = Eigen::Matrix<double, 1, 1>;
  struct Modes {
    int fired = 0;
  };
  struct Inputs {};
  void derivatives(double, const State&, const Modes&, const Inputs&, State& dx) const { dx[0] = 1.0; }
  void crossings(double, const State& x, const Modes& m, const Inputs&, double* z) const {
    z[0] = m.fired == 0 ? 1.0 - x[0] : 1.0;
  }
  void on_crossing(int, double, State&, Modes& m, const Inputs&) const { ++m.fired; }
};

TEST(EventStepper, ACrossingExactlyOnTheStepEndFiresOnce) {
  const Clock plant;
  Rk4<Clock> rk4(plant);
  EventStepper<Clock, Rk4<Clock>> stepper(plant, rk4, 0.0, 0.125);
  Clock::State x(0.0);
  Clock::Modes m;
  int events = 0;
  for (int n = 0; n < 16; ++n) {
    const StepReport r = stepper.advance(n, x, m, {});
    events += r.events;
    if (r.events) {
      EXPECT_EQ(n, 7);
    }
  }
  EXPECT_EQ(events, 1);
}

}  // namespace
}  // namespace ehpt::solvers
