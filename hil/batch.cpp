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
  add(plant::kFaultDriveSolve, "the drive's operating point did not converge");
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

// The columns of timeseries.csv: the scenario's output.signals, or every signal.
std::vector<int> chosen_columns(const Scenario& sc, const std::vector<SignalInfo>& signals) {
  std::vector<int> columns;
  if (sc.output.signals.empty()) {
    for (std::size_t i = 0; i < signals.size(); ++i) columns.push_back(static_cast<int>(i));
    return columns;
  }
  for (const std::string& name : sc.output.signals) {
    for (std::size_t i = 0; i < signals.size(); ++i) {
      if (signals[i].name == name) columns.push_back(static_cast<int>(i));
    }
  }
  return columns;
}

// How the stepping went: wall times, a signal that stopped it, a write error.
struct Streamed {
  int interrupted_by = 0;  // signal number
  double wall_s = 0.0, run_wall_s = 0.0;
  std::string csv_error;   // the first write error (the run stops there)
};

// Runs the simulation in chunks and writes its rows to the CSV between chunks (the run phase
// is inside Simulation::run: no I/O there), with the progress line.
Streamed stream(Simulation& sim, const Scenario& sc, std::string text, std::size_t columns,
                io::TextFileWriter& csv, const BatchOptions& opt, std::ostream& log) {
  Streamed out;
  const auto wall_start = std::chrono::steady_clock::now();
  for (;;) {
    const auto t0 = std::chrono::steady_clock::now();
    if (opt.driver != nullptr) {
      opt.driver->advance(sim, kChunkSteps, opt.stop_signal);
    } else {
      sim.run(opt.stop_signal);
    }
    out.run_wall_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const auto rows = sim.rows();
    for (std::size_t i = 0; i < rows.size(); ++i) {
      io::append_number(text, rows[i]);
      text += (i + 1) % columns == 0 ? '\n' : ',';
    }
    sim.clear_rows();
    if (out.csv_error.empty()) csv.write(text, out.csv_error);
    if (out.csv_error.empty() && opt.driver != nullptr) opt.driver->flush(out.csv_error);
    text.clear();
    if (opt.progress) {
      char buf[96];
      std::snprintf(buf, sizeof buf, "\r[%3d%%] t = %.1f s of %.1f s",
                    static_cast<int>(100.0 * sim.step_index() / std::max<std::int64_t>(1, sim.total_steps())),
                    sim.time_s(), sc.solver.duration_s);
      log << buf << std::flush;
    }
    if (sim.finished() || !out.csv_error.empty()) break;  // a write error ends the run: its rows are lost
    if (opt.stop_signal != nullptr && opt.stop_signal->load() != 0) {
      out.interrupted_by = opt.stop_signal->load();
      break;
    }
  }
  if (opt.progress) log << "\n";
  if (out.csv_error.empty()) csv.close(out.csv_error);
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return out;
}

// Everything the summary says, computed once from the finished simulation.
struct Report {
  RunStats st;
  MetricTotals mt;
  RunFigures fig;
  plant::EnergyAudit audit;
  Streamed run;
  double sim_s = 0.0, distance_m = 0.0, relative = 0.0, fuel_g = 0.0, fuel_L_per_100km = 0.0;
  bool audit_closes = true;
  std::int64_t codec_saturations = 0;
  std::string status = "ok";
};

Report report_of(const Simulation& sim, Streamed run) {
  Report r{sim.stats(), sim.metrics(), sim.figures(), sim.audit(), std::move(run)};
  r.sim_s = sim.time_s();
  r.codec_saturations = sim.ecu_codec_saturations();
  r.distance_m = r.fig.distance_m.value_or(0.0);
  r.relative = std::abs(r.audit.residual_J) / std::max(r.audit.scale_J, 1.0);
  r.audit_closes = r.relative <= kAuditWarnRelative;
  if (r.fig.fuel_g) {
    r.fuel_g = *r.fig.fuel_g;
    const double litres = r.fuel_g / 1000.0 / r.fig.fuel_density_kg_m3 * 1000.0;
    r.fuel_L_per_100km = r.distance_m > 0.0 ? litres / (r.distance_m / 1e5) : NAN;
  }
  if (r.st.fault != 0) {
    r.status = "fault";
  } else if (r.run.interrupted_by != 0) {
    r.status = "interrupted";
  }
  return r;
}

// The warning of an energy audit that does not close, with its likely causes.
std::string audit_warning(const Scenario& sc, const Report& r) {
  std::string causes;
  if (r.st.newton_failures > 0) causes += std::to_string(r.st.newton_failures) + " implicit-Euler steps did not converge; ";
  if (r.st.chattering_steps > 0) causes += std::to_string(r.st.chattering_steps) + " steps hit the event cap (chattering); ";
  causes += "the step may be too coarse for the dynamics (solver.step_s = " + io::number_text(sc.solver.step_s) +
            " s; the shipped scenarios use 0.001 s)";
  char rel[32];
  std::snprintf(rel, sizeof rel, "%.3g", r.relative);
  return std::string("the energy audit does not close: relative residual ") + rel + " > " +
         io::number_text(kAuditWarnRelative) + ". Likely causes: " + causes + ". Treat the results with care.";
}

