// SPDX-License-Identifier: BSD-3-Clause
// `ehpt fmu`: the scenario as an FMI 3.0 co-simulation FMU (docs/fmu.md). The FMU carries its
// library (targets/fmu/, built beside ehpt), the scenario and every file it reads under
// resources/ (their layout kept, so the scenario's relative paths hold), and a page of its
// variables; it needs no ehpt on the machine that runs it.

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <set>

#include "hil/bus/bus_binding.hpp"  // builtin_ehpt_dbc: the LS-BUS FMU's contract
#include "hil/bus/bus_ecu.hpp"      // has_bus_ecu: --role ecu
#include "hil/bus/bus_plant.hpp"    // can_run_on_bus: --ecu none has the bus's rule
#include "hil/bus/in_process_bus.hpp"  // has_bus_faults
#include "io/can/ls_bus.hpp"
#include "hil/config/config.hpp"
#include "hil/diag/provenance.hpp"
#include "io/junit.hpp"
#include "io/number_format.hpp"
#include "io/output_dir.hpp"
#include "io/process.hpp"
#include "io/sha256.hpp"
#include "io/text_file.hpp"
#include "io/zip.hpp"
#include "targets/cli.hpp"
#include "targets/fmu/fmu_description.hpp"
#include "targets/fmu/fmu_instance.hpp"

namespace fs = std::filesystem;

