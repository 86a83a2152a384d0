// SPDX-License-Identifier: BSD-3-Clause
// `ehpt bench` sections (a) and (b): speed in this process.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "targets/bench/sections.hpp"

#include "plant/battery_rc.hpp"
#include "targets/bench/supervisor.hpp"

namespace ehpt::bench {

namespace {

// psecu2 on NEDC as an ECU test: one sensor fault, four expectations at every step (the
// shipped soc_sensor_stuck test's shape, over the whole cycle).
constexpr const char* kPsecu2Test = R"(description = "ehpt bench: what a test costs"
scenario = "psecu2_nedc"
[[fault]]
kind = "stuck"
target = "batSOC"
at_s = 100
[[expect]]
signal = "soc"
min = 0.3
max = 0.9
[[expect]]
signal = "speed_m_s"
other = "speed_ref_m_s"
tol = 3.0
from_s = 5
[[expect]]
signal = "iceW_rad_s"
max = 600
[[expect]]
signal = "soc"
min = 0.3
window = "at_end"
)";

}  // namespace

namespace {

SpeedRun measure_speed(const std::string& scenario, const std::string& solver, double duration_s, int reps) {
  SpeedRun r;
  r.scenario = scenario;
  r.solver = solver;
  std::vector<std::string> sets = {"solver.method=" + solver, "solver.step_s=0.001"};
  if (duration_s > 0.0) sets.push_back("solver.duration_s=" + ehpt::io::number_text(duration_s));
  ehpt::hil::Scenario sc;
  r.error = load(scenario, sets, sc);
  if (!r.error.empty()) return r;
  r.steps = sc.solver.steps;
  r.duration_s = static_cast<double>(sc.solver.steps) * sc.solver.step_s;
  std::vector<double> ns, walls;
  for (int k = 0; k < reps; ++k) {
    double wall = 0.0;
    if (!timed_run(sc, wall, nullptr, r.error)) return r;
    walls.push_back(wall);
    ns.push_back(1e9 * wall / static_cast<double>(r.steps));
  }
  r.ns_per_step = spread(ns);
  r.wall_s = spread(walls);
  r.realtime_factor = r.duration_s / r.wall_s.median;
  return r;
}
}  // namespace

// One whole run through the facade; wall time of the stepping alone (start-up excluded).
// False (why) on a fault or a stop.
bool timed_run(const ehpt::hil::Scenario& sc, double& wall_s, ehpt::hil::RunFigures* figures, std::string& why) {
  ehpt::hil::SimulationOptions so;
  const std::unique_ptr<ehpt::hil::Simulation> sim = ehpt::hil::make_simulation(sc, so);
  const auto t0 = Clock::now();
  while (!sim->finished() && !stopping()) {
    sim->run(&g_stop);
    sim->clear_rows();
  }
  wall_s = seconds_since(t0);
  if (stopping()) {
    why = "stopped";
    return false;
  }
  if (sim->stats().fault != 0) {
    why = "fault at t = " + ehpt::io::number_text(sim->stats().fault_time_s) + " s";
    return false;
  }
  if (figures != nullptr) *figures = sim->figures();
  return true;
}

