// SPDX-License-Identifier: BSD-3-Clause
// Merging a sweep (sweep_merge.hpp).
#include "hil/campaign/sweep_merge.hpp"

#include <map>
#include <set>
#include <utility>
#include <vector>

#include <toml++/toml.h>

#include "io/json_value.hpp"
#include "io/json_writer.hpp"
#include "io/output_dir.hpp"
#include "io/text_file.hpp"

namespace ehpt::hil {

namespace {

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
  std::string out = "\"";
  for (const char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

// An override's value for the results: a string without its TOML quotes, else as written.
std::string plain_value(const std::string& toml_text) {
  if (toml_text.empty() || toml_text.front() != '"') return toml_text;
  try {
    const toml::table t = toml::parse("v = " + toml_text);
    if (const auto s = t["v"].value<std::string>()) return *s;
  } catch (const toml::parse_error&) {
  }
  return toml_text;
}

// The value as JSON: numbers and booleans as they are (when JSON reads them), else a string.
std::string json_value_text(const std::string& toml_text) {
  const std::string plain = plain_value(toml_text);
  if (plain == toml_text) {
    io::JsonValue v;
    std::string error;
    if (io::parse_json(toml_text, v, error) && v.kind != io::JsonValue::Kind::kString) return toml_text;
  }
  return io::json_escape(plain);
}

}  // namespace

bool merge_results(const SweepPlan& plan, const SweepFolder& f, SweepTally& tally, std::string& error) {
  const Campaign& c = plan.campaign;
  const std::vector<std::string> swept = c.swept_keys();
  struct Row {
    RunOutcome outcome;
    std::string status;  // ok, failed, pending
    std::vector<std::pair<std::string, std::string>> fields;  // the summary, flattened
    std::string summary_json;                                  // compact
  };
  std::vector<Row> rows(plan.runs.size());
  std::vector<std::string> columns;
  // a summary key named like one of our columns (its "scenario", a swept "vehicle_file") is
  // left out: one name, one column
  std::set<std::string> column_set{"run_id", "scenario", "sweep_status", "exit_code", "message"};
  column_set.insert(swept.begin(), swept.end());
  for (std::size_t i = 0; i < plan.runs.size(); ++i) {
    const PlannedRun& run = plan.runs[i];
    Row& row = rows[i];
    row.outcome = read_outcome(f, run.id);
    row.status = run_done(f, run.id, row.outcome) ? "ok" : run_failed(row.outcome) ? "failed" : "pending";
    if (row.status == "pending") {
      ++tally.pending;
      continue;
    }
    std::string text, reason;
    io::JsonValue v;
    std::string parse_error;
    if (!io::read_text_file(f.run_dir(run.id) + "/summary.json", text, reason)) {
      (row.status == "ok" ? tally.ok : tally.failed) += 1;  // a failure before any output
      continue;
    }
    if (!io::parse_json(text, v, parse_error)) {
      // a damaged summary is not a result
      row.status = "failed";
      row.outcome.message += (row.outcome.message.empty() ? "" : " | ") + ("summary.json: " + parse_error);
      ++tally.failed;
      continue;
    }
    (row.status == "ok" ? tally.ok : tally.failed) += 1;
    io::flatten(v, row.fields);
    row.summary_json = io::to_compact_json(v);
    for (const auto& [k, value] : row.fields) {
      if (column_set.insert(k).second) columns.push_back(k);
    }
  }
  std::string csv = "run_id,scenario";
  for (const std::string& k : swept) csv += "," + csv_field(k);
  csv += ",sweep_status,exit_code,message";
  for (const std::string& k : columns) csv += "," + csv_field(k);
  csv += "\n";
  std::string jsonl;
  for (std::size_t i = 0; i < plan.runs.size(); ++i) {
    const PlannedRun& run = plan.runs[i];
    const Row& row = rows[i];
    const std::string& status = row.status;
    std::map<std::string, std::string> set_of;
    for (const CampaignOverride& o : overrides_of(c, run)) set_of[o.key] = o.value;
    csv += run.id + "," + csv_field(c.scenarios[run.scenario].name);
    for (const std::string& k : swept) {
      const auto it = set_of.find(k);
      csv += "," + (it == set_of.end() ? std::string() : csv_field(plain_value(it->second)));
    }
    const std::string code = row.outcome.recorded ? std::to_string(row.outcome.exit_code) : "";
    csv += "," + status + "," + code + "," + csv_field(row.outcome.message);
    std::map<std::string, std::string> value_of(row.fields.begin(), row.fields.end());
    for (const std::string& k : columns) {
      const auto it = value_of.find(k);
      csv += "," + (it == value_of.end() ? std::string() : csv_field(it->second));
    }
    csv += "\n";
    jsonl += "{\"run_id\":\"" + run.id + "\",\"scenario\":" + io::json_escape(c.scenarios[run.scenario].name) +
             ",\"overrides\":{";
    bool first = true;
    for (const std::string& k : swept) {
      const auto it = set_of.find(k);
      if (it == set_of.end()) continue;
      jsonl += (first ? "" : ",") + io::json_escape(k) + ":" + json_value_text(it->second);
      first = false;
    }
    jsonl += "},\"sweep_status\":\"" + status + "\",\"exit_code\":" + (code.empty() ? "null" : code) +
             ",\"message\":" + io::json_escape(row.outcome.message) + ",\"summary\":" +
             (row.summary_json.empty() ? "null" : row.summary_json) + "}\n";
  }
  return io::write_file_atomically(f.dir + "/results.csv", csv, error) &&
         io::write_file_atomically(f.dir + "/results.jsonl", jsonl, error);
}

int sweep_exit_code(const SweepTally& t) { return t.pending > 0 ? 4 : t.failed > 0 ? 3 : 0; }

}  // namespace ehpt::hil