namespace ehpt::cli {

namespace {

const char* kFmuHelp =
    "usage: ehpt fmu SCENARIO [--fmi 3|2] [--ecu builtin|none] [--out FILE.fmu]\n"
    "                [--set key=value ...] [--fault SPEC ...] [--variables]\n"
    "       ehpt fmu SCENARIO --bus ls-bus [--role plant|ecu] [--out FILE.fmu] ...\n"
    "\n"
    "Builds an FMI 3.0 (or 2.0) co-simulation FMU of the scenario for x86_64-linux: its\n"
    "vehicle on the scenario's cycle, every output of 'ehpt signals SCENARIO' an FMU output\n"
    "(Float64, SI units), doStep in whole plant steps. The FMU holds the scenario,\n"
    "vehicle, maps and cycle under resources/ and runs where ehpt is not installed.\n"
    "docs/fmu.md: the variables, the calling sequence, and how to import it (FMPy, OMSimulator,\n"
    "Simulink, VEOS, SIL Kit).\n"
    "  --ecu builtin    the built-in ECU drives the plant: the same trajectory as 'ehpt run'\n"
    "                   (the default)\n"
    "  --ecu none       the importer is the ECU: the command message's fields are inputs\n"
    "                   (command.motTauRef_Nm, ...), the sensor message's outputs\n"
    "                   (sensors.batSOC, ...), sampled at each communication point\n"
    "  --bus ls-bus     the ECU is on a CAN bus: one FMI-LS-BUS CAN terminal (CAN.Tx_Data,\n"
    "                   CAN.Tx_Clock, CAN.Rx_Data, CAN.Rx_Clock) carries the frames of ehpt's\n"
    "                   contract (the DBC is in the FMU, extra/org.fmi-standard.fmi-ls-bus/);\n"
    "                   Event Mode, triggered clocks; each ECU sample must be a communication\n"
    "                   point. FMI 3.0 only. docs/fmu.md: the calling sequence\n"
    "  --role plant|ecu with --bus: the plant (the default; it applies its ECU's latest\n"
    "                   command, safe state after 3 ECU periods without one) or the scenario's\n"
    "                   built-in ECU alone on the terminal (as 'ehpt ecu' is on a bus):\n"
    "                   connect the two Tx_Data -> Rx_Data and the run is the lockstep bus\n"
    "                   session's, 'ehpt run --set vehicle.ecu.codec=can'\n"
    "  --fmi 3|2        the FMI version: 3.0 (the default) or 2.0 (Simulink, OMSimulator, FMPy\n"
    "                   and older importers); the same variables and trajectory\n"
    "  --out FILE.fmu   where to write it (default out/<scenario name>.fmu); never over an\n"
    "                   existing file\n"
    "  --set key=value  as for 'ehpt run': the FMU's scenario is the one with these overrides\n"
    "  --fault SPEC     as for 'ehpt run', repeatable: a fault acting in the FMU. Faults on\n"
    "                   CAN frames (drop, delay, error_frames, bus_off, ...) need the bus:\n"
    "                   --bus ls-bus\n"
    "  --variables      print the FMU's variables (a Markdown table: value reference, name,\n"
    "                   causality, unit, start, description) and write nothing\n";

// Whether the scenario's bus faults fit the LS-BUS plant (ehpt's contract, a terminal that
// carries Bus Error and Status): the plant the FMU will make, made once here and dropped.
bool bus_faults_fit(const hil::Scenario& sc, std::string& why) {
  if (!hil::has_bus_faults(sc)) return true;
  std::vector<std::string> errors;
  std::optional<hil::Binding> binding = hil::default_binding(hil::bus_family(sc), sc.ecu_timing.period_s, errors);
  if (!binding) {
    why = errors.empty() ? "no binding" : errors.front();
    return false;
  }
  io::can::ls_bus::LsBusTerminal terminal;
  hil::BusPlantOptions opt;
  opt.event_mode = true;
  return hil::make_bus_plant(sc, terminal, opt, std::move(*binding), why) != nullptr;
}

// A C identifier from the scenario's name: modelIdentifier, the library's file name.
std::string identifier_of(const std::string& name) {
  std::string id = "ehpt_";
  for (const char c : name) id += (std::isalnum(static_cast<unsigned char>(c)) != 0) ? c : '_';
  return id;
}

bool read_file(const std::string& path, std::string& out, std::string& error) {
  std::string reason;
  if (!io::read_text_file(path, out, reason, 512u << 20)) {
    error = path + ": " + reason;
    return false;
  }
  return true;
}

// The deepest folder that holds every path.
fs::path common_root(const std::vector<fs::path>& paths) {
  fs::path root = paths.front().parent_path();
  for (const fs::path& p : paths) {
    while (!root.empty() && std::mismatch(root.begin(), root.end(), p.begin(), p.end()).first != root.end()) {
      root = root.parent_path();
    }
  }
  return root;
}

std::string documentation_page(const fmu::Description& d, const std::string& id, const std::string& fmi) {
  using io::xml_escape;
  std::string h = "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>" + xml_escape(id) +
                  "</title></head><body>\n<h1>" + xml_escape(d.model_name) + "</h1>\n<p>" + xml_escape(d.description) +
                  "</p>\n<p>An FMI " + fmi + ".0 co-simulation FMU made by ehpt (BSD-3-Clause): the vehicle on the scenario's "
                  "cycle, " + (d.role == fmu::Role::kEcu      ? "this FMU being its built-in ECU alone on an FMI-LS-BUS CAN terminal"
                                : d.ecu == fmu::EcuMode::kBus  ? "its ECU on an FMI-LS-BUS CAN terminal (Event Mode)"
                                : d.ecu == fmu::EcuMode::kNone ? "its ECU the importer (command.* inputs, sensors.* outputs)"
                                                               : "driven by its built-in ECU") +
                  ". Communication steps are whole multiples of " +
                  xml_escape(io::number_text(d.step_s)) + " s; startTime 0. Licences: licenses/.</p>\n";
  h += "<table>\n<tr><th>valueReference</th><th>name</th><th>causality</th><th>unit</th><th>description</th></tr>\n";
  for (const fmu::Variable& v : d.variables) {
    h += "<tr><td>" + std::to_string(v.vr) + "</td><td>" + xml_escape(v.name) + "</td><td>" +
         (v.causality == fmu::Causality::kIndependent ? "independent"
          : v.causality == fmu::Causality::kInput    ? "input"
          : v.causality == fmu::Causality::kParameter ? "parameter"
          : v.causality == fmu::Causality::kStructuralParameter ? "structuralParameter"
                                                      : "output") +
         "</td><td>" + xml_escape(v.unit) +
         "</td><td>" + xml_escape(v.description) + "</td></tr>\n";
  }
  return h + "</table>\n</body></html>\n";
}

// The variables as a Markdown table (docs/fmu-variables.md is made of these).
std::string variables_table(const fmu::Description& d, const std::string& fmi) {
  std::string t = "| vr | name | causality | unit | start | description |\n|---|---|---|---|---|---|\n";
  for (const fmu::Variable& v : d.variables) {
    if (fmi == "2" && v.causality == fmu::Causality::kIndependent) continue;  // FMI 2.0 has no time variable
    const char* causality = v.causality == fmu::Causality::kIndependent ? "independent"
                            : v.causality == fmu::Causality::kInput     ? "input"
                            : v.causality == fmu::Causality::kParameter ? "parameter"
                            : v.causality == fmu::Causality::kStructuralParameter ? "structuralParameter"
                                                                        : "output";
    std::string start;
    const bool scalar = v.type == fmu::Type::kFloat64 || v.type == fmu::Type::kBoolean;  // Binary, Clock: no start here
    if (scalar && (v.causality == fmu::Causality::kInput || v.causality == fmu::Causality::kParameter ||
                   v.causality == fmu::Causality::kStructuralParameter)) {
      start = v.type == fmu::Type::kBoolean ? (v.start != 0.0 ? "true" : "false") : io::number_text(v.start);
    }
    std::string description = v.description;
    for (char& c : description) c = c == '|' ? '/' : c;
    t += "| " + std::to_string(v.vr) + " | `" + v.name + "` | " + causality +
         (v.type == fmu::Type::kBoolean  ? " (Boolean)"
          : v.type == fmu::Type::kBinary ? " (Binary)"
          : v.type == fmu::Type::kClock  ? " (Clock)"
                                         : "") +
         " | " + v.unit + " | " + start + " | " + description + " |\n";
  }
  return t;
}

}  // namespace

int cmd_fmu(const std::vector<std::string>& args) {
  if (wants_help(args)) return out(kFmuHelp) ? 0 : 1;
  std::string scenario, out_path, fmi = "3", ecu = "builtin", bus, role = "plant";
  bool ecu_given = false;
  bool list_variables = false;
  std::vector<std::string> sets, faults;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if ((a == "--out" || a == "--set" || a == "--fault" || a == "--fmi" || a == "--ecu" || a == "--bus" || a == "--role") &&
        i + 1 >= args.size()) {
      std::cerr << a << " needs a value\n" << kFmuHelp;
      return 1;
    }
    if (a == "--out") {
      out_path = args[++i];
    } else if (a == "--set") {
      sets.push_back(args[++i]);
    } else if (a == "--fault") {
      faults.push_back(args[++i]);
    } else if (a == "--fmi") {
      fmi = args[++i];
    } else if (a == "--ecu") {
      ecu = args[++i];
      ecu_given = true;
    } else if (a == "--bus") {
      bus = args[++i];
    } else if (a == "--role") {
      role = args[++i];
    } else if (a == "--variables") {
      list_variables = true;
    } else if (!a.empty() && a[0] == '-') {
      std::cerr << "unknown option " << a << "\n" << kFmuHelp;
      return 1;
    } else if (scenario.empty()) {
      scenario = a;
    } else {
      std::cerr << "one scenario per FMU (got " << scenario << " and " << a << ")\n";
      return 1;
    }
  }
  if (scenario.empty()) {
    std::cerr << kFmuHelp;
    return 1;
  }
  if (fmi != "3" && fmi != "2") {
    std::cerr << "--fmi " << fmi << ": 3 (FMI 3.0) or 2 (FMI 2.0)\n";
    return 2;
  }
  const std::string library_name = "libehpt_fmu" + fmi + ".so";
  if (ecu != "builtin" && ecu != "none") {
    std::cerr << "--ecu " << ecu << ": builtin (the scenario's ECU drives the plant) or none (the importer is the ECU)\n";
    return 2;
  }
  if (!bus.empty() && bus != "ls-bus") {
    std::cerr << "--bus " << bus << ": ls-bus (an FMI-LS-BUS CAN terminal) is the one bus an FMU has\n";
    return 2;
  }
  if (role != "plant" && role != "ecu") {
    std::cerr << "--role " << role << ": plant or ecu\n";
    return 2;
  }
  if (role == "ecu" && bus.empty()) {
    std::cerr << "--role ecu: the ECU alone is an FMU on a bus: give --bus ls-bus too\n";
    return 2;
  }
  if (!bus.empty() && (fmi != "3" || ecu_given)) {
    std::cerr << "--bus ls-bus: " << (fmi != "3" ? "FMI-LS-BUS is FMI 3.0's (clocks, Event Mode): leave --fmi at 3"
                                                 : "the ECU is on the bus: --ecu does not apply (--role ecu makes the ECU's FMU)")
              << "\n";
    return 2;
  }
  const fmu::EcuMode mode = !bus.empty() ? fmu::EcuMode::kBus : ecu == "none" ? fmu::EcuMode::kNone : fmu::EcuMode::kBuiltin;
  const fmu::Role fmu_role = role == "ecu" ? fmu::Role::kEcu : fmu::Role::kPlant;
  hil::Scenario sc;
  if (role == "ecu" && !faults.empty()) {
    std::cerr << "--fault with --role ecu: faults act in the plant; give them to the plant's FMU\n";
    return 2;
  }
  if (const int rc = load(scenario, sets, sc, faults); rc != 0) return rc;
  if (mode != fmu::EcuMode::kBus && hil::has_bus_faults(sc)) {
    std::cerr << "error: " << sc.name << " has faults on CAN frames (drop, delay, error_frames, ...): they need a bus, "
              << "which this FMU has not (its ECU is " << (mode == fmu::EcuMode::kNone ? "the importer" : "built in")
              << "): make it with --bus ls-bus (the ECU on its CAN terminal), or run it with 'ehpt run'\n";
    return 2;
  }
  if (std::string why; mode == fmu::EcuMode::kBus && fmu_role == fmu::Role::kPlant && !bus_faults_fit(sc, why)) {
    std::cerr << "error: --bus ls-bus: " << why << "\n";
    return 2;
  }
  if (std::string why; mode == fmu::EcuMode::kBus && !hil::can_run_on_bus(sc, why)) {
    std::cerr << "error: --bus ls-bus: " << why << "\n";
    return 2;
  }
  if (std::string why; fmu_role == fmu::Role::kEcu && !hil::has_bus_ecu(sc, why)) {
    std::cerr << "error: --role ecu: " << why << "\n";
    return 2;
  }
  if (std::string why; mode == fmu::EcuMode::kNone && !hil::can_run_on_bus(sc, why)) {
    // the same rule as a bus: a rig has no messages; an ECU latency belongs to the built-in ECU
    std::cerr << "error: --ecu none: " << why << "\n";
    return 2;
  }
  for (const auto& [option, values] : {std::pair{"--set", &sets}, std::pair{"--fault", &faults}}) {
    for (const std::string& s : *values) {
      if (s.find('\n') != std::string::npos || s.find('\r') != std::string::npos) {
        std::cerr << option << ": a line break in '" << s << "' cannot go into the FMU's manifest\n";
        return 2;
      }
    }
  }
  if (list_variables) {
    std::vector<std::pair<std::string, double>> numbers;
    std::vector<std::string> load_errors;
    if (!hil::scenario_numbers(sc.path, sets, numbers, load_errors)) {
      for (const std::string& e : load_errors) std::cerr << e << "\n";
      return 2;
    }
    return out(variables_table(fmu::describe(sc, mode, numbers, fmu_role), fmi)) ? 0 : 1;
  }
  if (out_path.empty()) out_path = "out/" + sc.name + ".fmu";
  std::error_code ec;
  if (fs::exists(fs::symlink_status(out_path, ec))) {
    std::cerr << "error: --out " << out_path << ": " << io::describe_path(out_path)
              << " is there already; ehpt fmu never writes over a path (remove it, or give another --out)\n";
    return 2;
  }
  const std::string id = identifier_of(sc.name) + (fmu_role == fmu::Role::kEcu      ? "_ecu"
                                                   : mode != fmu::EcuMode::kBuiltin ? "_plant"
                                                                                    : "");
  std::string error;