io::JsonObject summary_json(const Scenario& sc, const Report& r, const std::vector<std::string>& warnings) {
  io::JsonObject j;
  const RunStats& st = r.st;
  const MetricTotals& mt = r.mt;
  j.text("status", r.status);
  if (st.fault != 0) {
    j.text("fault", fault_text(st.fault) + " at t = " + io::number_text(st.fault_time_s) + " s (step " +
                        std::to_string(st.fault_step) + ")");
    j.integer("fault_steps", st.fault_steps);
  }
  j.text("scenario", sc.name);
  j.text("description", sc.description);
  if (r.run.interrupted_by != 0) j.text("interrupted_by", signal_name(r.run.interrupted_by));
  j.text("vehicle_file", sc.vehicle_path);
  j.text("cycle_file", sc.cycle_path);
  j.text("solver", solver_name(sc.solver.kind));
  j.number("step_s", sc.solver.step_s);
  j.number("duration_s", r.sim_s);
  j.integer("steps", st.steps_done);
  j.integer("events", st.events);
  j.integer("chattering_steps", st.chattering_steps);
  j.integer("newton_failures", st.newton_failures);
  j.integer("newton_iterations", st.newton_iterations);
  j.integer("output_decimation", sc.output.decimation);
  j.integer("rows_dropped", st.rows_dropped);
  if (sc.ecu_codec == EcuCodec::kCan) j.integer("ecu_codec_saturated_signals", r.codec_saturations);
  j.number("distance_m", r.distance_m);
  if (mt.has_speed) {
    j.number("speed_error_rms_kmh", mt.speed_error_rms_kmh());
    j.number("speed_error_max_kmh", mt.speed_error_max_kmh);
    j.number("locked_time_s", mt.locked_time_s);
  } else {
    j.null("speed_error_rms_kmh");
    j.null("speed_error_max_kmh");
  }
  const double km = r.distance_m / 1000.0;
  j.number("battery_energy_J", r.audit.battery_out_J);
  j.number("battery_Wh_per_km", r.distance_m > 0.0 ? r.audit.battery_out_J / 3600.0 / km : NAN);
  // what left the EMF (terminal energy + battery losses): tracks the SOC drop, and is what
  // the library tutorial reports as Wh/km (MODELS.md §10.3)
  j.number("battery_emf_Wh_per_km",
           r.distance_m > 0.0 ? (r.audit.battery_out_J + r.audit.battery_loss_J) / 3600.0 / km : NAN);
  if (r.fig.soc_start) {
    j.number("soc_start", *r.fig.soc_start);
    j.number("soc_end", *r.fig.soc_end);
  } else {
    j.null("soc_start");
    j.null("soc_end");
  }
  j.number("fuel_g", r.fuel_g);
  j.number("fuel_L_per_100km", r.fuel_L_per_100km);
  if (mt.has_engine) {
    j.number("ice_on_time_s", mt.engine_on_time_s);
    j.integer("ice_starts", mt.engine_starts);
  }
  j.number("energy_balance_residual_J", r.audit.residual_J);
  j.number("energy_balance_relative", r.relative);
  j.boolean("energy_balance_ok", r.audit_closes);
  io::JsonObject terms;
  for (const auto& [k, v] : r.audit.terms) terms.number(k, v);
  j.object("energy_audit", terms);
  j.number("wall_time_s", r.run.wall_s);
  j.number("run_wall_time_s", r.run.run_wall_s);
  j.number("realtime_factor", r.run.run_wall_s > 0.0 ? r.sim_s / r.run.run_wall_s : NAN);
  j.number("ns_per_step", st.steps_done > 0 ? 1e9 * r.run.run_wall_s / st.steps_done : NAN);
  j.strings("warnings", warnings);
  return j;
}

