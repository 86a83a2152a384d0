// SPDX-License-Identifier: BSD-3-Clause
// The Python module `ehpt` (issue 13 item 5, issue 21 item 7): a thin pybind11 binding of the
// Simulation facade. docs/python.md is its guide, python/ehpt.pyi its type stub.
//
//   ehpt.run(scenario, set=None, cycle=None) -> RunResult      the CLI's `ehpt run`, into memory
//   ehpt.Simulation(scenario, set=None, external_ecu=False, chunk_steps=50000, cycle=None)
//       .step(n), .run(), .read_sensors(), .write_command(cmd), .timeseries(), ...
//   ehpt.PsdSensors / PsdCommand / EvSensors / EvCommand / ShevSensors / ShevCommand / Stamp:
//   the messages of msgs/
//   ehpt.Error (a ValueError) and ehpt.Problem: what is wrong with a scenario, parsed
//
// Everything numeric is computed by the same library code as the CLI (ehpt_hil), so a run
// here equals `ehpt run` bit for bit; this file only converts. The simulation runs with the
// GIL released. The allocation guard's hooks (ehpt_alloc_guard) are not linked: they replace
// malloc for a whole process, which a shared object loaded into Python must never do.

#include <pybind11/eval.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "ecu/ev_follower.hpp"
#include "ecu/psd_ecu.hpp"
#include "ecu/shev_ems.hpp"
#include "hil/bus/bus_family.hpp"
#include "hil/bus/in_process_bus.hpp"
#include "hil/config/config.hpp"
#include "hil/config/scenario.hpp"
#include "hil/diag/provenance.hpp"
#include "hil/run/batch.hpp"
#include "hil/run/simulation.hpp"
#include "msgs/ev.hpp"
#include "msgs/psd.hpp"
#include "msgs/shev.hpp"
#include "msgs/stamp.hpp"

namespace py = pybind11;
using namespace ehpt;

// ---- arguments taken as any object ------------------------------------------------------------

// An argument pybind11 passes on whatever its type, so that the type is checked here with a
// message naming the argument and the type wanted (pybind11's own is "incompatible function
// arguments", the whole overload list). The signature pybind11 writes (help(), the first line
// of each __doc__, compared with python/ehpt.pyi by tests/python/test_stub.py) shows the type
// the argument must have.
#define EHPT_PY_ARG(Name, Shown)                                                      \
  namespace ehpt_py {                                                                 \
  struct Name : py::object {                                                          \
    using py::object::object;                                                         \
    explicit Name(const py::object& o) : py::object(o) {}                             \
    static bool check_(py::handle h) { return h.ptr() != nullptr; }                   \
  };                                                                                  \
  }                                                                                   \
  template <>                                                                         \
  struct pybind11::detail::handle_type_name<ehpt_py::Name> {                          \
    static constexpr auto name = const_name(Shown);                                   \
  };

EHPT_PY_ARG(ScenarioArg, "str | os.PathLike[str]")
EHPT_PY_ARG(SetArg, "dict[str, object] | None")
EHPT_PY_ARG(CycleArg, "tuple[ArrayLike, ArrayLike] | None")
EHPT_PY_ARG(FaultsArg, "Sequence[str] | None")
EHPT_PY_ARG(BoolArg, "bool")
EHPT_PY_ARG(IntArg, "int")
EHPT_PY_ARG(CommandArg, "PsdCommand | EvCommand | ShevCommand")
EHPT_PY_ARG(AnyValue, "object")
// return types that pybind11 would show as "dict", "list" or "object"
EHPT_PY_ARG(FloatDict, "dict[str, float]")
EHPT_PY_ARG(ArrayDict, "dict[str, numpy.ndarray]")
EHPT_PY_ARG(StatsDict, "dict[str, int | float | None]")
EHPT_PY_ARG(SummaryDict, "dict[str, Any]")
EHPT_PY_ARG(VerdictDict, "dict[str, Any] | None")
EHPT_PY_ARG(ParamsDict, "dict[str, Any] | None")
EHPT_PY_ARG(StrList, "list[str]")
EHPT_PY_ARG(SensorsValue, "PsdSensors | EvSensors | ShevSensors")
EHPT_PY_ARG(DataFrameValue, "pandas.DataFrame")
EHPT_PY_ARG(OptionalInt, "int | None")
#undef EHPT_PY_ARG

using namespace ehpt_py;

namespace {

std::string type_name(py::handle v) { return py::type::of(v).attr("__name__").cast<std::string>(); }

// repr(v), cut to a readable length
std::string short_repr(py::handle v) {
  std::string r = py::repr(v).cast<std::string>();
  return r.size() <= 60 ? r : r.substr(0, 57) + "...";
}

[[noreturn]] void wrong_type(const std::string& what, const std::string& wanted, py::handle v) {
  throw py::type_error(what + " must be " + wanted + ", got " + type_name(v) + " " + short_repr(v));
}

std::string scenario_of(const py::object& v, const char* who) {
  if (py::isinstance<py::str>(v)) return v.cast<std::string>();
  if (py::hasattr(v, "__fspath__")) {
    const py::object p = py::module_::import("os").attr("fspath")(v);
    if (py::isinstance<py::str>(p)) return p.cast<std::string>();
  }
  wrong_type(std::string(who) + ": scenario", "a str (a name from `ehpt list` or a .toml path) or an os.PathLike", v);
}

bool bool_of(const py::object& v, const std::string& what) {
  if (py::isinstance<py::bool_>(v)) return v.cast<bool>();
  if (type_name(v) == "bool_" && py::hasattr(v, "item")) return v.attr("item")().cast<bool>();  // numpy.bool_
  wrong_type(what, "a bool (True or False)", v);
}

// An int of any size (numpy ints too, by __index__); a bool or a float is not one.
py::int_ int_of(const py::object& v, const std::string& what) {
  if (!py::isinstance<py::bool_>(v) && (py::isinstance<py::int_>(v) || py::hasattr(v, "__index__"))) {
    return py::int_(py::reinterpret_borrow<py::object>(v));
  }
  wrong_type(what, "an int", v);
}

// ---- ehpt.Error and ehpt.Problem ----------------------------------------------------------------

// Python classes, so that Error is a real exception class (a subclass of ValueError: the type a
// bad scenario raised before it existed) with plain attributes. Parsing is done below in C++.
const char* const kErrorSource = R"PY(
class Problem:
    """One problem ehpt found in a scenario, an override (set=) or a cycle (cycle=).

    Parsed from ehpt's message "where: key = value: message", the line the CLI prints, where
    `where` is "file:line" (the value is in that file), "file (default)" (the key was not given
    and its default does not fit), "--set key=value" (an entry of set=) or
    "<cycle arrays>:index" (a value of cycle=, index 0-based). Attributes, None when the message
    has no such part:

      text     the whole message
      where    its location as written
      file     the file (None for an entry of set=)
      line     int: the line in file (for cycle= the index into the arrays)
      key      the dotted key as the message names it (e.g. "ecu.soc_ref", "driver.cycle")
      column   a table's column ("time_s", "speed_m_s" of a cycle), else None
      value    the value as the message writes it (text, e.g. "1.5" or '"x.csv"')
      message  what is expected of the value (e.g. "must be in [0, 1]")
    """

