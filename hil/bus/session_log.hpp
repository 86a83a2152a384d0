// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Record and replay of a bus session (issue 11 §4). A wall-clock or real-time `ehpt plant`
// session depends on when the ECU's commands arrived; the plant writes every command it
// applied (the ECU's, and the safe state's at a timeout) with the step index from which it
// acted into inputs.log in its output folder. `ehpt replay RUN_DIR` loads the same scenario
// with the same overrides and applies the same commands at the same steps, offline and as
// fast as possible: the trajectory is the session's, bit for bit (summary.json's
// trajectory_hash says so).
//
// inputs.log, text, one command per line (numbers with 17 significant digits: exact):
//   # ehpt inputs log 1
//   # scenario /abs/path/scenario.toml
//   # set key=value                        (each --set, in order)
//   # family ev | psd
//   # pacing wall_clock | realtime | lockstep
//   ev  STEP SEQ STAMP_STEP STAMP_TIME_S driveTauRef_Nm
//   psd STEP SEQ STAMP_STEP STAMP_TIME_S icePowRef_W iceTauRef_Nm genTauRef_Nm motTauRef_Nm iceON
// The run phase appends to a buffer reserved at start-up and writes it when 1 MB is buffered
// (about every 8 000 commands) and between chunks, as bus.log does.

#include <cstdint>
#include <string>
#include <vector>

#include "hil/config/config.hpp"
#include "msgs/ev.hpp"
#include "msgs/psd.hpp"

namespace ehpt::hil {

inline constexpr const char* kInputsLogName = "inputs.log";

template <class Command>
struct RecordedCommand {
  std::int64_t step = 0;  // the command acted from this step on
  Command command{};
};

// A command as one line (without the newline) into buf; returns its length. No allocation.
int format_command(char* buf, std::size_t size, std::int64_t step, const msgs::EvCommand& c);
int format_command(char* buf, std::size_t size, std::int64_t step, const msgs::PsdCommand& c);

// A whole inputs.log, read at start-up.
struct InputsLog {
  InputFile file;  // its SHA-256 and size (a replay's provenance)
  std::string scenario_path;
  std::vector<std::string> overrides;
  std::string family;  // "ev" or "psd"
  std::string pacing;
  std::vector<RecordedCommand<msgs::EvCommand>> ev;
  std::vector<RecordedCommand<msgs::PsdCommand>> psd;
};

// Reads path; false and "path:line: what" problems if it is not a well-formed log (steps must
// not decrease; every number finite).
bool read_inputs_log(const std::string& path, InputsLog& out, std::vector<std::string>& problems);

// The header lines of a new log.
std::string inputs_log_header(const std::string& scenario_path, const std::vector<std::string>& overrides,
                              const char* family, const char* pacing);

}  // namespace ehpt::hil
