// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Series hybrid (EHPTlib SHEVpowerFilt, SHEVpowerFiltSoc, SHEV_OO), MODELS.md §10.6, built from
// PropDriver (§8), a one-flange map drive (§1), Batt1 (§6), DragForce and the vehicle (§7), and
// the genset of plant/genset.hpp (engine + generator on one shaft, run by its own GMS from a
// power request). Vehicle kind "shev".
//
//   driver:   tau_req = clamp(k (v_ref(t) - v), -yMax, yMax)        (N m at the drive shaft)
//   ECU:      the EMS (ecu/shev_ems.hpp, or an external one on a bus): msgs::ShevCommand
//             {driveTauRef, gensetPowRef, gensetON}, held over each ECU period
//   drive:    w_d = v G / r;  tau_d = limiter(driveTauRef, w_d);  P_dc,d from its map
//   genset:   GMS + engine + generator (genset.hpp) from (gensetPowRef, on, w);
//             on = gensetON for an ON/OFF genset (genset.ice.on_off), always on otherwise
//             (J_ice + J_gen / r_gs^2) dw/dt = tau_ice + tau_gen / r_gs
//   DC bus:   the battery supplies P_dc,d + P_dc,gen (P_dc,gen < 0 while generating)
//   brake:    the braking the drive cannot deliver: F = (G / r) max(0, tau_d - driveTauRef)
//             (the library's SHEV has none; a real bus brakes what its drive cannot)
//   body:     (m + J_d (G/r)^2) dv/dt = tau_d G/r - F_roll - F_v(v) - m g sin(alpha) - F_brake
//   stuck:    as the EV (plant/ev_plant.hpp): crossing 0
//
// State (one flat vector): v (m/s) | VehicleBody (s, h, road work, brake work) | BatteryRc
// (E, v_rc) | w, the genset's engine speed (rad/s) | fuel (kg) | energy integrals (J): engine
// work, battery terminal energy out, drive losses, generator losses, battery losses.
// Energy audit: fuel chemical energy + battery stored-energy decrease = road work + engine
// losses (fuel energy - engine work) + drive, generator and battery losses + brake + change of
// kinetic energy (vehicle, drive rotor, genset shaft) + m g dh.

#include <array>
#include <span>

#include <Eigen/Core>

#include "msgs/shev.hpp"
#include "plant/battery_rc.hpp"
#include "plant/genset.hpp"
#include "plant/health.hpp"
#include "plant/map_drive.hpp"
#include "plant/prop_driver.hpp"
#include "plant/road_load.hpp"
#include "plant/signals.hpp"
#include "plant/vehicle_body.hpp"

namespace ehpt::plant {

struct ShevParams {
  VehicleBodyParams body;   // gear_ratio = G (drive speed / wheel speed)
  RoadLoadParams road;
  BrakeParams brake;
  PropDriverParams driver;  // request in N m at the drive shaft
  BatteryRcParams battery;
  MapDriveParams drive;
  GensetParams genset;      // genset.ice.on_off: GensetOO (obeys gensetON)
};

void validate(const ShevParams& p, Problems& problems);

class ShevPlant {
 public:
  static constexpr int kSpeed = 0;
  static constexpr int kBodyAt = 1;
  static constexpr int kBatteryAt = kBodyAt + VehicleBody::kNumStates;
  static constexpr int kGensetSpeed = kBatteryAt + BatteryRc::kNumStates;
  static constexpr int kFuelKg = kGensetSpeed + 1;
  static constexpr int kIntegralsAt = kFuelKg + 1;
  static constexpr int kNumStates = kIntegralsAt + 5;
  static constexpr int kDistance = kBodyAt + VehicleBody::kDistance, kAltitude = kBodyAt + VehicleBody::kAltitude;
  static constexpr int kRoadJ = kBodyAt + VehicleBody::kRoadJ, kBrakeJ = kBodyAt + VehicleBody::kBrakeJ;
  static constexpr int kEmf = kBatteryAt + BatteryRc::kEmf, kVrc = kBatteryAt + BatteryRc::kVrc;
  static constexpr int kIceWorkJ = kIntegralsAt, kBatteryOutJ = kIntegralsAt + 1, kDriveLossJ = kIntegralsAt + 2,
                       kGenLossJ = kIntegralsAt + 3, kBatteryLossJ = kIntegralsAt + 4;
  // States no derivative reads: implicit Euler skips their Jacobian columns
  static constexpr std::array<int, 9> kAuditOnlyStates = {kAltitude,    kRoadJ,      kBrakeJ,   kFuelKg,      kIceWorkJ,
                                                          kBatteryOutJ, kDriveLossJ, kGenLossJ, kBatteryLossJ};
  static constexpr int kNumCrossings = 1;
  using State = Eigen::Matrix<double, kNumStates, 1>;
  struct Modes {
    Motion motion = Motion::kStuck;
  };
  using Params = ShevParams;
  using Inputs = msgs::ShevCommand;  // held over each ECU period
  using Sensors = msgs::ShevSensors;

