#pragma once
// A whole batch run of one scenario: build the plant, run it as fast as possible in chunks,
// stream timeseries.csv, write summary.json, commit the output folder. Start-up and
// shutdown may allocate and do I/O; the chunks in between are the run phase.

#include <atomic>
#include <iosfwd>
#include <string>

#include "hil/config.hpp"
#include "io/output_dir.hpp"

namespace ehpt::hil {

struct BatchOptions {
  std::string out_dir;               // final folder (written as out_dir.partial first)
  bool progress = false;             // "\r[ 42%] ..." on the log stream between chunks
  const std::atomic<bool>* stop = nullptr;  // set by SIGINT: stop, keep what was computed
};

struct BatchResult {
  int exit_code = 0;                 // 0 ok, 3 run-time fault, 130 interrupted, 1 output error
  io::JsonObject summary;
  std::string summary_text;          // human-readable lines for the terminal
};

BatchResult run_batch(const Scenario& scenario, const BatchOptions& options, std::ostream& log);

// Fault bits -> words ("SOC left its window, ...").
std::string fault_text(unsigned fault);

}  // namespace ehpt::hil
