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
//   # fault kind=... target=... at_s=...   (each --fault, in order)
//   # family ev | psd | shev
//   # pacing wall_clock | realtime | lockstep
//   ev  STEP SEQ STAMP_STEP STAMP_TIME_S driveTauRef_Nm
//   psd STEP SEQ STAMP_STEP STAMP_TIME_S icePowRef_W iceTauRef_Nm genTauRef_Nm motTauRef_Nm iceON
//   shev STEP SEQ STAMP_STEP STAMP_TIME_S driveTauRef_Nm gensetPowRef_W gensetON
// The run phase appends to a buffer reserved at start-up and writes it when 1 MB is buffered
// (about every 8 000 commands) and between chunks, as bus.log does. A replay reads it back as
// a stream: its memory does not grow with the log.

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "hil/config/config.hpp"
#include "msgs/ev.hpp"
#include "msgs/psd.hpp"
#include "msgs/shev.hpp"

namespace ehpt::hil {

inline constexpr const char* kInputsLogName = "inputs.log";

// A command as one line (without the newline, NUL-terminated) into buf; returns its length, or
// -1 if buf cannot hold the longest line of the family (320 bytes always can). No allocation.
int format_command(char* buf, std::size_t size, std::int64_t step, const msgs::EvCommand& c);
int format_command(char* buf, std::size_t size, std::int64_t step, const msgs::PsdCommand& c);
int format_command(char* buf, std::size_t size, std::int64_t step, const msgs::ShevCommand& c);

// An inputs.log's header and what a validating read found; the commands stay in the file
// (a log of a day's session is hundreds of MB: a replay streams it, InputsLogReader).
struct InputsLog {
  InputFile file;  // its SHA-256 and size (a replay's provenance)
  std::string scenario_path;
  std::vector<std::string> overrides;
  std::vector<std::string> faults;  // --fault one-offs (the scenario file's [[fault]] tables are in it)
  std::string family;  // "ev", "psd" or "shev"
  std::string pacing;
  std::int64_t commands = 0;
};

// Reads path through once, in fixed memory: false and "path:line: what" problems (at most
// 20) if it is not a well-formed log (steps must not decrease; every number finite; lines at
// most kMaxInputsLineBytes).
bool read_inputs_log(const std::string& path, InputsLog& out, std::vector<std::string>& problems);

inline constexpr std::size_t kMaxInputsLineBytes = 8192;

// One command line: FAMILY STEP SEQUENCE STAMP_STEP then the values (2 for ev, 6 for psd).
struct InputsLogLine {
  std::string_view family;  // points into the line
  std::int64_t step = 0, stamp_step = 0;
  std::uint32_t sequence = 0;
  std::array<double, 6> values{};
  std::size_t n_values = 0;
};
// Pure; no allocation unless it fails (why: what is wrong, without the file:line).
bool parse_inputs_line(std::string_view line, InputsLogLine& out, std::string& why);

struct InputsLogLines;  // a file as lines in fixed memory (session_log.cpp)

// The commands of a log read_inputs_log accepted, one at a time, in fixed memory (a 64 KiB
// block and one line, allocated with the reader). next() is false at the end or on a problem
// (error() then names file:line); a log that changed since it was validated is such a problem
// (its bytes or SHA-256 differ at the end).
class InputsLogReader {
 public:
  InputsLogReader(const std::string& path, const InputsLog& validated);
  ~InputsLogReader();
  InputsLogReader(const InputsLogReader&) = delete;
  InputsLogReader& operator=(const InputsLogReader&) = delete;

  bool next(std::int64_t& step, msgs::EvCommand& c);
  bool next(std::int64_t& step, msgs::PsdCommand& c);
  bool next(std::int64_t& step, msgs::ShevCommand& c);
  const std::string& error() const { return error_; }
  std::int64_t commands_read() const { return commands_; }

 private:
  bool next_line(InputsLogLine& l);

  std::string path_;
  InputFile expected_;
  std::string family_;
  std::unique_ptr<InputsLogLines> lines_;  // the file, a block of it and the current line (allocated once)
  std::int64_t last_step_ = 0, commands_ = 0;
  bool done_ = false;
  std::string error_;
};

// The header lines of a new log.
std::string inputs_log_header(const std::string& scenario_path, const std::vector<std::string>& overrides,
                              const std::vector<std::string>& faults,
                              const char* family, const char* pacing);

}  // namespace ehpt::hil
