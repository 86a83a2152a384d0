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

// <configured data dir>/<relative> if that folder exists, else "". The folder the library was
// configured to be installed in (CMake's EHPT_DATA_INSTALL_DIR under CMAKE_INSTALL_PREFIX, an
// absolute path compiled in): the last place looked, for a program of one's own that links the
// installed static library (its executable says nothing about ehpt's prefix). A fixed path,
// never one derived by climbing from where the code is.
std::string configured(const std::string& relative) {
  const std::string dir = configured_data_dir();
  if (dir.empty() || relative.empty()) return dir;
  return is_dir(fs::path(dir) / relative) ? (fs::path(dir) / relative).string() : "";
}

}  // namespace

std::string configured_data_dir() {
#if defined(EHPT_INSTALLED_DATA_DIR)
  const std::string dir = EHPT_INSTALLED_DATA_DIR;
  return fs::path(dir).is_absolute() ? dir : "";
#else
  return "";
#endif
}

std::string scenarios_dir() {
  if (const char* env = scenarios_env()) return env;
  if (is_dir("scenarios")) return "scenarios";
  // an installed ehpt uses its own data (also one installed into a folder of the build tree)
  if (std::string dir = installed("share/ehpt/scenarios"); !dir.empty()) return dir;
  if (std::string dir = in_source_tree("scenarios"); !dir.empty()) return dir;
  return configured("scenarios");
}

std::string scenarios_search_text() {
  if (scenarios_env() != nullptr) return "$EHPT_SCENARIOS";
  std::string s = "./scenarios";
  if (const fs::path prefix = code_prefix(); !prefix.empty()) s += ", " + (prefix / "share/ehpt/scenarios").string();
  if (!in_source_tree("").empty()) s += ", the source tree";
  if (const std::string dir = configured_data_dir(); !dir.empty() && dir != (code_prefix() / "share/ehpt").string()) {
    s += ", " + (fs::path(dir) / "scenarios").string();
  }
  return s;
}

std::vector<std::string> vehicles_dirs() {
  std::vector<std::string> out;
  const auto add = [&](const std::string& dir) {
    if (!dir.empty() && is_dir(dir) && std::find(out.begin(), out.end(), dir) == out.end()) out.push_back(dir);
  };
  if (const char* env = scenarios_env()) add((fs::path(env).parent_path() / "vehicles").string());
  if (is_dir("vehicles")) add("vehicles");
  add(installed("share/ehpt/vehicles"));
  add(in_source_tree("vehicles"));
  add(configured("vehicles"));
  return out;
}

std::vector<std::string> vehicle_names() {
  std::vector<std::string> names;
  for (const std::string& dir : vehicles_dirs()) {
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
      std::error_code e;
      if (it->path().extension() == ".toml" && fs::is_regular_file(it->path(), e)) names.push_back(it->path().stem().string());
    }
  }
  std::sort(names.begin(), names.end());
  names.erase(std::unique(names.begin(), names.end()), names.end());
  return names;
}

std::string resolve_vehicle(const std::string& name, std::string& reason) {
  std::string stem = name;
  if (stem.size() > 5 && stem.ends_with(".toml")) stem.resize(stem.size() - 5);
  const std::vector<std::string> dirs = vehicles_dirs();
  if (!stem.empty() && stem.find('/') == std::string::npos && stem != "." && stem != "..") {
    for (const std::string& dir : dirs) {
      const fs::path candidate = fs::path(dir) / (stem + ".toml");
      std::error_code ec;
      if (fs::is_regular_file(candidate, ec)) return candidate.string();
    }
  }
  if (dirs.empty()) {
    reason = "no shipped vehicle of that name: no vehicles folder found (looked next to the scenarios: " +
             scenarios_search_text() + ")";
    return "";
  }
  const std::vector<std::string> names = vehicle_names();
  std::string list;
  for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
  reason = "no shipped vehicle of that name (in " + dirs.front() + (dirs.size() > 1 ? " and others" : "") +
           "; the vehicles are " + list + ")";
  if (const std::string best = closest_name(stem, names); !best.empty()) reason += "; did you mean \"" + best + "\"?";
  return "";
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  const auto lower = [](char c) { return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c; };
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (lower(a[i - 1]) == lower(b[j - 1]) ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

std::string closest_name(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_d = word.size() / 3 + 1;  // more than a third differs: not a near miss
  for (const std::string& c : candidates) {
    const std::size_t d = edit_distance(word, c);
    if (d < best_d) {
      best_d = d;
      best = c;
    }
  }
  return best;
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
