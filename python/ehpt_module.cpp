// SPDX-License-Identifier: BSD-3-Clause
// The Python module `ehpt` (issue 13 item 5): a thin pybind11 binding of the Simulation facade.
//
//   ehpt.run(scenario, set=None) -> RunResult      the CLI's `ehpt run`, into memory
//   ehpt.Simulation(scenario, set=None, external_ecu=False)
//       .step(n), .run(), .read_sensors(), .write_command(cmd), .timeseries(), ...
//   ehpt.PsdSensors / PsdCommand / EvSensors / EvCommand / Stamp: the messages of msgs/
//
// Everything numeric is computed by the same library code as the CLI (ehpt_hil), so a run
// here equals `ehpt run` bit for bit; this file only converts. The simulation runs with the
// GIL released. The allocation guard's hooks (ehpt_alloc_guard) are not linked: they replace
// malloc for a whole process, which a shared object loaded into Python must never do.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include "ecu/ev_follower.hpp"
#include "ecu/psd_ecu.hpp"
#include "hil/run/batch.hpp"
#include "hil/config/config.hpp"
#include "hil/config/scenario.hpp"
#include "hil/run/simulation.hpp"
#include "msgs/ev.hpp"
#include "msgs/psd.hpp"
#include "msgs/stamp.hpp"

namespace py = pybind11;
using namespace ehpt;

namespace {

// ---- set={...}: Python values -> the CLI's --set key=value text -----------------------------

// The value as TOML text: bool -> true/false, int -> digits, float -> repr() (the shortest text
// that reads back as the same double; inf and nan are TOML too), str -> quoted, list/tuple ->
// array. Anything else is a TypeError naming the key.
std::string toml_value(const py::handle& v, const std::string& key) {
  if (py::isinstance<py::bool_>(v)) return v.cast<bool>() ? "true" : "false";  // before int: bool is an int
  // float(v) first: a subclass (numpy.float64) has its own repr ("np.float64(0.62)")
  if (py::isinstance<py::float_>(v)) return py::repr(py::float_(v.cast<double>())).cast<std::string>();
  if (py::isinstance<py::int_>(v)) return py::str(v).cast<std::string>();
  if (py::isinstance<py::str>(v)) return hil::toml_string(v.cast<std::string>());  // a str stays a string: the CLI would read "0.5" as a number
  if (py::isinstance<py::list>(v) || py::isinstance<py::tuple>(v)) {
    std::string out = "[";
    for (const py::handle item : v) out += (out.size() > 1 ? ", " : "") + toml_value(item, key);
    return out + "]";
  }
  if (py::hasattr(v, "__index__")) return py::str(py::int_(py::reinterpret_borrow<py::object>(v))).cast<std::string>();  // numpy ints
  throw py::type_error("set[\"" + key + "\"]: a value of type " + py::type::of(v).attr("__name__").cast<std::string>() +
                       " cannot be a scenario value (bool, int, float, str or a list of them)");
}

std::vector<std::string> overrides_of(const py::object& set) {
  std::vector<std::string> out;
  if (set.is_none()) return out;
  if (!py::isinstance<py::dict>(set)) throw py::type_error("set must be a dict {\"dotted.key\": value} or None");
  for (const auto& [k, v] : set.cast<py::dict>()) {
    if (!py::isinstance<py::str>(k)) throw py::type_error("set: keys must be str, got " + py::repr(k).cast<std::string>());
    const std::string key = k.cast<std::string>();
    // one key per entry: an '=' would be read as the end of the key
    if (key.empty() || key.find_first_of(std::string("=\r\n\0", 4)) != std::string::npos) {
      throw py::value_error("set[" + py::repr(k).cast<std::string>() + "]: not a dotted key (e.g. \"vehicle.ecu.soc_ref\")");
    }
    out.push_back(key + "=" + toml_value(v, key));
  }
  return out;
}

// ---- loading -------------------------------------------------------------------------------

std::string joined(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& l : lines) s += (s.empty() ? "" : "\n") + l;
  return s;
}

