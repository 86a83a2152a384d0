// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Readers of the component tables a vehicle file is made of ([vehicle], [road], [drive],
// [battery], [driver], [brake], [ice], the ECU's timing), shared by the vehicle kinds.
// Start-up only.

#include "hil/config/config.hpp"
#include "hil/config/config_reader.hpp"
#include "plant/bev_plant.hpp"
#include "plant/map_ice.hpp"
#include "plant/am_drive.hpp"
#include "plant/pm_drive.hpp"

namespace ehpt::hil::detail {

plant::MapDriveParams read_drive(Reader r, Context& ctx);
// PMDrive machine data ([drive] of an ev_pm vehicle, [machine] of the PM test rig): keys = field names
plant::PmDriveParams read_pm_drive(Reader r);
// AMDrive machine data ([drive] of an ev_am vehicle, [machine] of the AM test rig): keys = field names
plant::AmDriveParams read_am_drive(Reader r);
plant::BatteryRcParams read_battery(Reader r);
plant::RoadLoadParams read_road(Reader r, Context& ctx);
plant::VehicleBodyParams read_body(Reader r);
plant::PropDriverParams read_driver(Reader r);
plant::BrakeParams read_brake(Reader r);
plant::MapIceParams read_ice(Reader r, Context& ctx);
void read_ecu_timing(Reader& r, EcuTiming& t);

}  // namespace ehpt::hil::detail
