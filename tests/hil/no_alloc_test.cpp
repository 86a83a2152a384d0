// SPDX-License-Identifier: BSD-3-Clause
// Zero heap allocations in the run phase: a counting operator new (support/alloc_counter.cpp)
// around 1e5 steps after start-up, for every plant and solver.
#include <gtest/gtest.h>

#include "ecu/psd_ecu.hpp"
#include "ecu/shev_ems.hpp"
#include "alloc_counter.hpp"
#include "hil/config/config.hpp"
#include "ecu/ev_follower.hpp"
#include "hil/run/runner.hpp"
#include "hil/run/simulation.hpp"
#include "plant/bev_plant.hpp"
#include "plant/drive_rigs.hpp"
#include "plant/psd_plant.hpp"
#include "plant/shev_plant.hpp"
#include "solvers/integrators.hpp"
#include "test_plants.hpp"

namespace ehpt::hil {
namespace {

template <class Plant, class Integrator, class Controller = NoController>
std::size_t allocations_over_run(const Plant& plant, std::int64_t steps, Controller* controller = nullptr,
                                 std::int64_t latency_steps = 0) {
  std::vector<int> columns{0, 1, 2};
  // start-up: may allocate
  Runner<Plant, Integrator, Controller> runner(
      plant, {.total_steps = steps, .decimation = 100, .columns = columns, .chunk_steps = steps, .ecu_latency_steps = latency_steps},
      controller);
  const std::size_t before = test::allocation_count();
  runner.run();  // run phase
  const std::size_t after = test::allocation_count();
  EXPECT_EQ(runner.step_index(), steps);
  return after - before;
}

TEST(NoAllocation, BevWithBothSolversAndItsEcu) {
  const plant::BevPlant plant(test::mbev("data/cycles/cycle_nedc.csv"));
  ecu::EvFollower follower;
  using P = plant::BevPlant;
  EXPECT_EQ((allocations_over_run<P, solvers::Rk4<P>>(plant, 100000, &follower)), 0u);
  EXPECT_EQ((allocations_over_run<P, solvers::ImplicitEuler<P>>(plant, 100000, &follower)), 0u);
  // commands in flight (latency 7 steps): the ring of pending commands is sized at start-up
  EXPECT_EQ((allocations_over_run<P, solvers::Rk4<P>>(plant, 100000, &follower, 7)), 0u);
}

// Through the facade the CLI uses: after make_simulation(), run() allocates nothing.
TEST(NoAllocation, SimulationFacade) {
  for (const char* scenario : {"scenarios/ev_nedc.toml", "scenarios/psecu2_nedc.toml", "scenarios/evpm_sort1.toml",
                               "scenarios/evpm_nedc.toml", "scenarios/evam_sort1.toml", "scenarios/evam_nedc.toml"}) {
    const Scenario sc = test::load(test::source_path(scenario), {"solver.duration_s=200", "vehicle.ecu.latency_s=0.005"});
    const auto sim = make_simulation(sc, SimulationOptions{{}, 200000});
    const std::size_t before = test::allocation_count();
    sim->run();
    EXPECT_EQ(test::allocation_count() - before, 0u) << scenario;
    EXPECT_EQ(sim->step_index(), 200000) << scenario;
  }
}

TEST(NoAllocation, PowerSplitHybridWithItsEcu) {
  const hil::Scenario sc = test::load(test::source_path("scenarios/psecu2_nedc.toml"));
  const auto& p = sc.plant.get<plant::PsdParams>();
  const plant::PsdPlant plant(p);
  ecu::PsdEcu ecu(sc.ecu.get<ecu::PsdEcuParams>(), 1e-3);
  using R = Runner<plant::PsdPlant, solvers::Rk4<plant::PsdPlant>, ecu::PsdEcu>;
  R runner(plant, {.total_steps = 400000, .decimation = 100, .columns = {0, 1, 2}, .chunk_steps = 400000}, &ecu);  // start-up: may allocate
  const std::size_t before = test::allocation_count();
  runner.run();  // run phase: 400 s, through engine starts at 145.5 s and 334.7 s and their stops
  EXPECT_EQ(test::allocation_count() - before, 0u);
  EXPECT_EQ(runner.step_index(), 400000);
  EXPECT_EQ(runner.metrics().engine_starts, 2);
  EXPECT_EQ(runner.last_outputs().iceON, 0.0);
}

// The series hybrid with ShevEMS, both solvers, through a genset start (267.3 s) and stop (373.2 s).
TEST(NoAllocation, SeriesHybridWithItsEms) {
  const hil::Scenario sc = test::load(test::source_path("scenarios/shev_oo_sort1.toml"));
  const plant::ShevPlant plant(sc.plant.get<plant::ShevParams>());
  using P = plant::ShevPlant;
  for (int solver = 0; solver < 2; ++solver) {
    ecu::ShevEms ems(sc.ecu.get<ecu::ShevEmsParams>(), 0.01);
    const auto runs = [&](auto integrator) {
      using I = decltype(integrator);
      Runner<P, I, ecu::ShevEms> runner(
          plant, {.total_steps = 400000, .decimation = 100, .columns = {0, 1, 2}, .chunk_steps = 400000, .ecu_ratio = 10},
          &ems);
      const std::size_t before = test::allocation_count();
      runner.run();
      EXPECT_EQ(test::allocation_count() - before, 0u) << solver;
      EXPECT_EQ(runner.metrics().engine_starts, 1) << solver;
      EXPECT_EQ(runner.last_outputs().genset_on, 0.0) << solver;
    };
    if (solver == 0) {
      runs(solvers::Rk4<P>(plant));
    } else {
      runs(solvers::ImplicitEuler<P>(plant));
    }
  }
  const auto sim = make_simulation(test::load(test::source_path("scenarios/shev_oo_sort1.toml"), {"solver.duration_s=200"}),
                                   SimulationOptions{{}, 200000});
  const std::size_t before = test::allocation_count();
  sim->run();
  EXPECT_EQ(test::allocation_count() - before, 0u);
}

TEST(NoAllocation, DriveRig) {
  Scenario sc;
  std::vector<std::string> errors;
  ASSERT_TRUE(load_scenario(test::source_path("scenarios/one_flange_test.toml"), {}, sc, errors));
  const plant::DriveRig rig(sc.plant.get<plant::DriveRigParams>());
  EXPECT_EQ((allocations_over_run<plant::DriveRig, solvers::Rk4<plant::DriveRig>>(rig, 50000)), 0u);
}

TEST(NoAllocation, TheCounterSeesAllocations) {
  const std::size_t before = test::allocation_count();
  std::vector<double> v(100, 1.0);
  v.push_back(2.0);  // grows: a second allocation
  EXPECT_EQ(v.size(), 101u);
  EXPECT_GE(test::allocation_count() - before, 2u);
}

}  // namespace
}  // namespace ehpt::hil
