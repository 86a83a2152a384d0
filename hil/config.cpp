#include "hil/config.hpp"

#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include <toml++/toml.h>

#include "hil/toml_guard.hpp"
#include "io/csv_table.hpp"
#include "io/number_format.hpp"
#include "io/text_file.hpp"

namespace fs = std::filesystem;

namespace ehpt::hil {

const char* solver_name(SolverKind k) { return k == SolverKind::kRk4 ? "rk4" : "implicit-euler"; }

namespace {

using plant::Problems;

std::string node_text(const toml::node& n) {
  std::ostringstream s;
  if (n.is_table()) return "(a table)";
  if (n.is_array()) return "(an array)";
  // floats as the shortest text that reads back (toml++ prints 2.2 as 2.2000000000000002)
  if (const auto d = n.value_exact<double>()) return io::number_text(*d);
  n.visit([&](const auto& v) { s << v; });
  return s.str();
}

std::string location(const toml::node* n, const std::string& fallback) {
  if (n == nullptr || !n->source().path) return fallback;
  const std::string& p = *n->source().path;
  if (p.rfind("--set", 0) == 0) return p;
  return p + ":" + std::to_string(n->source().begin.line);
}

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

// Collects messages and remembers where each field's value came from, so that problems
// found later by plant/ validate() can be given a file and line.
struct Context {
  std::vector<std::string> errors;
  std::vector<std::string> warnings;
  std::map<std::string, std::string> where;    // field -> "file:line"
  std::map<std::string, TableSource> tables;   // field -> its CSV
  std::set<std::string> failed_tables;  // fields whose file could not be read: no follow-on problems

  std::set<std::string> reported;  // fields with a problem already: validate() need not repeat it

  void error(const std::string& loc, const std::string& field, const std::string& value,
             const std::string& expected) {
    errors.push_back(loc + ": " + field + (value.empty() ? "" : " = " + value) + ": " + expected);
    reported.insert(field);
  }
  void warn(const std::string& loc, const std::string& field, const std::string& value, const std::string& why) {
    warnings.push_back(loc + ": " + field + (value.empty() ? "" : " = " + value) + ": " + why);
  }
  // A file named by ref cannot be read: say so at the key that names it.
  void unreadable(const FileRef& ref, const std::string& reason) {
    error(ref.where, ref.field, "\"" + ref.written + "\"", "cannot read " + ref.path + ": " + reason);
  }
};

// A view of one table through several layers, highest priority first (--set overrides,
// the scenario's [vehicle] table, the vehicle file). Unknown keys in any layer are errors.
class Reader {
 public:
  // where: the location of this table (for keys that are missing from it), default the file
  Reader(std::vector<const toml::table*> layers, std::string prefix, std::string file, Context& ctx,
         std::string where = "")
      : layers_(std::move(layers)), prefix_(std::move(prefix)), file_(std::move(file)), ctx_(ctx),
        where_(where.empty() ? file_ : std::move(where)) {}

  const std::string& name() const { return prefix_; }
  const std::string& where() const { return where_; }

  std::string field(std::string_view key) const { return prefix_.empty() ? std::string(key) : prefix_ + "." + std::string(key); }

  const toml::node* find(std::string_view key) {
    used_.insert(std::string(key));
    for (const toml::table* t : layers_) {
      if (t == nullptr) continue;
      if (const toml::node* n = t->get(key)) {
        ctx_.where[field(key)] = location(n, file_);
        return n;
      }
    }
    ctx_.where[field(key)] = file_ + " (default)";
    return nullptr;
  }
  bool has(std::string_view key) const { return layer_of(key) >= 0; }
  // The layer that gives key (0 is the highest: the last --set), -1 if none does.
  int layer_of(std::string_view key) const {
    for (std::size_t i = 0; i < layers_.size(); ++i) {
      if (layers_[i] != nullptr && layers_[i]->get(key) != nullptr) return static_cast<int>(i);
    }
    return -1;
  }

  std::optional<double> opt_number(std::string_view key) {
    const toml::node* n = find(key);
    if (n == nullptr) return std::nullopt;
    if (auto v = n->value<double>()) return *v;  // integers convert too
    ctx_.error(location(n, file_), field(key), node_text(*n), "must be a number");
    return std::nullopt;
  }
  double number(std::string_view key, double fallback) { return opt_number(key).value_or(fallback); }
  double required_number(std::string_view key) {
    if (!has(key)) {
      ctx_.error(where_, field(key), "", "missing (required number)");
      find(key);
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
    fs::path p(*v);
    if (p.is_relative() && n->source().path && n->source().path->rfind("--set", 0) != 0) {
      p = fs::path(*n->source().path).parent_path() / p;
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
        out.emplace_back(std::vector<const toml::table*>{t}, name, file_, ctx_, location(&e, file_));
      } else {
        ctx_.error(location(&e, file_), name, node_text(e), "must be a table");
      }
    }
    return out;
  }

  Reader sub(std::string_view key) {
    used_.insert(std::string(key));
    std::vector<const toml::table*> layers;
    std::string where;  // the lowest layer's table: usually the vehicle file's [table] line
    for (const toml::table* t : layers_) {
      const toml::node* n = t == nullptr ? nullptr : t->get(key);
      if (n != nullptr && !n->is_table()) {
        ctx_.error(location(n, file_), field(key), node_text(*n), "must be a table");
        n = nullptr;
      }
      layers.push_back(n == nullptr ? nullptr : n->as_table());
      if (n != nullptr) where = location(n, file_);
    }
    return Reader(std::move(layers), field(key), file_, ctx_, where.empty() ? where_ : where);
  }

