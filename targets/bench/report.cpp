// SPDX-License-Identifier: BSD-3-Clause
// The bench's reports (report.hpp).
#include "targets/bench/report.hpp"

#include "targets/bench/machine.hpp"

namespace ehpt::bench {

namespace {
// Each side's distance from RK4 at kFineStep_s: |final SOC difference|, |distance difference|.
struct CvodeErrors {
  double soc_rk4 = NAN, soc_cvode = NAN, distance_rk4_m = NAN, distance_cvode_m = NAN;
};
CvodeErrors cvode_errors(const CvodeRow& r) {
  const auto diff = [](std::optional<double> a, std::optional<double> b) { return a && b ? std::abs(*a - *b) : NAN; };
  return {diff(r.rk4.soc_end, r.fine.soc_end), diff(r.cv.soc_end, r.fine.soc_end),
          diff(r.rk4.distance_m, r.fine.distance_m), diff(r.cv.distance_m, r.fine.distance_m)};
}
// The lockstep runs against the transport's floor (issue 26): at least half its round trips.
constexpr double kTargetExchangeFloorRatio = 0.5;

const std::vector<std::pair<std::string, std::string>>& exchange_rows() {
  static const std::vector<std::pair<std::string, std::string>> rows = {
      {"lockstep_socketcand", "ehpt ecu, " + std::string(kRtScenario) + ", socketcand"},
      {"lockstep_socketcand_psecu2", "ehpt ecu, psecu2_nedc, socketcand"},
      {"lockstep_lcm", "ehpt ecu, " + std::string(kRtScenario) + ", LCM udpm"},
      {"lockstep_lcm_psecu2", "ehpt ecu, psecu2_nedc, LCM udpm"},
      {"lockstep_pycan", "tools/pycan_ecu.py (python-can 4.1, Nagle on), psecu2_nedc, socketcand"}};
  return rows;
}

// A lockstep run's periods/s over its transport's ping-pong round trips/s (LCM: UDP, else TCP);
// NaN if either is missing.
double exchange_floor_ratio(const Bench& b, const SubRun& r) {
  const PingPong& floor = r.name.rfind("lockstep_lcm", 0) == 0 ? b.udp_floor : b.tcp_floor;
  if (!r.ok() || !floor.error.empty() || floor.round_trips <= 0 || !std::isfinite(r.samples_per_s)) return NAN;
  return r.samples_per_s / floor.round_trips_per_s();
}

}  // namespace

// What an ECU test adds to a psecu2 rk4 step: (test - plain) / plain of the median ns per
// step, NaN if either did not run.
double test_overhead(const Bench& b) {
  const SpeedRun *plain = nullptr, *test = nullptr;
  for (const auto& r : b.speed) {
    if (!r.error.empty() || r.solver != "rk4") continue;
    if (r.scenario == "psecu2_nedc") plain = &r;
    if (r.scenario == kTestRow) test = &r;
  }
  if (plain == nullptr || test == nullptr) return NAN;
  return (test->ns_per_step.median - plain->ns_per_step.median) / plain->ns_per_step.median;
}

struct Group {
  std::string name, meaning;
  std::vector<std::string> members;
};

const std::vector<Group>& groups() {
  static const std::vector<Group> g = {
      {"built_in_ecu", "the built-in ECU, no codec: as fast as possible, real time, lockstep over LCM (doubles)",
       {"batch_1", "batch_2", "realtime", "lockstep_lcm"}},
      {"can_codec", "the ECU's signals through the CAN codec: in process, and lockstep over socketcand",
       {"batch_can", "lockstep_socketcand"}},
      {"wall_clock_session", "a wall-clock bus session and its replay (its own trajectory: command timing differs)",
       {"wallclock_socketcand", "replay"}},
  };
  return g;
}

// Whether the group's runs that ran agree; compared: how many hashes were compared.
bool group_equal(const Bench& b, const Group& g, int& compared) {
  std::string first;
  compared = 0;
  bool equal = true;
  for (const auto& m : g.members) {
    for (const auto& r : b.runs) {
      if (r.name != m || !r.ok() || r.hash.empty()) continue;
      ++compared;
      if (first.empty()) first = r.hash;
      if (r.hash != first) equal = false;
    }
  }
  return equal;
}

bool all_equal(const Bench& b) {
  for (const auto& g : groups()) {
    int n = 0;
    if (!group_equal(b, g, n)) return false;
  }
  return true;
}

// The run through the CAN codec differs from the plain one: the codec quantises what the
// ECU sees and sends, so equal hashes there would mean nothing moved (a vacuous comparison).
bool groups_distinct(const Bench& b) {
  std::string plain, can;
  for (const auto& r : b.runs) {
    if (r.name == "batch_1" && r.ok()) plain = r.hash;
    if (r.name == "batch_can" && r.ok()) can = r.hash;
  }
  return !plain.empty() && !can.empty() && plain != can;
}

std::string target_mark(bool met) { return met ? "met" : "NOT met"; }

std::string report_text(const Bench& b) {
  std::string s;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "ehpt bench%s: commit %s%s, %s\nmachine: %d CPUs (%s), %s\nload average: %s at the start, %s at the end\n",
                b.opt.quick ? " --quick" : "", b.commit.c_str(), b.dirty ? " (with uncommitted changes)" : "", b.date.c_str(),
                b.nproc, cpu_model().c_str(), kernel().c_str(), b.load_start.c_str(),
                b.load_end.empty() ? "-" : b.load_end.c_str());
  s += buf;
  const std::string each = std::to_string(b.reps) + " whole run" + (b.reps > 1 ? "s" : "") + " each";

