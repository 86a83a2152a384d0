// SPDX-License-Identifier: BSD-3-Clause
// The series hybrid's genset (plant/genset.hpp) on its test rigs, TestGenset2 and TestGensetOO
// (MODELS.md §11.5), through the shipped scenarios: the GMS asks the generator for the request
// (P_ref / w), so the generator's mechanical power is the request until its 55 kW limit acts,
// which is while the request is above 55 kW (1.75 s to 3.25 s); the DC power is below the
// request by the generator's efficiency; GensetOO is off at 4 s; the energy audit closes; the
// vehicle file's numbers are what the plant runs with; a bad number is named with file:line.
#include <gtest/gtest.h>

#include <unistd.h>  // getpid

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "hil/config/config.hpp"
#include "plant/genset_rig.hpp"
#include "test_plants.hpp"

namespace ehpt::hil {
namespace {

// Every signal at every output row (test::run_columns): name -> values.
std::map<std::string, std::vector<double>> run_all(const std::string& scenario, const std::vector<std::string>& sets = {}) {
  test::RunColumns r = test::run_columns(scenario, sets);
  EXPECT_LE(std::abs(r.audit.residual_J), 1e-9 * r.audit.scale_J) << scenario << ": the energy audit closes";
  EXPECT_GT(r.audit.scale_J, 1e5) << "the engine did work";
  EXPECT_EQ(r.fault, 0u);
  return std::move(r.y);
}

// The first time at which column c changes to a value v (NaN if never).
double first_time(const std::map<std::string, std::vector<double>>& y, const char* c, double from_s, double v) {
  const auto& t = y.at("time_s");
  const auto& x = y.at(c);
  for (std::size_t i = 1; i < t.size(); ++i) {
    if (t[i] >= from_s && x[i] == v && x[i - 1] != v) return t[i];
  }
  return NAN;
}

TEST(GensetRig, TestGenset2TheGeneratorsPowerLimitActsWhileTheRequestIsAbove55kW) {
  const auto y = run_all("scenarios/genset_test2.toml", {"output.interval_s=0.001"});
  ASSERT_EQ(y.at("time_s").size(), 5001u);
  const double h = 0.001 * (1.0 + 1e-9);  // one step (the grid's times are n x 0.001 rounded)
  // the request crosses 55 kW at 1.75 s (rising 40 -> 60 kW over 1..2 s) and at 3.25 s (falling):
  // the limit acts from the first step after the first, to the second
  EXPECT_NEAR(first_time(y, "gen_limiting", 0.0, 1.0), 1.75, h);
  EXPECT_NEAR(first_time(y, "gen_limiting", 2.0, 0.0), 3.25, h);
  const auto& t = y.at("time_s");
  for (std::size_t i = 0; i < t.size(); ++i) {
    const double p_ref = y.at("power_ref_W")[i], p_mech = -y.at("gen_power_mech_W")[i], p_dc = y.at("dc_power_W")[i];
    if (y.at("gen_limiting")[i] == 0.0) {
      // unlimited: the generator takes exactly the request
      ASSERT_NEAR(p_mech, p_ref, 1e-6 * p_ref) << "t = " << t[i];
    } else {
      // limited: 55 kW of mechanical power, below the request
      ASSERT_NEAR(p_mech, 55000.0, 1e-6 * 55000.0) << "t = " << t[i];
      ASSERT_LT(p_mech, p_ref) << "t = " << t[i];
    }
    // the DC side gets the mechanical power times the map's efficiency (< 1)
    ASSERT_NEAR(p_dc, p_mech * y.at("gen_efficiency")[i], 1e-9 * p_mech) << "t = " << t[i];
    ASSERT_LT(p_dc, p_ref) << "t = " << t[i];
  }
  // the GMS holds the engine a little below its best speed for 40 kW (115.19 rad/s): the
  // throttle it needs for 363 N m of 711 N m
  EXPECT_NEAR(y.at("iceW_rad_s").back(), 110.08, 0.01);
  EXPECT_NEAR(y.at("ice_power_W").back(), 40000.0, 1.0);
  EXPECT_GT(y.at("fuel_g").back(), 10.0);
}

TEST(GensetRig, TestGensetOOIsOffAt4sEngineAndGeneratorTorqueZeroNoFuel) {
  const auto y = run_all("scenarios/genset_test_oo.toml", {"output.interval_s=0.001"});
  const auto& t = y.at("time_s");
  ASSERT_EQ(t.size(), 8001u);
  for (std::size_t i = 0; i < t.size(); ++i) {
    const bool on = t[i] < 4.0;
    ASSERT_EQ(y.at("on")[i], on ? 1.0 : 0.0) << "t = " << t[i];
    if (on) {
      ASSERT_GT(y.at("ice_torque_Nm")[i], 0.0) << "t = " << t[i];
      ASSERT_LT(y.at("gen_torque_Nm")[i], 0.0) << "t = " << t[i];
    } else {
      ASSERT_EQ(y.at("ice_torque_Nm")[i], 0.0) << "t = " << t[i];
      ASSERT_EQ(y.at("gen_torque_Nm")[i], 0.0) << "t = " << t[i];
      ASSERT_EQ(y.at("fuel_rate_g_s")[i], 0.0) << "t = " << t[i];
      ASSERT_EQ(y.at("dc_power_W")[i], 0.0) << "t = " << t[i];
      ASSERT_EQ(y.at("iceW_rad_s")[i], y.at("iceW_rad_s")[4000]) << "the shaft coasts at t = " << t[i];
    }
  }
  EXPECT_EQ(y.at("fuel_g").back(), y.at("fuel_g")[4000]);
}

TEST(GensetRig, TheVehicleFilesNumbersAreWhatThePlantRunsWith) {
  Scenario sc;
  std::vector<std::string> errors;
  ASSERT_TRUE(load_scenario(test::source_path("scenarios/genset_test_oo.toml"), {}, sc, errors)) << errors[0];
  const auto& p = sc.plant.get<plant::GensetRigParams>();
  EXPECT_EQ(p.off_at_s, 4.0);
  EXPECT_EQ(p.dc_voltage_V, 100.0);
  EXPECT_EQ(p.genset.gear_ratio, 1.0);
  EXPECT_EQ(p.genset.throttle_per_rad_s, 0.1);
  EXPECT_EQ(p.genset.ice.inertia_kgm2, 0.5);
  EXPECT_EQ(p.genset.ice.speed_initial_rad_s, 114.0);
  EXPECT_EQ(p.genset.ice.torque_max_Nm(120.0), 800.0);  // map_shev_ice_max_torque.csv
  EXPECT_EQ(p.genset.opti_speed_rpm(40000.0), 1100.0);   // map_shev_ice_opti_speed.csv
  EXPECT_EQ(p.genset.generator.torque_max_Nm, 500.0);
  EXPECT_EQ(p.genset.generator.power_max_W, 55000.0);
  EXPECT_EQ(p.genset.generator.speed_max_rad_s, 300.0);
  EXPECT_EQ(p.genset.generator.inertia_kgm2, 0.25);
  EXPECT_EQ(p.genset.generator.loss_model, plant::DriveLossModel::kMap);
  EXPECT_EQ(p.request_W.offset, 40000.0);
  EXPECT_EQ(p.request_W.amplitude, 20000.0);
  EXPECT_EQ(p.request_W.start_s, 1.0);
  EXPECT_EQ(p.request_W.rising_s, 1.0);
  EXPECT_EQ(p.request_W.width_s, 1.0);
  EXPECT_EQ(p.request_W.falling_s, 1.0);
  EXPECT_EQ(p.request_W.period_s, 10.0);
  // a --set reaches it too
  Scenario set;
  ASSERT_TRUE(load_scenario(test::source_path("scenarios/genset_test2.toml"), {"vehicle.genset.throttle_per_rad_s=0.2"}, set,
                            errors));
  EXPECT_EQ(set.plant.get<plant::GensetRigParams>().genset.throttle_per_rad_s, 0.2);
}

// Each rule of the genset names the field, the value and the file:line.
TEST(GensetRig, ImpossibleNumbersAreNamedWithFileAndLine) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("ehpt-genset-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string vehicle = test::source_path("vehicles/test_genset2.toml");
  struct Case {
    const char* set;
    const char* field;
  };
  for (const Case& c : {Case{"vehicle.genset.gear_ratio=0", "genset.gear_ratio"},
                        Case{"vehicle.genset.throttle_per_rad_s=-1", "genset.throttle_per_rad_s"},
                        Case{"vehicle.genset.generator.power_max_W=0", "genset.generator.power_max_W"},
                        Case{"vehicle.genset.ice.inertia_kgm2=0", "genset.ice.inertia_kgm2"},
                        Case{"vehicle.request.rising_s=0", "request.rising_s"},
                        Case{"vehicle.off_at_s=-1", "off_at_s"}}) {
    Scenario sc;
    std::vector<std::string> errors;
    EXPECT_FALSE(load_scenario(test::source_path("scenarios/genset_test2.toml"), {c.set}, sc, errors)) << c.set;
    std::string all;
    for (const std::string& e : errors) all += e + "\n";
    EXPECT_NE(all.find(c.field), std::string::npos) << c.set << ": " << all;
  }
  // in the file itself: the line is named
  std::ifstream in(vehicle);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t at = text.find("gear_ratio = 1.0");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 16, "gear_ratio = 0.0");
  const std::size_t line = static_cast<std::size_t>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n')) + 1;
  // its map paths are relative to its folder (../data/maps/...): the copy gets a data folder
  // beside it that is the source's (a link), all inside this test's own folder
  fs::create_directories(dir / "vehicles");
  fs::create_directory_symlink(test::source_path("data"), dir / "data");
  const fs::path copy = dir / "vehicles" / "bad_genset.toml";
  std::ofstream(copy) << text;
  const fs::path scenario = dir / "s.toml";
  std::ofstream(scenario) << "vehicle_file = \"" << copy.string() << "\"\n[solver]\nmethod = \"rk4\"\nstep_s = 0.001\nduration_s = 1\n";
  Scenario sc;
  std::vector<std::string> errors;
  EXPECT_FALSE(load_scenario(scenario.string(), {}, sc, errors));
  std::string all;
  for (const std::string& e : errors) all += e + "\n";
  EXPECT_NE(all.find(copy.filename().string() + ":" + std::to_string(line)), std::string::npos) << all;
  EXPECT_NE(all.find("gear_ratio"), std::string::npos) << all;
  std::error_code ec;
  fs::remove(dir / "data", ec);  // the link, not what it points to
  fs::remove_all(dir, ec);       // the folder this test made
}

}  // namespace
}  // namespace ehpt::hil
