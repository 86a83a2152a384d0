// SPDX-License-Identifier: BSD-3-Clause
// Planning a sweep (sweep_plan.hpp).
#include "hil/campaign/sweep_plan.hpp"

#include <time.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <ostream>
#include <set>
#include <sstream>
#include <string_view>
#include <thread>
#include <unordered_map>

#include "hil/campaign/sweep_pool.hpp"

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

namespace {

// Run index of the campaign: its id, and what makes the campaign invalid (none: it is valid,
// or only this variant's value is refused, and it fails alone). cache: the worker's own.
PlannedRun plan_one(const Campaign& c, std::uint64_t index, LoadCache& cache, std::vector<std::string>* problems) {
  const std::size_t not_variant = c.fixed.size() + c.grid.size();
  hil::CampaignRun r = hil::campaign_run(c, index);
  std::vector<std::string> sets;
  sets.reserve(r.overrides.size());
  for (const CampaignOverride& o : r.overrides) sets.push_back(o.set_text());
  hil::Scenario sc;
  std::vector<std::string> load_errors;
  if (!hil::load_scenario(c.scenarios[r.scenario].path, sets, sc, load_errors, cache) && problems != nullptr) {
    // the variant's fault if the run loads without the variant's values (a cross-field check
    // such as ecu.period_s against solver.step_s names neither): it then fails alone
    bool variant_refused = false;
    if (r.overrides.size() > not_variant) {
      const std::vector<std::string> without(sets.begin(), sets.begin() + static_cast<std::ptrdiff_t>(not_variant));
      hil::Scenario probe;
      std::vector<std::string> probe_errors;
      variant_refused = hil::load_scenario(c.scenarios[r.scenario].path, without, probe, probe_errors, cache);
    }
    if (!variant_refused) {
      std::string with;  // the values of this run, for a message that names none of them
      for (std::size_t k = c.fixed.size(); k < not_variant; ++k) {
        with += (with.empty() ? "" : ", ") + r.overrides[k].set_text() + " (" + r.overrides[k].where + ")";
      }
      for (const std::string& e : load_errors) {
        std::string m = c.scenarios[r.scenario].name + ": " + blame(e, r.overrides);
        if (m == c.scenarios[r.scenario].name + ": " + e && !with.empty()) m += " [in the run with " + with + "]";
        problems->push_back(std::move(m));
      }
    }
  }
  return PlannedRun{index, r.scenario, hil::run_id(sc.inputs, r.overrides)};
}

}  // namespace

// Loads the campaign and every run's scenario (its files give the run's id), on every CPU
// this process may use: each worker plans a contiguous block of runs with its own cache of
// the files (each read and parsed once per worker), so that 10^5 runs plan in seconds. A
// problem that comes from the campaign's [set], [grid] or [output], or from a scenario itself,
// is a problem of the campaign: reported (in run order, each once), nothing runs (2). A
// variant whose value the scenario refuses is a run that will fail alone (its ehpt run says
// why, exit 2).
int plan_sweep(const std::string& path, SweepPlan& plan, bool progress, std::ostream& err) {
  std::vector<std::string> errors;
  if (!hil::load_campaign(path, plan.campaign, errors)) {
    for (const std::string& e : errors) err << e << "\n";
    err << "the campaign is not valid; nothing was run\n";
    return 2;
  }
  const Campaign& c = plan.campaign;
  const std::uint64_t n = hil::campaign_run_count(c);  // at most kMaxCampaignRuns: a size_t
  plan.runs.assign(static_cast<std::size_t>(n), PlannedRun{});
  const std::size_t workers = static_cast<std::size_t>(std::clamp<std::uint64_t>(n / 64, 1, static_cast<std::uint64_t>(usable_cpus())));
  const std::uint64_t per = (n + workers - 1) / workers;
  // each worker's problems in run order, each once (a value refused in every run is one line)
  std::vector<std::vector<std::string>> found(workers);
  std::atomic<std::uint64_t> done{0};
  std::atomic<std::size_t> working{workers};
  const auto work = [&](std::size_t w) {
    std::set<std::string> seen;
    std::vector<std::string> mine;
    const std::uint64_t begin = std::min<std::uint64_t>(n, w * per), end = std::min<std::uint64_t>(n, begin + per);
    try {
      LoadCache cache;
      for (std::uint64_t i = begin; i < end; ++i) {
        mine.clear();
        plan.runs[static_cast<std::size_t>(i)] = plan_one(c, i, cache, &mine);
        for (std::string& m : mine) {
          if (seen.insert(m).second) found[w].push_back(std::move(m));
        }
        done.fetch_add(1, std::memory_order_relaxed);
      }
    } catch (const std::exception& e) {  // out of memory, say: a problem, never a crash
      found[w].push_back(std::string("planning runs ") + std::to_string(begin) + ".." + std::to_string(end - 1) +
                         ": " + e.what());
    }
    working.fetch_sub(1);
  };
  {
    // the workers plan; this thread shows the progress until they are done
    std::vector<std::thread> threads;
    for (std::size_t w = 0; w < workers; ++w) {
      try {
        threads.emplace_back(work, w);
      } catch (const std::exception&) {  // no thread to be had: this block here, in this thread
        work(w);
      }
    }
    const double t0 = now_s();
    double last_shown = t0;
    bool shown = false;
    while (working.load() > 0) {
      // a line after the first half second, then four a second
      if (progress && now_s() - t0 > 0.5 && now_s() - last_shown > 0.25) {
        err << "\rplanning: " << done.load() << "/" << n << " runs loaded" << std::flush;
        shown = true;
        last_shown = now_s();
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    for (std::thread& t : threads) t.join();
    if (shown) err << "\r\033[K" << std::flush;
  }
  std::vector<std::string> problems;
  std::set<std::string> problem_set;
  for (std::vector<std::string>& list : found) {
    for (std::string& m : list) {
      if (problem_set.insert(m).second) problems.push_back(std::move(m));
    }
  }
  // two runs with one id: the first one's index for each id, in a map of 16-byte keys
  std::unordered_map<std::string_view, std::uint64_t> ids;
  ids.reserve(static_cast<std::size_t>(n));
  for (const PlannedRun& p : plan.runs) {
    if (const auto [it, fresh] = ids.emplace(p.id, p.index); !fresh) {
      const std::string m = "runs " + std::to_string(it->second) + " and " + std::to_string(p.index) +
                            " are the same run (the same files and values; two scenarios with identical files?)";
      if (problem_set.insert(m).second) problems.push_back(m);
    }
  }
  if (!problems.empty()) {
    constexpr std::size_t kShown = 40;
    for (std::size_t i = 0; i < std::min(kShown, problems.size()); ++i) err << problems[i] << "\n";
    if (problems.size() > kShown) err << "... and " << problems.size() - kShown << " more problems\n";
    err << "the campaign is not valid; nothing was run\n";
    return 2;
  }
  return 0;
}

PlannedRun plan_run(const Campaign& campaign, std::uint64_t index, LoadCache& cache) {
  return plan_one(campaign, index, cache, nullptr);
}

std::vector<CampaignOverride> overrides_of(const Campaign& campaign, const PlannedRun& run) {
  return campaign_run(campaign, run.index).overrides;
}

}  // namespace ehpt::hil
