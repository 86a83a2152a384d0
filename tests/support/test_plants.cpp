// SPDX-License-Identifier: BSD-3-Clause
#include "test_plants.hpp"

#include <unistd.h>

#include <stdexcept>

#include <gtest/gtest.h>

#include "hil/config/config.hpp"
#include "hil/run/runner.hpp"
#include "hil/run/simulation.hpp"

namespace ehpt::test {

namespace {

int g_expecting_fault = 0;

// The guard (gtest's own sample10 does its leak check the same way): a failure raised in
// OnTestEnd belongs to the test that just ran.
class UnexpectedFaultGuard : public ::testing::EmptyTestEventListener {
  void OnTestStart(const ::testing::TestInfo&) override {
    before_ = hil::g_runs_with_fault.load();
    g_expecting_fault = 0;
  }
  void OnTestEnd(const ::testing::TestInfo&) override {
    const std::int64_t faulted = hil::g_runs_with_fault.load() - before_;
    EXPECT_TRUE(faulted == 0 || g_expecting_fault > 0)
        << faulted << " run(s) in this test stopped on a fault it did not expect (test::ExpectFault)";
  }
  std::int64_t before_ = 0;
};

// Registered when a test binary starts (the support library is linked into every one).
const bool g_guard_registered = [] {
  ::testing::UnitTest::GetInstance()->listeners().Append(new UnexpectedFaultGuard);
  return true;
}();

}  // namespace

ExpectFault::ExpectFault() { ++g_expecting_fault; }
ExpectFault::~ExpectFault() {}

std::filesystem::path scratch_root() {
  struct Root {
    std::filesystem::path path =
        std::filesystem::temp_directory_path() / ("ehpt_test_" + std::to_string(::getpid()));
    Root() { std::filesystem::create_directories(path); }
    ~Root() {
      std::error_code ec;
      std::filesystem::remove_all(path, ec);  // ours: made by this process
    }
  };
  static const Root root;
  return root.path;
}

RunColumns run_columns(const std::string& scenario, const std::vector<std::string>& overrides,
                       const std::vector<std::string>& faults) {
  RunColumns r;
  hil::Scenario sc;
  std::vector<std::string> errors;
  if (!hil::load_scenario(source_path(scenario), overrides, faults, sc, errors)) {
    ADD_FAILURE() << scenario << ": " << (errors.empty() ? "" : errors[0]);
    return r;
  }
  const std::vector<hil::SignalInfo> signals = hil::scenario_signals(sc);
  const std::vector<int> columns = hil::chosen_columns(sc, signals);
  std::vector<std::string> names;
  for (const int c : columns) names.emplace_back(signals[static_cast<std::size_t>(c)].name);
  if (!sc.faults.empty()) names.emplace_back("faults_active");
  const auto sim = hil::make_simulation(sc, hil::SimulationOptions{columns});
  while (!sim->finished()) {
    sim->run();
    const auto rows = sim->rows();
    for (std::size_t i = 0; i + names.size() <= rows.size(); i += names.size()) {
      for (std::size_t j = 0; j < names.size(); ++j) r.y[names[j]].push_back(rows[i + j]);
    }
    sim->clear_rows();
  }
  r.audit = sim->audit();
  r.fault = sim->stats().fault;
  r.steps = sim->step_index();
  return r;
}

hil::Scenario load(const std::string& path, const std::vector<std::string>& overrides) {
  hil::Scenario sc;
  std::vector<std::string> errors;
  if (!hil::load_scenario(path, overrides, sc, errors)) {
    throw std::runtime_error(path + ": " + (errors.empty() ? "load failed" : errors.front()));
  }
  return sc;
}

plant::BevParams mbev(const std::string& cycle_file) {
  hil::Scenario sc;
  std::vector<std::string> errors;
  if (!hil::load_scenario(source_path("scenarios/ev_sort1.toml"), {"cycle=\"" + source_path(cycle_file) + "\""}, sc,
                          errors)) {
    throw std::runtime_error(errors.empty() ? "load failed" : errors.front());
  }
  return sc.plant.get<plant::BevParams>();
}

}  // namespace ehpt::test