  // Reports every key no reader asked for.
  void finish() {
    for (const toml::table* t : layers_) {
      if (t == nullptr) continue;
      for (const auto& [k, n] : *t) {
        if (used_.count(std::string(k.str())) == 0) {
          ctx_.error(location(&n, file_), field(k.str()), "", "unknown key");
        }
      }
    }
  }

 private:
  std::vector<const toml::table*> layers_;
  std::string prefix_, file_;
  Context& ctx_;
  std::string where_;
  std::set<std::string> used_;
};

// ref: the key that names the file (the vehicle file), so that a missing file is reported
// there; nullptr for the scenario itself.
bool parse_toml(const std::string& path, toml::table& out, Context& ctx, const FileRef* ref = nullptr) {
  std::string content, reason;
  if (!io::read_text_file(path, content, reason)) {
    if (ref != nullptr) {
      ctx.unreadable(*ref, reason);
    } else {
      ctx.errors.push_back(path + ": cannot read: " + reason);
    }
    return false;
  }
  if (const int line = line_with_too_many_dots(content); line != 0) {
    ctx.errors.push_back(path + ":" + std::to_string(line) + ": more than " + std::to_string(kMaxDotsPerLine) +
                         " dots on one line (a dotted key that long would overflow the TOML parser)");
    return false;
  }
  try {
    out = toml::parse(content, path);
    return true;
  } catch (const toml::parse_error& e) {
    const auto& src = e.source();
    ctx.errors.push_back(path + ":" + std::to_string(src.begin.line) + ": TOML syntax: " +
                         std::string(e.description()));
  }
  return false;
}

std::string toml_quote(const std::string& v) {
  std::string out = "\"";
  for (char c : v) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

// "a.b.c=value": the value is parsed as TOML (number, bool, quoted string, array), or taken as text.
bool parse_override(const std::string& text, toml::table& out, Context& ctx) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0) {
    ctx.errors.push_back("--set " + text + ": expected key=value, e.g. --set vehicle.battery.soc_initial=0.6");
    return false;
  }
  const std::string key = text.substr(0, eq);
  const std::string value = text.substr(eq + 1);
  const std::string label = "--set " + (text.size() <= 200 ? text : text.substr(0, 80) + "...");
  if (line_with_too_many_dots(text) != 0) {
    ctx.errors.push_back(label + ": more than " + std::to_string(kMaxDotsPerLine) +
                         " dots on one line (a dotted key that long would overflow the TOML parser)");
    return false;
  }
  try {
    out = toml::parse(key + " = " + value, label);
  } catch (const toml::parse_error&) {
    try {
      out = toml::parse(key + " = " + toml_quote(value), label);
    } catch (const toml::parse_error& e) {
      ctx.errors.push_back(label + ": cannot parse: " + std::string(e.description()));
      return false;
    }
  }
  return true;
}

// ---- CSV-backed tables ------------------------------------------------------------------

// Reads the CSV named by ref. A file that cannot be read is reported at the key that names
// it; its follow-on problems (no table) are not.
bool read_table(const FileRef& ref, const std::string& field, io::CsvTable& t, Context& ctx) {
  ctx.failed_tables.insert(field);
  std::string content, reason;
  if (!io::read_text_file(ref.path, content, reason)) {
    ctx.unreadable(ref, reason);
    return false;
  }
  return io::parse_csv_table(ref.path, content, t, ctx.errors);
}

// Remembers the CSV behind a table; csv_columns[k] is the CSV column of table column k.
void keep_source(const std::string& field, const io::CsvTable& t, const std::vector<int>& csv_columns, Context& ctx) {
  TableSource s{t.path, t.lines, {}, {}};
  for (int c : csv_columns) {
    s.columns.push_back(t.header[static_cast<std::size_t>(c)]);
    s.text.push_back(t.text[static_cast<std::size_t>(c)]);
  }
  ctx.tables[field] = std::move(s);
  ctx.failed_tables.erase(field);
}

// Cycle: time_s and speed_kmh or speed_m_s; other columns ignored. After its last row the
// last speed is held, or the cycle repeats (periodic).
plant::Table1d load_cycle(const FileRef& ref, const std::string& field, bool periodic, Context& ctx) {
  io::CsvTable t;
  if (!read_table(ref, field, t, ctx)) return {};
  const int ti = t.column_index("time_s");
  int vi = t.column_index("speed_m_s");
  double scale = 1.0;
  if (vi < 0) {
    vi = t.column_index("speed_kmh");
    scale = 1.0 / 3.6;
  }
  if (ti < 0 || vi < 0) {
    std::string found;
    for (const auto& h : t.header) found += (found.empty() ? "" : ", ") + h;
    ctx.errors.push_back(t.path + ":" + std::to_string(t.header_line) + ": header: expected a time_s column and a " +
                         "speed_kmh or speed_m_s column (found " + found + ")");
    return {};
  }
  std::vector<double> v = t.columns[static_cast<std::size_t>(vi)];
  for (double& s : v) s *= scale;
  keep_source(field, t, {ti, vi}, ctx);
  return plant::Table1d(t.columns[static_cast<std::size_t>(ti)], std::move(v),
                        periodic ? plant::Extrapolation::kPeriodic : plant::Extrapolation::kHold);
}

plant::Table1d load_curve(const FileRef& ref, const std::string& field, Context& ctx) {
  io::CsvTable t;
  if (!read_table(ref, field, t, ctx)) return {};
  if (t.header.size() < 2) {
    ctx.errors.push_back(t.path + ":" + std::to_string(t.header_line) + ": header: expected two columns (x, y)");
    return {};
  }
  keep_source(field, t, {0, 1}, ctx);
  return plant::Table1d(t.columns[0], t.columns[1], plant::Extrapolation::kHold);
}

// Tidy 2-D map "u1, u2, value" sorted by u1 then u2 (data/README.md) -> grid.
plant::Table2d load_map(const FileRef& ref, const std::string& field, Context& ctx) {
  io::CsvTable t;
  if (!read_table(ref, field, t, ctx)) return {};
  const std::string& path = t.path;
  if (t.header.size() != 3) {
    ctx.errors.push_back(path + ":" + std::to_string(t.header_line) +
                         ": header: expected three columns (row axis, column axis, value)");
    return {};
  }
  std::vector<double> u1, u2;
  for (std::size_t r = 0; r < t.rows(); ++r) {
    const double a = t.columns[0][r], b = t.columns[1][r];
    if (u1.empty() || a != u1.back()) {
      if (!u1.empty() && !(a > u1.back())) {
        ctx.errors.push_back(path + ":" + std::to_string(t.lines[r]) + ": " + field + ", column " + t.header[0] +
                             " = " + t.text[0][r] + ": row axis must be strictly increasing");
        return {};
      }
      u1.push_back(a);
    }
    if (u1.size() == 1) {
      if (!u2.empty() && !(b > u2.back())) {
        ctx.errors.push_back(path + ":" + std::to_string(t.lines[r]) + ": " + field + ", column " + t.header[1] +
                             " = " + t.text[1][r] + ": column axis must be strictly increasing");
        return {};
      }
      u2.push_back(b);
    }
  }
  if (t.rows() != u1.size() * u2.size()) {
    ctx.errors.push_back(path + ": " + field + ": " + std::to_string(t.rows()) + " rows, a full " +
                         std::to_string(u1.size()) + " x " + std::to_string(u2.size()) + " grid needs " +
                         std::to_string(u1.size() * u2.size()));
    return {};
  }
  for (std::size_t r = 0; r < t.rows(); ++r) {
    if (t.columns[0][r] != u1[r / u2.size()] || t.columns[1][r] != u2[r % u2.size()]) {
      ctx.errors.push_back(path + ":" + std::to_string(t.lines[r]) + ": " + field +
                           ": grid point out of order (rows must be sorted by the first column, then the second)");
      return {};
    }
  }
  keep_source(field, t, {0, 1, 2}, ctx);
  return plant::Table2d(std::move(u1), std::move(u2), t.columns[2]);
}

// ---- component readers ------------------------------------------------------------------

plant::MapDriveParams read_drive(Reader r, Context& ctx) {
  plant::MapDriveParams p;
  p.torque_max_Nm = r.required_number("torque_max_Nm");
  p.power_max_W = r.required_number("power_max_W");
  p.speed_max_rad_s = r.required_number("speed_max_rad_s");
  p.inertia_kgm2 = r.required_number("inertia_kgm2");
  p.limit_ramp_fraction = r.number("limit_ramp_fraction", p.limit_ramp_fraction);
  const std::string model = r.text("loss_model", "ideal");
  if (model == "ideal") {
    p.loss_model = plant::DriveLossModel::kIdeal;
  } else if (model == "map") {
    p.loss_model = plant::DriveLossModel::kMap;
    const FileRef map = r.path("efficiency_map", true);
    if (!map.empty()) p.efficiency_map = load_map(map, r.field("efficiency_map"), ctx);
  } else if (model == "formula") {
    p.loss_model = plant::DriveLossModel::kFormula;
    Reader f = r.sub("loss_formula");
    p.loss_formula.a = f.number("a", p.loss_formula.a);
    p.loss_formula.b_t = f.number("b_t", p.loss_formula.b_t);
    p.loss_formula.b_w = f.number("b_w", p.loss_formula.b_w);
    p.loss_formula.b_p = f.number("b_p", p.loss_formula.b_p);
    f.finish();
  } else {
    ctx.error(ctx.where[r.field("loss_model")], r.field("loss_model"), "\"" + model + "\"",
              "must be \"ideal\", \"map\" or \"formula\"");
  }
  if (model != "map" && r.has("efficiency_map")) r.path("efficiency_map", false);  // allowed, unused
  if (model != "formula" && r.has("loss_formula")) r.sub("loss_formula");
  r.finish();
  return p;
}

plant::BatteryRcParams read_battery(Reader r) {
  plant::BatteryRcParams p;
  p.cell_capacity_Ah = r.number("cell_capacity_Ah", p.cell_capacity_Ah);
  p.cell_emf_min_V = r.number("cell_emf_min_V", p.cell_emf_min_V);
  p.cell_emf_max_V = r.number("cell_emf_max_V", p.cell_emf_max_V);
  p.soc_min = r.number("soc_min", p.soc_min);
  p.soc_max = r.number("soc_max", p.soc_max);
  p.soc_initial = r.number("soc_initial", p.soc_initial);
  p.cell_current_max_A = r.opt_number("cell_current_max_A");
  p.r0_cell_Ohm = r.opt_number("r0_cell_Ohm");
  p.r1_cell_Ohm = r.opt_number("r1_cell_Ohm");
  p.c1_cell_F = r.opt_number("c1_cell_F");
  p.efficiency = r.number("efficiency", p.efficiency);
  p.cell_current_efficiency_A = r.opt_number("cell_current_efficiency_A");
  // a pack of more than 100 000 cells in either direction is a typo, not a battery
  p.cells_series = r.small_integer("cells_series", p.cells_series, 1, 100000);
  p.strings_parallel = r.small_integer("strings_parallel", p.strings_parallel, 1, 100000);
  r.finish();
  return p;
}

plant::RoadLoadParams read_road(Reader r, Context& ctx) {
  plant::RoadLoadParams p;
  const std::string form = r.text("form", "coefficients");
  static constexpr std::array<std::string_view, 4> kCoefficientKeys = {"rolling_coefficient", "air_density_kg_m3",
                                                                       "frontal_area_m2", "drag_coefficient"};
  static constexpr std::array<std::string_view, 3> kCoastDownKeys = {"f0_N", "f1_N_s_m", "f2_N_s2_m2"};
  // the keys of the other form are ignored with a warning, so that `--set road.form=...`
  // can switch forms on a vehicle file that gives the other one
  const auto ignore = [&](const auto& keys) {
    for (std::string_view key : keys) {
      if (!r.has(key)) continue;
      const toml::node* n = r.find(key);
      ctx.warn(ctx.where[r.field(key)], r.field(key), n != nullptr ? node_text(*n) : "",
               "ignored: road.form is \"" + form + "\"");
    }
  };
  if (form == "coefficients") {
    p.form = plant::RoadLoadForm::kCoefficients;
    p.rolling_coefficient = r.required_number("rolling_coefficient");
    p.air_density_kg_m3 = r.number("air_density_kg_m3", p.air_density_kg_m3);
    p.frontal_area_m2 = r.required_number("frontal_area_m2");
    p.drag_coefficient = r.required_number("drag_coefficient");
    ignore(kCoastDownKeys);
  } else if (form == "coast-down") {
    p.form = plant::RoadLoadForm::kCoastDown;
    p.f0_N = r.required_number("f0_N");
    p.f1_N_s_m = r.number("f1_N_s_m", 0.0);
    p.f2_N_s2_m2 = r.required_number("f2_N_s2_m2");
    ignore(kCoefficientKeys);
  } else {
    ctx.error(ctx.where[r.field("form")], r.field("form"), "\"" + form + "\"",
              "must be \"coefficients\" or \"coast-down\"");
    // the keys of both forms are known: no follow-on "unknown key"
    for (std::string_view key : kCoefficientKeys) r.find(key);
    for (std::string_view key : kCoastDownKeys) r.find(key);
  }
  const FileRef slope = r.path("slope_table", false);
  if (!slope.empty()) p.slope_rad = load_curve(slope, r.field("slope"), ctx);
  r.finish();
  return p;
}

plant::VehicleBodyParams read_body(Reader r) {
  plant::VehicleBodyParams b;
  b.mass_kg = r.required_number("mass_kg");
  b.wheel_radius_m = r.required_number("wheel_radius_m");
  b.gear_ratio = r.required_number("gear_ratio");
  b.speed_initial_m_s = r.number("speed_initial_m_s", 0.0);
  r.finish();
  return b;
}

plant::PropDriverParams read_driver(Reader r) {
  plant::PropDriverParams d;
  d.gain = r.required_number("gain");
  d.request_max = r.number("request_max", d.request_max);
  d.request_min = r.number("request_min", -d.request_max);
  r.finish();
  return d;
}

plant::BrakeParams read_brake(Reader r) {
  plant::BrakeParams b;
  b.enabled = r.flag("enabled", b.enabled);
  b.library_gain = r.flag("library_gain", b.library_gain);
  b.after_rotor_inertia = r.flag("after_rotor_inertia", b.after_rotor_inertia);
  r.finish();
  return b;
}

plant::MapIceParams read_ice(Reader r, Context& ctx) {
  plant::MapIceParams p;
  const std::string input = r.text("input", "power");
  if (input == "power") {
    p.input = plant::IceInput::kPower;
  } else if (input == "torque") {
    p.input = plant::IceInput::kTorque;
  } else {
    ctx.error(ctx.where[r.field("input")], r.field("input"), "\"" + input + "\"", "must be \"power\" or \"torque\"");
  }
  p.inertia_kgm2 = r.number("inertia_kgm2", p.inertia_kgm2);
  p.speed_initial_rad_s = r.number("speed_initial_rad_s", p.speed_initial_rad_s);
  p.control_gain_Nm_W = r.number("control_gain_Nm_W", p.control_gain_Nm_W);
  p.fuel_lhv_J_kg = r.number("fuel_lhv_J_kg", p.fuel_lhv_J_kg);
  p.fuel_density_kg_m3 = r.number("fuel_density_kg_m3", p.fuel_density_kg_m3);
  p.on_off = r.flag("on_off", false);
  const FileRef curve = r.path("torque_max_table", true);
  if (!curve.empty()) p.torque_max_Nm = load_curve(curve, r.field("torque_max"), ctx);
  const FileRef sfc = r.path("sfc_map", true);
  if (!sfc.empty()) p.sfc_g_kWh = load_map(sfc, r.field("sfc_map"), ctx);
  r.finish();
  return p;
}

// The timing every built-in ECU has: its period and its latency (whole numbers of steps).
void read_ecu_timing(Reader& r, EcuTiming& t) {
  t.period_s = r.number("period_s", t.period_s);
  t.latency_s = r.number("latency_s", t.latency_s);
}

ecu::PsdEcuParams read_psd_ecu(Reader r, EcuTiming& timing, Context& ctx) {
  ecu::PsdEcuParams p;
  const std::string kind = r.text("kind", "");
  if (kind == "MBecu1") {
    p.kind = ecu::PsdEcuKind::kMBecu1;
  } else if (kind == "MBecu1soc") {
    p.kind = ecu::PsdEcuKind::kMBecu1soc;
  } else if (kind == "MBecu2") {
    p.kind = ecu::PsdEcuKind::kMBecu2;
  } else {
    ctx.error(ctx.where[r.field("kind")], r.field("kind"), "\"" + kind + "\"",
              "must be \"MBecu1\", \"MBecu1soc\" or \"MBecu2\"");
  }
  read_ecu_timing(r, timing);
  p.max_torque_request_Nm = r.number("max_torque_request_Nm", p.max_torque_request_Nm);
  p.power_filter_s = r.number("power_filter_s", p.power_filter_s);
  p.gen_loop_gain_Nm_s_rad = r.required_number("gen_loop_gain_Nm_s_rad");
  p.gen_filter_s = r.number("gen_filter_s", p.gen_filter_s);
  p.gen_torque_max_Nm = r.number("gen_torque_max_Nm", p.gen_torque_max_Nm);
  p.ice_speed_min_rad_s = r.number("ice_speed_min_rad_s", p.ice_speed_min_rad_s);
  const FileRef table = r.path("power_to_speed_table", true);
  if (!table.empty()) {
    p.power_to_speed_rad_s = load_curve(table, r.field("power_to_speed"), ctx);
    // PowToW extrapolates linearly beyond its ends (§5.1)
    p.power_to_speed_rad_s = plant::Table1d(p.power_to_speed_rad_s.x(), p.power_to_speed_rad_s.y(),
                                            plant::Extrapolation::kLinear);
  }
  p.soc_ref = r.number("soc_ref", p.soc_ref);
  // MBecu1 has no SOC loop (PsdEcu ignores the gain); the others need it
  p.soc_loop_gain_W = p.kind == ecu::PsdEcuKind::kMBecu1 ? r.number("soc_loop_gain_W", 0.0)
                                                           : r.required_number("soc_loop_gain_W");
  p.on_threshold_W = r.number("on_threshold_W", p.on_threshold_W);
  p.off_threshold_W = r.number("off_threshold_W", p.off_threshold_W);
  p.ice_off_speed_ref_rad_s = r.number("ice_off_speed_ref_rad_s", p.ice_off_speed_ref_rad_s);
  r.finish();
  return p;
}

plant::PsdParams read_psd(Reader& root, const FileRef& cycle, bool periodic, Context& ctx) {
  plant::PsdParams p;
  p.body = read_body(root.sub("vehicle"));
  p.road = read_road(root.sub("road"), ctx);
  p.brake = read_brake(root.sub("brake"));
  p.driver = read_driver(root.sub("driver"));
  p.battery = read_battery(root.sub("battery"));
  p.ice = read_ice(root.sub("ice"), ctx);
  p.gen = read_drive(root.sub("gen"), ctx);
  p.mot = read_drive(root.sub("mot"), ctx);
  {
    Reader r = root.sub("planetary");
    p.ring_sun_ratio = r.number("ring_sun_ratio", p.ring_sun_ratio);
    r.finish();
  }
  if (!cycle.empty()) p.driver.cycle_m_s = load_cycle(cycle, "driver.cycle", periodic, ctx);
  return p;
}

// The EV's built-in ECU: the driver-follower; an optional [ecu] table sets its timing.
void read_ev_ecu(Reader r, EcuTiming& timing, Context& ctx) {
  const std::string kind = r.text("kind", "follower");
  if (kind != "follower") {
    ctx.error(ctx.where[r.field("kind")], r.field("kind"), "\"" + kind + "\"",
              "must be \"follower\" (the built-in ECU of the EV; an external one joins over a bus)");
  }
  read_ecu_timing(r, timing);
  r.finish();
}

plant::BevParams read_bev(Reader& root, const FileRef& cycle, bool periodic, Context& ctx) {
  plant::BevParams p;
  p.body = read_body(root.sub("vehicle"));
  p.road = read_road(root.sub("road"), ctx);
  p.drive = read_drive(root.sub("drive"), ctx);
  p.battery = read_battery(root.sub("battery"));
  p.driver = read_driver(root.sub("driver"));
  p.brake = read_brake(root.sub("brake"));
  if (!cycle.empty()) p.driver.cycle_m_s = load_cycle(cycle, "driver.cycle", periodic, ctx);
  return p;
}

plant::DriveRigParams read_rig(Reader& root, Context& ctx) {
  plant::DriveRigParams p;
  const std::int64_t flanges = root.integer("flanges", 1);
  if (flanges != 1 && flanges != 2) {
    ctx.error(ctx.where["flanges"], "flanges", std::to_string(flanges), "must be 1 or 2");
  }
  p.two_flange = flanges == 2;
  p.dc_voltage_V = root.number("dc_voltage_V", p.dc_voltage_V);
  p.drive = read_drive(root.sub("drive"), ctx);
  {
    Reader r = root.sub("load");
    p.load_inertia_kgm2 = r.number("inertia_kgm2", p.load_inertia_kgm2);
    p.speed_initial_rad_s = r.number("speed_initial_rad_s", p.speed_initial_rad_s);
    p.load_torque_nominal_Nm = r.number("torque_nominal_Nm", p.load_torque_nominal_Nm);
    p.load_speed_nominal_rad_s = r.number("speed_nominal_rad_s", p.load_speed_nominal_rad_s);
    p.flange_a_torque_Nm = r.number("flange_a_torque_Nm", p.flange_a_torque_Nm);
    r.finish();
  }
  {
    Reader r = root.sub("request");
    plant::Trapezoid& t = p.request_Nm;
    t.offset = r.number("offset_Nm", 0.0);
    t.amplitude = r.number("amplitude_Nm", 0.0);
    t.start_s = r.number("start_s", 0.0);
    t.rising_s = r.required_number("rising_s");
    t.width_s = r.number("width_s", 0.0);
    t.falling_s = r.required_number("falling_s");
    t.period_s = r.number("period_s", 1e6);
    r.finish();
  }
  return p;
}

plant::BatteryRigParams read_battery_rig(Reader& root, Context& ctx) {
  plant::BatteryRigParams p;
  p.battery = read_battery(root.sub("battery"));
  for (Reader& r : root.table_array("profile")) {
    plant::BatterySegment s;
    const bool current = r.has("current_A"), power = r.has("power_W");
    if (current == power) {
      ctx.error(r.where(), r.name(), "", "give either current_A or power_W (> 0 discharge, < 0 charge)");
    }
    s.kind = power ? plant::BatterySegment::Kind::kPower : plant::BatterySegment::Kind::kCurrent;
    s.value = power ? r.number("power_W", 0.0) : r.number("current_A", 0.0);
    if (current && power) r.find("current_A");  // reported above, not also unknown
    s.duration_s = r.required_number("duration_s");
    r.finish();
    p.profile.push_back(s);
  }
  return p;
}

// Gives plant/ problems the file and line their value came from; a problem in a table cell
// gets the CSV line, column and the value as written (a cycle in km/h stays in km/h).
void report_plant_problems(const Problems& problems, Context& ctx, std::vector<std::string>* sink = nullptr) {
  for (const plant::Problem& pr : problems.list()) {
    // a table whose file failed to read, or a value the loader rejected, was reported already
    if (sink == nullptr && ctx.reported.count(pr.field) != 0) continue;
    bool reported = false;
    for (const std::string& failed : ctx.failed_tables) reported = reported || pr.field.rfind(failed, 0) == 0;
    if (reported) continue;
    std::string loc, field = pr.field, value = pr.value;
    if (const auto t = ctx.tables.find(pr.field); t != ctx.tables.end()) {
      const TableSource& src = t->second;
      loc = src.path;
      if (pr.row >= 0 && static_cast<std::size_t>(pr.row) < src.lines.size()) {
        const auto row = static_cast<std::size_t>(pr.row);
        loc += ":" + std::to_string(src.lines[row]);
        if (pr.column >= 0 && static_cast<std::size_t>(pr.column) < src.columns.size()) {
          const auto col = static_cast<std::size_t>(pr.column);
          field += ", column " + src.columns[col];
          value = src.text[col][row];
        }
      }
    }
    if (loc.empty()) {
      if (auto w = ctx.where.find(pr.field); w != ctx.where.end()) loc = w->second;
    }
    if (loc.empty()) loc = "(vehicle)";
    if (sink != nullptr) {
      sink->push_back(loc + ": " + field + " = " + value + ": " + pr.expected);
    } else {
      ctx.error(loc, field, value, pr.expected);
    }
  }
}

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

}  // namespace

