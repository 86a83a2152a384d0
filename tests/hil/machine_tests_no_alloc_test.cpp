// SPDX-License-Identifier: BSD-3-Clause
// Zero heap allocations in the run phase of the detailed-machine rigs (TestPMDrive,
// TestAMDrive), through the facade the CLI uses: the drive's solve, the machine equations
// and the product's implicit Euler over 10^4 steps.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "hil/run/simulation.hpp"
#include "test_plants.hpp"

namespace ehpt::hil {
namespace {

TEST(NoAllocation, DetailedMachineRigs) {
  // held at a demanding point: PM in flux weakening at the current limit with T* out of reach
  // (the drive's longest solve), AM above base frequency at 150 N m
  const std::vector<std::string> held = {"solver.duration_s=0.05", "vehicle.speed.amplitude_rad_s=0",
                                         "vehicle.request.offset_Nm=150", "vehicle.request.amplitude_Nm=0"};
  struct Case {
    const char* scenario;
    const char* speed;
  };
  for (const Case& c : {Case{"scenarios/test_pm_drive.toml", "240"}, Case{"scenarios/test_am_drive.toml", "200"}}) {
    const char* scenario = c.scenario;
    std::vector<std::string> sets = held;
    sets.push_back(std::string("vehicle.speed.offset_rad_s=") + c.speed);
    const Scenario sc = test::load(test::source_path(scenario), sets);
    const auto sim = make_simulation(sc, SimulationOptions{{}, 10000});
    const std::size_t before = test::allocation_count();
    sim->run();
    EXPECT_EQ(test::allocation_count() - before, 0u) << scenario;
    EXPECT_EQ(sim->step_index(), 10000) << scenario;
  }
}

}  // namespace
}  // namespace ehpt::hil
