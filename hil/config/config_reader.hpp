// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The layered TOML reader behind load_scenario, shared by the scenario loader, the component
// readers (hil/config/config_components.hpp) and each vehicle kind's reader (hil/kinds/registry.cpp).
// Start-up only. Every problem is collected with the file and line its value came from.

#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <toml++/toml.h>

#include "hil/config/config.hpp"
#include "io/csv_table.hpp"
#include "plant/problems.hpp"
#include "plant/table.hpp"

namespace ehpt::hil::detail {

using plant::Problems;

// A value as written, for messages: floats as the shortest text that reads back.
std::string node_text(const toml::node& n);
// "file:line" of a node, or the --set that gave it; fallback if it has no source.
std::string location(const toml::node* n, const std::string& fallback);

// A table loaded from CSV, kept so that a problem plant/ finds in a cell can be reported
// with the file line, the CSV column and the value as written (before unit conversion).
struct TableSource {
  std::string path;
  std::vector<int> lines;                       // file line of each table row
  std::vector<std::string> columns;             // table column (0 axis, 1, 2) -> CSV header name
  std::vector<std::vector<std::string>> text;   // table column -> the fields as written
};

// A file named by a key: where the key is, the path as written, and the path resolved.
struct FileRef {
  std::string path;     // relative to the folder of the file that named it
  std::string written;  // as in the file
  std::string where;    // "file:line" of the key
  std::string field;    // dotted key
  bool empty() const { return path.empty(); }
};

}  // namespace ehpt::hil::detail

namespace ehpt::hil {
// What a LoadCache holds: each file's bytes (or why it cannot be read) with its SHA-256, and
// the TOML and CSV files parsed (a parse that failed is not kept: it is reported again).
struct LoadCache::Files {
  struct File {
    bool ok = false;
    std::string content, reason, sha256;
  };
  std::map<std::string, File> bytes;
  std::map<std::string, toml::table> toml;
  std::map<std::string, io::CsvTable> csv;
  std::map<std::string, toml::table> overrides;  // "key=value" as --set gave it, parsed
};
}  // namespace ehpt::hil

namespace ehpt::hil::detail {

// Collects messages and remembers where each field's value came from, so that problems
// found later by plant/ validate() can be given a file and line.
struct Context {
  std::vector<std::string> errors;
  std::vector<std::string> warnings;
  std::map<std::string, std::string> where;    // field -> "file:line"
  std::map<std::string, TableSource> tables;   // field -> its CSV
  std::set<std::string> failed_tables;  // fields whose file could not be read: no follow-on problems

  std::set<std::string> reported;  // fields with a problem already: validate() need not repeat it
  // field -> the key as the user wrote it: "vehicle.battery.x" for --set and a scenario's
  // [vehicle.battery], "battery.x" for a vehicle file's [battery] (fields are the latter)
  std::map<std::string, std::string> shown;
  // every key a reader asked for, as a scenario writes it ("solver.step_s",
  // "vehicle.battery.cell_capacity_Ah"): what an unknown key is compared with for a hint
  std::set<std::string> known;
  // an unknown key: its message (errors[error]) gets a "did you mean" once every table is read
  struct Unknown {
    std::size_t error;
    std::string path;           // as a scenario writes it
    bool vehicle_file = false;  // written in a vehicle file (without the scenario's "vehicle.")
  };
  std::vector<Unknown> unknown;
  const std::string& display(const std::string& field) const {
    const auto it = shown.find(field);
    return it == shown.end() ? field : it->second;
  }
  const CycleArrays* cycle_arrays = nullptr;  // load_scenario_with_cycle: load_cycle takes these, not a file
  // scenario_numbers: every number read (given or defaulted), keyed as --set writes it; null: none
  std::vector<std::pair<std::string, double>>* numbers = nullptr;
  // every file read, in the order read (each once): what the run depends on (hil/config/config.hpp)
  std::vector<InputFile> inputs;
  void read_file(const std::string& path, const std::string& content, const std::string* sha256 = nullptr);
  // the loads' shared files, or none (every file read from disk)
  LoadCache::Files* cache = nullptr;
  // The file's bytes (from the cache, else read into storage); nullptr and reason if it cannot
  // be read. Either way it is listed in inputs when read.
  const std::string* read(const std::string& path, std::string& storage, std::string& reason);

