// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Scenario and vehicle files (TOML) -> validated parameters. Start-up only.
//
// A scenario names a vehicle file, a cycle, the solver and the outputs; its [vehicle]
// table and every `--set key=value` override the vehicle file key by key. Keys are strict:
// an unknown key is an error, so a typo cannot become a default. Every problem is collected
// and reported as "file:line: field = value: expectation" before anything runs.

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "hil/config/any_params.hpp"
#include "hil/config/test_spec.hpp"

namespace ehpt::hil {

enum class SolverKind { kRk4, kImplicitEuler };
const char* solver_name(SolverKind k);

// The longest run: 1e10 steps (116 days at 1 ms, about 40 minutes of computation at
// 250 ns per step). Anything longer is a typo in duration_s or step_s.
inline constexpr std::int64_t kMaxSteps = 10'000'000'000;

struct SolverSettings {
  SolverKind kind = SolverKind::kRk4;
  double step_s = 1e-3;
  double duration_s = 0.0;
  std::int64_t steps = 0;  // round(duration_s / step_s)
  std::int64_t ecu_ratio = 1;  // ECU period / step (vehicles with a built-in ECU)
  std::int64_t ecu_latency_steps = 0;  // a command acts this many steps after its sample
};

struct OutputSettings {
  std::vector<std::string> signals;  // empty: all of the plant's signals
  std::int64_t decimation = 100;     // write every n-th step (row 0 and the last step always)
  // false: no timeseries.csv, summary.json only (a sweep's default); the rows are still
  // computed, so trajectory_hash is the same either way
  bool timeseries = true;
};

// [ecu] period_s (default 0.01 s, the bus contract's cycle time, GenMsgCycleTime in
// io/can/ehpt.dbc; 0: every plant step) and latency_s (0: a command acts from the sample it
// was computed from), both whole multiples of solver.step_s. codec = "can": the built-in
// ECU's sensors and commands pass through the CAN codec (quantised exactly as on the bus), the
// in-process reference of a bus run.
inline constexpr double kDefaultEcuPeriod_s = 0.01;
enum class EcuCodec { kNone, kCan };
struct EcuTiming {
  double period_s = kDefaultEcuPeriod_s;
  double latency_s = 0.0;
  std::string codec = "none";  // "none" or "can"
};

// A file the scenario read (the scenario, vehicle, cycle, maps, road tables), with the SHA-256
// of its bytes: what a run depends on besides its overrides (a sweep's run id is made of these).
struct InputFile {
  std::string path;
  std::string sha256;  // 64 hex digits
  std::size_t bytes = 0;
};

struct Scenario {
  std::string name;         // file name without .toml
  std::string path;
  std::string description;
  std::string vehicle_path;
  std::string cycle_path;   // empty for rigs
  std::string kind;          // the vehicle file's `kind` (hil/kinds/<kind>.cpp)
  // the vehicle's parameters, of its kind's type (e.g. plant::BevParams: plant.get<plant::BevParams>())
  AnyParams plant;
  // the built-in ECU of vehicles that have one (the EV's follower, MBecu1/1soc/2); empty if none
  AnyParams ecu;
  EcuTiming ecu_timing;
  EcuCodec ecu_codec = EcuCodec::kNone;
  SolverSettings solver;
  OutputSettings output;
  std::vector<std::string> warnings;  // legal but surprising settings, "file:line: field = value: why"
  std::vector<InputFile> inputs;      // every file read, in the order read, each once
  std::vector<std::string> overrides; // the --set texts as given ("key=value"), in order
  // ECU tests (docs/testing.md): faults at the plant's message seams, expectations on its
  // outputs, and what the file says about itself; the --fault texts as given
  std::vector<FaultSpec> faults;
  std::vector<ExpectSpec> expects;
  TestSettings test;
  std::vector<std::string> fault_args;
  // a test file's `scenario = "NAME"`: the scenario it runs (empty: the file is the scenario)
  std::string base_path;
};

// A text as a TOML basic string, quotes and backslashes escaped, control characters as \u00XX:
// an override's value that must stay a string (a campaign's, the Python module's).
std::string toml_string(const std::string& text);

// overrides: "dotted.key=value" as given to --set (value parsed as TOML, else taken as text).
// faults: --fault texts ("kind=stuck target=batSOC at_s=10"), added to the file's [[fault]]s.
// A file with `scenario = "NAME"` (a test file) is read over that scenario: its keys override
// the scenario's, its [[fault]] and [[expect]] tables add to the scenario's.
bool load_scenario(const std::string& path, const std::vector<std::string>& overrides, Scenario& out,
                   std::vector<std::string>& errors);
bool load_scenario(const std::string& path, const std::vector<std::string>& overrides,
                   const std::vector<std::string>& faults, Scenario& out, std::vector<std::string>& errors);

// The files a series of loads shares (a sweep's plan loads every run's scenario: the same
// vehicle, maps and cycle each time), each read, hashed and parsed once: a load through it
// gives what load_scenario gives while the files do not change. For loads close together in
// time (one plan), not for a long-lived process: a file changed meanwhile is not read again.
class LoadCache {
 public:
  LoadCache();
  ~LoadCache();
  LoadCache(const LoadCache&) = delete;
  LoadCache& operator=(const LoadCache&) = delete;
  struct Files;
  Files& files() { return *files_; }

 private:
  std::unique_ptr<Files> files_;
};
bool load_scenario(const std::string& path, const std::vector<std::string>& overrides, Scenario& out,
                   std::vector<std::string>& errors, LoadCache& cache);

// A drive cycle given as numbers instead of a CSV file (the Python module's cycle=(t_s, v_m_s)):
// time in s, speed in m/s. It takes the place of the scenario's `cycle` file (cycle_periodic
// applies as to a file) and is checked by the same rules with the same messages, a value named
// "<name>:<index>" (0-based) where a file's is "file:line". Its numbers' bytes (time_s then
// speed_m_s, as stored) are an input of the run, listed under name with their SHA-256.
struct CycleArrays {
  std::string name = "<cycle arrays>";
  std::vector<double> time_s;
  std::vector<double> speed_m_s;
};

// Every number a load of the scenario reads, given or defaulted, keyed as --set writes it
// ("vehicle.vehicle.mass_kg"), in the order read, each once: what an FMU offers as its
// parameters (targets/fmu/). false and the load's problems if it does not load.
bool scenario_numbers(const std::string& path, const std::vector<std::string>& overrides,
                      std::vector<std::pair<std::string, double>>& numbers, std::vector<std::string>& errors);

// load_scenario with the cycle given as arrays.
bool load_scenario_with_cycle(const std::string& path, const std::vector<std::string>& overrides,
                              const CycleArrays& cycle, Scenario& out, std::vector<std::string>& errors);

}  // namespace ehpt::hil
