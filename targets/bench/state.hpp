// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// What one `ehpt bench` measures, section by section (filled by targets/bench/section_*.cpp,
// reported by targets/bench/report.cpp).

#include "targets/bench/common.hpp"
#include "targets/bench/pingpong.hpp"

namespace ehpt::bench {

struct Options {
  bool quick = false, quiet = false;
  std::string out = "bench-out";
  int cpu = -1, priority = 80, rt_seconds = 0;
  std::vector<std::string> args;
};

struct SpeedRun {
  std::string scenario, solver, error;
  double duration_s = 0.0;
  std::int64_t steps = 0;
  Spread ns_per_step, wall_s;
  double realtime_factor = NAN;
  double target_ns = NAN;  // the target, where it gives one
  double target_floor_ratio = NAN;  // ns per step / the latency floor, where the issue gives a bound
};

// The speed row of psecu2 run as an ECU test (a fault, four expectations).
inline constexpr const char* kTestRow = "psecu2_nedc + test";

// RK4 at 1 ms and CVODE at kCvodeRtol, each against RK4 at kFineStep_s (its error is ~1e-4 of
// RK4's at 1 ms): the accuracy of each side, next to its time.
inline constexpr double kCvodeRtol = 1e-12;
inline constexpr double kFineStep_s = 1e-4;
struct CvodeRow {
  std::string scenario, error;
  double duration_s = 0.0;
  ehpt::hil::RunFigures rk4, cv, fine;
  Spread rk4_wall, cv_wall;
  ehpt::hil::ReferenceResult ref;
};

struct Latency {
  std::string status = "not run";  // "ok", or why not
  double p50 = NAN, p99 = NAN, p99_9 = NAN, max = NAN, mean = NAN;
  long long samples = 0, overflows = 0;
  std::string dma_latency;  // "0us" of cyclictest's "# /dev/cpu_dma_latency set to 0us", if it said so
};

struct SubRun {
  std::string name;       // folder under DIR
  std::string label;      // what it is, for the table
  std::string group;      // runs of one group must have the same trajectory hash
  std::string status = "not run";  // "ok", "not run: why", "failed: why", "not available in this build"
  std::string hash;
  std::optional<long long> allocations;
  bool allocations_reported = false;
  double peak_rss_MB = NAN;
  double wall_s = NAN;
  // lockstep bus runs: the exchange's rate and round trip (summary.json bus.*)
  double samples_per_s = NAN, round_trip_p50_us = NAN, round_trip_p99_us = NAN;
  // bus runs whose commands come per sample: how far apart a sample's command frames came
  // (bus.command_frames_spread_us), and the samples the ECU left without a fresh command
  double spread_p50_us = NAN, spread_p99_us = NAN, spread_max_us = NAN, stale_samples = NAN, timeouts = NAN;
  bool ok() const { return status == "ok"; }
  bool failed() const { return status.rfind("failed", 0) == 0; }
};

struct Bench {
  Options opt;
  std::string exe, dir, logs;
  std::time_t started_at = 0;
  Clock::time_point t0;
  int cpu = -1, seconds = 0, reps = 1, nproc = 0;
  double cvode_s = 0.0;   // (f): 0 the whole cycle, else its first cvode_s seconds
  double wall_clock_s = 0.0;  // the wall-clock socketcand session
  std::string commit = "unknown", load_start, load_end, date;
  bool dirty = false;
  std::string status = "complete";
  bool any_failed = false;

  std::string speed_status = "not run";
  double floor_ns_per_step = NAN;  // the latency floor of an RK4 step (section_speed.cpp), this run
  std::vector<SpeedRun> speed;
  std::string cvode_status = "not run";
  std::vector<CvodeRow> cvode;
  std::string latency_status = "not run";
  Latency cyclictest, rt_loop;
  std::string rt_scheduler;
  long long overruns = -1, missed_ticks = -1, ticks = -1;
  std::vector<std::string> rt_warnings;
  std::vector<SubRun> runs;
  PingPong tcp_floor, udp_floor;  // the transports' round trips alone (section_runs.cpp)
  bool replay_available = false;
  std::string plan_status = "not run";  // (g)
  int plan_runs = 0;
  double plan_wall_s = NAN, plan_rss_MB = NAN, plan_cpus = NAN;

  SubRun& run(const std::string& name) {
    for (auto& r : runs) {
      if (r.name == name) return r;
    }
    throw std::logic_error("no sub-run " + name);
  }

  void progress(const std::string& line) const {
    if (!opt.quiet) std::fprintf(stderr, "bench [%5.1f s] %s\n", seconds_since(t0), line.c_str());
  }
  std::vector<std::string> duration_set(double s) const { return {"--set", "solver.duration_s=" + ehpt::io::number_text(s)}; }
};

inline void fail(Bench& b, SubRun& r, const std::string& why) {
  r.status = "failed: " + why;
  b.any_failed = true;
}

}  // namespace ehpt::bench
