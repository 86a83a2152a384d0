// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The longitudinal vehicle body both vehicles share (MODELS.md §7): road load and grade (§7.1,
// §7.3), the friction brake, the stick/slip modes (§7.2), and the body's own states.
//
//   forces at speed v and distance s:  grade alpha(s), rolling A cos(alpha) (also the
//     break-away force), speed force F(v) (odd in v), grade force m g sin(alpha)
//   brake: F_brake = gain max(0, unmet braking torque), opposing motion; gain G/r, or MBEV's
//     G r (a source defect, §10.3)
//   states (at an offset the owning plant chooses): distance s (m), altitude h (m), road-load
//     work (J) and brake dissipation (J):
//       ds/dt = v,  dh/dt = v sin(alpha),  dW_road/dt = A |v| + F(v) v,  dW_brake/dt = F_brake |v|
//   modes: kForward, kBackward, kStuck; one crossing per mode, always falling through zero:
//       moving:  z = v (forward) or -v (backward)          -> rest: v := 0, then motion_at_rest
//       stuck:   z = F_breakaway - |F_applied|              -> start in the direction of F_applied
// The speed state is the owner's (the EV integrates v, the hybrid the ring speed v G/r), and
// so is the acceleration (one or two degrees of freedom): the body takes v as an argument.

#include <cmath>
#include <string>

#include "plant/problems.hpp"
#include "plant/road_load.hpp"

namespace ehpt::plant {

struct VehicleBodyParams {
  double mass_kg = 0.0;
  double wheel_radius_m = 0.0;
  double gear_ratio = 1.0;          // drive speed / wheel speed
  double speed_initial_m_s = 0.0;
};

void validate(const VehicleBodyParams& p, const std::string& at, Problems& problems);

struct BrakeParams {
  bool enabled = true;
  bool library_gain = false;  // reproduce MBEV's G*r gain instead of G/r (source defect)
  // MBEV measures the torque for its brake after the rotor inertia: tau_shaft = tau - J dw/dt,
  // so it also brakes J dw/dt in every deceleration (§10.3, correction of 2026-11-22). Off:
  // the applied torque tau (no algebraic loop; differs by ~0.2 % Wh/km on NEDC).
  bool after_rotor_inertia = false;
};

// Wheel force per N m of unmet braking torque at the drive shaft: G / r, or the MBEV's
// G * r when reproducing that source defect (§10.3); 0 without a brake.
inline double brake_gain_N_per_Nm(const BrakeParams& brake, const VehicleBodyParams& body) {
  if (!brake.enabled) return 0.0;
  return brake.library_gain ? body.gear_ratio * body.wheel_radius_m : body.gear_ratio / body.wheel_radius_m;
}

class VehicleBody {
 public:
  static constexpr int kDistance = 0, kAltitude = 1, kRoadJ = 2, kBrakeJ = 3;
  static constexpr int kNumStates = 4;

  struct Forces {
    double grade_rad, rolling_N, speed_force_N, grade_force_N;
  };

  VehicleBody() = default;
  VehicleBody(const VehicleBodyParams& body, const RoadLoadParams& road, const BrakeParams& brake)
      : road_(road, body.mass_kg), brake_gain_(plant::brake_gain_N_per_Nm(brake, body)) {}

  // Run phase: pure functions.
  [[gnu::always_inline]] Forces forces(double speed_m_s, double distance_m) const {
    const double grade_rad = road_.grade_rad(distance_m);
    return {grade_rad, road_.rolling_N(grade_rad), road_.speed_force_N(speed_m_s), road_.grade_force_N(grade_rad)};
  }
  // The braking the drive could not deliver (N m at the drive shaft) as a force at the wheel.
  double brake_N(double unmet_braking_Nm) const {
    return unmet_braking_Nm > 0.0 ? brake_gain_ * unmet_braking_Nm : 0.0;
  }
  double brake_gain_N_per_Nm() const { return brake_gain_; }
  // d/dt of the body's states, written at dx[kDistance..kBrakeJ]. Always inlined: it runs in
  // every integrator stage (a plant's derivatives() inlined into its RK4 step kept it out of line).
  [[gnu::always_inline]] void derivatives(double speed_m_s, const Forces& f, double brake_N, double* dx) const {
    const double speed_abs = std::abs(speed_m_s);
    dx[kDistance] = speed_m_s;
    dx[kAltitude] = f.grade_rad == 0.0 ? 0.0 : speed_m_s * std::sin(f.grade_rad);
    dx[kRoadJ] = f.rolling_N * speed_abs + f.speed_force_N * speed_m_s;
    dx[kBrakeJ] = brake_N * speed_abs;
  }
  // Road load, grade and brake on the moving vehicle, signed against +v (0 when stuck).
  [[gnu::always_inline]] static double resisting_N(Motion motion, const Forces& f, double brake_N) {
    switch (motion) {
      case Motion::kForward: return f.rolling_N + f.speed_force_N + f.grade_force_N + brake_N;
      case Motion::kBackward: return -f.rolling_N + f.speed_force_N + f.grade_force_N - brake_N;
      case Motion::kStuck: break;
    }
    return 0.0;
  }
  // The crossing of a moving mode: the speed, signed so that it falls through zero at rest.
  static double moving_crossing(Motion motion, double speed) { return motion == Motion::kForward ? speed : -speed; }
  // The crossing of the stuck mode: > 0 while the road holds the applied force.
  static double stuck_crossing(double applied_N, double breakaway_N) { return breakaway_N - std::abs(applied_N); }
  const RoadLoad& road() const { return road_; }

 private:
  RoadLoad road_;
  double brake_gain_ = 0.0;  // N per N m of unmet braking torque
};

}  // namespace ehpt::plant
