// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Parameter sets shared by several tests (the shipped MBEV, a coast-down vehicle, cycles).

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "hil/config/config.hpp"
#include "plant/bev_plant.hpp"

namespace ehpt::test {

inline std::string source_path(const std::string& rel) { return std::string(EHPT_SOURCE_DIR) + "/" + rel; }

// Every test fails if a run in it (hil::Runner) stopped on a fault, unless it declares an
// ExpectFault (anywhere in the test): a wrong parameter or a broken equation cannot hide
// behind a run that quietly ended early.
class ExpectFault {
 public:
  ExpectFault();
  ~ExpectFault();
  ExpectFault(const ExpectFault&) = delete;
  ExpectFault& operator=(const ExpectFault&) = delete;
};

// This test process's scratch folder, <temp>/ehpt_test_<pid>, made on first use and removed
// when the process ends: ctest runs every test in a process of its own, so tests that run at
// the same time (ctest -j, two checkouts, CI next to a developer) never share a path.
std::filesystem::path scratch_root();

// A scenario through the real loader (aborts the test on problems).
hil::Scenario load(const std::string& path, const std::vector<std::string>& overrides = {});

// A scenario (a path under the source tree) run to its end through make_simulation: every
// recorded column by name, as timeseries.csv names them (faults_active last when there are
// faults), with the run's energy audit, its first fault and its last step. A load error fails
// the test and gives empty columns.
struct RunColumns {
  std::map<std::string, std::vector<double>> y;
  plant::EnergyAudit audit;
  unsigned fault = 0;
  std::int64_t steps = 0;
};
RunColumns run_columns(const std::string& scenario, const std::vector<std::string>& overrides = {},
                       const std::vector<std::string>& faults = {});

// MBEV as in vehicles/mbev.toml, loaded through the real loader with the given cycle.
plant::BevParams mbev(const std::string& cycle_file = "data/cycles/cycle_sort1.csv");

// One step of a plant with its ECU sampled at the step's start, the command acting at once
// (latency 0), as hil::Runner does with an ECU every step: sense at t_n, update, advance.
template <class Plant, class Stepper, class Ecu>
auto step_with_ecu(const Plant& plant, Stepper& stepper, Ecu& ecu, std::int64_t n, typename Plant::State& x,
                   typename Plant::Modes& m, typename Plant::Inputs& command) {
  typename Plant::Sensors sensors;
  plant.sense(stepper.time_s(n), x, m, command, sensors);
  ecu.update(sensors, command);
  return stepper.advance(n, x, m, command);
}

}  // namespace ehpt::test
