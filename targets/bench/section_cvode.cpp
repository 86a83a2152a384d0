// SPDX-License-Identifier: BSD-3-Clause
// `ehpt bench` section (f): RK4 against the CVODE reference.
#include "targets/bench/sections.hpp"
#include "targets/bench/supervisor.hpp"

namespace ehpt::bench {

namespace {

CvodeRow measure_cvode(const std::string& scenario, double duration_s, int reps) {
  CvodeRow r;
  r.scenario = scenario;
  std::vector<std::string> sets = {"solver.method=rk4", "solver.step_s=0.001"};
  if (duration_s > 0.0) sets.push_back("solver.duration_s=" + ehpt::io::number_text(duration_s));
  ehpt::hil::Scenario sc;
  r.error = load(scenario, sets, sc);
  if (!r.error.empty()) return r;
  r.duration_s = static_cast<double>(sc.solver.steps) * sc.solver.step_s;
  std::vector<double> rk, cv;
  for (int k = 0; k < reps && r.error.empty(); ++k) {
    double wall = 0.0;
    if (timed_run(sc, wall, &r.rk4, r.error)) rk.push_back(wall);
  }
  ehpt::hil::ReferenceOptions ro;
  ro.rtol = kCvodeRtol;  // as accurate as RK4 at 1 ms (or more): a comparison at equal accuracy
  for (int k = 0; k < reps && r.error.empty() && !stopping(); ++k) {
    std::string why;
    if (!ehpt::hil::run_cvode_reference(sc, ro, r.ref, why)) {
      r.error = "CVODE: " + why;
    } else {
      cv.push_back(r.ref.wall_s);
      r.cv = r.ref.figures;
    }
  }
  // the yardstick of both: RK4 at a tenth of a millisecond (once; its time is not compared)
  if (r.error.empty() && !stopping()) {
    std::vector<std::string> fine_sets = sets;
    fine_sets[1] = "solver.step_s=" + ehpt::io::number_text(kFineStep_s);
    ehpt::hil::Scenario fine;
    r.error = load(scenario, fine_sets, fine);
    double wall = 0.0;
    if (r.error.empty() && !timed_run(fine, wall, &r.fine, r.error)) r.error = "RK4 at " + fine_sets[1] + ": " + r.error;
  }
  if (stopping() && r.error.empty()) r.error = "stopped";
  r.rk4_wall = spread(rk);
  r.cv_wall = spread(cv);
  return r;
}
}  // namespace

// (f)
void section_cvode(Bench& b) {
  const double d = b.cvode_s;
  b.progress("(f) CVODE (rtol 1e-12) vs RK4 at equal accuracy: ev_nedc, psecu2_nedc" +
             (d > 0 ? " (first " + fmt("%.0f", d) + " s)" : std::string()) + ", " + std::to_string(b.reps) +
             " run(s) each (about " + fmt("%.0f", b.reps * (d > 0 ? d / 1184.0 : 1.0) * 40.0 + 0.5) + " s)");
  for (const char* s : {"ev_nedc", "psecu2_nedc"}) {
    if (stopping()) return;
    CvodeRow r = measure_cvode(s, d, b.reps);
    if (r.error == "stopped") return;
    if (!r.error.empty()) b.any_failed = true;
    b.cvode.push_back(r);
  }
  b.cvode_status = "ok";
}

}  // namespace ehpt::bench
