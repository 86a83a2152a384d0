// SPDX-License-Identifier: BSD-3-Clause
// Fuzz harness for hil::load_scenario. The first input byte picks what the rest of the input is:
//   'v'  a vehicle TOML file, loaded by a fixed scenario with the SORT1 cycle (bev, psd)
//   'r'  a vehicle TOML file, loaded by a fixed scenario without a cycle (drive rigs)
//   's'  a scenario TOML file
//   'o'  lines, each a --set override applied to a valid scenario of the shipped mbev.toml
//   'p'  the same on the shipped psecu2.toml (power split: ice, gen, mot, ecu keys)
// Any other first byte picks one of these by its value, so every input means something.
// "@EHPT_SOURCE_DIR@" in the input becomes the source folder, so that seeds can point by
// absolute path at the shipped vehicles/mbev.toml and the cycle from any checkout.
// Any input must give an answer (true, or false with messages), never a crash, a hang or an
// exception: the call is made without try/catch so that an escaping exception is a finding.

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "fuzz_checks.hpp"
#include "hil/config/config.hpp"

namespace {

namespace fs = std::filesystem;

constexpr std::string_view kSourcePlaceholder = "@EHPT_SOURCE_DIR@";

std::string source_path(const std::string& relative) { return (fs::path(EHPT_SOURCE_DIR) / relative).string(); }

std::string toml_string(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

void write_text(const fs::path& path, std::string_view text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  if (!out) {
    // a harness that cannot write its input tests nothing: stop loudly, not silently
    std::fprintf(stderr, "scenario_fuzz: cannot write %s\n", path.string().c_str());
    std::abort();
  }
}

// The loader takes paths and resolves file names relative to the file that gives them, so each
// process gets a small tree of its own (parallel fuzzing jobs must not read each other's inputs):
//   data/cycles/cycle_sort1.csv, data/maps/*.csv   copies, so "../data/maps/x.csv" in a fuzzed
//                                                  vehicle resolves as in the shipped ones
//   vehicles/fuzz_vehicle.toml                     modes v, r: the input
//   scenarios/fuzz_scenario.toml                   mode s: the input
//   scenarios/{vehicle_cycle,vehicle_rig,base_bev,base_psd}.toml   fixed scenarios
// Removed at exit (after a crash it stays, in the system temp folder only).
class Workspace {
 public:
  Workspace() {
    const std::string base = "ehpt_fuzz_scenario_" + std::to_string(::getpid());
    // a folder left by an earlier process with the same pid is not ours: never reuse or remove it
    for (int n = 0;; ++n) {
      root_ = fs::temp_directory_path() / (n == 0 ? base : base + "_" + std::to_string(n));
      if (fs::create_directory(root_)) break;
    }
    fs::create_directories(root_ / "data" / "cycles");
    fs::create_directories(root_ / "vehicles");
    fs::create_directories(root_ / "scenarios");
    fs::copy_file(source_path("data/cycles/cycle_sort1.csv"), root_ / "data" / "cycles" / "cycle_sort1.csv");
    fs::copy(source_path("data/maps"), root_ / "data" / "maps", fs::copy_options::recursive);

    const std::string cycle = (root_ / "data" / "cycles" / "cycle_sort1.csv").string();
    write_text(root_ / "scenarios" / "vehicle_cycle.toml",
               "description = \"fuzzed vehicle on SORT1\"\n"
               "vehicle_file = \"../vehicles/fuzz_vehicle.toml\"\n"
               "cycle = \"../data/cycles/cycle_sort1.csv\"\n"
               "[solver]\nstep_s = 0.001\n[output]\ninterval_s = 0.1\n");
    write_text(root_ / "scenarios" / "vehicle_rig.toml",
               "description = \"fuzzed drive rig\"\n"
               "vehicle_file = \"../vehicles/fuzz_vehicle.toml\"\n"
               "[solver]\nstep_s = 0.001\nduration_s = 50.0\n[output]\ninterval_s = 0.01\n");
    write_text(root_ / "scenarios" / "base_bev.toml",
               "description = \"shipped MBEV on SORT1\"\n"
               "vehicle_file = " + toml_string(source_path("vehicles/mbev.toml")) + "\n"
               "cycle = " + toml_string(cycle) + "\n"
               "[solver]\nstep_s = 0.001\n[output]\ninterval_s = 0.1\n");
    write_text(root_ / "scenarios" / "base_psd.toml",
               "description = \"shipped PSecu2 on SORT1\"\n"
               "vehicle_file = " + toml_string(source_path("vehicles/psecu2.toml")) + "\n"
               "cycle = " + toml_string(cycle) + "\n"
               "[solver]\nstep_s = 0.001\n[output]\ninterval_s = 0.1\n");
  }
  ~Workspace() {
    std::error_code ec;
    fs::remove_all(root_, ec);
  }
  Workspace(const Workspace&) = delete;
  Workspace& operator=(const Workspace&) = delete;

  fs::path scenario(const char* name) const { return root_ / "scenarios" / (std::string(name) + ".toml"); }
  fs::path fuzz_vehicle() const { return root_ / "vehicles" / "fuzz_vehicle.toml"; }
  fs::path fuzz_scenario() const { return scenario("fuzz_scenario"); }

 private:
  fs::path root_;
};

void report(bool ok, const std::vector<std::string>& errors) { ehpt::fuzz::report("scenario_fuzz", ok, errors); }
void require(bool condition, const char* what) { ehpt::fuzz::require("scenario_fuzz", condition, what); }

void load_and_check(const fs::path& scenario, const std::vector<std::string>& overrides) {
  ehpt::hil::Scenario sc;
  std::vector<std::string> errors;
  const bool ok = ehpt::hil::load_scenario(scenario.string(), overrides, sc, errors);
  report(ok, errors);
  require(ok == errors.empty(), "returns true exactly when it reports no problem");
  if (!ok) return;
  // what the runner takes for granted of an accepted scenario
  require(sc.solver.step_s > 0.0 && sc.solver.step_s <= 1.0, "accepted step_s is in (0, 1]");
  require(std::isfinite(sc.solver.duration_s) && sc.solver.duration_s > 0.0, "accepted duration_s is > 0");
  require(sc.solver.steps >= 1, "an accepted scenario runs at least one step");
  require(sc.output.decimation >= 1, "accepted decimation is >= 1");
  require(sc.solver.ecu_ratio >= 1, "accepted ecu_ratio is >= 1");
}

std::vector<std::string> split_lines(std::string_view text) {
  std::vector<std::string> lines;
  std::size_t begin = 0;
  while (begin <= text.size()) {
    const std::size_t end = std::min(text.find('\n', begin), text.size());
    lines.emplace_back(text.substr(begin, end - begin));
    begin = end + 1;
  }
  return lines;
}

std::string replace_all(std::string text, std::string_view from, std::string_view to) {
  for (std::size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size())) {
    text.replace(at, from.size(), to);
  }
  return text;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const Workspace ws;
  if (size == 0) return 0;
  const std::string body = replace_all(std::string(reinterpret_cast<const char*>(data) + 1, size - 1),
                                       kSourcePlaceholder, EHPT_SOURCE_DIR);

  constexpr char kModes[] = {'v', 'r', 's', 'o', 'p'};
  char mode = static_cast<char>(data[0]);
  if (std::string_view(kModes, sizeof kModes).find(mode) == std::string_view::npos) {
    mode = kModes[data[0] % sizeof kModes];
  }

  switch (mode) {
    case 'v':
    case 'r':
      write_text(ws.fuzz_vehicle(), body);
      load_and_check(ws.scenario(mode == 'v' ? "vehicle_cycle" : "vehicle_rig"), {});
      // gone before the next input: a later scenario input must not find a stale vehicle
      fs::remove(ws.fuzz_vehicle());
      break;
    case 's':
      write_text(ws.fuzz_scenario(), body);
      load_and_check(ws.fuzz_scenario(), {});
      fs::remove(ws.fuzz_scenario());
      break;
    default:
      load_and_check(ws.scenario(mode == 'o' ? "base_bev" : "base_psd"), split_lines(body));
      break;
  }
  return 0;
}
