// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The EV's built-in ECU: the driver-follower. The driver (PropDriver, part of the plant) asks
// for a torque at the drive shaft; this ECU passes it to the drive as its torque reference,
// once per ECU period. An external ECU on a bus replaces it and may do anything else (torque
// shaping, limits, a speed controller of its own).

#include "msgs/ev.hpp"

namespace ehpt::ecu {

struct EvFollowerParams {};  // nothing to set: it passes the driver's request on

class EvFollower {
 public:
  // Run phase.
  void update(const msgs::EvSensors& in, msgs::EvCommand& out) { out.driveTauRef_Nm = in.driverRequest_Nm; }
};

}  // namespace ehpt::ecu
