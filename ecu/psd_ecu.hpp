// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Power-split ECUs MBecu1, MBecu1soc, MBecu2 (library Ecu1/Ecu2/Ecu3, V3 PsdEcu1/2/3),
// MODELS.md §5. Paper: P15 §5.2 (rules 1-6), Fig. 21.
//
// A discrete-time block run every period_s (a whole multiple of the plant step). Its two
// first-order filters are discretised exactly for an input held over the period,
// y[k+1] = y[k] + (1 - exp(-Ts/T)) (u[k] - y[k]), so the continuous library ECU and this
// one agree at the sampling instants. One update, from the bus at t_k:
//   motTauRef = maxTorqueReq * driverRequest                         (mot follows the driver)
//   P_add     = P_avg + socLoopGain (socRef - batSOC)                (MBecu1: gain 0)
//   iceON     = hysteresis(P_add; on above onThreshold, off below offThreshold)   (MBecu2;
//               the others keep the engine on)
//   icePowRef = iceON ? P_add : 0
//   w_ref     = iceON ? max(w_min, PowToW(icePowRef)) : ice_off_speed_ref   (§5.4)
//   genTauRef = clamp(tau_gf, -genTorqueMax, genTorqueMax)           (§13 item 11)
//   then the states: P_avg  += a_p (motPowDelB - P_avg),            T = powFiltT (60 s)
//                    tau_gf += a_g (genLoopGain (w_ref - iceW) - tau_gf),   T = 1 s
// The engine follows the averaged traction power, gen on the sun holds the engine at the
// speed that is optimal for that power, mot gives the wheels what the driver asks, and the
// battery covers the difference (rules 1-5); MBecu2 switches the engine off at low power.

#include <string>

#include "msgs/psd.hpp"
#include "plant/problems.hpp"
#include "plant/table.hpp"

// ecu/: the built-in controllers. They are not part of the plant: they read a sensor message
// and write a command message (msgs/), exactly what an external ECU on a bus does, and use
// only plant/'s tables and load-time Problems.
namespace ehpt::ecu {

using plant::Problems;
using plant::Table1d;

enum class PsdEcuKind { kMBecu1, kMBecu1soc, kMBecu2 };
const char* ecu_name(PsdEcuKind kind);

struct PsdEcuParams {
  PsdEcuKind kind = PsdEcuKind::kMBecu2;
  double period_s = 0.0;                 // 0: the plant step
  double max_torque_request_Nm = 80.0;   // motTauRef for a request of 1.0
  double power_filter_s = 60.0;          // powFiltT
  double gen_loop_gain_Nm_s_rad = 1.0;   // genLoopGain (every PSecu example: 1.0)
  double gen_filter_s = 1.0;
  double gen_torque_max_Nm = 80.0;
  double ice_speed_min_rad_s = 125.0;    // floor of the speed reference
  Table1d power_to_speed_rad_s;          // PowToW: W -> rad/s, linear, extrapolated
  double soc_ref = 0.6;
  double soc_loop_gain_W = 50000.0;      // W per unit of SOC error (ignored by MBecu1)
  double on_threshold_W = 7000.0;        // MBecu2
  double off_threshold_W = 5000.0;       // MBecu2
  double ice_off_speed_ref_rad_s = 125.0;  // MBecu2, engine off (0: the paper's description)
};

void validate(const PsdEcuParams& p, const std::string& at, Problems& problems);

class PsdEcu {
 public:
  PsdEcu(const PsdEcuParams& params, double period_s);

  // Run phase: one ECU period: the sensors sampled at its start -> the command for it.
  void update(const msgs::PsdSensors& in, msgs::PsdCommand& out);

  double power_average_W() const { return p_avg_W_; }

 private:
  PsdEcuParams p_;
  double a_power_, a_gen_;      // 1 - exp(-Ts / T)
  double p_avg_W_ = 0.0;        // P_avg(0) = 0
  double tau_gf_Nm_ = 0.0;      // tau_gf(0) = 0
  bool ice_on_ = false;         // MBecu2: iceON(0) = false
};

}  // namespace ehpt::ecu
