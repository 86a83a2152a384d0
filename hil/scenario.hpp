#pragma once
// Finding scenarios by name and listing them (start-up only).

#include <string>
#include <vector>

namespace ehpt::hil {

// The scenarios folder: $EHPT_SCENARIOS, else ./scenarios, else the source tree's.
std::string scenarios_dir();
// A path as given if it names a file, else NAME or NAME.toml in scenarios_dir(). On failure
// returns "" and sets reason ("no such scenario file or name", "is a FIFO, not a regular
// file", ...). Never throws (over-long or unreadable paths are reasons too).
std::string resolve_scenario(const std::string& name_or_path, std::string& reason);

struct ScenarioEntry {
  std::string name, path, description;
};
std::vector<ScenarioEntry> list_scenarios(const std::string& dir);

// tools/ (plot.py): $EHPT_TOOLS_DIR, else the source tree's.
std::string tools_dir();

}  // namespace ehpt::hil
