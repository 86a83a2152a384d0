// SPDX-License-Identifier: BSD-3-Clause
#include "hil/config/scenario.hpp"

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <system_error>

#include <toml++/toml.h>

#include "hil/config/toml_guard.hpp"
#include "io/text_file.hpp"

namespace fs = std::filesystem;

namespace ehpt::hil {

namespace {

bool is_dir(const fs::path& p) {
  std::error_code ec;
  return fs::is_directory(p, ec);
}

// The folder of the file the running code is in: the executable (/proc/self/exe), or the
// shared object that holds this code (the Python module; dladdr). Real paths, so a symbolic
// link in /usr/local/bin to an installed ehpt finds its data.
struct CodeFile {
  fs::path dir;
  bool shared_object = false;
};
CodeFile code_file() {
  std::error_code ec;
  const fs::path exe = fs::canonical("/proc/self/exe", ec);
  Dl_info info{};
  if (::dladdr(reinterpret_cast<void*>(&code_file), &info) != 0 && info.dli_fname != nullptr &&
      info.dli_fname[0] == '/') {
    std::error_code e;
    const fs::path object = fs::canonical(info.dli_fname, e);
    if (!e && object != exe) return {object.parent_path(), true};
  }
  return {ec ? fs::path() : exe.parent_path(), false};
}

// The prefix of the installation that holds the running code, by the exact layouts of
// `cmake --install` (never by climbing further: a copy of ehpt in /tmp/x/bin must not take
// /tmp/share or /tmp/libexec, which anyone can write): <prefix>/bin/ehpt for the executable,
// <prefix>/lib/python3/dist-packages/ehpt*.so for the Python module (whose process's
// executable, /usr/bin/python3, says nothing about ehpt's prefix).
fs::path code_prefix() {
  const CodeFile f = code_file();
  if (f.dir.empty()) return {};
  return f.shared_object ? f.dir.parent_path().parent_path().parent_path() : f.dir.parent_path();
}

// <prefix>/<relative> if that folder exists; "" if not.
std::string installed(const std::string& relative) {
  const fs::path prefix = code_prefix();
  return !prefix.empty() && is_dir(prefix / relative) ? (prefix / relative).string() : "";
}

// The source tree's folder, for a binary that runs from this source tree's build folder
// only: an installed ehpt never reads the tree it was built from.
std::string in_source_tree(const std::string& relative) {
#if defined(EHPT_SOURCE_DIR) && defined(EHPT_BINARY_DIR)
  std::error_code ec;
  const fs::path build = fs::weakly_canonical(EHPT_BINARY_DIR, ec);
  if (ec) return "";
  const fs::path dir = code_file().dir;
  const auto [b, d] = std::mismatch(build.begin(), build.end(), dir.begin(), dir.end());
  if (b == build.end() && is_dir(fs::path(EHPT_SOURCE_DIR) / relative)) {
    return (fs::path(EHPT_SOURCE_DIR) / relative).string();
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
  // an installed ehpt uses its own data (also one installed into a folder of the build tree)
  if (std::string dir = installed("share/ehpt/scenarios"); !dir.empty()) return dir;
  return in_source_tree("scenarios");
}

std::string scenarios_search_text() {
  if (scenarios_env() != nullptr) return "$EHPT_SCENARIOS";
  std::string s = "./scenarios";
  if (const fs::path prefix = code_prefix(); !prefix.empty()) s += ", " + (prefix / "share/ehpt/scenarios").string();
  if (!in_source_tree("").empty()) s += ", the source tree";
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
  if (const char* env = std::getenv("EHPT_TOOLS_DIR"); env != nullptr && env[0] != '\0') return env;
  if (std::string dir = installed("libexec/ehpt"); !dir.empty()) return dir;
  return in_source_tree("tools");
}

}  // namespace ehpt::hil