// The scenario (a name or a path) with its overrides, as `ehpt run` loads it. Called without
// the GIL (it reads files); the errors come back as text, turned into a ValueError by the caller.
bool load(const std::string& name, const std::vector<std::string>& overrides, hil::Scenario& sc,
          std::vector<std::string>& errors) {
  // a C string would end at a NUL: "ev_nedc.toml\0junk" must not run ev_nedc.toml
  if (name.find('\0') != std::string::npos) {
    errors.push_back("the scenario name contains a NUL character");
    return false;
  }
  std::string reason;
  const std::string path = hil::resolve_scenario(name, reason);
  if (path.empty()) {
    errors.push_back(name + ": " + reason);
    return false;
  }
  return hil::load_scenario(path, overrides, sc, errors);
}

// Text from files and paths as a Python str: bytes that are not UTF-8 (a Latin-1 folder name)
// come back as they were (surrogateescape, as Python itself decodes file names), never a
// UnicodeDecodeError after the run.
py::str text_of(const std::string& s) {
  PyObject* o = PyUnicode_DecodeUTF8(s.data(), static_cast<Py_ssize_t>(s.size()), "surrogateescape");
  if (o == nullptr) throw py::error_already_set();
  return py::reinterpret_steal<py::str>(o);
}

[[noreturn]] void throw_load_errors(const std::string& name, const std::vector<std::string>& errors) {
  std::string shown = name;  // a NUL would end the message there
  for (std::size_t at = shown.find('\0'); at != std::string::npos; at = shown.find('\0', at)) shown.replace(at, 1, "\\0");
  const std::string text = shown + ": " + std::to_string(errors.size()) + (errors.size() == 1 ? " problem" : " problems") +
                           "; nothing was run:\n" + joined(errors);
  PyErr_SetObject(PyExc_ValueError, text_of(text).ptr());
  throw py::error_already_set();
}

// ---- results -------------------------------------------------------------------------------

py::object json_loads(const std::string& text) { return py::module_::import("json").attr("loads")(text); }

// Row-major rows -> {name: 1-D float64 array}, one contiguous copy per column, in column order.
py::dict columns_of(const std::vector<std::string>& names, const std::vector<double>& rows) {
  py::dict out;
  const std::size_t nc = names.size();
  const std::size_t nr = nc == 0 ? 0 : rows.size() / nc;
  for (std::size_t c = 0; c < nc; ++c) {
    py::array_t<double> a(static_cast<py::ssize_t>(nr));
    double* p = a.mutable_data();
    for (std::size_t r = 0; r < nr; ++r) p[r] = rows[r * nc + c];
    out[py::str(names[c])] = a;
  }
  return out;
}

struct RunResult {
  py::object summary;     // dict: summary.json as json.loads reads it (NaN is null -> None)
  py::list columns;       // timeseries.csv's header
  py::dict timeseries;    // name -> float64 array
  int exit_code = 0;      // 0 ok, 3 run-time fault (outputs kept), 128 + signal interrupted
  py::list warnings;
  py::str text;           // the lines `ehpt run` prints
};

RunResult run(const std::string& scenario, const py::object& set) {
  const std::vector<std::string> overrides = overrides_of(set);
  hil::Scenario sc;
  std::vector<std::string> errors;
  hil::MemoryRun mr;
  bool loaded = false;
  {
    py::gil_scoped_release released;
    loaded = load(scenario, overrides, sc, errors);
    if (loaded) mr = hil::run_in_memory(sc);
  }
  if (!loaded) throw_load_errors(scenario, errors);
  RunResult r;
  r.summary = json_loads(mr.summary.str());
  for (const auto& c : mr.columns) r.columns.append(c);
  r.timeseries = columns_of(mr.columns, mr.rows);
  r.exit_code = mr.exit_code;
  for (const auto& w : mr.warnings) r.warnings.append(text_of(w));
  r.text = text_of(mr.summary_text);
  return r;
}

// ---- messages ------------------------------------------------------------------------------

