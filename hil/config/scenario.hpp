// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Finding scenarios by name and listing them (start-up only).

#include <string>
#include <string_view>
#include <vector>

namespace ehpt::hil {

// The scenarios folder: $EHPT_SCENARIOS (if not empty), else ./scenarios, else the
// installation's (<prefix>/share/ehpt/scenarios, <prefix> from where the running code is:
// <prefix>/bin/ehpt or <prefix>/lib/python3/dist-packages/ehpt*.so), else, for a binary in the
// build folder, the source tree's, else the data folder this library was configured to be
// installed in (<CMAKE_INSTALL_PREFIX>/share/ehpt: a program of one's own that links the
// installed library); "" if none.
std::string scenarios_dir();
// Where scenarios_dir() looked, for an error message.
std::string scenarios_search_text();
// A path as given if it names a file, else NAME or NAME.toml in scenarios_dir(). On failure
// returns "" and sets reason ("no such scenario file or name", "is a FIFO, not a regular
// file", ...). Never throws (over-long or unreadable paths are reasons too).
std::string resolve_scenario(const std::string& name_or_path, std::string& reason);

// The shipped vehicle files (vehicles/NAME.toml), looked up as scenario names are: the folders
// below in this order, the first that holds NAME.toml gives it: vehicles/ next to
// $EHPT_SCENARIOS (if set), ./vehicles, <prefix>/share/ehpt/vehicles of the running code, the
// source tree's (a binary in the build folder), the configured install's.
std::vector<std::string> vehicles_dirs();
// The file of a vehicle name ("psecu2" or "psecu2.toml"); "" if none, with reason (which lists
// the shipped vehicles and suggests the closest name).
std::string resolve_vehicle(const std::string& name, std::string& reason);
// Every vehicle name the folders hold, sorted, each once.
std::vector<std::string> vehicle_names();
// The data folder compiled in for an installed library (<CMAKE_INSTALL_PREFIX>/share/ehpt), ""
// if the build did not say.
std::string configured_data_dir();

// The closest of candidates to word by edit distance (case-insensitive), "" if none is close
// (more than a third of the word's letters differ). For "did you mean" hints.
std::string closest_name(const std::string& word, const std::vector<std::string>& candidates);
// Levenshtein distance, case-insensitive.
std::size_t edit_distance(std::string_view a, std::string_view b);

struct ScenarioEntry {
  std::string name, path, description;
};
std::vector<ScenarioEntry> list_scenarios(const std::string& dir);

// The plot tool's folder (plot.py): $EHPT_TOOLS_DIR (if not empty), else <prefix>/libexec/ehpt,
// else the source tree's tools/ for a binary in the build folder; "" if none.
std::string tools_dir();

}  // namespace ehpt::hil
