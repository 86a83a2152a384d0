#pragma once
// Provenance: what made a result. The ehpt build (version, git description, compiler, flags)
// and, per run, the SHA-256 of every input file and the --set overrides, so that a
// summary.json can be traced to its code and inputs and the run re-created exactly. The run
// id is the one a sweep files the run under (hil/campaign.hpp): one function makes both.

#include <string>
#include <string_view>
#include <vector>

#include "hil/config.hpp"
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

// `ehpt --version`: a few lines.
std::string version_text();

// The content address of a run: a SHA-256 over the bytes of every input file (their hashes
// and sizes, in the order read; paths left out, so the same files elsewhere are the same run)
// and the --set texts, in order.
std::string run_id(const std::vector<InputFile>& inputs, const std::vector<std::string>& set_texts);

// summary.json's "provenance": the build, the inputs (path, sha256, bytes), the overrides and
// the run id.
io::JsonObject provenance_json(const Scenario& sc);

}  // namespace ehpt::hil
