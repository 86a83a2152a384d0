// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// A CAN transport: how frames reach the other side (SocketCAN raw socket, a socketcand TCP
// endpoint, an in-memory pair for tests). Owned by the target, never called from plant code.
// Every call is non-blocking and never throws; problems are counted, never fatal, except at
// open (a clear error message). No allocation after open.

#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "io/can/frame.hpp"

namespace ehpt::io::can {

struct TransportCounters {
  std::int64_t frames_in = 0;       // data frames received and handed out
  std::int64_t frames_out = 0;      // data frames sent
  std::int64_t send_dropped = 0;    // not sent: TX queue full, no peer (nobody got the frame)
  std::int64_t slow_drops = 0;      // socketcand: a frame one client did not get (its buffer full), others did
  std::int64_t error_frames = 0;    // CAN error frames (SocketCAN), protocol errors of clients (socketcand)
  std::int64_t rx_malformed = 0;    // received text or frames that are not a classic data frame
  std::int64_t peers_connected = 0; // socketcand: clients that completed the handshake
  std::int64_t peers_lost = 0;      // socketcand: clients that went away
  std::int64_t peers_refused = 0;   // socketcand: connections refused (every slot taken)
  std::int64_t peers_evicted = 0;   // socketcand: listeners that never sent, dropped for a new client
  std::int64_t error_frames_sent = 0;  // CAN error frames put on the bus (bus faults, SocketCAN)
};

// A CAN error frame as SocketCAN reports one (linux/can/error.h), put on a virtual bus by the
// plant's bus faults for the ECU to see: a protocol error (a form error, as a disturbed bit
// gives), the controller going bus-off, and its restart.
enum class ErrorFrame { kBusError, kBusOff, kRestarted };

class Transport {
 public:
  virtual ~Transport() = default;
  // Queues one frame for sending; false (counted in send_dropped) if it cannot go now.
  virtual bool send(const Frame& frame) = 0;
  // The frames sent between cork() and uncork() leave together at uncork(), in one write per
  // peer where the transport has a stream (socketcand: a sample's frames are one TCP segment,
  // not one each, and the peer wakes once); outside, each send() writes at once. Transports
  // with one message per frame (SocketCAN, the in-process bus) send at once either way.
  virtual void cork() {}
  virtual void uncork() {}
  // Up to out.size() received frames (0: none now). Never blocks. Fewer than out.size(): the
  // transport had no more at the call (what comes later wakes wait()), so a caller drains
  // with one call, not one more that finds nothing.
  virtual std::size_t receive(std::span<Frame> out) = 0;
  // Waits up to timeout_ns for something to receive (or a peer to arrive); true if there may
  // be. The only call that may block, and only as long as asked.
  virtual bool wait(std::int64_t timeout_ns) = 0;
  // True when the other side can hear us (SocketCAN: always; socketcand: a client is in rawmode).
  virtual bool has_peer() const = 0;
  virtual const TransportCounters& counters() const = 0;
  virtual std::string describe() const = 0;  // e.g. "socketcan:vcan0"
  // Whether send_error can put error frames on this bus (SocketCAN can; socketcand's protocol
  // has no error frames).
  virtual bool sends_error_frames() const { return false; }
  // Puts one error frame on the bus; false if it cannot (not counted as a data frame).
  virtual bool send_error(ErrorFrame) { return false; }
};

}  // namespace ehpt::io::can