  struct Outputs {
    double time_s = 0, speed_ref_m_s = 0, speed_m_s = 0, distance_m = 0, acceleration_m_s2 = 0;
    double driver_request_Nm = 0, drive_torque_ref_Nm = 0, drive_torque_Nm = 0, drive_torque_limit_Nm = 0;
    double drive_limit_state = 0, drive_speed_rad_s = 0, drive_power_mech_W = 0, drive_power_dc_W = 0;
    double genset_power_ref_W = 0, genset_on = 0, genset_speed_rad_s = 0, genset_speed_ref_rad_s = 0, throttle = 0;
    double ice_torque_Nm = 0, ice_torque_max_Nm = 0, ice_power_W = 0, gen_torque_request_Nm = 0, gen_torque_Nm = 0;
    double gen_limit_state = 0, gen_power_mech_W = 0, genset_power_dc_W = 0, fuel_rate_g_s = 0, fuel_g = 0;
    double brake_force_N = 0, road_force_N = 0, grade_rad = 0;
    double battery_voltage_V = 0, battery_current_A = 0, battery_power_W = 0, soc = 0;
    double locked = 0, fault = 0;
  };
  static const std::array<Signal<Outputs>, 37> kSignals;
  static constexpr MetricSources<Outputs> kMetrics{.speed_ref_m_s = &Outputs::speed_ref_m_s,
                                                   .speed_m_s = &Outputs::speed_m_s,
                                                   .locked = &Outputs::locked,
                                                   .engine_on = &Outputs::genset_on,
                                                   .distance_m = &Outputs::distance_m,
                                                   .soc = &Outputs::soc,
                                                   .fuel_g = &Outputs::fuel_g};
  std::span<const Signal<Outputs>> signals() const { return kSignals; }

  explicit ShevPlant(const ShevParams& params);  // start-up: params already validated

  State initial_state() const;
  Modes initial_modes(const State& x0) const;

  // Run phase: pure functions, no allocation.
  void derivatives(double t_s, const State& x, const Modes& m, const Inputs& u, State& dx) const;
  void crossings(double t_s, const State& x, const Modes& m, const Inputs& u, double* z) const;
  void on_crossing(int index, double t_s, State& x, Modes& m, const Inputs& u) const;
  void outputs(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y) const;
  // The outputs and dx/dt from one evaluation (the runner's first stage of the next step).
  void outputs(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y, State& dx) const;
  // What the ECU reads at t_s (the stamp is the runner's).
  void sense(double t_s, const State& x, const Modes& m, const Inputs& u, Sensors& s) const;

  EnergyAudit audit(const State& x0, const State& x) const;
  // Plant faults, between steps only: the pack's constants and the machines' derating.
  static constexpr std::array<const char*, 2> kMachines = {"drive", "generator"};
  void set_health(const PlantHealth& h, const State& x) {
    battery_.set_health(h.battery, x[kEmf], x[kVrc]);
    torque_gain_ = h.torque_gain;
  }
  const ShevParams& params() const { return p_; }
  const Genset& genset() const { return genset_; }

  // Everything one evaluation computes (public: tests check the balances on it).
  struct Eval {
    DriveOperatingPoint drive;
    GensetPoint genset;
    bool on;
    BatteryTerminal battery;
    double drive_speed_rad_s, grade_rad, rolling_N, speed_force_N, grade_force_N, brake_N;
    double applied_N;  // drive force minus grade force: what the road holds while stuck
    double road_N;     // reaction of the road (rolling + speed part, or applied_N when stuck)
    double accel_m_s2;
  };
  Eval evaluate(const State& x, const Modes& m, const Inputs& u) const;

 private:
  void derivatives_from(const Eval& e, const State& x, State& dx) const;
  void outputs_from(const Eval& e, double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y) const;
  unsigned faults(const Eval& e, const State& x) const;
  double kinetic_energy_J(const State& x) const;

  ShevParams p_;
  MapDrive drive_;
  Genset genset_;
  BatteryRc battery_;
  VehicleBody body_;
  std::array<double, kMaxMachines> torque_gain_ = {1.0, 1.0};  // derating (plant faults): 1 healthy
  double g_over_r_ = 0.0, mass_eff_kg_ = 0.0, inv_mass_eff_kg_ = 0.0;
};

}  // namespace ehpt::plant
