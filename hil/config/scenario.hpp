// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Finding scenarios by name and listing them (start-up only).

#include <string>
#include <vector>

namespace ehpt::hil {

// The scenarios folder: $EHPT_SCENARIOS (if not empty), else ./scenarios, else the
// installation's (<prefix>/share/ehpt/scenarios, <prefix> from where the running code is:
// <prefix>/bin/ehpt or <prefix>/lib/python3/dist-packages/ehpt*.so), else, for a binary in the
// build folder, the source tree's; "" if none.
std::string scenarios_dir();
// Where scenarios_dir() looked, for an error message.
std::string scenarios_search_text();
// A path as given if it names a file, else NAME or NAME.toml in scenarios_dir(). On failure
// returns "" and sets reason ("no such scenario file or name", "is a FIFO, not a regular
// file", ...). Never throws (over-long or unreadable paths are reasons too).
std::string resolve_scenario(const std::string& name_or_path, std::string& reason);

struct ScenarioEntry {
  std::string name, path, description;
};
std::vector<ScenarioEntry> list_scenarios(const std::string& dir);

// The plot tool's folder (plot.py): $EHPT_TOOLS_DIR (if not empty), else <prefix>/libexec/ehpt,
// else the source tree's tools/ for a binary in the build folder; "" if none.
std::string tools_dir();

}  // namespace ehpt::hil