// A message struct as a Python class: a field per member (def_readwrite), keyword construction
// (PsdCommand(motTauRef_Nm=10.0); an unknown name is a TypeError), __repr__, _fields.
template <class T>
class MessageClass {
 public:
  MessageClass(py::module_& m, const char* name, const char* doc) : cls_(m, name, doc), name_(name) {}
  template <class V>
  MessageClass& field(const char* name, V T::*member) {
    cls_.def_readwrite(name, member);
    names_.push_back(name);
    return *this;
  }
  void finish() {
    const std::vector<std::string> names = names_;
    const std::string cls = name_;
    cls_.def(py::init([names, cls](const py::kwargs& kw) {
               T value{};
               const py::object self = py::cast(&value, py::return_value_policy::reference);
               for (const auto& [k, v] : kw) {
                 const std::string key = py::str(k);
                 if (std::find(names.begin(), names.end(), key) == names.end()) {
                   throw py::type_error(cls + "() has no field '" + key + "'");
                 }
                 try {
                   self.attr(k) = v;
                 } catch (py::error_already_set& e) {  // pybind's own message does not name the field
                   const std::string value = py::str(py::repr(v));
                   const std::string type = py::str(py::type::of(self.attr(k)).attr("__name__"));
                   throw py::type_error(cls + "." + key + ": " + value + " is not a " + type);
                 }
               }
               return value;
             }),
             "Keyword arguments set fields; the others keep their defaults.");
    cls_.def("__repr__", [names, cls](const py::object& self) {
      std::string s = cls + "(";
      for (std::size_t i = 0; i < names.size(); ++i) {
        s += (i ? ", " : "") + names[i] + "=" + py::repr(self.attr(names[i].c_str())).template cast<std::string>();
      }
      return s + ")";
    });
    py::tuple fields(names.size());
    for (std::size_t i = 0; i < names.size(); ++i) fields[i] = py::str(names[i]);
    cls_.attr("_fields") = fields;
  }

 private:
  py::class_<T> cls_;
  std::string name_;
  std::vector<std::string> names_;
};

void bind_messages(py::module_& m) {
  using namespace msgs;
  MessageClass<Stamp>(m, "Stamp", "Simulation time and step of a sample, and the sender's sequence number.")
      .field("time_s", &Stamp::time_s)
      .field("step", &Stamp::step)
      .field("sequence", &Stamp::sequence)
      .finish();
  MessageClass<PsdSensors>(m, "PsdSensors", "Power-split hybrid, plant -> ECU (msgs/psd.hpp).")
      .field("stamp", &PsdSensors::stamp)
      .field("driverRequest", &PsdSensors::driverRequest)
      .field("speed_m_s", &PsdSensors::speed_m_s)
      .field("iceW_rad_s", &PsdSensors::iceW_rad_s)
      .field("icePowDel_W", &PsdSensors::icePowDel_W)
      .field("genW_rad_s", &PsdSensors::genW_rad_s)
      .field("genPowDel_W", &PsdSensors::genPowDel_W)
      .field("genTauLim_Nm", &PsdSensors::genTauLim_Nm)
      .field("motW_rad_s", &PsdSensors::motW_rad_s)
      .field("motPowDelA_W", &PsdSensors::motPowDelA_W)
      .field("motPowDelB_W", &PsdSensors::motPowDelB_W)
      .field("motPowDelAB_W", &PsdSensors::motPowDelAB_W)
      .field("motTauLim_Nm", &PsdSensors::motTauLim_Nm)
      .field("batSOC", &PsdSensors::batSOC)
      .field("batPowDel_W", &PsdSensors::batPowDel_W)
      .field("battery_voltage_V", &PsdSensors::battery_voltage_V)
      .field("battery_current_A", &PsdSensors::battery_current_A)
      .field("fault", &PsdSensors::fault)
      .field("locked", &PsdSensors::locked)
      .finish();
  MessageClass<PsdCommand>(m, "PsdCommand", "Power-split hybrid, ECU -> plant (msgs/psd.hpp).")
      .field("stamp", &PsdCommand::stamp)
      .field("icePowRef_W", &PsdCommand::icePowRef_W)
      .field("iceTauRef_Nm", &PsdCommand::iceTauRef_Nm)
      .field("genTauRef_Nm", &PsdCommand::genTauRef_Nm)
      .field("motTauRef_Nm", &PsdCommand::motTauRef_Nm)
      .field("iceON", &PsdCommand::iceON)
      .finish();
  MessageClass<EvSensors>(m, "EvSensors", "Battery-electric vehicle, plant -> ECU (msgs/ev.hpp).")
      .field("stamp", &EvSensors::stamp)
      .field("driverRequest_Nm", &EvSensors::driverRequest_Nm)
      .field("speed_m_s", &EvSensors::speed_m_s)
      .field("driveW_rad_s", &EvSensors::driveW_rad_s)
      .field("driveTauLim_Nm", &EvSensors::driveTauLim_Nm)
      .field("drivePowDel_W", &EvSensors::drivePowDel_W)
      .field("batSOC", &EvSensors::batSOC)
      .field("batPowDel_W", &EvSensors::batPowDel_W)
      .field("battery_voltage_V", &EvSensors::battery_voltage_V)
      .field("battery_current_A", &EvSensors::battery_current_A)
      .field("fault", &EvSensors::fault)
      .field("locked", &EvSensors::locked)
      .finish();
  MessageClass<EvCommand>(m, "EvCommand", "Battery-electric vehicle, ECU -> plant (msgs/ev.hpp).")
      .field("stamp", &EvCommand::stamp)
      .field("driveTauRef_Nm", &EvCommand::driveTauRef_Nm)
      .finish();
}