  // (a), (b)
  s += "\n(a, b) speed in this process, h = 1 ms, " + each + (b.reps > 1 ? " (median; min..max)" : "") + "\n";
  std::vector<std::vector<std::string>> rows;
  for (const auto& r : b.speed) {
    if (!r.error.empty()) {
      rows.push_back({r.scenario, r.solver, "-", "-", "-", "", "-", "", "", "failed: " + r.error});
      continue;
    }
    std::string ratio, ratio_target;
    for (const auto& q : b.speed) {
      if (r.solver == "implicit-euler" && q.scenario == r.scenario && q.solver == "rk4" && q.error.empty()) {
        ratio = fmt("%.2f", r.ns_per_step.median / q.ns_per_step.median);
        ratio_target = "<= 2.5";
      }
    }
    const bool rk4 = r.solver == "rk4" && std::isfinite(b.floor_ns_per_step);
    rows.push_back({r.scenario, r.solver, fmt("%.0f", r.duration_s), fmt("%.1f", r.ns_per_step.median),
                    fmt("%.1f", r.ns_per_step.min) + ".." + fmt("%.1f", r.ns_per_step.max),
                    std::isfinite(r.target_ns) ? "<= " + fmt("%.0f", r.target_ns) : "",
                    rk4 ? fmt("%.2f", r.ns_per_step.median / b.floor_ns_per_step) : "",
                    std::isfinite(r.target_floor_ratio) ? "<= " + fmt("%.1f", r.target_floor_ratio) : "",
                    fmt("%.0f", r.realtime_factor), ratio, ratio_target, ""});
  }
  s += table({"vehicle", "solver", "sim s", "ns/step", "min..max", "target", "x floor", "target", "x real time",
              "IE/RK4", "target", ""},
             rows, "llrrrrrrrrrl");
  s += "  floor: " + fmt("%.1f", b.floor_ns_per_step) +
       " ns per step: the battery's four dependent stage chains (state, sqrt, P / V, derivatives), timed in this run\n";
  if (const double f = test_overhead(b); std::isfinite(f)) {
    s += "  an ECU test (a fault, four expectations at every step) costs " + fmt("%.1f", 100.0 * f) +
         " % of a psecu2_nedc rk4 step (target <= 10 %)\n";
  }
  if (b.speed_status != "ok") s += "  " + b.speed_status + "\n";