    __slots__ = {
        "text": "The whole message (str).",
        "where": "Its location as written: file:line, file (default), --set key=value (str or None).",
        "file": "The file the value is in (None for an entry of set=).",
        "line": "The line in file, an int (for cycle= the 0-based index into the arrays), or None.",
        "key": "The dotted key as the message names it, or None.",
        "column": "The table column of a table's value (a cycle's time_s or speed_m_s), or None.",
        "value": "The value as the message writes it (text), or None.",
        "message": "What is expected of the value (or the whole message when it has no key).",
    }

    def __init__(self, text, where=None, file=None, line=None, key=None, column=None, value=None, message=None):
        """Every part as parsed (ehpt makes these; you read them)."""
        self.text, self.where, self.file, self.line = text, where, file, line
        self.key, self.column, self.value, self.message = key, column, value, message

    def __repr__(self):
        return "ehpt.Problem(" + repr(self.text) + ")"

    def __str__(self):
        return self.text


class Error(ValueError):
    """What ehpt raises when a scenario cannot run: a bad scenario name or file, an unknown key or a
    bad value in it or in set=, a bad cycle (file or cycle= arrays), a bad vehicle file.

    str(error) is what the CLI prints: "NAME: N problems; nothing was run:" and one line per
    problem. problems: every problem, as ehpt.Problem, in the order found. file, line, key,
    column, value, message, where, text: those of the first problem (see ehpt.Problem).
    A subclass of ValueError: `except ValueError` catches it too.
    """

    def __init__(self, text, problems=()):
        """text: the message; problems: the ehpt.Problem list (ehpt makes these)."""
        super().__init__(text)
        self.problems = list(problems)
        first = self.problems[0] if self.problems else Problem(text, message=text)
        self.text, self.where, self.file, self.line = first.text, first.where, first.file, first.line
        self.key, self.column, self.value, self.message = first.key, first.column, first.value, first.message
)PY";

py::object g_problem_class, g_error_class;  // set once in PYBIND11_MODULE, kept for the process

// One message "where: key[, column C][ = value]: message" (hil/config/config_reader.hpp,
// Context::error), split into its parts. overrides: the run's --set texts, to find where a
// "--set key=value: ..." location ends (the value may hold ": ").
struct ParsedProblem {
  std::string text;
  std::optional<std::string> where, file, key, column, value, message;
  std::optional<long> line;
};

// The end of a value written from position j (a quoted string, an array, or up to ": ").
std::size_t value_end(const std::string& s, std::size_t j) {
  if (j >= s.size()) return std::string::npos;
  if (s[j] == '"' || s[j] == '\'') {
    for (std::size_t k = j + 1; k < s.size(); ++k) {
      if (s[j] == '"' && s[k] == '\\') {
        ++k;
      } else if (s[k] == s[j]) {
        return k + 1;
      }
    }
    return std::string::npos;
  }
  if (s[j] == '[') {
    int depth = 0;
    char quote = 0;
    for (std::size_t k = j; k < s.size(); ++k) {
      if (quote != 0) {
        if (quote == '"' && s[k] == '\\') {
          ++k;
        } else if (s[k] == quote) {
          quote = 0;
        }
      } else if (s[k] == '"' || s[k] == '\'') {
        quote = s[k];
      } else if (s[k] == '[') {
        ++depth;
      } else if (s[k] == ']' && --depth == 0) {
        return k + 1;
      }
    }
    return std::string::npos;
  }
  return s.find(": ", j);
}

// rest = "key[, column C][ = value]: message"; anything else is a message without a key.
void parse_key_value(const std::string& rest, ParsedProblem& p) {
  const auto key_char = [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '.' || c == '[' || c == ']' || c == '-';
  };
  std::size_t i = 0;
  if (!rest.empty() && (std::isalpha(static_cast<unsigned char>(rest[0])) != 0 || rest[0] == '_')) {
    while (i < rest.size() && key_char(rest[i])) ++i;
  }
  const std::size_t key_end = i;
  std::optional<std::string> column;
  if (i > 0 && rest.compare(i, 9, ", column ") == 0) {
    const std::size_t j = i + 9;
    const std::size_t end = std::min(rest.find(" = ", j), rest.find(": ", j));
    if (end != std::string::npos) {
      column = rest.substr(j, end - j);
      i = end;
    }
  }
  if (i > 0 && rest.compare(i, 2, ": ") == 0) {
    p.key = rest.substr(0, key_end);
    p.column = column;
    p.message = rest.substr(i + 2);
    return;
  }
  if (i > 0 && rest.compare(i, 3, " = ") == 0) {
    const std::size_t end = value_end(rest, i + 3);
    if (end != std::string::npos && rest.compare(end, 2, ": ") == 0) {
      p.key = rest.substr(0, key_end);
      p.column = column;
      p.value = rest.substr(i + 3, end - i - 3);
      p.message = rest.substr(end + 2);
      return;
    }
  }
  p.message = rest;
}

ParsedProblem parse_problem(const std::string& s, const std::vector<std::string>& overrides) {
  ParsedProblem p;
  p.text = s;
  std::string rest;
  std::size_t set_end = 0;  // the longest "--set TEXT" the message starts with, as parse_override labels it
  if (s.rfind("--set ", 0) == 0) {
    for (const std::string& o : overrides) {
      const std::string head = "--set " + (o.size() <= 200 ? o : o.substr(0, 80) + "...");
      if (head.size() > set_end && s.compare(0, head.size(), head) == 0 && s.compare(head.size(), 2, ": ") == 0) {
        set_end = head.size();
      }
    }
  }
  if (set_end > 0) {
    p.where = s.substr(0, set_end);
    rest = s.substr(set_end + 2);
  } else {
    const std::size_t i = s.find(": ");
    if (i == std::string::npos) {
      p.message = s;
      return p;
    }
    const std::string w = s.substr(0, i);
    p.where = w;
    rest = s.substr(i + 2);
    const std::string by_default = " (default)";
    const std::size_t colon = w.rfind(':');
    if (w.size() > by_default.size() && w.ends_with(by_default)) {
      p.file = w.substr(0, w.size() - by_default.size());
    } else if (colon != std::string::npos && colon + 1 < w.size() && colon + 10 > w.size() &&
               std::all_of(w.begin() + static_cast<std::ptrdiff_t>(colon) + 1, w.end(),
                           [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; })) {
      p.file = w.substr(0, colon);
      p.line = std::stol(w.substr(colon + 1));
    } else {
      p.file = w;
    }
  }
  parse_key_value(rest, p);
  return p;
}

// Text from files and paths as a Python str: bytes that are not UTF-8 (a Latin-1 folder name)
// come back as they were (surrogateescape, as Python itself decodes file names), never a
// UnicodeDecodeError after the run.
py::str text_of(const std::string& s) {
  PyObject* o = PyUnicode_DecodeUTF8(s.data(), static_cast<Py_ssize_t>(s.size()), "surrogateescape");
  if (o == nullptr) throw py::error_already_set();
  return py::reinterpret_steal<py::str>(o);
}

py::object optional_text(const std::optional<std::string>& v) { return v ? py::object(text_of(*v)) : py::object(py::none()); }

// Raises ehpt.Error(text, problems).
[[noreturn]] void raise_error(const std::string& text, const std::vector<ParsedProblem>& problems) {
  py::list list;
  for (const ParsedProblem& p : problems) {
    list.append(g_problem_class(text_of(p.text), optional_text(p.where), optional_text(p.file),
                                p.line ? py::object(py::int_(*p.line)) : py::object(py::none()), optional_text(p.key),
                                optional_text(p.column), optional_text(p.value), optional_text(p.message)));
  }
  const py::object error = g_error_class(text_of(text), list);
  PyErr_SetObject(g_error_class.ptr(), error.ptr());
  throw py::error_already_set();
}