// The built-in ECU's parameters as a dict, so that an ECU written in Python can start from
// exactly what the scenario loaded (overrides included): python/examples/mbecu2_ecu.py.
py::object ecu_parameters(const hil::Scenario& sc) {
  py::dict d;
  d["period_s"] = sc.ecu_timing.period_s;
  d["latency_s"] = sc.ecu_timing.latency_s;
  d["codec"] = sc.ecu_timing.codec;
  if (const auto* e = sc.ecu.get_if<ecu::PsdEcuParams>()) {
    d["kind"] = ecu::ecu_name(e->kind);
    d["max_torque_request_Nm"] = e->max_torque_request_Nm;
    d["power_filter_s"] = e->power_filter_s;
    d["gen_loop_gain_Nm_s_rad"] = e->gen_loop_gain_Nm_s_rad;
    d["gen_filter_s"] = e->gen_filter_s;
    d["gen_torque_max_Nm"] = e->gen_torque_max_Nm;
    d["ice_speed_min_rad_s"] = e->ice_speed_min_rad_s;
    d["power_to_speed_W"] = e->power_to_speed_rad_s.x();        // the table's axis (W)
    d["power_to_speed_rad_s"] = e->power_to_speed_rad_s.y();    // its values
    d["soc_ref"] = e->soc_ref;
    d["soc_loop_gain_W"] = e->soc_loop_gain_W;
    d["on_threshold_W"] = e->on_threshold_W;
    d["off_threshold_W"] = e->off_threshold_W;
    d["ice_off_speed_ref_rad_s"] = e->ice_off_speed_ref_rad_s;
  } else if (sc.ecu.holds<ecu::EvFollowerParams>()) {
    d["kind"] = "follower";
  } else {
    return py::none();
  }
  return d;
}

// ---- Simulation ----------------------------------------------------------------------------

enum class Family { kNone, kPsd, kEv };