  // (c)
  s += "\n(c) wake-up latency, period 1 ms, SCHED_FIFO priority " + std::to_string(b.opt.priority) + ", CPU " +
       std::to_string(b.cpu) + ", " + std::to_string(b.seconds) + " s each (" + kRtScenario + " for ehpt)\n";
  if (b.latency_status != "ok") {
    s += "  " + b.latency_status + "\n";
  } else {
    const auto lat_row = [](const std::string& who, const Latency& l) -> std::vector<std::string> {
      if (l.status != "ok") return {who, "-", "-", "-", "-", "-", l.status};
      return {who, fmt("%.1f", l.p50), fmt("%.1f", l.p99), fmt("%.1f", l.p99_9), fmt("%.1f", l.max),
              std::to_string(l.samples), ""};
    };
    s += table({"source", "p50 us", "p99 us", "p99.9 us", "max us", "wake-ups", ""},
               {lat_row("cyclictest", b.cyclictest), lat_row("ehpt run --realtime", b.rt_loop)}, "lrrrrrl");
    std::vector<std::vector<std::string>> t;
    if (b.cyclictest.status == "ok" && b.rt_loop.status == "ok") {
      const double ratio = b.rt_loop.p99 / b.cyclictest.p99;
      t.push_back({"p99 ehpt / cyclictest", fmt("%.2f", ratio), "<= 1.2", target_mark(ratio <= 1.2)});
    } else {
      t.push_back({"p99 ehpt / cyclictest", "-", "<= 1.2", ""});
    }
    if (b.rt_loop.status == "ok") {
      t.push_back({"overruns (ticks missed)", std::to_string(b.overruns) + " (" + std::to_string(b.missed_ticks) + ")",
                   "0 over 60 s",
                   b.overruns != 0 ? "NOT met" : b.seconds >= 60 ? "met" : "0 in " + std::to_string(b.seconds) + " s"});
      for (const auto& r : b.runs) {
        if (r.name == "realtime") {
          t.push_back({"peak RSS MB", fmt("%.1f", r.peak_rss_MB), "<= 16", target_mark(r.peak_rss_MB <= 16.0)});
        }
      }
      t.push_back({"scheduler", b.rt_scheduler, "", ""});
    }
    s += table({"figure", "value", "target", ""}, t, "lrrl");
    for (const auto& w : b.rt_warnings) s += "  warning (real-time set-up): " + w + "\n";
    if (!b.cyclictest.dma_latency.empty()) {
      s += "  note: cyclictest set /dev/cpu_dma_latency to " + b.cyclictest.dma_latency +
           " while it ran (no deep C-states); ehpt's loop does the same (summary.json realtime.cpu_dma_latency_zero)\n";
    }
  }

  // (d)
  s += "\n(d) heap allocations after start-up (malloc level, the whole process over the whole loop, bus IO and CSV\n"
       "    included) and peak RSS, from each run's summary.json\n";
  rows.clear();
  const std::vector<std::pair<std::string, std::string>> alloc_rows = {
      {"batch_1", "ehpt run (as fast as possible)"},
      {"realtime", "ehpt run --realtime"},
      {"lockstep_socketcand", "ehpt plant --lockstep, socketcand"},
      {"wallclock_socketcand", "ehpt plant (wall clock), socketcand"},
      {"lockstep_lcm", "ehpt plant --lockstep, LCM udpm"},
      {"replay", "ehpt replay"}};
  for (const auto& [name, label] : alloc_rows) {
    for (const auto& r : b.runs) {
      if (r.name != name) continue;
      if (!r.ok()) {
        rows.push_back({label, "-", "-", "", r.status});
      } else {
        rows.push_back({label, r.allocations ? std::to_string(*r.allocations) : "-", fmt("%.1f", r.peak_rss_MB), "<= 16",
                        r.allocations ? "" : "not counted (a binary without the allocation hooks)"});
      }
    }
  }
  rows.push_back({"ehpt ecu (the ECU's process)", "-", "-", "", "not reported (ehpt ecu writes no summary)"});
  s += table({"process", "allocations", "peak RSS MB", "target", ""}, rows, "lrrrl");