  // resources/: every file the scenario read, under the folder that holds them all
  std::vector<fs::path> input_files;
  for (const hil::InputFile& f : sc.inputs) input_files.push_back(fs::weakly_canonical(fs::absolute(f.path, ec), ec));
  const fs::path root = common_root(input_files);
  std::vector<io::ZipEntry> entries;
  std::set<std::string> seen;
  for (const fs::path& p : input_files) {
    const std::string rel = p.lexically_relative(root).generic_string();
    if (!seen.insert(rel).second) continue;
    io::ZipEntry e{"resources/" + rel, ""};
    if (!read_file(p.string(), e.data, error)) {
      std::cerr << "error: " << error << "\n";
      return 2;
    }
    entries.push_back(std::move(e));
  }
  const fs::path scenario_file = fs::weakly_canonical(fs::absolute(sc.path, ec), ec);
  const std::string scenario_rel = scenario_file.lexically_relative(root).generic_string();

  // binaries/: the library (it needs the C and C++ runtimes only: toml++ is compiled in)
  const fs::path self_dir = fs::path(io::self_executable()).parent_path();
  // the build tree (beside ehpt), or the installation (<prefix>/bin/ehpt, <prefix>/<libdir>/ehpt/fmu/)
  const std::vector<fs::path> candidates{self_dir / library_name,
                                         self_dir / ".." / EHPT_INSTALL_LIBDIR / "ehpt" / "fmu" / library_name};
  const auto library = std::find_if(candidates.begin(), candidates.end(), [&](const fs::path& p) { return fs::exists(p, ec); });
  if (library == candidates.end()) {
    std::cerr << "error: the FMU library " << library_name << " is not beside this ehpt (" << candidates[0].string()
              << ", " << candidates[1].string() << "): build the target ehpt_fmu" << fmi << ", or install ehpt\n";
    return 1;
  }
  io::ZipEntry so{"binaries/x86_64-linux/" + id + ".so", ""};
  if (!read_file(library->string(), so.data, error)) {
    std::cerr << "error: " << error << "\n";
    return 1;
  }
  entries.push_back(std::move(so));
  std::string notice;
  if (read_file("/usr/share/doc/libtomlplusplus3/copyright", notice, error)) {
    entries.push_back({"documentation/licenses/tomlplusplus.txt", notice});
  } else {
    entries.push_back({"documentation/licenses/tomlplusplus.txt",
                       "toml++ (compiled into the FMU's library), Copyright (c) Mark Gillard, MIT licence: "
                       "https://github.com/marzer/tomlplusplus/blob/master/LICENSE\n"});
  }
  entries.push_back({"documentation/licenses/ehpt.txt",
                     "ehpt, BSD-3-Clause: the LICENSE file of its source and of /usr/share/doc/ehpt/copyright.\n"
                     "The data under resources/ keep their own notices (data/README.md of ehpt).\n"});

