// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The transport's floor for the lockstep exchange (issue 26, item 4): two processes on this
// machine's loopback passing one message each way per round trip, each one write and one
// blocking read, nothing else. A lockstep period is that plus the plant's steps, the codecs
// and the logs, so periods/s over round trips/s says how much of the exchange is ehpt's own.
//   TCP: the shape of a socketcand session (TCP_NODELAY both ways, as the plant and ehpt ecu set);
//   UDP: the shape of LCM udpm (one datagram each way; unicast on 127.0.0.1).

#include <cstddef>
#include <cstdint>
#include <string>

namespace ehpt::bench {

struct PingPong {
  std::string error;             // empty: measured
  std::int64_t round_trips = 0;  // in the measured window (after a warm-up)
  double seconds = 0.0;          // the measured window
  double round_trips_per_s() const { return seconds > 0.0 ? static_cast<double>(round_trips) / seconds : 0.0; }
};

enum class PingPongKind { kTcp, kUdp };

// Forks a child (the echoing side) and measures for `seconds` after a 0.2 s warm-up; out_bytes
// go one way and back_bytes come back (each 1..65000). The bench must have one thread (fork);
// the child is killed and reaped whatever happens.
PingPong ping_pong(PingPongKind kind, std::size_t out_bytes, std::size_t back_bytes, double seconds);

}  // namespace ehpt::bench
