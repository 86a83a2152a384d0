// SPDX-License-Identifier: BSD-3-Clause
#include "hil/campaign/campaign.hpp"

#include <algorithm>
#include <filesystem>
#include <set>

#include "hil/config/config_reader.hpp"
#include "hil/diag/provenance.hpp"
#include "hil/config/scenario.hpp"
#include "io/csv_table.hpp"
#include "io/number_format.hpp"

namespace fs = std::filesystem;

namespace ehpt::hil {

using detail::Context;
using detail::location;
using detail::node_text;

namespace {

// A value of the grid or [set] as --set text, so that it reads back as the same TOML value
// (floats as the shortest text that reads back exactly). "" if it is not a scalar.
std::string value_text(const toml::node& n) {
  if (const auto d = n.value_exact<double>()) {
    // a float that prints like an integer (60.0 -> "60") still reads as the same number
    return io::number_text(*d);
  }
  if (const auto i = n.value_exact<std::int64_t>()) return std::to_string(*i);
  if (const auto b = n.value_exact<bool>()) return *b ? "true" : "false";
  if (const auto s = n.value_exact<std::string>()) return toml_string(*s);
  return "";
}

// ["a","b"] for an array of strings, "" for anything else
std::string signal_list_text(const toml::node& n) {
  const toml::array* a = n.as_array();
  if (a == nullptr) return "";
  std::string text = "[";
  for (std::size_t i = 0; i < a->size(); ++i) {
    const auto s = (*a)[i].value_exact<std::string>();
    if (!s) return "";
    text += (i ? "," : "") + toml_string(*s);
  }
  return text + "]";
}

// A variants cell as --set would read it (a TOML value, else text), written canonically as
// the grid's values are: "0.60" and "0.6 # note" are the run 0.6, 'rk4' is "rk4".
std::string cell_value(const std::string& cell) {
  try {
    const toml::table t = toml::parse("v = " + cell);
    if (const toml::node* n = t.get("v")) {
      if (const std::string v = value_text(*n); !v.empty()) return v;
    }
  } catch (const toml::parse_error&) {
  }
  return toml_string(cell);
}

// "number", "true or false", "a string": the kind of a scalar, for "mixed kinds" messages
const char* kind_of(const toml::node& n) {
  if (n.is_number()) return "a number";
  if (n.is_boolean()) return "true or false";
  if (n.is_string()) return "a string";
  return "";
}

// A dotted key as --set takes it: parts of letters, digits, '_' and '-'.
bool valid_key(const std::string& k) {
  if (k.empty() || k.front() == '.' || k.back() == '.' || k.find("..") != std::string::npos) return false;
  for (const char c : k) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
                    c == '-' || c == '.';
    if (!ok) return false;
  }
  return true;
}

// A scenario entry: a path (with a '/' or ending in .toml) relative to the campaign's folder,
// else a name looked up as 'ehpt run NAME' does.
std::string resolve_entry(const std::string& entry, const fs::path& campaign_dir, std::string& reason) {
  const bool is_path = entry.find('/') != std::string::npos || entry.ends_with(".toml");
  const std::string candidate = is_path && fs::path(entry).is_relative() ? (campaign_dir / entry).string() : entry;
  std::string found = resolve_scenario(candidate, reason);
  if (found.empty()) return found;
  std::error_code ec;
  const fs::path abs = fs::absolute(found, ec);
  return ec ? found : abs.lexically_normal().string();
}

// A table's entries in the order of the file (toml++ iterates them sorted by key): the grid's
// first key is the outermost loop, and problems are listed line by line.
std::vector<std::pair<std::string, const toml::node*>> in_file_order(const toml::table& t) {
  std::vector<std::pair<std::string, const toml::node*>> out;
  for (const auto& [k, n] : t) out.emplace_back(std::string(k.str()), &n);
  std::stable_sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    const toml::source_position pa = a.second->source().begin, pb = b.second->source().begin;
    return pa.line != pb.line ? pa.line < pb.line : pa.column < pb.column;
  });
  return out;
}

}  // namespace

