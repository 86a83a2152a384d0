// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// FMI-LS-BUS 1.0.0, Network Abstraction ("Low-Cut") for CAN, written from the specification
// (fmi-standard.org, FMI-LS-BUS §4.1 and §4.4.1): a bus terminal's Tx_Data and Rx_Data are
// fmi3Binary buffers holding a sequence of operations, each
//     OP Code (4 bytes) | Total Length (4 bytes: the whole operation) | arguments
// numbers little-endian. The operations used here:
//     CAN Transmit  0x10: ID (4) | Ide (1) | Rtr (1) | Data Length (2) | Data      16 + n bytes
//     Bus Error     0x31: ID (4) | Error Code (1) | Error Flag (1) | Is Sender (1)  15 bytes
//     Status        0x41: Status (1: 1 error active, 2 error passive, 3 bus-off)    9 bytes
//     Format Error  0x01: Data Length (2) | Data (the operation it refuses)       10 + n bytes
// A Network FMU on a classic-CAN contract: CAN FD and XL Transmit and remote frames are other
// nodes' business on a mixed bus (valid operations, counted and let be); what is not an
// operation of the standard at all is answered by a Format Error.
// Pure functions over byte spans, and LsBusTerminal: a Transport (io/can/transport.hpp) whose
// sent frames go into a Tx buffer and whose received frames come from an Rx buffer, for an
// FMU (targets/fmu/) to hand to its importer. Buffers are sized at construction: nothing is
// allocated after it.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "io/can/transport.hpp"

namespace ehpt::io::can::ls_bus {

inline constexpr std::uint32_t kOpFormatError = 0x01;
inline constexpr std::uint32_t kOpCanTransmit = 0x10;
inline constexpr std::uint32_t kOpCanFdTransmit = 0x11;
inline constexpr std::uint32_t kOpCanXlTransmit = 0x12;
inline constexpr std::uint32_t kOpConfirm = 0x20;
inline constexpr std::uint32_t kOpArbitrationLost = 0x30;
inline constexpr std::uint32_t kOpBusError = 0x31;
inline constexpr std::uint32_t kOpConfiguration = 0x40;
inline constexpr std::uint32_t kOpStatus = 0x41;
inline constexpr std::uint32_t kOpWakeup = 0x42;

inline constexpr std::size_t kHeaderBytes = 8;
inline constexpr std::size_t kTransmitBytes = 16;  // without its data
inline constexpr std::size_t kBusErrorBytes = 15;
inline constexpr std::size_t kStatusBytes = 9;

// Bus Error's Error Code, Error Flag; Status' Status
inline constexpr std::uint8_t kFormError = 0x03;
inline constexpr std::uint8_t kPrimaryErrorFlag = 0x01;
inline constexpr std::uint8_t kErrorActive = 0x01, kErrorPassive = 0x02, kBusOff = 0x03;

// The MIME type of the terminal's Binary variables (FMI-LS-BUS §4.3.4).
inline constexpr const char* kMimeType = "application/org.fmi-standard.fmi-ls-bus.can; version=\"1.0.0\"";

// Appends one operation to out[used..]; the bytes written, 0 if it does not fit (nothing written).
std::size_t put_transmit(std::span<std::uint8_t> out, std::size_t used, const Frame& frame);
std::size_t put_bus_error(std::span<std::uint8_t> out, std::size_t used, std::uint32_t id, std::uint8_t code,
                          std::uint8_t flag, bool is_sender);
std::size_t put_status(std::span<std::uint8_t> out, std::size_t used, std::uint8_t status);
// A Format Error carrying the operation it refuses (as much of it as the standard's 2-byte Data
// Length holds).
std::size_t put_format_error(std::span<std::uint8_t> out, std::size_t used, std::span<const std::uint8_t> refused);

// What one Rx buffer held.
struct RxCounts {
  std::int64_t frames = 0;        // CAN Transmit operations with a classic frame (0..8 bytes)
  std::int64_t bus_errors = 0;    // Bus Error operations
  std::int64_t status = 0;        // Status operations
  std::int64_t ignored = 0;       // well-formed operations a Network FMU may let be (Confirm, Configuration, ...)
  std::int64_t not_classic = 0;   // CAN FD and XL Transmit, remote frames: valid, not this contract's
  std::int64_t malformed = 0;     // not LS-BUS CAN (a length that does not add up, an unknown OP code)
  std::uint8_t last_status = 0;   // the last Status operation's value (0: none)
};

// Walks an Rx buffer: each CAN Transmit's frame to on_frame(const Frame&), each malformed
// operation to on_malformed(span of its bytes) (a length that runs past the buffer ends the
// walk: the rest is that one malformed operation).
template <class OnFrame, class OnMalformed>
RxCounts parse(std::span<const std::uint8_t> in, OnFrame&& on_frame, OnMalformed&& on_malformed);

// One CAN bus terminal of an FMU: a Transport over its Tx_Data and Rx_Data.
class LsBusTerminal final : public Transport {
 public:
  explicit LsBusTerminal(std::size_t tx_bytes = 4096, std::size_t rx_frames = 1024);

