// SPDX-License-Identifier: BSD-3-Clause
// Speed of the plants (Google Benchmark; figures, never test assertions).
//   BM_BevStep/<solver>:  one fixed step of the map-based EV (NEDC, h = 1 ms): sensing, the
//                         follower ECU and stepper.advance
//   BM_BevRun/<solver>:   a whole NEDC run through the batch runner (outputs and metrics every
//                         step, rows every 100); counters: ns_per_step, realtime_factor
//   BM_Psecu2Step:        the paper's PSecu2 (NEDC, h = 1 ms): ECU update + one advance();
//                         RK4, and /maps/implicit-euler
//   BM_Psecu2Run_nedc:    the whole 1400 s run through the runner with the ECU
//   BM_OneFlangeStep:     one step of the TestMBOneFlange rig
//   BM_EvRun_sort1/<vehicle>: a whole Sort1 run (150 s, RK4, h = 1 ms) of the map-based EV and
//                         the machine-drive EVs side by side (EvPm_bat: MTPA / flux weakening
//                         solved at every RK4 stage; EvAm_bat: the equivalent circuit)
#include <benchmark/benchmark.h>

#include "ecu/ev_follower.hpp"
#include "ecu/psd_ecu.hpp"
#include "hil/config/config.hpp"
#include "hil/run/runner.hpp"
#include "plant/bev_plant.hpp"
#include "plant/drive_rigs.hpp"
#include "plant/ev_machine_plant.hpp"
#include "plant/psd_plant.hpp"
#include "solvers/event_stepper.hpp"

namespace {

using namespace ehpt;

hil::Scenario load(const char* name) {
  hil::Scenario sc;
  std::vector<std::string> errors;
  if (!hil::load_scenario(std::string(EHPT_SOURCE_DIR) + "/scenarios/" + name, {}, sc, errors)) std::abort();
  return sc;
}

// Counters for `steps` plant steps of 1 ms: wall time per step, and simulated / wall time.
void set_step_counters(benchmark::State& state, double steps) {
  state.counters["ns_per_step"] = benchmark::Counter(steps, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["realtime_factor"] = benchmark::Counter(1e-3 * steps, benchmark::Counter::kIsRate);
}

template <class Integrator>
void BM_BevStep(benchmark::State& state) {
  const hil::Scenario sc = load("ev_nedc.toml");
  const plant::BevPlant plant(sc.plant.get<plant::BevParams>());
  Integrator integrator(plant);
  solvers::EventStepper<plant::BevPlant, Integrator> stepper(plant, integrator, 0.0, 1e-3);
  plant::BevPlant::State x = plant.initial_state();
  plant::BevPlant::Modes m = plant.initial_modes(x);
  ecu::EvFollower follower;
  msgs::EvSensors sensors;
  msgs::EvCommand command;
  std::int64_t n = 0;
  for (auto _ : state) {
    plant.sense(stepper.time_s(n), x, m, command, sensors);
    follower.update(sensors, command);
    stepper.advance(n, x, m, command);
    if (++n == 1184000) {  // wrap around the cycle
      n = 0;
      x = plant.initial_state();
      m = plant.initial_modes(x);
    }
    benchmark::DoNotOptimize(x);
  }
  set_step_counters(state, static_cast<double>(state.iterations()));
}
BENCHMARK(BM_BevStep<solvers::Rk4<plant::BevPlant>>)->Name("BM_BevStep/rk4");
BENCHMARK(BM_BevStep<solvers::ImplicitEuler<plant::BevPlant>>)->Name("BM_BevStep/implicit-euler");

template <class Integrator>
void BM_BevRun(benchmark::State& state) {
  const hil::Scenario sc = load("ev_nedc.toml");
  const plant::BevPlant plant(sc.plant.get<plant::BevParams>());
  std::int64_t steps = 0;
  for (auto _ : state) {
    ecu::EvFollower follower;
    hil::Runner<plant::BevPlant, Integrator, ecu::EvFollower> runner(
        plant, {.total_steps = sc.solver.steps, .decimation = 100, .columns = {0, 1, 2}, .chunk_steps = sc.solver.steps},
        &follower);
    runner.run();
    steps += runner.step_index();
    benchmark::DoNotOptimize(runner.state());
  }
  set_step_counters(state, static_cast<double>(steps));
}
BENCHMARK(BM_BevRun<solvers::Rk4<plant::BevPlant>>)->Name("BM_BevRun_nedc/rk4")->Unit(benchmark::kMillisecond);
BENCHMARK(BM_BevRun<solvers::ImplicitEuler<plant::BevPlant>>)
    ->Name("BM_BevRun_nedc/implicit-euler")
    ->Unit(benchmark::kMillisecond);

// The paper's PSecu2 on NEDC with MBecu2 every step (h = 1 ms): one step = ECU update (with
// the plant's sensing) + one advance(); and the whole 1400 s run through the runner.
// /maps: the default (gen and mot on efficiency maps); /eta1: the example source's set-up
// without drive losses, the workload these benchmarks measured before the maps were default.
template <class Integrator>
void psecu2_step(benchmark::State& state, const char* scenario) {
  const hil::Scenario sc = load(scenario);
  const auto& p = sc.plant.get<plant::PsdParams>();
  const plant::PsdPlant plant(p);
  const auto& ecu_params = sc.ecu.get<ecu::PsdEcuParams>();
  ecu::PsdEcu ecu(ecu_params, 1e-3);
  Integrator integrator(plant);
  solvers::EventStepper<plant::PsdPlant, Integrator> stepper(plant, integrator, 0.0, 1e-3);
  plant::PsdPlant::State x = plant.initial_state();
  plant::PsdPlant::Modes m = plant.initial_modes(x);
  msgs::PsdSensors sensors;
  msgs::PsdCommand bus;
  std::int64_t n = 0;
  for (auto _ : state) {
    plant.sense(stepper.time_s(n), x, m, bus, sensors);
    ecu.update(sensors, bus);
    stepper.advance(n, x, m, bus);
    if (++n == 1400000) {
      n = 0;
      x = plant.initial_state();
      m = plant.initial_modes(x);
      ecu = ecu::PsdEcu(ecu_params, 1e-3);
    }
    benchmark::DoNotOptimize(x);
  }
  set_step_counters(state, static_cast<double>(state.iterations()));
}
void BM_Psecu2Step(benchmark::State& state, const char* scenario) {
  psecu2_step<solvers::Rk4<plant::PsdPlant>>(state, scenario);
}
void BM_Psecu2StepIE(benchmark::State& state, const char* scenario) {
  psecu2_step<solvers::ImplicitEuler<plant::PsdPlant>>(state, scenario);
}
BENCHMARK_CAPTURE(BM_Psecu2Step, maps, "psecu2_nedc.toml");
BENCHMARK_CAPTURE(BM_Psecu2Step, eta1, "psecu2_source_nedc.toml");
BENCHMARK_CAPTURE(BM_Psecu2StepIE, maps, "psecu2_nedc.toml")->Name("BM_Psecu2Step/maps/implicit-euler");

void BM_Psecu2Run_nedc(benchmark::State& state, const char* scenario) {
  const hil::Scenario sc = load(scenario);
  const auto& p = sc.plant.get<plant::PsdParams>();
  const plant::PsdPlant plant(p);
  std::int64_t steps = 0;
  for (auto _ : state) {
    const auto& ecu_params = sc.ecu.get<ecu::PsdEcuParams>();
  ecu::PsdEcu ecu(ecu_params, 1e-3);
    hil::Runner<plant::PsdPlant, solvers::Rk4<plant::PsdPlant>, ecu::PsdEcu> runner(
        plant, {.total_steps = sc.solver.steps, .decimation = 100, .columns = {0, 1, 2}, .chunk_steps = sc.solver.steps},
        &ecu);
    runner.run();
    steps += runner.step_index();
    benchmark::DoNotOptimize(runner.state());
  }
  set_step_counters(state, static_cast<double>(steps));
}
BENCHMARK_CAPTURE(BM_Psecu2Run_nedc, maps, "psecu2_nedc.toml")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Psecu2Run_nedc, eta1, "psecu2_source_nedc.toml")->Unit(benchmark::kMillisecond);

void BM_OneFlangeStep(benchmark::State& state) {
  const hil::Scenario sc = load("one_flange_test.toml");
  const plant::DriveRig rig(sc.plant.get<plant::DriveRigParams>());
  solvers::Rk4<plant::DriveRig> rk4(rig);
  solvers::EventStepper<plant::DriveRig, solvers::Rk4<plant::DriveRig>> stepper(rig, rk4, 0.0, 1e-3);
  plant::DriveRig::State x = rig.initial_state();
  plant::DriveRig::Modes m{};
  std::int64_t n = 0;
  for (auto _ : state) {
    stepper.advance(n, x, m, {});
    if (++n == 50000) {
      n = 0;
      x = rig.initial_state();
    }
    benchmark::DoNotOptimize(x);
  }
}
BENCHMARK(BM_OneFlangeStep);

}  // namespace

