// SPDX-License-Identifier: BSD-3-Clause
#include "hil/campaign/campaign.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "io/sha256.hpp"
#include "test_plants.hpp"

namespace ehpt::hil {
namespace {

namespace fs = std::filesystem;

// A private folder with files written by the test, removed at the end (made by mkdtemp).
class CampaignFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string tmpl = (fs::temp_directory_path() / "ehpt-campaign-XXXXXX").string();
    ASSERT_NE(::mkdtemp(tmpl.data()), nullptr);
    dir_ = tmpl;
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) {
    const std::string p = dir_ + "/" + name;
    std::ofstream(p) << text;
    return p;
  }
  std::string joined(const std::vector<std::string>& errors) {
    std::string s;
    for (const auto& e : errors) s += e + "\n";
    return s;
  }
  std::string dir_;
};

TEST_F(CampaignFiles, GridInFileOrderLastKeyFastestThenVariants) {
  write("v.csv", "solver.method,vehicle.ecu.period_s\nrk4,0.01\nimplicit-euler,\n");
  const std::string p = write("c.toml",
                              "scenarios = [\"ev_nedc\", \"psecu2_nedc\"]\nvariants = \"v.csv\"\n"
                              "[set]\n\"solver.duration_s\" = 10\n"
                              "[grid]\n\"vehicle.battery.soc_initial\" = [0.5, 0.6, 0.7]\n"
                              "\"solver.step_s\" = [0.001, 0.002]\n");
  Campaign c;
  std::vector<std::string> errors;
  ASSERT_TRUE(load_campaign(p, c, errors)) << joined(errors);
  ASSERT_EQ(campaign_run_count(c), 2u * 3u * 2u * 2u);
  // the grid's keys in the order of the file, not toml++'s sorted order
  ASSERT_EQ(c.swept_keys(), (std::vector<std::string>{"vehicle.battery.soc_initial", "solver.step_s", "solver.method",
                                                       "vehicle.ecu.period_s"}));
  const auto text = [&](std::uint64_t i) {
    std::string s = c.scenarios[campaign_run(c, i).scenario].name;
    for (const auto& o : campaign_run(c, i).overrides) s += " " + o.set_text();
    return s;
  };
  EXPECT_EQ(text(0), "ev_nedc solver.duration_s=10 output.timeseries=false vehicle.battery.soc_initial=0.5 "
                     "solver.step_s=0.001 solver.method=\"rk4\" vehicle.ecu.period_s=0.01");
  // variants innermost; an empty cell is not set
  EXPECT_EQ(text(1), "ev_nedc solver.duration_s=10 output.timeseries=false vehicle.battery.soc_initial=0.5 "
                     "solver.step_s=0.001 solver.method=\"implicit-euler\"");
  EXPECT_EQ(text(2), "ev_nedc solver.duration_s=10 output.timeseries=false vehicle.battery.soc_initial=0.5 "
                     "solver.step_s=0.002 solver.method=\"rk4\" vehicle.ecu.period_s=0.01");
  EXPECT_EQ(text(4), "ev_nedc solver.duration_s=10 output.timeseries=false vehicle.battery.soc_initial=0.6 "
                     "solver.step_s=0.001 solver.method=\"rk4\" vehicle.ecu.period_s=0.01");
  EXPECT_EQ(text(12).substr(0, 12), "psecu2_nedc ");
  EXPECT_NE(campaign_run(c, 4).overrides[2].where.find("c.toml:6"), std::string::npos);
  EXPECT_NE(campaign_run(c, 1).overrides[4].where.find("v.csv:3"), std::string::npos);
}

TEST_F(CampaignFiles, ValuesAsSetTextReadBackExactly) {
  const std::string p = write("c.toml",
                              "scenarios = [\"ev_nedc\"]\n[grid]\n\"a.b\" = [0.1, 1e-5, 60.0, 3]\n"
                              "\"c\" = [\"x\\\"y\", \"implicit-euler\"]\n\"d\" = [true, false]\n"
                              "[output]\ntimeseries = true\ninterval_s = 0.5\nsignals = [\"time_s\", \"soc\"]\n");
  Campaign c;
  std::vector<std::string> errors;
  ASSERT_TRUE(load_campaign(p, c, errors)) << joined(errors);
  ASSERT_EQ(c.grid.size(), 3u);
  std::vector<std::string> values;
  for (const auto& v : c.grid[0].values) values.push_back(v.value);
  EXPECT_EQ(values, (std::vector<std::string>{"0.1", "1e-05", "60", "3"}));
  EXPECT_EQ(c.grid[1].values[0].value, "\"x\\\"y\"");
  EXPECT_EQ(c.grid[2].values[1].value, "false");
  // [output]: timeseries kept (no output.timeseries=false), the others passed on
  std::vector<std::string> fixed;
  for (const auto& o : c.fixed) fixed.push_back(o.set_text());
  EXPECT_EQ(fixed, (std::vector<std::string>{"output.interval_s=0.5", "output.signals=[\"time_s\",\"soc\"]"}));
}

