// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Genset of the series hybrid (EHPTlib MapBased.Genset / GensetOO), MODELS.md §10.6 with §3
// (the engine, IceT01) and §1 (the generator, a one-flange drive): an engine and a generator on
// one shaft through an ideal gear, run by its genset manager (GMS) from a power request.
//
//   GMS:   w_opt    = optiSpeed(P_ref) 2 pi / 60                (optiSpeed in rpm vs W)
//          throttle = clamp(k_w (w_opt - w), -1, 1)              (k_w = throttle_per_rad_s)
//          P_ref    = max(0, power request)                      (the genset's input limiter)
//          tau_load = clamp(P_ref / w, -tau_max_ice(w), tau_max_ice(w))   (gms_limits_torque;
//                     the plain Genset of V3 disables this limit, GensetOO keeps it)
//          generator torque request = -r tau_load               (r = gear_ratio)
//   ICE (IceT01):  tau_ice = tau_max_ice(w) clamp(throttle, 0, 1)
//   generator:     tau_gen = limiter(request, w_gen), w_gen = w / r, P_dc from its map (§1.4)
//   shaft (ICE side): (J_ice + J_gen / r^2) dw/dt = tau_ice + tau_gen / r
// The engine speed w is the state (starts at ice.speed_initial_rad_s, wIceStart). The ON/OFF
// variant (GensetOO): off, the engine gets no fuel and neither machine gives torque (the shaft
// coasts). Pure functions of (request, on, speed): the owner integrates.

#include <string>

#include "plant/map_drive.hpp"
#include "plant/map_ice.hpp"
#include "plant/problems.hpp"
#include "plant/table.hpp"

namespace ehpt::plant {

struct GensetParams {
  MapIceParams ice;             // torque_max and sfc maps, inertia, wIceStart (speed_initial_rad_s)
  MapDriveParams generator;     // maxTau, maxGenPow, maxGenW, J, efficiency map (per unit)
  double gear_ratio = 1.0;      // gsRatio: w_ice = r w_gen
  double throttle_per_rad_s = 0.1;  // GMS speed-error gain (throttlePerWerr)
  Table1d opti_speed_rpm;       // GMS: the engine's best speed (rpm) vs power request (W)
  // GMS: clamp P_ref / w to the engine's maximum torque. V3's plain Genset sets the GMS's limits
  // to 1e9 N m (its documentation: "GMS torque limitation is disabled"), GensetOO keeps them.
  bool gms_limits_torque = true;
};

void validate(const GensetParams& p, const std::string& at, Problems& problems);

// What the genset does at one point.
struct GensetPoint {
  double speed_ref_rad_s = 0.0;   // w_opt
  double throttle = 0.0;          // the GMS's, before the engine's clamp to [0, 1]
  double ice_torque_Nm = 0.0;
  double ice_torque_max_Nm = 0.0;
  double gen_request_Nm = 0.0;    // -r tau_load (< 0: generating)
  DriveOperatingPoint gen;        // at the generator's speed; power_dc_W < 0 when generating
  double fuel_rate_kg_s = 0.0;
  double shaft_torque_Nm = 0.0;   // tau_ice + tau_gen / r, on the engine side
};

class Genset {
 public:
  Genset() = default;
  explicit Genset(const GensetParams& params);
  const GensetParams& params() const { return p_; }
  // the inertia the engine's shaft moves: J_ice + J_gen / r^2
  double inertia_kgm2() const { return inertia_kgm2_; }

  // Run phase: pure, no allocation. gen_torque_gain < 1: the generator derated (a plant fault,
  // plant/health.hpp), its torque bound x the gain.
  // power_request_W: the genset's input (< 0 is taken as 0, its input limiter's P_ref).
  GensetPoint operate(double power_request_W, bool on, double speed_rad_s, double gen_torque_gain = 1.0) const;

 private:
  GensetParams p_;
  MapIce ice_;
  MapDrive gen_;
  double inertia_kgm2_ = 0.0;
};

}  // namespace ehpt::plant
