// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The series hybrid's energy management (MODELS.md §5.5 and §10.6): the EMS of the library's
// SHEVpowerFilt and SHEVpowerFiltSoc examples (blocks in the example) and ShevEMS (SHEV_OO).
//
// A discrete-time block run every period_s (a whole multiple of the plant step). Its power
// filter is discretised exactly for an input held over the period,
//   P_f[k+1] = P_f[k] + (1 - exp(-Ts/T)) (drivePowDc[k] - P_f[k]),   P_f(0) = power_filter_initial_W,
// so the continuous library block and this one agree at the sampling instants. One update, from
// the bus at t_k:
//   driveTauRef = driverRequest                                   (the drive follows the driver)
//   P_c         = clamp(P_f + soc_gain_W (soc_ref - batSOC), 0, power_max_W)   (PowerFilt: gain 0)
//   on          = hysteresis(P_c; on above on_W, off below off_W), on(0) = false   (ShevEMS;
//                 the others keep the genset on)
//   gensetPowRef = on ? P_c : 0,  gensetON = on
// The genset follows the averaged traction power; the SOC loop pulls the battery back to
// soc_ref; ShevEMS stops the engine while the power it would give is too low to be efficient.
// The crossing of on_W / off_W is located at the ECU's sampling instants: the switch happens at
// the first sample at which P_c is beyond the threshold (P_c moves by a few W per 10 ms period).

#include <string>

#include "msgs/shev.hpp"
#include "plant/problems.hpp"

namespace ehpt::ecu {

using plant::Problems;

enum class ShevEmsKind { kPowerFilt, kPowerFiltSoc, kShevEms };
const char* ecu_name(ShevEmsKind kind);

struct ShevEmsParams {
  ShevEmsKind kind = ShevEmsKind::kShevEms;
  double period_s = 0.0;                  // 0: the plant step
  double power_filter_s = 300.0;          // tauPowFilt (SHEVpowerFilt/FiltSoc: 500 s)
  double power_filter_initial_W = 20e3;   // the filter's y_start
  double soc_ref = 0.7;
  double soc_gain_W = 100e3;              // powPerSoc / socErrToPow, W per unit of SOC error (PowerFilt: none)
  double power_max_W = 100e3;             // the clamp's upper bound (the lower is 0)
  double on_W = 5000.0;                   // ShevEMS powHigh
  double off_W = 3000.0;                  // ShevEMS powLow
};

void validate(const ShevEmsParams& p, const std::string& at, Problems& problems);

class ShevEms {
 public:
  ShevEms(const ShevEmsParams& params, double period_s);

  // Run phase: one ECU period: the sensors sampled at its start -> the command for it.
  void update(const msgs::ShevSensors& in, msgs::ShevCommand& out);

  double power_filtered_W() const { return p_f_W_; }
  // P_c of the last update, before the ON/OFF switch (what the hysteresis compared)
  double power_command_W() const { return p_c_W_; }

 private:
  ShevEmsParams p_;
  double a_power_;            // 1 - exp(-Ts / T)
  double p_f_W_;              // P_f
  double p_c_W_ = 0.0;
  bool on_ = false;           // ShevEMS: on(0) = false
};

}  // namespace ehpt::ecu