std::vector<std::string> Campaign::swept_keys() const {
  std::vector<std::string> keys;
  for (const CampaignGridKey& g : grid) keys.push_back(g.key);
  for (const std::string& k : variant_keys) keys.push_back(k);
  return keys;
}

bool load_campaign(const std::string& path, Campaign& out, std::vector<std::string>& errors) {
  out = Campaign{};
  Context ctx;
  toml::table doc;
  if (!detail::parse_toml(path, doc, ctx)) {
    errors = ctx.errors;
    return false;
  }
  std::error_code ec;
  const fs::path abs = fs::absolute(path, ec);
  out.path = ec ? path : abs.lexically_normal().string();
  out.name = fs::path(path).stem().string();
  const fs::path dir = fs::path(out.path).parent_path();
  const auto err = [&](const toml::node* n, const std::string& what) {
    ctx.errors.push_back(location(n, path) + ": " + what);
  };

  bool output_timeseries = false;  // [output] timeseries given
  std::set<std::string> keys_seen;  // a key may be given once: in [set], [grid] or the variants
  const auto claim = [&](const toml::node* n, const std::string& key, const char* where) {
    if (!valid_key(key)) {
      err(n, where + std::string(" key \"") + key + "\": not a dotted key as --set takes it (e.g. vehicle.ecu.soc_ref)");
      return false;
    }
    if (!keys_seen.insert(key).second) {
      err(n, where + std::string(" key \"") + key + "\": given more than once ([set], [grid], [output] or the variants)");
      return false;
    }
    return true;
  };

  for (const auto& [key, node_ptr] : in_file_order(doc)) {
    const toml::node& node = *node_ptr;
    if (key == "description") {
      if (const auto s = node.value_exact<std::string>()) {
        out.description = *s;
      } else {
        err(&node, "description = " + node_text(node) + ": must be a string");
      }
    } else if (key == "scenarios") {
      const toml::array* a = node.as_array();
      if (a == nullptr || a->empty()) {
        err(&node, "scenarios = " + node_text(node) + ": must be a non-empty array of scenario names or paths");
        continue;
      }
      std::set<std::string> seen;
      for (const toml::node& e : *a) {
        const auto s = e.value_exact<std::string>();
        if (!s || s->empty()) {
          err(&e, "scenarios: " + node_text(e) + ": must be a scenario name or path (a non-empty string)");
          continue;
        }
        std::string reason;
        const std::string found = resolve_entry(*s, dir, reason);
        if (found.empty()) {
          err(&e, "scenarios: \"" + *s + "\": " + reason + " (names as in 'ehpt list', paths relative to " +
                      dir.string() + ")");
        } else if (!seen.insert(found).second) {
          err(&e, "scenarios: \"" + *s + "\": listed twice (" + found + ")");
        } else {
          out.scenarios.push_back(CampaignScenario{found, fs::path(found).stem().string(), location(&e, path)});
        }
      }
    } else if (key == "variants") {
      const auto s = node.value_exact<std::string>();
      if (!s || s->empty()) {
        err(&node, "variants = " + node_text(node) + ": must be the name of a CSV file (a non-empty string)");
        continue;
      }
      const fs::path p = fs::path(*s).is_relative() ? dir / *s : fs::path(*s);
      out.variants_path = p.lexically_normal().string();
      io::CsvTable t;
      if (!io::read_csv_table(out.variants_path, t, ctx.errors, /*numbers=*/false)) continue;
      for (const std::string& h : t.header) {
        const std::string at = out.variants_path + ":" + std::to_string(t.header_line);
        if (!valid_key(h)) {
          ctx.errors.push_back(at + ": column \"" + h + "\": not a dotted key as --set takes it");
        } else if (!keys_seen.insert(h).second) {
          ctx.errors.push_back(at + ": column \"" + h + "\": given more than once ([set], [grid], [output] or the variants)");
        }
        out.variant_keys.push_back(h);
      }
      std::set<std::vector<std::string>> rows_seen;
      for (std::size_t r = 0; r < t.rows(); ++r) {
        std::vector<CampaignOverride> row;
        std::vector<std::string> cells;
        for (std::size_t c = 0; c < t.header.size(); ++c) {
          const std::string& cell = t.text[c][r];
          cells.push_back(cell);
          if (cell.empty()) continue;  // the scenario's value
          if (cell.find_first_of("\r\n") != std::string::npos) {
            ctx.errors.push_back(out.variants_path + ":" + std::to_string(t.lines[r]) + ": column " + t.header[c] +
                                 ": a line break in a value");
          }
          row.push_back(CampaignOverride{t.header[c], cell_value(cell), out.variants_path + ":" + std::to_string(t.lines[r])});
        }
        if (!rows_seen.insert(cells).second) {
          ctx.errors.push_back(out.variants_path + ":" + std::to_string(t.lines[r]) +
                               ": the same variant as an earlier row (it would be the same run)");
        }
        out.variants.push_back(std::move(row));
      }
    } else if (key == "set" || key == "grid" || key == "output") {
      const toml::table* t = node.as_table();
      if (t == nullptr) {
        err(&node, key + " = " + node_text(node) + ": must be a table ([" + key + "])");
        continue;
      }
      if (key == "output") {
        for (const auto& [okey, on_ptr] : in_file_order(*t)) {
          const toml::node& on = *on_ptr;
          if (okey == "timeseries") {
            if (const auto b = on.value_exact<bool>()) {
              output_timeseries = true;
              if (claim(&on, "output.timeseries", "[output]")) out.timeseries = *b;
            } else {
              err(&on, "output.timeseries = " + node_text(on) + ": must be true or false");
            }
          } else if (okey == "interval_s" || okey == "decimation" || okey == "signals") {
            // passed on to every run, which checks them as it checks its own [output]
            std::string text = okey == "signals" ? signal_list_text(on) : on.is_number() ? value_text(on) : "";
            if (text.empty()) {
              err(&on, "output." + okey + " = " + node_text(on) + ": must be " +
                           (okey == "signals" ? "an array of signal names" : "a number"));
            } else if (claim(&on, "output." + okey, "[output]")) {
              out.fixed.push_back(CampaignOverride{"output." + okey, text, location(&on, path)});
            }
          } else {
            err(&on, "output." + okey + ": unknown key (timeseries, interval_s, decimation, signals)");
          }
        }
        continue;
      }
      for (const auto& [gkey, gn_ptr] : in_file_order(*t)) {
        const toml::node& gn = *gn_ptr;
        if (key == "set") {
          const std::string v = value_text(gn);
          if (v.empty()) {
            err(&gn, "set." + gkey + " = " + node_text(gn) + ": must be a number, true/false or a string");
          } else if (claim(&gn, gkey, "[set]")) {
            out.fixed.push_back(CampaignOverride{gkey, v, location(&gn, path)});
          }
          continue;
        }
        const toml::array* a = gn.as_array();
        if (a == nullptr) {
          err(&gn, "grid.\"" + gkey + "\" = " + node_text(gn) + ": must be an array of values ([0.55, 0.6])");
          continue;
        }
        if (a->empty()) {
          err(&gn, "grid.\"" + gkey + "\" = []: an empty grid (no value, so no run); give at least one value");
          continue;
        }
        if (!claim(&gn, gkey, "[grid]")) continue;
        CampaignGridKey g{gkey, {}};
        std::set<std::string> seen;
        std::string first_kind;  // of the first scalar: every value of a key has one type
        for (const toml::node& e : *a) {
          const std::string v = value_text(e);
          if (first_kind.empty() && !v.empty()) first_kind = kind_of(e);
          if (v.empty()) {
            err(&e, "grid.\"" + gkey + "\": " + node_text(e) + ": must be a number, true/false or a string");
          } else if (kind_of(e) != first_kind) {
            err(&e, "grid.\"" + gkey + "\": " + node_text(e) + ": is " + kind_of(e) + ", the first value is " +
                        first_kind + " (one key, one type)");
          } else if (!seen.insert(v).second) {
            err(&e, "grid.\"" + gkey + "\": " + node_text(e) + ": listed twice");
          } else {
            g.values.push_back(CampaignOverride{gkey, v, location(&e, path)});
          }
        }
        out.grid.push_back(std::move(g));
      }
    } else {
      err(&node, key + ": unknown key (description, scenarios, variants, [set], [grid], [output])");
    }
  }
  // two scenario files of one name (a/x.toml, b/x.toml): named by their paths relative to the
  // campaign's folder, so that results.csv and the figures tell them apart
  for (CampaignScenario& sc : out.scenarios) {
    const auto same = std::count_if(out.scenarios.begin(), out.scenarios.end(),
                                    [&](const CampaignScenario& o) { return fs::path(o.path).stem() == fs::path(sc.path).stem(); });
    if (same > 1) sc.name = fs::path(sc.path).lexically_relative(dir).replace_extension().string();
  }
  if (out.scenarios.empty() && !doc.contains("scenarios")) {
    ctx.errors.push_back(path + ": scenarios: missing (the scenarios to run, e.g. scenarios = [\"psecu2_nedc\"])");
  }
  if (!out.variants_path.empty() && out.variants.empty() && ctx.errors.empty()) {
    ctx.errors.push_back(out.variants_path + ": no variants (a header and no rows)");
  }
  // summary.json only, unless the campaign asks for the timeseries
  if (keys_seen.count("output.timeseries") != 0 && !output_timeseries) {
    // given in [set], [grid] or the variants: as given (true where a run keeps it)
    out.timeseries = true;
  } else if (!out.timeseries) {
    out.fixed.push_back(CampaignOverride{"output.timeseries", "false", path + " (default)"});
  }
  if (ctx.errors.empty()) {
    // the count, computed without overflow before anything is expanded
    std::uint64_t n = out.scenarios.size();
    const auto times = [&](std::uint64_t k) { n = k != 0 && n > kMaxCampaignRuns / k ? kMaxCampaignRuns + 1 : n * k; };
    for (const CampaignGridKey& g : out.grid) times(g.values.size());
    times(std::max<std::size_t>(1, out.variants.size()));
    if (n > kMaxCampaignRuns) {
      ctx.errors.push_back(path + ": more than " + std::to_string(kMaxCampaignRuns) +
                           " runs (scenarios x grid x variants); split the campaign");
    }
  }
  errors = ctx.errors;
  return errors.empty();
}

