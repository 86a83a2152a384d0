// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// A sweep's plan: a campaign (campaign.hpp) loaded with every run's scenario, each run with its
// content-addressed id. Start-up only (hil/campaign/sweep_*.hpp run, record and merge it;
// `ehpt sweep`, targets/cmd_sweep.cpp, drives them).

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "hil/campaign/campaign.hpp"

namespace ehpt::hil {

// A run of the plan: its overrides are campaign_run(campaign, index)'s (overrides_of), not
// kept, so that a plan of 10^5 runs is a few MB.
struct PlannedRun {
  std::uint64_t index = 0;  // campaign_run's index
  std::size_t scenario = 0;
  std::string id;  // run_id: 64 hex digits
};

struct SweepPlan {
  Campaign campaign;
  std::vector<PlannedRun> runs;  // in campaign_run order
};

// Loads the campaign at path and every run's scenario (its files give the run's id). A problem
// of the campaign's [set], [grid] or [output], or of a scenario itself, is a problem of the
// campaign: every one is written to err ("file:line: ...", the campaign's locations in place of
// --set labels; at most 40 of the runs' problems), then "the campaign is not valid; nothing was
// run", and 2 is returned. A variant whose value the scenario refuses is a run that will fail
// alone (not a problem here). Two runs with the same id are a problem. progress: a "planning:
// i/n" line on err while it takes long. 0 when the plan is complete. Runs on every CPU this
// process may use (a worker per block of runs).
int plan_sweep(const std::string& path, SweepPlan& plan, bool progress, std::ostream& err);

// The run at index of the campaign as planned by plan_sweep (its scenario loaded for its id;
// a scenario that does not load gives the id of the files it read so far). cache: shared by
// the calls of one pass (an array task's queue).
PlannedRun plan_run(const Campaign& campaign, std::uint64_t index, LoadCache& cache);

// The run's overrides, in --set order ([set] and [output], the grid's, the variant's).
std::vector<CampaignOverride> overrides_of(const Campaign& campaign, const PlannedRun& run);

// A loader message names an override as "--set key=value": says where the campaign wrote it
// ("file:line (key=value)"), whole labels only ("--set a=1" is not "--set a=10").
std::string blame(std::string message, const std::vector<CampaignOverride>& overrides);

// A whole decimal number in [lo, hi] (at most 18 digits: no overflow), nothing else.
bool whole_number(const std::string& text, std::int64_t lo, std::int64_t hi, std::int64_t& out);

// 64 lower-case hex digits: a run id (it names files under the sweep folder).
bool is_run_id(const std::string& s);

// CLOCK_MONOTONIC in seconds, and a duration as "1 h 2 min 3 s".
double now_s();
std::string duration_text(double s);

}  // namespace ehpt::hil
