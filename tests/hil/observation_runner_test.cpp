// SPDX-License-Identifier: BSD-3-Clause
// The runner with a plant's observation (solvers/plant.hpp, PlantWithObservation): the full
// outputs only for the rows it records, the observation at every other grid point, dx/dt and
// the crossing functions handed to the next step. Against the same plant with the observation
// deleted (the runner then computes the full outputs at every grid point, as it always did):
// the same rows, metrics, counters, state and outputs, bit for bit, through chunk boundaries,
// an interrupted run, a fault and an ECU outside the runner.
#include <gtest/gtest.h>

#include <atomic>
#include <bit>
#include <cstdint>
#include <cstring>
#include <vector>

#include "ecu/ev_follower.hpp"
#include "ecu/psd_ecu.hpp"
#include "hil/run/runner.hpp"
#include "plant/bev_plant.hpp"
#include "plant/psd_plant.hpp"
#include "solvers/integrators.hpp"
#include "test_plants.hpp"

namespace ehpt::hil {
namespace {

// The plant as the runner saw it before: no observation, the full outputs at every point.
template <class P>
struct FullOutputsOnly : P {
  using P::P;
  void observe(double, const typename P::State&, const typename P::Modes&, const typename P::Inputs&,
               typename P::Outputs&, typename P::State&, double*) const = delete;
};
static_assert(solvers::PlantWithObservation<plant::BevPlant>);
static_assert(!solvers::PlantWithObservation<FullOutputsOnly<plant::BevPlant>>);
static_assert(solvers::PlantWithObservation<plant::PsdPlant>);
static_assert(!solvers::PlantWithObservation<FullOutputsOnly<plant::PsdPlant>>);

// A pacer that raises the stop flag before step `at` (an interrupted run, as Ctrl-C does).
struct StopAt final : StepPacer {
  StopAt(std::atomic<int>* f, std::int64_t n) : flag(f), at(n) {}
  std::atomic<int>* flag = nullptr;
  std::int64_t at = -1;
  void wait_for_step(std::int64_t n) override {
    if (n == at) flag->store(1);
  }
};

// Everything a run leaves, for comparison.
template <class Outputs, class State>
struct Result {
  std::vector<double> rows;
  std::vector<Outputs> chunk_outputs;  // last_outputs() after every run() call
  Outputs last{}, initial{};
  State x;
  RunStats stats;
  MetricTotals metrics;
  std::int64_t steps = 0;
};

bool same_bits(const void* a, const void* b, std::size_t n) { return std::memcmp(a, b, n) == 0; }

template <class Plant, class Ecu, class Params>
auto run(const Params& params, Ecu ecu, std::int64_t steps, std::int64_t decimation, std::int64_t chunk,
         std::int64_t ecu_ratio, std::int64_t stop_at = -1) {
  const Plant plant(params);
  std::vector<int> columns;
  for (std::size_t i = 0; i < plant.signals().size(); ++i) columns.push_back(static_cast<int>(i));
  std::atomic<int> stop{0};
  StopAt pacer{&stop, stop_at};
  Runner<Plant, solvers::Rk4<Plant>, Ecu> runner(
      plant, {.total_steps = steps, .decimation = decimation, .columns = columns, .chunk_steps = chunk, .ecu_ratio = ecu_ratio},
      &ecu, &pacer);
  Result<typename Plant::Outputs, typename Plant::State> r;
  while (!runner.finished() && stop.load() == 0) {
    runner.run(&stop);
    r.rows.insert(r.rows.end(), runner.rows().begin(), runner.rows().end());
    runner.clear_rows();
    r.chunk_outputs.push_back(runner.last_outputs());
  }
  if (stop.load() != 0) {  // the interrupted run records the state it reached
    runner.run(&stop);
    r.rows.insert(r.rows.end(), runner.rows().begin(), runner.rows().end());
  }
  r.last = runner.last_outputs();
  r.initial = runner.initial_outputs();
  r.x = runner.state();
  r.stats = runner.stats();
  r.metrics = runner.metrics();
  r.steps = runner.step_index();
  return r;
}

template <class R>
void expect_same(const R& a, const R& b) {
  ASSERT_EQ(a.rows.size(), b.rows.size());
  EXPECT_TRUE(same_bits(a.rows.data(), b.rows.data(), a.rows.size() * sizeof(double))) << "rows";
  ASSERT_EQ(a.chunk_outputs.size(), b.chunk_outputs.size());
  for (std::size_t i = 0; i < a.chunk_outputs.size(); ++i) {
    EXPECT_TRUE(same_bits(&a.chunk_outputs[i], &b.chunk_outputs[i], sizeof(a.chunk_outputs[i])))
        << "last_outputs() after run() call " << i;
  }
  EXPECT_TRUE(same_bits(&a.last, &b.last, sizeof(a.last))) << "last_outputs()";
  EXPECT_TRUE(same_bits(&a.initial, &b.initial, sizeof(a.initial))) << "initial_outputs()";
  EXPECT_TRUE(same_bits(a.x.data(), b.x.data(), sizeof(double) * static_cast<std::size_t>(a.x.size()))) << "state";
  EXPECT_EQ(a.steps, b.steps);
  EXPECT_EQ(a.stats.events, b.stats.events);
  EXPECT_EQ(a.stats.chattering_steps, b.stats.chattering_steps);
  EXPECT_EQ(a.stats.fault, b.stats.fault);
  EXPECT_EQ(a.stats.fault_step, b.stats.fault_step);
  EXPECT_EQ(a.stats.fault_steps, b.stats.fault_steps);
  EXPECT_EQ(std::bit_cast<std::uint64_t>(a.stats.fault_time_s), std::bit_cast<std::uint64_t>(b.stats.fault_time_s));
  EXPECT_EQ(a.metrics.speed_samples, b.metrics.speed_samples);
  EXPECT_EQ(std::bit_cast<std::uint64_t>(a.metrics.speed_error_sq_sum),
            std::bit_cast<std::uint64_t>(b.metrics.speed_error_sq_sum));
  EXPECT_EQ(std::bit_cast<std::uint64_t>(a.metrics.speed_error_max_kmh),
            std::bit_cast<std::uint64_t>(b.metrics.speed_error_max_kmh));
  EXPECT_EQ(std::bit_cast<std::uint64_t>(a.metrics.locked_time_s), std::bit_cast<std::uint64_t>(b.metrics.locked_time_s));
  EXPECT_EQ(std::bit_cast<std::uint64_t>(a.metrics.engine_on_time_s),
            std::bit_cast<std::uint64_t>(b.metrics.engine_on_time_s));
  EXPECT_EQ(a.metrics.engine_starts, b.metrics.engine_starts);
}

struct Psecu2 {
  plant::PsdParams plant;
  ecu::PsdEcuParams ecu;
  std::int64_t steps, ratio;
};
Psecu2 psecu2(const std::vector<std::string>& overrides = {}) {
  const Scenario sc = test::load(test::source_path("scenarios/psecu2_nedc.toml"), overrides);
  return {sc.plant.get<plant::PsdParams>(), sc.ecu.get<ecu::PsdEcuParams>(), sc.solver.steps,
          sc.solver.ecu_ratio};
}

// Chunks that end between rows (7777 is not a multiple of 100): the outputs a caller reads
// after each run() call are the full ones.
TEST(ObservationRunner, Psecu2NedcIsBitIdenticalToFullOutputsAtEveryStep) {
  const Psecu2 p = psecu2();
  const auto a = run<plant::PsdPlant>(p.plant, ecu::PsdEcu(p.ecu, p.ecu.period_s), p.steps, 100, 7777, p.ratio);
  const auto b =
      run<FullOutputsOnly<plant::PsdPlant>>(p.plant, ecu::PsdEcu(p.ecu, p.ecu.period_s), p.steps, 100, 7777, p.ratio);
  expect_same(a, b);
  EXPECT_EQ(a.steps, p.steps);
  EXPECT_GT(a.stats.events, 10);  // stops and starts: the crossings handed over are used
  EXPECT_GT(a.metrics.engine_starts, 1);
  EXPECT_GT(a.metrics.locked_time_s, 100.0);
}

TEST(ObservationRunner, MapEvNedcIsBitIdenticalToFullOutputsAtEveryStep) {
  const Scenario sc = test::load(test::source_path("scenarios/ev_nedc.toml"));
  const auto& p = sc.plant.get<plant::BevParams>();
  const auto a = run<plant::BevPlant>(p, ecu::EvFollower{}, sc.solver.steps, 100, 50000, sc.solver.ecu_ratio);
  const auto b =
      run<FullOutputsOnly<plant::BevPlant>>(p, ecu::EvFollower{}, sc.solver.steps, 100, 50000, sc.solver.ecu_ratio);
  expect_same(a, b);
  EXPECT_EQ(a.steps, sc.solver.steps);
  EXPECT_GT(a.stats.events, 10);
}

// Interrupted between two rows: the last row is the full outputs where the run stopped.
TEST(ObservationRunner, AnInterruptedRunEndsWithTheSameRow) {
  const Psecu2 p = psecu2({"solver.duration_s=200"});
  for (const std::int64_t stop_at : {std::int64_t{123457}, std::int64_t{150000}}) {
    const auto a =
        run<plant::PsdPlant>(p.plant, ecu::PsdEcu(p.ecu, p.ecu.period_s), p.steps, 100, 50000, p.ratio, stop_at);
    const auto b = run<FullOutputsOnly<plant::PsdPlant>>(p.plant, ecu::PsdEcu(p.ecu, p.ecu.period_s), p.steps, 100,
                                                         50000, p.ratio, stop_at);
    expect_same(a, b);
    EXPECT_EQ(a.steps, stop_at);  // raised on the way to stop_at, seen before the step from it
    EXPECT_EQ(a.rows[a.rows.size() - plant::PsdPlant::kSignals.size()], 1e-3 * static_cast<double>(stop_at));
  }
}

// The first fault is found at the same step from the observation, and its row is the full one.
TEST(ObservationRunner, AFaultIsFoundAtTheSameStepWithTheSameRow) {
  const test::ExpectFault expected;
  Psecu2 p = psecu2({"solver.duration_s=300"});
  p.plant.battery.soc_min = 0.595;  // the SOC leaves the window at 21.597 s, while driving
  const auto a = run<plant::PsdPlant>(p.plant, ecu::PsdEcu(p.ecu, p.ecu.period_s), p.steps, 100, 50000, p.ratio);
  const auto b =
      run<FullOutputsOnly<plant::PsdPlant>>(p.plant, ecu::PsdEcu(p.ecu, p.ecu.period_s), p.steps, 100, 50000, p.ratio);
  expect_same(a, b);
  EXPECT_EQ(a.stats.fault, plant::kFaultSocWindow);
  EXPECT_NE(a.stats.fault_step % 100, 0);  // between two rows: the fault row is an extra one
  EXPECT_GT(a.stats.fault_step, 1000) << "found from the observation, after some driving";
  EXPECT_LT(a.steps, p.steps);
}

// An ECU outside the runner (a bus, a test): run() stops at each sample step; the caller
// reads the sensors, writes the command, and the outputs a caller sees are the full ones.
template <class Plant>
auto run_external(const Psecu2& p, std::int64_t decimation) {
  const Plant plant(p.plant);
  ecu::PsdEcu ecu(p.ecu, p.ecu.period_s);
  std::vector<int> columns;
  for (std::size_t i = 0; i < plant.signals().size(); ++i) columns.push_back(static_cast<int>(i));
  Runner<Plant, solvers::Rk4<Plant>, ecu::PsdEcu> runner(plant,
                                                          {.total_steps = p.steps,
                                                           .decimation = decimation,
                                                           .columns = columns,
                                                           .chunk_steps = 100000,
                                                           .ecu_ratio = p.ratio,
                                                           .external_ecu = true});
  Result<typename Plant::Outputs, typename Plant::State> r;
  msgs::PsdSensors sensors;
  msgs::PsdCommand command;
  while (!runner.finished()) {
    runner.sense(sensors);
    ecu.update(sensors, command);
    runner.set_command(command);
    runner.run();
    r.rows.insert(r.rows.end(), runner.rows().begin(), runner.rows().end());
    runner.clear_rows();
    r.chunk_outputs.push_back(runner.last_outputs());
  }
  r.last = runner.last_outputs();
  r.initial = runner.initial_outputs();
  r.x = runner.state();
  r.stats = runner.stats();
  r.metrics = runner.metrics();
  r.steps = runner.step_index();
  return r;
}

TEST(ObservationRunner, AnExternalEcuSeesTheSameOutputs) {
  const Psecu2 p = psecu2({"solver.duration_s=200"});
  const auto a = run_external<plant::PsdPlant>(p, 100);
  const auto b = run_external<FullOutputsOnly<plant::PsdPlant>>(p, 100);
  expect_same(a, b);
  // one run() call per ECU period, and one that takes the outputs at the last step
  EXPECT_EQ(a.chunk_outputs.size(), static_cast<std::size_t>(p.steps / p.ratio + 1));
}

}  // namespace
}  // namespace ehpt::hil
