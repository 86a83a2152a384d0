// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// A whole batch run of one scenario: build the plant, run it as fast as possible in chunks,
// stream timeseries.csv, write summary.json, commit the output folder. Start-up and
// shutdown may allocate and do I/O; the chunks in between are the run phase.

#include <atomic>
#include <cmath>
#include <functional>
#include <iosfwd>
#include <limits>
#include <string>
#include <vector>

#include "hil/config/config.hpp"
#include "hil/diag/provenance.hpp"
#include "hil/run/realtime.hpp"
#include "io/output_dir.hpp"

namespace ehpt::hil {

class Simulation;

// A run whose ECU is outside (a bus target, a replayed session): the simulation is built
// without its built-in ECU and holds on through faults (an HIL plant reports them on the bus).
// What the link to an outside ECU did, for a test's figures (`ecu_timeouts`, `safe_state_s`):
// the commands that timed out, the time the plant spent in its safe state. A run with the
// built-in ECU has no link: 0 and 0. NaN where a driver cannot tell (an expectation on it
// then fails, never passes by accident).
struct LinkFigures {
  double ecu_timeouts = 0.0;
  double safe_state_s = 0.0;
};

// The driver is a port of the runner's step loop (hil/run/port.hpp), plugged in by start();
// between chunks the batch writes the recorded rows and asks the driver to flush its files.
class ExternalDriver {
 public:
  virtual ~ExternalDriver() = default;
  // Start-up: the output folder is open; false and error if the driver's files cannot be made.
  virtual bool open(const io::OutputDir& dir, std::string& error) = 0;
  // Instead of open, for a run into memory (run_in_memory: no folder): its files are not written.
  virtual void discard_files() {}
  // Start-up, before t = 0 (may wait for the ECU; not timed): plugs its port (and its pacer,
  // if it paces: the wall clock) into the simulation (Simulation::attach). stop: non-zero
  // ends its waits, then and in the run.
  virtual void start(Simulation& sim, const std::atomic<int>* stop) = 0;
  // The real-time loop (BatchOptions::realtime) paces the steps itself: false and why if
  // this driver cannot run so (lockstep waits for the ECU).
  virtual bool realtime_capable(std::string& why) const {
    why = "this driver has no real-time mode";
    return false;
  }
  // The real-time loop's IO figure: the time its port spent in the loop since the last call.
  virtual std::int64_t take_io_ns() { return 0; }
  // Called by the real-time loop's writer thread, concurrently with the loop: the driver
  // writes its files (bus.log) from buffers the loop handed over, so no file write blocks a tick.
  virtual void background_flush() {}
  // Between chunks and at the end: the driver's own files (bus.log); false and error on failure.
  virtual bool flush(std::string& error) = 0;
  // Once, after the last step: what ends its files (an ASC log's last line), then flush.
  virtual bool finish(std::string& error) { return flush(error); }
  // The end: its figures, into summary.json ("bus") and onto the terminal.
  virtual void report(io::JsonObject& summary, std::string& text) const = 0;
  // summary.json's provenance: where the commands came from (they are not the built-in ECU's).
  virtual CommandSource command_source() const = 0;
  // The end: why the session did not do what a session must (no ECU, commands that timed
  // out, a bus that reported errors or dropped frames); empty if it did. Any reason makes the
  // run's status "degraded" (summary.json status and degraded, the last line, exit 4).
  virtual std::vector<std::string> degraded_reasons() const { return {}; }
  // Whether it acts out the scenario's bus faults (hil/bus/bus_faults.hpp): a CAN bus plant
  // does, a replay reads back what they did (inputs.log); every other run refuses them.
  virtual bool takes_bus_faults() const { return false; }
  // The end: its figures for a test (LinkFigures).
  virtual LinkFigures link_figures() const { return {NAN, NAN}; }
  // Between steps, a bus plant whose commands come in an FMU's Event Mode (BusPlantOptions::
  // event_mode): if the simulation stopped at an ECU sample step not yet sent, its sensors go
  // out now (true); the command then comes before the next step (Simulation::exchange_now).
  virtual bool send_ahead() { return false; }
};

struct BatchOptions {
  std::string out_dir;               // final folder (written as out_dir.partial-<pid> first)
  bool progress = false;             // "\r[ 42%] ..." on the log stream between chunks
  // set to a signal number (SIGINT, SIGTERM, SIGHUP) to stop; what was computed is kept
  const std::atomic<int>* stop_signal = nullptr;
  // called with the temporary folder after the outputs are written and before it is
  // committed (the plot tool draws there, so its figures are part of the run's manifest);
  // returns false on failure (the run is still committed, BatchResult::after_failed is set)
  std::function<bool(const std::string& dir)> before_commit;
  ExternalDriver* driver = nullptr;  // null: the built-in ECU, as fast as possible
  // set: the real-time loop (SCHED_FIFO, absolute deadlines, rows to a writer thread)
  const RealtimeOptions* realtime = nullptr;
  // a degraded session (ExternalDriver::degraded_reasons) exits 0 instead of 4; its status
  // stays "degraded"
  bool allow_degraded = false;
};

// The exit code of a degraded bus session (docs/cli.md).
inline constexpr int kExitDegraded = 4;

// A run whose energy audit does not close to this relative residual (0.1 %) is flagged.
// Measured on every shipped scenario at 1 ms: RK4 closes to 1e-14..4e-11, implicit Euler
// (first order, and the energy integrals with it) to 3e-6..1.3e-4; a step that is too
// coarse for the dynamics gives percent (step_s = 1 s on Sort1: 30 %).
inline constexpr double kAuditWarnRelative = 1e-3;

// A test's verdict (a scenario with faults or expectations; docs/testing.md).
struct ExpectLine {
  ExpectSpec spec;  // as the test states it
  std::string name;
  bool passed = false;
  std::string message;                         // what was expected and what happened
  double time_s = std::numeric_limits<double>::quiet_NaN();  // where it was decided (NaN: nowhere)
  double value = std::numeric_limits<double>::quiet_NaN();
  // the window it was judged over, in s (NaN: none, e.g. a within whose event never came)
  double window_from_s = std::numeric_limits<double>::quiet_NaN();
  double window_to_s = std::numeric_limits<double>::quiet_NaN();
};
struct FaultLine {
  std::string name, kind, target;
  double first_s = std::numeric_limits<double>::quiet_NaN(), last_s = std::numeric_limits<double>::quiet_NaN();
  std::int64_t active_steps = 0;
};
struct TestVerdict {
  bool present = false;      // the scenario is a test
  bool expect_fail = false;  // written to fail
  bool all_held = false;     // every expectation held (and the run did what it was asked)
  bool passed = false;       // all_held, or (expect_fail) not all_held
  std::vector<ExpectLine> expectations;
  std::vector<FaultLine> faults;
  std::string first_failure;  // the first expectation that failed: "name: message"
};
// The exit code of `ehpt run` when a scenario's expectation failed.
inline constexpr int kExitExpectationFailed = 5;

struct BatchResult {
  int exit_code = 0;  // 0 ok, 3 run-time fault, 4 degraded session, 128 + signal interrupted, 1 output error
  std::vector<std::string> degraded;  // why the session was degraded (empty: it was not)
  TestVerdict test;                   // a test's verdict (test.present)
  io::JsonObject summary;
  std::string summary_text;          // human-readable lines for the terminal
  std::vector<std::string> warnings; // for the terminal: "warning: ..."
  bool after_failed = false;         // before_commit returned false
  std::string results_dir;           // where the outputs are: the --out folder, or (an
                                     // interrupted run that did not replace an earlier one)
                                     // its temporary folder
};

BatchResult run_batch(const Scenario& scenario, const BatchOptions& options, std::ostream& log);

// "" if this run can act out the scenario's bus faults (none, or a driver that takes them:
// ExternalDriver::takes_bus_faults); else why not and what would. driver: nullptr for a run
// with the built-in ECU (ehpt run, the Python module).
std::string bus_faults_refused(const Scenario& scenario, const ExternalDriver* driver);

// The same run as run_batch with the built-in ECU, as fast as possible, into memory: no folder,
// no file, no progress line (the Python module's ehpt.run). The rows are the doubles
// timeseries.csv would hold (row-major, the scenario's columns; empty with output.timeseries
// off), so the summary's trajectory_hash is the CLI's.
struct MemoryRun : BatchResult {
  std::vector<std::string> columns;  // signal names, as the CSV header
  std::vector<double> rows;          // row-major, columns.size() per row
};
// driver: as run_batch's (its files discarded; hil/bus/in_process_bus.hpp for bus faults).
MemoryRun run_in_memory(const Scenario& scenario, const std::atomic<int>* stop = nullptr,
                        ExternalDriver* driver = nullptr);

// A test's verdict on a simulation as it stands: summary.json's "test" object (JSON text), its
// expectations judged as if the run ended at its last step (a window not reached yet fails).
// Empty if the scenario is no test. The simulation steps on unchanged (the Python module's
// Simulation.verdict()).
std::string test_verdict_json(const Scenario& scenario, Simulation& sim);

// Fault bits -> words ("SOC left its window, ...").
std::string fault_text(unsigned fault);

}  // namespace ehpt::hil
