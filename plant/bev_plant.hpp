// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Battery-electric vehicle with a map-based one-flange drive: MBEV, MODELS.md §10.3
// (tutorial §4), built from PropDriver (§8), OneFlange (§1), Batt1 (§6), DragForce (§7) and
// the vehicle of §7.4. Paper: P15 §5.1 (same structure as EvPm_bat, map-based drive).
// The vehicle is EvPlant (ev_plant.hpp); this file holds its drive, MapDrive (map_drive.hpp)
// as an EvPlant Drive:
//
//   drive:    w = v G / r;  tau = clamp(tau_cmd, -tau_lim(w), tau_lim(w));  P_dc from the map
//   brake:    brake.after_rotor_inertia, MBEV's brake signal, is this drive's (kMbevBrakeSignal)

#include <algorithm>
#include <array>

#include "plant/battery_rc.hpp"
#include "plant/ev_plant.hpp"
#include "plant/map_drive.hpp"
#include "plant/problems.hpp"
#include "plant/signals.hpp"

namespace ehpt::plant {

// MapDrive (map_drive.hpp) as the EV's drive.
class MapMachine {
 public:
  using Params = MapDriveParams;
  using Point = DriveOperatingPoint;
  struct Outputs {
    double drive_torque_limit_Nm = 0, drive_limit_state = 0, drive_limiting = 0, drive_efficiency = 0;
  };
  static constexpr int kNumCrossings = 0;  // the limiter's states are kinks of a continuous map
  struct Mode {};
  static constexpr bool kMbevBrakeSignal = true;

  explicit MapMachine(const Params& p) : drive_(p) {}
  // the map drive has no voltage limit: u_dc is not used
  [[gnu::always_inline]] Point operate(double torque_ref_Nm, double speed_rad_s, double) const {
    return drive_.operate(torque_ref_Nm, speed_rad_s);
  }
  // at rest the drive speed is 0, so the limit is tau_max (state 0)
  [[gnu::always_inline]] double torque_at_rest_Nm(double torque_ref_Nm, double) const {
    const double tau_max_Nm = drive_.params().torque_max_Nm;
    return std::clamp(torque_ref_Nm, -tau_max_Nm, tau_max_Nm);
  }
  double inertia_kgm2() const { return drive_.params().inertia_kgm2; }
  // For the ECU (driveTauLim): the limiter bound yH at this speed.
  double torque_limit_Nm(const Point& op, double) const { return op.limit_Nm; }
  static double torque_Nm(const Point& op) { return op.torque_Nm; }
  static double power_dc_W(const Point& op) { return op.power_dc_W; }
  static unsigned faults(const Point&) { return 0u; }  // closed forms
  static void fill(const Point& op, Outputs& y) {
    y.drive_torque_limit_Nm = op.limit_Nm;
    y.drive_limit_state = op.limit_state;
    y.drive_limiting = op.limiting ? 1.0 : 0.0;
    y.drive_efficiency = op.efficiency;
  }
  static void validate_with_battery(const Params&, const BatteryRcParams&, Problems&) {}  // no voltage limit

  // MBEV's signals, in its column order (the library's names in parentheses).
  template <class O>
  static constexpr std::array<Signal<O>, 31> ev_signals() {
    return {{
        {"time_s", &O::time_s, "simulation time"},
        {"speed_ref_m_s", &O::speed_ref_m_s, "cycle (wanted) speed"},
        {"speed_m_s", &O::speed_m_s, "vehicle speed"},
        {"distance_m", &O::distance_m, "travelled distance"},
        {"acceleration_m_s2", &O::acceleration_m_s2, "vehicle acceleration"},
        {"driver_request_Nm", &O::driver_request_Nm, "driver torque request at the drive shaft (driverRequest)"},
        {"drive_torque_ref_Nm", &O::drive_torque_ref_Nm, "torque the ECU asks of the drive (driveTauRef)"},
        {"drive_torque_Nm", &O::drive_torque_Nm, "torque the drive applies (after the limiter)"},
        {"drive_torque_limit_Nm", &O::drive_torque_limit_Nm, "limiter bound yH (genTauLim)"},
        {"drive_limit_state", &O::drive_limit_state, "limiter state 0 torque, 1 power, 2 speed ramp, 3 over speed"},
        {"drive_limiting", &O::drive_limiting, "1 when the limiter cuts the request"},
        {"drive_speed_rad_s", &O::drive_speed_rad_s, "drive shaft speed"},
        {"drive_power_mech_W", &O::drive_power_mech_W, "mechanical power torque x speed"},
        {"drive_power_dc_W", &O::drive_power_dc_W, "DC power drawn by the drive"},
        {"drive_efficiency", &O::drive_efficiency, "efficiency from the map"},
        {"brake_force_N", &O::brake_force_N, "friction-brake force magnitude"},
        {"road_force_N", &O::road_force_N, "road load (rolling + aero), or the locked reaction"},
        {"grade_rad", &O::grade_rad, "road angle, > 0 uphill"},
        {"altitude_m", &O::altitude_m, "altitude gained since start"},
        {"battery_voltage_V", &O::battery_voltage_V, "terminal voltage"},
        {"battery_current_A", &O::battery_current_A, "terminal current, > 0 discharging"},
        {"battery_power_W", &O::battery_power_W, "terminal power v i (batPowDel)"},
        {"battery_emf_V", &O::battery_emf_V, "EMF E"},
        {"soc", &O::soc, "state of charge (batSOC)"},
        {"locked", &O::locked, "1 while the vehicle is stuck at standstill (dragForce.locked)"},
        {"fault", &O::fault, "fault bits: 1 SOC window, 2 cell current, 4 power infeasible, 8 non-finite"},
        {"battery_out_J", &O::battery_out_J, "integral of terminal power"},
        {"road_work_J", &O::road_work_J, "integral of road-load power"},
        {"drive_loss_J", &O::drive_loss_J, "integral of drive losses"},
        {"battery_loss_J", &O::battery_loss_J, "integral of battery losses"},
        {"brake_work_J", &O::brake_work_J, "integral of brake dissipation"},
    }};
  }

 private:
  MapDrive drive_;
};

using BevPlant = EvPlant<MapMachine>;
using BevParams = EvParams<MapMachine>;
extern template class EvPlant<MapMachine>;

}  // namespace ehpt::plant
