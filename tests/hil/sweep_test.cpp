// SPDX-License-Identifier: BSD-3-Clause
// The sweep's engine (hil/campaign/sweep_*.hpp) without running anything: the plan and its
// ids, the resume decision from the folder's statuses, merging, the folder's refusals.
#include <gtest/gtest.h>

#include "hil/diag/provenance.hpp"
#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "hil/campaign/sweep_folder.hpp"
#include "hil/campaign/sweep_merge.hpp"
#include "hil/campaign/sweep_plan.hpp"
#include "io/json_value.hpp"
#include "io/text_file.hpp"

namespace ehpt::hil {
namespace {

namespace fs = std::filesystem;

class SweepFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string tmpl = (fs::temp_directory_path() / "ehpt-sweep-XXXXXX").string();
    ASSERT_NE(::mkdtemp(tmpl.data()), nullptr);
    dir_ = tmpl;
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) {
    const std::string p = dir_ + "/" + name;
    fs::create_directories(fs::path(p).parent_path());
    std::ofstream(p) << text;
    return p;
  }
  std::string read(const std::string& name) {
    std::string text, reason;
    EXPECT_TRUE(io::read_text_file(dir_ + "/" + name, text, reason)) << reason;
    return text;
  }
  // five runs of ev_nedc, one per SOC
  std::string five_runs() {
    return write("c.toml", "scenarios = [\"ev_nedc\"]\n[set]\n\"solver.duration_s\" = 10\n"
                           "[grid]\n\"vehicle.battery.soc_initial\" = [0.5, 0.55, 0.6, 0.65, 0.7]\n");
  }
  std::string dir_;
};

TEST_F(SweepFiles, ThePlanHasOneStableIdPerRun) {
  SweepPlan plan;
  std::ostringstream err;
  ASSERT_EQ(plan_sweep(five_runs(), plan, false, err), 0) << err.str();
  ASSERT_EQ(plan.runs.size(), 5u);
  for (std::size_t i = 0; i < plan.runs.size(); ++i) {
    const PlannedRun& r = plan.runs[i];
    EXPECT_EQ(r.index, i);
    EXPECT_TRUE(is_run_id(r.id)) << r.id;
    EXPECT_EQ(overrides_of(plan.campaign, r).back().set_text(), "vehicle.battery.soc_initial=" + std::string(i == 0 ? "0.5" : i == 1 ? "0.55" : i == 2 ? "0.6" : i == 3 ? "0.65" : "0.7"));
    LoadCache cache;
    EXPECT_EQ(plan_run(plan.campaign, i, cache).id, r.id);  // what an array task checks its queue against
    for (std::size_t k = 0; k < i; ++k) EXPECT_NE(plan.runs[k].id, r.id);
  }
  SweepPlan again;
  ASSERT_EQ(plan_sweep(dir_ + "/c.toml", again, false, err), 0);
  EXPECT_EQ(again.runs[3].id, plan.runs[3].id);
  EXPECT_EQ(err.str(), "");
}

TEST_F(SweepFiles, AGridValueTheScenarioRefusesIsTheCampaignsProblem) {
  const std::string p = write("c.toml", "scenarios = [\"ev_nedc\"]\n[grid]\n\"vehicle.battery.soc_initial\" = [0.5, 1.5]\n");
  SweepPlan plan;
  std::ostringstream err;
  EXPECT_EQ(plan_sweep(p, plan, false, err), 2);
  // where the campaign wrote it, not "--set ..."
  EXPECT_NE(err.str().find("ev_nedc: " + p + ":3 (vehicle.battery.soc_initial=1.5)"), std::string::npos) << err.str();
  EXPECT_NE(err.str().find("the campaign is not valid; nothing was run\n"), std::string::npos) << err.str();
  // with variants too: the refused grid value is still the campaign's problem
  write("m.csv", "solver.method\nrk4\nimplicit-euler\n");
  const std::string r = write("e.toml", "scenarios = [\"ev_nedc\"]\nvariants = \"m.csv\"\n[grid]\n"
                                        "\"vehicle.battery.soc_initial\" = [0.5, 1.5]\n");
  SweepPlan mixed;
  std::ostringstream err3;
  EXPECT_EQ(plan_sweep(r, mixed, false, err3), 2);
  EXPECT_NE(err3.str().find(r + ":4 (vehicle.battery.soc_initial=1.5)"), std::string::npos) << err3.str();
  // a variant the scenario refuses fails alone: the plan is valid
  write("v.csv", "vehicle.battery.soc_initial\n0.5\n1.5\n");
  const std::string q = write("d.toml", "scenarios = [\"ev_nedc\"]\nvariants = \"v.csv\"\n");
  SweepPlan ok;
  std::ostringstream err2;
  EXPECT_EQ(plan_sweep(q, ok, false, err2), 0) << err2.str();
  EXPECT_EQ(ok.runs.size(), 2u);
}

