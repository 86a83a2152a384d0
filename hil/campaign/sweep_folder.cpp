// SPDX-License-Identifier: BSD-3-Clause
// The sweep folder (sweep_folder.hpp).
#include "hil/campaign/sweep_folder.hpp"

#include <filesystem>
#include <sstream>
#include <system_error>

#include "hil/diag/provenance.hpp"
#include "io/json_value.hpp"
#include "io/sha256.hpp"
#include "io/json_writer.hpp"
#include "io/output_dir.hpp"
#include "io/text_file.hpp"

namespace fs = std::filesystem;

namespace ehpt::hil {

namespace {

// The build that runs a sweep's runs, as sweep.json records it: run ids are made of the
// inputs alone, so a resume with another binary would merge its results with the first's.
std::string this_build() {
  const BuildInfo& b = build_info();
  return std::string(b.version) + " (" + (b.git.empty() ? std::string("not from git") : std::string(b.git)) + ", " +
         std::string(b.compiler) + ", " + std::string(b.build_type) + ", flags sha256 " +
         io::sha256_hex(std::string(b.flags)).substr(0, 16) + ")";
}

std::string build_of(const std::string& dir) {
  std::string text, reason, error;
  io::JsonValue v;
  if (!io::read_text_file(dir + "/sweep.json", text, reason) || !io::parse_json(text, v, error)) return "";
  const io::JsonValue* b = v.find("build");
  return b != nullptr && b->kind == io::JsonValue::Kind::kString ? b->text : "";
}

}  // namespace

// Reads "campaign" from DIR/sweep.json; false if DIR has no sweep.json (or it is not ours).
bool sweep_campaign_of(const std::string& dir, std::string& campaign, std::string& why) {
  std::string text, reason;
  if (!io::read_text_file(dir + "/sweep.json", text, reason)) {
    why = dir + "/sweep.json: " + reason;
    return false;
  }
  io::JsonValue v;
  std::string error;
  if (!io::parse_json(text, v, error)) {
    why = dir + "/sweep.json: " + error;
    return false;
  }
  const io::JsonValue* f = v.find("format");
  const io::JsonValue* c = v.find("campaign");
  const std::string format = f != nullptr && f->kind == io::JsonValue::Kind::kString ? f->text : "";
  campaign = c != nullptr && c->kind == io::JsonValue::Kind::kString ? c->text : "";
  if (format != kSweepFormat || campaign.empty()) {
    why = dir + "/sweep.json: not an ehpt sweep folder (format \"" + format + "\")";
    return false;
  }
  return true;
}

// DIR's own folders: made if missing; one that is a symbolic link or not a folder is refused
// (the runs, statuses and logs would be written wherever it points).
bool make_subfolders(const std::string& dir, std::initializer_list<const char*> subs, std::string& error) {
  for (const char* sub : subs) {
    const std::string p = dir + "/" + sub;
    std::error_code ec;
    const fs::file_status st = fs::symlink_status(p, ec);
    if (fs::is_symlink(st) || (fs::exists(st) && !fs::is_directory(st))) {
      error = p + ": is " + (fs::is_symlink(st) ? std::string("a symbolic link") : io::describe_path(p)) +
              ", not a folder of this sweep; refused";
      return false;
    }
    fs::create_directory(p, ec);
    if (ec) {
      error = p + ": cannot create: " + ec.message();
      return false;
    }
  }
  return true;
}

// DIR for this campaign: made if missing; an empty folder is claimed; an earlier sweep of the
// same campaign is resumed. Anything else (another campaign's sweep, a folder of other files,
// a symbolic link) is refused before anything is written.
bool open_sweep_folder(const std::string& dir, const std::string& campaign, std::string& error) {
  std::error_code ec;
  const fs::file_status st = fs::symlink_status(dir, ec);
  if (fs::is_symlink(st)) {
    error = dir + ": is a symbolic link; give the folder itself";
    return false;
  }
  if (fs::exists(st)) {
    if (!fs::is_directory(st)) {
      error = dir + ": exists and is " + io::describe_path(dir) + ", not a sweep folder";
      return false;
    }
    std::string theirs, why;
    if (fs::exists(dir + "/sweep.json", ec)) {
      if (!sweep_campaign_of(dir, theirs, why)) {
        error = why;
        return false;
      }
      if (theirs != campaign) {
        error = dir + " holds the sweep of another campaign (" + theirs + "); give another --out";
        return false;
      }
      const std::string started_by = build_of(dir);
      if (started_by != this_build()) {
        error = dir + " holds runs of another ehpt build (" +
                (started_by.empty() ? std::string("an older ehpt that did not record its build") : started_by) +
                "; this one is " + this_build() + "): resuming would merge its results with this build's under the "
                "same run ids. Give another --out (or resume it with the build that started it)";
        return false;
      }
    } else if (!fs::is_empty(dir, ec)) {
      std::string names;
      int shown = 0;
      for (const auto& e : fs::directory_iterator(dir, ec)) {
        if (shown++ < 3) names += (names.empty() ? "" : ", ") + e.path().filename().string();
      }
      error = dir + " exists and is not an ehpt sweep folder (it holds " + names + (shown > 3 ? ", ..." : "") +
              "); give a new or empty folder";
      return false;
    } else {
      io::JsonObject j;
      j.text("format", kSweepFormat);
      j.text("campaign", campaign);
      j.text("build", this_build());
      if (!io::write_file_atomically(dir + "/sweep.json", j.str() + "\n", error)) return false;
    }
  } else {
    if (!fs::create_directories(dir, ec) && ec) {
      error = dir + ": cannot create: " + ec.message();
      return false;
    }
    io::JsonObject j;
    j.text("format", kSweepFormat);
    j.text("campaign", campaign);
    j.text("build", this_build());
    if (!io::write_file_atomically(dir + "/sweep.json", j.str() + "\n", error)) return false;
  }
  return make_subfolders(dir, {"runs", "status", "logs"}, error);
}

// Absolute and without a trailing '/': the job-array script and its tasks name the same folder
// from anywhere, and the lock beside it is "DIR.ehpt-lock", not a file inside it.
std::string absolute_folder(const std::string& dir) {
  std::error_code ec;
  fs::path p = fs::absolute(dir, ec).lexically_normal();
  if (ec) p = fs::path(dir).lexically_normal();
  if (!p.has_filename() && p.has_parent_path() && p != p.root_path()) p = p.parent_path();
  return p.string();
}

RunOutcome read_outcome(const SweepFolder& f, const std::string& id) {
  RunOutcome o;
  std::string text, reason;
  if (!io::read_text_file(f.status_file(id), text, reason)) return o;
  if (text.rfind("exit ", 0) != 0) return o;
  const std::size_t nl = text.find('\n');
  std::int64_t code = -1;
  // a whole number 0..255 (an exit status), else the file is not ours or damaged: not recorded
  if (!whole_number(text.substr(5, nl == std::string::npos ? std::string::npos : nl - 5), 0, 255, code)) return o;
  o.recorded = true;
  o.exit_code = static_cast<int>(code);
  if (nl != std::string::npos) o.message = text.substr(nl + 1);
  while (!o.message.empty() && o.message.back() == '\n') o.message.pop_back();
  return o;
}

// Done: ended with exit 0 and its folder is there (committed at once with its summary.json);
// a run whose folder went missing runs again.
bool run_done(const SweepFolder& f, const std::string& id, const RunOutcome& o) {
  std::error_code ec;
  return o.recorded && o.exit_code == 0 && fs::is_regular_file(f.run_dir(id) + "/summary.json", ec);
}
bool run_failed(const RunOutcome& o) { return o.recorded && o.exit_code != 0; }

// What the run's stderr says, on one line, the campaign's locations in place of --set labels.
std::string failure_message(const SweepFolder& f, const std::string& run_id, const std::vector<CampaignOverride>& overrides,
                            int code) {
  std::string text, reason;
  (void)io::read_text_file(f.log_file(run_id), text, reason);
  std::string message;
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    // warnings, and the loader's closing count ("1 problem; nothing was run."), say nothing more
    if (line.empty() || line.rfind("warning: ", 0) == 0 || line.ends_with("nothing was run.")) continue;
    message += (message.empty() ? "" : " | ") + line;
    if (message.size() > 2000) {
      message.resize(2000);
      message += "...";
      break;
    }
  }
  if (message.empty()) {
    message = code > 128 ? "killed by signal " + std::to_string(code - 128) : "exit " + std::to_string(code);
  }
  return blame(message, overrides);
}

// The run's log says its folder is locked by another ehpt run (DirLock's message).
bool folder_busy(const SweepFolder& f, const PlannedRun& run) {
  std::string text, reason;
  return io::read_text_file(f.log_file(run.id), text, reason) &&
         text.find("another ehpt run is writing this folder") != std::string::npos;
}

bool is_sweep_folder(const std::string& dir) {
  std::string campaign, why;
  return sweep_campaign_of(dir, campaign, why);
}

SweepSelection select_runs(const SweepPlan& plan, const SweepFolder& f, bool retry_failed) {
  SweepSelection s;
  for (std::size_t i = 0; i < plan.runs.size(); ++i) {
    const RunOutcome o = read_outcome(f, plan.runs[i].id);
    if (run_done(f, plan.runs[i].id, o)) {
      ++s.done_before;
    } else if (run_failed(o) && !retry_failed) {
      ++s.failed_before;
    } else {
      s.todo.push_back(i);
    }
  }
  return s;
}

}  // namespace ehpt::hil
