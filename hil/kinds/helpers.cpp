// SPDX-License-Identifier: BSD-3-Clause
#include "hil/kinds/kind.hpp"

namespace ehpt::hil::kinds {

void need_cycle(const KindInput& in, Context& ctx) {
  if (in.cycle.empty()) ctx.error(in.scenario_path, "cycle", "", "missing (a vehicle with a driver needs a cycle file)");
}
void no_cycle(const KindInput& in, const char* what, Context& ctx) {
  if (!in.cycle.empty()) {
    ctx.error(in.cycle.where, "cycle", "\"" + in.cycle.written + "\"", std::string(what) + " has no driver: remove the cycle");
  }
}
void read_follower_ecu(Reader r, EcuTiming& timing, Context& ctx) {
  const std::string kind = r.text("kind", "follower");
  if (kind != "follower") {
    ctx.error(ctx.where[r.field("kind")], r.field("kind"), "\"" + kind + "\"",
              "must be \"follower\" (the built-in ECU of the EV; an external one joins over a bus)");
  }
  read_ecu_timing(r, timing);
  r.finish();
}

std::optional<double> cycle_length(const plant::PropDriverParams& d) {
  if (d.cycle_m_s.empty()) return std::nullopt;
  return d.cycle_m_s.x().back();
}

plant::Trapezoid read_trapezoid(Reader r, const std::string& unit) {
  plant::Trapezoid t;
  t.offset = r.number("offset_" + unit, 0.0);
  t.amplitude = r.number("amplitude_" + unit, 0.0);
  t.start_s = r.number("start_s", 0.0);
  t.rising_s = r.required_number("rising_s");
  t.width_s = r.number("width_s", 0.0);
  t.falling_s = r.required_number("falling_s");
  t.period_s = r.number("period_s", 1e6);
  r.finish();
  return t;
}

}  // namespace ehpt::hil::kinds