TEST(SweepBlame, WholeLabelsOnly) {
  const std::vector<CampaignOverride> o{{"a", "1", "c.toml:4"}, {"a", "10", "c.toml:5"}};
  EXPECT_EQ(blame("--set a=10: bad; --set a=1 here", o), "c.toml:5 (a=10): bad; c.toml:4 (a=1) here");
  EXPECT_EQ(blame("--set a=100: other", o), "--set a=100: other");
}

TEST_F(SweepFiles, TheResumeDecisionFollowsTheStatuses) {
  SweepPlan plan;
  std::ostringstream err;
  ASSERT_EQ(plan_sweep(five_runs(), plan, false, err), 0) << err.str();
  const SweepFolder f{dir_ + "/sweep"};
  std::string error;
  ASSERT_TRUE(open_sweep_folder(f.dir, plan.campaign.path, error)) << error;
  const auto& id = [&](int i) { return plan.runs[static_cast<std::size_t>(i)].id; };
  write("sweep/status/" + id(0) + ".txt", "exit 0\n");  // done: ok and its summary is there
  write("sweep/runs/" + id(0) + "/summary.json", "{\"status\": \"ok\", \"fuel_g\": 1.5, \"energy_audit\": {\"x\": 2}}\n");
  // failed: a run-time fault keeps its outputs (exit 3), so a summary is no sign of success
  write("sweep/status/" + id(1) + ".txt", "exit 3\nFAULT battery SOC at t = 2 s\n");
  write("sweep/runs/" + id(1) + "/summary.json", "{\"status\": \"fault\"}\n");
  // run 2: no status (never ran)
  write("sweep/status/" + id(3) + ".txt", "exit 0\n");    // ok, but its folder went missing
  write("sweep/status/" + id(4) + ".txt", "exit 2x\n");   // not ours: not recorded
  EXPECT_TRUE(run_done(f, id(0), read_outcome(f, id(0))));
  EXPECT_TRUE(run_failed(read_outcome(f, id(1))));
  EXPECT_FALSE(run_done(f, id(1), read_outcome(f, id(1))));
  EXPECT_EQ(read_outcome(f, id(1)).exit_code, 3);
  EXPECT_EQ(read_outcome(f, id(1)).message, "FAULT battery SOC at t = 2 s");
  EXPECT_FALSE(read_outcome(f, id(4)).recorded);
  const SweepSelection s = select_runs(plan, f, false);
  EXPECT_EQ(s.todo, (std::vector<std::size_t>{2, 3, 4}));
  EXPECT_EQ(s.done_before, 1u);
  EXPECT_EQ(s.failed_before, 1u);
  const SweepSelection retry = select_runs(plan, f, true);
  EXPECT_EQ(retry.todo, (std::vector<std::size_t>{1, 2, 3, 4}));
  EXPECT_EQ(retry.failed_before, 0u);

  // merged: one row per planned run, in plan order
  SweepTally t;
  ASSERT_TRUE(merge_results(plan, f, t, error)) << error;
  EXPECT_EQ(t.ok, 1u);
  EXPECT_EQ(t.failed, 1u);
  EXPECT_EQ(t.pending, 3u);
  EXPECT_EQ(sweep_exit_code(t), 4);
  std::istringstream csv(read("sweep/results.csv"));
  std::string header, row0, row1, row2;
  std::getline(csv, header);
  std::getline(csv, row0);
  std::getline(csv, row1);
  std::getline(csv, row2);
  EXPECT_EQ(header, "run_id,scenario,vehicle.battery.soc_initial,sweep_status,exit_code,message,status,fuel_g,energy_audit.x");
  EXPECT_EQ(row0, id(0) + ",ev_nedc,0.5,ok,0,,ok,1.5,2");
  EXPECT_EQ(row1, id(1) + ",ev_nedc,0.55,failed,3,FAULT battery SOC at t = 2 s,fault,,");
  EXPECT_EQ(row2, id(2) + ",ev_nedc,0.6,pending,,,,,");
  io::JsonValue first;
  std::string jsonl = read("sweep/results.jsonl");
  ASSERT_TRUE(io::parse_json(jsonl.substr(0, jsonl.find('\n')), first, error)) << error;
  ASSERT_NE(first.find("overrides"), nullptr);
  const io::JsonValue* soc = first.find("overrides")->find("vehicle.battery.soc_initial");
  ASSERT_NE(soc, nullptr);
  EXPECT_EQ(soc->kind, io::JsonValue::Kind::kNumber);  // a number, not the text "0.5"
  EXPECT_EQ(soc->text, "0.5");
  EXPECT_EQ(first.find("summary")->find("fuel_g")->text, "1.5");

  // nothing pending, one failed: 3; all ok: 0
  EXPECT_EQ(sweep_exit_code(SweepTally{4, 1, 0}), 3);
  EXPECT_EQ(sweep_exit_code(SweepTally{5, 0, 0}), 0);
}

