// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// --bus on the command line: which transport, where.
//   socketcan:IFACE            a SocketCAN interface (vcan0, can0)
//   socketcand:HOST:PORT       a socketcand endpoint: the plant listens there, an ECU connects
// Parsing is pure; open_bus() opens the transport (start-up only).

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>

#include "io/can/transport.hpp"

namespace ehpt::io::can {

struct BusSpec {
  enum class Kind { kSocketCan, kSocketcand } kind = Kind::kSocketCan;
  std::string interface_name;  // socketcan; for socketcand the channel name in bus.log
  std::string host;            // socketcand
  std::uint16_t port = 0;      // socketcand
};

bool parse_bus_spec(std::string_view text, BusSpec& out, std::string& error);

enum class BusRole { kPlant, kEcu };  // on socketcand the plant serves and the ECU connects

// rx_ids: the ids this side accepts (SocketCAN's kernel filter; socketcand takes all and the
// codec's filter counts the others). nullptr and one line in error if it cannot open.
std::unique_ptr<Transport> open_bus(const BusSpec& spec, BusRole role, std::span<const std::uint32_t> rx_ids,
                                    std::string& error);

}  // namespace ehpt::io::can
