// SPDX-License-Identifier: BSD-3-Clause
#include "io/can/bus_spec.hpp"

#include "io/can/socketcan.hpp"
#include "io/can/socketcand.hpp"

namespace ehpt::io::can {

bool parse_bus_spec(std::string_view text, BusSpec& out, std::string& error) {
  const auto usage = [&](const std::string& why) {
    error = "--bus " + std::string(text.substr(0, 200)) + ": " + why +
            " (use socketcan:IFACE or socketcand:HOST:PORT)";
    return false;
  };
  BusSpec spec;
  if (text.rfind("socketcan:", 0) == 0) {
    spec.kind = BusSpec::Kind::kSocketCan;
    spec.interface_name = std::string(text.substr(10));
    if (spec.interface_name.empty() || spec.interface_name.size() > 15 ||
        spec.interface_name.find_first_of("/: ") != std::string::npos) {
      return usage("the interface name must be 1 to 15 characters without '/', ':' or spaces");
    }
  } else if (text.rfind("socketcand:", 0) == 0) {
    spec.kind = BusSpec::Kind::kSocketcand;
    const std::string_view rest = text.substr(11);
    const std::size_t colon = rest.rfind(':');
    if (colon == std::string_view::npos || colon == 0) return usage("HOST:PORT is missing");
    spec.host = std::string(rest.substr(0, colon));
    // an IPv6 address is bracketed, as in a URL: socketcand:[::1]:29536
    if (spec.host.size() >= 2 && spec.host.front() == '[' && spec.host.back() == ']') {
      spec.host = spec.host.substr(1, spec.host.size() - 2);
      if (spec.host.empty()) return usage("the brackets hold no address");
    } else if (spec.host.find_first_of("[]:") != std::string::npos) {
      return usage("an IPv6 address is written in brackets: socketcand:[::1]:PORT");
    }
    const std::string_view port = rest.substr(colon + 1);
    unsigned long value = 0;
    for (char c : port) {
      if (c < '0' || c > '9' || value > 65535) return usage("the port must be a number from 1 to 65535");
      value = value * 10 + static_cast<unsigned long>(c - '0');
    }
    if (port.empty() || value < 1 || value > 65535) return usage("the port must be a number from 1 to 65535");
    spec.port = static_cast<std::uint16_t>(value);
    spec.interface_name = "can0";  // socketcand serves one bus; this names it in bus.log
  } else {
    return usage("unknown transport");
  }
  out = spec;
  return true;
}

std::unique_ptr<Transport> open_bus(const BusSpec& spec, BusRole role, std::span<const std::uint32_t> rx_ids,
                                    std::string& error) {
  if (spec.kind == BusSpec::Kind::kSocketCan) return open_socketcan(spec.interface_name, rx_ids, error);
  if (role == BusRole::kPlant) return open_socketcand_server(spec.host, spec.port, error);
  return open_socketcand_client(spec.host, spec.port, spec.interface_name, 10.0, error);
}

}  // namespace ehpt::io::can
