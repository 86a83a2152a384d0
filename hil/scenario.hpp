#pragma once
// Finding scenarios by name and listing them (start-up only).

#include <string>
#include <vector>

namespace ehpt::hil {

// The scenarios folder: $EHPT_SCENARIOS, else ./scenarios, else the source tree's.
std::string scenarios_dir();
// A path as given if it exists, else NAME or NAME.toml in scenarios_dir(); "" if none.
std::string resolve_scenario(const std::string& name_or_path);

struct ScenarioEntry {
  std::string name, path, description;
};
std::vector<ScenarioEntry> list_scenarios(const std::string& dir);

// tools/ (plot.py): $EHPT_TOOLS_DIR, else the source tree's.
std::string tools_dir();

}  // namespace ehpt::hil
