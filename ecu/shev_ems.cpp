// SPDX-License-Identifier: BSD-3-Clause
#include "ecu/shev_ems.hpp"

#include <algorithm>
#include <cmath>

namespace ehpt::ecu {

using plant::number_text;

const char* ecu_name(ShevEmsKind kind) {
  switch (kind) {
    case ShevEmsKind::kPowerFilt: return "PowerFilt";
    case ShevEmsKind::kPowerFiltSoc: return "PowerFiltSoc";
    case ShevEmsKind::kShevEms: return "ShevEMS";
  }
  return "?";
}

void validate(const ShevEmsParams& p, const std::string& at, Problems& problems) {
  problems.require_positive(at + ".power_filter_s", p.power_filter_s);
  problems.require_finite(at + ".power_filter_initial_W", p.power_filter_initial_W);
  problems.require_in(at + ".soc_ref", p.soc_ref, 0.0, 1.0);
  problems.require_non_negative(at + ".soc_gain_W", p.soc_gain_W);
  problems.require_positive(at + ".power_max_W", p.power_max_W);
  if (p.kind == ShevEmsKind::kShevEms) {
    problems.require_finite(at + ".on_W", p.on_W);
    problems.require_finite(at + ".off_W", p.off_W);
    if (std::isfinite(p.on_W) && std::isfinite(p.off_W) && !(p.off_W < p.on_W)) {
      problems.add(at + ".off_W", number_text(p.off_W), "must be < on_W = " + number_text(p.on_W) + " (hysteresis)");
    }
    if (std::isfinite(p.off_W) && !(p.off_W > 0.0)) {
      problems.add(at + ".off_W", number_text(p.off_W),
                   "must be > 0: P_c is clamped to >= 0, so it is never below off_W and the genset would never stop");
    }
    if (std::isfinite(p.on_W) && p.on_W >= p.power_max_W) {
      problems.add(at + ".on_W", number_text(p.on_W),
                   "must be < power_max_W = " + number_text(p.power_max_W) +
                       ": P_c never exceeds power_max_W, so the genset would never start");
    }
  }
}

ShevEms::ShevEms(const ShevEmsParams& params, double period_s)
    : p_(params), a_power_(1.0 - std::exp(-period_s / params.power_filter_s)), p_f_W_(params.power_filter_initial_W) {
  if (p_.kind == ShevEmsKind::kPowerFilt) p_.soc_gain_W = 0.0;
}

// Run phase: no allocation.
void ShevEms::update(const msgs::ShevSensors& in, msgs::ShevCommand& out) {
  out.driveTauRef_Nm = in.driverRequest_Nm;
  p_c_W_ = std::clamp(p_f_W_ + p_.soc_gain_W * (p_.soc_ref - in.batSOC), 0.0, p_.power_max_W);
  if (p_.kind == ShevEmsKind::kShevEms) {
    if (!on_ && p_c_W_ > p_.on_W) on_ = true;
    if (on_ && p_c_W_ < p_.off_W) on_ = false;
  } else {
    on_ = true;
  }
  out.gensetON = on_;
  out.gensetPowRef_W = on_ ? p_c_W_ : 0.0;
  // the filter, exact for the input held over the period
  p_f_W_ += a_power_ * (in.drivePowDc_W - p_f_W_);
}

}  // namespace ehpt::ecu
