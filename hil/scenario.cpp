#include "hil/scenario.hpp"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <system_error>

#include <toml++/toml.h>

#include "hil/toml_guard.hpp"
#include "io/text_file.hpp"

namespace fs = std::filesystem;

namespace ehpt::hil {

std::string scenarios_dir() {
  if (const char* env = std::getenv("EHPT_SCENARIOS")) return env;
  std::error_code ec;
  if (fs::is_directory("scenarios", ec)) return "scenarios";
  return std::string(EHPT_SOURCE_DIR) + "/scenarios";
}

std::string resolve_scenario(const std::string& name, std::string& reason) {
  std::error_code ec;
  // a bare name in the scenarios folder (a name with a slash is a path only)
  const auto by_name = [&]() -> std::string {
    if (name.find('/') != std::string::npos || name.empty()) return "";
    const std::string dir = scenarios_dir();
    for (const std::string& candidate : {dir + "/" + name, dir + "/" + name + ".toml"}) {
      std::error_code e;
      if (fs::is_regular_file(candidate, e)) return candidate;
    }
    return "";
  };
  const fs::file_status st = fs::status(name, ec);
  if (fs::exists(st)) {
    if (fs::is_regular_file(st)) return name;
    // a folder called like a scenario (its output folder: out/ev_nedc) does not hide the name
    if (std::string found = by_name(); !found.empty()) return found;
    reason = "is " + io::describe_path(name) + ", not a scenario file";
    return "";
  }
  if (ec && ec != std::errc::no_such_file_or_directory) {
    reason = ec.message();
    return "";
  }
  if (std::string found = by_name(); !found.empty()) return found;
  reason = "no such scenario file or name (see 'ehpt list')";
  return "";
}

std::vector<ScenarioEntry> list_scenarios(const std::string& dir) {
  std::vector<ScenarioEntry> out;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const fs::path& p = it->path();
    if (p.extension() != ".toml") continue;
    ScenarioEntry s{p.stem().string(), p.string(), ""};
    std::string text, reason;
    if (!io::read_text_file(p.string(), text, reason)) {
      s.description = "(cannot read: " + reason + ")";
    } else if (line_with_too_many_dots(text) != 0) {
      s.description = "(cannot parse)";
    } else {
      try {
        const toml::table t = toml::parse(text, p.string());
        s.description = t["description"].value_or(std::string());
      } catch (const toml::parse_error&) {
        s.description = "(cannot parse)";
      }
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