BENCHMARK_MAIN();

namespace {

// A whole run of a vehicle with the follower ECU through the runner, as `ehpt run` does it.
template <class Plant>
void BM_EvRun(benchmark::State& state, const char* scenario) {
  const hil::Scenario sc = load(scenario);
  const Plant plant(sc.plant.get<typename Plant::Params>());
  using Integrator = solvers::Rk4<Plant>;
  std::int64_t steps = 0;
  for (auto _ : state) {
    ecu::EvFollower follower;
    hil::Runner<Plant, Integrator, ecu::EvFollower> runner(
        plant, {.total_steps = sc.solver.steps, .decimation = 100, .columns = {0, 1, 2}, .chunk_steps = sc.solver.steps},
        &follower);
    runner.run();
    steps += runner.step_index();
    benchmark::DoNotOptimize(runner.state());
  }
  set_step_counters(state, static_cast<double>(steps));
}

}  // namespace

void BM_EvRun_mbev(benchmark::State& state) { BM_EvRun<plant::BevPlant>(state, "ev_sort1.toml"); }
void BM_EvRun_evpm(benchmark::State& state) { BM_EvRun<plant::EvPmPlant>(state, "evpm_sort1.toml"); }
void BM_EvRun_evam(benchmark::State& state) { BM_EvRun<plant::EvAmPlant>(state, "evam_sort1.toml"); }
BENCHMARK(BM_EvRun_mbev)->Name("BM_EvRun_sort1/mbev")->Unit(benchmark::kMillisecond);
BENCHMARK(BM_EvRun_evpm)->Name("BM_EvRun_sort1/evpm_bat")->Unit(benchmark::kMillisecond);
BENCHMARK(BM_EvRun_evam)->Name("BM_EvRun_sort1/evam_bat")->Unit(benchmark::kMillisecond);
