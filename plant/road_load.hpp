// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Road load: DragForce and DragForceAngle, MODELS.md §7. Paper: P15 §4, eq. (3), Fig. 20.
//
// Smooth part (§7.1), opposing motion:
//   coefficients form:  F = A + B v^2,  A = fc m g cos(alpha),  B = 0.5 rho S Cx
//   coast-down form:    F = f0 cos(alpha) + f1 |v| + f2 v^2   (chassis-dynamometer road load)
// Slope (§7.3, the physical variant recommended there): alpha(s) from a table of angle vs
// travelled distance; the grade force m g sin(alpha) acts whatever the direction of motion,
// and takes part in the break-away test. (The library's DragForceAngle flips the slope force
// with the direction and ignores it at break-away; not reproduced.)
//
// Stick/slip (§7.2): at standstill the road reacts with whatever force keeps the car still
// ("locked") until the applied force exceeds the rolling force A (break-away = sliding force).
// The vehicle that owns the speed state implements the modes; this file gives the forces
// and the mode decision taken at an event.

#include <cmath>
#include <string>

#include "plant/problems.hpp"
#include "plant/table.hpp"

namespace ehpt::plant {

inline constexpr double kGravity_m_s2 = 9.80665;

enum class RoadLoadForm { kCoefficients, kCoastDown };

struct RoadLoadParams {
  RoadLoadForm form = RoadLoadForm::kCoefficients;
  // coefficients form
  double rolling_coefficient = 0.01;  // fc
  double air_density_kg_m3 = 1.226;
  double frontal_area_m2 = 0.0;       // S
  double drag_coefficient = 0.0;      // Cx
  // coast-down form
  double f0_N = 0.0;
  double f1_N_s_m = 0.0;
  double f2_N_s2_m2 = 0.0;
  // optional slope: angle (rad, > 0 uphill) vs distance (m), linear, end values held
  Table1d slope_rad;
};

void validate(const RoadLoadParams& p, const std::string& at, Problems& problems);

// Motion mode of the stick/slip state machine; kStuck is the paper's "locked".
enum class Motion { kStuck = 0, kForward = 1, kBackward = -1 };

class RoadLoad {
 public:
  RoadLoad() = default;
  RoadLoad(const RoadLoadParams& p, double mass_kg);

  // Run phase: pure functions.
  // (the flat-road test inline in every stage, the slope table out of line)
  [[gnu::always_inline]] double grade_rad(double distance_m) const {
    return has_slope_ ? slope_grade_rad(distance_m) : 0.0;
  }
  // Rolling (Coulomb) magnitude, also the break-away force.
  double rolling_N(double grade_rad) const {
    return grade_rad == 0.0 ? rolling_level_N_ : rolling_level_N_ * std::cos(grade_rad);
  }
  // Speed-dependent part, odd in v: opposes motion, F(v) v >= 0.
  double speed_force_N(double speed_m_s) const {
    const double a = speed_m_s < 0.0 ? -speed_m_s : speed_m_s;
    return speed_m_s * (f1_N_s_m_ + f2_N_s2_m2_ * a);
  }
  double grade_force_N(double grade_rad) const {
    return grade_rad == 0.0 ? 0.0 : mass_kg_ * kGravity_m_s2 * std::sin(grade_rad);
  }
  bool has_slope() const { return has_slope_; }

 private:
  [[gnu::noinline]] double slope_grade_rad(double distance_m) const { return p_.slope_rad(distance_m); }
  RoadLoadParams p_;
  double mass_kg_ = 0.0;
  double rolling_level_N_ = 0.0;  // A on level road
  double f1_N_s_m_ = 0.0, f2_N_s2_m2_ = 0.0;
  bool has_slope_ = false;
};

// Mode after the vehicle has come to rest (or while stuck): stay stuck while the applied
// force |F| < break-away force, else start in the direction of F (§7.2). ">=" matches the
// crossing z = F_breakaway - |F| <= 0 that fires the event, so a located crossing always
// switches; a zero force never starts the vehicle, even with no rolling resistance.
inline Motion motion_at_rest(double applied_N, double breakaway_N) {
  if (applied_N >= breakaway_N && applied_N > 0.0) return Motion::kForward;
  if (applied_N <= -breakaway_N && applied_N < 0.0) return Motion::kBackward;
  return Motion::kStuck;
}

}  // namespace ehpt::plant