  // the lockstep exchange's own rate (from the first command to the last), against the
  // transport's floor timed in this run
  const auto floor_text = [](const PingPong& p) {
    return p.error.empty() ? fmt("%.0f", p.round_trips_per_s()) + " round trips/s" : "not measured (" + p.error + ")";
  };
  s += "\n    the lockstep exchange: periods answered per second (one sample out, its command back) and the round\n"
       "    trip, from each run's summary.json bus; x floor: over a ping-pong of two processes on 127.0.0.1\n"
       "    timed in this run (one write each way, blocking reads): TCP " + floor_text(b.tcp_floor) + ", UDP " +
       floor_text(b.udp_floor) + "\n";
  rows.clear();
  for (const auto& [name, label] : exchange_rows()) {
    for (const auto& r : b.runs) {
      if (r.name != name) continue;
      const double target = name == "lockstep_pycan" ? 2000.0 : kTargetExchangeFloorRatio;
      const std::string target_text = name == "lockstep_pycan" ? ">= 2000/s" : ">= " + fmt("%.1f", target) + " x floor";
      if (!r.ok()) {
        rows.push_back({label, "-", "-", "-", "-", target_text, r.status});
        continue;
      }
      const double ratio = exchange_floor_ratio(b, r);
      const bool met = name == "lockstep_pycan" ? r.samples_per_s >= target : ratio >= target;
      rows.push_back({label, fmt("%.0f", r.samples_per_s), fmt("%.0f", r.round_trip_p50_us),
                      fmt("%.0f", r.round_trip_p99_us), fmt("%.2f", ratio), target_text,
                      std::isfinite(ratio) || name == "lockstep_pycan" ? target_mark(met) : "no floor to compare"});
    }
  }
  s += table({"ECU, transport", "periods/s", "round trip p50 us", "p99 us", "x floor", "target", ""}, rows, "lrrrrrl");

  // the python-can ECU on the wall clock: its two command frames of a sample, as the plant
  // read them (resolution: the plant's 1 ms step, when it drains the bus)
  s += "\n    tools/pycan_ecu.py on the wall clock (psecu2_nedc, " + fmt("%.0f", b.wall_clock_s) +
       " s): how far apart the two command frames of a sample came, as the plant read them (it drains\n"
       "    every 1 ms step), and the samples left without a fresh command\n";
  rows.clear();
  for (const auto& r : b.runs) {
    if (r.name != "wallclock_pycan") continue;
    if (!r.ok()) {
      rows.push_back({"wall clock, python-can", "-", "-", "-", "-", "<= 1000", r.status});
    } else {
      rows.push_back({"wall clock, python-can", fmt("%.0f", r.spread_p50_us), fmt("%.0f", r.spread_p99_us),
                      fmt("%.0f", r.spread_max_us), fmt("%.0f", r.stale_samples), "<= 1000",
                      target_mark(r.spread_p99_us <= 1000.0)});
    }
  }
  s += table({"ECU", "spread p50 us", "p99 us", "max us", "stale samples", "target (p99)", ""}, rows, "lrrrrrl");

  // the VCU of its own DBC (no echo): does it keep up on the wall clock and in real time
  s += "\n    examples/own_dbc/vcu_ecu.py (its own DBC, E2E, no echo) bound to psecu2_nedc, " + fmt("%.0f", b.wall_clock_s) +
       " s: samples the VCU left without a fresh command, and timeouts\n";
  rows.clear();
  for (const auto& [name, label] : std::vector<std::pair<std::string, std::string>>{
           {"wallclock_own_dbc", "wall clock"}, {"realtime_own_dbc", "real time (SCHED_FIFO)"}}) {
    for (const auto& r : b.runs) {
      if (r.name != name) continue;
      if (!r.ok()) {
        rows.push_back({label, "-", "-", "0 on a quiet machine", r.status});
      } else {
        rows.push_back({label, fmt("%.0f", r.stale_samples), fmt("%.0f", r.timeouts), "0 on a quiet machine",
                        target_mark(r.stale_samples == 0.0 && r.timeouts == 0.0)});
      }
    }
  }
  s += table({"pacing", "stale samples", "timeouts", "target", ""}, rows, "lrrll");

