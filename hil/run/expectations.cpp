// SPDX-License-Identifier: BSD-3-Clause
#include "hil/run/expectations.hpp"

#include <cstdio>

#include "io/number_format.hpp"

namespace ehpt::hil {

ExpectOutcome judge_figure(const ExpectSpec& e, double value) {
  ExpectOutcome o;
  o.value = value;
  o.passed = bound_violation(e, value, e.value) == 0.0;
  o.why = o.passed ? ExpectOutcome::Why::kHeld : ExpectOutcome::Why::kOutOfBound;
  return o;
}

namespace {

std::string bound_text(const ExpectSpec& e) {
  std::string b;
  const auto add = [&](const std::string& s) { b += (b.empty() ? "" : " and ") + s; };
  if (e.has_min && e.has_max) {
    add("in [" + io::number_text(e.min) + ", " + io::number_text(e.max) + "]");
  } else if (e.has_min) {
    add(">= " + io::number_text(e.min));
  } else if (e.has_max) {
    add("<= " + io::number_text(e.max));
  }
  if (e.has_near) add("within " + io::number_text(e.tol) + " of " + (e.other.empty() ? io::number_text(e.value) : e.other));
  if (e.has_rate) add("|rate| <= " + io::number_text(e.rate_max) + "/s");
  return b;
}

std::string window_text(const ExpectSpec& e) {
  switch (e.window) {
    case ExpectWindow::kAlways:
    case ExpectWindow::kEventually:
      return std::string(expect_window_name(e.window)) + " in [" + io::number_text(e.from_s) + ", " +
             (std::isfinite(e.to_s) ? io::number_text(e.to_s) : std::string("end")) + "] s";
    case ExpectWindow::kWithin:
      return "within " + io::number_text(e.within_s) + " s after " + e.after;
    case ExpectWindow::kAtEnd:
      return "at the end";
  }
  return "";
}

}  // namespace

std::string expect_message(const ExpectSpec& e, const ExpectOutcome& o, double step_s) {
  const std::string what = (e.figure.empty() ? e.signal : e.figure) + " " + bound_text(e) + " " + window_text(e);
  // a grid time as written (332.376, not 332.37600000000003): ten significant digits
  const auto at = [&](std::int64_t n) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.10g", static_cast<double>(n) * step_s);
    return std::string(" at t = ") + buf + " s";
  };
  switch (o.why) {
    case ExpectOutcome::Why::kHeld:
      if (e.window == ExpectWindow::kAlways && o.step >= 0) {  // where it came closest to its bound
        return what + ": held; closest " + e.signal + " = " + io::number_text(o.value) + at(o.step);
      }
      return what + ": held" + (o.step >= 0 ? at(o.step) : std::string());
    case ExpectOutcome::Why::kOutOfBound:
      return what + ": " + (e.figure.empty() ? e.signal : e.figure) + " = " + io::number_text(o.value) +
             (e.other.empty() ? std::string() : ", " + e.other + " = " + io::number_text(o.reference)) +
             (o.step >= 0 ? at(o.step) : std::string());
    case ExpectOutcome::Why::kRate:
      return what + ": |rate| = " + io::number_text(o.value) + "/s" + at(o.step);
    case ExpectOutcome::Why::kNeverHeld:
      return what + ": never held; closest " + e.signal + " = " + io::number_text(o.value) +
             (e.other.empty() ? std::string() : ", " + e.other + " = " + io::number_text(o.reference)) +
             (o.step >= 0 ? at(o.step) : std::string());
    case ExpectOutcome::Why::kNoEvent:
      return what + ": the event (" + e.after + ") did not happen";
    case ExpectOutcome::Why::kNotReached:
      return what + ": the run ended" + (o.step >= 0 ? at(o.step) : std::string()) + " before the window did";
  }
  return what;
}

}  // namespace ehpt::hil
