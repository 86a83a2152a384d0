// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Provenance: what made a result. The ehpt build (version, git description, compiler, flags)
// and, per run, the SHA-256 of every input file and the --set overrides, so that a
// summary.json can be traced to its code and inputs and the run re-created exactly. The run
// id is the one a sweep files the run under (hil/campaign/campaign.hpp): one function makes both.

#include <string>
#include <string_view>
#include <vector>

#include "hil/config/config.hpp"
#include "io/output_dir.hpp"

namespace ehpt::hil {

struct BuildInfo {
  std::string_view version;     // project(ehpt VERSION ...)
  std::string_view git;         // `git describe --always --dirty` of the source tree; empty: not built from git
  std::string_view compiler;    // "GNU 12.2.0"
  std::string_view flags;       // the C++ flags of the build type and every compile option
  std::string_view build_type;  // Release, Debug, ...
};
const BuildInfo& build_info();  // generated at build time (cmake/build_info.cmake)

// What gave the commands when not the scenario's built-in ECU (ExternalDriver): a bus ECU
// cannot be re-created from the input files, a replay can from its log.
struct CommandSource {
  std::string kind;               // "" the built-in ECU (or none, a rig); "external" (a bus ECU); "replay"
  std::string description;        // for the summary: the transport and pacing, or the log
  std::vector<InputFile> inputs;  // the files that hold the commands (a replay's inputs.log)
};

// `ehpt --version`: a few lines.
std::string version_text();

// The content address of a run: a SHA-256 over the bytes of every input file (their hashes
// and sizes, in the order read; paths left out, so the same files elsewhere are the same run)
// and the --set texts, in order; commands: the CommandSource kind ("" adds nothing, so a
// built-in run's id is the sweep's).
std::string run_id(const std::vector<InputFile>& inputs, const std::vector<std::string>& set_texts,
                   const std::string& commands = "");

// summary.json's "provenance": the build, the inputs (path, sha256, bytes; a replay's log
// last), the overrides, where the commands came from and the run id.
io::JsonObject provenance_json(const Scenario& sc, const CommandSource& commands = {});

}  // namespace ehpt::hil