TEST_F(CampaignFiles, VariantCellsReadAsSetWouldAndCanonically) {
  // "0.60" and "0.6 # note" are the same run as the grid's 0.6; 'rk4' is the string rk4; a bare
  // word is text, as for --set
  write("v.csv", "a,b\n0.60,'rk4'\n0.6 # note,rk4\n1e-5,true\n");
  Campaign c;
  std::vector<std::string> errors;
  ASSERT_TRUE(load_campaign(write("c.toml", "scenarios = [\"ev_nedc\"]\nvariants = \"v.csv\"\n"), c, errors))
      << joined(errors);
  ASSERT_EQ(c.variants.size(), 3u);
  EXPECT_EQ(c.variants[0][0].value, "0.6");
  EXPECT_EQ(c.variants[0][1].value, "\"rk4\"");
  EXPECT_EQ(c.variants[1][0].value, "0.6");
  EXPECT_EQ(c.variants[1][1].value, "\"rk4\"");
  EXPECT_EQ(c.variants[2][0].value, "1e-05");
  EXPECT_EQ(c.variants[2][1].value, "true");
}

TEST_F(CampaignFiles, TimeseriesFromSetIsKeptAndNamesTellFilesApart) {
  fs::create_directories(dir_ + "/a");
  fs::create_directories(dir_ + "/b");
  const std::string scenario = std::string("vehicle_file = \"") + test::source_path("vehicles/mbev.toml") +
                               "\"\ncycle = \"" + test::source_path("data/cycles/cycle_nedc.csv") + "\"\n";
  write("a/x.toml", scenario);
  write("b/x.toml", scenario + "# b\n");
  Campaign c;
  std::vector<std::string> errors;
  ASSERT_TRUE(load_campaign(write("c.toml", "scenarios = [\"a/x.toml\", \"b/x.toml\"]\n[set]\n"
                                            "\"output.timeseries\" = true\n"), c, errors))
      << joined(errors);
  std::vector<std::string> fixed;
  for (const auto& o : c.fixed) fixed.push_back(o.set_text());
  EXPECT_EQ(fixed, (std::vector<std::string>{"output.timeseries=true"}));  // no default after it
  EXPECT_TRUE(c.timeseries);
  ASSERT_EQ(c.scenarios.size(), 2u);
  EXPECT_EQ(c.scenarios[0].name, "a/x");
  EXPECT_EQ(c.scenarios[1].name, "b/x");
}

TEST_F(CampaignFiles, EveryProblemWithFileAndLine) {
  write("v.csv", "solver.method,bad key\nrk4,1\nrk4,1\n");
  const std::string p = write("c.toml",
                              "scenarios = [\"ev_nedc\", \"ev_nedc\", \"no_such\", 3]\n"  // 1
                              "variants = \"v.csv\"\n"                                    // 2
                              "colour = 1\n"                                              // 3
                              "[grid]\n"                                                  // 4
                              "\"vehicle.x\" = []\n"                                      // 5
                              "\"vehicle.y\" = [1, \"a\"]\n"                              // 6
                              "\"vehicle.z\" = 0.5\n"                                     // 7
                              "\"solver.method\" = [\"rk4\"]\n"                           // 8
                              "\"vehicle.w\" = [[1], 2, 2]\n"                             // 9
                              "[output]\nformat = \"x\"\ntimeseries = 1\n");              // 10-12
  Campaign c;
  std::vector<std::string> errors;
  ASSERT_FALSE(load_campaign(p, c, errors));
  const std::string all = joined(errors);
  for (const char* needle : {
           "c.toml:1: scenarios: \"ev_nedc\": listed twice", "c.toml:1: scenarios: \"no_such\": no such scenario",
           "c.toml:1: scenarios: 3: must be a scenario name", "c.toml:3: colour: unknown key",
           "c.toml:5: grid.\"vehicle.x\" = []: an empty grid", "c.toml:6: grid.\"vehicle.y\": 'a': is a string",
           "c.toml:7: grid.\"vehicle.z\" = 0.5: must be an array", "c.toml:9: grid.\"vehicle.w\": (an array): must be a number",
           "c.toml:9: grid.\"vehicle.w\": 2: listed twice", "c.toml:11: output.format: unknown key",
           "c.toml:12: output.timeseries = 1: must be true or false", "v.csv:1: column \"bad key\": not a dotted key",
           "v.csv:3: the same variant as an earlier row"}) {
    EXPECT_NE(all.find(needle), std::string::npos) << "missing: " << needle << "\nin:\n" << all;
  }
  // solver.method in both the grid and the variants
  EXPECT_NE(all.find("\"solver.method\": given more than once"), std::string::npos) << all;
  // listed line by line
  ASSERT_GE(errors.size(), 2u);
  EXPECT_NE(errors[0].find("/c.toml:1:"), std::string::npos) << all;
}

