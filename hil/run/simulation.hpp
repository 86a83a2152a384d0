// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Simulation: one loaded scenario, ready to step, behind one type-erased interface (the CLI,
// the batch runner and later the Python module use it; none of them knows the vehicle's C++
// type). Each vehicle kind registers once (hil/kinds/registry.cpp): its factory and its signals;
// a new kind touches that table and nothing else that runs.

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "hil/config/config.hpp"
#include "hil/run/metrics.hpp"
#include "hil/run/runner.hpp"
#include "msgs/ev.hpp"
#include "msgs/psd.hpp"
#include "msgs/shev.hpp"
#include "plant/signals.hpp"

namespace ehpt::hil {

struct SignalInfo {
  std::string_view name;     // column header, SI unit as suffix
  std::string_view meaning;  // one line
};

struct SimulationOptions {
  std::vector<int> columns;              // indices into signals() to record; empty: all
  std::int64_t chunk_steps = 50000;      // most steps one run() takes; sizes the row buffer
  FaultPolicy fault_policy = FaultPolicy::kStop;
  // true: no built-in ECU; the caller reads the sensors and writes the commands between
  // steps (read_sensors, write_command), as an external ECU does
  bool external_ecu = false;
};

// The figures of a run that exist only for some vehicles (nullopt where there is none).
struct RunFigures {
  std::optional<double> distance_m;
  std::optional<double> soc_start, soc_end;
  std::optional<double> fuel_g;               // used during the run
  double fuel_density_kg_m3 = 0.0;            // with fuel_g: for L/100 km
};

// A test's record at the end of a run: when each fault acted, how each expectation ended (a
// figure's outcome is left for the caller, who has the figures).
struct TestRecord {
  std::vector<FaultSpan> faults;        // the scenario's faults, in order
  std::vector<ExpectOutcome> outcomes;  // the scenario's expectations, in order
};

// A saved state of a simulation (Simulation::save_state), opaque: only the simulation that
// saved it (or one built from the same scenario and options) can restore it.
class SimulationState {
 public:
  virtual ~SimulationState() = default;
};

class Simulation {
 public:
  virtual ~Simulation() = default;

  virtual std::span<const SignalInfo> signals() const = 0;
  // Run phase: up to chunk_steps steps (no allocation, no I/O); stop: non-zero ends the run.
  virtual std::int64_t run(const std::atomic<int>* stop = nullptr) = 0;
  virtual bool finished() const = 0;
  virtual std::int64_t step_index() const = 0;
  virtual std::int64_t total_steps() const = 0;
  virtual double time_s() const = 0;
  // Recorded rows since the last clear (row-major, the chosen columns).
  virtual std::span<const double> rows() const = 0;
  virtual void clear_rows() = 0;

  // Exactly n steps (n at most chunk_steps), e.g. one ECU period of an external ECU.
  virtual std::int64_t step(std::int64_t n) = 0;
  // Every signal's value now, in signals() order (into a buffer sized at start-up).
  virtual std::span<const double> outputs() = 0;
  // The messages, for an ECU outside (false: the vehicle is not of that family). Sensors are
  // sampled now and stamped; a command acts from the current step on.
  virtual bool read_sensors(msgs::EvSensors&) { return false; }
  virtual bool read_sensors(msgs::PsdSensors&) { return false; }
  virtual bool read_sensors(msgs::ShevSensors&) { return false; }
  virtual bool write_command(const msgs::EvCommand&) { return false; }
  virtual bool write_command(const msgs::PsdCommand&) { return false; }
  virtual bool write_command(const msgs::ShevCommand&) { return false; }
  // Start-up (external_ecu): an ECU port and its pacer plug into the runner's step loop
  // (hil/run/port.hpp): from then on run() and step() exchange with the port at every step
  // instead of stopping at each sample. false: the vehicle is not of that family.
  virtual bool attach(EcuPort<msgs::EvSensors, msgs::EvCommand>*, StepPacer*) { return false; }
  virtual bool attach(EcuPort<msgs::PsdSensors, msgs::PsdCommand>*, StepPacer*) { return false; }
  virtual bool attach(EcuPort<msgs::ShevSensors, msgs::ShevCommand>*, StepPacer*) { return false; }
  // With a port whose command comes between steps (an LS-BUS FMU, hil/run/runner.hpp): once,
  // after attach, the exchange at a run's last grid point waits for exchange_now() or the next
  // run(); exchange_now() does it (false without a port).
  virtual void defer_exchange() {}
  virtual bool exchange_now() { return false; }

  virtual const RunStats& stats() const = 0;
  virtual const MetricTotals& metrics() const = 0;
  virtual plant::EnergyAudit audit() const = 0;  // end of run; allocates
  virtual RunFigures figures() const = 0;
  // The end: the faults' spans and the expectations' outcomes (allocates).
  virtual TestRecord test_record() { return {}; }
  // Run phase: the faults acting at the current step (bit i: the scenario's fault[i]); a bus
  // plant reads it at each exchange for the faults that act on frames (hil/bus/bus_faults.hpp).
  virtual std::uint64_t fault_mask() const { return 0; }
  // Signals the CAN codec saturated (ecu.codec = "can"; else 0).
  virtual std::int64_t ecu_codec_saturations() const { return 0; }

  // Between steps, not in the run phase (it allocates): the whole state now (plant, ECU,
  // faults, expectations, runner), and back to such a state; the run then goes on from there
  // bit for bit as it did (an FMU's get/set FMU state, for importers that roll back). restore
  // is false for a state of another kind of simulation. Not with a port attached (a bus).
  virtual std::unique_ptr<SimulationState> save_state() const { return nullptr; }
  virtual bool restore_state(const SimulationState&) { return false; }
};

// The simulation of a loaded scenario, built by its vehicle kind's factory.
std::unique_ptr<Simulation> make_simulation(const Scenario& sc, const SimulationOptions& options);
// Loads a scenario (a path or a name, with --set style overrides) and builds its simulation;
// nullptr and every problem in errors if it cannot.
std::unique_ptr<Simulation> load_simulation(const std::string& scenario, const std::vector<std::string>& overrides,
                                            const SimulationOptions& options, std::vector<std::string>& errors);
// The output signals of the scenario's vehicle (ehpt signals, column choice).
std::vector<SignalInfo> scenario_signals(const Scenario& sc);
// The columns a run records (timeseries.csv): output.signals in their order, or every signal;
// indices into signals.
std::vector<int> chosen_columns(const Scenario& sc, std::span<const SignalInfo> signals);

}  // namespace ehpt::hil
