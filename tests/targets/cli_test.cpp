// The real binary: bad input is rejected with file, line, field and value, exit code 2 and no
// output folder; good runs are bit-identical; a run-time fault keeps its outputs.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>

#include "test_plants.hpp"

namespace fs = std::filesystem;

namespace {

struct Result {
  int exit_code = -1;
  std::string out, err;
};

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

Result ehpt(const std::string& args) {
  // one folder per test: ctest runs tests in parallel
  const fs::path tmp = fs::temp_directory_path() /
                       ("ehpt_cli_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
  fs::create_directories(tmp);
  const std::string out = (tmp / "stdout").string(), err = (tmp / "stderr").string();
  const std::string cmd = std::string(EHPT_BINARY) + " " + args + " >" + out + " 2>" + err;
  const int status = std::system(cmd.c_str());
  Result r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

void replace_once(std::string& s, const std::string& from, const std::string& to) {
  const auto at = s.find(from);
  ASSERT_NE(at, std::string::npos) << from;
  s.replace(at, from.size(), to);
}

// A scratch copy of the MBEV vehicle and a scenario using it, with one line replaced.
class BadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("ehpt_bad_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    vehicle_ = slurp(ehpt::test::source_path("vehicles/mbev.toml"));
    const std::string map = ehpt::test::source_path("data/maps/map_evmaps_eff.csv");
    replace(vehicle_, "efficiency_map = \"../data/maps/map_evmaps_eff.csv\"", "efficiency_map = \"" + map + "\"");
    cycle_ = slurp(ehpt::test::source_path("data/cycles/cycle_sort1.csv"));
    map_ = slurp(map);
  }
  static void replace(std::string& s, const std::string& from, const std::string& to) { replace_once(s, from, to); }
  // Writes the files and runs `ehpt run`; the output folder must not appear.
  Result run() {
    std::ofstream(dir_ / "vehicle.toml") << vehicle_;
    std::ofstream(dir_ / "cycle.csv") << cycle_;
    std::ofstream(dir_ / "map.csv") << map_;
    std::ofstream(dir_ / "scenario.toml") << "description = \"bad input test\"\nvehicle_file = \"vehicle.toml\"\ncycle = \"" +
                                                 cycle_name_ + "\"\n";
    const std::string out = (dir_ / "out").string();
    Result r = ehpt("run " + (dir_ / "scenario.toml").string() + " --out " + out);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find("nothing was run"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
    EXPECT_FALSE(fs::exists(out + ".partial"));
    return r;
  }
  std::string file(const std::string& name) const { return (dir_ / name).string(); }

  fs::path dir_;
  std::string vehicle_, cycle_, map_, cycle_name_ = "cycle.csv";
};

#define EXPECT_HAS(haystack, needle) EXPECT_NE((haystack).find(needle), std::string::npos) << (haystack)

TEST_F(BadInput, UnknownKey) {
  replace(vehicle_, "mass_kg = 1300.0", "mass_kg = 1300.0\nmass_kgs = 3");
  EXPECT_HAS(run().err, file("vehicle.toml") + ":8: vehicle.mass_kgs: unknown key");
}

TEST_F(BadInput, MissingField) {
  replace(vehicle_, "mass_kg = 1300.0\n", "");
  EXPECT_HAS(run().err, file("vehicle.toml") + ": vehicle.mass_kg: missing (required number)");
}

TEST_F(BadInput, NegativeMass) {
  replace(vehicle_, "mass_kg = 1300.0", "mass_kg = -1300.0");
  EXPECT_HAS(run().err, file("vehicle.toml") + ":7: vehicle.mass_kg = -1300: must be a finite number > 0");
}

TEST_F(BadInput, NanValue) {
  replace(vehicle_, "frontal_area_m2 = 2.2", "frontal_area_m2 = nan");
  EXPECT_HAS(run().err, file("vehicle.toml") + ":15: road.frontal_area_m2 = nan: must be a finite number >= 0");
}

TEST_F(BadInput, NonMonotonicCycleAxis) {
  replace(cycle_, "24.17,0", "4.17,0");
  EXPECT_HAS(run().err, file("cycle.csv") + ":5: driver.cycle[3] = 4.17: axis must be non-decreasing (previous value 17.22)");
}

TEST_F(BadInput, TextInNumberColumn) {
  replace(cycle_, "5.39,20", "5.39,fast");
  EXPECT_HAS(run().err, file("cycle.csv") + ":3: column speed_kmh: \"fast\" is not a number");
}

TEST_F(BadInput, EfficiencyOutsideZeroOne) {
  replace(map_, "0.5,0.5,0.83", "0.5,0.5,1.3");
  replace(vehicle_, ehpt::test::source_path("data/maps/map_evmaps_eff.csv"), "map.csv");
  EXPECT_HAS(run().err, file("map.csv") + ": drive.efficiency_map = 1.3: efficiency must be in (0, 1]");
}

TEST_F(BadInput, EmptyCycle) {
  cycle_ = "time_s,speed_kmh\n";
  EXPECT_HAS(run().err, file("cycle.csv") + ": no data rows after the header");
}

TEST_F(BadInput, MissingFile) {
  cycle_name_ = "no_such_cycle.csv";
  EXPECT_HAS(run().err, file("no_such_cycle.csv") + ": cannot open file (missing or unreadable)");
}

TEST_F(BadInput, EveryProblemIsListedAtOnce) {
  replace(vehicle_, "mass_kg = 1300.0", "mass_kg = -1300.0");
  replace(vehicle_, "soc_initial = 0.7", "soc_initial = 1.7");
  replace(cycle_, "5.39,20", "5.39,fast");
  const Result r = run();
  EXPECT_HAS(r.err, "vehicle.mass_kg = -1300");
  EXPECT_HAS(r.err, "battery.soc_initial = 1.7");
  EXPECT_HAS(r.err, "\"fast\" is not a number");
  EXPECT_HAS(r.err, "3 problems; nothing was run.");
}

// The paper's PSecu2 vehicle with its maps copied next to it, one line replaced.
class BadPsdInput : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("ehpt_badpsd_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    vehicle_ = slurp(ehpt::test::source_path("vehicles/psecu2.toml"));
    for (const char* map : {"map_psd_ice_max_torque.csv", "map_psd_ice_sfc.csv", "ecu_psd_power_to_ice_speed.csv"}) {
      files_[map] = slurp(ehpt::test::source_path(std::string("data/maps/") + map));
      replace_once(vehicle_, std::string("../data/maps/") + map, map);
    }
  }
  Result run() {
    std::ofstream(dir_ / "vehicle.toml") << vehicle_;
    for (const auto& [name, text] : files_) std::ofstream(dir_ / name) << text;
    std::ofstream(dir_ / "scenario.toml") << "vehicle_file = \"vehicle.toml\"\ncycle = \"" +
                                                 ehpt::test::source_path("data/cycles/cycle_nedc.csv") + "\"\n";
    const std::string out = (dir_ / "out").string();
    Result r = ehpt("run " + (dir_ / "scenario.toml").string() + " --out " + out);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find("nothing was run"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
    return r;
  }
  std::string file(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
  std::string vehicle_;
  std::map<std::string, std::string> files_;
};

TEST_F(BadPsdInput, NegativeSfc) {
  replace_once(files_["map_psd_ice_sfc.csv"], "50,300,265", "50,300,-265");
  EXPECT_HAS(run().err, file("map_psd_ice_sfc.csv") + ": ice.sfc_map = -265: specific consumption must be > 0 g/kWh");
}

TEST_F(BadPsdInput, RingSunRatioNotAboveOne) {
  replace_once(vehicle_, "ring_sun_ratio = 2.6", "ring_sun_ratio = 0.8");
  EXPECT_HAS(run().err, file("vehicle.toml") + ":38: planetary.ring_sun_ratio = 0.8: must be > 1");
}

TEST_F(BadPsdInput, HysteresisThresholdsInTheWrongOrder) {
  replace_once(vehicle_, "off_threshold_W = 5000.0", "off_threshold_W = 9000.0");
  EXPECT_HAS(run().err, file("vehicle.toml") + ":76: ecu.off_threshold_W = 9000: must be < on_threshold_W = 7000");
}

TEST_F(BadPsdInput, TorqueCurveWithNonMonotonicSpeedAxis) {
  replace_once(files_["map_psd_ice_max_torque.csv"], "300,92", "150,92");
  EXPECT_HAS(run().err, file("map_psd_ice_max_torque.csv") +
                            ":4: ice.torque_max[2] = 150: axis must be strictly increasing (previous value 200)");
}

TEST_F(BadPsdInput, UnknownEcuKind) {
  replace_once(vehicle_, "kind = \"MBecu2\"", "kind = \"MBecu3\"");
  EXPECT_HAS(run().err, "ecu.kind = \"MBecu3\": must be \"MBecu1\", \"MBecu1soc\" or \"MBecu2\"");
}

TEST(Cli, TwoRunsGiveBitIdenticalTimeseries) {
  const fs::path tmp = fs::temp_directory_path() / "ehpt_cli_repeat";
  fs::remove_all(tmp);
  const std::string scenario = ehpt::test::source_path("scenarios/ev_sort1.toml");
  const std::string hybrid = ehpt::test::source_path("scenarios/psecu2_nedc.toml") + " --set solver.duration_s=400";
  ASSERT_EQ(ehpt("run " + hybrid + " --quiet --out " + (tmp / "h1").string()).exit_code, 0);
  ASSERT_EQ(ehpt("run " + hybrid + " --quiet --out " + (tmp / "h2").string()).exit_code, 0);
  EXPECT_EQ(slurp((tmp / "h1/timeseries.csv").string()), slurp((tmp / "h2/timeseries.csv").string()));
  const std::string hybrid_summary = slurp((tmp / "h1/summary.json").string());
  for (const char* key : {"fuel_g", "fuel_L_per_100km", "ice_on_time_s", "ice_starts", "fuel_chemical_J", "events"}) {
    EXPECT_HAS(hybrid_summary, std::string("\"") + key + "\": ");
  }
  ASSERT_EQ(ehpt("run " + scenario + " --quiet --out " + (tmp / "a").string()).exit_code, 0);
  ASSERT_EQ(ehpt("run " + scenario + " --quiet --out " + (tmp / "b").string()).exit_code, 0);
  const std::string a = slurp((tmp / "a/timeseries.csv").string());
  EXPECT_GT(a.size(), 100000u);
  EXPECT_EQ(a, slurp((tmp / "b/timeseries.csv").string()));
  const std::string summary = slurp((tmp / "a/summary.json").string());
  for (const char* key : {"scenario", "solver", "step_s", "duration_s", "steps", "events", "distance_m",
                          "speed_error_rms_kmh", "speed_error_max_kmh", "battery_energy_J", "battery_Wh_per_km",
                          "soc_start", "soc_end", "fuel_g", "fuel_L_per_100km", "energy_balance_residual_J",
                          "energy_balance_relative", "wall_time_s", "realtime_factor"}) {
    EXPECT_HAS(summary, std::string("\"") + key + "\": ");
  }
}

TEST(Cli, RunTimeFaultKeepsOutputsAndExitsNonZero) {
  const fs::path out = fs::temp_directory_path() / "ehpt_cli_fault";
  fs::remove_all(out);
  const Result r = ehpt("run " + ehpt::test::source_path("scenarios/ev_sort1.toml") +
                        " --set vehicle.battery.soc_min=0.6999 --out " + out.string());
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_HAS(r.out, "FAULT");
  const std::string summary = slurp((out / "summary.json").string());
  EXPECT_HAS(summary, "\"status\": \"fault\"");
  EXPECT_HAS(summary, "SOC left [soc_min, soc_max] at t = ");
  EXPECT_TRUE(fs::exists(out / "timeseries.csv"));
}

TEST(Cli, WarnsAboutTheLimiterQuirkOfTheTwoFlangeTest) {
  const fs::path out = fs::temp_directory_path() / "ehpt_cli_warn";
  const Result r = ehpt("run " + ehpt::test::source_path("scenarios/two_flange_test.toml") + " --out " + out.string());
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_HAS(r.err, "test_mb_two_flange.toml:12: drive.speed_max_rad_s = 300: below power_max_W / torque_max_Nm");
}

TEST(Cli, PlotWritesTheFigures) {
  if (std::system("/usr/bin/python3 -c 'import matplotlib, numpy' >/dev/null 2>&1") != 0) {
    GTEST_SKIP() << "/usr/bin/python3 with matplotlib and numpy is not installed (tools/setup.sh installs it)";
  }
  const fs::path out = fs::temp_directory_path() / "ehpt_cli_plot";
  fs::remove_all(out);
  const Result r = ehpt("run " + ehpt::test::source_path("scenarios/ev_sort1.toml") + " --quiet --plot --out " +
                        out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* png : {"speed.png", "torque.png", "power.png", "soc.png", "locked.png"}) {
    EXPECT_GT(fs::file_size(out / png), 10000u) << png;
  }
  const fs::path hybrid = fs::temp_directory_path() / "ehpt_cli_plot_hybrid";
  ASSERT_EQ(ehpt("run " + ehpt::test::source_path("scenarios/psecu2_nedc.toml") +
                 " --set solver.duration_s=60 --quiet --plot --out " + hybrid.string())
                .exit_code,
            0);
  EXPECT_GT(fs::file_size(hybrid / "hybrid.png"), 10000u);
  EXPECT_GT(fs::file_size(hybrid / "hybrid_power.png"), 10000u);
  const fs::path rig = fs::temp_directory_path() / "ehpt_cli_plot_rig";
  ASSERT_EQ(ehpt("run " + ehpt::test::source_path("scenarios/one_flange_test.toml") + " --quiet --out " + rig.string())
                .exit_code,
            0);
  ASSERT_EQ(ehpt("plot " + rig.string()).exit_code, 0);
  EXPECT_TRUE(fs::exists(rig / "torque.png"));
  EXPECT_TRUE(fs::exists(rig / "efficiency.png"));
  EXPECT_EQ(ehpt("plot /nonexistent/folder").exit_code, 1);
}

TEST(Cli, HelpListAndSignals) {
  const Result help = ehpt("--help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_HAS(help.out, "run SCENARIO");
  for (const char* cmd : {"run", "list", "signals", "plot"}) {
    const Result r = ehpt(std::string(cmd) + " --help");
    EXPECT_EQ(r.exit_code, 0) << cmd;
    EXPECT_HAS(r.out, std::string("usage: ehpt ") + cmd);
  }
  const Result list = ehpt("list --dir " + ehpt::test::source_path("scenarios"));
  EXPECT_EQ(list.exit_code, 0);
  EXPECT_HAS(list.out, "ev_nedc");
  EXPECT_HAS(list.out, "one_flange_test");
  const Result sig = ehpt("signals " + ehpt::test::source_path("scenarios/one_flange_test.toml"));
  EXPECT_EQ(sig.exit_code, 0);
  EXPECT_HAS(sig.out, "genTauRef_Nm");
  EXPECT_EQ(ehpt("frobnicate").exit_code, 1);
  EXPECT_EQ(ehpt("run no_such_scenario_name").exit_code, 2);
}

}  // namespace