  // the token: a digest of everything in the FMU but its description, which carries it
  std::string digest_input;
  for (const io::ZipEntry& e : entries) digest_input += e.name + '\0' + io::sha256_hex(e.data) + '\n';
  for (const std::string& s : sets) digest_input += "set " + s + '\n';
  for (const std::string& f : faults) digest_input += "fault " + f + '\n';
  digest_input += "ecu " + ecu + "\nfmi " + fmi + "\nbus " + bus + "\nrole " + role + '\n';
  const std::string token = "{" + io::sha256_hex(digest_input).substr(0, 32) + "}";
  std::string manifest = "# ehpt fmu 1\ntoken " + token + "\nscenario " + scenario_rel + "\n";
  for (const std::string& s : sets) manifest += "set " + s + "\n";
  for (const std::string& f : faults) manifest += "fault " + f + "\n";
  if (mode == fmu::EcuMode::kNone) manifest += "ecu none\n";
  if (mode == fmu::EcuMode::kBus) manifest += "bus ls-bus\n";
  if (fmu_role == fmu::Role::kEcu) manifest += "role ecu\n";
  entries.push_back({std::string("resources/") + fmu::kManifestName, manifest});

  std::vector<std::pair<std::string, double>> numbers;  // the vehicle's: the FMU's parameters
  std::vector<std::string> load_errors;
  if (!hil::scenario_numbers(sc.path, sets, numbers, load_errors)) {
    for (const std::string& e : load_errors) std::cerr << e << "\n";
    return 2;
  }
  const fmu::Description d = fmu::describe(sc, mode, numbers, fmu_role);
  if (mode == fmu::EcuMode::kBus) {  // the terminal, the layered standard's manifest, the contract
    entries.push_back({"terminalsAndIcons/terminalsAndIcons.xml", fmu::terminals_and_icons(d)});
    entries.push_back({"extra/org.fmi-standard.fmi-ls-bus/fmi-ls-manifest.xml", fmu::ls_bus_manifest()});
    entries.push_back({"extra/org.fmi-standard.fmi-ls-bus/ehpt.dbc", std::string(hil::builtin_ehpt_dbc())});
  }
  const std::string tool = "ehpt " + std::string(hil::build_info().version);
  entries.insert(entries.begin(), io::ZipEntry{"modelDescription.xml", fmi == "3"
                                                                            ? fmu::model_description_3(d, id, token, tool)
                                                                            : fmu::model_description_2(d, id, token, tool)});
  entries.push_back({"documentation/index.html", documentation_page(d, id, fmi)});

