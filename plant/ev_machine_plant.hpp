// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Battery-electric vehicles with a physics-based machine drive: EvPm_bat (PMDrive, MODELS.md
// §10.1, P15 §5.1, Figs. 18-20) and EvAm_bat (AMDrive, §10.2). The same vehicle as the
// map-based EV, EvPlant (ev_plant.hpp, where the equations are); this file holds the two
// machines as EvPlant Drives (their interface: ev_plant.hpp) and the signals both record:
// the common ones, then the machine's own.

#include <array>
#include <cmath>
#include <cstddef>
#include <limits>

#include "plant/am_drive.hpp"
#include "plant/battery_rc.hpp"
#include "plant/ev_plant.hpp"
#include "plant/pm_drive.hpp"
#include "plant/problems.hpp"
#include "plant/signals.hpp"

namespace ehpt::plant {

// What every machine EV records (the fields of EvOutputs, ev_plant.hpp); the drive's own follow.
inline constexpr std::array<Signal<EvOutputs>, 27> kEvMachineSignals = {{
    {"time_s", &EvOutputs::time_s, "simulation time"},
    {"speed_ref_m_s", &EvOutputs::speed_ref_m_s, "cycle (wanted) speed"},
    {"speed_m_s", &EvOutputs::speed_m_s, "vehicle speed"},
    {"distance_m", &EvOutputs::distance_m, "travelled distance"},
    {"acceleration_m_s2", &EvOutputs::acceleration_m_s2, "vehicle acceleration"},
    {"driver_request_Nm", &EvOutputs::driver_request_Nm, "driver torque request at the drive shaft"},
    {"drive_torque_ref_Nm", &EvOutputs::drive_torque_ref_Nm, "torque the ECU asks of the drive"},
    {"drive_torque_Nm", &EvOutputs::drive_torque_Nm, "electromagnetic torque of the machine"},
    {"drive_speed_rad_s", &EvOutputs::drive_speed_rad_s, "rotor speed"},
    {"drive_power_mech_W", &EvOutputs::drive_power_mech_W, "mechanical power torque x speed"},
    {"drive_power_dc_W", &EvOutputs::drive_power_dc_W, "DC power drawn by the drive"},
    {"drive_loss_W", &EvOutputs::drive_loss_W, "machine copper + inverter losses"},
    {"brake_force_N", &EvOutputs::brake_force_N, "friction-brake force magnitude"},
    {"road_force_N", &EvOutputs::road_force_N, "road load (rolling + aero), or the locked reaction"},
    {"altitude_m", &EvOutputs::altitude_m, "altitude gained since start"},
    {"battery_voltage_V", &EvOutputs::battery_voltage_V, "terminal voltage"},
    {"battery_current_A", &EvOutputs::battery_current_A, "terminal current, > 0 discharging"},
    {"battery_power_W", &EvOutputs::battery_power_W, "terminal power v i"},
    {"battery_emf_V", &EvOutputs::battery_emf_V, "EMF E"},
    {"soc", &EvOutputs::soc, "state of charge"},
    {"locked", &EvOutputs::locked, "1 while the vehicle is stuck at standstill (dragForce.locked)"},
    {"fault", &EvOutputs::fault,
     "fault bits: 1 SOC window, 2 cell current, 4 power infeasible, 8 non-finite, 16 drive solve"},
    {"battery_out_J", &EvOutputs::battery_out_J, "integral of terminal power"},
    {"road_work_J", &EvOutputs::road_work_J, "integral of road-load power"},
    {"drive_loss_J", &EvOutputs::drive_loss_J, "integral of drive losses"},
    {"battery_loss_J", &EvOutputs::battery_loss_J, "integral of battery losses"},
    {"brake_work_J", &EvOutputs::brake_work_J, "integral of brake dissipation"},
}};

// The common signals followed by the drive's, as signals of the combined Outputs (a member
// pointer of a base converts to one of the derived class).
template <class Outputs, class A, class B, std::size_t NA, std::size_t NB>
constexpr std::array<Signal<Outputs>, NA + NB> join_signals(const std::array<Signal<A>, NA>& a,
                                                            const std::array<Signal<B>, NB>& b) {
  std::array<Signal<Outputs>, NA + NB> out{};
  for (std::size_t i = 0; i < NA; ++i) out[i] = {a[i].name, a[i].member, a[i].meaning};
  for (std::size_t i = 0; i < NB; ++i) out[NA + i] = {b[i].name, b[i].member, b[i].meaning};
  return out;
}


// PMDrive as the EV's drive (pm_drive.hpp).
class PmMachine {
 public:
  using Params = PmDriveParams;
  using Point = PmOperatingPoint;
  struct Outputs {
    double id_A = 0, iq_A = 0, vd_V = 0, vq_V = 0, voltage_peak_V = 0, current_rms_A = 0;
    double weakening = 0, voltage_limited = 0, current_limited = 0, overload = 0;
  };
  static constexpr std::array<Signal<Outputs>, 10> kSignals = {{
      {"id_A", &Outputs::id_A, "d-axis current, peak (< 0: flux weakening or MTPA of an anisotropic rotor)"},
      {"iq_A", &Outputs::iq_A, "q-axis current, peak"},
      {"vd_V", &Outputs::vd_V, "d-axis voltage, peak phase"},
      {"vq_V", &Outputs::vq_V, "q-axis voltage, peak phase"},
      {"voltage_peak_V", &Outputs::voltage_peak_V, "space-phasor voltage |V|, peak phase"},
      {"current_rms_A", &Outputs::current_rms_A, "phase current, rms"},
      {"weakening", &Outputs::weakening, "1 in flux weakening (|V| held at the set voltage)"},
      {"voltage_limited", &Outputs::voltage_limited, "1 when the request is beyond reach at this speed"},
      {"current_limited", &Outputs::current_limited, "1 when the current limit cuts the torque"},
      {"overload", &Outputs::overload, "1 when holding the voltage alone needs more than the current limit"},
  }};