// The latency floor of an RK4 step. Each of its four stages solves the battery's node on the
// result of the stage before: the stage's state (x + c h k), the terminal voltage (a square
// root), the current P / V, the EMF's and v_rc's derivatives from it, and the next stage's
// state from those. So no step can take less than four of these dependent chains, whatever
// else it does in parallel. This loop is that chain alone, through the plant's own
// BatteryRc::terminal (inlined, as in the step), with RK4's stage weights, measured in the
// same process and run as the steps it is compared with (best of reps, 5 million steps each).
// A bare sqrt -> divide chain (what this loop was before issue 26's item 1) leaves out the
// stage update and the derivatives, about a third of the chain.
double floor_ns_per_step(int reps) {
  constexpr std::int64_t kSteps = 5'000'000;
  constexpr double h = 1e-3;  // s, the step of (a)
  ehpt::plant::BatteryRcParams params;  // a pack of the EV's size
  params.cells_series = 96;
  params.strings_parallel = 4;
  const ehpt::plant::BatteryRc battery(params);
  double best = INFINITY;
  double sink = 0.0;
  for (int k = 0; k < std::max(1, reps); ++k) {
    double emf = battery.constants().emf_initial_V, v_rc = 0.0;
    const auto t0 = Clock::now();
    for (std::int64_t n = 0; n < kSteps; ++n) {
      // +-30 kW, a second each way: the pack stays near its start (the sign is no part of the chain)
      const double load_W = (n / 1000) % 2 == 0 ? 3.0e4 : -3.0e4;
      double k_emf = 0.0, k_vrc = 0.0, sum_emf = 0.0, sum_vrc = 0.0;
      for (int stage = 0; stage < 4; ++stage) {
        const double c = stage == 0 ? 0.0 : stage == 3 ? h : 0.5 * h;
        const double emf_s = emf + c * k_emf, v_rc_s = v_rc + c * k_vrc;
        const ehpt::plant::BatteryTerminal t = battery.terminal(emf_s, v_rc_s, load_W);
        k_emf = battery.demf_dt(t);
        k_vrc = battery.dvrc_dt(t, v_rc_s);
        const double w = stage == 0 || stage == 3 ? 1.0 : 2.0;
        sum_emf += w * k_emf;
        sum_vrc += w * k_vrc;
      }
      emf += h / 6.0 * sum_emf;
      v_rc += h / 6.0 * sum_vrc;
    }
    best = std::min(best, 1e9 * seconds_since(t0) / static_cast<double>(kSteps));
    sink += emf;
  }
  // the chain's result is used: the loop cannot be dropped
  if (!(sink > 0.0)) std::fprintf(stderr, "ehpt bench: the floor loop gave %g\n", sink);
  return best;
}

// (a), (b)
void section_speed(Bench& b) {
  const std::vector<std::string> vehicles = {"ev_nedc", "evpm_nedc", "evam_nedc", "psecu2_nedc"};
  b.progress("(a, b) speed: 4 vehicles x 2 solvers at 1 ms, " + std::to_string(b.reps) +
             " whole cycle(s) each (about " + std::to_string(b.reps * 6 + 1) + " s)");
  // warm-up, not measured: the first run of a process pays for cold caches and page faults
  {
    ehpt::hil::Scenario sc;
    double wall = 0.0;
    std::string why;
    if (load("ev_nedc", {"solver.duration_s=100"}, sc).empty()) timed_run(sc, wall, nullptr, why);
  }
  b.floor_ns_per_step = floor_ns_per_step(b.reps);
  for (const auto& v : vehicles) {
    for (const char* solver : {"rk4", "implicit-euler"}) {
      if (stopping()) return;
      SpeedRun r = measure_speed(v, solver, 0.0, b.reps);
      if (std::string(solver) == "rk4" && v == "psecu2_nedc") {
        r.target_ns = 150.0;
        r.target_floor_ratio = 1.3;
      }
      if (std::string(solver) == "rk4" && v == "ev_nedc") {
        r.target_ns = 100.0;
        r.target_floor_ratio = 1.2;
      }
      if (r.error == "stopped") return;
      if (!r.error.empty()) b.any_failed = true;
      b.speed.push_back(r);
    }
  }
  // what an ECU test costs: psecu2 with a fault and four expectations judged at every step,
  // next to the plain psecu2 above (this process, the same repetitions; docs/testing.md)
  if (stopping()) return;
  const std::string file = b.dir + "/psecu2_test.toml";
  std::string why;
  if (!ehpt::io::write_file_atomically(file, kPsecu2Test, why)) {
    SpeedRun failed;
    failed.scenario = kTestRow;
    failed.solver = "rk4";
    failed.error = "cannot write " + file + ": " + why;
    b.speed.push_back(failed);
    b.any_failed = true;
    return;
  }
  SpeedRun r = measure_speed(file, "rk4", 0.0, b.reps);
  r.scenario = kTestRow;
  if (!r.error.empty()) b.any_failed = true;
  b.speed.push_back(r);
  b.speed_status = "ok";
}

}  // namespace ehpt::bench