// One ehpt.Problem per message, parsed.
[[noreturn]] void raise_error(const std::string& text, const std::vector<std::string>& problems,
                              const std::vector<std::string>& overrides) {
  std::vector<ParsedProblem> parsed;
  for (const std::string& m : problems) parsed.push_back(parse_problem(m, overrides));
  raise_error(text, parsed);
}

[[noreturn]] void raise_error(const std::string& message) { raise_error(message, {message}, {}); }

// A problem with an argument itself (where: "set", "scenario"), not with a file's value.
[[noreturn]] void raise_argument_error(const std::string& where, const std::string& key, const std::string& value,
                                       const std::string& message) {
  ParsedProblem p;
  p.text = where + ": " + key + (value.empty() ? "" : " = " + value) + ": " + message;
  p.where = where;
  p.key = key;
  if (!value.empty()) p.value = value;
  p.message = message;
  raise_error(p.text, std::vector<ParsedProblem>{p});
}

std::string joined(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& l : lines) s += (s.empty() ? "" : "\n") + l;
  return s;
}

// name_error: the scenario name is the problem (load's): key "scenario", the name its value.
[[noreturn]] void throw_load_errors(const std::string& name, const std::vector<std::string>& errors,
                                    const std::vector<std::string>& overrides, bool name_error) {
  std::string shown = name;  // a NUL would end the message there
  for (std::size_t at = shown.find('\0'); at != std::string::npos; at = shown.find('\0', at)) shown.replace(at, 1, "\\0");
  const std::string text = shown + ": " + std::to_string(errors.size()) + (errors.size() == 1 ? " problem" : " problems") +
                           "; nothing was run:\n" + joined(errors);
  std::vector<ParsedProblem> parsed;
  for (const std::string& m : errors) {
    ParsedProblem p = parse_problem(m, overrides);
    if (name_error) {
      p = ParsedProblem{};
      p.text = m;
      p.key = "scenario";
      p.value = shown;
      p.message = m.rfind(name + ": ", 0) == 0 ? m.substr(name.size() + 2) : m;
    }
    parsed.push_back(p);
  }
  raise_error(text, parsed);
}

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
  throw py::type_error("set[\"" + key + "\"]: a value of type " + type_name(v) +
                       " cannot be a scenario value (bool, int, float, str or a list of them)");
}

std::vector<std::string> overrides_of(const py::object& set) {
  std::vector<std::string> out;
  if (set.is_none()) return out;
  if (!py::isinstance<py::dict>(set)) wrong_type("set", "a dict {\"dotted.key\": value} or None", set);
  for (const auto& [k, v] : set.cast<py::dict>()) {
    if (!py::isinstance<py::str>(k)) throw py::type_error("set: keys must be str, got " + short_repr(k));
    const std::string key = k.cast<std::string>();
    // one key per entry: an '=' would be read as the end of the key
    if (key.empty() || key.find_first_of(std::string("=\r\n\0", 4)) != std::string::npos) {
      raise_argument_error("set", py::repr(k).cast<std::string>(), "", "not a dotted key (e.g. \"vehicle.ecu.soc_ref\")");
    }
    out.push_back(key + "=" + toml_value(v, key));
  }
  return out;
}

// ---- cycle=(t_s, v_m_s) ---------------------------------------------------------------------------

// Two 1-D arrays of numbers -> hil::CycleArrays; the rules on the numbers (finite, time
// non-decreasing, >= 2 points, the same length, speeds in range) are the cycle file's, applied
// by load_scenario_with_cycle. Here only what makes them numbers: a pair, 1-D, int or float.
std::optional<hil::CycleArrays> cycle_of(const py::object& cycle) {
  if (cycle.is_none()) return std::nullopt;
  if (!(py::isinstance<py::tuple>(cycle) || py::isinstance<py::list>(cycle)) || py::len(cycle) != 2) {
    wrong_type("cycle", "a pair (t_s, v_m_s) of 1-D arrays (time in s, speed in m/s) or None", cycle);
  }
  hil::CycleArrays a;
  const py::object asarray = py::module_::import("numpy").attr("asarray");
  const char* names[2] = {"t_s", "v_m_s"};
  std::vector<double>* into[2] = {&a.time_s, &a.speed_m_s};
  for (int k = 0; k < 2; ++k) {
    const std::string head = a.name + ": cycle = (t_s, v_m_s): " + names[k];
    py::array arr;
    try {
      arr = asarray(cycle.cast<py::sequence>()[static_cast<std::size_t>(k)]);
    } catch (py::error_already_set& e) {  // a ragged list, say
      if (!e.matches(PyExc_ValueError) && !e.matches(PyExc_TypeError)) throw;
      raise_error(head + " is not an array of numbers (" + std::string(e.what()) + ")");
    }
    const char kind = arr.dtype().kind();
    if (kind != 'i' && kind != 'u' && kind != 'f') {
      raise_error(head + " must hold numbers (int or float), not dtype " + py::str(arr.dtype()).cast<std::string>());
    }
    if (arr.ndim() != 1) {
      raise_error(head + " must be a 1-D array, not one of shape " + py::str(py::getattr(arr, "shape")).cast<std::string>());
    }
    const auto d = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(arr);
    into[k]->assign(d.data(), d.data() + d.size());
  }
  return a;
}

// ---- loading -------------------------------------------------------------------------------

// The scenario (a name or a path) with its overrides, as `ehpt run` loads it, and the cycle
// given as arrays, if any. Called without the GIL (it reads files); the errors come back as
// text, turned into an ehpt.Error by the caller.
// name_error: the name itself is the problem (no such scenario), errors holds that one message.
bool load(const std::string& name, const std::vector<std::string>& overrides, const std::optional<hil::CycleArrays>& cycle,
          hil::Scenario& sc, std::vector<std::string>& errors, bool& name_error,
          const std::vector<std::string>& faults = {}, bool bus_faults_ok = false) {
  // a C string would end at a NUL: "ev_nedc.toml\0junk" must not run ev_nedc.toml
  if (name.find('\0') != std::string::npos) {
    errors.push_back("the scenario name contains a NUL character");
    name_error = true;
    return false;
  }
  std::string reason;
  const std::string path = hil::resolve_scenario(name, reason);
  if (path.empty()) {
    errors.push_back(name + ": " + reason);
    name_error = true;
    return false;
  }
  if (cycle && !faults.empty()) {
    errors.push_back("faults and cycle arrays together are not supported yet: put the faults in a test file's "
                     "[[fault]] tables, or give the cycle as a file");
    return false;
  }
  if (!(cycle ? hil::load_scenario_with_cycle(path, overrides, *cycle, sc, errors)
              : hil::load_scenario(path, overrides, faults, sc, errors))) {
    return false;
  }
  if (bus_faults_ok || !hil::has_bus_faults(sc)) return true;
  // a Simulation calls its ECU (or takes yours) directly: no frames for a bus fault to act on
  const auto f = std::find_if(sc.faults.begin(), sc.faults.end(), [](const hil::FaultSpec& x) { return x.side == hil::FaultSide::kBus; });
  errors.push_back(f->where + ": kind = \"" + hil::fault_effect_name(f->effect) + "\" on " + f->target +
                   " acts on CAN frames, and a Simulation steps the plant with its commands passed directly, no frames "
                   "between them: ehpt.run(...) takes bus faults (the built-in ECU on an in-process CAN bus), as do "
                   "`ehpt run` and `ehpt test`");
  return false;
}