  explicit PmMachine(const Params& p)
      : p_(p),
        torque_max_Nm_(pm_torque_at_current_limit_Nm(p)),
        mtpa_at_limit_{pm_mtpa(p, torque_max_Nm_), pm_mtpa(p, -torque_max_Nm_)} {}
  // The operating point; MTPA for T* is solved once per command (see mtpa_of).
  Point operate(double torque_ref_Nm, double speed_rad_s, double u_dc_V) const {
    return pm_operating_point(p_, torque_ref_Nm, speed_rad_s, u_dc_V, mtpa_of(torque_ref_Nm));
  }

  // MTPA <-> flux weakening as a located event (the "switch as an event"; the
  // operating point itself is continuous there, MODELS.md §12, and picks its branch at every
  // evaluation, so the event only keeps RK4 steps off the kink and marks the time). The
  // switch is where the MTPA currents of the torque the drive gives reach the voltage: T*,
  // or MTPA at the current limit when T* needs more current.
  static constexpr int kNumCrossings = 1;
  struct Mode {
    bool weakening = false;
  };
  static constexpr bool kMbevBrakeSignal = false;
  void crossings(const Mode& m, double torque_ref_Nm, double speed_rad_s, double u_dc_V, double* z) const {
    const PmCurrents& c = std::abs(torque_ref_Nm) > torque_max_Nm_ ? mtpa_at_limit_[torque_ref_Nm > 0.0 ? 0 : 1]
                                                                   : mtpa_of(torque_ref_Nm);
    const double excess_V2 = pm_voltage_excess_V2(p_, c, speed_rad_s, u_dc_V);
    z[0] = m.weakening ? excess_V2 : -excess_V2;
  }
  void on_crossing(int, Mode& m) const { m.weakening = !m.weakening; }

  // the torque at rest: the operating point at zero speed
  double torque_at_rest_Nm(double torque_ref_Nm, double u_dc_V) const {
    return torque_Nm(operate(torque_ref_Nm, 0.0, u_dc_V));
  }
  double inertia_kgm2() const { return p_.inertia_kgm2; }
  // For the ECU (driveTauLim): the MTPA torque at the current limit; flux weakening lowers
  // what is reachable above base speed, which this bound does not follow.
  double torque_limit_Nm(const Point&, double) const { return torque_max_Nm_; }
  static double torque_Nm(const Point& op) { return op.torque_Nm; }
  static double power_dc_W(const Point& op) { return op.p_dc_W; }
  static unsigned faults(const Point& op) { return op.converged ? 0u : kFaultDriveSolve; }
  static void fill(const Point& op, Outputs& y) {
    y.id_A = op.id_A;
    y.iq_A = op.iq_A;
    y.vd_V = op.vd_V;
    y.vq_V = op.vq_V;
    y.voltage_peak_V = std::sqrt(op.vd_V * op.vd_V + op.vq_V * op.vq_V);
    y.current_rms_A = std::sqrt(0.5 * (op.id_A * op.id_A + op.iq_A * op.iq_A));
    y.weakening = op.weakening ? 1.0 : 0.0;
    y.voltage_limited = op.voltage_limited ? 1.0 : 0.0;
    y.current_limited = op.current_limited ? 1.0 : 0.0;
    y.overload = op.overload ? 1.0 : 0.0;
  }
  template <class O>
  static constexpr auto ev_signals() { return join_signals<O>(kEvMachineSignals, kSignals); }
  // The machine's set voltage must be within what the pack gives at its lowest EMF.
  static void validate_with_battery(const Params& p, const BatteryRcParams& b, Problems& problems);