  void error(const std::string& loc, const std::string& field, const std::string& value,
             const std::string& expected) {
    errors.push_back(loc + ": " + display(field) + (value.empty() ? "" : " = " + value) + ": " + expected);
    reported.insert(field);
  }
  void warn(const std::string& loc, const std::string& field, const std::string& value, const std::string& why) {
    warnings.push_back(loc + ": " + display(field) + (value.empty() ? "" : " = " + value) + ": " + why);
  }
  // Adds "; did you mean `key`?" to each unknown key's message: the closest known key by edit
  // distance, in the same table or at another depth (vehicle.mass_kg -> vehicle.vehicle.mass_kg).
  void suggest_known_keys();
  // A file named by ref cannot be read: say so at the key that names it.
  void unreadable(const FileRef& ref, const std::string& reason) {
    error(ref.where, ref.field, "\"" + ref.written + "\"", "cannot read " + ref.path + ": " + reason);
  }
};

// One table of a layer: vehicle_file tells how its keys are written (a vehicle file's
// [battery] x is "battery.x"; the same key from --set or a scenario is "vehicle.battery.x").
struct Layer {
  const toml::table* table = nullptr;
  bool vehicle_file = false;
};

// A view of one table through several layers, highest priority first (--set overrides,
// the scenario's [vehicle] table, the vehicle file and the files it extends). Unknown keys in
// any layer are errors.
class Reader {
 public:
  // where: the location of this table (for keys that are missing from it), default the file;
  // space: what a scenario writes before this reader's fields ("vehicle." for the vehicle's);
  // where_in_vehicle_file: whether where is in a vehicle file (how a missing key is named)
  Reader(std::vector<Layer> layers, std::string prefix, std::string file, Context& ctx, std::string where = "",
         std::string space = "", bool where_in_vehicle_file = false)
      : layers_(std::move(layers)), prefix_(std::move(prefix)), file_(std::move(file)), ctx_(ctx),
        where_(where.empty() ? file_ : std::move(where)), space_(std::move(space)),
        where_in_vehicle_file_(where_in_vehicle_file) {}

  const std::string& name() const { return prefix_; }
  const std::string& where() const { return where_; }
  Context& context() { return ctx_; }

  std::string field(std::string_view key) const { return prefix_.empty() ? std::string(key) : prefix_ + "." + std::string(key); }
  // key as the user wrote it in layer (-1: as a missing key of this table is named)
  std::string written(std::string_view key, int layer) const {
    const bool in_file = layer < 0 ? where_in_vehicle_file_ : layers_[static_cast<std::size_t>(layer)].vehicle_file;
    return (in_file ? "" : space_) + field(key);
  }
  // A key this reader knows but reads elsewhere (or not at all): not unknown.
  void known(std::string_view key) { known_field(key, field(key)); }

  // (every key of every load passes here: a sweep's plan loads each run's scenario, so the
  // field name is built once and each map is written with one lookup)
  const toml::node* find(std::string_view key) {
    std::string f = field(key);
    known_field(key, f);
    const toml::node* found = nullptr;
    int layer = -1;
    for (std::size_t i = 0; i < layers_.size(); ++i) {
      if (layers_[i].table == nullptr) continue;
      if ((found = layers_[i].table->get(key)) != nullptr) {
        layer = static_cast<int>(i);
        break;
      }
    }
    const bool in_file = layer < 0 ? where_in_vehicle_file_ : layers_[static_cast<std::size_t>(layer)].vehicle_file;
    ctx_.shown.insert_or_assign(f, in_file ? f : space_ + f);
    ctx_.where.insert_or_assign(std::move(f), found != nullptr ? location(found, file_) : file_ + " (default)");
    return found;
  }
  bool has(std::string_view key) const { return layer_of(key) >= 0; }
  // The layer that gives key (0 is the highest: the last --set), -1 if none does.
  int layer_of(std::string_view key) const {
    for (std::size_t i = 0; i < layers_.size(); ++i) {
      if (layers_[i].table != nullptr && layers_[i].table->get(key) != nullptr) return static_cast<int>(i);
    }
    return -1;
  }

