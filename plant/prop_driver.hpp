// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// PropDriver: proportional driver on a speed profile, MODELS.md §8. Paper: P15 §5.1.
//   v_ref(t) = Cycle(t)                (linear in time; repeated stamps = steps; end value held)
//   u        = k (v_ref - v)
//   request  = clamp(u, request_min, request_max)
//   accel    = clamp(u, 0, request_max),  brake = clamp(u, request_min, 0)   (brake <= 0, as the code)
// Units of the request depend on the vehicle: a shaft torque in N m for the EVs (k in
// N m/(m/s)), a per-unit request for the power-split vehicles (k in 1/(m/s)).
// No state. The cycle is loaded from CSV at start-up and converted to m/s there.

#include <string>

#include "plant/problems.hpp"
#include "plant/table.hpp"

namespace ehpt::plant {

struct PropDriverParams {
  Table1d cycle_m_s;            // speed reference vs time (s)
  double gain = 0.0;            // k
  double request_max = 1e5;     // yMax
  double request_min = -1e5;    // -yMax unless set
};

void validate(const PropDriverParams& p, const std::string& at, Problems& problems);

struct DriverOutput {
  double speed_ref_m_s = 0.0;
  double request = 0.0;
  double accel = 0.0;
  double brake = 0.0;
};

// Run phase: pure functions. drive_at: the driver for a speed reference already read from the
// cycle (a plant that reads v_ref(t) for its metrics computes the request from the same value).
[[gnu::always_inline]] inline DriverOutput drive_at(const PropDriverParams& p, double speed_ref_m_s,
                                                    double speed_m_s) {
  const double u = p.gain * (speed_ref_m_s - speed_m_s);
  const double request = u > p.request_max ? p.request_max : (u < p.request_min ? p.request_min : u);
  return {.speed_ref_m_s = speed_ref_m_s,
          .request = request,
          .accel = request > 0.0 ? request : 0.0,
          .brake = request < 0.0 ? request : 0.0};
}
[[gnu::always_inline]] inline DriverOutput drive(const PropDriverParams& p, double t_s, double speed_m_s) {
  return drive_at(p, p.cycle_m_s(t_s), speed_m_s);
}

}  // namespace ehpt::plant
