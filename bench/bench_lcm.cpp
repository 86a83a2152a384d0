// SPDX-License-Identifier: BSD-3-Clause
// Lockstep SIL over LCM memq (one process, one thread: the ECU answers inside its LCM
// handler): ECU periods per second and the plant's round trip, next to the udpm and
// socketcand figures of tools/bus_bench.sh.
#include <benchmark/benchmark.h>

#include <vector>

#include "hil/bus/bus_plant.hpp"
#include "hil/config/config.hpp"
#include "hil/run/simulation.hpp"
#include "io/lcm/lcm_bus.hpp"
#include "io/lcm/lcm_codec.hpp"

namespace {

using namespace ehpt;

struct FollowerOnLcm {
  io::lcm::LcmBus* bus;
  std::vector<std::uint8_t> out = std::vector<std::uint8_t>(64);
  static void on_sample(const void* data, int size, void* user) {
    auto* self = static_cast<FollowerOnLcm*>(user);
    ehpt_lcm::ev_sensors_t m{};
    if (m.decode(data, 0, size) != size) return;
    ehpt_lcm::ev_command_t c{};
    c.utime = m.utime;
    c.step = m.step;
    c.driveTauRef_Nm = m.driverRequest_Nm;
    const int n = c.encode(self->out.data(), 0, static_cast<int>(self->out.size()));
    self->bus->publish("EHPT_ECU_COMMAND", self->out.data(), n);
  }
};

void BM_LcmMemqLockstep_ev(benchmark::State& state) {
  hil::Scenario sc;
  std::vector<std::string> errors;
  hil::load_scenario(std::string(EHPT_SOURCE_DIR) + "/scenarios/ev_nedc.toml", {"solver.duration_s=60"}, sc, errors);
  std::int64_t periods = 0;
  for (auto _ : state) {
    std::string error;
    auto bus = io::lcm::LcmBus::open("memq://", error);
    FollowerOnLcm ecu{bus.get()};
    bus->subscribe("EHPT_PLANT_STATUS", &FollowerOnLcm::on_sample, &ecu, error);
    hil::SimulationOptions opt;
    opt.external_ecu = true;
    opt.fault_policy = hil::FaultPolicy::kHold;
    auto sim = hil::make_simulation(sc, opt);
    hil::BusPlantOptions bo;
    bo.lockstep = true;
    auto driver = hil::make_bus_plant(sc, *bus, bo, error);
    driver->start(*sim, nullptr);
    while (!sim->finished()) {
      sim->run();
      sim->clear_rows();
    }
    periods += sim->total_steps() / sc.solver.ecu_ratio + 1;
  }
  state.counters["ecu_periods_per_s"] = benchmark::Counter(static_cast<double>(periods), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_LcmMemqLockstep_ev)->Unit(benchmark::kMillisecond);

}  // namespace
