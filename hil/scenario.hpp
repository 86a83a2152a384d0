#pragma once
// Finding scenarios by name and listing them (start-up only).

#include <string>
#include <vector>

namespace ehpt::hil {

// The scenarios folder: $EHPT_SCENARIOS, else ./scenarios, else, for a binary in the build
// folder, the source tree's, else the installation's (<prefix>/share/ehpt/scenarios, found
// from where the running code is); "" if none.
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

// The plot tool's folder (plot.py): $EHPT_TOOLS_DIR, else the source tree's tools/ for a
// binary in the build folder, else <prefix>/libexec/ehpt.
std::string tools_dir();

}  // namespace ehpt::hil
