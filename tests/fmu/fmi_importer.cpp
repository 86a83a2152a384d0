// SPDX-License-Identifier: BSD-3-Clause
#include "fmi_importer.hpp"

#include <dlfcn.h>
#include <stdlib.h>  // mkdtemp

#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "io/zip.hpp"

namespace ehpt::test {

namespace fs = std::filesystem;

namespace {

// FMI 2.0's logger: the message is a printf format with the arguments after it
void collect2(fmi2ComponentEnvironment env, fmi2String, fmi2Status status, fmi2String category, fmi2String message, ...) {
  char text[4096];
  va_list args;
  va_start(args, message);
  std::vsnprintf(text, sizeof text, message != nullptr ? message : "", args);
  va_end(args);
  auto* log = static_cast<std::vector<std::string>*>(env);
  log->push_back(std::to_string(static_cast<int>(status)) + " " + (category ? category : "") + ": " + text);
}

void collect(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
  auto* log = static_cast<std::vector<std::string>*>(env);
  log->push_back(std::to_string(static_cast<int>(status)) + " " + (category ? category : "") + ": " +
                 (message ? message : ""));
}

std::string attribute(const std::string& xml, const std::string& element, const std::string& name) {
  const std::regex re("<" + element + "\\b[^>]*\\s" + name + "=\"([^\"]*)\"");
  std::smatch m;
  return std::regex_search(xml, m, re) ? m[1].str() : "";
}

template <class F>
bool symbol(void* lib, const char* name, F*& out, std::string& error) {
  out = reinterpret_cast<F*>(dlsym(lib, name));
  if (out == nullptr) error = std::string("the FMU's library has no ") + name;
  return out != nullptr;
}

}  // namespace

Fmi3Fmu::~Fmi3Fmu() {
  if (library_ != nullptr) dlclose(library_);
  std::error_code ec;
  if (made_dir_) fs::remove_all(dir, ec);  // the folder mkdtemp made for us, nothing else
}

bool Fmi3Fmu::open(const std::string& fmu_path, std::string& error) {
  std::ifstream in(fmu_path, std::ios::binary);
  std::stringstream bytes;
  bytes << in.rdbuf();
  if (!in) {
    error = fmu_path + ": cannot read it";
    return false;
  }
  std::vector<io::ZipEntry> entries;
  if (!io::zip_read(bytes.str(), entries, error)) return false;
  std::string base = (fs::temp_directory_path() / "ehpt-fmu-XXXXXX").string();
  if (::mkdtemp(base.data()) == nullptr) {
    error = "mkdtemp failed";
    return false;
  }
  dir = base;
  made_dir_ = true;
  for (const io::ZipEntry& e : entries) {
    const fs::path p = fs::path(dir) / e.name;
    fs::create_directories(p.parent_path());
    std::ofstream(p, std::ios::binary) << e.data;
    if (e.name == "modelDescription.xml") xml = e.data;
  }
  if (xml.empty()) {
    error = "no modelDescription.xml";
    return false;
  }
  const std::string fmi_version = attribute(xml, "fmiModelDescription", "fmiVersion");
  version = fmi_version == "3.0" ? 3 : fmi_version == "2.0" ? 2 : 0;
  if (version == 0) {
    error = "fmiVersion \"" + fmi_version + "\": this importer takes 3.0 and 2.0";
    return false;
  }
  token = attribute(xml, "fmiModelDescription", version == 3 ? "instantiationToken" : "guid");
  model_identifier = attribute(xml, "CoSimulation", "modelIdentifier");
  step_s = std::strtod(attribute(xml, version == 3 ? "CoSimulation" : "DefaultExperiment",
                                 version == 3 ? "fixedInternalStepSize" : "stepSize")
                           .c_str(),
                       nullptr);
  stop_s = std::strtod(attribute(xml, "DefaultExperiment", "stopTime").c_str(), nullptr);
  if (version == 3) {
    const std::regex var("<Float64 name=\"([^\"]*)\" valueReference=\"([0-9]+)\"[^>]*causality=\"([a-z]+)\"");
    for (auto it = std::sregex_iterator(xml.begin(), xml.end(), var); it != std::sregex_iterator(); ++it) {
      vr[(*it)[1].str()] = static_cast<fmi3ValueReference>(std::stoul((*it)[2].str()));
      if ((*it)[3].str() == "output") output_names.push_back((*it)[1].str());
    }
    const std::regex boolean("<Boolean name=\"([^\"]*)\" valueReference=\"([0-9]+)\"");
    for (auto it = std::sregex_iterator(xml.begin(), xml.end(), boolean); it != std::sregex_iterator(); ++it) {
      boolean_vr[(*it)[1].str()] = static_cast<fmi3ValueReference>(std::stoul((*it)[2].str()));
    }
    const std::regex bus("<(Binary|Clock) name=\"([^\"]*)\" valueReference=\"([0-9]+)\"");
    for (auto it = std::sregex_iterator(xml.begin(), xml.end(), bus); it != std::sregex_iterator(); ++it) {
      bus_vr[(*it)[2].str()] = static_cast<fmi3ValueReference>(std::stoul((*it)[3].str()));
    }
    has_event_mode = attribute(xml, "CoSimulation", "hasEventMode") == "true";
  } else {
    const std::regex var("<ScalarVariable name=\"([^\"]*)\" valueReference=\"([0-9]+)\"[^>]*causality=\"([a-z]+)\"[^>]*>"
                         "<(Real|Boolean)");
    for (auto it = std::sregex_iterator(xml.begin(), xml.end(), var); it != std::sregex_iterator(); ++it) {
      const auto ref = static_cast<fmi3ValueReference>(std::stoul((*it)[2].str()));
      if ((*it)[4].str() == "Boolean") {
        boolean_vr[(*it)[1].str()] = ref;
        continue;
      }
      vr[(*it)[1].str()] = ref;
      if ((*it)[3].str() == "output") output_names.push_back((*it)[1].str());
    }
  }
  const std::string so = dir + "/binaries/x86_64-linux/" + model_identifier + ".so";
  library_ = dlopen(so.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (library_ == nullptr) {
    error = std::string("dlopen: ") + dlerror();
    return false;
  }
  if (version == 2) {
    return symbol(library_, "fmi2Instantiate", instantiate2, error) &&
           symbol(library_, "fmi2FreeInstance", free_instance2, error) &&
           symbol(library_, "fmi2SetupExperiment", setup_experiment2, error) &&
           symbol(library_, "fmi2EnterInitializationMode", enter_initialization2, error) &&
           symbol(library_, "fmi2ExitInitializationMode", exit_initialization2, error) &&
           symbol(library_, "fmi2DoStep", do_step2, error) && symbol(library_, "fmi2GetReal", get_real2, error) &&
           symbol(library_, "fmi2SetReal", set_real2, error) && symbol(library_, "fmi2GetBoolean", get_boolean2, error) &&
           symbol(library_, "fmi2SetBoolean", set_boolean2, error) && symbol(library_, "fmi2Terminate", terminate2, error) &&
           symbol(library_, "fmi2GetBooleanStatus", get_boolean_status2, error) &&
           symbol(library_, "fmi2GetVersion", get_version2, error) &&
           symbol(library_, "fmi2GetFMUstate", get_state2, error) && symbol(library_, "fmi2SetFMUstate", set_state2, error) &&
           symbol(library_, "fmi2FreeFMUstate", free_state2, error) &&
           symbol(library_, "fmi2SerializedFMUstateSize", serialized_size2, error) &&
           symbol(library_, "fmi2SerializeFMUstate", serialize2, error) &&
           symbol(library_, "fmi2DeSerializeFMUstate", deserialize2, error);
  }
  return symbol(library_, "fmi3InstantiateCoSimulation", instantiate, error) &&
         symbol(library_, "fmi3FreeInstance", free_instance, error) &&
         symbol(library_, "fmi3EnterInitializationMode", enter_initialization, error) &&
         symbol(library_, "fmi3ExitInitializationMode", exit_initialization, error) &&
         symbol(library_, "fmi3DoStep", do_step, error) && symbol(library_, "fmi3GetFloat64", get_float64, error) &&
         symbol(library_, "fmi3SetFloat64", set_float64, error) && symbol(library_, "fmi3GetBoolean", get_boolean, error) &&
         symbol(library_, "fmi3SetBoolean", set_boolean, error) && symbol(library_, "fmi3Terminate", terminate, error) &&
         symbol(library_, "fmi3Reset", reset, error) && symbol(library_, "fmi3GetVersion", get_version, error) &&
         symbol(library_, "fmi3GetFMUState", get_state, error) && symbol(library_, "fmi3SetFMUState", set_state, error) &&
         symbol(library_, "fmi3FreeFMUState", free_state, error) &&
         symbol(library_, "fmi3SerializedFMUStateSize", serialized_size, error) &&
         symbol(library_, "fmi3SerializeFMUState", serialize, error) &&
         symbol(library_, "fmi3DeserializeFMUState", deserialize, error) &&
         symbol(library_, "fmi3EnterEventMode", enter_event_mode, error) &&
         symbol(library_, "fmi3UpdateDiscreteStates", update_discrete_states, error) &&
         symbol(library_, "fmi3EnterStepMode", enter_step_mode, error) && symbol(library_, "fmi3GetClock", get_clock, error) &&
         symbol(library_, "fmi3SetClock", set_clock, error) && symbol(library_, "fmi3GetBinary", get_binary, error) &&
         symbol(library_, "fmi3SetBinary", set_binary, error);
}

fmi3Instance Fmi3Fmu::make_instance(const char* name, const char* token_override, bool event_mode) {
  const std::string resources = dir + "/resources/";
  return instantiate(name, token_override != nullptr ? token_override : token.c_str(), resources.c_str(), fmi3False,
                     fmi3False, event_mode ? fmi3True : fmi3False, fmi3False, nullptr, 0, &log, collect, nullptr);
}

namespace {

struct Node {
  Fmi3Fmu* fmu;
  fmi3Instance instance;
};

std::string last_log(const Fmi3Fmu& fmu) { return fmu.log.empty() ? std::string() : fmu.log.back(); }

// Operations of node 1 on their way to node 0 (delay_events > 0): the bytes, and the Event Mode
// at which they arrive.
struct InFlight {
  std::vector<std::uint8_t> bytes;
  std::int64_t due_event = 0;
};

// hands bytes to a node's Rx (its Rx_Clock ticking)
bool deliver(Node& dst, const std::uint8_t* data, size_t size, BusRun& run, std::string& error) {
  const fmi3ValueReference rx_clock = dst.fmu->bus_vr.at("CAN.Rx_Clock"), rx_data = dst.fmu->bus_vr.at("CAN.Rx_Data");
  const fmi3Clock active = fmi3ClockActive;
  const fmi3Binary value = data;
  if (dst.fmu->set_clock(dst.instance, &rx_clock, 1, &active) != fmi3OK ||
      dst.fmu->set_binary(dst.instance, &rx_data, 1, &size, &value, 1) != fmi3OK) {
    error = "fmi3SetClock/SetBinary(Rx): " + last_log(*dst.fmu);
    return false;
  }
  ++run.transfers;
  run.bytes += static_cast<std::int64_t>(size);
  return true;
}

// One point's Event Mode (both FMUs in it): Tx to Rx while a Tx_Clock ticks, each move followed by
// fmi3UpdateDiscreteStates of every FMU, until a round moves nothing (at most 16 rounds).
bool event_iteration(std::vector<Node>& nodes, BusRun& run, std::string& error, int delay_events,
                     std::vector<InFlight>& in_flight) {
  ++run.events;
  for (int round = 0; round < 16; ++round) {
    bool moved = false;
    if (round == 0) {  // what a delaying bus carried here
      for (auto it = in_flight.begin(); it != in_flight.end();) {
        if (it->due_event > run.events) {
          ++it;
          continue;
        }
        if (!deliver(nodes[0], it->bytes.data(), it->bytes.size(), run, error)) return false;
        it = in_flight.erase(it);
        moved = true;
      }
    }
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      Fmi3Fmu& src = *nodes[i].fmu;
      const fmi3ValueReference tx_clock = src.bus_vr.at("CAN.Tx_Clock"), tx_data = src.bus_vr.at("CAN.Tx_Data");
      fmi3Clock ticked = fmi3ClockInactive;
      if (src.get_clock(nodes[i].instance, &tx_clock, 1, &ticked) != fmi3OK) {
        error = "fmi3GetClock(Tx_Clock): " + last_log(src);
        return false;
      }
      if (ticked != fmi3ClockActive) continue;
      size_t size = 0;
      fmi3Binary data = nullptr;
      if (src.get_binary(nodes[i].instance, &tx_data, 1, &size, &data, 1) != fmi3OK) {
        error = "fmi3GetBinary(Tx_Data): " + last_log(src);
        return false;
      }
      if (i == 0 && run.first_plant_tx.empty()) run.first_plant_tx.assign(data, data + size);
      for (std::size_t at = 0; i == 0 && at + 8 <= size;) {  // the plant's operations, by OP code
        const auto u32 = [&](std::size_t k) {
          return static_cast<std::uint32_t>(data[k] | data[k + 1] << 8 | data[k + 2] << 16 | data[k + 3] << 24);
        };
        const std::uint32_t op = u32(at), length = u32(at + 4);
        if (length < 8 || length > size - at) break;
        ++run.plant_ops[op];
        if (op == 0x41 && length == 9) run.plant_status.push_back(data[at + 8]);
        at += length;
      }
      if (size == 0) continue;
      for (std::size_t j = 0; j < nodes.size(); ++j) {  // direct connection: every other node hears it
        if (j == i) continue;
        if (i == 1 && delay_events > 0) {  // on its way
          in_flight.push_back({std::vector<std::uint8_t>(data, data + size), run.events + delay_events});
          continue;
        }
        if (!deliver(nodes[j], data, size, run, error)) return false;
      }
      moved = true;
    }
    for (Node& n : nodes) {
      fmi3Boolean need = fmi3False, terminate = fmi3False, nominals = fmi3False, values = fmi3False, next = fmi3False;
      fmi3Float64 next_time = 0.0;
      if (n.fmu->update_discrete_states(n.instance, &need, &terminate, &nominals, &values, &next, &next_time) != fmi3OK) {
        error = "fmi3UpdateDiscreteStates: " + last_log(*n.fmu);
        return false;
      }
    }
    if (!moved) return true;
  }
  error = "the Event Mode did not settle in 16 rounds";
  return false;
}

}  // namespace

bool run_bus_pair(Fmi3Fmu& a, fmi3Instance ia, Fmi3Fmu* b, fmi3Instance ib, std::int64_t k, double stop_s,
                  std::vector<std::vector<double>>& rows, BusRun& run, std::string& error, int delay_events) {
  rows.clear();
  std::vector<InFlight> in_flight;
  std::vector<Node> nodes{{&a, ia}};
  if (b != nullptr) nodes.push_back({b, ib});
  for (Node& n : nodes) {
    if (n.fmu->enter_initialization(n.instance, fmi3False, 0.0, 0.0, fmi3True, stop_s) != fmi3OK ||
        n.fmu->exit_initialization(n.instance) != fmi3OK) {
      error = "initialization failed: " + last_log(*n.fmu);
      return false;
    }
  }
  // FMI 3.0 co-simulation with eventModeUsed: Event Mode follows initialization (sample 0)
  if (!event_iteration(nodes, run, error, delay_events, in_flight)) return false;
  for (Node& n : nodes) {
    if (n.fmu->enter_step_mode(n.instance) != fmi3OK) {
      error = "fmi3EnterStepMode: " + last_log(*n.fmu);
      return false;
    }
  }
  std::vector<fmi3ValueReference> refs;
  for (const std::string& name : a.output_names) refs.push_back(a.vr.at(name));
  std::vector<double> y(refs.size());
  const std::int64_t total = std::llround(stop_s / a.step_s);
  for (std::int64_t done = 0; done < total; done += k) {
    const double t = static_cast<double>(done) * a.step_s;
    const std::int64_t n = std::min(k, total - done);
    bool any_event = false;
    for (Node& node : nodes) {
      fmi3Boolean event = fmi3False, terminate = fmi3False, early = fmi3False;
      fmi3Float64 last = 0.0;
      if (node.fmu->do_step(node.instance, t, static_cast<double>(n) * a.step_s, fmi3True, &event, &terminate, &early,
                            &last) != fmi3OK) {
        error = "doStep at t = " + std::to_string(t) + " failed: " + last_log(*node.fmu);
        return false;
      }
      any_event = any_event || event == fmi3True;
    }
    if (any_event) {
      for (Node& node : nodes) {
        if (node.fmu->enter_event_mode(node.instance) != fmi3OK) {
          error = "fmi3EnterEventMode: " + last_log(*node.fmu);
          return false;
        }
      }
      if (!event_iteration(nodes, run, error, delay_events, in_flight)) return false;
      for (Node& node : nodes) {
        if (node.fmu->enter_step_mode(node.instance) != fmi3OK) {
          error = "fmi3EnterStepMode: " + last_log(*node.fmu);
          return false;
        }
      }
    }
    double time = 0.0;
    const fmi3ValueReference time_vr = 0;
    if (a.get_float64(ia, &time_vr, 1, &time, 1) != fmi3OK || a.get_float64(ia, refs.data(), refs.size(), y.data(), y.size()) != fmi3OK) {
      error = "getFloat64 failed: " + last_log(a);
      return false;
    }
    std::vector<double> row{time};
    row.insert(row.end(), y.begin(), y.end());
    rows.push_back(std::move(row));
  }
  run.terminate_status = a.terminate(ia);
  if (b != nullptr && b->terminate(ib) != fmi3OK) {
    error = "the ECU's fmi3Terminate: " + last_log(*b);
    return false;
  }
  if (run.terminate_status != fmi3OK && run.terminate_status != fmi3Warning) {
    error = "fmi3Terminate: " + last_log(a);
    return false;
  }
  return true;
}

fmi2Component Fmi3Fmu::make_instance2(const char* name, const char* guid_override) {
  static thread_local fmi2CallbackFunctions callbacks;
  callbacks = fmi2CallbackFunctions{collect2, nullptr, nullptr, nullptr, &log};
  // a file URI, with the characters a path may hold that a URI may not percent-encoded
  std::string uri = "file://";
  for (const char ch : dir + "/resources") {
    if (ch == ' ' || ch == '%' || ch == '#' || ch == '?') {
      char buf[4];
      std::snprintf(buf, sizeof buf, "%%%02X", static_cast<unsigned char>(ch));
      uri += buf;
    } else {
      uri += ch;
    }
  }
  return instantiate2(name, fmi2CoSimulation, guid_override != nullptr ? guid_override : token.c_str(), uri.c_str(),
                      &callbacks, fmi2False, fmi2False);
}

bool run_fmu2(Fmi3Fmu& fmu, fmi2Component instance, std::int64_t k, double stop_s, std::vector<std::vector<double>>& rows,
              std::string& error) {
  rows.clear();
  if (fmu.setup_experiment2(instance, fmi2False, 0.0, 0.0, fmi2True, stop_s) != fmi2OK ||
      fmu.enter_initialization2(instance) != fmi2OK || fmu.exit_initialization2(instance) != fmi2OK) {
    error = "initialization failed: " + (fmu.log.empty() ? std::string() : fmu.log.back());
    return false;
  }
  std::vector<fmi2ValueReference> refs;
  for (const std::string& n : fmu.output_names) refs.push_back(fmu.vr.at(n));
  const std::int64_t total = std::llround(stop_s / fmu.step_s);
  std::vector<double> y(refs.size());
  for (std::int64_t done = 0; done < total; done += k) {
    const double t = static_cast<double>(done) * fmu.step_s;
    const std::int64_t n = std::min(k, total - done);
    if (fmu.do_step2(instance, t, static_cast<double>(n) * fmu.step_s, fmi2True) != fmi2OK) {
      error = "doStep at t = " + std::to_string(t) + " failed: " + (fmu.log.empty() ? std::string() : fmu.log.back());
      return false;
    }
    if (fmu.get_real2(instance, refs.data(), refs.size(), y.data()) != fmi2OK) {
      error = "getReal failed";
      return false;
    }
    // FMI 2.0 has no time variable: the importer's own point, whole steps times the step, as
    // ehpt's time column is (step index x step_s)
    std::vector<double> row{static_cast<double>(done + n) * fmu.step_s};
    row.insert(row.end(), y.begin(), y.end());
    rows.push_back(std::move(row));
  }
  return fmu.terminate2(instance) == fmi2OK;
}

bool run_fmu(Fmi3Fmu& fmu, fmi3Instance instance, std::int64_t k, double stop_s, std::vector<std::vector<double>>& rows,
             std::string& error) {
  rows.clear();
  if (fmu.enter_initialization(instance, fmi3False, 0.0, 0.0, fmi3True, stop_s) != fmi3OK ||
      fmu.exit_initialization(instance) != fmi3OK) {
    error = "initialization failed: " + (fmu.log.empty() ? std::string() : fmu.log.back());
    return false;
  }
  std::vector<fmi3ValueReference> refs;
  for (const std::string& n : fmu.output_names) refs.push_back(fmu.vr.at(n));
  const double h = static_cast<double>(k) * fmu.step_s;
  const std::int64_t total = std::llround(stop_s / fmu.step_s);
  std::vector<double> y(refs.size());
  for (std::int64_t done = 0; done < total; done += k) {
    // the communication point as an importer keeps it: whole plant steps times the step
    const double t = static_cast<double>(done) * fmu.step_s;
    fmi3Boolean event = fmi3False, terminate = fmi3False, early = fmi3False;
    fmi3Float64 last = 0.0;
    const std::int64_t n = std::min(k, total - done);
    if (fmu.do_step(instance, t, static_cast<double>(n) * fmu.step_s, fmi3True, &event, &terminate, &early, &last) != fmi3OK) {
      error = "doStep at t = " + std::to_string(t) + " failed: " + (fmu.log.empty() ? std::string() : fmu.log.back());
      return false;
    }
    double time = 0.0;
    const fmi3ValueReference time_vr = 0;
    if (fmu.get_float64(instance, &time_vr, 1, &time, 1) != fmi3OK ||
        fmu.get_float64(instance, refs.data(), refs.size(), y.data(), y.size()) != fmi3OK) {
      error = "getFloat64 failed";
      return false;
    }
    std::vector<double> row{time};
    row.insert(row.end(), y.begin(), y.end());
    rows.push_back(std::move(row));
  }
  (void)h;
  return fmu.terminate(instance) == fmi3OK;
}

}  // namespace ehpt::test
