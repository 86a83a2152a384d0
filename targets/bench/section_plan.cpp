// SPDX-License-Identifier: BSD-3-Clause
// `ehpt bench` section (g): planning a sweep of 10^5 runs (--quick: 10^4), as `ehpt sweep
// CAMPAIGN --plan` reports it: wall time and peak memory (the target: <= 10 s and
// <= 100 MB for 10^5 runs).
#include "targets/bench/sections.hpp"
#include "targets/bench/supervisor.hpp"

#include <cstdlib>

namespace ehpt::bench {

namespace {

// A grid of 10 x 10 x 10 x (runs / 1000) psecu2_nedc runs: MBecu2's calibration keys and the
// duration, so that every run has its own id and its scenario is loaded and validated.
std::string campaign_text(int runs) {
  const auto values = [](double lo, double hi, int n) {
    std::string s = "[";
    for (int i = 0; i < n; ++i) s += (i ? ", " : "") + ehpt::io::number_text(lo + (hi - lo) * i / std::max(1, n - 1));
    return s + "]";
  };
  return "description = \"ehpt bench: planning " + std::to_string(runs) + " runs\"\n"
         "scenarios = [\"psecu2_nedc\"]\n[grid]\n"
         "\"vehicle.ecu.soc_ref\" = " + values(0.55, 0.65, 10) + "\n"
         "\"vehicle.ecu.on_threshold_W\" = " + values(8000, 12000, 10) + "\n"
         "\"vehicle.ecu.off_threshold_W\" = " + values(2000, 5000, 10) + "\n"
         "\"solver.duration_s\" = " + values(100, 1000, runs / 1000) + "\n";
}

// The number after `label` in line (NaN if there is none).
double number_after(const std::string& line, const std::string& label) {
  const std::size_t at = line.find(label);
  if (at == std::string::npos) return NAN;
  const char* begin = line.c_str() + at + label.size();
  char* end = nullptr;
  const double v = std::strtod(begin, &end);
  return end == begin ? NAN : v;
}

}  // namespace

void section_plan(Bench& b) {
  const int runs = b.opt.quick ? 10'000 : 100'000;
  b.progress("(g) sweep planning: " + std::to_string(runs) + " psecu2_nedc runs, ehpt sweep --plan");
  const std::string file = b.dir + "/plan_campaign.toml";
  std::string why;
  if (!ehpt::io::write_file_atomically(file, campaign_text(runs), why)) {
    b.plan_status = "failed: cannot write " + file + ": " + why;
    b.any_failed = true;
    return;
  }
  const Outcome o = run_child({b.exe, "sweep", file, "--plan", "--quiet"}, b.logs, "plan", 300.0);
  if (o.stopped) {
    b.plan_status = "stopped";
    return;
  }
  const std::string line = last_line(b.logs + "/plan.out");
  b.plan_runs = runs;
  b.plan_wall_s = number_after(line, "planned in ");
  b.plan_cpus = number_after(line, " s on ");
  b.plan_rss_MB = number_after(line, "peak memory ");
  if (!o.ok() || line.find(std::to_string(runs) + " runs, every one valid") == std::string::npos ||
      !std::isfinite(b.plan_wall_s) || !std::isfinite(b.plan_rss_MB)) {
    const std::string err = last_line(b.logs + "/plan.err");
    b.plan_status = "failed: ehpt sweep --plan: " + (o.why.empty() ? "exit " + std::to_string(o.code) : o.why) +
                    (err.empty() ? "" : ": " + err);
    b.any_failed = true;
    return;
  }
  b.plan_status = "ok";
}

}  // namespace ehpt::bench
