// SPDX-License-Identifier: BSD-3-Clause
// A vehicle of ehpt driven by an ECU of one's own, in one's own C++ harness: load the
// installed ev_nedc scenario without its built-in ECU, and once per ECU period read the
// sensors, compute the command and write it, then step the plant to the next sample.
//
//   embed_ecu [--torque-limit-Nm T] [--scenario NAME|PATH]
//
// --scenario takes a file or a scenario's name ("ev_nedc"), looked up as `ehpt run` does; the
// installed library knows its data folder, so a name resolves in this program too.
//
// The ECU here is the EV's driver-follower with an optional torque limit. Without a limit its
// commands are the built-in ECU's, so the run is `ehpt run ev_nedc` bit for bit: the harness
// prints the final distance and SOC with 17 digits to compare with that run's summary.json.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "hil/config/config.hpp"
#include "hil/config/scenario.hpp"
#include "hil/run/simulation.hpp"
#include "msgs/ev.hpp"

namespace {

// The ECU of this harness: pure, so it can be tested on its own.
ehpt::msgs::EvCommand my_ecu(const ehpt::msgs::EvSensors& s, double torque_limit_Nm) {
  ehpt::msgs::EvCommand c;
  c.driveTauRef_Nm = std::clamp(s.driverRequest_Nm, -torque_limit_Nm, torque_limit_Nm);
  return c;
}

int usage(const char* why) {
  std::fprintf(stderr, "error: %s\nusage: embed_ecu [--torque-limit-Nm T] [--scenario NAME|PATH]\n", why);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  double torque_limit_Nm = INFINITY;
  std::string scenario = std::string(EHPT_DATA_DIR) + "/scenarios/ev_nedc.toml";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) return usage(("missing value after " + a).c_str());
    const std::string v = argv[++i];
    if (a == "--torque-limit-Nm") {
      char* end = nullptr;
      torque_limit_Nm = std::strtod(v.c_str(), &end);
      if (end == v.c_str() || *end != '\0' || !(torque_limit_Nm > 0.0)) return usage("--torque-limit-Nm must be > 0");
    } else if (a == "--scenario") {
      std::string reason;
      scenario = ehpt::hil::resolve_scenario(v, reason);
      if (scenario.empty()) {
        std::fprintf(stderr, "error: %s: %s\n", v.c_str(), reason.c_str());
        return 2;
      }
    } else {
      return usage(("unknown option " + a).c_str());
    }
  }

  // start-up: load and validate (every problem named with file:line), build the plant
  ehpt::hil::Scenario sc;
  std::vector<std::string> errors;
  if (!ehpt::hil::load_scenario(scenario, {}, sc, errors)) {
    for (const std::string& e : errors) std::fprintf(stderr, "error: %s\n", e.c_str());
    return 2;
  }
  ehpt::hil::SimulationOptions options;
  options.external_ecu = true;  // no built-in ECU: the commands are ours
  const std::unique_ptr<ehpt::hil::Simulation> sim = ehpt::hil::make_simulation(sc, options);
  const std::int64_t period_steps =
      std::max<std::int64_t>(1, std::llround(sc.ecu_timing.period_s / sc.solver.step_s));

  // run: one ECU sample per period, as a lockstep ECU on a bus would see it
  ehpt::msgs::EvSensors sensors;
  if (!sim->read_sensors(sensors)) {
    std::fprintf(stderr, "error: %s is not an EV (no EvSensors)\n", scenario.c_str());
    return 2;
  }
  while (!sim->finished()) {
    sim->read_sensors(sensors);
    sim->write_command(my_ecu(sensors, torque_limit_Nm));
    sim->step(std::min(period_steps, sim->total_steps() - sim->step_index()));
    sim->clear_rows();  // the recorded rows (sim->rows()) are not used here: the buffer is reused
  }

  const ehpt::hil::RunFigures f = sim->figures();
  std::printf("distance_m %.17g\nsoc_end %.17g\nsteps %lld\nfault %u\n", f.distance_m.value_or(NAN),
              f.soc_end.value_or(NAN), static_cast<long long>(sim->step_index()), sim->stats().fault);
  return sim->stats().fault != 0 ? 3 : 0;
}
