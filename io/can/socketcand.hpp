// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// socketcand endpoints (the TCP text protocol of linux-can/socketcand, raw mode), so that
// python-can's interface="socketcand" and other socketcand clients reach the plant on
// machines whose kernel has no CAN.
//   Server (the plant): listens on HOST:PORT and serves one bus to up to 8 clients (one
//   that has not finished its handshake after 5 s is dropped). Per client: "< hi >";
//   "< open CHANNEL >" -> "< ok >"; "< rawmode >" -> "< ok >"; then every frame on the bus
//   goes to it as " < frame ID SECS.USECS DATA >" and its "< send ID LEN B0 B1 ... >" frames
//   reach the plant and the other clients (a bus: everyone hears everyone else).
//   Client (an ECU): connects, does the handshake, then the same two message kinds.
// Traps of python-can 4.1's client, measured: each handshake reply must arrive as its own
// TCP read (sent as its own write with TCP_NODELAY, and no frame to a client until it has
// had time to read its last "< ok >"); it drops a character after each read, so every
// frame is preceded by a space; it reads data only as contiguous hex.

#include <cstdint>
#include <memory>
#include <string>

#include "io/can/transport.hpp"

namespace ehpt::io::can {

// nullptr and one line in error ("socketcand:127.0.0.1:29536: port in use") if it cannot listen.
std::unique_ptr<Transport> open_socketcand_server(const std::string& host, std::uint16_t port, std::string& error);
// Connects and completes the handshake within timeout_s; nullptr and one line in error if not.
std::unique_ptr<Transport> open_socketcand_client(const std::string& host, std::uint16_t port,
                                                  const std::string& channel, double timeout_s, std::string& error);

// Pure, for the tests: one message of the protocol, "< ... >", parsed. kFrame fills frame.
// kOpen: "< open CHANNEL >" with a channel name socketcand would take (1..15 of letters,
// digits, '_', '-', '.'); kBadChannel: one it would not; kEcho: "< echo >" (socketcand answers
// it with the same: a client's keep-alive).
enum class SocketcandMessage { kFrame, kSend, kOpen, kBadChannel, kEcho, kRawmode, kHi, kOk, kError, kOther, kMalformed };
SocketcandMessage parse_socketcand(std::string_view message, Frame& frame);

}  // namespace ehpt::io::can