  bool send(const Frame& frame) override;
  std::size_t receive(std::span<Frame> out) override;
  bool wait(std::int64_t) override { return rx_count_ > 0; }  // nothing comes while the FMU runs
  bool has_peer() const override { return true; }
  const TransportCounters& counters() const override { return counters_; }
  std::string describe() const override { return "fmi-ls-bus"; }
  // Bus Error and Status operations (a bus fault's error frames, bus-off and restart)
  bool sends_error_frames() const override { return true; }
  bool send_error(ErrorFrame e) override;

  // The operations sent since clear_tx (Tx_Data); the terminal keeps them until then.
  std::span<const std::uint8_t> tx() const { return {tx_.data(), tx_used_}; }
  void clear_tx() { tx_used_ = 0; }
  // Rx_Data: its frames queued for receive (a full queue drops the rest, counted), the rest
  // counted; each malformed operation answered by a Format Error in Tx. Returns its counts.
  RxCounts take_rx(std::span<const std::uint8_t> rx);

  // Figures: operations received, by kind, over the whole run.
  const RxCounts& rx_totals() const { return rx_totals_; }
  std::int64_t rx_dropped() const { return rx_dropped_; }

 private:
  std::vector<std::uint8_t> tx_;
  std::size_t tx_used_ = 0;
  std::vector<Frame> rx_;
  std::size_t rx_head_ = 0, rx_count_ = 0;
  RxCounts rx_totals_;
  std::int64_t rx_dropped_ = 0;
  TransportCounters counters_;
};

// --- implementation of parse ---

std::uint32_t read_u32(const std::uint8_t* p);
std::uint16_t read_u16(const std::uint8_t* p);

template <class OnFrame, class OnMalformed>
RxCounts parse(std::span<const std::uint8_t> in, OnFrame&& on_frame, OnMalformed&& on_malformed) {
  RxCounts c;
  std::size_t at = 0;
  while (at < in.size()) {
    const std::size_t left = in.size() - at;
    const std::uint8_t* p = in.data() + at;
    const std::uint32_t length = left >= kHeaderBytes ? read_u32(p + 4) : 0;
    if (left < kHeaderBytes || length < kHeaderBytes || length > left) {
      ++c.malformed;
      on_malformed(in.subspan(at));
      break;
    }
    const std::uint32_t op = read_u32(p);
    bool ok = true;
    switch (op) {
      case kOpCanTransmit: {
        const std::size_t n = length >= kTransmitBytes ? read_u16(p + 14) : 0;
        ok = length >= kTransmitBytes && length == kTransmitBytes + n && p[12] <= 1 && p[13] <= 1;
        if (!ok) break;
        Frame f;
        f.id = read_u32(p + 8);
        f.extended = p[12] == 1;
        ok = f.id <= (f.extended ? kMaxExtendedId : kMaxStandardId);
        if (!ok) break;
        if (p[13] == 1 || n > 8) {  // a remote frame, or more than 8 bytes: not classic CAN data
          ++c.not_classic;
          break;
        }
        f.len = static_cast<std::uint8_t>(n);
        for (std::size_t i = 0; i < n; ++i) f.data[i] = p[kTransmitBytes + i];
        ++c.frames;
        on_frame(f);
        break;
      }
      case kOpCanFdTransmit:
      case kOpCanXlTransmit:
        ++c.not_classic;  // another node's, on a mixed bus: its layout is not read here
        break;
      case kOpBusError:
        ok = length == kBusErrorBytes;
        if (ok) ++c.bus_errors;
        break;
      case kOpStatus:
        ok = length == kStatusBytes && p[8] >= kErrorActive && p[8] <= kBusOff;
        if (ok) {
          ++c.status;
          c.last_status = p[8];
        }
        break;
      case kOpFormatError:
      case kOpConfirm:
      case kOpArbitrationLost:
      case kOpConfiguration:
      case kOpWakeup:
        ++c.ignored;  // a Network FMU that does not wait for bus notifications may let them be
        break;
      default:  // not an operation of the standard
        ok = false;
        break;
    }
    if (!ok) {
      ++c.malformed;
      on_malformed(in.subspan(at, length));
    }
    at += length;
  }
  return c;
}

}  // namespace ehpt::io::can::ls_bus
