// SPDX-License-Identifier: BSD-3-Clause
// The real binary: bad input is rejected with file, line, field and value, exit code 2 and no
// output folder; good runs are bit-identical; a run-time fault keeps its outputs.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <thread>
#include <tuple>

#include "io/csv_table.hpp"
#include "io/json_value.hpp"
#include "io/json_writer.hpp"
#include "io/sha256.hpp"
#include "plant/battery_rig.hpp"
#include "test_plants.hpp"

extern char** environ;

namespace fs = std::filesystem;

namespace {

struct Result {
  int exit_code = -1;  // 128 + N when killed by signal N
  std::string out, err;
};

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// One folder per test for the captured streams: ctest runs tests in parallel.
fs::path capture_dir() {
  const fs::path tmp = ehpt::test::scratch_root() /
                       ("ehpt_cli_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
  fs::create_directories(tmp);
  return tmp;
}

// Starts the binary with an argument vector (no shell), stdout and stderr into files, or
// stdout into stdout_fd when given. env: extra "NAME=value" entries.
pid_t spawn_ehpt(const std::vector<std::string>& args, const std::string& tag, int stdout_fd = -1,
                 const std::vector<std::string>& env = {}, const std::string& cwd = "") {
  const fs::path tmp = capture_dir();
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  if (!cwd.empty()) posix_spawn_file_actions_addchdir_np(&fa, cwd.c_str());
  if (stdout_fd >= 0) {
    posix_spawn_file_actions_adddup2(&fa, stdout_fd, STDOUT_FILENO);
  } else {
    posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, (tmp / (tag + ".out")).c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  }
  posix_spawn_file_actions_addopen(&fa, STDERR_FILENO, (tmp / (tag + ".err")).c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::vector<std::string> argv_s = {EHPT_BINARY};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::vector<std::string> env_s;
  for (char** e = environ; *e != nullptr; ++e) env_s.emplace_back(*e);
  env_s.insert(env_s.end(), env.begin(), env.end());
  std::vector<char*> envp;
  for (auto& e : env_s) envp.push_back(e.data());
  envp.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&fa);
  EXPECT_EQ(rc, 0);
  return pid;
}

Result wait_ehpt(pid_t pid, const std::string& tag) {
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  Result r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : WIFSIGNALED(status) ? 128 + WTERMSIG(status) : -1;
  const fs::path tmp = capture_dir();
  r.out = slurp((tmp / (tag + ".out")).string());
  r.err = slurp((tmp / (tag + ".err")).string());
  return r;
}

Result ehpt_argv(const std::vector<std::string>& args, const std::vector<std::string>& env = {}) {
  return wait_ehpt(spawn_ehpt(args, "run", -1, env), "run");
}

// Space-separated arguments (none of the paths used with it contain spaces).
Result ehpt(const std::string& args) {
  std::vector<std::string> v;
  std::istringstream in(args);
  for (std::string a; in >> a;) v.push_back(a);
  return ehpt_argv(v);
}

void replace_once(std::string& s, const std::string& from, const std::string& to) {
  const auto at = s.find(from);
  ASSERT_NE(at, std::string::npos) << from;
  s.replace(at, from.size(), to);
}

bool have_matplotlib() {
  pid_t pid = -1;
  char python[] = "/usr/bin/python3", flag[] = "-c", code[] = "import matplotlib, numpy";
  char* argv[] = {python, flag, code, nullptr};
  if (posix_spawn(&pid, python, nullptr, nullptr, argv, environ) != 0) return false;
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

// A scratch copy of the MBEV vehicle and a scenario using it, with one line replaced.
class BadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = ehpt::test::scratch_root() / ("ehpt_bad_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
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
  // at the line of the [vehicle] table it is missing from
  EXPECT_HAS(run().err, file("vehicle.toml") + ":6: vehicle.mass_kg: missing (required number)");
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
  EXPECT_HAS(run().err, file("cycle.csv") +
                            ":5: driver.cycle, column time_s = 4.17: axis must be non-decreasing (previous value 17.22)");
}

TEST_F(BadInput, CycleValuesAreReportedAsWrittenWithTheirRow) {
  replace(cycle_, "5.39,20", "5.39,-20");  // km/h: the message must not show -5.56 (m/s)
  EXPECT_HAS(run().err, file("cycle.csv") +
                            ":3: driver.cycle, column speed_kmh = -20: speed must be >= 0 and below 200 m/s (720 km/h)");
}

TEST_F(BadInput, QuotedNumbersAndAByteOrderMarkAreRead) {
  // as a spreadsheet exports it; then one bad quoted field, named as written
  cycle_ = "\xEF\xBB\xBF\"time_s\",\"speed_kmh\"\r\n\"0\",\"0\"\r\n\"5.39\",\"20\"\r\n\"17.22\",\"2O\"\r\n";
  EXPECT_HAS(run().err, file("cycle.csv") + ":4: column speed_kmh: \"2O\" is not a number");
}

TEST_F(BadInput, MapAxisSizeIsPlacedAtTheMapFile) {
  map_ = "torque_pu,speed_pu,efficiency\n0,0,0.9\n0,1,0.9\n";  // one row-axis value
  replace(vehicle_, ehpt::test::source_path("data/maps/map_evmaps_eff.csv"), "map.csv");
  EXPECT_HAS(run().err, file("map.csv") + ": drive.efficiency_map = 1 value on the row axis: a map needs at least 2 "
                                          "values on each axis");
}

TEST_F(BadInput, MissingVehicleFileIsReportedAtTheKeyThatNamesIt) {
  std::ofstream(dir_ / "scenario2.toml") << "description = \"x\"\nvehicle_file = \"nope.toml\"\n";
  const Result r = ehpt("run " + file("scenario2.toml") + " --out " + file("out"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_HAS(r.err, file("scenario2.toml") + ":2: vehicle_file = \"nope.toml\": cannot read " + file("nope.toml") +
                        ": no such file");
}

TEST_F(BadInput, InputFilesThatAreNotRegularFilesAreRefusedWithoutHanging) {
  ASSERT_EQ(mkfifo(file("fifo.csv").c_str(), 0644), 0);
  cycle_name_ = "fifo.csv";
  EXPECT_HAS(run().err, "cycle = \"fifo.csv\": cannot read " + file("fifo.csv") + ": is a FIFO, not a regular file");
  cycle_name_ = "/dev/urandom";
  EXPECT_HAS(run().err, "cycle = \"/dev/urandom\": cannot read /dev/urandom: is a device, not a regular file");
  replace(vehicle_, "efficiency_map = \"" + ehpt::test::source_path("data/maps/map_evmaps_eff.csv") + "\"",
          "efficiency_map = \"/dev/zero\"");
  cycle_name_ = "cycle.csv";
  EXPECT_HAS(run().err, "drive.efficiency_map = \"/dev/zero\": cannot read /dev/zero: is a device");
  // as the scenario itself
  const Result r = ehpt("run " + file("fifo.csv"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_HAS(r.err, "fifo.csv: is a FIFO, not a scenario file");
}

TEST_F(BadInput, AnOverLongOrUnreadablePathIsAMessageNotAnAbort) {
  const Result r = ehpt_argv({"run", std::string(5000, 'a')});
  EXPECT_EQ(r.exit_code, 2);  // was 134: an uncaught std::filesystem_error
  EXPECT_HAS(r.err, "... (5000 characters): File name too long");
  const Result deep = ehpt_argv({"run", "/proc/self/fd/999/x.toml"});
  EXPECT_EQ(deep.exit_code, 2);
}

TEST_F(BadInput, AHugeInputFileIsRefusedBeforeItIsRead) {
  {
    std::ofstream big(file("big.csv"));
    big << "time_s,speed_kmh\n";
    const std::string row(1 << 20, '#');  // comment lines: 65 MiB in 65 writes
    for (int i = 0; i < 65; ++i) big << row << "\n";
  }
  cycle_name_ = "big.csv";
  EXPECT_HAS(run().err, "bytes, more than the limit of 67108864 bytes for an input file");
}

TEST_F(BadInput, TextInNumberColumn) {
  replace(cycle_, "5.39,20", "5.39,fast");
  EXPECT_HAS(run().err, file("cycle.csv") + ":3: column speed_kmh: \"fast\" is not a number");
}

TEST_F(BadInput, EfficiencyOutsideZeroOne) {
  replace(map_, "0.5,0.5,0.83", "0.5,0.5,1.3");
  replace(vehicle_, ehpt::test::source_path("data/maps/map_evmaps_eff.csv"), "map.csv");
  EXPECT_HAS(run().err, file("map.csv") + ":14: drive.efficiency_map, column efficiency = 1.3: efficiency must be in (0, 1]");
}

TEST_F(BadInput, EmptyCycle) {
  cycle_ = "time_s,speed_kmh\n";
  EXPECT_HAS(run().err, file("cycle.csv") + ": no data rows after the header");
}

TEST_F(BadInput, MissingFile) {
  cycle_name_ = "no_such_cycle.csv";
  EXPECT_HAS(run().err, file("scenario.toml") + ":3: cycle = \"no_such_cycle.csv\": cannot read " +
                            file("no_such_cycle.csv") + ": no such file");
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

// Physically impossible machine data (issue 10), in the machine EVs' own vehicle files.
TEST_F(BadInput, ImpossibleMachineDataIsNamedWithFileLineFieldAndValue) {
  vehicle_ = slurp(ehpt::test::source_path("vehicles/evpm_bat.toml"));
  replace(vehicle_, "pole_pairs = 2", "pole_pairs = 0");
  replace(vehicle_, "psi_pm_Wb = 0.5055", "psi_pm_Wb = -0.5");
  replace(vehicle_, "Ld_H = 2.0e-3", "Ld_H = 0.0");
  const Result r = run();
  EXPECT_HAS(r.err, file("vehicle.toml") + ":22: drive.pole_pairs = 0: must be a whole number in [1, 100]");
  EXPECT_HAS(r.err, file("vehicle.toml") + ":23: drive.psi_pm_Wb = -0.5: must be a finite number > 0");
  EXPECT_HAS(r.err, file("vehicle.toml") + ":24: drive.Ld_H = 0: must be a finite number > 0");
}

TEST_F(BadInput, ASetVoltageTheBatteryCannotSupplyIsNamed) {
  vehicle_ = slurp(ehpt::test::source_path("vehicles/evpm_bat.toml"));
  replace(vehicle_, "U_max_rms_V = 100.0", "U_max_rms_V = 200.0");
  EXPECT_HAS(run().err, file("vehicle.toml") + ":27: drive.U_max_rms_V = 200: the DC bus cannot supply it: its peak (" );
  vehicle_ = slurp(ehpt::test::source_path("vehicles/evam_bat.toml"));
  replace(vehicle_, "U_base_rms_V = 100.0", "U_base_rms_V = 150.0");
  EXPECT_HAS(run().err, file("vehicle.toml") + ":28: drive.U_base_rms_V = 150: the DC bus cannot supply it");
  // the same machine in per unit: named by the field its file has
  vehicle_ = slurp(ehpt::test::source_path("vehicles/evam_pu_bat.toml"));
  replace(vehicle_, "V_nom_rms_V = 100.0", "V_nom_rms_V = 150.0");
  EXPECT_HAS(run().err, file("vehicle.toml") + ":23: drive.V_nom_rms_V = 150: the DC bus cannot supply it");
}

TEST_F(BadInput, ACurrentLimitBelowTheNoLoadCurrentIsNamed) {
  vehicle_ = slurp(ehpt::test::source_path("vehicles/evpm_bat.toml"));
  replace(vehicle_, "I_lim_rms_A = 100.0", "I_lim_rms_A = 50.0");
  EXPECT_HAS(run().err, file("vehicle.toml") + ":28: drive.I_lim_rms_A = 50: is below the no-load current flux weakening needs at speed_max_rad_s");
  vehicle_ = slurp(ehpt::test::source_path("vehicles/evam_bat.toml"));
  replace(vehicle_, "I_max_rms_A = 250.0", "I_max_rms_A = 30.0");
  EXPECT_HAS(run().err, file("vehicle.toml") + ":30: drive.I_max_rms_A = 30: must be above the no-load");
}

// The paper's PSecu2 vehicle with its maps copied next to it, one line replaced.
class BadPsdInput : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = ehpt::test::scratch_root() / ("ehpt_badpsd_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    vehicle_ = slurp(ehpt::test::source_path("vehicles/psecu2.toml"));
    for (const char* map : {"map_psd_ice_max_torque.csv", "map_psd_ice_sfc.csv", "ecu_psd_power_to_ice_speed.csv",
                            "map_psd_gen_eff.csv", "map_psd_mot_eff.csv"}) {
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
  EXPECT_HAS(run().err, file("map_psd_ice_sfc.csv") +
                            ":24: ice.sfc_map, column sfc_g_per_kWh = -265: specific consumption must be > 0 g/kWh");
}

TEST_F(BadPsdInput, RingSunRatioNotAboveOne) {
  replace_once(vehicle_, "ring_sun_ratio = 2.6", "ring_sun_ratio = 0.8");
  EXPECT_HAS(run().err, file("vehicle.toml") + ":38: planetary.ring_sun_ratio = 0.8: must be > 1");
}

TEST_F(BadPsdInput, HysteresisThresholdsInTheWrongOrder) {
  replace_once(vehicle_, "off_threshold_W = 5000.0", "off_threshold_W = 9000.0");
  EXPECT_HAS(run().err, file("vehicle.toml") + ":80: ecu.off_threshold_W = 9000: must be < on_threshold_W = 7000");
}

TEST_F(BadPsdInput, TorqueCurveWithNonMonotonicSpeedAxis) {
  replace_once(files_["map_psd_ice_max_torque.csv"], "300,92", "150,92");
  EXPECT_HAS(run().err, file("map_psd_ice_max_torque.csv") +
                            ":4: ice.torque_max, column speed_rad_s = 150: axis must be strictly increasing (previous value 200)");
}

TEST_F(BadPsdInput, UnknownEcuKind) {
  replace_once(vehicle_, "kind = \"MBecu2\"", "kind = \"MBecu3\"");
  EXPECT_HAS(run().err, "ecu.kind = \"MBecu3\": must be \"MBecu1\", \"MBecu1soc\" or \"MBecu2\"");
}

TEST(Cli, TwoRunsGiveBitIdenticalTimeseries) {
  const fs::path tmp = ehpt::test::scratch_root() / "ehpt_cli_repeat";
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

// Provenance: the build and every input file (SHA-256 and size of its bytes), the overrides in
// order, and the run id a sweep would file the run under.
TEST(Cli, TheSummaryRecordsTheBuildEveryInputFileAndTheOverrides) {
  const fs::path out = ehpt::test::scratch_root() / "ehpt_cli_provenance";
  fs::remove_all(out);
  const std::string scenario = ehpt::test::source_path("scenarios/ev_sort1.toml");
  const std::vector<std::string> sets = {"solver.duration_s=5", "vehicle.battery.soc_initial=0.65"};
  ASSERT_EQ(ehpt_argv({"run", scenario, "--quiet", "--out", out.string(), "--set", sets[0], "--set", sets[1]}).exit_code, 0);
  ehpt::io::JsonValue summary;
  std::string error;
  ASSERT_TRUE(ehpt::io::parse_json(slurp((out / "summary.json").string()), summary, error)) << error;
  const ehpt::io::JsonValue* p = summary.find("provenance");
  ASSERT_NE(p, nullptr);
  const Result version = ehpt("--version");
  EXPECT_EQ(version.exit_code, 0);
  EXPECT_HAS(version.out, "ehpt " + p->find("ehpt_version")->text + " ");
  EXPECT_HAS(version.out, "flags: " + p->find("flags")->text + "\n");
  EXPECT_HAS(p->find("flags")->text, "-ffp-contract=off");
  EXPECT_HAS(version.out, "compiler: " + p->find("compiler")->text + "\n");
  EXPECT_EQ(ehpt("--version extra").exit_code, 1);

  // every file the run read, in the order read, hashed here independently
  const std::vector<std::string> expected = {scenario, ehpt::test::source_path("vehicles/mbev.toml"),
                                             ehpt::test::source_path("data/maps/map_evmaps_eff.csv"),
                                             ehpt::test::source_path("data/cycles/cycle_sort1.csv")};
  const auto& inputs = p->find("inputs")->items;
  ASSERT_EQ(inputs.size(), expected.size());
  std::string id_text = "ehpt-run-id 1\n";
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    EXPECT_EQ(fs::weakly_canonical(inputs[i].find("path")->text), fs::weakly_canonical(expected[i]));
    const std::string bytes = slurp(expected[i]);
    EXPECT_EQ(inputs[i].find("sha256")->text, ehpt::io::sha256_hex(bytes)) << expected[i];
    EXPECT_EQ(inputs[i].find("bytes")->text, std::to_string(bytes.size()));
    id_text += "input " + ehpt::io::sha256_hex(bytes) + " " + std::to_string(bytes.size()) + "\n";
  }
  const auto& overrides = p->find("overrides")->items;
  ASSERT_EQ(overrides.size(), 2u);
  EXPECT_EQ(overrides[0].text, sets[0]);
  EXPECT_EQ(overrides[1].text, sets[1]);
  for (const std::string& s : sets) id_text += "set " + s + "\n";
  EXPECT_EQ(p->find("run_id")->text, ehpt::io::sha256_hex(id_text));
}

TEST(Cli, RunTimeFaultKeepsOutputsAndExitsNonZero) {
  const fs::path out = ehpt::test::scratch_root() / "ehpt_cli_fault";
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
  const fs::path out = ehpt::test::scratch_root() / "ehpt_cli_warn";
  fs::remove_all(out);
  const Result r = ehpt("run " + ehpt::test::source_path("scenarios/two_flange_test.toml") + " --out " + out.string());
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_HAS(r.err, "test_mb_two_flange.toml:12: drive.speed_max_rad_s = 300: below power_max_W / torque_max_Nm");
}

TEST(Cli, PlotWritesTheFigures) {
  if (!have_matplotlib()) {
    GTEST_SKIP() << "/usr/bin/python3 with matplotlib and numpy is not installed (tools/setup.sh installs it)";
  }
  const fs::path out = ehpt::test::scratch_root() / "ehpt_cli_plot";
  fs::remove_all(out);
  const Result r = ehpt("run " + ehpt::test::source_path("scenarios/ev_sort1.toml") + " --quiet --plot --out " +
                        out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* png : {"speed.png", "torque.png", "power.png", "soc.png", "locked.png"}) {
    EXPECT_GT(fs::file_size(out / png), 10000u) << png;
  }
  const fs::path hybrid = ehpt::test::scratch_root() / "ehpt_cli_plot_hybrid";
  fs::remove_all(hybrid);
  ASSERT_EQ(ehpt("run " + ehpt::test::source_path("scenarios/psecu2_nedc.toml") +
                 " --set solver.duration_s=60 --quiet --plot --out " + hybrid.string())
                .exit_code,
            0);
  EXPECT_GT(fs::file_size(hybrid / "hybrid.png"), 10000u);
  EXPECT_GT(fs::file_size(hybrid / "hybrid_power.png"), 10000u);
  const fs::path rig = ehpt::test::scratch_root() / "ehpt_cli_plot_rig";
  fs::remove_all(rig);
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

// ---- output folders, the plot tool, signals and streams (issue 6) --------------------

// A number of summary.json by key (NaN, and a test failure, if it is not there).
double json_number(const std::string& summary, const std::string& key) {
  std::smatch found;
  if (!std::regex_search(summary, found, std::regex("\"" + key + "\": ([-0-9.e+]+)"))) {
    ADD_FAILURE() << "no number " << key << " in summary.json";
    return NAN;
  }
  return std::stod(found[1].str());
}

fs::path fresh(const std::string& name) {
  const fs::path p = ehpt::test::scratch_root() / ("ehpt_cli6_" + name);
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

// Waits (bounded) until path exists: the child has started its run.
bool wait_for(const fs::path& path, double seconds = 20.0) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < until) {
    if (fs::exists(path)) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return false;
}

// ~2 s of work on this machine: long enough to be interrupted or raced.
const std::vector<std::string> kLongRun = {"--set", "solver.step_s=0.0001", "--set", "output.interval_s=1"};

TEST(CliOutputs, AProjectFolderThatHoldsASummaryIsNeverReplaced) {
  const fs::path root = fresh("project");
  const fs::path project = root / "project";
  fs::create_directories(project / "src");
  std::ofstream(project / "src/main.c") << "int main() {}";
  std::ofstream(project / "README.txt") << "mine";
  std::ofstream(project / "summary.json") << "{}";
  const Result r = ehpt_argv({"run", ehpt::test::source_path("scenarios/ev_sort1.toml"), "--out", project.string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_HAS(r.err, "is not an earlier ehpt run (no ehpt-manifest.txt (no such file); it holds files ehpt did not "
                    "write: README.txt, src/, summary.json)");
  EXPECT_EQ(slurp((project / "src/main.c").string()), "int main() {}");
  EXPECT_EQ(slurp((project / "summary.json").string()), "{}");
  EXPECT_EQ(std::distance(fs::directory_iterator(root), fs::directory_iterator()), 1);  // nothing of ours left
}

TEST(CliOutputs, TheUsersPartialAndReplacedPathsAreNeverTouched) {
  const fs::path root = fresh("user_paths");
  const std::string out = (root / "run").string();
  fs::create_directories(out + ".partial");
  std::ofstream(out + ".partial/data.csv") << "mine";
  std::ofstream(out + ".replaced") << "mine too";
  const std::string sc = ehpt::test::source_path("scenarios/ev_sort1.toml");
  ASSERT_EQ(ehpt_argv({"run", sc, "--quiet", "--out", out}).exit_code, 0);
  ASSERT_EQ(ehpt_argv({"run", sc, "--quiet", "--out", out}).exit_code, 0);  // replaces the first
  EXPECT_EQ(slurp(out + ".partial/data.csv"), "mine");
  EXPECT_EQ(slurp(out + ".replaced"), "mine too");
  EXPECT_HAS(slurp(out + "/ehpt-manifest.txt"), "summary.json\ntimeseries.csv\n");
}

TEST(CliOutputs, TwoRunsOnOneFolderCannotMix) {
  const fs::path root = fresh("race");
  const std::string out = (root / "run").string();
  // A: a long EV run; B: the drive rig, started while A runs, must stop at once
  std::vector<std::string> a_args = {"run", ehpt::test::source_path("scenarios/ev_nedc.toml"), "--quiet", "--out", out};
  a_args.insert(a_args.end(), kLongRun.begin(), kLongRun.end());
  const pid_t a = spawn_ehpt(a_args, "a");
  ASSERT_TRUE(wait_for(out + ".ehpt-lock"));
  const Result b = ehpt_argv({"run", ehpt::test::source_path("scenarios/one_flange_test.toml"), "--out", out});
  const Result ra = wait_ehpt(a, "a");
  EXPECT_EQ(b.exit_code, 1);
  EXPECT_HAS(b.err, "another ehpt run is writing this folder");
  EXPECT_EQ(ra.exit_code, 0) << ra.err;
  // the committed folder is A's, whole: its summary and its timeseries
  EXPECT_HAS(slurp(out + "/summary.json"), "\"scenario\": \"ev_nedc\"");
  EXPECT_EQ(slurp(out + "/timeseries.csv").rfind("time_s,speed_ref_m_s,", 0), 0u);
  EXPECT_FALSE(fs::exists(out + ".ehpt-lock"));
  for (const auto& e : fs::directory_iterator(root)) {
    EXPECT_EQ(e.path().filename().string().find("partial"), std::string::npos) << e.path();
  }
}

TEST(CliOutputs, PlotRunsWithoutAShellWhateverTheFolderIsCalled) {
  if (!have_matplotlib()) GTEST_SKIP() << "/usr/bin/python3 with matplotlib and numpy is not installed";
  const fs::path root = fresh("quote");
  const fs::path pwned = root / "PWNED";
  // with a shell this name ran `touch PWNED`
  const std::string out = (root / ("it's a run'; touch " + pwned.string() + "; echo '")).string();
  const Result r = ehpt_argv({"run", ehpt::test::source_path("scenarios/one_flange_test.toml"), "--quiet", "--plot",
                              "--out", out});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(out + "/torque.png"));
  const Result p = ehpt_argv({"plot", out});
  EXPECT_EQ(p.exit_code, 0) << p.err;
  EXPECT_HAS(p.out, "wrote " + out + "/torque.png");
  EXPECT_FALSE(fs::exists(pwned));
  // the figures are in the manifest, so the folder is still an earlier run that may be replaced
  EXPECT_HAS(slurp(out + "/ehpt-manifest.txt"), "torque.png\n");
  EXPECT_EQ(ehpt_argv({"run", ehpt::test::source_path("scenarios/one_flange_test.toml"), "--quiet", "--out", out})
                .exit_code,
            0);
  EXPECT_FALSE(fs::exists(out + "/torque.png"));  // listed, hence removed with the earlier run
}

TEST(CliOutputs, AFailedPlotIsANonZeroExitAndKeepsTheRun) {
  const fs::path root = fresh("plotfail");
  fs::create_directories(root / "tools");
  std::ofstream(root / "tools/plot.py") << "import sys\nsys.exit(3)\n";
  const std::string out = (root / "run").string();
  const Result r = ehpt_argv({"run", ehpt::test::source_path("scenarios/one_flange_test.toml"), "--quiet", "--plot",
                              "--out", out},
                             {"EHPT_TOOLS_DIR=" + (root / "tools").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_HAS(r.err, "plotting failed (the plot tool exited with 3)");
  EXPECT_TRUE(fs::exists(out + "/timeseries.csv"));
  EXPECT_EQ(ehpt_argv({"plot", out}, {"EHPT_TOOLS_DIR=" + (root / "tools").string()}).exit_code, 1);
}

TEST(CliOutputs, PlotNeverOverwritesAUsersFileAndWaitsForNoRun) {
  if (!have_matplotlib()) GTEST_SKIP() << "/usr/bin/python3 with matplotlib and numpy is not installed";
  const fs::path root = fresh("plotmine");
  const std::string run = (root / "run").string();
  ASSERT_EQ(ehpt_argv({"run", ehpt::test::source_path("scenarios/one_flange_test.toml"), "--quiet", "--out", run})
                .exit_code,
            0);
  // a user's folder with a file of a figure's name: that file is kept, the others are drawn
  const fs::path mine = root / "mine";
  fs::create_directories(mine);
  fs::copy_file(run + "/timeseries.csv", mine / "timeseries.csv");
  std::ofstream(mine / "torque.png") << "my own figure";
  const Result p = ehpt_argv({"plot", mine.string()});
  EXPECT_EQ(p.exit_code, 1);
  EXPECT_HAS(p.err, "torque.png: exists and is not a figure ehpt made");
  EXPECT_EQ(slurp((mine / "torque.png").string()), "my own figure");
  EXPECT_TRUE(fs::exists(mine / "efficiency.png"));
  // while a run writes the folder, `ehpt plot` on it stops at once
  std::vector<std::string> args = {"run", ehpt::test::source_path("scenarios/ev_nedc.toml"), "--quiet", "--out", run};
  args.insert(args.end(), kLongRun.begin(), kLongRun.end());
  const pid_t writer = spawn_ehpt(args, "writer");
  ASSERT_TRUE(wait_for(run + ".ehpt-lock"));
  const Result busy = ehpt_argv({"plot", run});
  EXPECT_EQ(wait_ehpt(writer, "writer").exit_code, 0);
  EXPECT_EQ(busy.exit_code, 1);
  EXPECT_HAS(busy.err, "another ehpt run is writing this folder");
  EXPECT_HAS(slurp(run + "/summary.json"), "\"scenario\": \"ev_nedc\"");  // the run committed undisturbed
}

TEST(CliOutputs, FolderNamesThatLookLikeOptionsOrAreEmpty) {
  if (!have_matplotlib()) GTEST_SKIP() << "/usr/bin/python3 with matplotlib and numpy is not installed";
  const fs::path root = fresh("dash");
  // relative to the child's working folder: --out -run
  const Result r = wait_ehpt(spawn_ehpt({"run", ehpt::test::source_path("scenarios/one_flange_test.toml"), "--quiet",
                                         "--plot", "--out", "-run"},
                                        "dash", -1, {}, root.string()),
                             "dash");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(root / "-run/torque.png"));
  const Result empty = ehpt_argv({"run", ehpt::test::source_path("scenarios/one_flange_test.toml"), "--out", ""});
  EXPECT_EQ(empty.exit_code, 1);
  EXPECT_HAS(empty.err, "--out needs a folder name");
}

// A signal while loading or running never lets this run replace a complete earlier one.
TEST(CliOutputs, AnInterruptedRunKeepsTheEarlierRun) {
  const fs::path root = fresh("keep_earlier");
  const std::string out = (root / "run").string();
  ASSERT_EQ(ehpt_argv({"run", ehpt::test::source_path("scenarios/ev_sort1.toml"), "--quiet", "--out", out}).exit_code, 0);
  const std::string earlier = slurp(out + "/summary.json");
  // while the run steps (its lock is taken after loading): it stays in its own folder
  {
    std::vector<std::string> args = {"run", ehpt::test::source_path("scenarios/ev_nedc.toml"), "--out", out};
    args.insert(args.end(), kLongRun.begin(), kLongRun.end());
    const pid_t pid = spawn_ehpt(args, "running");
    ASSERT_TRUE(wait_for(out + ".ehpt-lock"));
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    kill(pid, SIGINT);
    const Result r = wait_ehpt(pid, "running");
    EXPECT_EQ(r.exit_code, 130) << r.err;
    EXPECT_EQ(slurp(out + "/summary.json"), earlier);
    EXPECT_HAS(r.err, "warning: the earlier run in " + out + " was kept; this run's outputs are in " + out + ".partial-");
    EXPECT_HAS(r.out, "outputs       " + out + ".partial-");
  }
  // a 2M-row cycle: the signal comes while it loads or while the run steps, either way
  {
    std::ofstream big(root / "big.csv");
    big << "time_s,speed_kmh\n";
    for (int i = 0; i < 2000000; ++i) big << i << ",0\n";
  }
  std::ofstream(root / "s.toml") << "vehicle_file = \"" << ehpt::test::source_path("vehicles/mbev.toml")
                                 << "\"\ncycle = \"big.csv\"\n[solver]\nduration_s = 20000\n";
  const pid_t pid = spawn_ehpt({"run", (root / "s.toml").string(), "--quiet", "--out", out}, "int");
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  kill(pid, SIGINT);
  const Result r = wait_ehpt(pid, "int");
  EXPECT_EQ(r.exit_code, 130) << r.err;
  EXPECT_EQ(slurp(out + "/summary.json"), earlier);  // was: replaced by a 0-step "interrupted" run
  EXPECT_FALSE(fs::exists(out + ".ehpt-lock"));
}

TEST(CliOutputs, SigtermAndSighupStopCleanlyWithTheirExitCodes) {
  for (const auto& [sig, code, name] : {std::tuple{SIGTERM, 143, "SIGTERM"}, std::tuple{SIGHUP, 129, "SIGHUP"},
                                        std::tuple{SIGINT, 130, "SIGINT"}}) {
    const fs::path root = fresh(std::string("signal_") + name);
    const std::string out = (root / "run").string();
    std::vector<std::string> args = {"run", ehpt::test::source_path("scenarios/ev_nedc.toml"), "--quiet", "--out", out};
    args.insert(args.end(), kLongRun.begin(), kLongRun.end());
    const pid_t pid = spawn_ehpt(args, name);
    ASSERT_TRUE(wait_for(out + ".ehpt-lock"));
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    kill(pid, sig);
    const Result r = wait_ehpt(pid, name);
    EXPECT_EQ(r.exit_code, code) << name << r.err;
    const std::string summary = slurp(out + "/summary.json");
    EXPECT_HAS(summary, "\"status\": \"interrupted\"");
    EXPECT_HAS(summary, std::string("\"interrupted_by\": \"") + name + "\"");
    EXPECT_GT(fs::file_size(out + "/timeseries.csv"), 100u);
  }
}

TEST(CliOutputs, AFailedStdoutWriteIsReportedAndAClosedPipeIsNot141) {
  const fs::path root = fresh("stdout");
  const std::string sc = ehpt::test::source_path("scenarios/ev_sort1.toml");
  const int full = open("/dev/full", O_WRONLY);
  ASSERT_GE(full, 0);
  Result r = wait_ehpt(spawn_ehpt({"run", sc, "--out", (root / "a").string()}, "full", full), "full");
  close(full);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_HAS(r.err, "cannot write to standard output: No space left on device");
  EXPECT_TRUE(fs::exists(root / "a/summary.json"));  // the run itself was committed
  int pipe_fds[2];
  ASSERT_EQ(pipe(pipe_fds), 0);
  close(pipe_fds[0]);  // nobody reads: like `ehpt run ... | head -0`
  r = wait_ehpt(spawn_ehpt({"run", sc, "--out", (root / "b").string()}, "pipe", pipe_fds[1]), "pipe");
  close(pipe_fds[1]);
  EXPECT_EQ(r.exit_code, 1);  // was 141 (killed by SIGPIPE after the commit)
  EXPECT_HAS(r.err, "cannot write to standard output: Broken pipe");
  EXPECT_TRUE(fs::exists(root / "b/summary.json"));
}

TEST(CliOutputs, AnEnergyAuditThatDoesNotCloseIsFlagged) {
  const fs::path root = fresh("audit");
  // implicit Euler (first order) at 0.2 s: the energy integrals drift by 2.7 %
  const Result r = ehpt_argv({"run", ehpt::test::source_path("scenarios/ev_sort1.toml"), "--set",
                              "solver.method=implicit-euler", "--set", "solver.step_s=0.2", "--set",
                              "vehicle.ecu.period_s=0.2", "--out",
                              (root / "run").string()});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_HAS(r.err, "warning: the energy audit does not close: relative residual 0.0265 > 0.001");
  EXPECT_HAS(r.err, "the step may be too coarse for the dynamics (solver.step_s = 0.2 s");
  const std::string summary = slurp((root / "run/summary.json").string());
  EXPECT_HAS(summary, "\"energy_balance_ok\": false");
  EXPECT_HAS(summary, "the energy audit does not close");
  const Result ok = ehpt_argv({"run", ehpt::test::source_path("scenarios/ev_sort1.toml"), "--out", (root / "ok").string()});
  EXPECT_EQ(ok.err.find("energy audit"), std::string::npos) << ok.err;
  EXPECT_HAS(slurp((root / "ok/summary.json").string()), "\"energy_balance_ok\": true");
}

TEST(CliOutputs, OutOfMemoryIsOneLineAndExitOne) {
  // a cycle that fits the size bound but not in 300 MB of address space once parsed
  const fs::path root = fresh("oom");
  {
    std::ofstream big(root / "big.csv");
    big << "time_s,speed_kmh\n";
    std::string chunk;
    for (int i = 0; i < 100000; ++i) chunk += "1,1\n";
    for (int i = 0; i < 150; ++i) big << chunk;  // 15e6 rows, 60 MB
  }
  std::ofstream(root / "s.toml") << "vehicle_file = \"" << ehpt::test::source_path("vehicles/mbev.toml")
                                 << "\"\ncycle = \"big.csv\"\n";
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const rlimit lim{300u << 20, 300u << 20};
    setrlimit(RLIMIT_AS, &lim);
    const int err = open((root / "err").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    dup2(err, STDERR_FILENO);
    execl(EHPT_BINARY, EHPT_BINARY, "run", (root / "s.toml").c_str(), "--out", (root / "run").c_str(), nullptr);
    _exit(127);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status)) << "killed by signal " << WTERMSIG(status);  // was: abort (134)
  EXPECT_EQ(WEXITSTATUS(status), 1);
  EXPECT_HAS(slurp((root / "err").string()), "error: out of memory");
  EXPECT_FALSE(fs::exists(root / "run"));
  for (const auto& e : fs::directory_iterator(root)) {
    EXPECT_EQ(e.path().filename().string().find("run."), std::string::npos) << e.path();
  }
}

// The battery rig through the binary: a constant-current discharge against its closed form
// (MODELS.md §6.1): E = E0 - I (1 + k) t / C_batt, v_rc = R1 I (1 + k) (1 - exp(-t / (R1 C1))).
TEST(CliBatteryRig, ConstantCurrentDischargeFollowsTheClosedForm) {
  const fs::path root = fresh("battery_rig");
  const std::string scenario = ehpt::test::source_path("scenarios/battery_cc_discharge.toml");
  const Result r = ehpt_argv({"run", scenario, "--quiet", "--out", (root / "run").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto sc = ehpt::test::load(scenario);
  const auto& rig = sc.plant.get<ehpt::plant::BatteryRigParams>();
  const ehpt::plant::BatteryRcConstants k = ehpt::plant::derive(rig.battery);
  ASSERT_EQ(rig.profile[0].kind, ehpt::plant::BatterySegment::Kind::kCurrent);
  const double current_A = rig.profile[0].value, end_s = rig.profile[0].duration_s;
  ASSERT_EQ(current_A, 100.0);
  ehpt::io::CsvTable t;
  std::vector<std::string> errors;
  ASSERT_TRUE(ehpt::io::read_csv_table((root / "run/timeseries.csv").string(), t, errors));
  const auto col = [&](const char* name) {
    const int c = t.column_index(name);
    EXPECT_GE(c, 0) << name;
    return t.columns[static_cast<std::size_t>(std::max(c, 0))];
  };
  const auto time = col("time_s"), emf = col("battery_emf_V"), vrc = col("battery_vrc_V"), v = col("battery_voltage_V");
  const auto i = col("battery_current_A"), soc = col("soc");
  const double i_m = current_A * (1.0 + k.k_parasitic), tau_s = k.r1_Ohm * k.c1_F;
  std::size_t checked = 0;
  for (std::size_t row = 0; row < t.rows() && time[row] < end_s; ++row) {
    const double s = time[row];
    const double e = k.emf_initial_V - i_m * s / k.c_batt_F;
    const double v_rc = k.r1_Ohm * i_m * (1.0 - std::exp(-s / tau_s));
    ASSERT_NEAR(emf[row], e, 1e-9 * e) << s;
    ASSERT_NEAR(vrc[row], v_rc, 1e-9) << s;
    ASSERT_NEAR(v[row], e - v_rc - k.r0_Ohm * current_A, 1e-9 * e) << s;
    ASSERT_EQ(i[row], current_A) << s;
    ASSERT_NEAR(soc[row], (e - k.emf_min_V) / (k.emf_max_V - k.emf_min_V), 1e-9) << s;
    ++checked;
  }
  EXPECT_EQ(checked, 1800u);
  // then the rest: E frozen, the RC block relaxes with tau = 60 s
  const std::size_t rest = 1800, later = 1860;
  ASSERT_EQ(time[later], 1860.0);
  EXPECT_EQ(i[rest], 0.0);
  EXPECT_EQ(emf[later], emf[rest]);
  EXPECT_NEAR(vrc[later], vrc[rest] * std::exp(-60.0 / tau_s), 1e-9);
  const std::string summary = slurp((root / "run/summary.json").string());
  EXPECT_HAS(summary, "\"energy_balance_ok\": true");
}

// Energy per km in summary.json against the last row of timeseries.csv (an independent
// computation): terminal energy, and EMF-side energy (terminal + battery losses), the figure
// the library tutorial reports (116 Wh/km for MBEV on NEDC).
TEST(CliSummary, WhPerKmAgreesWithTheTimeseries) {
  const fs::path root = fresh("wh_per_km");
  const Result r = ehpt_argv({"run", ehpt::test::source_path("scenarios/ev_tutorial_nedc.toml"), "--quiet", "--out",
                              (root / "run").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  ehpt::io::CsvTable t;
  std::vector<std::string> errors;
  ASSERT_TRUE(ehpt::io::read_csv_table((root / "run/timeseries.csv").string(), t, errors));
  const auto last = [&](const char* name) {
    const int c = t.column_index(name);
    EXPECT_GE(c, 0) << name;
    return t.columns[static_cast<std::size_t>(std::max(c, 0))].back();
  };
  EXPECT_EQ(last("time_s"), 1400.0);  // NEDC repeated to 1400 s
  const double km = last("distance_m") / 1000.0;
  const double terminal = last("battery_out_J") / 3600.0 / km;
  const double emf = (last("battery_out_J") + last("battery_loss_J")) / 3600.0 / km;
  const std::string summary = slurp((root / "run/summary.json").string());
  EXPECT_NEAR(json_number(summary, "battery_Wh_per_km"), terminal, 1e-9 * terminal);
  EXPECT_NEAR(json_number(summary, "battery_emf_Wh_per_km"), emf, 1e-9 * emf);
  EXPECT_NEAR(emf, 116.0, 0.5);
}

// ---- summary.json against an independent computation from timeseries.csv (issue 7) ------

// A timeseries written at every step, read back as columns by name.
struct Series {
  ehpt::io::CsvTable t;
  const std::vector<double>& operator[](const char* name) const {
    const int c = t.column_index(name);
    EXPECT_GE(c, 0) << name;
    return t.columns[static_cast<std::size_t>(std::max(c, 0))];
  }
};

Series every_step(const std::string& scenario, const std::string& signals, const std::string& duration,
                  const fs::path& out) {
  std::vector<std::string> args = {"run", ehpt::test::source_path(scenario), "--quiet", "--out", out.string(),
                                   "--set", "output.interval_s=0.001", "--set", "output.signals=" + signals};
  if (!duration.empty()) args.insert(args.end(), {"--set", "solver.duration_s=" + duration});
  const Result r = ehpt_argv(args);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  Series s;
  std::vector<std::string> errors;
  EXPECT_TRUE(ehpt::io::read_csv_table((out / "timeseries.csv").string(), s.t, errors));
  return s;
}

TEST(CliSummary, EveryMetricOfTheEvAgreesWithItsTimeseries) {
  const fs::path root = fresh("metrics_ev");
  const Series s = every_step("scenarios/ev_sort1.toml",
                              R"(["time_s","speed_ref_m_s","speed_m_s","distance_m","locked","battery_out_J"])", "",
                              root / "run");
  const auto& t = s["time_s"];
  ASSERT_EQ(t.size(), 150001u);  // every grid point of 150 s at 1 ms
  const double h = t[1] - t[0];
  double sq = 0.0, max_err = 0.0, locked_s = 0.0;
  for (std::size_t n = 0; n < t.size(); ++n) {
    const double e = 3.6 * (s["speed_ref_m_s"][n] - s["speed_m_s"][n]);  // km/h
    sq += e * e;
    max_err = std::max(max_err, std::abs(e));
    if (n > 0 && s["locked"][n] != 0.0) locked_s += h;  // locked at the end of step n
  }
  const std::string summary = slurp((root / "run/summary.json").string());
  const double km = s["distance_m"].back() / 1000.0;
  EXPECT_NEAR(json_number(summary, "distance_m"), s["distance_m"].back(), 1e-9);
  EXPECT_NEAR(json_number(summary, "speed_error_rms_kmh"), std::sqrt(sq / static_cast<double>(t.size())), 1e-9);
  EXPECT_NEAR(json_number(summary, "speed_error_max_kmh"), max_err, 1e-12);
  EXPECT_NEAR(json_number(summary, "locked_time_s"), locked_s, 1e-6);
  EXPECT_GT(locked_s, 10.0);  // Sort1 stands still between its three runs
  EXPECT_NEAR(json_number(summary, "battery_Wh_per_km"), s["battery_out_J"].back() / 3600.0 / km, 1e-9);
  EXPECT_NEAR(json_number(summary, "battery_energy_J"), s["battery_out_J"].back(), 1e-6);
  EXPECT_EQ(json_number(summary, "fuel_g"), 0.0);
}

TEST(CliSummary, EveryMetricOfTheHybridAgreesWithItsTimeseries) {
  const fs::path root = fresh("metrics_psd");
  // 300 s: standing, the urban part, the first engine start (145.5 s) and stop
  const Series s = every_step("scenarios/psecu2_nedc.toml",
                              R"(["time_s","speed_ref_m_s","speed_m_s","distance_m","locked","iceON","fuel_g"])", "300",
                              root / "run");
  const auto& t = s["time_s"];
  ASSERT_EQ(t.size(), 300001u);
  const double h = t[1] - t[0];
  double sq = 0.0, max_err = 0.0, locked_s = 0.0, on_s = 0.0;
  int starts = s["iceON"][0] != 0.0 ? 1 : 0;
  for (std::size_t n = 0; n < t.size(); ++n) {
    const double e = 3.6 * (s["speed_ref_m_s"][n] - s["speed_m_s"][n]);
    sq += e * e;
    max_err = std::max(max_err, std::abs(e));
    if (n > 0 && s["locked"][n] != 0.0) locked_s += h;
    if (n + 1 < t.size() && s["iceON"][n] != 0.0) on_s += h;  // on during the step that starts at n
    if (n > 0 && s["iceON"][n] != 0.0 && s["iceON"][n - 1] == 0.0) ++starts;
  }
  const std::string summary = slurp((root / "run/summary.json").string());
  const double fuel_g = s["fuel_g"].back() - s["fuel_g"].front();
  const double litres = fuel_g / 1000.0 / 745.0 * 1000.0;  // gasoline at 745 kg/m^3 (psecu2.toml)
  EXPECT_NEAR(json_number(summary, "speed_error_rms_kmh"), std::sqrt(sq / static_cast<double>(t.size())), 1e-9);
  EXPECT_NEAR(json_number(summary, "speed_error_max_kmh"), max_err, 1e-12);
  EXPECT_NEAR(json_number(summary, "locked_time_s"), locked_s, 1e-6);
  EXPECT_NEAR(json_number(summary, "fuel_g"), fuel_g, 1e-9);
  EXPECT_NEAR(json_number(summary, "fuel_L_per_100km"), litres / (s["distance_m"].back() / 1e5), 1e-9);
  EXPECT_NEAR(json_number(summary, "ice_on_time_s"), on_s, 1e-6);
  EXPECT_EQ(json_number(summary, "ice_starts"), starts);
  EXPECT_GT(on_s, 10.0);
  EXPECT_EQ(starts, 1);  // 145.5 s; the second start (334.7 s) is after the 300 s
}

// One run per fault bit, each raised deliberately: exit 3, the fault named in summary.json
// and on the terminal, the outputs kept.
TEST(CliFaults, EachFaultBitStopsTheRunWithItsOwnText) {
  const fs::path root = fresh("faults");
  struct Case {
    const char* name;
    std::string scenario;
    std::vector<std::string> sets;
    const char* text;
  };
  const std::vector<Case> cases = {
      {"soc", "scenarios/ev_sort1.toml", {"vehicle.battery.soc_min=0.6999"}, "SOC left [soc_min, soc_max] at t = "},
      {"current",
       "scenarios/ev_sort1.toml",
       {"vehicle.battery.cell_current_max_A=20", "vehicle.battery.r0_cell_Ohm=2.075e-4",
        "vehicle.battery.cell_current_efficiency_A=500"},
       "cell current reached cell_current_max_A at t = 4.097 s (step 4097)"},
      {"power",
       "scenarios/ev_sort1.toml",
       {"vehicle.battery.r0_cell_Ohm=0.05", "vehicle.battery.cell_current_efficiency_A=1"},
       "the drive asked for more power than the battery can give at t = 3.913"},
      {"nonfinite",
       "scenarios/one_flange_test.toml",
       {"vehicle.drive.inertia_kgm2=1e-300", "vehicle.load.inertia_kgm2=0"},
       "non-finite state (NaN or Inf) at t = 0.001 s (step 1)"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> args = {"run", ehpt::test::source_path(c.scenario), "--out", (root / c.name).string()};
    for (const auto& s : c.sets) args.insert(args.end(), {"--set", s});
    const Result r = ehpt_argv(args);
    EXPECT_EQ(r.exit_code, 3) << c.name << r.err;
    EXPECT_HAS(r.out, std::string("FAULT         ") + c.text);
    const std::string summary = slurp((root / c.name / "summary.json").string());
    EXPECT_HAS(summary, "\"status\": \"fault\"");
    EXPECT_HAS(summary, std::string("\"fault\": \"") + c.text);
    EXPECT_HAS(summary, "\"fault_steps\": 1");  // the run stopped at it
    EXPECT_TRUE(fs::exists(root / c.name / "timeseries.csv")) << c.name;
  }
}

// Charging past soc_max is a fault too, at the first grid point past the closed-form time
// t = (soc_max - soc_0) Q / (I (1 - k)) of a constant-current charge (MODELS.md §6.1).
TEST(CliFaults, ChargingAboveSocMaxStopsTheRunWhenTheClosedFormSays) {
  const fs::path root = fresh("soc_max");
  const std::string scenario = ehpt::test::source_path("scenarios/battery_cc_discharge.toml");
  const std::vector<std::string> sets = {"vehicle.battery.soc_initial=0.9", "vehicle.battery.soc_max=0.95",
                                         "vehicle.profile=[{current_A = -100.0, duration_s = 400.0}]"};
  std::vector<std::string> args = {"run", scenario, "--out", (root / "run").string()};
  for (const auto& s : sets) args.insert(args.end(), {"--set", s});
  const Result r = ehpt_argv(args);
  EXPECT_EQ(r.exit_code, 3) << r.err;
  const auto sc = ehpt::test::load(scenario, sets);
  const auto k = ehpt::plant::derive(sc.plant.get<ehpt::plant::BatteryRigParams>().battery);
  const double charge_As = 0.05 * k.c_batt_F * (k.emf_max_V - k.emf_min_V);
  const double t_full = charge_As / (100.0 * (1.0 - k.k_parasitic));
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.out, m, std::regex("FAULT         SOC left \\[soc_min, soc_max\\] at t = ([0-9.]+) s")))
      << r.out;
  const double t_fault = std::stod(m[1].str());
  EXPECT_GT(t_fault, t_full);
  EXPECT_LE(t_fault, t_full + 1e-3 + 1e-9);
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  return lines;
}

// The real-time loop gives the batch run's trajectory bit for bit, with its timing figures;
// a tick of two steps too; and no heap allocation after start-up in either.
TEST(CliRealtime, TheRealTimeLoopGivesTheBatchTrajectoryBitForBit) {
  const fs::path root = fresh("rt_identical");
  const std::string sc = ehpt::test::source_path("scenarios/ev_sort1.toml");
  const std::vector<std::string> short_run = {"--set", "solver.duration_s=1.5", "--set", "output.interval_s=0.001"};
  const auto run = [&](const std::string& name, std::vector<std::string> extra) {
    std::vector<std::string> args = {"run", sc, "--quiet", "--out", (root / name).string()};
    args.insert(args.end(), short_run.begin(), short_run.end());
    args.insert(args.end(), extra.begin(), extra.end());
    const Result r = ehpt_argv(args);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return r;
  };
  run("batch", {});
  run("rt", {"--realtime"});
  run("rt2", {"--realtime", "--period", "2ms", "--priority", "50", "--cpu", "0"});
  const std::string batch = slurp((root / "batch/timeseries.csv").string());
  EXPECT_EQ(lines_of(batch).size(), 1502u);  // header + 1501 rows: every row went through the writer thread
  EXPECT_EQ(slurp((root / "rt/timeseries.csv").string()), batch);
  EXPECT_EQ(slurp((root / "rt2/timeseries.csv").string()), batch);
  const std::string sb = slurp((root / "batch/summary.json").string());
  const std::string s1 = slurp((root / "rt/summary.json").string());
  const std::string s2 = slurp((root / "rt2/summary.json").string());
  const std::regex hash("\"trajectory_hash\": \"([0-9a-f]{16})\"");
  std::smatch mb, m1;
  ASSERT_TRUE(std::regex_search(sb, mb, hash)) << sb;
  ASSERT_TRUE(std::regex_search(s1, m1, hash)) << s1;
  EXPECT_EQ(mb[1], m1[1]);
  EXPECT_EQ(sb.find("\"realtime\": {"), std::string::npos);
  EXPECT_EQ(json_number(s1, "ticks"), 1500);
  EXPECT_EQ(json_number(s1, "steps_per_tick"), 1);
  EXPECT_EQ(json_number(s2, "ticks"), 750);
  EXPECT_EQ(json_number(s2, "steps_per_tick"), 2);
  EXPECT_EQ(json_number(s2, "period_s"), 0.002);
  EXPECT_HAS(s2, "\"cpu\": 0");
  for (const std::string* s : {&s1, &s2}) {
    EXPECT_EQ(json_number(*s, "heap_allocations_after_startup"), 0) << *s;
    EXPECT_EQ(json_number(*s, "queue_rows_dropped"), 0);
    EXPECT_GE(json_number(*s, "realtime_factor"), 0.9);  // paced: about 1, never thousands
    EXPECT_LE(json_number(*s, "realtime_factor"), 1.1);
    for (const char* key : {"wakeup_latency_us", "compute_us", "io_us"}) EXPECT_HAS(*s, std::string("\"") + key + "\": {");
    EXPECT_GT(json_number(*s, "p50"), 0.0);  // the wake-up latency: never exactly zero on a real clock
    EXPECT_LE(json_number(*s, "p50"), json_number(*s, "p99"));
    EXPECT_LE(json_number(*s, "p99"), json_number(*s, "p99_9"));
    EXPECT_TRUE(s->find("\"scheduler\": \"SCHED_FIFO\"") != std::string::npos ||
                s->find("SCHED_FIFO priority") != std::string::npos)  // granted, or a warning with the reason
        << *s;
  }
  EXPECT_EQ(json_number(sb, "heap_allocations_after_startup"), 0);
}

// Ctrl-C ends a real-time run at the next tick: exit 130, every row computed is written, the
// rows are the batch run's, and the figures are in summary.json.
TEST(CliRealtime, CtrlCEndsARealTimeRunWithEveryRowWritten) {
  const fs::path root = fresh("rt_ctrl_c");
  const std::string sc = ehpt::test::source_path("scenarios/ev_nedc.toml");
  const std::string out = (root / "rt").string();
  const pid_t pid = spawn_ehpt({"run", sc, "--quiet", "--realtime", "--out", out, "--set", "output.interval_s=0.01"}, "rt");
  ASSERT_TRUE(wait_for(out + ".ehpt-lock"));
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  kill(pid, SIGINT);
  const auto t0 = std::chrono::steady_clock::now();
  const Result r = wait_ehpt(pid, "rt");
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
  EXPECT_EQ(r.exit_code, 130) << r.err;
  const std::string summary = slurp(out + "/summary.json");
  EXPECT_HAS(summary, "\"status\": \"interrupted\"");
  const double steps = json_number(summary, "steps");
  EXPECT_GT(steps, 500);
  EXPECT_LT(steps, 100000);
  const std::vector<std::string> rt = lines_of(slurp(out + "/timeseries.csv"));
  // header, a row every 10 steps from step 0, and the row of the state reached
  const auto grid_rows = static_cast<std::size_t>(steps) / 10 + 1;
  EXPECT_TRUE(rt.size() == 1 + grid_rows + 1 || rt.size() == 1 + grid_rows) << rt.size() << " " << steps;
  ASSERT_EQ(ehpt_argv({"run", sc, "--quiet", "--out", (root / "batch").string(), "--set", "output.interval_s=0.01",
                       "--set", "solver.duration_s=" + std::to_string(steps * 0.001 + 1)})
                .exit_code,
            0);
  const std::vector<std::string> batch = lines_of(slurp((root / "batch/timeseries.csv").string()));
  ASSERT_GT(batch.size(), grid_rows);
  for (std::size_t i = 0; i < grid_rows + 1; ++i) ASSERT_EQ(rt[i], batch[i]) << "line " << i;
}

TEST(CliRealtime, BadRealTimeOptionsAreNamed) {
  const std::string sc = ehpt::test::source_path("scenarios/ev_sort1.toml");
  const fs::path root = fresh("rt_bad");
  const std::string out = (root / "never").string();
  const auto bad = [&](std::vector<std::string> extra, int code, const std::string& message) {
    std::vector<std::string> args = {"run", sc, "--out", out};
    args.insert(args.end(), extra.begin(), extra.end());
    const Result r = ehpt_argv(args);
    EXPECT_EQ(r.exit_code, code) << r.err;
    EXPECT_HAS(r.err, message);
    EXPECT_FALSE(fs::exists(out));
  };
  bad({"--realtime", "--period", "1.5ms"}, 2, "--period 0.0015 s: must be a whole number of solver steps (solver.step_s = 0.001 s)");
  bad({"--realtime", "--period", "abc"}, 1, "--period abc: must be a duration");
  bad({"--realtime", "--period", "20s"}, 1, "--period 20s: must be a duration between 1us and 10s");
  bad({"--realtime", "--period", "-1ms"}, 1, "--period -1ms");
  bad({"--realtime", "--priority", "0"}, 1, "--priority 0: must be a whole number from 1 to 99");
  bad({"--realtime", "--priority", "100"}, 1, "--priority 100");
  bad({"--realtime", "--cpu", "4095"}, 1, "--cpu 4095: not a CPU this process may run on (");
  bad({"--realtime", "--cpu", "-1"}, 1, "--cpu -1: must be a whole number");
  bad({"--realtime", "--cpu"}, 1, "--cpu needs a value");
  bad({"--period", "1ms"}, 1, "--period, --cpu and --priority belong to --realtime");
  const Result r = ehpt_argv({"plant", sc, "--bus", "socketcand:127.0.0.1:1", "--lockstep", "--realtime", "--out", out});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_HAS(r.err, "--realtime and --lockstep");
  EXPECT_FALSE(fs::exists(out));
}

// A TCP port on 127.0.0.1 that was free a moment ago (the plant listens there next).
int free_port() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = 0;
  socklen_t len = sizeof a;
  if (fd < 0 || bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
      getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) != 0) {
    ADD_FAILURE() << "no free port";
  }
  close(fd);
  return ntohs(a.sin_port);
}

// One bus session: `ehpt plant` with extra options and `ehpt ecu` as its ECU over socketcand.
Result bus_session(const std::string& scenario, const std::string& out, std::vector<std::string> plant_extra,
                   const std::string& tag, int interrupt_after_ms = 0, std::vector<std::string> ecu_extra = {}) {
  const std::string bus = "socketcand:127.0.0.1:" + std::to_string(free_port());
  std::vector<std::string> plant = {"plant", scenario, "--bus", bus, "--quiet", "--out", out};
  plant.insert(plant.end(), plant_extra.begin(), plant_extra.end());
  const pid_t p = spawn_ehpt(plant, tag + "_plant");
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // listening
  std::vector<std::string> ecu = {"ecu", scenario, "--bus", bus, "--quiet"};
  for (std::size_t i = 0; i + 1 < plant_extra.size(); ++i) {
    if (plant_extra[i] == "--set") ecu.insert(ecu.end(), {"--set", plant_extra[i + 1]});
  }
  ecu.insert(ecu.end(), ecu_extra.begin(), ecu_extra.end());
  const pid_t e = spawn_ehpt(ecu, tag + "_ecu");
  if (interrupt_after_ms > 0) {
    std::this_thread::sleep_for(std::chrono::milliseconds(interrupt_after_ms));
    kill(p, SIGINT);
  }
  const Result r = wait_ehpt(p, tag + "_plant");
  wait_ehpt(e, tag + "_ecu");
  return r;
}

std::string hash_of(const std::string& summary) {
  std::smatch m;
  static const std::regex hash("\"trajectory_hash\": \"([0-9a-f]{16})\"");
  return std::regex_search(summary, m, hash) ? m[1].str() : "";
}

// A wall-clock and a real-time session on the bus, each replayed offline: the same
// trajectory bit for bit (hash and timeseries.csv); an interrupted session too.
// A replay never writes into the session it reads, a folder inside it, or another recorded
// session: each is refused (exit 2) before anything runs, and every file there is unchanged.
TEST(CliReplay, NeverWritesIntoASessionFolder) {
  const fs::path root = fresh("replay_guard");
  const std::string scenario = ehpt::test::source_path("scenarios/ev_sort1.toml");
  const std::string a = (root / "a").string(), b = (root / "b").string();
  ASSERT_EQ(bus_session(scenario, a, {"--set", "solver.duration_s=1"}, "guard_a", 0, {}).exit_code, 0);
  ASSERT_EQ(bus_session(scenario, b, {"--set", "solver.duration_s=1"}, "guard_b", 0, {}).exit_code, 0);
  const auto files_of = [](const std::string& dir) {
    std::map<std::string, std::string> files;
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
      if (e.is_regular_file()) files[e.path().string()] = slurp(e.path().string());
    }
    return files;
  };
  const auto before_a = files_of(a), before_b = files_of(b);
  ASSERT_TRUE(before_a.count(a + "/inputs.log") && before_a.count(a + "/bus.log"));
  struct Case {
    std::string out, says;
  };
  for (const Case& c : std::vector<Case>{{a, "is the session folder the replay reads"},
                                         {a + "/", "is the session folder the replay reads"},
                                         {root.string() + "/./a", "is the session folder the replay reads"},
                                         {a + "/replay", "is inside the session folder the replay reads"},
                                         {b, "holds a recorded bus session (its inputs.log)"}}) {
    const Result r = ehpt_argv({"replay", a, "--out", c.out});
    EXPECT_EQ(r.exit_code, 2) << c.out << r.out;
    EXPECT_HAS(r.err, "error: --out " + c.out + " " + c.says + ": a replay never writes there");
    EXPECT_EQ(r.out.find("bit-identical"), std::string::npos) << c.out;
  }
  // the default folder is refused too when a session sits there
  const Result in_place = ehpt_argv({"replay", a + "/inputs.log", "--out", a});
  EXPECT_EQ(in_place.exit_code, 2);
  EXPECT_TRUE(files_of(a) == before_a) << "the session's files changed";
  EXPECT_TRUE(files_of(b) == before_b) << "the other session's files changed";
  EXPECT_FALSE(fs::exists(a + "/replay"));
  // and a folder of its own works
  EXPECT_EQ(ehpt_argv({"replay", a, "--out", (root / "own").string(), "--quiet"}).exit_code, 0);
}

TEST(CliReplay, ARecordedSessionReplaysBitForBit) {
  const fs::path root = fresh("replay");
  struct Case {
    const char* name;
    std::string scenario;
    std::vector<std::string> extra;
    int interrupt_ms;
    std::vector<std::string> ecu_extra = {};
  };
  const std::vector<Case> cases = {
      {"wall_psd", ehpt::test::source_path("scenarios/psecu2_nedc.toml"), {"--set", "solver.duration_s=3"}, 0},
      {"rt_ev", ehpt::test::source_path("scenarios/ev_sort1.toml"), {"--realtime", "--set", "solver.duration_s=2"}, 0},
      {"int_ev", ehpt::test::source_path("scenarios/ev_nedc.toml"), {"--set", "output.interval_s=0.01"}, 1500},
      // the ECU stops answering after 120 samples: the safe state's commands are in the log too
      {"timeout_psd", ehpt::test::source_path("scenarios/psecu2_nedc.toml"), {"--set", "solver.duration_s=3"}, 0,
       {"--max-samples", "120"}},
  };
  for (const Case& c : cases) {
    const std::string session = (root / c.name).string();
    const Result s = bus_session(c.scenario, session, c.extra, c.name, c.interrupt_ms, c.ecu_extra);
    // an ECU that stops answering makes the session degraded (exit 4); it replays all the same
    const bool silent_ecu = !c.ecu_extra.empty();
    ASSERT_EQ(s.exit_code, c.interrupt_ms > 0 ? 130 : silent_ecu ? 4 : 0) << c.name << s.err;
    const std::string log = slurp(session + "/inputs.log");
    EXPECT_HAS(log, "# ehpt inputs log 1\n# scenario " + c.scenario + "\n");
    EXPECT_GT(lines_of(log).size(), 50u) << c.name;
    const Result r = ehpt_argv({"replay", session, "--out", session + "_replay"});
    EXPECT_EQ(r.exit_code, 0) << c.name << r.err << r.out;
    EXPECT_HAS(r.out, "bit-identical to the session in " + session);
    const std::string a = slurp(session + "/summary.json"), b = slurp(session + "_replay/summary.json");
    EXPECT_EQ(hash_of(a), hash_of(b)) << c.name;
    EXPECT_EQ(json_number(a, "steps"), json_number(b, "steps")) << c.name;
    EXPECT_TRUE(slurp(session + "/timeseries.csv") == slurp(session + "_replay/timeseries.csv")) << c.name;
    // provenance: the session's commands came from a bus ECU, the replay's from its log, whose
    // bytes are an input like the scenario's files: neither has a plain run's id
    ehpt::io::JsonValue ja, jb;
    std::string error;
    ASSERT_TRUE(ehpt::io::parse_json(a, ja, error) && ehpt::io::parse_json(b, jb, error)) << error;
    const ehpt::io::JsonValue &pa = *ja.find("provenance"), &pb = *jb.find("provenance");
    EXPECT_EQ(pa.find("commands")->text.rfind("external ECU over ", 0), 0u) << pa.find("commands")->text;
    EXPECT_EQ(pb.find("commands")->text, "replay of " + session + "/inputs.log");
    const auto& log_input = pb.find("inputs")->items.back();
    EXPECT_EQ(log_input.find("path")->text, session + "/inputs.log");
    EXPECT_EQ(log_input.find("sha256")->text, ehpt::io::sha256_hex(log));
    EXPECT_EQ(pb.find("inputs")->items.size(), pa.find("inputs")->items.size() + 1);
    EXPECT_NE(pa.find("run_id")->text, pb.find("run_id")->text);
    if (c.interrupt_ms > 0) {
      EXPECT_LT(json_number(a, "steps"), 500000) << "interrupted early";
    }
    if (!c.ecu_extra.empty()) {
      EXPECT_GE(json_number(a, "timeouts"), 1) << a;  // the safe state was entered
      EXPECT_GT(json_number(a, "safe_state_time_s"), 1.0) << a;
    }
  }
  // the replay uses the commands: one torque changed in the log is a different trajectory (exit 1)
  const std::string src = (root / "rt_ev").string(), tampered = (root / "tampered").string();
  fs::create_directories(tampered);
  fs::copy_file(src + "/summary.json", tampered + "/summary.json");
  std::vector<std::string> lines = lines_of(slurp(src + "/inputs.log"));
  std::string& line = lines[lines.size() / 2];
  const auto last_space = line.rfind(' ');
  line = line.substr(0, last_space) + " 12.5";
  {
    std::ofstream f(tampered + "/inputs.log");
    for (const auto& l : lines) f << l << "\n";
  }
  const Result t = ehpt_argv({"replay", tampered, "--out", tampered + "_replay"});
  EXPECT_EQ(t.exit_code, 1) << t.err;
  EXPECT_HAS(t.out, "DIFFERS from the session");
  EXPECT_HAS(t.err, "the replay's trajectory differs");
}

TEST(CliReplay, ABadLogIsNamedWithItsLineAndNothingRuns) {
  const fs::path root = fresh("replay_bad");
  const std::string dir = (root / "s").string();
  fs::create_directories(dir);
  std::ofstream(dir + "/summary.json") << "{\n  \"steps\": 100,\n  \"trajectory_hash\": \"0000000000000000\"\n}\n";
  const std::string sc = ehpt::test::source_path("scenarios/ev_sort1.toml");
  const auto bad = [&](const std::string& log, int code, const std::string& message) {
    std::ofstream(dir + "/inputs.log") << log;
    const Result r = ehpt_argv({"replay", dir, "--out", (root / "never").string()});
    EXPECT_EQ(r.exit_code, code) << r.err;
    EXPECT_HAS(r.err, message);
    EXPECT_FALSE(fs::exists(root / "never"));
  };
  const std::string head = "# ehpt inputs log 1\n# scenario " + sc + "\n# family ev\n# pacing wall_clock\n";
  bad(head + "ev 0 0 0 0 1.5\nev 10 1 10 0.01 nan\n", 2, dir + "/inputs.log:6: 'nan' is not a finite number");
  bad(head + "ev 20 0 0 0 1.5\nev 10 1 10 0.01 2\n", 2, dir + "/inputs.log:6: step 10 before the previous command's 20");
  bad(head + "ev 0 0 0 0\n", 2, dir + "/inputs.log:5: expected 6 fields");
  bad(head + "psd 0 0 0 0 1 2 3 4 1\n", 2, "a command of family 'psd' (the log's family is 'ev')");
  // counts that do not fit their field, and a line no command needs (the reader's buffer)
  bad(head + "ev 0 4294967296 0 0 1.5\n", 2, dir + "/inputs.log:5: expected FAMILY STEP SEQUENCE STAMP_STEP");
  bad(head + "ev -10 0 0 0 1.5\n", 2, dir + "/inputs.log:5: expected FAMILY STEP SEQUENCE STAMP_STEP");
  bad(head + "ev 99999999999999999999 0 0 0 1.5\n", 2, dir + "/inputs.log:5: expected FAMILY STEP SEQUENCE STAMP_STEP");
  bad(head + "ev 0 0 0 0 1.5 2.5\n", 2, dir + "/inputs.log:5: expected 6 fields");
  bad(head + "ev 0 0 0 0 1e999\n", 2, dir + "/inputs.log:5: '1e999' is not a finite number");
  bad(head + "ev 0 0 0 0 " + std::string(9000, '1') + "\nev 10 0 0 0 x\n", 2,
      dir + "/inputs.log:5: a line longer than 8192 bytes");
  bad(head + "ev 0 0 0 0 " + std::string(9000, '1') + "\nev 10 0 0 0 x\n", 2, dir + "/inputs.log:6: 'x' is not");
  bad("hello\n", 2, "not an ehpt inputs log");
  bad("# ehpt inputs log 1\n# scenario " + ehpt::test::source_path("scenarios/psecu2_nedc.toml") + "\n# family ev\n", 2,
      "its commands are of family 'ev' but");
  bad("# ehpt inputs log 1\n# scenario " + ehpt::test::source_path("scenarios/battery_cc_discharge.toml") + "\n# family ev\n", 2,
      "has no bus messages");
  // the header comes first and says each thing once
  bad(head + "ev 0 0 0 0 1.5\n# family psd\n", 2, dir + "/inputs.log:6: '# family' after the commands: the header comes before them");
  bad(head + "ev 0 0 0 0 1.5\n# set solver.step_s=0.002\n", 2, dir + "/inputs.log:6: '# set' after the commands");
  bad("# ehpt inputs log 1\n# scenario " + sc + "\n# family ev\n# family psd\n", 2,
      dir + "/inputs.log:4: a second '# family' line (the first said 'ev')");
  // a log saved with CRLF line ends reads as the same log (it was "family 'ev' vs 'ev'")
  std::string crlf = head + "ev 0 0 0 0\n";
  for (std::size_t at = 0; (at = crlf.find('\n', at)) != std::string::npos; at += 2) crlf.replace(at, 1, "\r\n");
  bad(crlf, 2, dir + "/inputs.log:5: expected 6 fields");
  std::string crlf_good = head + "ev 0 0 0 0 1.5\n";
  for (std::size_t at = 0; (at = crlf_good.find('\n', at)) != std::string::npos; at += 2) crlf_good.replace(at, 1, "\r\n");
  std::ofstream(dir + "/inputs.log") << crlf_good;
  const Result ran = ehpt_argv({"replay", dir, "--out", (root / "crlf").string()});
  EXPECT_EQ(ran.exit_code, 1) << ran.err;  // it ran: the hash differs from the dummy summary's
  EXPECT_HAS(ran.out, "DIFFERS from the session");
  // a FIFO in its place (no writer): refused at once, never waited on
  fs::remove(dir + "/inputs.log");
  ASSERT_EQ(::mkfifo((dir + "/inputs.log").c_str(), 0600), 0);
  const Result fifo = ehpt_argv({"replay", dir, "--out", (root / "never").string()});
  EXPECT_EQ(fifo.exit_code, 2) << fifo.err;
  EXPECT_HAS(fifo.err, dir + "/inputs.log: cannot read (not a regular file)");
  EXPECT_FALSE(fs::exists(root / "never"));
  fs::remove(dir + "/inputs.log");
  const Result r = ehpt_argv({"replay", dir});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_HAS(r.err, dir + "/inputs.log: ");
}

// A folder called like a scenario (its own output folder, after 'cd out') does not hide
// the scenario's name; a folder that is no scenario's name is still refused as a folder.
TEST(CliOutputs, AFolderNamedLikeAScenarioDoesNotHideIt) {
  const fs::path root = fresh("shadow");
  fs::create_directories(root / "ev_sort1");
  fs::create_directories(root / "not_a_scenario");
  const pid_t pid = spawn_ehpt({"run", "ev_sort1", "--quiet", "--out", (root / "run").string(), "--set",
                                "solver.duration_s=1", "--set", "output.interval_s=0.5"},
                               "shadow", -1, {}, root.string());
  const Result r = wait_ehpt(pid, "shadow");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_HAS(slurp((root / "run/summary.json").string()), "\"scenario\": \"ev_sort1\"");
  const pid_t pid2 = spawn_ehpt({"run", "not_a_scenario", "--quiet", "--out", (root / "run2").string()}, "shadow2", -1,
                                {}, root.string());
  const Result r2 = wait_ehpt(pid2, "shadow2");
  EXPECT_EQ(r2.exit_code, 2);
  EXPECT_HAS(r2.err, "not_a_scenario: is a folder, not a scenario file");
}


// ---- the help texts and the summary line (issue 21) --------------------------------------

// The "--set key=value" examples of a help text, as a shell would pass them ('...' unquoted).
std::vector<std::string> set_examples(const std::string& help) {
  std::vector<std::string> sets;
  const std::regex example(R"(--set ('[^']+'|[^ \n]+))");
  for (std::sregex_iterator it(help.begin(), help.end(), example), end; it != end; ++it) {
    std::string v = (*it)[1].str();
    if (v.front() == '\'') v = v.substr(1, v.size() - 2);
    if (v != "key=value") sets.push_back(v);
  }
  return sets;
}

// Every key 'ehpt run --help' shows is one the loader takes, with the value shown: all of them
// at once on the shipped hybrid run (exit 0), each changing what summary.json records.
TEST(CliHelp, EveryKeyTheRunHelpShowsIsTakenAsShown) {
  const Result help = ehpt("run --help");
  ASSERT_EQ(help.exit_code, 0);
  const std::vector<std::string> sets = set_examples(help.out);
  // the keys the docs and the issue name (docs/cli.md, docs/scenarios.md)
  for (const char* key : {"solver.method=", "solver.step_s=", "solver.duration_s=", "output.interval_s=",
                          "output.signals=", "output.timeseries=false", "vehicle.battery.soc_initial=",
                          "vehicle.vehicle.mass_kg=", "vehicle.ecu.soc_ref="}) {
    EXPECT_TRUE(std::any_of(sets.begin(), sets.end(), [&](const std::string& v) { return v.starts_with(key); }))
        << key << " is not in 'ehpt run --help':\n" << help.out;
  }
  EXPECT_HAS(help.out, "docs/scenarios.md");
  EXPECT_HAS(help.out, "'ehpt signals'");
  const fs::path root = fresh("run_help_keys");
  std::vector<std::string> argv{"run", "psecu2_nedc", "--quiet", "--out", (root / "run").string()};
  for (const std::string& v : sets) {
    argv.push_back("--set");
    argv.push_back(v);
  }
  const Result r = ehpt_argv(argv);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string summary = slurp((root / "run/summary.json").string());
  for (const std::string& v : sets) EXPECT_HAS(summary, ehpt::io::json_escape(v));  // the overrides, recorded
  EXPECT_FALSE(fs::exists(root / "run/timeseries.csv"));                           // output.timeseries=false
  EXPECT_HAS(summary, "\"implicit-euler\"");
}

// docs/cli.md quotes each command's help: the quote is the help (the line naming this ehpt's
// own folder aside, which differs between the build folder and an installed ehpt).
TEST(CliHelp, TheDocsQuoteEachHelpAsPrinted) {
  const std::string doc = slurp(ehpt::test::source_path("docs/cli.md"));
  int compared = 0;
  for (const char* cmd : {"run", "plant", "ecu", "replay", "list", "signals", "plot", "sweep", "bench", "dbc", "test", "fmu"}) {
    const std::string heading = std::string("### ehpt ") + cmd + "\n\n```\n";
    const std::size_t at = doc.find(heading);
    if (at == std::string::npos) continue;
    const std::size_t begin = at + heading.size();
    const std::string quoted = doc.substr(begin, doc.find("```\n", begin) - begin);
    std::string help = ehpt(std::string(cmd) + " --help").out;
    if (const std::size_t own = help.find("\nThis ehpt: "); own != std::string::npos) {
      help = help.substr(0, own + 1) + "This ehpt: ...\n";
    }
    EXPECT_EQ(quoted, help) << "docs/cli.md, 'ehpt " << cmd << "'";
    ++compared;
  }
  EXPECT_GE(compared, 8);
}

// 'ehpt dbc': a DBC's problems as FILE:LINE with exit 2; frames decoded with names, units and
// value names; a frame no message has, or too short for its message, is exit 2.
TEST(CliDbc, ChecksListsAndDecodes) {
  const fs::path root = fresh("dbc");
  const std::string bad = (root / "bad.dbc").string();
  std::ofstream(bad) << "BO_ 1 A: 8 Ecu\n SG_ S : 60|8@1+ (1,0) [0|0] \"\" Ecu\n";
  Result r = ehpt_argv({"dbc", bad});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_HAS(r.err, bad + ":2: signal S (start bit 60, 8 bits, Intel) does not fit in the 8 bytes of A");
  EXPECT_HAS(r.err, "error: " + bad + ": 1 problem; fix the DBC (nothing decoded)");

  const std::string dbc = ehpt::test::source_path("tests/io/dbc/byte_orders.dbc");
  r = ehpt_argv({"dbc", dbc});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_HAS(r.out, "5 messages, 16 signals, 2 nodes");
  EXPECT_HAS(r.out, "0x100 EngineCmd: 8 bytes, from Ecu, no cycle time\n");
  EXPECT_HAS(r.out, "  TorqueReq: bit 7, 16 bits Motorola signed, factor 0.01, [-327.68, 327.67] Nm\n");
  // TorqueReq 0xFF85 = -123 -> -1.23 Nm; SpeedReq 0xABC = 2748 x 0.5 - 100; Mode bits 27..25 = 0b010
  r = ehpt_argv({"dbc", dbc, "100#FF85ABC400000000"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_HAS(r.out, "0x100 EngineCmd: TorqueReq = -1.23 Nm, SpeedReq = 1274 rpm, Mode = 2 \"Run\", Enable = 0");
  r = ehpt_argv({"dbc", dbc, "7FF#00", "100#00"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_HAS(r.err, "frame 1 '7FF#00': no message of " + dbc + " has this id");
  EXPECT_HAS(r.err, "frame 2 '100#00': 1 data bytes; EngineCmd has 8");
  EXPECT_HAS(r.err, "error: 2 of 2 frames not decoded");
  // asked to decode a file without a frame: an error, not the message list with exit 0
  const std::string none = (root / "none.log").string();
  std::ofstream(none) << "no frames here\n";
  r = ehpt_argv({"dbc", dbc, "--frames", none});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_HAS(r.err, "error: --frames " + none + ": no frame (ID#DATA) in it");
  EXPECT_EQ(r.out, "");
}

// 'ehpt list' and 'ehpt plot' say every place they look, then where this ehpt found its folder.
TEST(CliHelp, ListAndPlotSayWhereThisEhptLooks) {
  const Result list = ehpt("list --help");
  ASSERT_EQ(list.exit_code, 0);
  for (const char* place : {"$EHPT_SCENARIOS", "./scenarios", "<prefix>/share/ehpt/scenarios for an installed ehpt",
                            "the source tree's scenarios/ for an ehpt run from its build folder"}) {
    EXPECT_HAS(list.out, place);
  }
  // the binary under test runs from the build folder (its working folder has no scenarios/)
  EXPECT_HAS(list.out, "This ehpt: " + ehpt::test::source_path("scenarios") + "\n");
  const fs::path own = fresh("list_help_env");
  EXPECT_HAS(ehpt_argv({"list", "--help"}, {"EHPT_SCENARIOS=" + own.string()}).out, "This ehpt: " + own.string() + "\n");
  const Result plot = ehpt("plot --help");
  ASSERT_EQ(plot.exit_code, 0);
  for (const char* place : {"$EHPT_TOOLS_DIR", "<prefix>/libexec/ehpt for an installed ehpt", "the source tree's tools/"}) {
    EXPECT_HAS(plot.out, place);
  }
  EXPECT_HAS(plot.out, "This ehpt: " + ehpt::test::source_path("tools") + "/plot.py\n");
  EXPECT_HAS(ehpt_argv({"plot", "--help"}, {"EHPT_TOOLS_DIR=" + own.string()}).out, "This ehpt: " + own.string() + "/plot.py\n");
}

// "1 start", "2 starts": the count agrees with summary.json's ice_starts and the noun with the count.
TEST(CliSummary, TheEngineStartsAreCountedInGoodEnglish) {
  const fs::path root = fresh("starts");
  for (const auto& [duration, starts] : {std::pair<const char*, int>{"200", 1}, {"400", 2}}) {
    const fs::path dir = root / duration;
    const Result r = ehpt_argv({"run", "psecu2_nedc", "--out", dir.string(), "--set", std::string("solver.duration_s=") + duration,
                                "--set", "output.timeseries=false"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    ASSERT_EQ(json_number(slurp((dir / "summary.json").string()), "ice_starts"), starts) << duration;
    const std::regex line(R"(engine on [0-9.]+ s, ([0-9]+) (starts?)\n)");
    std::smatch m;
    ASSERT_TRUE(std::regex_search(r.out, m, line)) << r.out;
    EXPECT_EQ(std::stoi(m[1].str()), starts);
    EXPECT_EQ(m[2].str(), starts == 1 ? "start" : "starts") << r.out;
  }
}

// --plot draws from timeseries.csv: without one (output.timeseries=false) it is refused before
// anything runs, exit 2, with what to do, and no folder (temporary or not) is left behind.
TEST(CliPlot, PlotWithoutATimeseriesIsRefusedBeforeTheRun) {
  const fs::path root = fresh("plot_no_timeseries");
  const fs::path out = root / "run";
  const Result r = ehpt_argv({"run", "ev_sort1", "--plot", "--out", out.string(), "--set", "output.timeseries=false"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_HAS(r.err, "--plot draws its figures from timeseries.csv, but output.timeseries = false");
  EXPECT_HAS(r.err, "drop --plot, or drop output.timeseries = false");
  EXPECT_HAS(r.err, "nothing was run");
  EXPECT_EQ(r.out, "");  // no summary: nothing ran
  EXPECT_TRUE(fs::is_empty(root)) << "a folder was left in " << root;
  // the same refusal when the scenario file says it
  std::ofstream(root / "s.toml") << "vehicle_file = \"" << ehpt::test::source_path("vehicles/mbev.toml")
                                 << "\"\ncycle = \"" << ehpt::test::source_path("data/cycles/cycle_sort1.csv")
                                 << "\"\n[output]\ntimeseries = false\n";
  const Result f = ehpt_argv({"run", (root / "s.toml").string(), "--plot", "--out", out.string()});
  EXPECT_EQ(f.exit_code, 2) << f.err;
  EXPECT_HAS(f.err, "--plot draws its figures from timeseries.csv");
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