 private:
  // MTPA of T*, remembered for the last T* (the command is held over an ECU period, so all
  // RK4 stages and crossings of the period share one Newton solve). pm_mtpa is a pure
  // function of T*, so the memo returns exactly what a fresh solve would: a run does not
  // depend on the order of calls. Not for two threads at once (a plant belongs to one run).
  const PmCurrents& mtpa_of(double torque_ref_Nm) const {
    if (!(torque_ref_Nm == memo_torque_Nm_)) {  // NaN never matches: solved (and flagged) each time
      memo_ = pm_mtpa(p_, torque_ref_Nm);
      memo_torque_Nm_ = torque_ref_Nm;
    }
    return memo_;
  }

  Params p_;
  double torque_max_Nm_;
  PmCurrents mtpa_at_limit_[2];  // MTPA at the current limit, motoring and braking
  mutable PmCurrents memo_;
  mutable double memo_torque_Nm_ = std::numeric_limits<double>::quiet_NaN();
};

// AMDrive as the EV's drive (am_drive.hpp): TorqueToDW, slip limiter, current limit, QSAsma.
class AmMachine {
 public:
  using Params = AmDriveParams;
  using Point = AmOperatingPoint;
  struct Outputs {
    double slip_rad_s = 0, stator_frequency_rad_s = 0, emf_rms_V = 0, u1_rms_V = 0, i1_rms_A = 0, i2_rms_A = 0;
    double torque_at_max = 0, current_limited = 0, weakening = 0;
  };
  static constexpr std::array<Signal<Outputs>, 9> kSignals = {{
      {"slip_rad_s", &Outputs::slip_rad_s, "slip frequency dWe = w_e - pp w_m (electrical)"},
      {"stator_frequency_rad_s", &Outputs::stator_frequency_rad_s, "stator electrical angular frequency w_e"},
      {"emf_rms_V", &Outputs::emf_rms_V, "E behind R1 (U/f rule), rms phase"},
      {"u1_rms_V", &Outputs::u1_rms_V, "terminal voltage |U1|, rms phase"},
      {"i1_rms_A", &Outputs::i1_rms_A, "stator current |I1|, rms"},
      {"i2_rms_A", &Outputs::i2_rms_A, "rotor current |I2| (referred), rms"},
      {"torque_at_max", &Outputs::torque_at_max, "1 when the request is at or beyond the reachable torque"},
      {"current_limited", &Outputs::current_limited, "1 when the current limit reduces the slip"},
      {"weakening", &Outputs::weakening, "1 above base frequency (E held at U_base)"},
  }};

  explicit AmMachine(const Params& p) : p_(p) {}
  static constexpr int kNumCrossings = 0;  // continuous (§12): no event
  struct Mode {};
  static constexpr bool kMbevBrakeSignal = false;
  // the U/f drive sets E from the frequency; the DC voltage only bounds it (validate)
  Point operate(double torque_ref_Nm, double speed_rad_s, double) const {
    return am_operating_point(p_, torque_ref_Nm, speed_rad_s);
  }
  // the torque at rest: the operating point at zero speed
  double torque_at_rest_Nm(double torque_ref_Nm, double u_dc_V) const {
    return torque_Nm(operate(torque_ref_Nm, 0.0, u_dc_V));
  }
  double inertia_kgm2() const { return p_.inertia_kgm2; }
  double torque_limit_Nm(const Point&, double speed_rad_s) const { return am_torque_limit_Nm(p_, speed_rad_s); }
  static double torque_Nm(const Point& op) { return op.torque_Nm; }
  static double power_dc_W(const Point& op) { return op.power_dc_W; }
  static unsigned faults(const Point&) { return 0u; }  // closed forms and bounded bracketed solves
  static void fill(const Point& op, Outputs& y) {
    y.slip_rad_s = op.slip_rad_s;
    y.stator_frequency_rad_s = op.w_e_rad_s;
    y.emf_rms_V = op.emf_rms_V;
    y.u1_rms_V = op.u1_rms_V;
    y.i1_rms_A = op.i1_rms_A;
    y.i2_rms_A = op.i2_rms_A;
    y.torque_at_max = op.torque_at_max ? 1.0 : 0.0;
    y.current_limited = op.current_limited ? 1.0 : 0.0;
    y.weakening = op.weakening ? 1.0 : 0.0;
  }
  template <class O>
  static constexpr auto ev_signals() { return join_signals<O>(kEvMachineSignals, kSignals); }
  // The U/f base voltage must be within what the pack gives at its lowest EMF.
  static void validate_with_battery(const Params& p, const BatteryRcParams& b, Problems& problems);

 private:
  Params p_;
};

using EvPmPlant = EvPlant<PmMachine>;
using EvPmParams = EvParams<PmMachine>;
using EvAmPlant = EvPlant<AmMachine>;
using EvAmParams = EvParams<AmMachine>;
// the names the machine EVs had before EvPlant (hil/kinds/ev_machine.cpp)
template <class Drive>
using EvMachinePlant = EvPlant<Drive>;
template <class Drive>
using EvMachineParams = EvParams<Drive>;
extern template class EvPlant<PmMachine>;
extern template class EvPlant<AmMachine>;

}  // namespace ehpt::plant
