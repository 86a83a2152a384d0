// SPDX-License-Identifier: BSD-3-Clause
#include "hil/config/config.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <filesystem>
#include <set>

#include "hil/config/config_reader.hpp"
#include "hil/config/scenario.hpp"
#include "hil/config/test_reader.hpp"
#include "hil/config/vehicle_kinds.hpp"
#include "io/number_format.hpp"

namespace fs = std::filesystem;

namespace ehpt::hil {

using namespace detail;

std::string toml_string(const std::string& v) {
  std::string out = "\"";
  for (const char c : v) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (u < 0x20 || u == 0x7f) {
      static const char* hex = "0123456789ABCDEF";
      out += "\\u00";
      out += hex[u >> 4];
      out += hex[u & 15];
    } else {
      out += c;
    }
  }
  return out + "\"";
}

const char* solver_name(SolverKind k) { return k == SolverKind::kRk4 ? "rk4" : "implicit-euler"; }

namespace {

// The longest chain of vehicle files extending each other: deeper is a mistake, not a design.
constexpr std::size_t kMaxExtends = 16;

// The file a vehicle name or a path names: a name ("psecu2") is a shipped vehicle
// (resolve_vehicle); a path (with a slash, or ending in .toml) is relative to the folder of the
// file that gives it (--set: the current folder).
FileRef vehicle_file_of(const toml::node& n, const std::string& fallback_file, const std::string& field,
                        bool name_only, Context& ctx) {
  const std::string where = location(&n, fallback_file);
  const auto v = n.value_exact<std::string>();
  if (!v || v->empty()) {
    ctx.errors.push_back(where + ": " + field + " = " + node_text(n) + ": must be " +
                         (name_only ? "the name of a shipped vehicle (a non-empty string; see docs/scenarios.md)"
                                    : "a vehicle's name or a vehicle file (a non-empty string)"));
    return {};
  }
  const bool is_path = v->find('/') != std::string::npos || (v->ends_with(".toml") && !name_only);
  if (is_path && name_only) {
    ctx.errors.push_back(where + ": " + field + " = \"" + *v + "\": a name of a shipped vehicle, not a path; name a " +
                         "file of your own with vehicle_file = \"" + *v + "\"");
    return {};
  }
  if (is_path) {
    fs::path p(*v);
    if (p.is_relative() && n.source().path && n.source().path->rfind("--set", 0) != 0) {
      p = fs::path(*n.source().path).parent_path() / p;
    }
    return {p.lexically_normal().string(), *v, where, field};
  }
  std::string reason;
  const std::string found = resolve_vehicle(*v, reason);
  if (found.empty()) {
    ctx.errors.push_back(where + ": " + field + " = \"" + *v + "\": " + reason);
    return {};
  }
  return {found, *v, where, field};
}

// vehicle = "NAME" (a shipped vehicle) or vehicle_file = "PATH", from the highest layer that
// gives one; both in one layer is an error. A layer's vehicle table ([vehicle.x] overrides) is
// read later, over the vehicle file.
FileRef choose_vehicle(const std::vector<Layer>& layers, Reader& sc, const std::string& path, Context& ctx) {
  sc.known("vehicle");
  int name_layer = -1, file_layer = -1;
  for (std::size_t i = 0; i < layers.size(); ++i) {
    const toml::node* n = layers[i].table->get("vehicle");
    if (n != nullptr && !n->is_table() && !n->is_string()) {
      ctx.errors.push_back(location(n, path) + ": vehicle = " + node_text(*n) +
                           ": must be a shipped vehicle's name (vehicle = \"psecu2\") or a table of overrides "
                           "([vehicle.battery] ...)");
    }
    if (name_layer < 0 && n != nullptr && n->is_string()) name_layer = static_cast<int>(i);
    if (file_layer < 0 && layers[i].table->get("vehicle_file") != nullptr) file_layer = static_cast<int>(i);
  }
  if (name_layer >= 0 && name_layer == file_layer) {
    const toml::node* n = layers[static_cast<std::size_t>(name_layer)].table->get("vehicle");
    sc.path("vehicle_file", false);
    ctx.errors.push_back(location(n, path) + ": vehicle = \"" + *n->value_exact<std::string>() +
                         "\": give either vehicle (a shipped vehicle's name) or vehicle_file (a path), not both");
    return {};
  }
  if (name_layer >= 0 && (file_layer < 0 || name_layer < file_layer)) {
    if (file_layer >= 0) sc.known("vehicle_file");  // under the name given by a higher layer
    const toml::node* n = layers[static_cast<std::size_t>(name_layer)].table->get("vehicle");
    return vehicle_file_of(*n, path, "vehicle", true, ctx);
  }
  if (file_layer < 0) {
    sc.known("vehicle_file");
    ctx.errors.push_back(path + ": vehicle: missing (name a shipped vehicle with vehicle = \"NAME\", e.g. \"psecu2\", "
                                "or a file with vehicle_file = \"PATH\")");
    return {};
  }
  return sc.path("vehicle_file", true);
}

// Reads the vehicle file named by ref and every file it extends (extends = "NAME" or "PATH"),
// the file first, its base last. A cycle is an error that names the files; a file may not
// change the base's kind.
bool load_vehicle_chain(FileRef ref, std::deque<toml::table>& storage, std::vector<const toml::table*>& docs,
                        Context& ctx) {
  std::vector<std::string> chain;  // canonical paths, for the cycle check
  std::vector<std::string> shown;  // as read, for messages
  docs.clear();
  while (true) {
    std::error_code ec;
    const fs::path canonical = fs::weakly_canonical(ref.path, ec);
    const std::string id = ec ? ref.path : canonical.string();
    if (std::find(chain.begin(), chain.end(), id) != chain.end()) {
      std::string loop;
      for (const std::string& f : shown) loop += f + " -> ";
      ctx.errors.push_back(ref.where + ": " + ref.field + " = \"" + ref.written + "\": the vehicle files extend each other " +
                           "in a cycle: " + loop + ref.path);
      return false;
    }
    if (chain.size() >= kMaxExtends) {
      ctx.errors.push_back(ref.where + ": " + ref.field + " = \"" + ref.written + "\": more than " +
                           std::to_string(kMaxExtends) + " vehicle files extend each other");
      return false;
    }
    const toml::table* doc = read_toml(ref.path, storage.emplace_back(), ctx, &ref);
    if (doc == nullptr) return false;
    chain.push_back(id);
    shown.push_back(ref.path);
    docs.push_back(doc);
    const toml::node* ext = doc->get("extends");
    if (ext == nullptr) break;
    FileRef next = vehicle_file_of(*ext, ref.path, "extends", false, ctx);
    if (next.empty()) return false;
    ref = std::move(next);
  }
  // the kind comes from the base; a file over it may repeat it, not change it
  std::string base_kind, base_file;
  for (std::size_t i = docs.size(); i-- > 0;) {
    const toml::node* k = docs[i]->get("kind");
    if (k == nullptr || !k->is_string()) continue;
    const std::string kind = *k->value_exact<std::string>();
    if (base_kind.empty()) {
      base_kind = kind;
      base_file = shown[i];
    } else if (kind != base_kind) {
      ctx.errors.push_back(location(k, shown[i]) + ": kind = \"" + kind + "\": differs from kind = \"" + base_kind +
                           "\" of " + base_file + ", which it extends (a vehicle file keeps its base's kind)");
      return false;
    }
  }
  return true;
}

// load_scenario's work; cycle: the cycle as arrays in place of the scenario's file (nullptr: the file)
bool load(const std::string& path, const std::vector<std::string>& overrides, const std::vector<std::string>& fault_args,
          const CycleArrays* cycle, Scenario& out, std::vector<std::string>& errors, LoadCache* cache = nullptr,
          std::vector<std::pair<std::string, double>>* numbers = nullptr) {
  Context ctx;
  if (cache != nullptr) ctx.cache = &cache->files();
  ctx.numbers = numbers;
  out = Scenario{};
  out.path = path;
  out.name = fs::path(path).stem().string();
  out.overrides = overrides;

  // layers: each --set, the last given first (the last --set of a key wins), then the file
  std::vector<toml::table> set_storage(overrides.size());
  std::vector<const toml::table*> set_docs(overrides.size());
  for (std::size_t i = 0; i < overrides.size(); ++i) set_docs[i] = read_override(overrides[i], set_storage[i], ctx);
  toml::table scenario_storage, base_storage;
  const toml::table* const scenario_read = read_toml(path, scenario_storage, ctx);
  if (scenario_read == nullptr) {
    errors = ctx.errors;
    out.inputs = std::move(ctx.inputs);
    return false;
  }
  const toml::table& scenario_doc = *scenario_read;
  // a test file names the scenario it runs (scenario = "NAME" or a path): that file is read
  // under it, so the test's keys override the scenario's and its tables add to them
  const toml::table* base_read = nullptr;
  bool has_base = false;
  if (const toml::node* n = scenario_doc.get("scenario")) {
    const auto v = n->value_exact<std::string>();
    std::string reason, base;
    if (v && !v->empty()) {
      const bool is_path = v->find('/') != std::string::npos || v->ends_with(".toml");
      fs::path p(*v);
      if (is_path && p.is_relative()) p = fs::path(path).parent_path() / p;
      base = resolve_scenario(is_path ? p.lexically_normal().string() : *v, reason);
    } else {
      reason = "must be a scenario's name ('ehpt list') or a scenario file (a non-empty string)";
    }
    if (base.empty()) {
      ctx.errors.push_back(location(n, path) + ": scenario = " + node_text(*n) + ": " + reason);
    } else if ((base_read = read_toml(base, base_storage, ctx)) != nullptr) {
      if (const toml::node* again = base_read->get("scenario")) {
        ctx.errors.push_back(location(again, base) + ": scenario: " + path + " runs " + base +
                             ", which names another scenario itself; a test names the scenario it runs, one level only");
      } else {
        has_base = true;
        out.base_path = base;
      }
    }
    if (!has_base) {
      errors = ctx.errors;
      out.inputs = std::move(ctx.inputs);
      return false;
    }
  }
  std::vector<Layer> layers;
  for (auto d = set_docs.rbegin(); d != set_docs.rend(); ++d) layers.push_back({*d, false});
  layers.push_back({&scenario_doc, false});
  if (has_base) layers.push_back({base_read, false});
  Reader sc(layers, "", path, ctx);
  sc.known("scenario");

  out.description = sc.text("description", "");
  const FileRef vehicle_ref = choose_vehicle(layers, sc, path, ctx);
  FileRef cycle_ref = sc.path("cycle", false);
  if (cycle != nullptr) {
    cycle_ref = FileRef{cycle->name, cycle->name, cycle->name, "cycle"};
    ctx.cycle_arrays = cycle;
  }
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
    out.output.timeseries = r.flag("timeseries", true);
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

  read_tests(layers, sc, fault_args, out, ctx);

  // the vehicle: --set vehicle.*, then the scenario's [vehicle] table, then the vehicle file and
  // the files it extends, the base last
  sc.finish();
  std::deque<toml::table> vehicle_storage;
  std::vector<const toml::table*> vehicle_docs;
  if (vehicle_ref.empty() || !load_vehicle_chain(vehicle_ref, vehicle_storage, vehicle_docs, ctx)) {
    ctx.suggest_known_keys();
    errors = ctx.errors;
    out.inputs = std::move(ctx.inputs);
    return false;
  }
  std::vector<Layer> vlayers;
  for (auto d = set_docs.rbegin(); d != set_docs.rend(); ++d) vlayers.push_back({(*d)->get_as<toml::table>("vehicle"), false});
  vlayers.push_back({scenario_doc.get_as<toml::table>("vehicle"), false});
  if (has_base) vlayers.push_back({base_read->get_as<toml::table>("vehicle"), false});
  for (const toml::table* doc : vehicle_docs) vlayers.push_back({doc, true});
  for (std::size_t i = 0; i + vehicle_docs.size() < vlayers.size(); ++i) {
    // only a vehicle file extends another: in a scenario the vehicle is named by vehicle = "..."
    if (const toml::node* n = vlayers[i].table == nullptr ? nullptr : vlayers[i].table->get("extends")) {
      ctx.errors.push_back(location(n, path) + ": vehicle.extends: only a vehicle file can extend another; a scenario "
                                              "names its vehicle with vehicle = \"NAME\" or vehicle_file = \"PATH\"");
    }
  }
  Reader vr(vlayers, "", out.vehicle_path, ctx, "", "vehicle.", true);
  vr.known("extends");
  vr.text("description", "");
  const std::string kind = vr.text("kind", "");
  out.kind = kind;
  Problems problems, warnings;
  KindRead read;
  if (const ReadKind read_kind = find_kind_reader(kind)) {
    read = read_kind(vr, KindInput{cycle_ref, cycle_periodic, path}, out, problems, warnings, ctx);
    if (read.length_s && out.solver.duration_s == 0.0) out.solver.duration_s = *read.length_s;
  } else {
    ctx.error(ctx.where["kind"], "kind", "\"" + kind + "\"", "must be " + kind_names());
  }
  ctx.suggest_known_keys();
  const bool has_ecu = read.has_ecu;
  const bool duration_unknown = read.length_unknown;
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
  if (has_ecu && step_ok && out.solver.steps > 0) {
    // the ECU runs every whole number of plant steps (0: every step), and its commands act a
    // whole number of steps after the sample they were computed from (0: at once)
    const auto whole_steps = [&](double value_s, const char* field, std::int64_t& steps) {
      const double ratio = value_s / h;
      steps = ratio >= 0.0 && ratio < 1e9 ? std::llround(ratio) : -1;
      if (steps < 0 || std::abs(ratio - static_cast<double>(steps)) > 1e-9 * std::max(1.0, ratio)) {
        const auto at = ctx.where.find(field);
        const bool by_default = at == ctx.where.end() || at->second.ends_with("(default)");
        if (by_default && std::string_view(field) == "ecu.period_s") {  // not written anywhere
          ctx.error(ctx.where["solver.step_s"], field, io::number_text(value_s),
                    "the default ECU period (the bus cycle time) is not a whole multiple of solver.step_s = " +
                        io::number_text(h) + "; set vehicle.ecu.period_s to one (0: every step)");
        } else {
          ctx.error(ctx.where[field], field, io::number_text(value_s),
                    "must be a whole multiple of solver.step_s = " + io::number_text(h) + " (and >= 0)");
        }
      }
    };
    EcuTiming& t = out.ecu_timing;
    if (t.period_s == 0.0) t.period_s = h;
    whole_steps(t.period_s, "ecu.period_s", out.solver.ecu_ratio);
    if (out.solver.ecu_ratio == 0) {
      ctx.error(ctx.where["ecu.period_s"], "ecu.period_s", io::number_text(t.period_s), "must be > 0 (0: every step)");
    }
    whole_steps(t.latency_s, "ecu.latency_s", out.solver.ecu_latency_steps);
    if (t.codec == "can") {
      out.ecu_codec = EcuCodec::kCan;
    } else if (t.codec != "none") {
      ctx.error(ctx.where["ecu.codec"], "ecu.codec", "\"" + t.codec + "\"", "must be \"none\" or \"can\"");
    }
    if (read.set_ecu_period != nullptr) read.set_ecu_period(out, t.period_s);
  }
  check_test_times(out, ctx);
  for (std::string& w : ctx.warnings) out.warnings.push_back(std::move(w));
  out.inputs = std::move(ctx.inputs);
  errors = ctx.errors;
  return errors.empty();
}

}  // namespace