  // (e)
  s += "\n(e) determinism: " + std::string(kRtScenario) + ", " + std::to_string(b.seconds) + " s (the wall-clock session " +
       fmt("%.0f", b.wall_clock_s) + " s); trajectory_hash: FNV-1a over every recorded value\n";
  rows.clear();
  for (const auto& g : groups()) {
    int n = 0;
    const bool eq = group_equal(b, g, n);
    bool first = true;
    for (const auto& m : g.members) {
      for (const auto& r : b.runs) {
        if (r.name != m) continue;
        rows.push_back({first ? g.name : "", r.label, r.ok() ? r.hash : "-",
                        first ? (n < 2 ? "nothing to compare" : eq ? "yes" : "NO") : "", r.ok() ? "" : r.status});
        first = false;
      }
    }
  }
  s += table({"group", "run", "hash", "equal", ""}, rows, "lllll");
  s += "SocketCAN (vcan0): not run (needs the vcan guest: tools/vcan-vm.sh)\n";
  s += std::string("all equal: ") + (all_equal(b) ? "yes" : "NO") +
       " (a wall-clock bus session is compared with its own replay only: its command timing differs)\n";
  const bool distinct = groups_distinct(b);
  s += std::string("the CAN codec's quantisation changes the trajectory (a check that the runs moved): ") +
       (distinct ? "yes" : "NO") + "\n";

  // (f)
  s += "\n(f) RK4 at 1 ms against CVODE (BDF, rtol " + fmt("%g", kCvodeRtol) + "), " + each +
       (b.reps > 1 ? " (median wall time)" : "") + "; each one's error against RK4 at " + fmt("%g", kFineStep_s * 1e3) +
       " ms (final SOC, distance)\n";
  rows.clear();
  for (const auto& r : b.cvode) {
    if (!r.error.empty()) {
      rows.push_back({r.scenario, "-", "-", "-", "-", "-", "-", "-", "-", "", "failed: " + r.error});
      continue;
    }
    const CvodeErrors e = cvode_errors(r);
    rows.push_back({r.scenario, fmt("%.0f", r.duration_s), fmt("%.1e", e.soc_rk4), fmt("%.1e", e.soc_cvode),
                    fmt("%.1e", e.distance_rk4_m), fmt("%.1e", e.distance_cvode_m), fmt("%.3f", r.rk4_wall.median),
                    fmt("%.3f", r.cv_wall.median), fmt("%.1f", r.cv_wall.median / r.rk4_wall.median), ">= 20", ""});
  }
  s += table({"scenario", "sim s", "SOC err RK4", "SOC err CVODE", "dist err RK4 m", "dist err CVODE m", "RK4 s",
              "CVODE s", "CVODE/RK4", "target", ""},
             rows, "lrrrrrrrrrl");
  if (b.cvode_status != "ok") s += "  " + b.cvode_status + "\n";

  // (g)
  s += "\n(g) sweep planning ('ehpt sweep CAMPAIGN --plan', psecu2_nedc runs)\n";
  if (b.plan_status == "ok") {
    s += "  " + std::to_string(b.plan_runs) + " runs planned in " + fmt("%.2f", b.plan_wall_s) + " s on " +
         fmt("%.0f", b.plan_cpus) + " CPUs, peak memory " + fmt("%.1f", b.plan_rss_MB) +
         " MB (target for 100000 runs: <= 10 s, <= 100 MB)\n";
  } else {
    s += "  " + b.plan_status + "\n";
  }
  std::snprintf(buf, sizeof buf, "\nbench %s in %.1f s; outputs in %s (bench.json, bench.txt, logs/)\n", b.status.c_str(),
                seconds_since(b.t0), b.opt.out.c_str());
  s += buf;
  return s;
}

