// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Vector ASC log text (the format CANoe and CANalyzer write and read, and python-can's
// ASCReader reads): a header with the start's local date, then one line per frame,
// "   0.010000 1  210             Rx   d 8 00 11 22 33 44 55 66 77", its time relative to the
// start, channel 1, the id in hex, the direction as the plant sees it. Pure.

#include <string>

#include "io/can/frame.hpp"

namespace ehpt::io::can {

// The header for a log that starts at wall time start_s (seconds since the epoch), in local time.
std::string asc_header(double start_s);
// The last line.
inline const char* asc_footer() { return "End TriggerBlock\n"; }
// Appends one frame's line (with '\n'); t_s from the start. Allocates only if `out` lacks the
// capacity (reserve it).
void append_asc_line(std::string& out, double t_s, const Frame& f, bool rx);

}  // namespace ehpt::io::can