  std::optional<double> opt_number(std::string_view key) {
    const toml::node* n = find(key);
    if (n == nullptr) return std::nullopt;
    if (auto v = n->value<double>()) {  // integers convert too
      if (ctx_.numbers != nullptr) ctx_.numbers->emplace_back(space_ + field(key), *v);
      return *v;
    }
    ctx_.error(location(n, file_), field(key), node_text(*n), "must be a number");
    return std::nullopt;
  }
  double number(std::string_view key, double fallback) {
    const std::optional<double> v = opt_number(key);
    if (!v && ctx_.numbers != nullptr && !has(key)) ctx_.numbers->emplace_back(space_ + field(key), fallback);
    return v.value_or(fallback);
  }
  double required_number(std::string_view key) {
    if (!has(key)) {
      find(key);
      ctx_.error(where_, field(key), "", "missing (required number)");
      return std::nan("");
    }
    return opt_number(key).value_or(std::nan(""));
  }
  std::int64_t integer(std::string_view key, std::int64_t fallback) {
    const toml::node* n = find(key);
    if (n == nullptr) return fallback;
    if (auto v = n->value_exact<std::int64_t>()) return *v;
    ctx_.error(location(n, file_), field(key), node_text(*n), "must be a whole number");
    return fallback;
  }
  // A whole number in [lo, hi], checked before it is narrowed, so that 2^32 + 100 is
  // reported as written instead of running as 100.
  int small_integer(std::string_view key, int fallback, int lo, int hi) {
    const toml::node* n = find(key);
    if (n == nullptr) return fallback;
    const auto v = n->value_exact<std::int64_t>();
    if (v && *v >= lo && *v <= hi) return static_cast<int>(*v);
    ctx_.error(location(n, file_), field(key), node_text(*n),
               "must be a whole number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return fallback;
  }
  bool flag(std::string_view key, bool fallback) {
    const toml::node* n = find(key);
    if (n == nullptr) return fallback;
    if (auto v = n->value_exact<bool>()) return *v;
    ctx_.error(location(n, file_), field(key), node_text(*n), "must be true or false");
    return fallback;
  }
  std::string text(std::string_view key, const std::string& fallback) {
    const toml::node* n = find(key);
    if (n == nullptr) return fallback;
    if (auto v = n->value_exact<std::string>()) return *v;
    ctx_.error(location(n, file_), field(key), node_text(*n), "must be a string");
    return fallback;
  }
  // A file name, relative to the folder of the file that gave it (--set: the current folder).
  FileRef path(std::string_view key, bool required) {
    const toml::node* n = find(key);
    if (n == nullptr) {
      if (required) ctx_.error(where_, field(key), "", "missing (required file name)");
      return {};
    }
    auto v = n->value_exact<std::string>();
    if (!v || v->empty()) {
      ctx_.error(location(n, file_), field(key), node_text(*n), "must be a file name (a non-empty string)");
      return {};
    }
    std::filesystem::path p(*v);
    if (p.is_relative() && n->source().path && n->source().path->rfind("--set", 0) != 0) {
      p = std::filesystem::path(*n->source().path).parent_path() / p;
    }
    return {p.lexically_normal().string(), *v, location(n, file_), field(key)};
  }
  std::vector<std::string> strings(std::string_view key) {
    std::vector<std::string> out;
    const toml::node* n = find(key);
    if (n == nullptr) return out;
    const toml::array* a = n->as_array();
    if (a == nullptr) {
      ctx_.error(location(n, file_), field(key), node_text(*n), "must be an array of strings");
      return out;
    }
    for (const toml::node& e : *a) {
      if (auto s = e.value_exact<std::string>()) {
        out.push_back(*s);
      } else {
        ctx_.error(location(&e, file_), field(key), node_text(e), "must be a string");
      }
    }
    return out;
  }

  // An array of tables ([[key]] ... in TOML): one reader each, named key[0], key[1], ...
  // The highest layer that gives the array gives all of it.
  std::vector<Reader> table_array(std::string_view key) {
    std::vector<Reader> out;
    const toml::node* n = find(key);
    if (n == nullptr) return out;
    const toml::array* a = n->as_array();
    if (a == nullptr) {
      ctx_.error(location(n, file_), field(key), node_text(*n), "must be an array of tables ([[" + field(key) + "]])");
      return out;
    }
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::node& e = *a->get(i);
      const std::string name = field(key) + "[" + std::to_string(i) + "]";
      if (const toml::table* t = e.as_table()) {
        ctx_.where[name] = location(&e, file_);
        const int layer = layer_of(key);
        const bool in_file = layer >= 0 && layers_[static_cast<std::size_t>(layer)].vehicle_file;
        ctx_.shown[name] = (in_file ? "" : space_) + name;
        out.emplace_back(std::vector<Layer>{{t, in_file}}, name, file_, ctx_, location(&e, file_), space_, in_file);
      } else {
        ctx_.error(location(&e, file_), name, node_text(e), "must be a table");
      }
    }
    return out;
  }

  Reader sub(std::string_view key) {
    known(key);
    std::vector<Layer> layers;
    std::string where;  // the lowest layer's table: usually the vehicle file's [table] line
    bool where_in_file = where_in_vehicle_file_;
    for (std::size_t i = 0; i < layers_.size(); ++i) {
      const toml::table* t = layers_[i].table;
      const toml::node* n = t == nullptr ? nullptr : t->get(key);
      if (n != nullptr && !n->is_table()) {
        ctx_.shown[field(key)] = written(key, static_cast<int>(i));
        ctx_.error(location(n, file_), field(key), node_text(*n), "must be a table");
        n = nullptr;
      }
      layers.push_back({n == nullptr ? nullptr : n->as_table(), layers_[i].vehicle_file});
      if (n != nullptr) {
        where = location(n, file_);
        where_in_file = layers_[i].vehicle_file;
      }
    }
    return Reader(std::move(layers), field(key), file_, ctx_, where.empty() ? where_ : where, space_, where_in_file);
  }