ehpt::io::JsonObject run_json(const SubRun& r) {
  ehpt::io::JsonObject j;
  j.text("run", r.label);
  j.text("status", r.status);
  if (r.ok()) {
    j.text("trajectory_hash", r.hash);
    if (r.allocations) {
      j.integer("heap_allocations_after_startup", *r.allocations);
    } else {
      j.null("heap_allocations_after_startup");
    }
    j.number("peak_rss_MB", r.peak_rss_MB);
    if (std::isfinite(r.samples_per_s)) {
      j.number("samples_per_s", r.samples_per_s);
      j.number("round_trip_p50_us", r.round_trip_p50_us);
      j.number("round_trip_p99_us", r.round_trip_p99_us);
    }
    if (std::isfinite(r.spread_p99_us)) {
      j.number("command_frames_spread_p50_us", r.spread_p50_us);
      j.number("command_frames_spread_p99_us", r.spread_p99_us);
      j.number("command_frames_spread_max_us", r.spread_max_us);
    }
    if (std::isfinite(r.stale_samples)) j.number("stale_samples", r.stale_samples);
    if (std::isfinite(r.timeouts)) j.number("timeouts", r.timeouts);
  }
  j.number("wall_time_s", r.wall_s);
  return j;
}

ehpt::io::JsonObject latency_json(const Latency& l) {
  ehpt::io::JsonObject j;
  j.text("status", l.status);
  if (l.status == "ok") {
    j.number("p50", l.p50);
    j.number("p99", l.p99);
    j.number("p99_9", l.p99_9);
    j.number("max", l.max);
    j.number("mean", l.mean);
    j.integer("samples", l.samples);
    if (!l.dma_latency.empty()) j.text("cpu_dma_latency", l.dma_latency);
  }
  return j;
}

