// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Map-based internal-combustion engine: MBice / IceT / IceP / IceConnP / IceConnPOO,
// MODELS.md §3. Paper: P15 §3 ("MBice"), §5.2.
//
// An inertia with a torque source; the torque follows a request within [0, tau_max(w)],
// fuel flows according to a brake-specific-consumption map. No friction or pumping torque,
// no start/stop dynamics: the engine never absorbs power by itself.
//   J_ice dw/dt = tau_ice + tau_ext
//   sfc  = SFC(tau_ice, w)            g/kWh, bilinear, torque = row axis, linear
//                                     extrapolation, floored at 0 (§3.2)
//   mdot = sfc * tau_ice * w / 3.6e9  kg/s   (g/kWh * W / 3.6e6 = g/s)
//   icePowDel = (tau_ice - J_ice dw/dt) w   (power at the flange, after the inertia)
// Torque from the request (§3.4, §3.5):
//   torque input (IceT):        tau = min(tau_max(w), max(0, tau_ref))
//   power input (IceConnP):     tau = clamp(K (P_ref - icePowDel), 0, tau_max(w))
//     icePowDel contains dw/dt, which depends on tau through the drivetrain: with
//     dw/dt = a0 + a1 tau (from the plant's mass matrix) the loop is solved exactly,
//       tau = K (P_ref + J w a0) / (1 + K w (1 - J a1)),   then clamped (§3.5, §13 item 9).
//   ON/OFF (IceConnPOO, §3.6):  OFF -> tau = 0 and no fuel; the engine turns if driven.
// State of the owner: w (shared with the carrier), fuel mass (kg).

#include <string>

#include "plant/problems.hpp"
#include "plant/table.hpp"

namespace ehpt::plant {

enum class IceInput { kPower, kTorque };

struct MapIceParams {
  IceInput input = IceInput::kPower;  // IceConnP (power request) or IceT (torque request)
  bool on_off = false;                // IceConnPOO: obeys the ON flag; otherwise always on
  double inertia_kgm2 = 0.5;
  double speed_initial_rad_s = 167.0;
  double control_gain_Nm_W = 0.1;  // K of the power loop (contrGain)
  Table1d torque_max_Nm;           // vs speed (rad/s), end values held
  Table2d sfc_g_kWh;               // rows torque (N m), columns speed (rad/s)
  double fuel_lhv_J_kg = 43.0e6;   // lower heating value (gasoline ~43 MJ/kg): energy audit
  double fuel_density_kg_m3 = 745.0;  // gasoline, for L/100 km
};

void validate(const MapIceParams& p, const std::string& at, Problems& problems);

class MapIce {
 public:
  MapIce() = default;
  explicit MapIce(const MapIceParams& params) : p_(params) {}
  const MapIceParams& params() const { return p_; }

  // Run phase: pure functions.
  // Whether the engine runs: an ON/OFF engine follows the flag, the others always run.
  bool running(bool on_flag) const { return !p_.on_off || on_flag; }
  // Engine torque for the bus command (power or torque request per the engine's input);
  // dw/dt = a0 + a1 tau for the power loop. An engine that is off gives no torque.
  [[gnu::always_inline]] double torque_Nm(bool on_flag, double power_ref_W, double torque_ref_Nm,
                                          double speed_rad_s, double a0, double a1) const {
    if (!running(on_flag)) return 0.0;
    return p_.input == IceInput::kTorque ? torque_for_request_Nm(torque_ref_Nm, speed_rad_s)
                                         : torque_for_power_Nm(power_ref_W, speed_rad_s, a0, a1);
  }
  // Fuel mass flow; none while off.
  [[gnu::always_inline]] double fuel_rate_kg_s(bool on_flag, double torque_Nm, double speed_rad_s) const {
    return running(on_flag) ? fuel_rate_kg_s(torque_Nm, speed_rad_s) : 0.0;
  }
  [[gnu::always_inline]] double torque_max_Nm(double speed_rad_s) const { return p_.torque_max_Nm(speed_rad_s); }
  [[gnu::always_inline]] double torque_for_request_Nm(double torque_ref_Nm, double speed_rad_s) const {
    const double t = torque_ref_Nm > 0.0 ? torque_ref_Nm : 0.0;
    const double t_max = torque_max_Nm(speed_rad_s);
    return t < t_max ? t : t_max;
  }
  // Power loop with the algebraic loop solved; dw/dt = a0 + a1 tau.
  [[gnu::always_inline]] double torque_for_power_Nm(double power_ref_W, double speed_rad_s, double a0, double a1) const {
    const double k = p_.control_gain_Nm_W, j = p_.inertia_kgm2;
    const double t = k * (power_ref_W + j * speed_rad_s * a0) / (1.0 + k * speed_rad_s * (1.0 - j * a1));
    if (!(t > 0.0)) return 0.0;
    const double t_max = torque_max_Nm(speed_rad_s);
    return t < t_max ? t : t_max;
  }
  [[gnu::always_inline]] double sfc_g_kWh(double torque_Nm, double speed_rad_s) const {
    const double s = p_.sfc_g_kWh(torque_Nm, speed_rad_s);
    return s > 0.0 ? s : 0.0;
  }
  [[gnu::always_inline]] double fuel_rate_kg_s(double torque_Nm, double speed_rad_s) const {
    const double power_W = torque_Nm * speed_rad_s;
    return power_W > 0.0 ? sfc_g_kWh(torque_Nm, speed_rad_s) * power_W / 3.6e9 : 0.0;
  }

 private:
  MapIceParams p_;
};

}  // namespace ehpt::plant
