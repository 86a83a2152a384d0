#include "hil/scenario.hpp"

#include <algorithm>
#include <cstdlib>
#include <filesystem>

#include <toml++/toml.h>

namespace fs = std::filesystem;

namespace ehpt::hil {

std::string scenarios_dir() {
  if (const char* env = std::getenv("EHPT_SCENARIOS")) return env;
  if (fs::is_directory("scenarios")) return "scenarios";
  return std::string(EHPT_SOURCE_DIR) + "/scenarios";
}

std::string resolve_scenario(const std::string& name) {
  if (fs::is_regular_file(name)) return name;
  const std::string dir = scenarios_dir();
  for (const std::string& candidate : {dir + "/" + name, dir + "/" + name + ".toml"}) {
    if (fs::is_regular_file(candidate)) return candidate;
  }
  return "";
}

std::vector<ScenarioEntry> list_scenarios(const std::string& dir) {
  std::vector<ScenarioEntry> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (e.path().extension() != ".toml") continue;
    ScenarioEntry s{e.path().stem().string(), e.path().string(), ""};
    try {
      const toml::table t = toml::parse_file(e.path().string());
      s.description = t["description"].value_or(std::string());
    } catch (const std::exception&) {
      s.description = "(cannot parse)";
    }
    out.push_back(std::move(s));
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
  return out;
}

std::string tools_dir() {
  if (const char* env = std::getenv("EHPT_TOOLS_DIR")) return env;
  return std::string(EHPT_SOURCE_DIR) + "/tools";
}

}  // namespace ehpt::hil