class PySimulation {
 public:
  PySimulation(const std::string& scenario, const py::object& set, bool external_ecu, std::int64_t chunk_steps)
      : external_(external_ecu) {
    // the row buffer holds chunk_steps rows of every column: bounded, so that a typo cannot ask
    // for terabytes (1 000 000 rows of 60 columns: 480 MB)
    constexpr std::int64_t kMaxChunkSteps = 1'000'000;
    if (chunk_steps < 1 || chunk_steps > kMaxChunkSteps) {
      throw py::value_error("chunk_steps must be in [1, " + std::to_string(kMaxChunkSteps) + "], got " +
                            std::to_string(chunk_steps));
    }
    const std::vector<std::string> overrides = overrides_of(set);
    std::vector<std::string> errors;
    bool loaded = false;
    {
      py::gil_scoped_release released;
      loaded = load(scenario, overrides, sc_, errors);
    }
    if (!loaded) throw_load_errors(scenario, errors);
    family_ = sc_.ecu.holds<ecu::PsdEcuParams>()  ? Family::kPsd
              : sc_.ecu.holds<ecu::EvFollowerParams>() ? Family::kEv
                                                                       : Family::kNone;
    if (external_ && family_ == Family::kNone) {
      throw py::value_error(scenario + ": this vehicle has no ECU (a test rig): external_ecu=True does not apply");
    }
    if (external_ && sc_.solver.ecu_latency_steps != 0) {
      // the runner applies an external command from its sample on (as a lockstep bus plant)
      throw py::value_error(scenario + ": vehicle.ecu.latency_s belongs to the built-in ECU; with external_ecu=True "
                                       "the command acts from its sample on (set it to 0)");
    }
    const std::vector<hil::SignalInfo> signals = hil::scenario_signals(sc_);
    columns_ = hil::chosen_columns(sc_, signals);
    hil::SimulationOptions opt;
    opt.columns = columns_;
    opt.chunk_steps = chunk_steps;
    opt.external_ecu = external_;
    sim_ = hil::make_simulation(sc_, opt);
    for (const auto& s : sim_->signals()) signal_names_.emplace_back(s.name);
    for (const int c : columns_) column_names_.push_back(signal_names_[static_cast<std::size_t>(c)]);
    chunk_steps_ = chunk_steps;
  }

  // n as a Python int of any size: one beyond int64 is out of range too (a ValueError, not the
  // TypeError of a failed conversion)
  std::int64_t step(const py::int_& n_obj) {
    int overflow = 0;
    const long long n = PyLong_AsLongLongAndOverflow(n_obj.ptr(), &overflow);
    if (overflow != 0 || n < 1 || n > chunk_steps_) {
      throw py::value_error("step(n): n must be in [1, " + std::to_string(chunk_steps_) + "] (chunk_steps), got " +
                            py::repr(n_obj).cast<std::string>());
    }
    const Busy busy(*this);
    py::gil_scoped_release released;
    const std::int64_t taken = sim_->step(n);
    keep_rows();
    return taken;
  }

  // To the end (external_ecu: the last command is held through every later sample).
  std::int64_t run() {
    const Busy busy(*this);
    py::gil_scoped_release released;
    const std::int64_t start = sim_->step_index();
    while (!sim_->finished()) {
      sim_->run();
      keep_rows();
    }
    return sim_->step_index() - start;
  }

  py::object read_sensors() {
    switch (family_) {
      case Family::kPsd: {
        msgs::PsdSensors s;
        sim().read_sensors(s);
        return py::cast(s);
      }
      case Family::kEv: {
        msgs::EvSensors s;
        sim().read_sensors(s);
        return py::cast(s);
      }
      case Family::kNone: break;
    }
    throw py::type_error(sc_.name + ": this vehicle has no ECU messages (a test rig)");
  }

  void write_command(const py::object& cmd) {
    if (family_ == Family::kPsd && py::isinstance<msgs::PsdCommand>(cmd)) {
      sim().write_command(cmd.cast<const msgs::PsdCommand&>());
    } else if (family_ == Family::kEv && py::isinstance<msgs::EvCommand>(cmd)) {
      sim().write_command(cmd.cast<const msgs::EvCommand&>());
    } else {
      const char* wanted = family_ == Family::kPsd ? "ehpt.PsdCommand" : family_ == Family::kEv ? "ehpt.EvCommand" : "none";
      throw py::type_error(sc_.name + ": write_command needs " + std::string(wanted) + ", got " +
                           py::type::of(cmd).attr("__name__").cast<std::string>());
    }
  }

  py::dict outputs() {
    const std::span<const double> y = sim().outputs();
    py::dict d;
    for (std::size_t i = 0; i < y.size(); ++i) d[py::str(signal_names_[i])] = y[i];
    return d;
  }

  py::dict timeseries() const {
    sim();  // not while step() adds rows
    return columns_of(column_names_, rows_);
  }