bool load_scenario(const std::string& path, const std::vector<std::string>& overrides, Scenario& out,
                   std::vector<std::string>& errors) {
  return load(path, overrides, {}, nullptr, out, errors);
}

bool load_scenario(const std::string& path, const std::vector<std::string>& overrides,
                   const std::vector<std::string>& faults, Scenario& out, std::vector<std::string>& errors) {
  return load(path, overrides, faults, nullptr, out, errors);
}

LoadCache::LoadCache() : files_(std::make_unique<Files>()) {}
LoadCache::~LoadCache() = default;

bool load_scenario(const std::string& path, const std::vector<std::string>& overrides, Scenario& out,
                   std::vector<std::string>& errors, LoadCache& cache) {
  return load(path, overrides, {}, nullptr, out, errors, &cache);
}

bool load_scenario_with_cycle(const std::string& path, const std::vector<std::string>& overrides,
                              const CycleArrays& cycle, Scenario& out, std::vector<std::string>& errors) {
  return load(path, overrides, {}, &cycle, out, errors);
}

bool scenario_numbers(const std::string& path, const std::vector<std::string>& overrides,
                      std::vector<std::pair<std::string, double>>& numbers, std::vector<std::string>& errors) {
  Scenario sc;
  std::vector<std::pair<std::string, double>> read;
  if (!load(path, overrides, {}, nullptr, sc, errors, nullptr, &read)) return false;
  // each key once, as the load used it (the first read; a key read again reads the same value)
  numbers.clear();
  std::set<std::string> seen;
  for (auto& [key, value] : read) {
    if (seen.insert(key).second) numbers.emplace_back(std::move(key), value);
  }
  return true;
}

}  // namespace ehpt::hil
