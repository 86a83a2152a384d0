// SPDX-License-Identifier: BSD-3-Clause
#include "hil/config/config_reader.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "hil/config/scenario.hpp"
#include "hil/config/toml_guard.hpp"
#include "io/number_format.hpp"
#include "io/sha256.hpp"
#include "io/text_file.hpp"

namespace fs = std::filesystem;

namespace ehpt::hil::detail {

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
  // one allocation: every key of every load is located (a sweep's plan loads 10^5 of them)
  char line[24];
  const int k = std::snprintf(line, sizeof line, ":%u", static_cast<unsigned>(n->source().begin.line));
  std::string out;
  out.reserve(p.size() + static_cast<std::size_t>(k));
  out.append(p).append(line, static_cast<std::size_t>(k));
  return out;
}

namespace {

std::string_view leaf_of(std::string_view path) {
  const auto dot = path.rfind('.');
  return dot == std::string_view::npos ? path : path.substr(dot + 1);
}
std::string_view parent_of(std::string_view path) {
  const auto dot = path.rfind('.');
  return dot == std::string_view::npos ? std::string_view() : path.substr(0, dot);
}
std::vector<std::string> tokens_of(std::string_view leaf) {
  std::vector<std::string> out;
  std::string t;
  for (const char c : leaf) {
    if (c == '_') {
      if (!t.empty()) out.push_back(t);
      t.clear();
    } else {
      t += (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c;
    }
  }
  if (!t.empty()) out.push_back(t);
  return out;
}
bool ends_with_part(std::string_view path, std::string_view tail) {
  return path.size() > tail.size() && path.ends_with(tail) && path[path.size() - tail.size() - 1] == '.';
}

// How far the unknown key is from a known one (lower is closer; -1: not a near miss).
int key_distance(const std::string& unknown, const std::string& known) {
  if (known == unknown) return -1;
  // the right key at the wrong depth: vehicle.mass_kg for vehicle.vehicle.mass_kg, or a
  // scenario key inside [vehicle]
  if (ends_with_part(known, unknown) || ends_with_part(unknown, known)) return 1;
  const std::string_view a = leaf_of(unknown), b = leaf_of(known);
  const int elsewhere = parent_of(unknown) == parent_of(known) ? 0 : 2;
  const auto d = static_cast<int>(edit_distance(a, b));
  if (d <= std::max<int>(1, static_cast<int>(a.size()) / 4)) return 1 + d + elsewhere;
  // every word of the unknown key begins a word of the known one: capacity -> cell_capacity_Ah
  const std::vector<std::string> ta = tokens_of(a), tb = tokens_of(b);
  if (ta.empty() || ta.size() > tb.size()) return -1;
  std::size_t matched = 0;
  for (const std::string& w : ta) {
    bool found = false;
    for (const std::string& v : tb) found = found || (w.size() >= 2 && v.rfind(w, 0) == 0);
    matched += found ? 1 : 0;
  }
  if (matched != ta.size() || tb.size() - ta.size() > 3) return -1;
  return 3 + static_cast<int>(tb.size() - ta.size()) + elsewhere;
}

}  // namespace

void Context::suggest_known_keys() {
  for (const Unknown& u : unknown) {
    std::string best;
    int best_d = -1;
    for (const std::string& k : known) {
      const int d = key_distance(u.path, k);
      if (d < 0) continue;
      // a tie goes to the shorter key, then the first in order
      if (best_d < 0 || d < best_d || (d == best_d && k.size() < best.size())) {
        best_d = d;
        best = k;
      }
    }
    if (best.empty() || u.error >= errors.size()) continue;
    std::string hint;
    if (!u.vehicle_file) {
      hint = "`" + best + "`";
    } else if (best.rfind("vehicle.", 0) == 0) {
      hint = "`" + best.substr(8) + "`";  // a vehicle file writes its keys without "vehicle."
    } else {
      hint = "`" + best + "` (a key of the scenario, not of the vehicle file)";
    }
    errors[u.error] += "; did you mean " + hint + "?";
  }
}

// ref: the key that names the file (the vehicle file), so that a missing file is reported
// there; nullptr for the scenario itself.
void Context::read_file(const std::string& path, const std::string& content, const std::string* sha256) {
  for (const InputFile& f : inputs) {
    if (f.path == path) return;
  }
  inputs.push_back(InputFile{path, sha256 != nullptr ? *sha256 : io::sha256_hex(content), content.size()});
}

const std::string* Context::read(const std::string& path, std::string& storage, std::string& why) {
  if (cache == nullptr) {
    if (!io::read_text_file(path, storage, why)) return nullptr;
    read_file(path, storage);
    return &storage;
  }
  auto [it, fresh] = cache->bytes.try_emplace(path);
  LoadCache::Files::File& f = it->second;
  if (fresh) {
    f.ok = io::read_text_file(path, f.content, f.reason);
    if (f.ok) f.sha256 = io::sha256_hex(f.content);
  }
  if (!f.ok) {
    why = f.reason;
    return nullptr;
  }
  read_file(path, f.content, &f.sha256);
  return &f.content;
}

const toml::table* read_toml(const std::string& path, toml::table& storage, Context& ctx, const FileRef* ref) {
  if (ctx.cache != nullptr) {
    if (const auto it = ctx.cache->toml.find(path); it != ctx.cache->toml.end()) {
      std::string bytes, reason;
      (void)ctx.read(path, bytes, reason);  // listed as an input, as when parsed
      return &it->second;
    }
  }
  std::string bytes, reason;
  const std::string* read = ctx.read(path, bytes, reason);
  if (read == nullptr) {
    if (ref != nullptr) {
      ctx.unreadable(*ref, reason);
    } else {
      ctx.errors.push_back(path + ": cannot read: " + reason);
    }
    return nullptr;
  }
  const std::string& content = *read;
  if (const int line = line_with_too_many_dots(content); line != 0) {
    ctx.errors.push_back(path + ":" + std::to_string(line) + ": more than " + std::to_string(kMaxDotsPerLine) +
                         " dots on one line (a dotted key that long would overflow the TOML parser; write a long "
                         "array of numbers over several lines)");
    return nullptr;
  }
  try {
    // a table is never copied: a copy of a toml++ node loses its source (file:line in messages)
    if (ctx.cache != nullptr) return &ctx.cache->toml.emplace(path, toml::parse(content, path)).first->second;
    storage = toml::parse(content, path);
    return &storage;
  } catch (const toml::parse_error& e) {
    const auto& src = e.source();
    ctx.errors.push_back(path + ":" + std::to_string(src.begin.line) + ": TOML syntax: " +
                         std::string(e.description()));
  }
  return nullptr;
}

bool parse_toml(const std::string& path, toml::table& out, Context& ctx, const FileRef* ref) {
  LoadCache::Files* const cache = ctx.cache;
  ctx.cache = nullptr;  // out is the caller's own
  const bool ok = read_toml(path, out, ctx, ref) != nullptr;
  ctx.cache = cache;
  return ok;
}

// "a.b.c=value": the value is parsed as TOML (number, bool, quoted string, array), or taken as text.
bool parse_override(const std::string& text, toml::table& out, Context& ctx) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0) {
    ctx.errors.push_back("--set " + text + ": expected key=value, e.g. --set vehicle.battery.soc_initial=0.6");
    return false;
  }
  // One --set is one key: a line break would let TOML read further keys past the layering
  // and the last-one-wins rule (and would put the break into the message)
  if (const auto br = text.find_first_of("\r\n"); br != std::string::npos) {
    ctx.errors.push_back("--set " + text.substr(0, std::min<std::size_t>(br, 80)) +
                         "...: one key=value per --set; the text holds a line break");
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
      out = toml::parse(key + " = " + toml_string(value), label);
    } catch (const toml::parse_error& e) {
      ctx.errors.push_back(label + ": cannot parse: " + std::string(e.description()));
      return false;
    }
  }
  return true;
}