// faults=None or a list of str, each as `ehpt run --fault` takes it ("kind=stuck target=batSOC
// at_s=300"); anything else is a TypeError naming the argument.
std::vector<std::string> faults_of(const py::object& faults, const char* where) {
  std::vector<std::string> out;
  if (faults.is_none()) return out;
  if (!py::isinstance<py::list>(faults) && !py::isinstance<py::tuple>(faults)) {
    throw py::type_error(std::string(where) + ": faults must be None or a list of str such as "
                         "[\"kind=stuck target=batSOC at_s=300\"], got " + py::str(faults.get_type().attr("__name__")).cast<std::string>());
  }
  for (const py::handle f : faults) {
    if (!py::isinstance<py::str>(f)) {
      throw py::type_error(std::string(where) + ": every fault is a str (key=value pairs, as ehpt run --fault), got " +
                           py::str(f.get_type().attr("__name__")).cast<std::string>());
    }
    out.push_back(f.cast<std::string>());
  }
  return out;
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

// {name: array} -> a pandas DataFrame: a column per signal in order, indexed by time_s (the
// column moves to the index) when it was recorded, else by row number.
DataFrameValue dataframe_of(const py::dict& series, const char* who) {
  py::module_ pd;
  try {
    pd = py::module_::import("pandas");
  } catch (py::error_already_set& e) {
    if (!e.matches(PyExc_ImportError)) throw;
    PyErr_SetString(PyExc_ImportError, (std::string(who) + ".to_dataframe() needs pandas, which this Python cannot import (" +
                                        e.what() + "); on Debian: apt-get install python3-pandas")
                                           .c_str());
    throw py::error_already_set();
  }
  py::dict data;
  py::object index = py::none();
  for (const auto& [name, values] : series) {
    if (name.cast<std::string>() == "time_s") {
      index = pd.attr("Index")(values, py::arg("name") = "time_s");
    } else {
      data[name] = values;
    }
  }
  return DataFrameValue(pd.attr("DataFrame")(data, py::arg("index") = index));
}

struct RunResult {
  py::object summary;     // dict: summary.json as json.loads reads it (NaN is null -> None)
  py::list columns;       // timeseries.csv's header
  py::dict timeseries;    // name -> float64 array
  int exit_code = 0;      // 0 ok, 3 run-time fault (outputs kept), 4 degraded, 5 a test failed, 128 + signal
  py::list warnings;
  py::str text;           // the lines `ehpt run` prints
};

RunResult run(const ScenarioArg& scenario_arg, const SetArg& set, const CycleArg& cycle_arg, const FaultsArg& faults_arg) {
  const std::string scenario = scenario_of(scenario_arg, "run()");
  const std::vector<std::string> overrides = overrides_of(set);
  const std::vector<std::string> faults = faults_of(faults_arg, "run()");
  const std::optional<hil::CycleArrays> cycle = cycle_of(cycle_arg);
  hil::Scenario sc;
  std::vector<std::string> errors;
  hil::MemoryRun mr;
  bool loaded = false, name_error = false;
  {
    py::gil_scoped_release released;
    loaded = load(scenario, overrides, cycle, sc, errors, name_error, faults, true);
    std::unique_ptr<hil::ExternalDriver> bus;  // bus faults: the built-in ECU on an in-process CAN bus
    if (loaded && hil::has_bus_faults(sc)) {
      std::string error;
      hil::BusPlantOptions bo;
      bo.scenario_path = sc.path;
      bo.overrides = overrides;
      bo.faults = faults;
      bus = hil::make_in_process_bus(sc, bo, error);
      if (!bus) {
        errors.push_back(error);
        loaded = false;
      }
    }
    if (loaded) mr = hil::run_in_memory(sc, nullptr, bus.get());
  }
  if (!loaded) throw_load_errors(scenario, errors, overrides, name_error);
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

// A message struct as a Python class: a property per member, keyword construction
// (PsdCommand(motTauRef_Nm=10.0); an unknown name is a TypeError), __repr__, __eq__, _fields.
// A value of the wrong type is a TypeError naming the class, the field and the type wanted.
// defaults: what PsdCommand() holds (for commands the safe state, not the C++ struct's
// default: make_message_classes).
template <class T>
class MessageClass {
 public:
  MessageClass(py::module_& m, const char* name, const char* doc, T defaults = T{})
      : cls_(m, name, doc), name_(name), defaults_(defaults) {}
  template <class V>
  MessageClass& field(const char* name, V T::*member, const char* type, const char* doc) {
    const std::string what = name_ + "." + name;
    const std::string wanted = type;
    cls_.def_property(
        name, [member](T& self) -> V& { return self.*member; },
        [member, what, wanted](T& self, const AnyValue& v) {
          // pybind11 would take 1 for a bool, and 1.5 for an int field would be its TypeError
          const bool is_bool = py::isinstance<py::bool_>(v);
          bool ok = true;
          if constexpr (std::is_same_v<V, bool>) {
            ok = is_bool || type_name(v) == "bool_";  // numpy.bool_ too
          } else if constexpr (std::is_floating_point_v<V>) {
            ok = !is_bool && (py::isinstance<py::float_>(v) || py::isinstance<py::int_>(v) || py::hasattr(v, "__float__"));
          } else if constexpr (std::is_integral_v<V>) {
            ok = !is_bool && (py::isinstance<py::int_>(v) || py::hasattr(v, "__index__"));
          }
          if (ok) {
            try {
              self.*member = v.cast<V>();
              return;
            } catch (const py::cast_error&) {  // an int out of the field's range, a Stamp of another class
            }
          }
          throw py::type_error(what + ": " + short_repr(v) + " is not " + wanted);
        },
        py::return_value_policy::reference_internal, doc);
    names_.push_back(name);
    return *this;
  }
  void finish() {
    const std::vector<std::string> names = names_;
    const std::string cls = name_;
    const T defaults = defaults_;
    cls_.def(py::init([names, cls, defaults](const py::kwargs& kw) {
               T value = defaults;
               const py::object self = py::cast(&value, py::return_value_policy::reference);
               for (const auto& [k, v] : kw) {
                 const std::string key = py::str(k);
                 if (std::find(names.begin(), names.end(), key) == names.end()) {
                   throw py::type_error(cls + "() has no field '" + key + "' (fields: " + joined_names(names) + ")");
                 }
                 self.attr(k) = v;
               }
               return value;
             }),
             ("Keyword arguments set fields by name (" + joined_names(names) + "); the others keep their defaults.").c_str());
    cls_.def(
        "__repr__",
        [names, cls](const py::object& self) {
          std::string s = cls + "(";
          for (std::size_t i = 0; i < names.size(); ++i) {
            s += (i ? ", " : "") + names[i] + "=" + py::repr(self.attr(names[i].c_str())).template cast<std::string>();
          }
          return s + ")";
        },
        "Every field, as keyword arguments that make this message again.");
    cls_.def(
        "__eq__",
        [names](const py::object& self, const py::object& other) -> py::object {
          if (!py::type::of(self).is(py::type::of(other))) return py::reinterpret_borrow<py::object>(Py_NotImplemented);
          for (const auto& n : names) {
            if (!self.attr(n.c_str()).equal(other.attr(n.c_str()))) return py::bool_(false);
          }
          return py::bool_(true);
        },
        "Equal when every field is.");
    cls_.attr("__hash__") = py::none();  // mutable
    py::tuple fields(names.size());
    for (std::size_t i = 0; i < names.size(); ++i) fields[i] = py::str(names[i]);
    cls_.attr("_fields") = fields;
  }

 private:
  static std::string joined_names(const std::vector<std::string>& names) {
    std::string s;
    for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
    return s;
  }
  py::class_<T> cls_;
  std::string name_;
  T defaults_;
  std::vector<std::string> names_;
};

// A command made in Python starts in the bus plant's safe state (hil/bus/bus_family.hpp
// make_safe: every torque and power reference 0) with the engine off: a forgotten field asks
// nothing of the machine. (The C++ struct's iceON default is true, the plant's start state.)
msgs::PsdCommand safe_psd_command() {
  msgs::PsdCommand c{};
  hil::BusFamily<msgs::PsdSensors>::make_safe(c);
  c.iceON = false;
  return c;
}

msgs::EvCommand safe_ev_command() {
  msgs::EvCommand c{};
  hil::BusFamily<msgs::EvSensors>::make_safe(c);
  return c;
}

msgs::ShevCommand safe_shev_command() {
  msgs::ShevCommand c{};
  hil::BusFamily<msgs::ShevSensors>::make_safe(c);
  c.gensetON = false;
  return c;
}

void bind_messages(py::module_& m) {
  using namespace msgs;
  const char* per_sender = "per sender, +1 per message (wraps at 2**32)";
  MessageClass<Stamp>(m, "Stamp", "Simulation time and step of a sample, and the sender's sequence number (msgs/stamp.hpp).")
      .field("time_s", &Stamp::time_s, "a float", "Simulation time of the sample, s.")
      .field("step", &Stamp::step, "an int", "Plant step index of the sample.")
      .field("sequence", &Stamp::sequence, "an int in [0, 2**32)", per_sender)
      .finish();
  MessageClass<PsdSensors>(m, "PsdSensors", "Power-split hybrid, plant -> ECU, sampled at the start of an ECU period (msgs/psd.hpp).")
      .field("stamp", &PsdSensors::stamp, "an ehpt.Stamp", "The sample's time, step and sequence number.")
      .field("driverRequest", &PsdSensors::driverRequest, "a float", "Driver's torque request, per unit (-1.8..1.8).")
      .field("speed_m_s", &PsdSensors::speed_m_s, "a float", "Vehicle speed, m/s.")
      .field("iceW_rad_s", &PsdSensors::iceW_rad_s, "a float", "Engine speed, rad/s.")
      .field("icePowDel_W", &PsdSensors::icePowDel_W, "a float", "Power at the engine flange, after its inertia, W.")
      .field("genW_rad_s", &PsdSensors::genW_rad_s, "a float", "Generator (sun) speed, rad/s.")
      .field("genPowDel_W", &PsdSensors::genPowDel_W, "a float", "Power the generator delivers at its flange, W.")
      .field("genTauLim_Nm", &PsdSensors::genTauLim_Nm, "a float", "Most torque the generator can deliver at its speed, N m.")
      .field("motW_rad_s", &PsdSensors::motW_rad_s, "a float", "Motor (ring) speed, rad/s.")
      .field("motPowDelA_W", &PsdSensors::motPowDelA_W, "a float", "Power the motor delivers through flange A (ring side), W.")
      .field("motPowDelB_W", &PsdSensors::motPowDelB_W, "a float", "Power the motor delivers through flange B (final gear): traction power, W.")
      .field("motPowDelAB_W", &PsdSensors::motPowDelAB_W, "a float", "motPowDelA_W + motPowDelB_W, W.")
      .field("motTauLim_Nm", &PsdSensors::motTauLim_Nm, "a float", "Most torque the motor can deliver at its speed, N m.")
      .field("batSOC", &PsdSensors::batSOC, "a float", "Battery state of charge, fraction (0..1).")
      .field("batPowDel_W", &PsdSensors::batPowDel_W, "a float", "Battery terminal power, W.")
      .field("battery_voltage_V", &PsdSensors::battery_voltage_V, "a float", "Battery terminal voltage, V.")
      .field("battery_current_A", &PsdSensors::battery_current_A, "a float", "Battery terminal current, A (> 0 discharging).")
      .field("fault", &PsdSensors::fault, "an int in [0, 2**32)", "Fault bits (plant::Fault); 0: none.")
      .field("locked", &PsdSensors::locked, "a bool", "True while the vehicle is held at standstill.")
      .finish();
  MessageClass<PsdCommand>(m, "PsdCommand",
                           "Power-split hybrid, ECU -> plant, held until the next command (msgs/psd.hpp).\n\n"
                           "PsdCommand() is the safe state: every reference 0 and iceON=False (engine off).",
                           safe_psd_command())
      .field("stamp", &PsdCommand::stamp, "an ehpt.Stamp", "The stamp of the sensor sample the command was computed from.")
      .field("icePowRef_W", &PsdCommand::icePowRef_W, "a float", "Power the engine is asked to deliver, W (power-input engines). Default 0.")
      .field("iceTauRef_Nm", &PsdCommand::iceTauRef_Nm, "a float", "Torque the engine is asked to deliver, N m (torque-input engines). Default 0.")
      .field("genTauRef_Nm", &PsdCommand::genTauRef_Nm, "a float", "Torque asked of the generator, N m. Default 0.")
      .field("motTauRef_Nm", &PsdCommand::motTauRef_Nm, "a float", "Torque asked of the motor, N m. Default 0.")
      .field("iceON", &PsdCommand::iceON, "a bool", "Engine on (ON/OFF engines only). Default False.")
      .finish();
  MessageClass<EvSensors>(m, "EvSensors", "Battery-electric vehicle, plant -> ECU, sampled at the start of an ECU period (msgs/ev.hpp).")
      .field("stamp", &EvSensors::stamp, "an ehpt.Stamp", "The sample's time, step and sequence number.")
      .field("driverRequest_Nm", &EvSensors::driverRequest_Nm, "a float", "Driver's torque request at the drive shaft, N m.")
      .field("speed_m_s", &EvSensors::speed_m_s, "a float", "Vehicle speed, m/s.")
      .field("driveW_rad_s", &EvSensors::driveW_rad_s, "a float", "Drive shaft speed, rad/s.")
      .field("driveTauLim_Nm", &EvSensors::driveTauLim_Nm, "a float", "Most torque the drive can deliver at its speed, N m.")
      .field("drivePowDel_W", &EvSensors::drivePowDel_W, "a float", "Mechanical power the drive delivers (torque x speed), W.")
      .field("batSOC", &EvSensors::batSOC, "a float", "Battery state of charge, fraction (0..1).")
      .field("batPowDel_W", &EvSensors::batPowDel_W, "a float", "Battery terminal power, W.")
      .field("battery_voltage_V", &EvSensors::battery_voltage_V, "a float", "Battery terminal voltage, V.")
      .field("battery_current_A", &EvSensors::battery_current_A, "a float", "Battery terminal current, A (> 0 discharging).")
      .field("fault", &EvSensors::fault, "an int in [0, 2**32)", "Fault bits (plant::Fault); 0: none.")
      .field("locked", &EvSensors::locked, "a bool", "True while the vehicle is held at standstill.")
      .finish();
  MessageClass<EvCommand>(m, "EvCommand",
                          "Battery-electric vehicle, ECU -> plant, held until the next command (msgs/ev.hpp).\n\n"
                          "EvCommand() is the safe state: no torque asked.",
                          safe_ev_command())
      .field("stamp", &EvCommand::stamp, "an ehpt.Stamp", "The stamp of the sensor sample the command was computed from.")
      .field("driveTauRef_Nm", &EvCommand::driveTauRef_Nm, "a float", "Torque asked of the drive, N m (the limiter may cut it). Default 0.")
      .finish();
  MessageClass<ShevSensors>(m, "ShevSensors", "Series hybrid, plant -> ECU, sampled at the start of an ECU period (msgs/shev.hpp).")
      .field("stamp", &ShevSensors::stamp, "an ehpt.Stamp", "The sample's time, step and sequence number.")
      .field("driverRequest_Nm", &ShevSensors::driverRequest_Nm, "a float", "Driver's torque request at the drive shaft, N m.")
      .field("speed_m_s", &ShevSensors::speed_m_s, "a float", "Vehicle speed, m/s.")
      .field("driveW_rad_s", &ShevSensors::driveW_rad_s, "a float", "Drive shaft speed, rad/s.")
      .field("driveTauLim_Nm", &ShevSensors::driveTauLim_Nm, "a float", "Most torque the drive can deliver at its speed, N m.")
      .field("drivePowDc_W", &ShevSensors::drivePowDc_W, "a float", "DC power the drive draws from the bus (the EMS's input), W.")
      .field("gensetW_rad_s", &ShevSensors::gensetW_rad_s, "a float", "Genset (engine) shaft speed, rad/s.")
      .field("gensetPowDc_W", &ShevSensors::gensetPowDc_W, "a float", "DC power the genset delivers to the bus (> 0 generating), W.")
      .field("batSOC", &ShevSensors::batSOC, "a float", "Battery state of charge, fraction (0..1).")
      .field("batPowDel_W", &ShevSensors::batPowDel_W, "a float", "Battery terminal power, W.")
      .field("battery_voltage_V", &ShevSensors::battery_voltage_V, "a float", "Battery terminal voltage, V.")
      .field("battery_current_A", &ShevSensors::battery_current_A, "a float", "Battery terminal current, A (> 0 discharging).")
      .field("fault", &ShevSensors::fault, "an int in [0, 2**32)", "Fault bits (plant::Fault); 0: none.")
      .field("locked", &ShevSensors::locked, "a bool", "True while the vehicle is held at standstill.")
      .finish();
  MessageClass<ShevCommand>(m, "ShevCommand",
                            "Series hybrid, ECU -> plant, held until the next command (msgs/shev.hpp).\n\n"
                            "ShevCommand() is the safe state: no torque, no genset power, gensetON=False.",
                            safe_shev_command())
      .field("stamp", &ShevCommand::stamp, "an ehpt.Stamp", "The stamp of the sensor sample the command was computed from.")
      .field("driveTauRef_Nm", &ShevCommand::driveTauRef_Nm, "a float", "Torque asked of the drive, N m (the limiter may cut it). Default 0.")
      .field("gensetPowRef_W", &ShevCommand::gensetPowRef_W, "a float", "DC power asked of the genset, W (its GMS takes < 0 as 0). Default 0.")
      .field("gensetON", &ShevCommand::gensetON, "a bool", "Genset on (ON/OFF gensets only; a plain genset always runs). Default False.")
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
  } else if (const auto* sh = sc.ecu.get_if<ecu::ShevEmsParams>()) {
    d["kind"] = ecu::ecu_name(sh->kind);
    d["power_filter_s"] = sh->power_filter_s;
    d["power_filter_initial_W"] = sh->power_filter_initial_W;
    d["power_max_W"] = sh->power_max_W;
    d["soc_ref"] = sh->soc_ref;
    d["soc_gain_W"] = sh->soc_gain_W;
    d["on_W"] = sh->on_W;
    d["off_W"] = sh->off_W;
  } else if (sc.ecu.holds<ecu::EvFollowerParams>()) {
    d["kind"] = "follower";
  } else {
    return py::none();
  }
  return d;
}

// ---- Simulation ----------------------------------------------------------------------------

enum class Family { kNone, kPsd, kEv, kShev };

class PySimulation {
 public:
  PySimulation(const ScenarioArg& scenario_arg, const SetArg& set, const BoolArg& external_ecu,
               const IntArg& chunk_steps_arg, const CycleArg& cycle_arg, const FaultsArg& faults_arg)
      : external_(bool_of(external_ecu, "Simulation(): external_ecu")) {
    const std::string scenario = scenario_of(scenario_arg, "Simulation()");
    // the row buffer holds chunk_steps rows of every column: bounded, so that a typo cannot ask
    // for terabytes (1 000 000 rows of 60 columns: 480 MB)
    constexpr std::int64_t kMaxChunkSteps = 1'000'000;
    const py::int_ chunk = int_of(chunk_steps_arg, "Simulation(): chunk_steps");
    int overflow = 0;
    const long long chunk_steps = PyLong_AsLongLongAndOverflow(chunk.ptr(), &overflow);
    if (overflow != 0 || chunk_steps < 1 || chunk_steps > kMaxChunkSteps) {
      throw py::value_error("chunk_steps must be in [1, " + std::to_string(kMaxChunkSteps) + "], got " +
                            py::repr(chunk).cast<std::string>());
    }
    const std::vector<std::string> overrides = overrides_of(set);
    const std::optional<hil::CycleArrays> cycle = cycle_of(cycle_arg);
    const std::vector<std::string> faults = faults_of(faults_arg, "Simulation()");
    std::vector<std::string> errors;
    bool loaded = false, name_error = false;
    {
      py::gil_scoped_release released;
      loaded = load(scenario, overrides, cycle, sc_, errors, name_error, faults);
    }
    if (!loaded) throw_load_errors(scenario, errors, overrides, name_error);
    family_ = sc_.ecu.holds<ecu::PsdEcuParams>()     ? Family::kPsd
              : sc_.ecu.holds<ecu::EvFollowerParams>() ? Family::kEv
              : sc_.ecu.holds<ecu::ShevEmsParams>()    ? Family::kShev
                                                       : Family::kNone;
    if (external_ && family_ == Family::kNone) {
      raise_argument_error(scenario, "external_ecu", "True",
                           "this vehicle has no ECU (a test rig), so there is none to replace");
    }
    if (external_ && sc_.solver.ecu_latency_steps != 0) {
      // the runner applies an external command from its sample on (as a lockstep bus plant)
      raise_argument_error(scenario, "external_ecu", "True",
                           "vehicle.ecu.latency_s belongs to the built-in ECU; with an external ECU the command acts "
                           "from its sample on (set it to 0)");
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
    if (!sc_.faults.empty()) column_names_.emplace_back("faults_active");  // the recorder's last column
    chunk_steps_ = chunk_steps;
  }

  // n as a Python int of any size: one beyond int64 is out of range too (a ValueError, not the
  // TypeError of a failed conversion)
  std::int64_t step(const IntArg& n_arg) {
    const py::int_ n_obj = int_of(n_arg, "step(n): n");
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

  SensorsValue read_sensors() {
    switch (family_) {
      case Family::kPsd: {
        msgs::PsdSensors s;
        sim().read_sensors(s);
        return SensorsValue(py::cast(s));
      }
      case Family::kEv: {
        msgs::EvSensors s;
        sim().read_sensors(s);
        return SensorsValue(py::cast(s));
      }
      case Family::kShev: {
        msgs::ShevSensors s;
        sim().read_sensors(s);
        return SensorsValue(py::cast(s));
      }
      case Family::kNone: break;
    }
    throw py::type_error(sc_.name + ": this vehicle has no ECU messages (a test rig)");
  }

  void write_command(const CommandArg& cmd) {
    // a NaN or an infinity is refused, never applied (as over LCM; CAN cannot carry one)
    const auto refuse_non_finite = [&](bool finite) {
      if (!finite) raise_error(sc_.name + ": write_command(command): a number of the command is not finite (NaN or inf); not applied");
    };
    if (family_ == Family::kPsd && py::isinstance<msgs::PsdCommand>(cmd)) {
      const auto& c = cmd.cast<const msgs::PsdCommand&>();
      refuse_non_finite(msgs::all_finite(c));
      sim().write_command(c);
    } else if (family_ == Family::kEv && py::isinstance<msgs::EvCommand>(cmd)) {
      const auto& c = cmd.cast<const msgs::EvCommand&>();
      refuse_non_finite(msgs::all_finite(c));
      sim().write_command(c);
    } else if (family_ == Family::kShev && py::isinstance<msgs::ShevCommand>(cmd)) {
      const auto& c = cmd.cast<const msgs::ShevCommand&>();
      refuse_non_finite(msgs::all_finite(c));
      sim().write_command(c);
    } else {
      const char* wanted = family_ == Family::kPsd    ? "an ehpt.PsdCommand"
                           : family_ == Family::kEv   ? "an ehpt.EvCommand"
                           : family_ == Family::kShev ? "an ehpt.ShevCommand"
                                                      : "none (a rig has no ECU)";
      wrong_type(sc_.name + ": write_command(command): command", wanted, cmd);
    }
  }

  FloatDict outputs() {
    const std::span<const double> y = sim().outputs();
    py::dict d;
    for (std::size_t i = 0; i < y.size(); ++i) d[py::str(signal_names_[i])] = y[i];
    return FloatDict(d);
  }

  ArrayDict timeseries() const {
    sim();  // not while step() adds rows
    return ArrayDict(columns_of(column_names_, rows_));
  }

  DataFrameValue to_dataframe() const { return dataframe_of(timeseries(), "Simulation"); }

  // The counters and figures the Simulation keeps, for the run so far (summary.json is made by
  // the batch run from more than these: ehpt.run gives it).
  StatsDict stats() const {
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
    return StatsDict(d);
  }

  // summary["test"] of the run as it stands (None: no test); "incomplete" until finished.
  VerdictDict verdict() const {
    hil::Simulation& s = sim();
    const std::string text = hil::test_verdict_json(sc_, s);
    if (text.empty()) return VerdictDict(py::none());
    py::dict d = json_loads(text);
    if (!s.finished()) d["verdict"] = "incomplete";  // never "passed" for a run not yet done
    d["finished"] = s.finished();
    return VerdictDict(d);
  }

  bool finished() const { return sim().finished(); }
  double time_s() const { return sim().time_s(); }
  std::int64_t step_index() const { return sim().step_index(); }
  std::int64_t total_steps() const { return sim().total_steps(); }
  std::int64_t chunk_steps() const { return chunk_steps_; }
  bool external_ecu() const { return external_; }
  double step_s() const { return sc_.solver.step_s; }
  const std::string& name() const { return sc_.name; }
  OptionalInt ecu_period_steps() const {
    return OptionalInt(family_ == Family::kNone ? py::object(py::none()) : py::cast(sc_.solver.ecu_ratio));
  }
  ParamsDict ecu_params() const { return ParamsDict(ecu_parameters(sc_)); }
  StrList signals() const { return StrList(py::cast(signal_names_)); }
  StrList columns() const { return StrList(py::cast(column_names_)); }

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

// ---- docstrings ------------------------------------------------------------------------------

const char* const kRunDoc = R"(Runs a scenario as `ehpt run` does, with the built-in ECU, into memory.

The run equals the CLI's bit for bit (every column, every summary key but the wall-clock ones).

Arguments:
  scenario  a name from `ehpt list` (e.g. "psecu2_nedc") or the path of a scenario .toml
            (str or os.PathLike).
  set       None, or {"dotted.key": value}: overrides, as `--set key=value` (e.g.
            {"vehicle.ecu.soc_ref": 0.62, "solver.duration_s": 100}). Values: bool, int,
            float (sent as its repr, the shortest text that reads back the same), str (stays
            a string) or a list of them.
  cycle     None (the scenario's cycle file), or a pair (t_s, v_m_s) of 1-D arrays of the
            same length: time in s (non-decreasing, >= 2 points) and speed in m/s (finite,
            >= 0, < 200), in place of the scenario's cycle file and checked by the same rules;
            solver.duration_s defaults to the last time, cycle_periodic applies.
  faults    None, or a list of faults, each as `ehpt run --fault` takes it:
            ["kind=stuck target=batSOC at_s=300"] (docs/testing.md); they add to the file's
            [[fault]] tables. A test file's [[expect]] verdict is summary["test"]
            (verdict, expectations with message, time and value), exit_code 5 if one failed;
            timeseries gets a faults_active column. A bus fault (on CAN frames) runs the
            built-in ECU on an in-process CAN bus, summary["bus"] its figures.

Returns:
  RunResult: summary (summary.json as a dict), columns, timeseries ({name: float64 array}),
  exit_code (0 ok; 3 a run-time fault such as SOC out of its window; 4 degraded: with bus
  faults, a command timeout no fault explains; 5 an expectation of a test failed: the outputs
  are kept, nothing is raised), warnings, text; to_dataframe() gives
  a pandas DataFrame.

Raises:
  ehpt.Error (a ValueError) when the scenario does not load: every problem, each with its
  file, line, key, value and message (error.problems); TypeError for an argument of the
  wrong type, naming it.)";

const char* const kSimulationDoc = R"(A loaded scenario to step, with the built-in ECU or with yours.

external_ecu=True: no built-in ECU; at every ECU sample (every ecu_period_steps steps from
step 0) step() returns, you read_sensors() and write_command(), and the command acts from
that step on: the lockstep protocol of a bus ECU, so an ECU that computes what the built-in
one does reproduces its run bit for bit (python/examples/mbecu2_ecu.py).

    sim = ehpt.Simulation("psecu2_nedc", external_ecu=True)
    while not sim.finished:
        s = sim.read_sensors()
        sim.write_command(ehpt.PsdCommand(motTauRef_Nm=80.0 * s.driverRequest))
        sim.step(sim.ecu_period_steps))";

const char* const kSimulationInitDoc = R"(Loads the scenario (nothing runs until step() or run()).

Arguments:
  scenario      a name from `ehpt list` or the path of a scenario .toml (str or os.PathLike).
  set           None, or {"dotted.key": value}: overrides, as for ehpt.run.
  external_ecu  False: the scenario's built-in ECU drives; True: you are the ECU
                (read_sensors / write_command at each sample; a rig has no ECU: ehpt.Error).
  chunk_steps   the most steps one step(n) may take, in [1, 1000000]: the row buffer holds
                that many rows (ValueError outside).
  cycle         None, or a pair (t_s, v_m_s) of 1-D arrays (time in s, speed in m/s) in place
                of the scenario's cycle file, as for ehpt.run.
  faults        None, or a list of faults as for ehpt.run (["kind=offset target=batSOC
                offset=0.05 at_s=10"]): read_sensors() returns the faulted sensors, the plant
                gets the faulted commands; timeseries() gets a faults_active column.

Raises:
  ehpt.Error when the scenario does not load (as ehpt.run); TypeError for an argument of the
  wrong type, naming it.)";

}  // namespace

PYBIND11_MODULE(ehpt, m) {
  m.doc() =
      "ehpt: plant models of electric and hybrid power trains (the CLI's runs, in process).\n\n"
      "    r = ehpt.run(\"psecu2_nedc\", set={\"vehicle.ecu.soc_ref\": 0.62})\n"
      "    r.summary[\"fuel_g\"], r.timeseries[\"speed_m_s\"], r.to_dataframe()\n\n"
      "    sim = ehpt.Simulation(\"psecu2_nedc\", external_ecu=True)   # you are the ECU\n"
      "    while not sim.finished:\n"
      "        s = sim.read_sensors(); sim.write_command(my_ecu(s)); sim.step(sim.ecu_period_steps)\n\n"
      "A scenario that does not load raises ehpt.Error. Guide: docs/python.md.";
  m.attr("__version__") = std::string(hil::build_info().version);

  {
    py::dict ns;
    ns["__name__"] = "ehpt";
    ns["__builtins__"] = py::module_::import("builtins");
    py::exec(kErrorSource, ns);
    g_problem_class = ns["Problem"];
    g_error_class = ns["Error"];
    // kept for the life of the process (a module is never unloaded): no destructor at exit
    g_problem_class.inc_ref();
    g_error_class.inc_ref();
    m.attr("Problem") = g_problem_class;
    m.attr("Error") = g_error_class;
  }

  bind_messages(m);

  py::class_<RunResult>(m, "RunResult", "What `ehpt run` writes, in memory (ehpt.run's result).")
      .def_property_readonly(
          "summary", [](const RunResult& r) { return SummaryDict(r.summary); },
          "summary.json as a dict (null -> None), provenance included.")
      .def_property_readonly(
          "columns", [](const RunResult& r) { return StrList(r.columns); },
          "timeseries.csv's header: the recorded signals' names in column order.")
      .def_property_readonly(
          "timeseries", [](const RunResult& r) { return ArrayDict(r.timeseries); },
          "{name: 1-D float64 numpy array}, in column order (0 rows with output.timeseries = false).")
      .def_readonly("exit_code", &RunResult::exit_code, "The CLI's: 0 ok, 3 a run-time fault (outputs kept), 4 degraded (bus faults), 5 a test failed.")
      .def_property_readonly(
          "warnings", [](const RunResult& r) { return StrList(r.warnings); },
          "What the CLI prints as 'warning: ...' (legal but surprising settings).")
      .def_property_readonly(
          "text", [](const RunResult& r) { return py::str(r.text); }, "The summary lines the CLI prints.")
      .def(
          "to_dataframe", [](const RunResult& r) { return dataframe_of(r.timeseries, "RunResult"); },
          "The timeseries as a pandas DataFrame: a column per recorded signal, in order, indexed by\n"
          "time_s (the index, named \"time_s\", not a column; a row number if time_s was not recorded).\n"
          "ImportError with the install hint (apt-get install python3-pandas) without pandas.")
      .def("__repr__", [](const RunResult& r) {
        return "<ehpt.RunResult exit_code=" + std::to_string(r.exit_code) + ", " + std::to_string(py::len(r.columns)) +
               " columns>";
      });

  m.def("run", &run, py::arg("scenario"), py::arg("set") = py::none(), py::arg("cycle") = py::none(),
        py::arg("faults") = py::none(), kRunDoc);

  py::class_<PySimulation>(m, "Simulation", kSimulationDoc)
      .def(py::init<const ScenarioArg&, const SetArg&, const BoolArg&, const IntArg&, const CycleArg&, const FaultsArg&>(),
           py::arg("scenario"), py::arg("set") = py::none(), py::arg("external_ecu") = false,
           py::arg("chunk_steps") = 50000, py::arg("cycle") = py::none(), py::arg("faults") = py::none(),
           kSimulationInitDoc)
      .def("step", &PySimulation::step, py::arg("n"),
           "Up to n steps (1 <= n <= chunk_steps, else ValueError); with external_ecu it stops early at\n"
           "an ECU sample. Returns the steps taken (0 once finished). Releases the GIL.")
      .def("run", &PySimulation::run, "Steps to the end; returns the steps taken. Releases the GIL.")
      .def("read_sensors", &PySimulation::read_sensors,
           "The sensor message now (PsdSensors, EvSensors or ShevSensors), stamped; TypeError for a rig (no ECU).")
      .def("write_command", &PySimulation::write_command, py::arg("command"),
           "PsdCommand or EvCommand, this vehicle's (TypeError if not); acts from the current step on.")
      .def("outputs", &PySimulation::outputs,
           "Every signal at the last grid point observed, {name: float}. With external_ecu, stopped at a sample\n"
           "step n, that is step n - 1: the outputs at n follow the command (as the built-in ECU's do).")
      .def("timeseries", &PySimulation::timeseries, "The rows recorded so far, {name: float64 array} as RunResult.timeseries.")
      .def("to_dataframe", &PySimulation::to_dataframe,
           "The rows recorded so far as a pandas DataFrame, indexed by time_s (as RunResult.to_dataframe).")
      .def("stats", &PySimulation::stats,
           "Counters and figures of the run so far: steps_done, events, chattering_steps, newton_failures,\n"
           "fault, fault_time_s, rows_dropped, distance_m, soc_start, soc_end, fuel_g (None: not applicable).")
      .def("verdict", &PySimulation::verdict,
           "A test's verdict as it stands (None: the scenario has no [[fault]] or [[expect]]): the dict\n"
           "ehpt.run gives as summary[\"test\"] (verdict, first_failure, expectations with message, time\n"
           "and value, faults with their spans), judged as if the run ended at the last step taken, and\n"
           "finished. Before the end verdict is \"incomplete\" (a window not reached yet fails); at the\n"
           "end it equals ehpt.run's. Stepping on after a call is unaffected.")
      .def_property_readonly("finished", &PySimulation::finished, "True once every step is taken.")
      .def_property_readonly("time_s", &PySimulation::time_s, "Simulation time of the next step, s (step_index * step_s).")
      .def_property_readonly("step_index", &PySimulation::step_index, "Steps taken so far.")
      .def_property_readonly("total_steps", &PySimulation::total_steps, "Steps in the whole run (solver.duration_s / step_s).")
      .def_property_readonly("chunk_steps", &PySimulation::chunk_steps, "The most steps one step(n) may take.")
      .def_property_readonly("external_ecu", &PySimulation::external_ecu, "True: you are the ECU (no built-in one).")
      .def_property_readonly("step_s", &PySimulation::step_s, "The solver step, s.")
      .def_property_readonly("name", &PySimulation::name, "The scenario's name (its file name without .toml).")
      .def_property_readonly("ecu_period_steps", &PySimulation::ecu_period_steps,
                             "Steps per ECU period (None: no ECU); samples at every multiple from step 0.")
      .def_property_readonly("ecu_parameters", &PySimulation::ecu_params,
                             "The built-in ECU's parameters as loaded, overrides included (dict; None: no ECU).")
      .def_property_readonly("signals", &PySimulation::signals, "Every signal's name, in outputs() order.")
      .def_property_readonly("columns", &PySimulation::columns, "The recorded signals (timeseries() columns).")
      .def("__repr__", [](const PySimulation& s) {
        return "<ehpt.Simulation " + s.name() + " step " + std::to_string(s.step_index()) + "/" +
               std::to_string(s.total_steps()) + (s.external_ecu() ? ", external ECU>" : ">");
      });
}