TEST_F(CampaignFiles, TooManyRunsIsRefusedWithoutOverflow) {
  std::string grid = "scenarios = [\"ev_nedc\"]\n[grid]\n";
  // 20 keys of 10 values: 1e20 runs, more than 2^64: counted without wrapping
  for (int k = 0; k < 20; ++k) {
    grid += "\"k" + std::to_string(k) + "\" = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9]\n";
  }
  Campaign c;
  std::vector<std::string> errors;
  ASSERT_FALSE(load_campaign(write("c.toml", grid), c, errors));
  EXPECT_NE(joined(errors).find("more than 10000000 runs"), std::string::npos) << joined(errors);
}

TEST(RunId, APureFunctionOfContentsAndOverrides) {
  const std::vector<InputFile> inputs{{"/a/s.toml", io::sha256_hex("scenario"), 8},
                                      {"/a/cycle.csv", io::sha256_hex("cycle"), 5}};
  const std::vector<CampaignOverride> overrides{{"vehicle.ecu.soc_ref", "0.6", "c.toml:3"}};
  // the scheme itself: the same on every machine and in every release that keeps it
  EXPECT_EQ(run_id(inputs, overrides), io::sha256_hex("ehpt-run-id 1\ninput " + io::sha256_hex("scenario") +
                                                      " 8\ninput " + io::sha256_hex("cycle") +
                                                      " 5\nset vehicle.ecu.soc_ref=0.6\n"));
  // paths and where an override was written do not matter; contents and values do
  auto moved = inputs;
  moved[0].path = "/elsewhere/s.toml";
  auto written_elsewhere = overrides;
  written_elsewhere[0].where = "other.toml:9";
  EXPECT_EQ(run_id(moved, written_elsewhere), run_id(inputs, overrides));
  auto changed = inputs;
  changed[1].sha256 = io::sha256_hex("cycle!");
  EXPECT_NE(run_id(changed, overrides), run_id(inputs, overrides));
  auto other_value = overrides;
  other_value[0].value = "0.61";
  EXPECT_NE(run_id(inputs, other_value), run_id(inputs, overrides));
  EXPECT_NE(run_id({inputs[1], inputs[0]}, overrides), run_id(inputs, overrides));
}

TEST(RunId, ScenarioInputsAreEveryFileItReadsWithItsDigest) {
  Scenario sc;
  std::vector<std::string> errors;
  ASSERT_TRUE(load_scenario(test::source_path("scenarios/psecu2_nedc.toml"), {}, sc, errors));
  std::vector<std::string> names;
  std::string nedc_digest;
  for (const auto& f : sc.inputs) {
    names.push_back(fs::path(f.path).filename().string());
    if (names.back() == "cycle_nedc.csv") nedc_digest = f.sha256;
    EXPECT_EQ(f.bytes, fs::file_size(f.path)) << f.path;
  }
  ASSERT_GE(names.size(), 5u);
  EXPECT_EQ(names[0], "psecu2_nedc.toml");
  EXPECT_EQ(names[1], "psecu2.toml");
  EXPECT_NE(std::find(names.begin(), names.end(), "map_psd_mot_eff.csv"), names.end());
  // the digest sha256sum gives (data/SHA256SUMS)
  EXPECT_EQ(nedc_digest, "1b9e2981e28172f6c9da979f3722a4e5679d5bd604de00ba464ba6663c650a6b");
  // a failed load still names what it read (a run that fails has an id too)
  Scenario bad;
  ASSERT_FALSE(load_scenario(test::source_path("scenarios/psecu2_nedc.toml"), {"vehicle.nope=1"}, bad, errors));
  EXPECT_GE(bad.inputs.size(), 2u);
}

}  // namespace
}  // namespace ehpt::hil