bool load_scenario(const std::string& path, const std::vector<std::string>& overrides, Scenario& out,
                   std::vector<std::string>& errors) {
  Context ctx;
  out = Scenario{};
  out.path = path;
  out.name = fs::path(path).stem().string();

  // layers: each --set, the last given first (the last --set of a key wins), then the file
  std::vector<toml::table> set_docs(overrides.size());
  for (std::size_t i = 0; i < overrides.size(); ++i) parse_override(overrides[i], set_docs[i], ctx);
  toml::table scenario_doc;
  if (!parse_toml(path, scenario_doc, ctx)) {
    errors = ctx.errors;
    return false;
  }
  std::vector<const toml::table*> layers;
  for (auto d = set_docs.rbegin(); d != set_docs.rend(); ++d) layers.push_back(&*d);
  layers.push_back(&scenario_doc);
  Reader sc(layers, "", path, ctx);

  out.description = sc.text("description", "");
  const FileRef vehicle_ref = sc.path("vehicle_file", true);
  const FileRef cycle_ref = sc.path("cycle", false);
  // repeat the cycle to fill solver.duration_s, as the library's EV examples do
  const bool cycle_periodic = sc.flag("cycle_periodic", false);
  out.vehicle_path = vehicle_ref.path;
  out.cycle_path = cycle_ref.path;
  bool has_interval = false, has_decimation = false;
  double interval_s = 0.1;
  {
    Reader r = sc.sub("solver");
    const std::string method = r.text("method", "rk4");
    if (method == "rk4") {
      out.solver.kind = SolverKind::kRk4;
    } else if (method == "implicit-euler") {
      out.solver.kind = SolverKind::kImplicitEuler;
    } else {
      ctx.error(ctx.where["solver.method"], "solver.method", "\"" + method + "\"", "must be \"rk4\" or \"implicit-euler\"");
    }
    out.solver.step_s = r.number("step_s", out.solver.step_s);
    if (!(out.solver.step_s > 0.0 && out.solver.step_s <= 1.0)) {
      ctx.error(ctx.where["solver.step_s"], "solver.step_s", io::number_text(out.solver.step_s), "must be in (0, 1] s");
    }
    out.solver.duration_s = r.number("duration_s", 0.0);  // 0: the cycle's length
    r.finish();
  }
  {
    Reader r = sc.sub("output");
    out.output.signals = r.strings("signals");
    const int interval_layer = r.layer_of("interval_s"), decimation_layer = r.layer_of("decimation");
    has_interval = interval_layer >= 0;
    has_decimation = decimation_layer >= 0;
    interval_s = r.number("interval_s", interval_s);
    out.output.decimation = r.integer("decimation", 1);
    if (has_interval && has_decimation && interval_layer == decimation_layer) {
      ctx.error(ctx.where["output.decimation"], "output.decimation", std::to_string(out.output.decimation),
                "give either output.interval_s or output.decimation, not both");
    } else if (has_interval && has_decimation) {
      // from different layers (--set over the scenario): the higher one wins, as for any key
      const bool decimation_wins = decimation_layer < interval_layer;
      const std::string loser = decimation_wins ? "output.interval_s" : "output.decimation";
      ctx.warn(ctx.where[loser], loser, "", std::string("ignored: ") +
                                               (decimation_wins ? "output.decimation" : "output.interval_s") +
                                               " is given by " + ctx.where[decimation_wins ? "output.decimation" : "output.interval_s"]);
      (decimation_wins ? has_interval : has_decimation) = false;
    }
    if (has_decimation && out.output.decimation < 1) {
      ctx.error(ctx.where["output.decimation"], "output.decimation", std::to_string(out.output.decimation),
                "must be >= 1");
    } else if (!has_decimation && !(interval_s > 0.0 && std::isfinite(interval_s))) {
      ctx.error(ctx.where["output.interval_s"], "output.interval_s", io::number_text(interval_s),
                "must be a finite number > 0 s");
    }
    r.finish();
  }

  // the vehicle: --set vehicle.*, then the scenario's [vehicle] table, then the vehicle file
  (void)sc.sub("vehicle");  // read below, as a layer over the vehicle file
  sc.finish();
  toml::table vehicle_doc;
  if (vehicle_ref.empty() || !parse_toml(vehicle_ref.path, vehicle_doc, ctx, &vehicle_ref)) {
    errors = ctx.errors;
    return false;
  }
  std::vector<const toml::table*> vlayers;
  for (auto d = set_docs.rbegin(); d != set_docs.rend(); ++d) vlayers.push_back(d->get_as<toml::table>("vehicle"));
  vlayers.push_back(scenario_doc.get_as<toml::table>("vehicle"));
  vlayers.push_back(&vehicle_doc);
  Reader vr(vlayers, "", out.vehicle_path, ctx);
  vr.text("description", "");
  const std::string kind = vr.text("kind", "");
  Problems problems, warnings;
  // vehicles with a driver: a cycle is required, and its length is the default duration
  const auto need_cycle = [&]() {
    if (cycle_ref.empty()) ctx.error(path, "cycle", "", "missing (a vehicle with a driver needs a cycle file)");
  };
  const auto no_cycle = [&](const char* what) {
    if (!cycle_ref.empty()) {
      ctx.error(cycle_ref.where, "cycle", "\"" + cycle_ref.written + "\"", std::string(what) + " has no driver: remove the cycle");
    }
  };
  const auto default_duration = [&](double end_s) {
    if (out.solver.duration_s == 0.0) out.solver.duration_s = end_s;
  };
  bool has_ecu = false;                // vehicles with a built-in ECU
  bool duration_unknown = false;       // from a table or profile that has a problem already
  if (kind == "bev") {
    need_cycle();
    plant::BevParams p = read_bev(vr, cycle_ref, cycle_periodic, ctx);
    read_ev_ecu(vr.sub("ecu"), out.ecu_timing, ctx);
    vr.finish();
    has_ecu = true;
    out.ecu = ecu::EvFollowerParams{};
    if (!p.driver.cycle_m_s.empty()) default_duration(p.driver.cycle_m_s.x().back());
    plant::validate(p, problems);
    if (problems.empty()) plant::warn(p.drive, "drive", warnings);
    check_signals(plant::BevPlant::kSignals, out.output.signals, ctx);
    out.plant = std::move(p);
  } else if (kind == "psd") {
    need_cycle();
    plant::PsdParams p = read_psd(vr, cycle_ref, cycle_periodic, ctx);
    ecu::PsdEcuParams e = read_psd_ecu(vr.sub("ecu"), out.ecu_timing, ctx);
    vr.finish();
    ecu::validate(e, "ecu", problems);
    has_ecu = true;
    if (!p.driver.cycle_m_s.empty()) default_duration(p.driver.cycle_m_s.x().back());
    plant::validate(p, problems);
    if (problems.empty()) {
      plant::warn(p.gen, "gen", warnings);
      plant::warn(p.mot, "mot", warnings);
      if (e.kind == ecu::PsdEcuKind::kMBecu2 && !p.ice.on_off) {
        warnings.add("ice.on_off", "false",
                     "MBecu2 stops the engine through iceON, which this engine ignores: when OFF only "
                     "icePowRef = 0, and the power loop may still give torque and burn fuel");
      }
      if (p.ice.input == plant::IceInput::kTorque) {
        warnings.add("ice.input", "\"torque\"",
                     "the built-in ECUs send icePowRef, not iceTauRef: with them this engine gives no torque");
      }
    }
    check_signals(plant::PsdPlant::kSignals, out.output.signals, ctx);
    out.plant = std::move(p);
    out.ecu = std::move(e);
  } else if (kind == "drive_rig") {
    no_cycle("a drive rig");
    plant::DriveRigParams p = read_rig(vr, ctx);
    vr.finish();
    plant::validate(p, problems);
    if (problems.empty()) plant::warn(p.drive, "drive", warnings);
    check_signals(plant::DriveRig(p).signals(), out.output.signals, ctx);
    out.plant = std::move(p);
  } else if (kind == "battery_rig") {
    no_cycle("a battery rig");
    plant::BatteryRigParams p = read_battery_rig(vr, ctx);
    vr.finish();
    plant::validate(p, problems);
    if (problems.empty()) {
      double end_s = 0.0;
      for (const plant::BatterySegment& seg : p.profile) end_s += seg.duration_s;
      default_duration(end_s);
    } else {
      duration_unknown = true;  // the profile's problem was reported: its length is unknown
    }
    check_signals(plant::BatteryRig::kSignals, out.output.signals, ctx);
    out.plant = std::move(p);
  } else {
    ctx.error(ctx.where["kind"], "kind", "\"" + kind + "\"",
              "must be \"bev\", \"psd\", \"drive_rig\" or \"battery_rig\"");
  }
  report_plant_problems(problems, ctx);
  report_plant_problems(warnings, ctx, &out.warnings);

  // steps, rows and ECU ticks: counts computed from user numbers, checked before rounding
  const double h = out.solver.step_s;
  const bool step_ok = h > 0.0 && h <= 1.0;
  if ((duration_unknown || ctx.failed_tables.count("driver.cycle") != 0) && out.solver.duration_s == 0.0) {
    // no cycle or profile: its length is unknown, and its problem was reported already
  } else if (!(out.solver.duration_s > 0.0) || !std::isfinite(out.solver.duration_s)) {
    ctx.error(ctx.where["solver.duration_s"], "solver.duration_s", io::number_text(out.solver.duration_s),
              "must be a finite number > 0 s (give it, or a cycle whose last time stamp sets it)");
  } else if (step_ok) {
    const double ratio = out.solver.duration_s / h;
    // blame the key the user gave: the duration, or else the step (the duration is the
    // cycle's or the profile's length)
    const bool duration_given = ctx.where["solver.duration_s"].find("(default)") == std::string::npos;
    if (!(ratio < static_cast<double>(kMaxSteps) + 0.5)) {
      const std::string too_many = io::number_text(ratio) + " steps, more than the limit of 1e10 per run; " +
                                   "use a longer step or a shorter run";
      if (duration_given) {
        ctx.error(ctx.where["solver.duration_s"], "solver.duration_s", io::number_text(out.solver.duration_s),
                  "with solver.step_s = " + io::number_text(h) + " s that is " + too_many);
      } else {
        ctx.error(ctx.where["solver.step_s"], "solver.step_s", io::number_text(h),
                  "over the default duration of " + io::number_text(out.solver.duration_s) + " s that is " + too_many);
      }
    } else if (std::llround(ratio) < 1) {
      ctx.error(ctx.where["solver.duration_s"], "solver.duration_s", io::number_text(out.solver.duration_s),
                "shorter than half a step (solver.step_s = " + io::number_text(h) + "): the run would have no step");
    } else {
      out.solver.steps = std::llround(ratio);
      const double end_s = static_cast<double>(out.solver.steps) * h;
      if (std::abs(end_s - out.solver.duration_s) > 1e-9 * out.solver.duration_s) {
        ctx.warn(ctx.where["solver.duration_s"], "solver.duration_s", io::number_text(out.solver.duration_s),
                 "not a whole number of steps; the run ends at t = " + io::number_text(end_s) + " s");
      }
    }
  }
  if (out.solver.steps > 0 && !has_decimation && interval_s > 0.0 && std::isfinite(interval_s)) {
    // a row every interval, rounded to whole steps; an interval longer than the run gives
    // the first and last rows only
    const double ratio = interval_s / h;
    out.output.decimation = ratio >= static_cast<double>(out.solver.steps) ? out.solver.steps
                                                                          : std::max<std::int64_t>(1, std::llround(ratio));
    if (ratio < 0.5 && has_interval) {
      ctx.warn(ctx.where["output.interval_s"], "output.interval_s", io::number_text(interval_s),
               "shorter than the step (" + io::number_text(h) + " s): every step is written");
    }
  }
  if (has_ecu && step_ok) {
    // the ECU runs every whole number of plant steps (0: every step), and its commands act a
    // whole number of steps after the sample they were computed from (0: at once)
    const auto whole_steps = [&](double value_s, const char* field, std::int64_t& steps) {
      const double ratio = value_s / h;
      steps = ratio >= 0.0 && ratio < 1e9 ? std::llround(ratio) : -1;
      if (steps < 0 || std::abs(ratio - static_cast<double>(steps)) > 1e-9 * std::max(1.0, ratio)) {
        ctx.error(ctx.where[field], field, io::number_text(value_s),
                  "must be a whole multiple of solver.step_s = " + io::number_text(h) + " (and >= 0)");
      }
    };
    EcuTiming& t = out.ecu_timing;
    if (t.period_s == 0.0) t.period_s = h;
    whole_steps(t.period_s, "ecu.period_s", out.solver.ecu_ratio);
    if (out.solver.ecu_ratio == 0) {
      ctx.error(ctx.where["ecu.period_s"], "ecu.period_s", io::number_text(t.period_s), "must be > 0 (0: every step)");
    }
    whole_steps(t.latency_s, "ecu.latency_s", out.solver.ecu_latency_steps);
    if (auto* e = std::get_if<ecu::PsdEcuParams>(&out.ecu)) e->period_s = t.period_s;
  }
  for (std::string& w : ctx.warnings) out.warnings.push_back(std::move(w));
  errors = ctx.errors;
  return errors.empty();
}

}  // namespace ehpt::hil
