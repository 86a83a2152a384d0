// SPDX-License-Identifier: BSD-3-Clause
// The plants' observation (solvers/plant.hpp, PlantWithObservation), one typed test for every
// plant of plant::ObservedPlants (plant/observation.hpp): at every grid point of a whole
// cycle, with the built-in ECU closing the loop, observe() gives bit for bit what outputs()
// gives on the fields the runner reads at every step (those kMetrics names, and fault), what
// derivatives() gives for dx/dt and what crossings() gives for z, and leaves every other output
// as it was. The runner computes the full outputs only for recorded rows and hands dx and z to
// the next step, so this is what keeps its trajectories unchanged.
// A plant's observe() asserts that the plant is in ObservedPlants, and a listed plant without
// a Case below does not compile: a new plant with observe() cannot be left out.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "ecu/ev_follower.hpp"
#include "ecu/psd_ecu.hpp"
#include "hil/run/runner.hpp"
#include "plant/bev_plant.hpp"
#include "plant/ev_machine_plant.hpp"
#include "plant/observation.hpp"
#include "plant/psd_plant.hpp"
#include "solvers/integrators.hpp"
#include "test_plants.hpp"

namespace ehpt::plant {
namespace {

// What a plant's run looks like: its scenario, its built-in ECU, and how much of each regime
// (standstill, driving, engine on and off) the cycle must visit for the comparison to mean
// something. No primary definition: every plant of ObservedPlants needs one.
template <class Plant>
struct Case;

template <>
struct Case<BevPlant> {
  static constexpr const char* kName = "MapEvOnNedc";
  static constexpr const char* kScenario = "scenarios/ev_nedc.toml";
  static constexpr std::int64_t kMinStuck = 100000, kMinMoving = 500000, kMinEachEngineState = 0;
  static ecu::EvFollower ecu(const hil::Scenario&) { return {}; }
};
template <>
struct Case<EvPmPlant> {
  static constexpr const char* kName = "EvPmOnNedc";
  static constexpr const char* kScenario = "scenarios/evpm_nedc.toml";
  static constexpr std::int64_t kMinStuck = 100000, kMinMoving = 500000, kMinEachEngineState = 0;
  static ecu::EvFollower ecu(const hil::Scenario&) { return {}; }
};
template <>
struct Case<EvAmPlant> {
  static constexpr const char* kName = "EvAmOnSort1";
  static constexpr const char* kScenario = "scenarios/evam_sort1.toml";
  static constexpr std::int64_t kMinStuck = 1000, kMinMoving = 50000, kMinEachEngineState = 0;
  static ecu::EvFollower ecu(const hil::Scenario&) { return {}; }
};
template <>
struct Case<PsdPlant> {
  static constexpr const char* kName = "Psecu2OnNedc";
  static constexpr const char* kScenario = "scenarios/psecu2_nedc.toml";
  static constexpr std::int64_t kMinStuck = 100000, kMinMoving = 500000, kMinEachEngineState = 100000;
  static ecu::PsdEcu ecu(const hil::Scenario& sc) {
    const auto& p = sc.ecu.get<ecu::PsdEcuParams>();
    return ecu::PsdEcu(p, p.period_s);
  }
};

template <class List>
struct GtestTypes;
template <class... Plants>
struct GtestTypes<PlantList<Plants...>> {
  static_assert((solvers::PlantWithObservation<Plants> && ...));
  static_assert(((Case<Plants>::kMinStuck > 0) && ...));  // instantiates every Case
  using type = ::testing::Types<Plants...>;
};

struct CaseName {
  template <class Plant>
  static std::string GetName(int) {
    return Case<Plant>::kName;
  }
};

bool same_bits(double a, double b) { return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b); }

// What the comparison met over a run.
struct Seen {
  std::int64_t points = 0, stuck = 0, moving = 0, engine_on = 0, mismatches = 0;
};

// Steps the plant one grid point at a time through the runner with its ECU (every observation
// there is the full outputs) and compares observe() with outputs(), derivatives() and
// crossings() at every point (t_n, x_n, modes_n, command_n): the point the runner observes.
template <class Plant, class Ecu>
Seen compare_over_run(const Plant& plant, Ecu& ecu, std::int64_t steps, std::int64_t ecu_ratio) {
  using Outputs = typename Plant::Outputs;
  using State = typename Plant::State;
  constexpr int kZ = Plant::kNumCrossings;
  hil::Runner<Plant, solvers::Rk4<Plant>, Ecu> runner(
      plant, {.total_steps = steps, .decimation = steps, .columns = {0}, .chunk_steps = 1, .ecu_ratio = ecu_ratio}, &ecu);
  const auto& src = Plant::kMetrics;
  // the fields observe() fills: those kMetrics names, and fault
  std::vector<double Outputs::*> observed{&Outputs::fault};
  for (double Outputs::*f : {src.speed_ref_m_s, src.speed_m_s, src.locked, src.engine_on, src.distance_m, src.soc,
                             src.fuel_g}) {
    if (f != nullptr) observed.push_back(f);
  }
  constexpr double kUntouched = -123456.789;
  Seen seen;
  for (;;) {
    const double t = runner.time_s();
    const State& x = runner.state();
    const auto& m = runner.modes();
    const auto& u = runner.command();
    Outputs full{}, obs{};
    for (const auto& s : plant.signals()) obs.*s.member = kUntouched;
    State dx_full, dx_obs, dx_deriv;
    double z_full[kZ], z_obs[kZ];
    plant.outputs(t, x, m, u, full, dx_full);
    plant.derivatives(t, x, m, u, dx_deriv);
    plant.crossings(t, x, m, u, z_full);
    plant.observe(t, x, m, u, obs, dx_obs, z_obs);
    // every field, with the same dx/dt and z: what the runner takes where a test reads them all
    Outputs all{};
    State dx_all;
    double z_all[kZ];
    plant.template observe<plant::OutputSet::kAll>(t, x, m, u, all, dx_all, z_all);
    bool same = true;
    for (const auto& s : plant.signals()) {
      if (!same_bits(all.*s.member, full.*s.member)) {
        ADD_FAILURE() << s.name << " at t = " << t << ": observe<kAll> " << all.*s.member << ", outputs "
                      << full.*s.member;
        same = false;
      }
    }
    for (int i = 0; i < Plant::kNumStates; ++i) same = same && same_bits(dx_all[i], dx_full[i]);
    for (int i = 0; i < kZ; ++i) same = same && same_bits(z_all[i], z_full[i]);
    EXPECT_TRUE(same) << "observe<kAll> at t = " << t << ": dx/dt or z differ from outputs() and crossings()";
    for (const auto& s : plant.signals()) {
      const bool is_observed = std::find(observed.begin(), observed.end(), s.member) != observed.end();
      if (is_observed ? !same_bits(obs.*s.member, full.*s.member) : !same_bits(obs.*s.member, kUntouched)) {
        ADD_FAILURE() << s.name << " at t = " << t << ": observe " << obs.*s.member << ", outputs "
                      << full.*s.member << (is_observed ? "" : " (should be left as it was)");
        same = false;
      }
    }
    for (int i = 0; i < Plant::kNumStates; ++i) {
      if (!same_bits(dx_obs[i], dx_full[i]) || !same_bits(dx_obs[i], dx_deriv[i])) {
        ADD_FAILURE() << "dx[" << i << "] at t = " << t << ": observe " << dx_obs[i] << ", outputs " << dx_full[i]
                      << ", derivatives " << dx_deriv[i];
        same = false;
      }
    }
    for (int i = 0; i < kZ; ++i) {
      if (!same_bits(z_obs[i], z_full[i])) {
        ADD_FAILURE() << "z[" << i << "] at t = " << t << ": observe " << z_obs[i] << ", crossings " << z_full[i];
        same = false;
      }
    }
    ++seen.points;
    seen.stuck += full.locked != 0.0 ? 1 : 0;
    seen.moving += full.locked == 0.0 ? 1 : 0;
    if (src.engine_on != nullptr) seen.engine_on += full.*src.engine_on != 0.0 ? 1 : 0;
    if (!same && ++seen.mismatches >= 5) break;  // enough to see what is wrong
    if (runner.finished()) break;
    runner.run();
    runner.clear_rows();
  }
  return seen;
}

template <class Plant>
class Observation : public ::testing::Test {};
TYPED_TEST_SUITE(Observation, GtestTypes<ObservedPlants>::type, CaseName);

TYPED_TEST(Observation, EqualsTheOutputsAtEveryGridPointOfItsCycle) {
  using Plant = TypeParam;
  using C = Case<Plant>;
  const hil::Scenario sc = test::load(test::source_path(C::kScenario));
  const Plant plant(sc.plant.get<typename Plant::Params>());
  auto ecu = C::ecu(sc);
  const Seen seen = compare_over_run(plant, ecu, sc.solver.steps, sc.solver.ecu_ratio);
  EXPECT_EQ(seen.mismatches, 0);
  EXPECT_EQ(seen.points, sc.solver.steps + 1);
  EXPECT_GT(seen.stuck, C::kMinStuck);  // standstills (the stuck crossing) and driving both met
  EXPECT_GT(seen.moving, C::kMinMoving);
  if (Plant::kMetrics.engine_on != nullptr) {  // engine on and off both met
    EXPECT_GT(seen.engine_on, C::kMinEachEngineState);
    EXPECT_GT(seen.points - seen.engine_on, C::kMinEachEngineState);
  }
}

// The fault bits come from the observation at every step the runner does not record: a state
// that is not finite, and a SOC outside its window, give the same bits as the outputs.
TYPED_TEST(Observation, FaultBitsEqualTheOutputs) {
  using Plant = TypeParam;
  const hil::Scenario sc = test::load(test::source_path(Case<Plant>::kScenario));
  typename Plant::Params p = sc.plant.get<typename Plant::Params>();
  p.battery.soc_max = p.battery.soc_initial - 0.01;  // starts outside the window
  const Plant plant(p);
  typename Plant::State x = plant.initial_state();
  const typename Plant::Modes m = plant.initial_modes(x);
  const typename Plant::Inputs u{};
  const double inf = std::numeric_limits<double>::infinity();
  for (const double bad : {0.0, std::nan(""), inf, -inf}) {
    x[Plant::kAuditOnlyStates.back()] = bad;  // a state no derivative reads: only the fault check sees it
    typename Plant::Outputs full, obs;
    typename Plant::State dx;
    double z[Plant::kNumCrossings];
    plant.outputs(1.0, x, m, u, full);
    plant.observe(1.0, x, m, u, obs, dx, z);
    EXPECT_TRUE(same_bits(obs.fault, full.fault)) << bad;
    const unsigned expected = kFaultSocWindow | (std::isfinite(bad) ? 0u : kFaultNonFinite);
    EXPECT_EQ(static_cast<unsigned>(obs.fault), expected) << bad;
  }
}

// Every position of an odd-sized vector and of the plants' states (vectorised sums).
template <class Vector>
void expect_all_finite_is_eigens(Vector x) {
  const double values[] = {1.0, -2.0, 0.0, -0.0, 1e308, -1e308, 4.9e-324};
  for (int i = 0; i < x.size(); ++i) x[i] = values[i % 7];
  EXPECT_TRUE(all_finite(x));
  const double inf = std::numeric_limits<double>::infinity();
  for (int i = 0; i < x.size(); ++i) {
    for (const double bad : {std::nan(""), -std::nan(""), inf, -inf}) {
      Vector y = x;
      y[i] = bad;
      EXPECT_EQ(all_finite(y), y.allFinite()) << i << " " << bad;
      EXPECT_FALSE(all_finite(y)) << i << " " << bad;
    }
  }
}

TEST(ObservationAllFinite, IsEigensAllFinite) {
  expect_all_finite_is_eigens(Eigen::Matrix<double, 7, 1>{});
  expect_all_finite_is_eigens(PsdPlant::State{});
  expect_all_finite_is_eigens(BevPlant::State{});
}

}  // namespace
}  // namespace ehpt::plant
