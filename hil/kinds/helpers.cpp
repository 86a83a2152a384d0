// SPDX-License-Identifier: BSD-3-Clause
#include "hil/kinds/kind.hpp"

#include <numbers>

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

plant::GensetParams read_genset(Reader g, Context& ctx) {
  plant::GensetParams gs;
  gs.gear_ratio = g.number("gear_ratio", gs.gear_ratio);
  gs.throttle_per_rad_s = g.number("throttle_per_rad_s", gs.throttle_per_rad_s);

  const FileRef opti = g.path("opti_speed_table", !g.has("opti_speed_rad_s"));
  if (!opti.empty()) gs.opti_speed_rpm = load_curve(opti, g.field("opti_speed_table"), ctx);
  // one best speed for every request (the library's Level 1 genset: constOptimalSpeed)
  if (g.has("opti_speed_rad_s")) {
    const double w_rad_s = g.number("opti_speed_rad_s", 0.0);
    if (!opti.empty()) {
      ctx.error(ctx.where[g.field("opti_speed_rad_s")], g.field("opti_speed_rad_s"), plant::number_text(w_rad_s),
                "give either opti_speed_table or opti_speed_rad_s, not both");
    } else if (!(w_rad_s > 0.0) || !std::isfinite(w_rad_s)) {
      ctx.error(ctx.where[g.field("opti_speed_rad_s")], g.field("opti_speed_rad_s"), plant::number_text(w_rad_s),
                "must be a finite number > 0 (the engine's best speed for every request)");
    }
    const double rpm = w_rad_s * 60.0 / (2.0 * std::numbers::pi);
    gs.opti_speed_rpm = plant::Table1d({0.0, 1.0}, {rpm, rpm}, plant::Extrapolation::kHold);
  }
  gs.ice = read_ice(g.sub("ice"), ctx);
  // the GMS limits P / w to the engine's torque in the ON/OFF genset (GensetOO), not in the plain
  // one (V3's Genset: 1e9 N m); the default follows the genset's kind
  gs.gms_limits_torque = g.flag("gms_limits_torque", gs.ice.on_off);
  gs.generator = read_drive(g.sub("generator"), ctx);
  g.finish();
  return gs;
}

}  // namespace ehpt::hil::kinds
