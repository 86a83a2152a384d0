// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// A SIL campaign (campaigns/*.toml): base scenarios x a grid of overrides x a list of
// variants, expanded into runs with content-addressed ids. Start-up only; `ehpt sweep`
// (hil/campaign/sweep_*.hpp, from targets/cmd_sweep.cpp) runs them.
//
//   description = "MBecu2 calibration"
//   scenarios = ["psecu2_nedc", "../my/scenario.toml"]   # names as for 'ehpt run', or paths
//                                                       # relative to this file
//   variants = "variants.csv"      # optional: a header row of keys, one variant per row
//   [set]                          # optional: overrides of every run
//   "solver.duration_s" = 100
//   [grid]                         # optional: every combination of these values
//   "vehicle.ecu.soc_ref" = [0.55, 0.60, 0.65]
//   [output]                       # what each run keeps (default: summary.json only)
//   timeseries = true              # also timeseries.csv,
//   interval_s = 1.0               # a row every interval_s (default: the scenario's)
//
// Every key that 'ehpt run --set' takes can be swept. Problems in the campaign file (an
// unknown key, an empty grid, a value of the wrong type, a scenario that cannot be found) are
// reported as "file:line: ..." before anything runs.

#include <cstdint>
#include <string>
#include <vector>

#include "hil/config/config.hpp"

namespace ehpt::hil {

// "key=value" as --set takes it, and where the campaign wrote it ("file:line").
struct CampaignOverride {
  std::string key;
  std::string value;  // TOML text: 0.55, true, "implicit-euler"
  std::string where;
  std::string set_text() const { return key + "=" + value; }
};

struct CampaignScenario {
  std::string path;  // as resolved (absolute)
  std::string name;  // file name without .toml
  std::string where;
};

struct CampaignGridKey {
  std::string key;
  std::vector<CampaignOverride> values;
};

struct Campaign {
  std::string path;  // absolute
  std::string name;  // file name without .toml
  std::string description;
  std::vector<CampaignScenario> scenarios;
  std::vector<CampaignOverride> fixed;   // [set] and [output]: every run
  std::vector<CampaignGridKey> grid;     // in file order
  std::string variants_path;             // "" if none
  std::vector<std::string> variant_keys; // the CSV header
  // one per CSV row: the overrides of its non-empty cells (an empty cell keeps the scenario's)
  std::vector<std::vector<CampaignOverride>> variants;
  bool timeseries = false;

  // the keys that vary between runs (grid, then variants), in that order: results.csv's columns
  std::vector<std::string> swept_keys() const;
};

// More runs than this is a typo (a grid of 10 keys x 10 values), refused at load.
inline constexpr std::uint64_t kMaxCampaignRuns = 10'000'000;

// Loads and validates the campaign. On failure returns false with every problem in errors.
bool load_campaign(const std::string& path, Campaign& out, std::vector<std::string>& errors);

// The number of runs: scenarios x grid combinations x variants (at least one each).
std::uint64_t campaign_run_count(const Campaign& c);

// Run i (0 <= i < campaign_run_count) in a stable order: scenario outermost, then the grid
// (its first key outermost), then the variants. overrides: [set] and [output], then the grid's,
// then the variant's, in --set order.
struct CampaignRun {
  std::uint64_t index = 0;
  std::size_t scenario = 0;
  std::vector<CampaignOverride> overrides;
};
CampaignRun campaign_run(const Campaign& c, std::uint64_t index);

// A run's content address: SHA-256 over the bytes of every file its scenario reads (in the
// order read) and its overrides, so that the same inputs give the same id on any machine
// and in any folder, and one changed byte in a cycle or map gives another id. Pure; the same
// id as hil::run_id of the --set texts, which every summary.json records (provenance.run_id).
std::string run_id(const std::vector<InputFile>& inputs, const std::vector<CampaignOverride>& overrides);

}  // namespace ehpt::hil