// The lines on the terminal.
std::string summary_text(const Scenario& sc, const Report& r) {
  char buf[256];
  std::string s;
  const RunStats& st = r.st;
  const MetricTotals& mt = r.mt;
  std::snprintf(buf, sizeof buf, "scenario      %s (%s, h = %g s, %lld steps, %lld events)\n", sc.name.c_str(),
                solver_name(sc.solver.kind), sc.solver.step_s, static_cast<long long>(st.steps_done),
                static_cast<long long>(st.events));
  s += buf;
  if (mt.has_speed) {
    std::snprintf(buf, sizeof buf, "distance      %.4f km\nspeed error   rms %.3f km/h, max %.3f km/h\n",
                  r.distance_m / 1000.0, mt.speed_error_rms_kmh(), mt.speed_error_max_kmh);
    s += buf;
  }
  if (r.fig.soc_start) {
    const double wh = r.audit.battery_out_J / 3600.0;
    if (r.distance_m > 0.0) {
      std::snprintf(buf, sizeof buf, "battery       %.1f Wh out, %.1f Wh/km, SOC %.4f -> %.4f\n", wh,
                    wh / (r.distance_m / 1000.0), *r.fig.soc_start, *r.fig.soc_end);
    } else {  // a rig: no distance
      std::snprintf(buf, sizeof buf, "battery       %.1f Wh out, SOC %.4f -> %.4f\n", wh, *r.fig.soc_start,
                    *r.fig.soc_end);
    }
    s += buf;
  }
  if (mt.has_engine) {
    std::snprintf(buf, sizeof buf, "fuel          %.1f g, %.2f L/100 km; engine on %.1f s, %lld starts\n", r.fuel_g,
                  r.fuel_L_per_100km, mt.engine_on_time_s, static_cast<long long>(mt.engine_starts));
    s += buf;
  }
  std::snprintf(buf, sizeof buf, "energy audit  residual %.3g J (relative %.2g)\n", r.audit.residual_J, r.relative);
  s += buf;
  const double rw = r.run.run_wall_s;
  std::snprintf(buf, sizeof buf, "speed         %.0f x real time (%.1f ns per step, %.3f s wall)\n",
                rw > 0 ? r.sim_s / rw : 0.0, st.steps_done > 0 ? 1e9 * rw / st.steps_done : 0.0, r.run.wall_s);
  s += buf;
  if (st.fault != 0) {
    s += "FAULT         " + fault_text(st.fault) + " at t = " + io::number_text(st.fault_time_s) + " s (step " +
         std::to_string(st.fault_step) + ")" +
         (st.fault_steps > 1 ? ", " + std::to_string(st.fault_steps) + " steps with a fault" : std::string()) + "\n";
  }
  if (r.run.interrupted_by != 0) {
    s += "INTERRUPTED   at t = " + io::number_text(r.sim_s) + " s; outputs so far kept\n";
  }
  return s;
}

}  // namespace

// A batch run: columns, the output folder, the simulation streamed to CSV, the summary, the
// commit. Each step is one of the functions above.
BatchResult run_batch(const Scenario& sc, const BatchOptions& opt, std::ostream& log) {
  BatchResult res;
  // a signal while loading: nothing was run, and an earlier run in DIR stays as it is
  if (opt.stop_signal != nullptr && opt.stop_signal->load() != 0) {
    log << "interrupted by " << signal_name(opt.stop_signal->load()) << " before the run started; nothing was run\n";
    res.exit_code = 128 + opt.stop_signal->load();
    return res;
  }
  const std::vector<SignalInfo> signals = scenario_signals(sc);
  const std::vector<int> columns = chosen_columns(sc, signals);
  io::OutputDir dir;
  io::TextFileWriter csv;
  std::string error;
  if (!dir.open(opt.out_dir, error) || !csv.open(dir.file("timeseries.csv"), error) ||
      (opt.driver != nullptr && !opt.driver->open(dir, error))) {
    log << "error: " << error << "\n";
    res.exit_code = 1;
    return res;
  }
  std::string header;
  for (std::size_t c = 0; c < columns.size(); ++c) {
    header += (c ? "," : "") + std::string(signals[static_cast<std::size_t>(columns[c])].name);
  }
  header += "\n";

  SimulationOptions sim_opt{columns, kChunkSteps};
  if (opt.driver != nullptr) {
    sim_opt.external_ecu = true;
    sim_opt.fault_policy = FaultPolicy::kHold;
  }
  const std::unique_ptr<Simulation> sim = make_simulation(sc, sim_opt);
  const Report r = report_of(*sim, stream(*sim, sc, header, columns.size(), csv, opt, log));
  if (r.st.fault != 0) {
    res.exit_code = 3;
  } else if (r.run.interrupted_by != 0) {
    res.exit_code = 128 + r.run.interrupted_by;  // the shell's convention: 130 SIGINT, 143 SIGTERM, 129 SIGHUP
  }
  if (!r.audit_closes) res.warnings.push_back(audit_warning(sc, r));
  std::vector<std::string> warnings = sc.warnings;
  warnings.insert(warnings.end(), res.warnings.begin(), res.warnings.end());
  res.summary = summary_json(sc, r, warnings);
  res.summary_text = summary_text(sc, r);
  if (opt.driver != nullptr) opt.driver->report(res.summary, res.summary_text);

  if (!r.run.csv_error.empty()) {
    log << "error: " << r.run.csv_error << " (the run's files are in " << dir.partial_dir() << ")\n";
    res.exit_code = 1;
    return res;
  }
  if (!io::write_file_atomically(dir.file("summary.json"), res.summary.str() + "\n", error)) {
    log << "error: " << error << " (the run's files are in " << dir.partial_dir() << ")\n";
    res.exit_code = 1;
    return res;
  }
  if (opt.before_commit && !opt.before_commit(dir.partial_dir())) res.after_failed = true;
  // an interrupted run never replaces a complete earlier one: it stays in its own folder
  if (!dir.commit(error, r.run.interrupted_by == 0)) {
    log << "error: " << error << "\n";
    res.exit_code = 1;
  }
  res.results_dir = dir.results_dir();
  for (const std::string& w : dir.warnings()) res.warnings.push_back(w);
  return res;
}

}  // namespace ehpt::hil
