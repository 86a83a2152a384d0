#include "hil/batch.hpp"

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <ostream>

#include "hil/simulation.hpp"
#include "io/number_format.hpp"
#include "io/text_file.hpp"

namespace ehpt::hil {

std::string fault_text(unsigned fault) {
  std::string s;
  const auto add = [&](unsigned bit, const char* text) {
    if (fault & bit) s += (s.empty() ? "" : ", ") + std::string(text);
  };
  add(plant::kFaultSocWindow, "SOC left [soc_min, soc_max]");
  add(plant::kFaultCellCurrent, "cell current reached cell_current_max_A");
  add(plant::kFaultPowerInfeasible, "the drive asked for more power than the battery can give");
  add(plant::kFaultNonFinite, "non-finite state (NaN or Inf)");
  return s;
}

namespace {

constexpr std::int64_t kChunkSteps = 50000;

std::string signal_name(int sig) {
  switch (sig) {
    case SIGINT: return "SIGINT";
    case SIGTERM: return "SIGTERM";
    case SIGHUP: return "SIGHUP";
    default: return "signal " + std::to_string(sig);
  }
}

}  // namespace

BatchResult run_batch(const Scenario& sc, const BatchOptions& opt, std::ostream& log) {
  BatchResult res;
  const std::vector<SignalInfo> signals = scenario_signals(sc);
  std::vector<int> columns;
  if (sc.output.signals.empty()) {
    for (std::size_t i = 0; i < signals.size(); ++i) columns.push_back(static_cast<int>(i));
  } else {
    for (const std::string& name : sc.output.signals) {
      for (std::size_t i = 0; i < signals.size(); ++i) {
        if (signals[i].name == name) columns.push_back(static_cast<int>(i));
      }
    }
  }

  // a signal while loading: nothing was run, and an earlier run in DIR stays as it is
  if (opt.stop_signal != nullptr && opt.stop_signal->load() != 0) {
    log << "interrupted by " << signal_name(opt.stop_signal->load()) << " before the run started; nothing was run\n";
    res.exit_code = 128 + opt.stop_signal->load();
    return res;
  }
  io::OutputDir dir;
  std::string error;
  if (!dir.open(opt.out_dir, error)) {
    log << "error: " << error << "\n";
    res.exit_code = 1;
    return res;
  }
  io::TextFileWriter csv;
  std::string csv_error;  // the first write error; the run goes on, the outputs are not committed
  if (!csv.open(dir.file("timeseries.csv"), csv_error)) {
    log << "error: " << csv_error << "\n";
    res.exit_code = 1;
    return res;
  }
  std::string text;
  for (std::size_t c = 0; c < columns.size(); ++c) {
    text += (c ? "," : "") + std::string(signals[static_cast<std::size_t>(columns[c])].name);
  }
  text += "\n";

  const std::unique_ptr<Simulation> sim = make_simulation(sc, SimulationOptions{columns, kChunkSteps});
  Simulation& runner = *sim;
  const auto wall_start = std::chrono::steady_clock::now();
  double run_wall_s = 0.0;
  int interrupted_by = 0;  // signal number
  for (;;) {
    const auto t0 = std::chrono::steady_clock::now();
    runner.run(opt.stop_signal);
    run_wall_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // between chunks: write rows and report progress
    const auto rows = runner.rows();
    for (std::size_t i = 0; i < rows.size(); ++i) {
      io::append_number(text, rows[i]);
      text += (i + 1) % columns.size() == 0 ? '\n' : ',';
    }
    runner.clear_rows();
    if (csv_error.empty()) csv.write(text, csv_error);
    text.clear();
    if (opt.progress) {
      char buf[96];
      std::snprintf(buf, sizeof buf, "\r[%3d%%] t = %.1f s of %.1f s", static_cast<int>(100.0 * runner.step_index() / std::max<std::int64_t>(1, runner.total_steps())),
                    runner.time_s(), sc.solver.duration_s);
      log << buf << std::flush;
    }
    if (runner.finished() || !csv_error.empty()) break;  // a write error ends the run: its rows are lost
    if (opt.stop_signal != nullptr && opt.stop_signal->load() != 0) {
      interrupted_by = opt.stop_signal->load();
      break;
    }
  }
  if (opt.progress) log << "\n";
  if (csv_error.empty()) csv.close(csv_error);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();

  const RunStats& st = runner.stats();
  const MetricTotals& mt = runner.metrics();
  const RunFigures fig = runner.figures();
  const plant::EnergyAudit audit = runner.audit();
  const double sim_s = runner.time_s();

  io::JsonObject& j = res.summary;
  std::string status = "ok";
  if (st.fault != 0) {
    status = "fault";
    res.exit_code = 3;
  } else if (interrupted_by != 0) {
    status = "interrupted";
    res.exit_code = 128 + interrupted_by;  // the shell's convention: 130 SIGINT, 143 SIGTERM, 129 SIGHUP
  }
  const double relative = std::abs(audit.residual_J) / std::max(audit.scale_J, 1.0);
  const bool audit_closes = relative <= kAuditWarnRelative;
  if (!audit_closes) {
    std::string causes;
    if (st.newton_failures > 0) causes += std::to_string(st.newton_failures) + " implicit-Euler steps did not converge; ";
    if (st.chattering_steps > 0) causes += std::to_string(st.chattering_steps) + " steps hit the event cap (chattering); ";
    causes += "the step may be too coarse for the dynamics (solver.step_s = " + io::number_text(sc.solver.step_s) +
              " s; the shipped scenarios use 0.001 s)";
    char rel[32];
    std::snprintf(rel, sizeof rel, "%.3g", relative);
    res.warnings.push_back(std::string("the energy audit does not close: relative residual ") + rel + " > " +
                           io::number_text(kAuditWarnRelative) + ". Likely causes: " + causes +
                           ". Treat the results with care.");
  }
  j.text("status", status);
  if (st.fault != 0) {
    j.text("fault", fault_text(st.fault) + " at t = " + io::number_text(st.fault_time_s) + " s (step " +
                        std::to_string(st.fault_step) + ")");
  }
  j.text("scenario", sc.name);
  j.text("description", sc.description);
  if (interrupted_by != 0) j.text("interrupted_by", signal_name(interrupted_by));
  j.text("vehicle_file", sc.vehicle_path);
  j.text("cycle_file", sc.cycle_path);
  j.text("solver", solver_name(sc.solver.kind));
  j.number("step_s", sc.solver.step_s);
  j.number("duration_s", sim_s);
  j.integer("steps", st.steps_done);
  j.integer("events", st.events);
  j.integer("chattering_steps", st.chattering_steps);
  j.integer("newton_failures", st.newton_failures);
  j.integer("newton_iterations", st.newton_iterations);
  j.integer("output_decimation", sc.output.decimation);
  j.integer("rows_dropped", st.rows_dropped);

  const double distance_m = fig.distance_m.value_or(0.0);
  j.number("distance_m", distance_m);
  const double rms_kmh = mt.speed_error_rms_kmh();
  if (mt.has_speed) {
    j.number("speed_error_rms_kmh", rms_kmh);
    j.number("speed_error_max_kmh", mt.speed_error_max_kmh);
    j.number("locked_time_s", mt.locked_time_s);
  } else {
    j.null("speed_error_rms_kmh");
    j.null("speed_error_max_kmh");
  }
  j.number("battery_energy_J", audit.battery_out_J);
  j.number("battery_Wh_per_km", distance_m > 0.0 ? audit.battery_out_J / 3600.0 / (distance_m / 1000.0) : NAN);
  // what left the EMF (terminal energy + battery losses): tracks the SOC drop, and is what
  // the library tutorial reports as Wh/km (MODELS.md §10.3)
  j.number("battery_emf_Wh_per_km", distance_m > 0.0 ? (audit.battery_out_J + audit.battery_loss_J) / 3600.0 /
                                                          (distance_m / 1000.0)
                                                    : NAN);
  if (fig.soc_start) {
    j.number("soc_start", *fig.soc_start);
    j.number("soc_end", *fig.soc_end);
  } else {
    j.null("soc_start");
    j.null("soc_end");
  }
  double fuel_g = 0.0, fuel_L_per_100km = 0.0;
  if (fig.fuel_g) {
    fuel_g = *fig.fuel_g;
    const double litres = fuel_g / 1000.0 / fig.fuel_density_kg_m3 * 1000.0;
    fuel_L_per_100km = distance_m > 0.0 ? litres / (distance_m / 1e5) : NAN;
  }
  j.number("fuel_g", fuel_g);
  j.number("fuel_L_per_100km", fuel_L_per_100km);
  if (mt.has_engine) {
    j.number("ice_on_time_s", mt.engine_on_time_s);
    j.integer("ice_starts", mt.engine_starts);
  }
  j.number("energy_balance_residual_J", audit.residual_J);
  j.number("energy_balance_relative", relative);
  j.boolean("energy_balance_ok", audit_closes);
  io::JsonObject terms;
  for (const auto& [k, v] : audit.terms) terms.number(k, v);
  j.object("energy_audit", terms);
  j.number("wall_time_s", wall_s);
  j.number("run_wall_time_s", run_wall_s);
  j.number("realtime_factor", run_wall_s > 0.0 ? sim_s / run_wall_s : NAN);
  j.number("ns_per_step", st.steps_done > 0 ? 1e9 * run_wall_s / st.steps_done : NAN);

  // human-readable lines
  char buf[256];
  std::string& s = res.summary_text;
  std::snprintf(buf, sizeof buf, "scenario      %s (%s, h = %g s, %lld steps, %lld events)\n", sc.name.c_str(),
                solver_name(sc.solver.kind), sc.solver.step_s, static_cast<long long>(st.steps_done),
                static_cast<long long>(st.events));
  s += buf;
  if (mt.has_speed) {
    std::snprintf(buf, sizeof buf, "distance      %.4f km\nspeed error   rms %.3f km/h, max %.3f km/h\n", distance_m / 1000.0,
                  rms_kmh, mt.speed_error_max_kmh);
    s += buf;
  }
  if (fig.soc_start) {
    if (distance_m > 0.0) {
      std::snprintf(buf, sizeof buf, "battery       %.1f Wh out, %.1f Wh/km, SOC %.4f -> %.4f\n",
                    audit.battery_out_J / 3600.0, audit.battery_out_J / 3600.0 / (distance_m / 1000.0), *fig.soc_start,
                    *fig.soc_end);
    } else {  // a rig: no distance
      std::snprintf(buf, sizeof buf, "battery       %.1f Wh out, SOC %.4f -> %.4f\n", audit.battery_out_J / 3600.0,
                    *fig.soc_start, *fig.soc_end);
    }
    s += buf;
  }
  if (mt.has_engine) {
    std::snprintf(buf, sizeof buf, "fuel          %.1f g, %.2f L/100 km; engine on %.1f s, %lld starts\n", fuel_g,
                  fuel_L_per_100km, mt.engine_on_time_s, static_cast<long long>(mt.engine_starts));
    s += buf;
  }
  std::snprintf(buf, sizeof buf, "energy audit  residual %.3g J (relative %.2g)\n", audit.residual_J, relative);
  s += buf;
  std::snprintf(buf, sizeof buf, "speed         %.0f x real time (%.1f ns per step, %.3f s wall)\n",
                run_wall_s > 0 ? sim_s / run_wall_s : 0.0, st.steps_done > 0 ? 1e9 * run_wall_s / st.steps_done : 0.0,
                wall_s);
  s += buf;
  if (st.fault != 0) {
    s += "FAULT         " + fault_text(st.fault) + " at t = " + io::number_text(st.fault_time_s) + " s (step " +
         std::to_string(st.fault_step) + ")\n";
  }
  if (interrupted_by != 0) s += "INTERRUPTED   at t = " + io::number_text(sim_s) + " s; outputs so far kept\n";
  j.strings("warnings", [&] {
    std::vector<std::string> all = sc.warnings;
    all.insert(all.end(), res.warnings.begin(), res.warnings.end());
    return all;
  }());

  if (!csv_error.empty()) {
    log << "error: " << csv_error << " (the run's files are in " << dir.partial_dir() << ")\n";
    res.exit_code = 1;
    return res;
  }
  if (!io::write_file_atomically(dir.file("summary.json"), j.str() + "\n", error)) {
    log << "error: " << error << " (the run's files are in " << dir.partial_dir() << ")\n";
    res.exit_code = 1;
    return res;
  }
  if (opt.before_commit && !opt.before_commit(dir.partial_dir())) res.after_failed = true;
  // an interrupted run never replaces a complete earlier one: it stays in its own folder
  if (!dir.commit(error, interrupted_by == 0)) {
    log << "error: " << error << "\n";
    res.exit_code = 1;
  }
  res.results_dir = dir.results_dir();
  for (const std::string& w : dir.warnings()) res.warnings.push_back(w);
  return res;
}

}  // namespace ehpt::hil