std::uint64_t campaign_run_count(const Campaign& c) {
  std::uint64_t n = c.scenarios.size();
  for (const CampaignGridKey& g : c.grid) n *= g.values.size();
  return n * std::max<std::size_t>(1, c.variants.size());
}

CampaignRun campaign_run(const Campaign& c, std::uint64_t index) {
  CampaignRun run;
  run.index = index;
  const std::uint64_t variants = std::max<std::size_t>(1, c.variants.size());
  std::uint64_t rest = index;
  const std::uint64_t variant = rest % variants;
  rest /= variants;
  // the grid's last key varies fastest
  std::vector<std::size_t> pick(c.grid.size());
  for (std::size_t k = c.grid.size(); k-- > 0;) {
    pick[k] = static_cast<std::size_t>(rest % c.grid[k].values.size());
    rest /= c.grid[k].values.size();
  }
  run.scenario = static_cast<std::size_t>(rest);
  run.overrides = c.fixed;
  for (std::size_t k = 0; k < c.grid.size(); ++k) run.overrides.push_back(c.grid[k].values[pick[k]]);
  if (!c.variants.empty()) {
    const auto& row = c.variants[static_cast<std::size_t>(variant)];
    run.overrides.insert(run.overrides.end(), row.begin(), row.end());
  }
  return run;
}

std::string run_id(const std::vector<InputFile>& inputs, const std::vector<CampaignOverride>& overrides) {
  // the overrides as `ehpt run --set` gets them: its summary's provenance.run_id is this id
  std::vector<std::string> set_texts;
  for (const CampaignOverride& o : overrides) set_texts.push_back(o.set_text());
  return hil::run_id(inputs, set_texts);
}

}  // namespace ehpt::hil
