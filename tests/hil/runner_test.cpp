#include "hil/runner.hpp"

#include <gtest/gtest.h>

#include "plant/bev_plant.hpp"
#include "solvers/integrators.hpp"
#include "test_plants.hpp"

namespace ehpt::hil {
namespace {

using BevRk4 = Runner<plant::BevPlant, solvers::Rk4<plant::BevPlant>>;

std::vector<double> run_all(const plant::BevPlant& plant, std::int64_t steps, std::int64_t chunk) {
  std::vector<int> columns;
  for (std::size_t i = 0; i < plant.signals().size(); ++i) columns.push_back(static_cast<int>(i));
  BevRk4 runner(plant, 1e-3, steps, 10, columns, chunk);
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
  BevRk4 runner(plant, 1e-3, 150000, 100, {0}, 150000);
  runner.run();
  EXPECT_TRUE(runner.finished());
  EXPECT_EQ(runner.stats().fault, plant::kFaultSocWindow);
  EXPECT_GT(runner.stats().fault_time_s, 0.0);
  EXPECT_LT(runner.step_index(), 150000);
  // the fault row is recorded
  EXPECT_EQ(runner.rows().back(), runner.stats().fault_time_s);
}

}  // namespace
}  // namespace ehpt::hil