  // A plausibility warning (not an error) for a given value outside the physical band [lo, hi]
  // of what: most likely a unit or a typo (1.8 for 1800 kg). Values that validate() rejects, and
  // 0 where 0 switches a term off, are left to it.
  void plausible(std::string_view key, double value, double lo, double hi, const std::string& unit,
                 const std::string& what) {
    if (!has(key) || !std::isfinite(value) || !(value > 0.0) || (value >= lo && value <= hi)) return;
    ctx_.warn(ctx_.where[field(key)], field(key), plant::number_text(value),
              "outside the plausible band [" + plant::number_text(lo) + ", " + plant::number_text(hi) + "]" +
                  (unit.empty() ? "" : " " + unit) + " of " + what + " (a unit or a typo? it runs as given)");
  }

  // Reports every key no reader asked for (with a hint, once every table is read).
  void finish() {
    for (std::size_t i = 0; i < layers_.size(); ++i) {
      const toml::table* t = layers_[i].table;
      if (t == nullptr) continue;
      for (const auto& [k, n] : *t) {
        if (used_.count(std::string(k.str())) != 0) continue;
        // a table from --set (a.b.c=1) holds one key: name the whole key the user wrote
        std::string key(k.str());
        const toml::node* leaf = &n;
        while (leaf->is_table() && leaf->as_table()->size() == 1 && is_from_set(*leaf)) {
          const toml::table& inner = *leaf->as_table();
          std::string inner_key;
          for (const auto& entry : inner) inner_key = std::string(entry.first.str());
          key += "." + inner_key;
          leaf = inner.get(inner_key);
        }
        ctx_.errors.push_back(location(&n, file_) + ": " + written(key, static_cast<int>(i)) + ": unknown key");
        ctx_.unknown.push_back({ctx_.errors.size() - 1, space_ + field(key), layers_[i].vehicle_file});
      }
    }
  }

 private:
  static bool is_from_set(const toml::node& n) {
    return n.source().path && n.source().path->rfind("--set", 0) == 0;
  }
  std::vector<Layer> layers_;
  std::string prefix_, file_;
  Context& ctx_;
  std::string where_;
  std::string space_;
  bool where_in_vehicle_file_ = false;
  std::set<std::string, std::less<>> used_;
  void known_field(std::string_view key, const std::string& f) {
    if (used_.find(key) == used_.end()) used_.emplace(key);
    if (space_.empty()) {
      if (ctx_.known.find(f) == ctx_.known.end()) ctx_.known.insert(f);
    } else {
      ctx_.known.insert(space_ + f);
    }
  }
};

// Parses a TOML file (a regular file of at most 64 MiB, no over-long dotted keys). ref: the
// key that names the file, so that a missing file is reported there; nullptr for the
// scenario itself.
bool parse_toml(const std::string& path, toml::table& out, Context& ctx, const FileRef* ref = nullptr);
// The same into the context's cache when it has one (the table there, parsed once), else into
// storage; nullptr when it cannot be read or parsed (the problem in ctx).
const toml::table* read_toml(const std::string& path, toml::table& storage, Context& ctx, const FileRef* ref = nullptr);
// "a.b.c=value" as given to --set: the value as TOML (number, bool, quoted string, array), or text.
bool parse_override(const std::string& text, toml::table& out, Context& ctx);
// The same through the context's cache when it has one (a sweep's runs share their values);
// storage holds it otherwise, or an empty table when it does not parse (the problem in ctx).
const toml::table* read_override(const std::string& text, toml::table& storage, Context& ctx);

// CSV-backed tables, remembered in ctx so that a problem in a cell is reported at its line.
// (ctx.cycle_arrays: those numbers instead of the file)
plant::Table1d load_cycle(const FileRef& ref, const std::string& field, bool periodic, Context& ctx);
plant::Table1d load_curve(const FileRef& ref, const std::string& field, Context& ctx);
plant::Table2d load_map(const FileRef& ref, const std::string& field, Context& ctx);

// Gives plant/ problems the file and line their value came from (sink: warnings instead).
void report_plant_problems(const Problems& problems, Context& ctx, std::vector<std::string>* sink = nullptr);

template <class Signals>
void check_signals(const Signals& available, const std::vector<std::string>& wanted, Context& ctx) {
  for (const std::string& w : wanted) {
    bool found = false;
    for (const auto& s : available) found = found || s.name == w;
    if (!found) {
      std::string names;
      for (const auto& s : available) names += (names.empty() ? "" : ", ") + std::string(s.name);
      ctx.error(ctx.where["output.signals"], "output.signals", "\"" + w + "\"", "unknown signal; available: " + names);
    }
  }
}


}  // namespace ehpt::hil::detail
