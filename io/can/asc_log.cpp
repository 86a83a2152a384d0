// SPDX-License-Identifier: BSD-3-Clause
#include "io/can/asc_log.hpp"

#include <cmath>
#include <cstdio>
#include <ctime>

namespace ehpt::io::can {

std::string asc_header(double start_s) {
  // "Wed Dec 02 01:00:00.123 am 2026": C locale names, 12-hour clock with am/pm, as Vector writes it
  const auto whole = static_cast<std::time_t>(std::floor(start_s));
  const int ms = static_cast<int>(std::floor((start_s - std::floor(start_s)) * 1000.0));
  std::tm tm{};
  localtime_r(&whole, &tm);
  static const char* const kDays[] = {"Sun", "Mon", "Tue", "Wed", "Thu", "Fri", "Sat"};
  static const char* const kMonths[] = {"Jan", "Feb", "Mar", "Apr", "May", "Jun",
                                        "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"};
  const int hour12 = tm.tm_hour % 12 == 0 ? 12 : tm.tm_hour % 12;
  char date[64];
  std::snprintf(date, sizeof date, "%s %s %02d %02d:%02d:%02d.%03d %s %d", kDays[tm.tm_wday], kMonths[tm.tm_mon],
                tm.tm_mday, hour12, tm.tm_min, tm.tm_sec, ms, tm.tm_hour < 12 ? "am" : "pm", tm.tm_year + 1900);
  return std::string("date ") + date + "\nbase hex  timestamps absolute\ninternal events logged\n// ehpt bus log\n" +
         "Begin Triggerblock " + date + "\n";
}

void append_asc_line(std::string& out, double t_s, const Frame& f, bool rx) {
  char buf[96];
  // Vector's form: an extended id is written with an "x" after it
  char id[16];
  std::snprintf(id, sizeof id, f.extended ? "%Xx" : "%X", static_cast<unsigned>(f.id & kMaxExtendedId));
  int n = std::snprintf(buf, sizeof buf, "%11.6f 1  %-15s %s   d %u", t_s < 0.0 ? 0.0 : t_s, id, rx ? "Rx" : "Tx",
                        static_cast<unsigned>(f.len));
  for (int i = 0; i < f.len && i < 8; ++i) {
    n += std::snprintf(buf + n, sizeof buf - static_cast<std::size_t>(n), " %02X", f.data[static_cast<std::size_t>(i)]);
  }
  buf[n++] = '\n';
  out.append(buf, static_cast<std::size_t>(n));
}

}  // namespace ehpt::io::can
