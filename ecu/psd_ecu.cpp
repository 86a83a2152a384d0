// SPDX-License-Identifier: BSD-3-Clause
#include "ecu/psd_ecu.hpp"

#include <algorithm>
#include <cmath>

namespace ehpt::ecu {

using plant::number_text;

const char* ecu_name(PsdEcuKind kind) {
  switch (kind) {
    case PsdEcuKind::kMBecu1: return "MBecu1";
    case PsdEcuKind::kMBecu1soc: return "MBecu1soc";
    case PsdEcuKind::kMBecu2: return "MBecu2";
  }
  return "?";
}

void validate(const PsdEcuParams& p, const std::string& at, Problems& problems) {
  problems.require_positive(at + ".max_torque_request_Nm", p.max_torque_request_Nm);
  problems.require_positive(at + ".power_filter_s", p.power_filter_s);
  problems.require_non_negative(at + ".gen_loop_gain_Nm_s_rad", p.gen_loop_gain_Nm_s_rad);
  problems.require_positive(at + ".gen_filter_s", p.gen_filter_s);
  problems.require_positive(at + ".gen_torque_max_Nm", p.gen_torque_max_Nm);
  problems.require_non_negative(at + ".ice_speed_min_rad_s", p.ice_speed_min_rad_s);
  validate(p.power_to_speed_rad_s, at + ".power_to_speed", false, problems);
  problems.require_in(at + ".soc_ref", p.soc_ref, 0.0, 1.0);
  problems.require_non_negative(at + ".soc_loop_gain_W", p.soc_loop_gain_W);
  problems.require_finite(at + ".on_threshold_W", p.on_threshold_W);
  problems.require_finite(at + ".off_threshold_W", p.off_threshold_W);
  if (p.kind == PsdEcuKind::kMBecu2 && !(p.off_threshold_W < p.on_threshold_W)) {
    problems.add(at + ".off_threshold_W", number_text(p.off_threshold_W),
                 "must be < on_threshold_W = " + number_text(p.on_threshold_W) + " (hysteresis)");
  }
  problems.require_non_negative(at + ".ice_off_speed_ref_rad_s", p.ice_off_speed_ref_rad_s);
}

PsdEcu::PsdEcu(const PsdEcuParams& params, double period_s)
    : p_(params),
      a_power_(1.0 - std::exp(-period_s / params.power_filter_s)),
      a_gen_(1.0 - std::exp(-period_s / params.gen_filter_s)) {
  if (p_.kind == PsdEcuKind::kMBecu1) p_.soc_loop_gain_W = 0.0;
}

// Run phase: no allocation.
void PsdEcu::update(const msgs::PsdSensors& in, msgs::PsdCommand& out) {
  // mot follows the driver directly
  out.motTauRef_Nm = p_.max_torque_request_Nm * in.driverRequest;
  // engine power: averaged traction power plus the SOC loop
  const double p_add_W = p_avg_W_ + p_.soc_loop_gain_W * (p_.soc_ref - in.batSOC);
  if (p_.kind == PsdEcuKind::kMBecu2) {
    if (!ice_on_ && p_add_W > p_.on_threshold_W) ice_on_ = true;
    if (ice_on_ && p_add_W < p_.off_threshold_W) ice_on_ = false;
  } else {
    ice_on_ = true;
  }
  out.iceON = ice_on_;
  out.icePowRef_W = ice_on_ ? p_add_W : 0.0;
  out.iceTauRef_Nm = 0.0;  // the built-in ECUs send power (IceConnP)
  // gen holds the engine at the optimal speed for that power
  const double speed_ref_rad_s = ice_on_ ? std::max(p_.ice_speed_min_rad_s, p_.power_to_speed_rad_s(out.icePowRef_W))
                                         : p_.ice_off_speed_ref_rad_s;
  out.genTauRef_Nm = std::clamp(tau_gf_Nm_, -p_.gen_torque_max_Nm, p_.gen_torque_max_Nm);
  // filters, exact for inputs held over the period
  p_avg_W_ += a_power_ * (in.motPowDelB_W - p_avg_W_);
  tau_gf_Nm_ += a_gen_ * (p_.gen_loop_gain_Nm_s_rad * (speed_ref_rad_s - in.iceW_rad_s) - tau_gf_Nm_);
}

}  // namespace ehpt::ecu
