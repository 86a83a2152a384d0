// SPDX-License-Identifier: BSD-3-Clause
// Planning a sweep (sweep_plan.hpp).
#include "hil/campaign/sweep_plan.hpp"

#include <time.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <ostream>
#include <set>
#include <sstream>

namespace ehpt::hil {

bool whole_number(const std::string& text, std::int64_t lo, std::int64_t hi, std::int64_t& out) {
  if (text.empty() || text.size() > 18 || text.find_first_not_of("0123456789") != std::string::npos) return false;
  out = std::stoll(text);
  return out >= lo && out <= hi;
}

bool is_run_id(const std::string& s) {
  return s.size() == 64 && s.find_first_not_of("0123456789abcdef") == std::string::npos;
}

double now_s() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

std::string duration_text(double s) {
  const long long t = std::llround(std::max(0.0, s));
  std::ostringstream o;
  if (t >= 3600) o << t / 3600 << " h ";
  if (t >= 60) o << (t / 60) % 60 << " min ";
  o << t % 60 << " s";
  return o.str();
}

std::string blame(std::string message, const std::vector<CampaignOverride>& overrides) {
  for (const CampaignOverride& o : overrides) {
    const std::string label = "--set " + o.set_text();
    for (std::size_t at = message.find(label); at != std::string::npos; at = message.find(label, at + 1)) {
      // only the whole label ("--set a=1" is not "--set a=10")
      const std::size_t end = at + label.size();
      if (end < message.size() && message[end] != ':' && message[end] != ' ') continue;
      const std::string where = o.where + " (" + o.set_text() + ")";
      message.replace(at, label.size(), where);
      at += where.size() - 1;
    }
  }
  return message;
}

// Loads the campaign and every run's scenario (its files give the run's id). A problem that
// comes from the campaign's [set], [grid] or [output], or from a scenario itself, is a problem
// of the campaign: reported, nothing runs (2). A variant whose value the scenario refuses is
// a run that will fail alone (its ehpt run says why, exit 2).
int plan_sweep(const std::string& path, SweepPlan& plan, bool progress, std::ostream& err) {
  std::vector<std::string> errors;
  if (!hil::load_campaign(path, plan.campaign, errors)) {
    for (const std::string& e : errors) err << e << "\n";
    err << "the campaign is not valid; nothing was run\n";
    return 2;
  }
  const Campaign& c = plan.campaign;
  const std::uint64_t n = hil::campaign_run_count(c);
  const std::size_t not_variant = c.fixed.size() + c.grid.size();
  std::vector<std::string> problems;
  std::set<std::string> problem_set;
  std::map<std::string, std::uint64_t> ids;
  plan.runs.reserve(static_cast<std::size_t>(n));
  const double t0 = now_s();
  double shown = t0;
  for (std::uint64_t i = 0; i < n; ++i) {
    hil::CampaignRun r = hil::campaign_run(c, i);
    std::vector<std::string> sets;
    for (const CampaignOverride& o : r.overrides) sets.push_back(o.set_text());
    hil::Scenario sc;
    std::vector<std::string> load_errors;
    if (!hil::load_scenario(c.scenarios[r.scenario].path, sets, sc, load_errors)) {
      // the variant's fault if the run loads without the variant's values (a cross-field check
      // such as ecu.period_s against solver.step_s names neither): it then fails alone
      bool variant_refused = false;
      if (r.overrides.size() > not_variant) {
        const std::vector<std::string> without(sets.begin(), sets.begin() + static_cast<std::ptrdiff_t>(not_variant));
        hil::Scenario probe;
        std::vector<std::string> probe_errors;
        variant_refused = hil::load_scenario(c.scenarios[r.scenario].path, without, probe, probe_errors);
      }
      if (!variant_refused) {
        std::string with;  // the values of this run, for a message that names none of them
        for (std::size_t k = c.fixed.size(); k < not_variant; ++k) {
          with += (with.empty() ? "" : ", ") + r.overrides[k].set_text() + " (" + r.overrides[k].where + ")";
        }
        for (const std::string& e : load_errors) {
          std::string m = c.scenarios[r.scenario].name + ": " + blame(e, r.overrides);
          if (m == c.scenarios[r.scenario].name + ": " + e && !with.empty()) m += " [in the run with " + with + "]";
          if (problem_set.insert(m).second) problems.push_back(m);
        }
      }
    }
    PlannedRun p{i, r.scenario, std::move(r.overrides), ""};
    p.id = hil::run_id(sc.inputs, p.overrides);
    if (const auto [it, fresh] = ids.emplace(p.id, i); !fresh) {
      const std::string m = "runs " + std::to_string(it->second) + " and " + std::to_string(i) +
                            " are the same run (the same files and values; two scenarios with identical files?)";
      if (problem_set.insert(m).second) problems.push_back(m);
    }
    plan.runs.push_back(std::move(p));
    if (progress && now_s() - shown > 0.5) {
      shown = now_s();
      err << "\rplanning: " << i + 1 << "/" << n << " runs loaded" << std::flush;
    }
  }
  if (progress && shown != t0) err << "\r\033[K";
  if (!problems.empty()) {
    constexpr std::size_t kShown = 40;
    for (std::size_t i = 0; i < std::min(kShown, problems.size()); ++i) err << problems[i] << "\n";
    if (problems.size() > kShown) err << "... and " << problems.size() - kShown << " more problems\n";
    err << "the campaign is not valid; nothing was run\n";
    return 2;
  }
  return 0;
}

PlannedRun plan_run(const Campaign& campaign, std::uint64_t index) {
  CampaignRun r = campaign_run(campaign, index);
  std::vector<std::string> sets;
  for (const CampaignOverride& o : r.overrides) sets.push_back(o.set_text());
  Scenario sc;
  std::vector<std::string> load_errors;
  (void)load_scenario(campaign.scenarios[r.scenario].path, sets, sc, load_errors);
  PlannedRun p{index, r.scenario, std::move(r.overrides), ""};
  p.id = run_id(sc.inputs, p.overrides);
  return p;
}

}  // namespace ehpt::hil
