// SPDX-License-Identifier: BSD-3-Clause
#include "hil/config/test_reader.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "hil/config/scenario.hpp"
#include "io/number_format.hpp"

namespace ehpt::hil {

const char* fault_effect_name(FaultEffect e) {
  switch (e) {
    case FaultEffect::kStuck: return "stuck";
    case FaultEffect::kFixed: return "fixed";
    case FaultEffect::kOffset: return "offset";
    case FaultEffect::kGain: return "gain";
    case FaultEffect::kNoise: return "noise";
    case FaultEffect::kDrift: return "drift";
    case FaultEffect::kDelay: return "delay";
    case FaultEffect::kQuantise: return "quantise";
    case FaultEffect::kIntermittent: return "intermittent";
    case FaultEffect::kSaturate: return "saturate";
    case FaultEffect::kLoss: return "loss";
    case FaultEffect::kNoStart: return "no_start";
    case FaultEffect::kR0Gain: return "r0_gain";
    case FaultEffect::kCapacityFade: return "capacity_fade";
    case FaultEffect::kInternalShort: return "internal_short";
    case FaultEffect::kStringLoss: return "string_loss";
    case FaultEffect::kDerate: return "derate";
    case FaultEffect::kDrop: return "drop";
    case FaultEffect::kDuplicate: return "duplicate";
    case FaultEffect::kReorder: return "reorder";
    case FaultEffect::kCorrupt: return "corrupt";
    case FaultEffect::kCounterFreeze: return "counter_freeze";
    case FaultEffect::kCounterJump: return "counter_jump";
    case FaultEffect::kBadCrc: return "bad_crc";
    case FaultEffect::kStop: return "stop";
    case FaultEffect::kPeriod: return "period";
    case FaultEffect::kBusOff: return "bus_off";
    case FaultEffect::kErrorFrames: return "error_frames";
  }
  return "?";
}

const char* expect_window_name(ExpectWindow w) {
  switch (w) {
    case ExpectWindow::kAlways: return "always";
    case ExpectWindow::kEventually: return "eventually";
    case ExpectWindow::kWithin: return "within";
    case ExpectWindow::kAtEnd: return "at_end";
  }
  return "?";
}

namespace detail {

namespace {

struct EffectInfo {
  FaultEffect effect;
  std::vector<std::string_view> required, optional;
};

const std::vector<EffectInfo>& effects() {
  static const std::vector<EffectInfo> k = {
      {FaultEffect::kStuck, {}, {}},
      {FaultEffect::kFixed, {"value"}, {}},
      {FaultEffect::kOffset, {"offset"}, {}},
      {FaultEffect::kGain, {"gain"}, {}},
      {FaultEffect::kNoise, {"sigma"}, {"seed"}},
      {FaultEffect::kDrift, {"rate"}, {}},
      {FaultEffect::kDelay, {"delay_s"}, {}},
      {FaultEffect::kQuantise, {"step"}, {}},
      {FaultEffect::kIntermittent, {"period_s"}, {"duty", "value"}},
      {FaultEffect::kSaturate, {"limit"}, {}},
      {FaultEffect::kLoss, {}, {}},
      {FaultEffect::kNoStart, {}, {}},
      {FaultEffect::kR0Gain, {"gain"}, {}},
      {FaultEffect::kCapacityFade, {"fraction"}, {}},
      {FaultEffect::kInternalShort, {"current_A"}, {}},
      {FaultEffect::kStringLoss, {"strings"}, {}},
      {FaultEffect::kDerate, {"gain"}, {}},
      {FaultEffect::kDrop, {}, {"probability", "pattern", "seed"}},
      {FaultEffect::kDuplicate, {}, {}},
      {FaultEffect::kReorder, {}, {}},
      {FaultEffect::kCorrupt, {}, {"byte", "mask"}},
      {FaultEffect::kCounterFreeze, {}, {}},
      {FaultEffect::kCounterJump, {}, {"jump"}},
      {FaultEffect::kBadCrc, {}, {}},
      {FaultEffect::kStop, {}, {}},
      {FaultEffect::kPeriod, {"period_s"}, {}},
      {FaultEffect::kBusOff, {}, {}},
      {FaultEffect::kErrorFrames, {}, {}},
  };
  return k;
}

constexpr std::array<std::string_view, 19> kParameters = {
    "value", "offset",   "gain",     "sigma",     "seed",    "rate",        "delay_s", "step", "period_s", "duty",
    "limit", "fraction", "current_A", "strings", "probability", "pattern", "byte",    "mask", "jump"};

constexpr std::array<std::string_view, 10> kFigures = {"soc_start",         "soc_end",
                                                       "soc_delta",         "fuel_g",
                                                       "distance_m",        "energy_residual_rel",
                                                       "plant_fault_steps", "speed_error_max_kmh",
                                                       "ecu_timeouts",      "safe_state_s"};

std::string joined(const std::vector<std::string_view>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + std::string(x);
  return s.empty() ? "none" : s;
}

std::string with_hint(const std::string& word, const std::vector<std::string>& names) {
  std::string list;
  for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
  const std::string best = closest_name(word, names);
  return (best.empty() ? std::string() : "did you mean \"" + best + "\"? ") + "one of: " + list;
}

void read_fault(Reader& r, std::size_t index, Scenario& out, Context& ctx) {
  FaultSpec f;
  f.where = r.where();
  f.name = r.text("name", "fault" + std::to_string(index + 1));
  const std::string kind = r.text("kind", "");
  const EffectInfo* info = nullptr;
  std::vector<std::string> kinds;
  for (const auto& e : effects()) {
    kinds.emplace_back(fault_effect_name(e.effect));
    if (kind == fault_effect_name(e.effect)) info = &e;
  }
  if (kind.empty()) {
    ctx.error(r.where(), r.field("kind"), "", "missing: the fault's kind, one of " + with_hint("", kinds).substr(8));
  } else if (info == nullptr) {
    ctx.error(ctx.where[r.field("kind")], r.field("kind"), "\"" + kind + "\"", "unknown fault kind; " + with_hint(kind, kinds));
  } else {
    f.effect = info->effect;
  }
  const bool battery_effect = is_plant_effect(f.effect) && f.effect != FaultEffect::kDerate;
  const bool whole_bus = f.effect == FaultEffect::kBusOff || f.effect == FaultEffect::kErrorFrames;
  f.target = r.text("target", f.effect == FaultEffect::kNoStart ? "iceON"
                              : battery_effect                  ? "battery"
                              : whole_bus                       ? "bus"
                                                                : "");
  if (f.target.empty() && info != nullptr) {
    ctx.error(r.where(), r.field("target"), "",
              f.effect == FaultEffect::kDerate
                  ? "missing: the machine it derates (\"drive\" in an EV; \"gen\" or \"mot\" in a PSD hybrid)"
              : is_bus_effect(f.effect)
                  ? "missing: the message whose frames it acts on, as the DBC names it (`ehpt signals SCENARIO "
                    "--fault-targets` lists them)"
                  : "missing: the field of the sensor or command message it acts on (`ehpt signals SCENARIO` lists them)");
  }
  if (is_bus_effect(f.effect)) f.side = FaultSide::kBus;  // its message is checked on the binding (hil/bus/bus_faults.hpp)
  if (whole_bus && f.target != "bus") {
    ctx.error(ctx.where[r.field("target")], r.field("target"), "\"" + f.target + "\"",
              "kind = \"" + kind + "\" acts on the whole bus: leave target out (or target = \"bus\")");
  }
  if (!whole_bus && info != nullptr && f.target == "bus") {
    ctx.error(ctx.where[r.field("target")], r.field("target"), "\"bus\"",
              "kind = \"" + kind + "\" acts on one message's frames (PsdCommand1, EvSensors1, ...); the whole bus "
              "takes bus_off and error_frames");
  }
  if (battery_effect && f.target != "battery") {
    ctx.error(ctx.where[r.field("target")], r.field("target"), "\"" + f.target + "\"",
              "kind = \"" + kind + "\" acts on the pack: leave target out (or target = \"battery\")");
  }
  if (!is_plant_effect(f.effect) && info != nullptr && f.target == "battery") {
    ctx.error(ctx.where[r.field("target")], r.field("target"), "\"battery\"",
              "kind = \"" + kind + "\" acts on a message field (batSOC, battery_voltage_V, ...); the pack's own "
              "faults are r0_gain, capacity_fade, internal_short and string_loss");
  }
  if (f.effect == FaultEffect::kNoStart && f.target != "iceON" && f.target != "gensetON") {
    ctx.error(ctx.where[r.field("target")], r.field("target"), "\"" + f.target + "\"",
              "kind = \"no_start\" acts on the engine: leave target out (or target = \"iceON\", the series "
              "hybrid's \"gensetON\")");
  }
  // when it acts: [at_s, until_s) or from the step after `when` first holds
  const bool has_at = r.has("at_s"), has_until = r.has("until_s"), has_duration = r.has("duration_s");
  f.at_s = r.number("at_s", 0.0);
  f.until_s = r.number("until_s", kForever);
  const double duration_s = r.number("duration_s", kForever);
  const std::string when = r.text("when", "");
  if (!(std::isfinite(f.at_s) && f.at_s >= 0.0)) {
    ctx.error(ctx.where[r.field("at_s")], r.field("at_s"), io::number_text(f.at_s), "must be a finite time >= 0 s");
  }
  if (has_until && has_duration) {
    ctx.error(ctx.where[r.field("duration_s")], r.field("duration_s"), io::number_text(duration_s),
              "give until_s or duration_s, not both");
  } else if (has_duration) {
    if (!(duration_s > 0.0)) {
      ctx.error(ctx.where[r.field("duration_s")], r.field("duration_s"), io::number_text(duration_s), "must be > 0 s");
    }
    f.until_s = f.at_s + duration_s;
  }
  if (has_until && !(f.until_s > f.at_s)) {
    ctx.error(ctx.where[r.field("until_s")], r.field("until_s"), io::number_text(f.until_s),
              "must be later than at_s = " + io::number_text(f.at_s) + " (leave it out: to the end of the run)");
  }
  if (!when.empty()) {
    std::string why;
    f.has_when = true;
    if (has_at) {
      ctx.error(ctx.where[r.field("when")], r.field("when"), "\"" + when + "\"",
                "give at_s or when, not both (a triggered fault starts at the step after its condition first holds)");
    }
    if (has_duration) {
      ctx.error(ctx.where[r.field("duration_s")], r.field("duration_s"), io::number_text(duration_s),
                "a triggered fault (when = ...) ends at until_s, an absolute time");
    }
    if (!parse_condition(when, f.when, why)) ctx.error(ctx.where[r.field("when")], r.field("when"), "\"" + when + "\"", why);
  }
  // the effect's parameters; one it does not use is a mistake, not a default
  for (const std::string_view p : kParameters) {
    if (!r.has(p) || info == nullptr) {
      r.known(p);
      continue;
    }
    const bool used = std::find(info->required.begin(), info->required.end(), p) != info->required.end() ||
                      std::find(info->optional.begin(), info->optional.end(), p) != info->optional.end();
    if (!used) {
      r.find(p);
      ctx.error(ctx.where[r.field(p)], r.field(p), "",
                "not a parameter of kind = \"" + kind + "\" (its parameters: " + joined(info->required) +
                    (info->optional.empty() ? "" : "; optional: " + joined(info->optional)) + ")");
    }
  }
  if (info != nullptr) {
    for (const std::string_view p : info->required) {
      if (!r.has(p)) {
        ctx.error(r.where(), r.field(p), "", "missing: kind = \"" + kind + "\" needs " + joined(info->required));
      }
    }
  }
  f.value = r.number("value", 0.0);
  f.offset = r.number("offset", 0.0);
  f.gain = r.number("gain", 1.0);
  f.sigma = r.number("sigma", 0.0);
  f.rate = r.number("rate", 0.0);
  f.delay_s = r.number("delay_s", 0.0);
  f.step = r.number("step", 0.0);
  f.period_s = r.number("period_s", 0.0);
  f.duty = r.number("duty", 0.5);
  f.limit = r.number("limit", 0.0);
  f.fraction = r.number("fraction", 0.0);
  f.current_A = r.number("current_A", 0.0);
  const std::int64_t strings = r.integer("strings", 0);
  if (r.has("strings") && (strings < 1 || strings > 1000000)) {
    ctx.error(ctx.where[r.field("strings")], r.field("strings"), std::to_string(strings),
              "must be a whole number of parallel strings >= 1 (and fewer than battery.strings_parallel)");
  }
  f.strings = static_cast<int>(std::clamp<std::int64_t>(strings, 0, 1000000));
  // bus faults
  f.probability = r.number("probability", 1.0);
  f.pattern = r.text("pattern", "");
  const std::int64_t byte = r.integer("byte", 0), mask = r.integer("mask", 0xFF), jump = r.integer("jump", 4);
  if (r.has("byte") && (byte < 0 || byte > 63)) {
    ctx.error(ctx.where[r.field("byte")], r.field("byte"), std::to_string(byte),
              "must be a byte of the frame: 0 .. its length - 1");
  }
  if (r.has("mask") && (mask < 1 || mask > 255)) {
    ctx.error(ctx.where[r.field("mask")], r.field("mask"), std::to_string(mask),
              "must be 1 .. 255 (0xFF): the bits of the byte flipped");
  }
  if (r.has("jump") && (jump < 1 || jump > 65535)) {
    ctx.error(ctx.where[r.field("jump")], r.field("jump"), std::to_string(jump),
              "must be a whole number 1 .. 65535 added to the counter (more than the receiver allows, 3, to be refused)");
  }
  f.byte = static_cast<int>(std::clamp<std::int64_t>(byte, 0, 63));
  f.mask = static_cast<int>(std::clamp<std::int64_t>(mask, 1, 255));
  f.jump = static_cast<int>(std::clamp<std::int64_t>(jump, 1, 65535));
  if (r.has("probability") && !(f.probability > 0.0 && f.probability <= 1.0)) {
    ctx.error(ctx.where[r.field("probability")], r.field("probability"), io::number_text(f.probability),
              "must be in (0, 1]: each frame's chance of being lost");
  }
  if (r.has("pattern")) {
    const bool digits = !f.pattern.empty() && f.pattern.size() <= 1000 &&
                        f.pattern.find_first_not_of("01") == std::string::npos;
    if (!digits || f.pattern.find('1') == std::string::npos) {
      ctx.error(ctx.where[r.field("pattern")], r.field("pattern"), "\"" + f.pattern.substr(0, 40) + "\"",
                "must be 1 .. 1000 characters of 0 and 1, at least one 1: \"1\" loses a frame, \"0\" passes it, "
                "repeated (\"0001\": every fourth frame lost)");
    }
    if (r.has("probability")) {
      ctx.error(ctx.where[r.field("pattern")], r.field("pattern"), "\"" + f.pattern.substr(0, 40) + "\"",
                "give probability or pattern, not both");
    }
  }
  const std::int64_t seed = r.integer("seed", static_cast<std::int64_t>(index) + 1);
  if (seed < 0) ctx.error(ctx.where[r.field("seed")], r.field("seed"), std::to_string(seed), "must be >= 0");
  f.seed = static_cast<std::uint64_t>(std::max<std::int64_t>(seed, 0));
  const auto need = [&](std::string_view key, double v, bool ok, const char* expectation) {
    if (r.has(key) && !ok) ctx.error(ctx.where[r.field(key)], r.field(key), io::number_text(v), expectation);
  };
  for (const auto& [key, v] : {std::pair<std::string_view, double>{"value", f.value}, {"offset", f.offset},
                               {"gain", f.gain}, {"rate", f.rate}}) {
    need(key, v, std::isfinite(v), "must be a finite number");
  }
  need("sigma", f.sigma, f.sigma > 0.0 && std::isfinite(f.sigma), "must be a finite number > 0 (the noise's standard deviation, in the target's unit)");
  need("delay_s", f.delay_s, f.delay_s > 0.0 && std::isfinite(f.delay_s), "must be a finite time > 0 s");
  need("step", f.step, f.step > 0.0 && std::isfinite(f.step), "must be a finite number > 0 (the quantum, in the target's unit)");
  need("period_s", f.period_s, f.period_s > 0.0 && std::isfinite(f.period_s), "must be a finite time > 0 s");
  need("duty", f.duty, f.duty > 0.0 && f.duty < 1.0, "must be in (0, 1): the fraction of each period the fault acts");
  need("limit", f.limit, f.limit >= 0.0 && std::isfinite(f.limit), "must be a finite number >= 0 (|value| is clamped to it)");
  need("fraction", f.fraction, f.fraction > 0.0 && f.fraction < 1.0,
       "must be in (0, 1): the share of the pack's capacity lost (0.2: 80 % remain)");
  need("current_A", f.current_A, f.current_A > 0.0 && std::isfinite(f.current_A),
       "must be a finite current > 0 A (the self-discharge through the short)");
  if (f.effect == FaultEffect::kR0Gain) {
    need("gain", f.gain, f.gain > 0.0 && std::isfinite(f.gain), "must be a finite number > 0 (R0 x gain; 2: doubled)");
  }
  if (f.effect == FaultEffect::kDerate) {
    need("gain", f.gain, f.gain >= 0.0 && f.gain <= 1.0,
         "must be in [0, 1]: the share of the machine's torque bound left (0.5: half)");
  }
  r.finish();
  for (const FaultSpec& g : out.faults) {
    if (g.name == f.name) {
      ctx.error(ctx.where[r.field("name")], r.field("name"), "\"" + f.name + "\"", "another fault has this name (" + g.where + ")");
    }
  }
  out.faults.push_back(std::move(f));
}

void read_expect(Reader& r, std::size_t index, Scenario& out, Context& ctx) {
  ExpectSpec e;
  e.where = r.where();
  e.name = r.text("name", "expect" + std::to_string(index + 1));
  e.signal = r.text("signal", "");
  e.figure = r.text("figure", "");
  if (e.signal.empty() == e.figure.empty()) {
    ctx.error(r.where(), r.field("signal"), "", "give either signal (a plant output, `ehpt signals`) or figure (a summary "
                                                "figure at the end of the run), not both and not neither");
  }
  if (!e.figure.empty()) {
    const auto& f = expect_figures();
    if (std::find(f.begin(), f.end(), e.figure) == f.end()) {
      std::vector<std::string> names(f.begin(), f.end());
      ctx.error(ctx.where[r.field("figure")], r.field("figure"), "\"" + e.figure + "\"", "unknown figure; " + with_hint(e.figure, names));
    }
  }
  e.has_min = r.has("min");
  e.has_max = r.has("max");
  e.min = r.number("min", 0.0);
  e.max = r.number("max", 0.0);
  const bool has_value = r.has("value");
  e.value = r.number("value", 0.0);
  e.other = r.text("other", "");
  const bool has_tol = r.has("tol");
  e.tol = r.number("tol", 0.0);
  e.has_near = has_value || !e.other.empty();
  e.has_rate = r.has("rate_max");
  e.rate_max = r.number("rate_max", 0.0);
  if (!e.has_min && !e.has_max && !e.has_near && !e.has_rate) {
    ctx.error(r.where(), r.field("max"), "", "missing: a bound (min, max, value or other with tol, rate_max)");
  }
  if (has_value && !e.other.empty()) {
    ctx.error(ctx.where[r.field("other")], r.field("other"), "\"" + e.other + "\"", "give value or other, not both");
  }
  if (e.has_near && !has_tol) ctx.error(r.where(), r.field("tol"), "", "missing: value and other need tol (>= 0)");
  if (has_tol && !e.has_near) {
    ctx.error(ctx.where[r.field("tol")], r.field("tol"), io::number_text(e.tol), "tol bounds |x - value| or |x - other|: give one");
  }
  if (has_tol && !(e.tol >= 0.0 && std::isfinite(e.tol))) {
    ctx.error(ctx.where[r.field("tol")], r.field("tol"), io::number_text(e.tol), "must be a finite number >= 0");
  }
  for (const auto& [key, v] : {std::pair<std::string_view, double>{"min", e.min}, {"max", e.max}, {"value", e.value}}) {
    if (r.has(key) && !std::isfinite(v)) ctx.error(ctx.where[r.field(key)], r.field(key), io::number_text(v), "must be finite");
  }
  if (e.has_min && e.has_max && e.min > e.max) {
    ctx.error(ctx.where[r.field("max")], r.field("max"), io::number_text(e.max),
              "must be >= min = " + io::number_text(e.min) + " (nothing could pass)");
  }
  if (e.has_rate && !(e.rate_max >= 0.0 && std::isfinite(e.rate_max))) {
    ctx.error(ctx.where[r.field("rate_max")], r.field("rate_max"), io::number_text(e.rate_max),
              "must be a finite number >= 0 (per second)");
  }
  if (!e.figure.empty() && (e.has_rate || !e.other.empty())) {
    ctx.error(r.where(), r.field("figure"), "\"" + e.figure + "\"", "a figure takes min, max or value with tol");
  }
  const std::string window = r.text("window", e.figure.empty() ? "always" : "at_end");
  std::vector<std::string> windows;
  bool known = false;
  for (ExpectWindow w : {ExpectWindow::kAlways, ExpectWindow::kEventually, ExpectWindow::kWithin, ExpectWindow::kAtEnd}) {
    windows.emplace_back(expect_window_name(w));
    if (window == expect_window_name(w)) {
      e.window = w;
      known = true;
    }
  }
  if (!known) {
    ctx.error(ctx.where[r.field("window")], r.field("window"), "\"" + window + "\"", "unknown window; " + with_hint(window, windows));
  }
  if (!e.figure.empty() && e.window != ExpectWindow::kAtEnd) {
    ctx.error(ctx.where[r.field("window")], r.field("window"), "\"" + window + "\"", "a figure is checked at the end: window = \"at_end\"");
  }
  const bool timed = e.window == ExpectWindow::kAlways || e.window == ExpectWindow::kEventually;
  for (const std::string_view key : {"from_s", "to_s"}) {
    if (r.has(key) && !timed) {
      r.find(key);
      ctx.error(ctx.where[r.field(key)], r.field(key), "", "only windows always and eventually take from_s and to_s");
    }
  }
  e.from_s = r.number("from_s", 0.0);
  e.to_s = r.number("to_s", kForever);
  if (!(std::isfinite(e.from_s) && e.from_s >= 0.0)) {
    ctx.error(ctx.where[r.field("from_s")], r.field("from_s"), io::number_text(e.from_s), "must be a finite time >= 0 s");
  }
  if (r.has("to_s") && !(e.to_s >= e.from_s)) {
    ctx.error(ctx.where[r.field("to_s")], r.field("to_s"), io::number_text(e.to_s), "must be >= from_s = " + io::number_text(e.from_s));
  }
  if (e.has_rate && e.window != ExpectWindow::kAlways) {
    ctx.error(ctx.where[r.field("rate_max")], r.field("rate_max"), io::number_text(e.rate_max), "a rate limit holds always: window = \"always\"");
  }
  e.after = r.text("after", "");
  e.within_s = r.number("within_s", 0.0);
  if (e.window == ExpectWindow::kWithin) {
    if (e.after.empty()) {
      ctx.error(r.where(), r.field("after"), "", "missing: window = \"within\" needs the event: after = \"FAULT.start\", "
                                                 "\"FAULT.end\" or a condition (\"soc_1 < 0.5\")");
    }
    if (!(e.within_s > 0.0 && std::isfinite(e.within_s))) {
      ctx.error(r.has("within_s") ? ctx.where[r.field("within_s")] : r.where(), r.field("within_s"),
                r.has("within_s") ? io::number_text(e.within_s) : "", "window = \"within\" needs within_s, a finite time > 0 s");
    }
  } else {
    for (const std::string_view key : {"after", "within_s"}) {
      if (r.has(key)) ctx.error(ctx.where[r.field(key)], r.field(key), "", "only window = \"within\" takes after and within_s");
    }
  }
  if (!e.after.empty()) {
    const auto dot = e.after.rfind('.');
    const std::string head = dot == std::string::npos ? "" : e.after.substr(0, dot);
    const std::string tail = dot == std::string::npos ? "" : e.after.substr(dot + 1);
    if ((tail == "start" || tail == "end") && e.after.find_first_of("<>") == std::string::npos) {
      std::vector<std::string> names;
      for (std::size_t i = 0; i < out.faults.size(); ++i) {
        names.push_back(out.faults[i].name);
        if (out.faults[i].name == head) e.after_fault = static_cast<int>(i);
      }
      e.after_end = tail == "end";
      if (e.after_fault < 0) {
        ctx.error(ctx.where[r.field("after")], r.field("after"), "\"" + e.after + "\"",
                  "no fault is named \"" + head + "\"; " + (names.empty() ? "this run has no faults" : with_hint(head, names)));
      }
    } else {
      std::string why;
      if (!parse_condition(e.after, e.after_condition, why)) {
        ctx.error(ctx.where[r.field("after")], r.field("after"), "\"" + e.after + "\"",
                  why + "; or name a fault's start or end: \"FAULT.start\", \"FAULT.end\"");
      }
    }
  }
  r.finish();
  for (const ExpectSpec& g : out.expects) {
    if (g.name == e.name) {
      ctx.error(ctx.where[r.field("name")], r.field("name"), "\"" + e.name + "\"", "another expectation has this name (" + g.where + ")");
    }
  }
  out.expects.push_back(std::move(e));
}

// "kind=stuck target=batSOC at_s=10" -> a table, each value TOML (else text), labelled for messages
bool parse_fault_arg(const std::string& text, toml::table& out, Context& ctx) {
  const std::string label = "--fault " + (text.size() <= 120 ? text : text.substr(0, 80) + "...");
  if (text.find_first_of("\r\n") != std::string::npos) {
    ctx.errors.push_back(label + ": one fault per --fault, on one line");
    return false;
  }
  std::size_t i = 0;
  while (i < text.size()) {
    while (i < text.size() && text[i] == ' ') ++i;
    if (i >= text.size()) break;
    std::size_t end = i;
    bool quoted = false;
    while (end < text.size() && (quoted || text[end] != ' ')) {
      if (text[end] == '"') quoted = !quoted;
      ++end;
    }
    const std::string pair = text.substr(i, end - i);
    i = end;
    const auto eq = pair.find('=');
    if (eq == std::string::npos || eq == 0) {
      ctx.errors.push_back(label + ": \"" + pair + "\": expected key=value, e.g. --fault \"kind=stuck target=batSOC at_s=10\"");
      return false;
    }
    const std::string key = pair.substr(0, eq), value = pair.substr(eq + 1);
    std::vector<std::string> keys = {"name", "kind", "target", "at_s", "until_s", "duration_s", "when"};
    keys.insert(keys.end(), kParameters.begin(), kParameters.end());
    if (std::find(keys.begin(), keys.end(), key) == keys.end()) {
      ctx.errors.push_back(label + ": \"" + key + "\": not a fault key; " + with_hint(key, keys));
      return false;
    }
    if (out.contains(key)) {
      ctx.errors.push_back(label + ": " + key + " is given twice");
      return false;
    }
    if (key == "pattern") {  // text, whether quoted or not (pattern=0011 is no TOML number)
      const bool quoted = value.size() >= 2 && value.front() == '"' && value.back() == '"';
      out.insert(key, quoted ? value.substr(1, value.size() - 2) : value);
      continue;
    }
    toml::table one;
    try {
      one = toml::parse(key + " = " + value, label);
      for (auto&& [k, v] : one) out.insert(k, v);
    } catch (const toml::parse_error&) {
      out.insert(key, value);  // not TOML: the text itself (kind=stuck)
    }
  }
  return true;
}

}  // namespace

std::span<const std::string_view> expect_figures() { return kFigures; }

bool parse_condition(const std::string& text, SignalCondition& out, std::string& why) {
  out.text = text;
  static constexpr std::array<std::pair<std::string_view, SignalCondition::Op>, 4> kOps = {{
      {"<=", SignalCondition::Op::kLessEqual},
      {">=", SignalCondition::Op::kGreaterEqual},
      {"<", SignalCondition::Op::kLess},
      {">", SignalCondition::Op::kGreater},
  }};
  for (const auto& [op, kind] : kOps) {
    const auto at = text.find(op);
    if (at == std::string::npos) continue;
    const auto trim = [](std::string s) {
      const auto a = s.find_first_not_of(' '), b = s.find_last_not_of(' ');
      return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
    };
    out.signal = trim(text.substr(0, at));
    const std::string number = trim(text.substr(at + op.size()));
    out.op = kind;
    char* end = nullptr;
    errno = 0;
    out.value = std::strtod(number.c_str(), &end);
    if (out.signal.empty() || number.empty() || end == nullptr || *end != '\0' || errno != 0 || !std::isfinite(out.value)) {
      why = "expected SIGNAL < NUMBER (or <=, >, >=), e.g. \"soc_1 < 0.3\"";
      return false;
    }
    return true;
  }
  why = "expected SIGNAL < NUMBER (or <=, >, >=), e.g. \"soc_1 < 0.3\"";
  return false;
}

void read_tests(const std::vector<Layer>& layers, Reader& sc, const std::vector<std::string>& fault_args, Scenario& out,
                Context& ctx) {
  {
    Reader t = sc.sub("test");
    out.test.is_test = sc.has("test");
    out.test.where = t.where();
    out.test.expect_fail = t.flag("expect_fail", false);
    t.finish();
  }
  sc.known("fault");
  sc.known("expect");
  // every layer's [[fault]] and [[expect]], the lowest (the named scenario) first: a test adds to
  // what its scenario states
  const auto arrays = [&](const char* key, auto&& each) {
    std::size_t index = 0;
    for (auto l = layers.rbegin(); l != layers.rend(); ++l) {
      if (l->table == nullptr) continue;
      const toml::node* n = l->table->get(key);
      if (n == nullptr) continue;
      const std::string file = n->source().path ? *n->source().path : out.path;
      Reader layer({{l->table, false}}, "", file, ctx);
      for (Reader& r : layer.table_array(key)) each(r, index++);
    }
    return index;
  };
  arrays("fault", [&](Reader& r, std::size_t i) { read_fault(r, i, out, ctx); });
  std::vector<toml::table> arg_tables(fault_args.size());
  for (std::size_t i = 0; i < fault_args.size(); ++i) {
    if (!parse_fault_arg(fault_args[i], arg_tables[i], ctx)) continue;
    const std::string label = "--fault " + fault_args[i];
    Reader r({{&arg_tables[i], false}}, "fault[" + std::to_string(out.faults.size()) + "]", label, ctx, label);
    read_fault(r, out.faults.size(), out, ctx);
  }
  if (out.faults.size() > kMaxFaults) {
    ctx.errors.push_back(out.faults[kMaxFaults].where + ": fault: more than " + std::to_string(kMaxFaults) +
                         " faults in one run (each is one bit of the faults_active column)");
  }
  arrays("expect", [&](Reader& r, std::size_t i) { read_expect(r, i, out, ctx); });
  if (!out.faults.empty() || !out.expects.empty()) out.test.is_test = true;
  out.fault_args = fault_args;
}

void check_test_targets(std::span<const std::string_view> outputs, std::span<const std::string_view> sensors,
                        std::span<const std::string_view> commands, const PlantFaultTargets& plant, Scenario& out,
                        Context& ctx) {
  const auto has = [](std::span<const std::string_view> v, const std::string& name) {
    return std::find(v.begin(), v.end(), name) != v.end();
  };
  std::vector<std::string> output_names(outputs.begin(), outputs.end());
  const auto output = [&](const std::string& where, const std::string& field, const std::string& name) {
    if (!has(outputs, name)) {
      ctx.errors.push_back(where + ": " + field + " = \"" + name + "\": not an output of this vehicle; " +
                           with_hint(name, output_names));
    }
  };
  int strings_lost = 0;  // by all string_loss faults: they may act at once
  for (std::size_t i = 0; i < out.faults.size(); ++i) {
    FaultSpec& f = out.faults[i];
    const std::string field = "fault[" + std::to_string(i) + "]";
    if (f.has_when) output(f.where, field + ".when", f.when.signal);
    if (f.target.empty()) continue;
    if (is_plant_effect(f.effect)) {
      f.side = FaultSide::kPlant;
      if (f.effect != FaultEffect::kDerate) {
        if (plant.strings_parallel <= 0) {
          ctx.errors.push_back(f.where + ": " + field + ": kind = \"" + fault_effect_name(f.effect) +
                               "\" acts on a vehicle's pack; this one's plant takes no plant faults");
        } else if (f.effect == FaultEffect::kStringLoss) {
          strings_lost += f.strings;
          if (strings_lost >= plant.strings_parallel) {
            ctx.errors.push_back(f.where + ": " + field + ".strings = " + std::to_string(f.strings) +
                                 ": the pack has battery.strings_parallel = " + std::to_string(plant.strings_parallel) +
                                 (strings_lost > f.strings ? " and the faults before lose " + std::to_string(strings_lost - f.strings) : "") +
                                 ": at least one string must remain (an open pack is no battery left to test)");
          }
        }
        continue;
      }
      std::vector<std::string> names(plant.machines.begin(), plant.machines.end());
      for (std::size_t m = 0; m < plant.machines.size(); ++m) {
        if (plant.machines[m] == f.target) f.machine = static_cast<int>(m);
      }
      if (names.empty()) {
        ctx.errors.push_back(f.where + ": " + field + ": kind = \"derate\" acts on a vehicle's machine; this one's "
                             "plant takes no plant faults");
      } else if (f.machine < 0) {
        ctx.errors.push_back(f.where + ": " + field + ".target = \"" + f.target +
                             "\": not a machine of this vehicle; " + with_hint(f.target, names));
      }
      continue;
    }
    if (sensors.empty() && commands.empty()) {
      ctx.errors.push_back(f.where + ": " + field + ".target = \"" + f.target +
                           "\": this vehicle has no ECU messages to fault (a rig); faults act on the sensor and "
                           "command messages of vehicles with an ECU");
      continue;
    }
    // a message's frames (and a delay on a name that is no field, nor close to one: a typo of a
    // field is named as such): checked on the bound contract when the wire is made
    // (hil/bus/bus_faults.hpp, before anything runs)
    if (f.side == FaultSide::kBus) continue;
    if (f.effect == FaultEffect::kDelay && !has(sensors, f.target) && !has(commands, f.target)) {
      std::vector<std::string> names(sensors.begin(), sensors.end());
      names.insert(names.end(), commands.begin(), commands.end());
      if (closest_name(f.target, names).empty()) {
        f.side = FaultSide::kBus;
        continue;
      }
    }
    if (f.effect == FaultEffect::kNoStart) {
      // the engine's ON flag: the power-split hybrid's iceON, the series hybrid's gensetON
      if (f.target == "iceON" && !has(commands, "iceON") && has(commands, "gensetON")) f.target = "gensetON";
      if (!has(commands, f.target)) {
        const char* flag = has(commands, "iceON") ? "iceON" : has(commands, "gensetON") ? "gensetON" : nullptr;
        ctx.errors.push_back(f.where + ": " + field + ": kind = \"no_start\" acts on an engine; " +
                             (flag ? "this vehicle's engine flag is " + std::string(flag) + " (leave target out)"
                                   : std::string("this vehicle has none")));
        continue;
      }
    }
    if (has(sensors, f.target)) {
      f.side = FaultSide::kSensor;
    } else if (has(commands, f.target)) {
      f.side = FaultSide::kCommand;
    } else {
      std::vector<std::string> names(sensors.begin(), sensors.end());
      names.insert(names.end(), commands.begin(), commands.end());
      ctx.errors.push_back(f.where + ": " + field + ".target = \"" + f.target +
                           "\": not a field of this vehicle's sensor or command message; " + with_hint(f.target, names));
      continue;
    }
    if (f.target == "fault" || f.target == "locked") {
      ctx.errors.push_back(f.where + ": " + field + ".target = \"" + f.target +
                           "\": the plant's status bits are not a sensor value to fault");
    }
  }
  for (std::size_t i = 0; i < out.expects.size(); ++i) {
    ExpectSpec& e = out.expects[i];
    const std::string field = "expect[" + std::to_string(i) + "]";
    if (!e.signal.empty()) output(e.where, field + ".signal", e.signal);
    if (!e.other.empty()) output(e.where, field + ".other", e.other);
    if (e.window == ExpectWindow::kWithin && e.after_fault < 0 && !e.after_condition.signal.empty()) {
      output(e.where, field + ".after", e.after_condition.signal);
    }
  }
}

void check_test_times(Scenario& out, Context& ctx) {
  if (out.solver.steps <= 0) return;
  const double end_s = static_cast<double>(out.solver.steps) * out.solver.step_s;
  const double h = out.solver.step_s;
  const auto whole = [](double value, double unit) {
    const double ratio = value / unit;
    return std::abs(ratio - std::round(ratio)) <= 1e-9 * std::max(1.0, ratio) && std::round(ratio) >= 1.0;
  };
  for (std::size_t i = 0; i < out.faults.size(); ++i) {
    const FaultSpec& f = out.faults[i];
    const std::string field = "fault[" + std::to_string(i) + "]";
    if (f.effect == FaultEffect::kPeriod) {
      const double unit = h * static_cast<double>(out.solver.ecu_ratio);
      if (!whole(f.period_s, unit) || f.period_s / unit < 1.5) {
        ctx.errors.push_back(f.where + ": " + field + ".period_s = " + io::number_text(f.period_s) +
                             ": must be a whole multiple of the ECU period (" + io::number_text(unit) +
                             " s), at least two (a message every second sample or fewer)");
      } else if (f.period_s / unit > kMaxDelaySamples) {
        ctx.errors.push_back(f.where + ": " + field + ".period_s = " + io::number_text(f.period_s) + ": more than 1e6 samples");
      }
    }
    if (f.effect == FaultEffect::kDelay && f.side == FaultSide::kBus) {
      // frames are held whole samples (they leave, or reach the plant's rules, with a later sample)
      const double unit = h * static_cast<double>(out.solver.ecu_ratio);
      if (!whole(f.delay_s, unit)) {
        ctx.errors.push_back(f.where + ": " + field + ".delay_s = " + io::number_text(f.delay_s) +
                             ": a message's frames are delayed by whole ECU periods (" + io::number_text(unit) + " s)");
      } else if (f.delay_s / unit > kMaxBusDelaySamples) {
        ctx.errors.push_back(f.where + ": " + field + ".delay_s = " + io::number_text(f.delay_s) + ": more than " +
                             std::to_string(static_cast<int>(kMaxBusDelaySamples)) +
                             " ECU periods (the frames wait in a ring sized at start-up)");
      }
    } else if (f.effect == FaultEffect::kDelay) {
      // a sensor value is sampled once per ECU period, a command integrated at every step
      const bool sensor = f.side == FaultSide::kSensor;
      const double unit = sensor ? h * static_cast<double>(out.solver.ecu_ratio) : h;
      if (!whole(f.delay_s, unit)) {
        ctx.errors.push_back(f.where + ": " + field + ".delay_s = " + io::number_text(f.delay_s) + ": must be a whole multiple of " +
                             (sensor ? "the ECU period (" : "the plant step (") + io::number_text(unit) + " s)");
      } else if (f.delay_s / unit > kMaxDelaySamples) {
        ctx.errors.push_back(f.where + ": " + field + ".delay_s = " + io::number_text(f.delay_s) + ": more than 1e6 " +
                             (sensor ? "samples" : "steps") + " of history");
      }
    }
    if (f.effect == FaultEffect::kIntermittent && f.period_s / h > static_cast<double>(kMaxSteps)) {
      ctx.errors.push_back(f.where + ": " + field + ".period_s = " + io::number_text(f.period_s) +
                           ": more than 1e10 steps (no run is that long)");
    } else if (f.effect == FaultEffect::kIntermittent && !whole(f.period_s, h)) {
      ctx.errors.push_back(f.where + ": " + field + ".period_s = " + io::number_text(f.period_s) +
                           ": must be a whole multiple of the plant step (" + io::number_text(h) + " s)");
    }
    if (!f.has_when && f.at_s > end_s) {
      ctx.errors.push_back(f.where + ": fault[" + std::to_string(i) + "].at_s = " + io::number_text(f.at_s) +
                           ": after the run's end (t = " + io::number_text(end_s) + " s): it would never act");
    }
  }
  for (std::size_t i = 0; i < out.expects.size(); ++i) {
    const ExpectSpec& e = out.expects[i];
    if ((e.window == ExpectWindow::kAlways || e.window == ExpectWindow::kEventually) && e.from_s > end_s) {
      ctx.errors.push_back(e.where + ": expect[" + std::to_string(i) + "].from_s = " + io::number_text(e.from_s) +
                           ": after the run's end (t = " + io::number_text(end_s) + " s): nothing would be checked");
    }
  }
}

}  // namespace detail
}  // namespace ehpt::hil