TEST_F(SweepFiles, AFolderOfAnotherCampaignOrOfOtherFilesIsRefused) {
  std::string error;
  ASSERT_TRUE(open_sweep_folder(dir_ + "/a", "/x/one.toml", error)) << error;
  std::string campaign, why;
  ASSERT_TRUE(sweep_campaign_of(dir_ + "/a", campaign, why)) << why;
  EXPECT_EQ(campaign, "/x/one.toml");
  EXPECT_TRUE(is_sweep_folder(dir_ + "/a"));
  EXPECT_TRUE(open_sweep_folder(dir_ + "/a", "/x/one.toml", error)) << error;  // resumed
  EXPECT_FALSE(open_sweep_folder(dir_ + "/a", "/x/two.toml", error));
  EXPECT_NE(error.find("holds the sweep of another campaign (/x/one.toml)"), std::string::npos) << error;
  write("b/notes.txt", "mine");
  EXPECT_FALSE(open_sweep_folder(dir_ + "/b", "/x/one.toml", error));
  EXPECT_NE(error.find("is not an ehpt sweep folder (it holds notes.txt)"), std::string::npos) << error;
  EXPECT_FALSE(is_sweep_folder(dir_ + "/b"));
  EXPECT_EQ(read("b/notes.txt"), "mine");
  EXPECT_EQ(absolute_folder(dir_ + "/a/"), dir_ + "/a");
}

// Run ids are made of the inputs alone: a sweep resumed by another ehpt build would merge two
// builds' results under the same ids, so the folder records its build and another is refused.
TEST_F(SweepFiles, AResumeByAnotherBuildIsRefused) {
  std::string error;
  ASSERT_TRUE(open_sweep_folder(dir_ + "/c", "/x/one.toml", error)) << error;
  const std::string json = read("c/sweep.json");
  EXPECT_NE(json.find("\"build\": \"" + std::string(build_info().version) + " ("), std::string::npos) << json;
  EXPECT_TRUE(open_sweep_folder(dir_ + "/c", "/x/one.toml", error)) << error;  // the same build resumes
  write("c/sweep.json", "{\"format\": \"ehpt sweep folder 1\", \"campaign\": \"/x/one.toml\", \"build\": \"0.1 (old)\"}\n");
  EXPECT_FALSE(open_sweep_folder(dir_ + "/c", "/x/one.toml", error));
  EXPECT_NE(error.find("holds runs of another ehpt build (0.1 (old); this one is "), std::string::npos) << error;
  write("c/sweep.json", "{\"format\": \"ehpt sweep folder 1\", \"campaign\": \"/x/one.toml\"}\n");
  EXPECT_FALSE(open_sweep_folder(dir_ + "/c", "/x/one.toml", error));
  EXPECT_NE(error.find("an older ehpt that did not record its build"), std::string::npos) << error;
  EXPECT_EQ(read("c/sweep.json"), "{\"format\": \"ehpt sweep folder 1\", \"campaign\": \"/x/one.toml\"}\n");  // untouched
}

}  // namespace
}  // namespace ehpt::hil