std::string report_json(const Bench& b) {
  using ehpt::io::JsonObject;
  JsonObject j;
  j.text("format", kBenchFormat);
  j.text("status", b.status);
  j.text("mode", b.opt.quick ? "quick" : "full");
  std::string cmd = "ehpt bench";
  for (const auto& a : b.opt.args) cmd += " " + a;
  j.text("command", cmd);
  j.text("out_dir", b.dir);
  j.text("commit", b.commit);
  j.boolean("uncommitted_changes", b.dirty);
  j.text("date_utc", b.date);
  JsonObject m;
  m.integer("nproc", b.nproc);
  m.text("cpu_model", cpu_model());
  m.text("kernel", kernel());
  m.text("load_average_start", b.load_start);
  m.text("load_average_end", b.load_end);
  j.object("machine", m);
  j.number("wall_time_s", seconds_since(b.t0));

  JsonObject speed;
  speed.text("status", b.speed_status);
  speed.number("step_s", 0.001);
  speed.integer("repetitions", b.reps);
  // the latency floor of an RK4 step (the battery's four dependent stage chains), this run
  speed.number("floor_ns_per_step", b.floor_ns_per_step);
  JsonObject by_vehicle;
  std::map<std::string, JsonObject> vehicles;
  std::vector<std::string> order;
  for (const auto& r : b.speed) {
    if (vehicles.find(r.scenario) == vehicles.end()) order.push_back(r.scenario);
    JsonObject one;
    if (!r.error.empty()) {
      one.text("status", "failed: " + r.error);
    } else {
      one.text("status", "ok");
      one.number("duration_s", r.duration_s);
      one.integer("steps", r.steps);
      one.object("ns_per_step", spread_json(r.ns_per_step));
      one.object("wall_time_s", spread_json(r.wall_s));
      one.number("realtime_factor", r.realtime_factor);
      if (std::isfinite(r.target_ns)) one.number("target_ns_per_step", r.target_ns);
      if (r.solver == "rk4") one.number("floor_ratio", r.ns_per_step.median / b.floor_ns_per_step);
      if (std::isfinite(r.target_floor_ratio)) one.number("target_floor_ratio", r.target_floor_ratio);
    }
    vehicles[r.scenario].object(r.solver, one);
  }
  for (const auto& v : order) {
    JsonObject& o = vehicles[v];
    const SpeedRun *rk = nullptr, *ie = nullptr;
    for (const auto& r : b.speed) {
      if (r.scenario == v && r.error.empty()) (r.solver == "rk4" ? rk : ie) = &r;
    }
    o.number("implicit_euler_over_rk4", rk && ie ? ie->ns_per_step.median / rk->ns_per_step.median : NAN);
    o.number("target_implicit_euler_over_rk4", 2.5);
    by_vehicle.object(v, o);
  }
  speed.object("vehicles", by_vehicle);
  // (test - plain) / plain of a psecu2 rk4 step, in %
  speed.number("test_overhead_percent", 100.0 * test_overhead(b));
  speed.number("target_test_overhead_percent", 10.0);
  j.object("speed", speed);

  JsonObject lat;
  lat.text("status", b.latency_status);
  lat.number("period_s", 0.001);
  lat.integer("priority", b.opt.priority);
  lat.integer("cpu", b.cpu);
  lat.integer("seconds", b.seconds);
  lat.object("cyclictest_us", latency_json(b.cyclictest));
  lat.object("ehpt_us", latency_json(b.rt_loop));
  lat.number("p99_ratio", b.cyclictest.status == "ok" && b.rt_loop.status == "ok" ? b.rt_loop.p99 / b.cyclictest.p99 : NAN);
  lat.number("target_p99_ratio", 1.2);
  if (b.rt_loop.status == "ok") {
    lat.integer("ticks", b.ticks);
    lat.integer("overruns", b.overruns);
    lat.integer("missed_ticks", b.missed_ticks);
    lat.text("scheduler", b.rt_scheduler);
  }
  lat.integer("target_overruns_over_60_s", 0);
  for (const auto& r : b.runs) {
    if (r.name == "realtime") lat.number("peak_rss_MB", r.peak_rss_MB);
  }
  lat.number("target_peak_rss_MB", 16.0);
  lat.strings("setup_warnings", b.rt_warnings);
  j.object("latency", lat);

  JsonObject runs;
  for (const auto& r : b.runs) {
    JsonObject one = run_json(r);
    const double ratio = exchange_floor_ratio(b, r);
    if (std::isfinite(ratio)) {
      one.number("floor_ratio", ratio);
      if (r.name != "lockstep_pycan") one.number("target_floor_ratio", kTargetExchangeFloorRatio);
    }
    runs.object(r.name, one);
  }
  // the transports' floors the lockstep runs are compared with (floor_ratio)
  JsonObject floors;
  for (const auto& [key, p] : {std::pair<const char*, const PingPong*>{"tcp", &b.tcp_floor}, {"udp", &b.udp_floor}}) {
    JsonObject one;
    one.text("status", p->error.empty() ? "ok" : p->error);
    if (p->error.empty()) {
      one.number("round_trips_per_s", p->round_trips_per_s());
      one.integer("round_trips", p->round_trips);
      one.number("seconds", p->seconds);
    }
    floors.object(key, one);
  }
  j.object("exchange_floors", floors);
  JsonObject ecu;
  ecu.text("status", "not reported (ehpt ecu writes no summary)");
  runs.object("ecu", ecu);
  j.object("runs", runs);

  JsonObject det;
  det.text("scenario", kRtScenario);
  det.number("duration_s", b.seconds);
  det.number("wall_clock_session_s", b.wall_clock_s);
  JsonObject gs;
  for (const auto& g : groups()) {
    JsonObject one;
    one.text("meaning", g.meaning);
    one.strings("runs", g.members);
    int n = 0;
    const bool eq = group_equal(b, g, n);
    one.integer("compared", n);
    one.boolean("equal", eq);
    gs.object(g.name, one);
  }
  det.object("groups", gs);
  det.text("socketcan", "not run (needs the vcan guest: tools/vcan-vm.sh)");
  det.text("replay", b.replay_available ? "available" : "not available in this build");
  det.boolean("all_equal", all_equal(b));
  det.boolean("can_codec_differs_from_plain", groups_distinct(b));
  j.object("determinism", det);

  JsonObject cv;
  cv.text("status", b.cvode_status);
  cv.number("rtol", kCvodeRtol);
  cv.number("fine_step_s", kFineStep_s);  // the yardstick of both sides' errors: RK4 at this step
  cv.integer("repetitions", b.reps);
  cv.number("target_wall_ratio", 20.0);
  cv.number("target_relative_difference_pct", 0.1);
  JsonObject rowsj;
  for (const auto& r : b.cvode) {
    JsonObject one;
    if (!r.error.empty()) {
      one.text("status", "failed: " + r.error);
      rowsj.object(r.scenario, one);
      continue;
    }
    one.text("status", "ok");
    one.number("duration_s", r.duration_s);
    const auto opt = [](std::optional<double> v) { return v ? *v : NAN; };
    one.number("soc_end_rk4", opt(r.rk4.soc_end));
    one.number("soc_end_cvode", opt(r.cv.soc_end));
    one.number("dsoc", opt(r.rk4.soc_end) - opt(r.cv.soc_end));
    one.number("dsoc_pct", rel_pct(r.rk4.soc_end, r.cv.soc_end));
    if (r.cv.fuel_g) {
      one.number("fuel_g_rk4", opt(r.rk4.fuel_g));
      one.number("fuel_g_cvode", opt(r.cv.fuel_g));
      one.number("dfuel_pct", rel_pct(r.rk4.fuel_g, r.cv.fuel_g));
    } else {
      one.null("dfuel_pct");
    }
    one.number("distance_m_rk4", opt(r.rk4.distance_m));
    one.number("distance_m_cvode", opt(r.cv.distance_m));
    one.number("ddistance_pct", rel_pct(r.rk4.distance_m, r.cv.distance_m));
    const CvodeErrors e = cvode_errors(r);
    one.number("soc_end_fine", opt(r.fine.soc_end));
    one.number("distance_m_fine", opt(r.fine.distance_m));
    one.number("soc_error_rk4", e.soc_rk4);
    one.number("soc_error_cvode", e.soc_cvode);
    one.number("distance_error_rk4_m", e.distance_rk4_m);
    one.number("distance_error_cvode_m", e.distance_cvode_m);
    one.object("rk4_wall_s", spread_json(r.rk4_wall));
    one.object("cvode_wall_s", spread_json(r.cv_wall));
    one.number("wall_ratio", r.cv_wall.median / r.rk4_wall.median);
    one.integer("cvode_steps", r.ref.cvode_steps);
    one.integer("cvode_restarts", r.ref.restarts);
    one.integer("events_cvode", r.ref.events);
    rowsj.object(r.scenario, one);
  }
  cv.object("scenarios", rowsj);
  j.object("cvode", cv);

  JsonObject plan;
  plan.text("status", b.plan_status);
  plan.integer("runs", b.plan_runs);
  plan.number("wall_s", b.plan_wall_s);
  plan.number("cpus", b.plan_cpus);
  plan.number("peak_rss_MB", b.plan_rss_MB);
  plan.integer("target_runs", 100000);
  plan.number("target_wall_s", 10.0);
  plan.number("target_peak_rss_MB", 100.0);
  j.object("sweep_plan", plan);
  return j.str() + "\n";
}

bool write_reports(Bench& b, bool with_text, std::string& text) {
  std::string error;
  if (!ehpt::io::write_file_atomically(b.dir + "/bench.json", report_json(b), error)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return false;
  }
  if (with_text) {
    text = report_text(b);
    if (!ehpt::io::write_file_atomically(b.dir + "/bench.txt", text, error)) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return false;
    }
  }
  return true;
}

}  // namespace ehpt::bench
