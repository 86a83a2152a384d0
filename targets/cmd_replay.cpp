// SPDX-License-Identifier: BSD-3-Clause
// `ehpt replay`: a recorded bus session again, offline, compared bit for bit.
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>

#include "hil/bus/bus_plant.hpp"
#include "hil/bus/replay.hpp"
#include "hil/run/batch.hpp"
#include "io/json_value.hpp"
#include "io/number_format.hpp"
#include "io/text_file.hpp"
#include "targets/cli.hpp"

namespace fs = std::filesystem;

namespace ehpt::cli {

namespace {

// "" if the replay may write into out_dir, else why not: a replay never writes into the
// session it reads (nor into a folder inside it), nor into any other recorded session (a
// folder with inputs.log: only 'ehpt plant' writes one). Both would replace the session's
// files, the only record of what its ECU sent.
std::string refuse_out_dir(const std::string& out_dir, const std::string& session_dir) {
  std::error_code ec;
  const fs::path out = fs::weakly_canonical(fs::absolute(out_dir, ec), ec);
  const fs::path session = fs::weakly_canonical(fs::absolute(session_dir.empty() ? "." : session_dir, ec), ec);
  const auto [end, rest] = std::mismatch(session.begin(), session.end(), out.begin(), out.end());
  if (end == session.end()) {
    return out == session ? "is the session folder the replay reads" : "is inside the session folder the replay reads";
  }
  if (fs::exists(out / ehpt::hil::kInputsLogName, ec)) {
    return "holds a recorded bus session (its " + std::string(ehpt::hil::kInputsLogName) + ")";
  }
  return "";
}

const char* kReplayHelp =
    "usage: ehpt replay RUN_DIR [--out DIR] [--quiet]\n"
    "\n"
    "Runs a recorded bus session again, offline and as fast as possible. Every 'ehpt plant'\n"
    "session (wall clock, real time or lockstep) writes inputs.log into its output folder:\n"
    "each command the plant applied, with the step it acted from. The replay loads the same\n"
    "scenario with the same --set overrides, applies those commands at those steps and\n"
    "writes timeseries.csv and summary.json like 'ehpt run'. It compares its trajectory_hash\n"
    "with the session's summary.json: equal means bit for bit the same trajectory (exit 0);\n"
    "a difference (the scenario's files changed since) is exit 1.\n"
    "  RUN_DIR          the session's output folder (or its inputs.log)\n"
    "  --out DIR        output folder (default out/<scenario name>_replay); never the\n"
    "                   session's folder, a folder inside it or another recorded session\n"
    "  --quiet          print nothing but errors\n";

// A top-level member of a summary.json as text: a string's value, a number's text; "" if
// absent or of another kind.
std::string summary_value(const ehpt::io::JsonValue& summary, const std::string& key) {
  const ehpt::io::JsonValue* v = summary.find(key);
  if (v == nullptr) return "";
  return v->kind == ehpt::io::JsonValue::Kind::kString || v->kind == ehpt::io::JsonValue::Kind::kNumber ? v->text : "";
}

}  // namespace

int cmd_replay(const std::vector<std::string>& args) {
  if (wants_help(args)) return out(kReplayHelp) ? 0 : 1;
  std::string source, out_dir;
  bool quiet = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--out") {
      if (i + 1 >= args.size() || args[i + 1].empty()) {
        std::cerr << "--out needs a folder name\n" << kReplayHelp;
        return 1;
      }
      out_dir = args[++i];
    } else if (args[i] == "--quiet") {
      quiet = true;
    } else if (!args[i].empty() && args[i][0] == '-') {
      std::cerr << "unknown option " << args[i] << "\n" << kReplayHelp;
      return 1;
    } else if (source.empty()) {
      source = args[i];
    } else {
      std::cerr << "one session per replay (got " << source << " and " << args[i] << ")\n";
      return 1;
    }
  }
  if (source.empty()) {
    std::cerr << kReplayHelp;
    return 1;
  }
  std::error_code ec;
  const bool is_dir = fs::is_directory(source, ec);
  const std::string log_path = is_dir ? source + "/" + ehpt::hil::kInputsLogName : source;
  const std::string session_dir = is_dir ? source : fs::path(source).parent_path().string();
  ehpt::hil::InputsLog log;
  std::vector<std::string> problems;
  if (!ehpt::hil::read_inputs_log(log_path, log, problems)) {
    for (const auto& p : problems) std::cerr << p << "\n";
    std::cerr << "nothing was run.\n";
    return 2;
  }
  // the session's own summary: how far it ran (an interrupted session stopped early) and its hash
  std::string session_summary, reason;
  const std::string summary_path = (session_dir.empty() ? std::string(".") : session_dir) + "/summary.json";
  if (!ehpt::io::read_text_file(summary_path, session_summary, reason)) {
    std::cerr << summary_path << ": " << reason << " (a session that did not end cleanly cannot be compared)\n";
    return 2;
  }
  ehpt::io::JsonValue session_json;
  std::string json_error;
  if (!ehpt::io::parse_json(session_summary, session_json, json_error)) {
    std::cerr << summary_path << ": " << json_error << " (not a summary.json; a session that did not end cleanly "
              << "cannot be compared)\n";
    return 2;
  }
  const std::string recorded_hash = summary_value(session_json, "trajectory_hash");
  const std::string steps_text = summary_value(session_json, "steps");
  char* end = nullptr;
  const long long recorded_steps = std::strtoll(steps_text.c_str(), &end, 10);
  if (steps_text.empty() || *end != '\0' || recorded_steps < 0) {
    std::cerr << summary_path << ": no \"steps\" count\n";
    return 2;
  }
  std::vector<std::string> sets = log.overrides;
  ehpt::hil::Scenario sc;
  if (const int rc = load(log.scenario_path, sets, sc, log.faults); rc != 0) return rc;
  if (recorded_steps < sc.solver.steps) {  // it ran this far: so does the replay
    sets.push_back("solver.duration_s=" + ehpt::io::number_text(static_cast<double>(recorded_steps) * sc.solver.step_s));
    if (const int rc = load(log.scenario_path, sets, sc, log.faults); rc != 0) return rc;
  }
  std::string why;
  if (!ehpt::hil::can_run_on_bus(sc, why)) {  // a rig: no bus session can have been recorded on it
    std::cerr << log_path << ": " << why << "\n";
    return 2;
  }
  if (const std::string family = ehpt::hil::bus_family(sc); family != log.family) {
    std::cerr << log_path << ": its commands are of family '" << log.family << "' but " << log.scenario_path
              << " is a vehicle of family '" << family << "'\n";
    return 2;
  }
  const std::unique_ptr<ehpt::hil::ExternalDriver> driver = ehpt::hil::make_replay_driver(log, log_path);
  ehpt::hil::BatchOptions opt;
  opt.out_dir = out_dir.empty() ? "out/" + sc.name + "_replay" : out_dir;
  if (const std::string why = refuse_out_dir(opt.out_dir, session_dir); !why.empty()) {
    std::cerr << "error: --out " << opt.out_dir << " " << why
              << ": a replay never writes there (the session's files are its only record); give another --out\n";
    return 2;
  }
  opt.progress = !quiet && isatty(STDERR_FILENO);
  opt.stop_signal = &g_stop;
  opt.driver = driver.get();
  const ehpt::hil::BatchResult r = ehpt::hil::run_batch(sc, opt, std::cerr);
  ehpt::io::JsonValue replay_json;
  const std::string hash =
      ehpt::io::parse_json(r.summary.str(), replay_json, json_error) ? summary_value(replay_json, "trajectory_hash") : "";
  const bool same = !recorded_hash.empty() && hash == recorded_hash;
  if (!quiet) {
    for (const auto& w : r.warnings) std::cerr << "warning: " << w << "\n";
    std::string text = r.summary_text;
    text += same ? "replay        bit-identical to the session in " + session_dir + " (trajectory_hash " + hash + ")\n"
                 : "replay        DIFFERS from the session in " + session_dir + ": trajectory_hash " + hash +
                       " here, " + (recorded_hash.empty() ? "none" : recorded_hash) + " there\n";
    if (!r.results_dir.empty()) text += "outputs       " + r.results_dir + "/timeseries.csv, summary.json\n";
    if (!out(text)) return 1;
  }
  if (r.exit_code != 0 && r.exit_code != 3) return r.exit_code;
  if (!same) {
    std::cerr << "error: the replay's trajectory differs from the session's (did the scenario's files change?)\n";
    return 1;
  }
  return r.exit_code;
}

}  // namespace ehpt::cli