  // The counters and figures the Simulation keeps, for the run so far (summary.json is made by
  // the batch run from more than these: ehpt.run gives it).
  py::dict stats() const {
    const hil::RunStats& st = sim().stats();
    const hil::RunFigures f = sim().figures();
    py::dict d;
    d["steps_done"] = st.steps_done;
    d["events"] = st.events;
    d["chattering_steps"] = st.chattering_steps;
    d["newton_failures"] = st.newton_failures;
    d["fault"] = st.fault;
    d["fault_time_s"] = st.fault != 0 ? py::cast(st.fault_time_s) : py::none();
    d["rows_dropped"] = st.rows_dropped;
    const auto opt = [](const std::optional<double>& v) { return v ? py::cast(*v) : py::none(); };
    d["distance_m"] = opt(f.distance_m);
    d["soc_start"] = opt(f.soc_start);
    d["soc_end"] = opt(f.soc_end);
    d["fuel_g"] = opt(f.fuel_g);
    return d;
  }

  bool finished() const { return sim().finished(); }
  double time_s() const { return sim().time_s(); }
  std::int64_t step_index() const { return sim().step_index(); }
  std::int64_t total_steps() const { return sim().total_steps(); }
  std::int64_t chunk_steps() const { return chunk_steps_; }
  bool external_ecu() const { return external_; }
  double step_s() const { return sc_.solver.step_s; }
  const std::string& name() const { return sc_.name; }
  py::object ecu_period_steps() const {
    return family_ == Family::kNone ? py::none() : py::cast(sc_.solver.ecu_ratio);
  }
  py::object ecu_params() const { return ecu_parameters(sc_); }
  const std::vector<std::string>& signals() const { return signal_names_; }
  const std::vector<std::string>& columns() const { return column_names_; }

 private:
  // step() and run() release the GIL, so another Python thread could call in while the
  // simulation steps: it gets a RuntimeError instead of a data race. Set and tested with the
  // GIL held (which makes them atomic between Python threads).
  class Busy {
   public:
    explicit Busy(PySimulation& s) : s_(s) {
      s_.sim();
      s_.busy_ = true;
    }
    ~Busy() { s_.busy_ = false; }
    Busy(const Busy&) = delete;
    Busy& operator=(const Busy&) = delete;

   private:
    PySimulation& s_;
  };
  hil::Simulation& sim() const {
    if (busy_) throw std::runtime_error("ehpt.Simulation: in use by another thread (step or run)");
    return *sim_;
  }

  // The recorder's buffer holds one chunk: its rows move here after every call.
  void keep_rows() {
    const std::span<const double> r = sim_->rows();
    rows_.insert(rows_.end(), r.begin(), r.end());
    sim_->clear_rows();
  }

  hil::Scenario sc_;
  bool external_;
  Family family_ = Family::kNone;
  std::int64_t chunk_steps_ = 0;
  std::vector<int> columns_;
  std::vector<std::string> signal_names_, column_names_;
  std::unique_ptr<hil::Simulation> sim_;
  std::vector<double> rows_;  // every row recorded so far, row-major
  bool busy_ = false;         // in step() or run(), the GIL released
};

}  // namespace