  std::string archive;
  if (!io::zip_store(entries, archive, error)) {
    std::cerr << "error: " << error << "\n";
    return 1;
  }
  const fs::path parent = fs::path(out_path).parent_path();
  if (!parent.empty()) fs::create_directories(parent, ec);
  if (!io::write_file_atomically(out_path, archive, error)) {
    std::cerr << "error: " << error << "\n";
    return 1;
  }
  std::size_t outputs = 0, inputs = 0, parameters = 0;
  for (const fmu::Variable& v : d.variables) {
    outputs += v.causality == fmu::Causality::kOutput ? 1 : 0;
    inputs += v.causality == fmu::Causality::kInput ? 1 : 0;
    parameters += v.causality == fmu::Causality::kParameter ? 1 : 0;
  }
  return out("fmu           " + out_path + ": FMI " + fmi + ".0 co-simulation, modelIdentifier " + id + ", " +
             std::to_string(parameters) + " parameters, " + std::to_string(inputs) + " inputs, " +
             std::to_string(outputs) + " outputs, step " +
             io::number_text(d.step_s) + " s, stop " +
             io::number_text(d.stop_s) + " s, " + std::to_string(entries.size()) + " files, " +
             std::to_string(archive.size()) + " bytes\n")
             ? 0
             : 1;
}

}  // namespace ehpt::cli
