// SPDX-License-Identifier: BSD-3-Clause
// LoadCache (hil/config/config.hpp): a series of loads that share their files (a sweep's plan)
// gives what each load from disk gives: the same inputs and ids, the same problems with the
// same file:line, however many times a file is taken from the cache.
#include "hil/config/config.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>

#include "hil/campaign/campaign.hpp"
#include "hil/config/scenario.hpp"
#include "hil/run/batch.hpp"
#include "ecu/psd_ecu.hpp"
#include "test_plants.hpp"

namespace ehpt::hil {
namespace {

namespace fs = std::filesystem;

struct Loaded {
  bool ok = false;
  Scenario sc;
  std::vector<std::string> errors;
};

Loaded from_disk(const std::string& path, const std::vector<std::string>& sets) {
  Loaded l;
  l.ok = load_scenario(path, sets, l.sc, l.errors);
  return l;
}
Loaded through(LoadCache& cache, const std::string& path, const std::vector<std::string>& sets) {
  Loaded l;
  l.ok = load_scenario(path, sets, l.sc, l.errors, cache);
  return l;
}

void expect_same(const Loaded& a, const Loaded& b, const std::string& what) {
  EXPECT_EQ(a.ok, b.ok) << what;
  EXPECT_EQ(a.errors, b.errors) << what;
  EXPECT_EQ(a.sc.warnings, b.sc.warnings) << what;
  ASSERT_EQ(a.sc.inputs.size(), b.sc.inputs.size()) << what;
  for (std::size_t i = 0; i < a.sc.inputs.size(); ++i) {
    EXPECT_EQ(a.sc.inputs[i].path, b.sc.inputs[i].path) << what;
    EXPECT_EQ(a.sc.inputs[i].sha256, b.sc.inputs[i].sha256) << what;
    EXPECT_EQ(a.sc.inputs[i].bytes, b.sc.inputs[i].bytes) << what;
  }
  EXPECT_EQ(run_id(a.sc.inputs, std::vector<CampaignOverride>{}), run_id(b.sc.inputs, std::vector<CampaignOverride>{}))
      << what;
  EXPECT_EQ(a.sc.kind, b.sc.kind) << what;
  EXPECT_EQ(a.sc.solver.steps, b.sc.solver.steps) << what;
  EXPECT_EQ(a.sc.vehicle_path, b.sc.vehicle_path) << what;
  EXPECT_EQ(a.sc.cycle_path, b.sc.cycle_path) << what;
}

TEST(LoadCache, EveryShippedScenarioLoadsAsFromDisk) {
  LoadCache cache;  // one cache for all: the scenarios share vehicles, maps and cycles
  const auto list = list_scenarios(test::source_path("scenarios"));
  ASSERT_GE(list.size(), 9u);
  for (int pass = 0; pass < 2; ++pass) {  // the second pass takes every file from the cache
    for (const auto& s : list) {
      const Loaded disk = from_disk(s.path, {});
      ASSERT_TRUE(disk.ok) << s.name;
      expect_same(disk, through(cache, s.path, {}), s.name + " (pass " + std::to_string(pass) + ")");
    }
  }
}

// What the loaded parameters do (maps, curves, the cycle and every number): the first half
// second of every shipped scenario, loaded from disk and through a cache that has read every
// file before, gives the same rows bit for bit.
TEST(LoadCache, EveryShippedScenarioRunsAsFromDisk) {
  LoadCache cache;
  const auto list = list_scenarios(test::source_path("scenarios"));
  for (const auto& s : list) (void)through(cache, s.path, {});  // every file in the cache
  int compared = 0;
  for (const auto& s : list) {
    const std::vector<std::string> sets = {"solver.duration_s=0.5"};
    const Loaded disk = from_disk(s.path, sets);
    if (!disk.ok) continue;  // a rig whose length is its programme's
    const Loaded cached = through(cache, s.path, sets);
    ASSERT_TRUE(cached.ok) << s.name;
    const MemoryRun a = run_in_memory(disk.sc), b = run_in_memory(cached.sc);
    ASSERT_EQ(a.rows.size(), b.rows.size()) << s.name;
    ASSERT_FALSE(a.rows.empty()) << s.name;
    EXPECT_EQ(0, std::memcmp(a.rows.data(), b.rows.data(), a.rows.size() * sizeof(double))) << s.name;
    ++compared;
  }
  EXPECT_GE(compared, 9);
}

TEST(LoadCache, OverridesActOnEachLoadAlone) {
  LoadCache cache;
  const std::string path = test::source_path("scenarios/psecu2_nedc.toml");
  for (const char* soc : {"0.55", "0.6", "0.65"}) {
    const Loaded l = through(cache, path, {std::string("vehicle.ecu.soc_ref=") + soc});
    ASSERT_TRUE(l.ok) << (l.errors.empty() ? "" : l.errors[0]);
    EXPECT_EQ(l.sc.ecu.get<ecu::PsdEcuParams>().soc_ref, std::stod(soc));
  }
  // and a load without the override is the file's again
  EXPECT_EQ(through(cache, path, {}).sc.ecu.get<ecu::PsdEcuParams>().soc_ref,
            from_disk(path, {}).sc.ecu.get<ecu::PsdEcuParams>().soc_ref);
}

class LoadCacheFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("ehpt_load_cache_" + std::to_string(getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p.string();
  }
  fs::path dir_;
};

// A problem in a file taken from the cache names the file and line as one read from disk: the
// parsed TOML is shared, never copied (a copy of a toml++ node has no source).
TEST_F(LoadCacheFiles, ProblemsKeepTheirFileAndLine) {
  const std::string vehicle = write("my_psd.toml", "extends = \"" + test::source_path("vehicles/psecu2.toml") +
                                                       "\"\n[battery]\ncell_capacity_Ah = -13.0\n");
  write("bad_cycle.csv", "time_s,speed_kmh\n0,0\n1,abc\n");
  const std::string scenario =
      write("s.toml", "vehicle_file = \"my_psd.toml\"\ncycle = \"bad_cycle.csv\"\n[solver]\nduration_s = 10\n");
  const Loaded disk = from_disk(scenario, {});
  ASSERT_FALSE(disk.ok);
  bool names_vehicle_line = false, names_cycle_line = false;
  for (const std::string& e : disk.errors) {
    names_vehicle_line = names_vehicle_line || e.find(vehicle + ":3") != std::string::npos;
    names_cycle_line = names_cycle_line || e.find("bad_cycle.csv:3") != std::string::npos;
  }
  EXPECT_TRUE(names_vehicle_line) << ::testing::PrintToString(disk.errors);
  EXPECT_TRUE(names_cycle_line) << ::testing::PrintToString(disk.errors);
  LoadCache cache;
  for (int i = 0; i < 3; ++i) expect_same(disk, through(cache, scenario, {}), "load " + std::to_string(i));
  // an override the model refuses, and one that does not parse, named as given each time
  // (the parsed --set is shared by the loads that give it)
  const std::string shipped = test::source_path("scenarios/psecu2_nedc.toml");
  for (const std::vector<std::string>& sets : {std::vector<std::string>{"vehicle.battery.soc_initial=1.5"},
                                              std::vector<std::string>{"vehicle.battery.soc_initial=[1,"}}) {
    const Loaded refused = from_disk(shipped, sets);
    ASSERT_FALSE(refused.ok) << sets[0];
    EXPECT_NE(refused.errors[0].find("--set " + sets[0]), std::string::npos) << refused.errors[0];
    for (int i = 0; i < 2; ++i) expect_same(refused, through(cache, shipped, sets), sets[0] + " " + std::to_string(i));
  }
  // a file that cannot be read is reported each time, at the key that names it
  const std::string missing = write("m.toml", "vehicle_file = \"nowhere.toml\"\ncycle = \"bad_cycle.csv\"\n");
  const Loaded gone = from_disk(missing, {});
  ASSERT_FALSE(gone.ok);
  for (int i = 0; i < 2; ++i) expect_same(gone, through(cache, missing, {}), "missing " + std::to_string(i));
}

}  // namespace
}  // namespace ehpt::hil
