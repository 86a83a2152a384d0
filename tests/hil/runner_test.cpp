// SPDX-License-Identifier: BSD-3-Clause
#include "hil/run/runner.hpp"

#include <gtest/gtest.h>

#include "ecu/ev_follower.hpp"
#include "plant/bev_plant.hpp"
#include "solvers/integrators.hpp"
#include "test_plants.hpp"

namespace ehpt::hil {
namespace {

using BevRk4 = Runner<plant::BevPlant, solvers::Rk4<plant::BevPlant>, ecu::EvFollower>;

std::vector<double> run_all(const plant::BevPlant& plant, std::int64_t steps, std::int64_t chunk) {
  std::vector<int> columns;
  for (std::size_t i = 0; i < plant.signals().size(); ++i) columns.push_back(static_cast<int>(i));
  ecu::EvFollower follower;
  BevRk4 runner(plant, {.total_steps = steps, .decimation = 10, .columns = columns, .chunk_steps = chunk}, &follower);
  std::vector<double> rows;
  while (!runner.finished()) {
    runner.run();
    rows.insert(rows.end(), runner.rows().begin(), runner.rows().end());
    runner.clear_rows();
  }
  return rows;
}

TEST(Runner, RepeatedRunsAreBitIdenticalWhateverTheChunking) {
  const plant::BevPlant plant(test::mbev());
  const auto a = run_all(plant, 60000, 60000);
  const auto b = run_all(plant, 60000, 60000);
  const auto c = run_all(plant, 60000, 777);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.size(), c.size());
  EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(double)));
  EXPECT_EQ(0, std::memcmp(a.data(), c.data(), a.size() * sizeof(double)));
  // rows: t = 0, every 10 steps, and the last step
  EXPECT_EQ(a.size(), (60000 / 10 + 1) * plant.signals().size());
}

TEST(Runner, StopsAtTheFirstFaultAndRecordsIt) {
  const test::ExpectFault expected;
  plant::BevParams p = test::mbev();
  p.battery.soc_min = 0.6999;  // SOC leaves the window as soon as the car draws power
  const plant::BevPlant plant(p);
  ecu::EvFollower follower;
  BevRk4 runner(plant, {.total_steps = 150000, .decimation = 100, .columns = {0}, .chunk_steps = 150000}, &follower);
  runner.run();
  EXPECT_TRUE(runner.finished());
  EXPECT_EQ(runner.stats().fault, plant::kFaultSocWindow);
  EXPECT_GT(runner.stats().fault_time_s, 0.0);
  EXPECT_LT(runner.step_index(), 150000);
  // the fault row is recorded
  EXPECT_EQ(runner.rows().back(), runner.stats().fault_time_s);
}

// The column of a signal in plant.signals().
template <class Plant>
int column_of(const Plant& plant, std::string_view name) {
  for (std::size_t i = 0; i < plant.signals().size(); ++i) {
    if (plant.signals()[i].name == name) return static_cast<int>(i);
  }
  ADD_FAILURE() << name;
  return 0;
}

// A command computed from the sample at t_n acts from t_{n+k}: with the follower, the drive's
// torque reference at step n is the driver's request sampled at n - k (held in between).
TEST(Runner, ACommandActsLatencyStepsAfterItsSample) {
  const plant::BevPlant plant(test::mbev());
  const int request = column_of(plant, "driver_request_Nm"), reference = column_of(plant, "drive_torque_ref_Nm");
  for (const std::int64_t latency : {0, 1, 7}) {
    for (const std::int64_t period : {1, 5}) {
      ecu::EvFollower follower;
      BevRk4 runner(plant,
                    {.total_steps = 3000,
                     .columns = {request, reference},
                     .chunk_steps = 3000,
                     .ecu_ratio = period,
                     .ecu_latency_steps = latency},
                    &follower);
      runner.run();
      const auto rows = runner.rows();
      ASSERT_EQ(rows.size(), 2u * 3001u);
      int compared = 0;
      for (std::int64_t n = 0; n <= 3000; ++n) {
        // the command in force at n: from the last sample s <= n - latency with s % period == 0
        const std::int64_t from = n - latency;
        const double want = from < 0 ? 0.0 : rows[2 * static_cast<std::size_t>(from - from % period)];
        ASSERT_EQ(rows[2 * static_cast<std::size_t>(n) + 1], want) << "n " << n << " latency " << latency;
        compared += want != 0.0;
      }
      EXPECT_GT(compared, 1000);
    }
  }
}

// The sensor and command messages carry the sample's time and step and a sequence number.
struct SpyEcu {
  std::vector<msgs::Stamp> sensor_stamps;
  void update(const msgs::EvSensors& in, msgs::EvCommand& out) {
    sensor_stamps.push_back(in.stamp);
    out.driveTauRef_Nm = in.driverRequest_Nm;
  }
};

TEST(Runner, MessagesAreStampedWithTheirSample) {
  const plant::BevPlant plant(test::mbev());
  SpyEcu spy;
  spy.sensor_stamps.reserve(100);
  Runner<plant::BevPlant, solvers::Rk4<plant::BevPlant>, SpyEcu> runner(
      plant, {.total_steps = 100, .columns = {0}, .chunk_steps = 100, .ecu_ratio = 10}, &spy);
  runner.run();
  ASSERT_EQ(spy.sensor_stamps.size(), 11u);  // steps 0, 10, ..., 100
  for (std::size_t k = 0; k < spy.sensor_stamps.size(); ++k) {
    EXPECT_EQ(spy.sensor_stamps[k].step, static_cast<std::int64_t>(10 * k));
    EXPECT_DOUBLE_EQ(spy.sensor_stamps[k].time_s, 0.01 * static_cast<double>(k));
    EXPECT_EQ(spy.sensor_stamps[k].sequence, k);
  }
}

}  // namespace
}  // namespace ehpt::hil
