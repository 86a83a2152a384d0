// SPDX-License-Identifier: BSD-3-Clause
#include "io/can/ls_bus.hpp"

#include <algorithm>

namespace ehpt::io::can::ls_bus {

namespace {

void write_u32(std::uint8_t* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
void write_u16(std::uint8_t* p, std::uint16_t v) {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
// room for n bytes at used: where they go, or nullptr
std::uint8_t* room(std::span<std::uint8_t> out, std::size_t used, std::size_t n) {
  return used <= out.size() && out.size() - used >= n ? out.data() + used : nullptr;
}
void header(std::uint8_t* p, std::uint32_t op, std::size_t length) {
  write_u32(p, op);
  write_u32(p + 4, static_cast<std::uint32_t>(length));
}

}  // namespace

std::uint32_t read_u32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}
std::uint16_t read_u16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>(p[0] | p[1] << 8);
}

std::size_t put_transmit(std::span<std::uint8_t> out, std::size_t used, const Frame& frame) {
  const std::size_t n = std::min<std::size_t>(frame.len, 8);
  std::uint8_t* p = room(out, used, kTransmitBytes + n);
  if (p == nullptr) return 0;
  header(p, kOpCanTransmit, kTransmitBytes + n);
  write_u32(p + 8, frame.id);
  p[12] = frame.extended ? 1 : 0;  // Ide
  p[13] = 0;                       // Rtr: data frames only
  write_u16(p + 14, static_cast<std::uint16_t>(n));
  std::copy_n(frame.data.begin(), n, p + kTransmitBytes);
  return kTransmitBytes + n;
}

std::size_t put_bus_error(std::span<std::uint8_t> out, std::size_t used, std::uint32_t id, std::uint8_t code,
                          std::uint8_t flag, bool is_sender) {
  std::uint8_t* p = room(out, used, kBusErrorBytes);
  if (p == nullptr) return 0;
  header(p, kOpBusError, kBusErrorBytes);
  write_u32(p + 8, id);
  p[12] = code;
  p[13] = flag;
  p[14] = is_sender ? 1 : 0;
  return kBusErrorBytes;
}

std::size_t put_status(std::span<std::uint8_t> out, std::size_t used, std::uint8_t status) {
  std::uint8_t* p = room(out, used, kStatusBytes);
  if (p == nullptr) return 0;
  header(p, kOpStatus, kStatusBytes);
  p[8] = status;
  return kStatusBytes;
}

std::size_t put_format_error(std::span<std::uint8_t> out, std::size_t used, std::span<const std::uint8_t> refused) {
  const std::size_t n = std::min<std::size_t>(refused.size(), 0xFFFF);  // Data Length is 2 bytes
  std::uint8_t* p = room(out, used, kHeaderBytes + 2 + n);
  if (p == nullptr) return 0;
  header(p, kOpFormatError, kHeaderBytes + 2 + n);
  write_u16(p + 8, static_cast<std::uint16_t>(n));
  std::copy_n(refused.begin(), n, p + 10);
  return kHeaderBytes + 2 + n;
}

LsBusTerminal::LsBusTerminal(std::size_t tx_bytes, std::size_t rx_frames)
    : tx_(std::max<std::size_t>(tx_bytes, 64)), rx_(std::max<std::size_t>(rx_frames, 1)) {}

bool LsBusTerminal::send(const Frame& frame) {
  const std::size_t k = put_transmit(tx_, tx_used_, frame);
  if (k == 0) {
    ++counters_.send_dropped;
    return false;
  }
  tx_used_ += k;
  ++counters_.frames_out;
  return true;
}

bool LsBusTerminal::send_error(ErrorFrame e) {
  std::size_t k = 0;
  switch (e) {
    case ErrorFrame::kBusError:  // what a disturbed bit gives: a form error, seen first by this node
      k = put_bus_error(tx_, tx_used_, 0, kFormError, kPrimaryErrorFlag, false);
      break;
    case ErrorFrame::kBusOff:
      k = put_status(tx_, tx_used_, kBusOff);
      break;
    case ErrorFrame::kRestarted:
      k = put_status(tx_, tx_used_, kErrorActive);
      break;
  }
  if (k == 0) return false;
  tx_used_ += k;
  ++counters_.error_frames_sent;
  return true;
}

std::size_t LsBusTerminal::receive(std::span<Frame> out) {
  std::size_t k = 0;
  while (k < out.size() && rx_count_ > 0) {
    out[k++] = rx_[rx_head_];
    rx_head_ = (rx_head_ + 1) % rx_.size();
    --rx_count_;
  }
  counters_.frames_in += static_cast<std::int64_t>(k);
  return k;
}

RxCounts LsBusTerminal::take_rx(std::span<const std::uint8_t> rx) {
  const RxCounts c = parse(
      rx,
      [&](const Frame& f) {
        if (rx_count_ == rx_.size()) {
          ++rx_dropped_;
          return;
        }
        rx_[(rx_head_ + rx_count_) % rx_.size()] = f;
        ++rx_count_;
      },
      [&](std::span<const std::uint8_t> refused) { tx_used_ += put_format_error(tx_, tx_used_, refused); });
  rx_totals_.frames += c.frames;
  rx_totals_.bus_errors += c.bus_errors;
  rx_totals_.status += c.status;
  rx_totals_.ignored += c.ignored;
  rx_totals_.not_classic += c.not_classic;
  rx_totals_.malformed += c.malformed;
  if (c.last_status != 0) rx_totals_.last_status = c.last_status;
  counters_.error_frames += c.bus_errors;
  counters_.rx_malformed += c.malformed;
  return c;
}

}  // namespace ehpt::io::can::ls_bus