const toml::table* read_override(const std::string& text, toml::table& storage, Context& ctx) {
  if (ctx.cache != nullptr) {
    if (const auto it = ctx.cache->overrides.find(text); it != ctx.cache->overrides.end()) return &it->second;
  }
  if (!parse_override(text, storage, ctx)) return &storage;
  if (ctx.cache != nullptr) return &ctx.cache->overrides.emplace(text, std::move(storage)).first->second;
  return &storage;
}

// ---- CSV-backed tables ------------------------------------------------------------------

namespace {

// Reads the CSV named by ref. A file that cannot be read is reported at the key that names
// it; its follow-on problems (no table) are not.
const io::CsvTable* read_table(const FileRef& ref, const std::string& field, io::CsvTable& storage, Context& ctx) {
  ctx.failed_tables.insert(field);
  std::string bytes, reason;
  const std::string* content = ctx.read(ref.path, bytes, reason);
  if (content == nullptr) {
    ctx.unreadable(ref, reason);
    return nullptr;
  }
  if (ctx.cache != nullptr) {
    if (const auto it = ctx.cache->csv.find(ref.path); it != ctx.cache->csv.end()) return &it->second;
  }
  if (!io::parse_csv_table(ref.path, *content, storage, ctx.errors)) return nullptr;
  if (ctx.cache != nullptr) return &ctx.cache->csv.emplace(ref.path, std::move(storage)).first->second;
  return &storage;
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

// A cycle given as arrays (load_scenario_with_cycle): a table source as a CSV file's, with the
// index as its "line" and the numbers' shortest text as written, so that plant/'s problems
// are reported as a file's are.
plant::Table1d cycle_of_arrays(const CycleArrays& a, const std::string& field, bool periodic, Context& ctx) {
  ctx.failed_tables.insert(field);
  if (a.time_s.size() != a.speed_m_s.size()) {
    ctx.error(a.name, field, std::to_string(a.time_s.size()) + " time stamps, " + std::to_string(a.speed_m_s.size()) + " speeds",
              "the two arrays must have the same length");
    return {};
  }
  std::string bytes(reinterpret_cast<const char*>(a.time_s.data()), a.time_s.size() * sizeof(double));
  bytes.append(reinterpret_cast<const char*>(a.speed_m_s.data()), a.speed_m_s.size() * sizeof(double));
  ctx.read_file(a.name, bytes);
  TableSource s{a.name, {}, {"time_s", "speed_m_s"}, {{}, {}}};
  for (std::size_t i = 0; i < a.time_s.size(); ++i) {
    s.lines.push_back(static_cast<int>(i));
    s.text[0].push_back(io::number_text(a.time_s[i]));
    s.text[1].push_back(io::number_text(a.speed_m_s[i]));
  }
  ctx.tables[field] = std::move(s);
  ctx.failed_tables.erase(field);
  return plant::Table1d(a.time_s, a.speed_m_s, periodic ? plant::Extrapolation::kPeriodic : plant::Extrapolation::kHold);
}

}  // namespace

// Cycle: time_s and speed_kmh or speed_m_s; other columns ignored. After its last row the
// last speed is held, or the cycle repeats (periodic).
plant::Table1d load_cycle(const FileRef& ref, const std::string& field, bool periodic, Context& ctx) {
  if (ctx.cycle_arrays != nullptr) return cycle_of_arrays(*ctx.cycle_arrays, field, periodic, ctx);
  io::CsvTable storage;
  const io::CsvTable* table = read_table(ref, field, storage, ctx);
  if (table == nullptr) return {};
  const io::CsvTable& t = *table;
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
  io::CsvTable storage;
  const io::CsvTable* table = read_table(ref, field, storage, ctx);
  if (table == nullptr) return {};
  const io::CsvTable& t = *table;
  if (t.header.size() < 2) {
    ctx.errors.push_back(t.path + ":" + std::to_string(t.header_line) + ": header: expected two columns (x, y)");
    return {};
  }
  keep_source(field, t, {0, 1}, ctx);
  return plant::Table1d(t.columns[0], t.columns[1], plant::Extrapolation::kHold);
}

// Tidy 2-D map "u1, u2, value" sorted by u1 then u2 (data/README.md) -> grid.
plant::Table2d load_map(const FileRef& ref, const std::string& field, Context& ctx) {
  io::CsvTable storage;
  const io::CsvTable* table = read_table(ref, field, storage, ctx);
  if (table == nullptr) return {};
  const io::CsvTable& t = *table;
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

// Gives plant/ problems the file and line their value came from; a problem in a table cell
// gets the CSV line, column and the value as written (a cycle in km/h stays in km/h).
void report_plant_problems(const Problems& problems, Context& ctx, std::vector<std::string>* sink) {
  for (const plant::Problem& pr : problems.list()) {
    // a table whose file failed to read, or a value the loader rejected, was reported already
    if (sink == nullptr && ctx.reported.count(pr.field) != 0) continue;
    bool reported = false;
    for (const std::string& failed : ctx.failed_tables) reported = reported || pr.field.rfind(failed, 0) == 0;
    if (reported) continue;
    std::string loc, field = ctx.display(pr.field), raw_field = pr.field, value = pr.value;
    if (const auto t = ctx.tables.find(pr.field); t != ctx.tables.end()) {
      const TableSource& src = t->second;
      loc = src.path;
      if (pr.row >= 0 && static_cast<std::size_t>(pr.row) < src.lines.size()) {
        const auto row = static_cast<std::size_t>(pr.row);
        loc += ":" + std::to_string(src.lines[row]);
        if (pr.column >= 0 && static_cast<std::size_t>(pr.column) < src.columns.size()) {
          const auto col = static_cast<std::size_t>(pr.column);
          field += ", column " + src.columns[col];
          raw_field += ", column " + src.columns[col];
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
      ctx.errors.push_back(loc + ": " + field + " = " + value + ": " + pr.expected);
      ctx.reported.insert(raw_field);
    }
  }
}

}  // namespace ehpt::hil::detail
