#include "hil/scenario.hpp"

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <system_error>

#include <toml++/toml.h>

#include "hil/toml_guard.hpp"
#include "io/text_file.hpp"

namespace fs = std::filesystem;

namespace ehpt::hil {

namespace {

bool is_dir(const fs::path& p) {
  std::error_code ec;
  return fs::is_directory(p, ec);
}

// The folders the running code is in: the executable's (/proc/self/exe) and, when this code
// is in a shared object (the Python module), that object's. Real paths: a symbolic link in
// /usr/local/bin to an installed ehpt finds the installation's data.
std::vector<fs::path> code_dirs() {
  std::vector<fs::path> dirs;
  std::error_code ec;
  const fs::path exe = fs::canonical("/proc/self/exe", ec);
  if (!ec) dirs.push_back(exe.parent_path());
  Dl_info info{};
  if (::dladdr(reinterpret_cast<void*>(&code_dirs), &info) != 0 && info.dli_fname != nullptr &&
      info.dli_fname[0] == '/') {
    const fs::path object = fs::canonical(info.dli_fname, ec);
    if (!ec && (dirs.empty() || object.parent_path() != dirs.front())) dirs.push_back(object.parent_path());
  }
  return dirs;
}

// <prefix>/<relative> of an installation that holds this code: the code is in <prefix>/bin,
// or at most three folders below <prefix> (lib/python3/dist-packages); "" if none.
std::string installed(const std::string& relative) {
  for (const fs::path& dir : code_dirs()) {
    fs::path prefix = dir;
    for (int up = 0; up < 4 && !prefix.empty(); ++up, prefix = prefix.parent_path()) {
      if (is_dir(prefix / relative)) return (prefix / relative).string();
      if (prefix == prefix.root_path()) break;
    }
  }
  return "";
}

// The source tree's folder, for a binary that runs from this source tree's build folder
// only: an installed ehpt never reads the tree it was built from.
std::string in_source_tree(const std::string& relative) {
#if defined(EHPT_SOURCE_DIR) && defined(EHPT_BINARY_DIR)
  std::error_code ec;
  const fs::path build = fs::weakly_canonical(EHPT_BINARY_DIR, ec);
  if (ec) return "";
  for (const fs::path& dir : code_dirs()) {
    const auto [b, d] = std::mismatch(build.begin(), build.end(), dir.begin(), dir.end());
    if (b == build.end() && is_dir(fs::path(EHPT_SOURCE_DIR) / relative)) {
      return (fs::path(EHPT_SOURCE_DIR) / relative).string();
    }
  }
#else
  (void)relative;
#endif
  return "";
}

// $EHPT_SCENARIOS if set and not empty (an empty variable is as good as none)
const char* scenarios_env() {
  const char* env = std::getenv("EHPT_SCENARIOS");
  return env != nullptr && env[0] != '\0' ? env : nullptr;
}

}  // namespace

std::string scenarios_dir() {
  if (const char* env = scenarios_env()) return env;
  if (is_dir("scenarios")) return "scenarios";
  // a binary in a build folder uses its own source tree, even below an installed prefix
  if (std::string dir = in_source_tree("scenarios"); !dir.empty()) return dir;
  return installed("share/ehpt/scenarios");
}

std::string scenarios_search_text() {
  if (scenarios_env() != nullptr) return "$EHPT_SCENARIOS";
  std::string s = "./scenarios";
  if (!in_source_tree("").empty()) s += ", the source tree";
  for (const fs::path& dir : code_dirs()) s += ", share/ehpt/scenarios up to 3 folders above " + dir.string();
  return s;
}

std::string resolve_scenario(const std::string& name, std::string& reason) {
  std::error_code ec;
  // a bare name in the scenarios folder (a name with a slash is a path only)
  const auto by_name = [&]() -> std::string {
    if (name.find('/') != std::string::npos || name.empty()) return "";
    const std::string dir = scenarios_dir();
    if (dir.empty()) return "";  // no folder: never "/" + name at the root
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
  const std::string dir = scenarios_dir();
  reason = "no such scenario file or name (see 'ehpt list'; " +
           (dir.empty() ? "no scenarios folder found: looked in " + scenarios_search_text() : "names are looked up in " + dir) +
           ")";
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
  if (std::string dir = in_source_tree("tools"); !dir.empty()) return dir;
  if (std::string dir = installed("libexec/ehpt"); !dir.empty()) return dir;
  return "/usr/libexec/ehpt";  // named in the error if the plot tool is not there either
}

}  // namespace ehpt::hil
