#pragma once
// Readers of the component tables a vehicle file is made of ([vehicle], [road], [drive],
// [battery], [driver], [brake], [ice], the ECU's timing), shared by the vehicle kinds.
// Start-up only.

#include "hil/config.hpp"
#include "hil/config_reader.hpp"
#include "plant/bev_plant.hpp"
#include "plant/map_ice.hpp"

namespace ehpt::hil::detail {

plant::MapDriveParams read_drive(Reader r, Context& ctx);
plant::BatteryRcParams read_battery(Reader r);
plant::RoadLoadParams read_road(Reader r, Context& ctx);
plant::VehicleBodyParams read_body(Reader r);
plant::PropDriverParams read_driver(Reader r);
plant::BrakeParams read_brake(Reader r);
plant::MapIceParams read_ice(Reader r, Context& ctx);
void read_ecu_timing(Reader& r, EcuTiming& t);

}  // namespace ehpt::hil::detail