PYBIND11_MODULE(ehpt, m) {
  m.doc() =
      "ehpt: plant models of electric and hybrid power trains (the CLI's runs, in process).\n\n"
      "    r = ehpt.run(\"psecu2_nedc\", set={\"vehicle.ecu.soc_ref\": 0.62})\n"
      "    r.summary[\"trajectory_hash\"], r.timeseries[\"speed_m_s\"]\n\n"
      "    sim = ehpt.Simulation(\"psecu2_nedc\", external_ecu=True)   # you are the ECU\n"
      "    while not sim.finished:\n"
      "        s = sim.read_sensors(); sim.write_command(my_ecu(s)); sim.step(sim.ecu_period_steps)\n";

  bind_messages(m);

  py::class_<RunResult>(m, "RunResult", "What `ehpt run` writes, in memory.")
      .def_readonly("summary", &RunResult::summary, "summary.json as a dict (null -> None)")
      .def_readonly("columns", &RunResult::columns, "timeseries.csv's header: signal names in column order")
      .def_readonly("timeseries", &RunResult::timeseries, "name -> 1-D float64 array (empty with output.timeseries off)")
      .def_readonly("exit_code", &RunResult::exit_code, "the CLI's: 0 ok, 3 run-time fault (outputs kept)")
      .def_readonly("warnings", &RunResult::warnings, "what the CLI prints as 'warning: ...'")
      .def_readonly("text", &RunResult::text, "the summary lines the CLI prints")
      .def("__repr__", [](const RunResult& r) {
        return "<ehpt.RunResult exit_code=" + std::to_string(r.exit_code) + ", " + std::to_string(py::len(r.columns)) +
               " columns>";
      });

  m.def("run", &run, py::arg("scenario"), py::arg("set") = py::none(),
        "Runs a scenario (a name from `ehpt list` or a .toml path) as `ehpt run` does, with the built-in ECU,\n"
        "into memory. set: {\"dotted.key\": value}, as --set key=value. A scenario that does not load raises\n"
        "ValueError (every problem, each naming its key); a run-time fault returns with exit_code 3.");

  py::class_<PySimulation>(m, "Simulation",
                           "A loaded scenario to step. external_ecu=True: no built-in ECU; at every ECU sample\n"
                           "(every ecu_period_steps steps from step 0) step() returns, you read_sensors() and\n"
                           "write_command(), and the command acts from that step on: the lockstep protocol of a bus\n"
                           "ECU, so an ECU that computes what the built-in one does reproduces its run bit for bit.")
      .def(py::init<const std::string&, const py::object&, bool, std::int64_t>(), py::arg("scenario"),
           py::arg("set") = py::none(), py::arg("external_ecu") = false, py::arg("chunk_steps") = 50000)
      .def("step", &PySimulation::step, py::arg("n"),
           "Up to n steps (1 <= n <= chunk_steps); with external_ecu it stops early at an ECU sample. Returns the\n"
           "steps taken (0 once finished).")
      .def("run", &PySimulation::run, "Steps to the end; returns the steps taken.")
      .def("read_sensors", &PySimulation::read_sensors, "The sensor message now (PsdSensors or EvSensors), stamped.")
      .def("write_command", &PySimulation::write_command, py::arg("command"),
           "PsdCommand or EvCommand (TypeError if not this vehicle's); acts from the current step on.")
      .def("outputs", &PySimulation::outputs,
           "Every signal at the last grid point observed, {name: float}. With external_ecu, stopped at a sample\n"
           "step n, that is step n - 1: the outputs at n follow the command (as the built-in ECU's do).")
      .def("timeseries", &PySimulation::timeseries, "The rows recorded so far, as RunResult.timeseries.")
      .def("stats", &PySimulation::stats, "Counters and figures of the run so far.")
      .def_property_readonly("finished", &PySimulation::finished)
      .def_property_readonly("time_s", &PySimulation::time_s)
      .def_property_readonly("step_index", &PySimulation::step_index)
      .def_property_readonly("total_steps", &PySimulation::total_steps)
      .def_property_readonly("chunk_steps", &PySimulation::chunk_steps)
      .def_property_readonly("external_ecu", &PySimulation::external_ecu)
      .def_property_readonly("step_s", &PySimulation::step_s)
      .def_property_readonly("name", &PySimulation::name)
      .def_property_readonly("ecu_period_steps", &PySimulation::ecu_period_steps,
                             "Steps per ECU period (None: no ECU); samples at every multiple from step 0.")
      .def_property_readonly("ecu_parameters", &PySimulation::ecu_params,
                             "The built-in ECU's parameters as loaded (dict; None: no ECU).")
      .def_property_readonly("signals", &PySimulation::signals, "Every signal's name (outputs()).")
      .def_property_readonly("columns", &PySimulation::columns, "The recorded signals (timeseries()).")
      .def("__repr__", [](const PySimulation& s) {
        return "<ehpt.Simulation " + s.name() + " step " + std::to_string(s.step_index()) + "/" +
               std::to_string(s.total_steps()) + (s.external_ecu() ? ", external ECU>" : ">");
      });
}
