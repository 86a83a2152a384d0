// SPDX-License-Identifier: BSD-3-Clause
// `ehpt test`: ECU test files (a scenario with [[fault]]s and [[expect]]s, docs/testing.md),
// each run as its own `ehpt run` child (a test that crashes fails alone; -j N at a time), its
// verdict read back from its summary.json; a table, a JUnit file, an exit code.
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <map>

#include <toml++/toml.h>

#include "hil/bus/bus_binding.hpp"
#include "hil/bus/bus_faults.hpp"
#include "hil/bus/bus_plant.hpp"
#include "hil/bus/in_process_bus.hpp"
#include "hil/config/scenario.hpp"
#include "hil/run/batch.hpp"
#include "io/json_value.hpp"
#include "io/junit.hpp"
#include "io/process.hpp"
#include "io/text_file.hpp"
#include "targets/cli.hpp"

namespace fs = std::filesystem;

namespace ehpt::cli {

namespace {

const char* kTestHelp =
    "usage: ehpt test PATH... [--out DIR] [--junit FILE] [-j N] [--set key=value ...] [--quiet]\n"
    "                 [--bus SPEC --ecu-cmd ARGV...]\n"
    "\n"
    "Runs ECU test files and judges them (docs/testing.md). A test file is a scenario, or\n"
    "names one (scenario = \"psecu2_nedc\") and overrides its keys, with [[fault]] tables (what\n"
    "goes wrong, when) and [[expect]] tables (what must hold, when). PATH is a test file, a\n"
    "folder (its *.toml files, sorted) or a suite file (tests = [\"a.toml\", ...]).\n"
    "  --out DIR        the tests' folder (default out/test): DIR/<test>/ holds each run\n"
    "                   (timeseries.csv with a faults_active column, summary.json with the\n"
    "                   verdict), DIR/logs/<test>.log its messages\n"
    "  --junit FILE     a JUnit XML report: one testcase per test, a failure names the first\n"
    "                   expectation that failed, with its time and value\n"
    "  -j N             tests at a time (default 1); each runs as its own process\n"
    "  --set key=value  override a key of every test (as 'ehpt run --set')\n"
    "  --quiet          print only the failures and the last line\n"
    "  --bus SPEC --ecu-cmd ARGV...  the ECU outside: each test's plant runs as 'ehpt plant\n"
    "                   TEST --bus SPEC --lockstep' and ehpt starts ARGV (the rest of the\n"
    "                   line; no shell) as its ECU, {test}, {bus} and {prefix} replaced by the\n"
    "                   test file, its bus and its LCM prefix. SPEC: socketcand:HOST:PORT\n"
    "                   (test slot k of -j N on PORT + k) or lcm:URL (udpm: slot k on the URL's\n"
    "                   port + k, default 7667; prefix EHPT_S<k>_). E.g.\n"
    "                   --bus socketcand:127.0.0.1:29600 --ecu-cmd ehpt ecu {test} --bus {bus}\n"
    "                   An ECU that exits non-zero or crashes is a test error (its status and\n"
    "                   the tail of its log in the report)\n"
    "\n"
    "Bus faults (drop, delay, corrupt, counter_jump, bus_off, ... on a message's frames) act on\n"
    "CAN frames: without --bus the built-in ECU then runs over an in-process CAN bus (the same\n"
    "session as over socketcand with 'ehpt ecu', bit for bit); over LCM, which carries no CAN\n"
    "frames, such a test is skipped (listed with its reason, <skipped> in the JUnit file).\n"
    "\n"
    "Every test file is checked before anything runs: a problem is 'file:line: field = value:\n"
    "expectation' (exit 2). A test with [test] expect_fail = true is written to fail: it\n"
    "passes when an expectation fails. Exit: 0 every test passed, 1 a test failed, 2 bad\n"
    "input, 3 a test could not run to its end (a plant fault, a crash), 128+N stopped by signal N.\n";

struct TestCase {
  std::string path;  // the test file
  std::string name;  // its folder name: the file's stem
  std::string group; // the folder or suite it came from
  std::string out_dir, log_path, ecu_log_path;
  // after the run
  enum class State { kPending, kPassed, kFailed, kError, kSkipped } state = State::kPending;
  std::string first_failure;  // or the error
  std::string details;        // every expectation's line
  double wall_s = 0.0;
  bool expect_fail = false;
};

bool is_suite(const std::string& path, std::vector<std::string>& tests, std::string& error) {
  toml::table doc;
  try {
    doc = toml::parse_file(path);
  } catch (const toml::parse_error&) {
    return false;  // load_scenario reports it with its line
  }
  const toml::node* n = doc.get("tests");
  if (n == nullptr) return false;
  const toml::array* a = n->as_array();
  if (a == nullptr || doc.size() > 2 || (doc.size() == 2 && !doc.contains("description"))) {
    error = path + ": tests: a suite file holds tests = [\"FILE\", ...] (and a description), nothing else";
    return true;
  }
  for (const toml::node& e : *a) {
    const auto s = e.value_exact<std::string>();
    if (!s || s->empty()) {
      error = path + ":" + std::to_string(e.source().begin.line) + ": tests: every entry is a test file's path";
      return true;
    }
    fs::path p(*s);
    if (p.is_relative()) p = fs::path(path).parent_path() / p;
    tests.push_back(p.lexically_normal().string());
  }
  return true;
}

// PATH... -> the test files, in order, each once. false with errors if a path is not one.
bool collect(const std::vector<std::string>& paths, std::vector<TestCase>& out, std::vector<std::string>& errors) {
  std::map<std::string, std::string> seen_names;  // name -> path
  const auto add = [&](const std::string& path, const std::string& group) {
    TestCase t;
    t.path = path;
    t.name = fs::path(path).stem().string();
    t.group = group;
    if (const auto it = seen_names.find(t.name); it != seen_names.end()) {
      if (it->second != path) {
        errors.push_back(path + ": a second test named \"" + t.name + "\" (also " + it->second +
                         "): each test's folder is named after its file");
      }
      return;
    }
    seen_names[t.name] = path;
    out.push_back(std::move(t));
  };
  for (const std::string& p : paths) {
    std::error_code ec;
    if (fs::is_directory(p, ec)) {
      std::vector<std::string> files;
      for (const auto& entry : fs::directory_iterator(p, ec)) {
        if (entry.path().extension() == ".toml" && entry.is_regular_file(ec)) files.push_back(entry.path().string());
      }
      // a suite file in the folder lists tests the folder holds anyway: not a test itself
      std::erase_if(files, [](const std::string& f) {
        std::vector<std::string> listed;
        std::string ignored;
        return is_suite(f, listed, ignored);
      });
      std::sort(files.begin(), files.end());
      if (files.empty()) errors.push_back(p + ": a folder with no .toml test files");
      for (const auto& f : files) add(f, fs::path(p).filename().string());
      continue;
    }
    std::string reason;
    const std::string file = hil::resolve_scenario(p, reason);
    if (file.empty()) {
      errors.push_back(p + ": " + reason);
      continue;
    }
    std::vector<std::string> suite;
    std::string error;
    if (is_suite(file, suite, error)) {
      if (!error.empty()) errors.push_back(error);
      for (const auto& f : suite) add(f, fs::path(file).stem().string());
      continue;
    }
    std::error_code aec;
    add(file, fs::absolute(file, aec).parent_path().filename().string());
  }
  return errors.empty();
}

// The last lines of a log (a crashed test's report).
std::string log_tail(const std::string& path) {
  std::string text, reason;
  if (!io::read_text_file(path, text, reason)) return "";
  if (text.size() > 2000) text = "..." + text.substr(text.size() - 2000);
  return text;
}

// A finished child: its verdict from its summary.json.
void judge(TestCase& t, int status) {
  std::string text, reason, error;
  io::JsonValue summary;
  const bool read = io::read_text_file(t.out_dir + "/summary.json", text, reason) && io::parse_json(text, summary, error);
  const io::JsonValue* test = read ? summary.find("test") : nullptr;
  const bool exited = WIFEXITED(status);
  const int code = exited ? WEXITSTATUS(status) : -1;
  if (test != nullptr) {
    for (const auto& e : test->find("expectations") ? test->find("expectations")->items : std::vector<io::JsonValue>{}) {
      const io::JsonValue* passed = e.find("passed");
      const io::JsonValue* message = e.find("message");
      const io::JsonValue* name = e.find("name");
      if (passed && message && name) {
        t.details += std::string(passed->boolean ? "ok     " : "FAILED ") + name->text + ": " + message->text + "\n";
      }
    }
    if (const io::JsonValue* f = test->find("first_failure")) t.first_failure = f->text;
    if (const io::JsonValue* x = test->find("expect_fail")) t.expect_fail = x->boolean;
  }
  const io::JsonValue* verdict = test != nullptr ? test->find("verdict") : nullptr;
  if (exited && (code == 0 || code == hil::kExitExpectationFailed) && verdict != nullptr) {
    const bool passed = verdict->text == "passed";
    // the child's exit code and its summary say the same, or neither is believed
    if (passed == (code == 0)) {
      t.state = passed ? TestCase::State::kPassed : TestCase::State::kFailed;
      if (passed && t.expect_fail) t.first_failure = "expected failure: " + t.first_failure;
      return;
    }
  }
  t.state = TestCase::State::kError;
  std::string why;
  if (!exited) {
    why = "the run was killed by signal " + std::to_string(WTERMSIG(status));
  } else if (code == 3) {
    why = "the run stopped on a plant fault";
    if (read) {
      if (const io::JsonValue* f = summary.find("fault")) why += ": " + f->text;
    }
  } else {
    why = "the run exited with status " + std::to_string(code);
  }
  t.first_failure = why;
  t.details += "log (" + t.log_path + "):\n" + log_tail(t.log_path);
}

// A stopped plant's ECU gets this long to end by itself (socketcand: the plant closed the
// connection; LCM: its idle timeout) before it is stopped.
constexpr double kEcuGrace_s = 15.0;

// --bus and --ecu-cmd: each running test gets its own port (socketcand: PORT + slot) or LCM
// channel prefix (EHPT_S<slot>_), so -j N sessions do not meet.
struct BusOptions {
  bool enabled = false, ecu_is_ehpt = false;
  std::string spec, host;
  int port = 0;
  bool lcm = false;
  std::vector<std::string> ecu_cmd;
  bool parse(const std::string& text) {
    spec = text;
    if (text.rfind("lcm:", 0) == 0 && text.size() > 4) {
      lcm = true;
      return parse_udpm_port(text.substr(4));
    }
    if (text.rfind("socketcand:", 0) != 0) return false;
    const auto colon = text.rfind(':');
    host = text.substr(11, colon - 11);
    char* end = nullptr;
    const long p = std::strtol(text.c_str() + colon + 1, &end, 10);
    if (host.empty() || colon <= 11 || *end != '\0' || p < 1 || p > 65535 - 256) return false;
    port = static_cast<int>(p);
    return true;
  }
  // udpm://ADDRESS[:PORT][?options]: slot k listens on PORT + k (LCM's default 7667 when the
  // URL names none). One shared port would hand every -j N session each other's datagrams:
  // each process then filters by channel prefix but its receive buffer carries the load of
  // all of them, and under CI load that lost a datagram (an ECU timeout).
  std::string udpm_head, udpm_tail;  // the URL around the port; empty when not udpm
  bool parse_udpm_port(const std::string& url) {
    const std::string scheme = "udpm://";
    if (url.rfind(scheme, 0) != 0) return true;  // memq:// and the rest: one spec for all
    const std::size_t query = std::min(url.find('?'), url.size());
    const std::size_t colon = url.find(':', scheme.size());
    const bool has_port = colon != std::string::npos && colon < query;
    port = 7667;
    if (has_port) {
      char* end = nullptr;
      const std::string digits = url.substr(colon + 1, query - colon - 1);
      const long p = std::strtol(digits.c_str(), &end, 10);
      if (digits.empty() || *end != '\0' || p < 1 || p > 65535 - 256) return false;
      port = static_cast<int>(p);
    }
    udpm_head = "lcm:" + url.substr(0, has_port ? colon : query);
    udpm_tail = url.substr(query);
    return true;
  }
  std::string spec_for(std::size_t slot) const {
    const int slot_port = port + static_cast<int>(slot);
    if (lcm) return udpm_head.empty() ? spec : udpm_head + ":" + std::to_string(slot_port) + udpm_tail;
    return "socketcand:" + host + ":" + std::to_string(slot_port);
  }
  std::string prefix_for(std::size_t slot) const { return lcm ? "EHPT_S" + std::to_string(slot) + "_" : "EHPT_"; }
};

// {test}, {bus} and {prefix} in an argument of --ecu-cmd.
std::string substitute(std::string a, const std::string& test, const std::string& bus, const std::string& prefix) {
  for (const auto& [key, value] : {std::pair<std::string, std::string>{"{test}", test}, {"{bus}", bus}, {"{prefix}", prefix}}) {
    for (std::size_t at = a.find(key); at != std::string::npos; at = a.find(key, at + value.size())) a.replace(at, key.size(), value);
  }
  return a;
}

bool make_dir(const std::string& dir, std::string& error) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir, ec)) {
    error = "cannot make the folder " + dir + ": " + (ec ? ec.message() : "not a folder");
    return false;
  }
  return true;
}

}  // namespace

int cmd_test(const std::vector<std::string>& args) {
  if (wants_help(args)) return out(kTestHelp) ? 0 : 1;
  std::vector<std::string> paths, sets;
  std::string out_dir = "out/test", junit;
  BusOptions bus;
  int jobs = 1;
  bool quiet = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if ((a == "--out" || a == "--junit" || a == "--set" || a == "-j" || a == "--bus" || a == "--ecu-cmd") &&
        i + 1 >= args.size()) {
      std::cerr << a << " needs a value\n" << kTestHelp;
      return 2;
    }
    if (a == "--out") {
      out_dir = args[++i];
    } else if (a == "--junit") {
      junit = args[++i];
    } else if (a == "--set") {
      sets.push_back(args[++i]);
    } else if (a == "-j") {
      const std::string& v = args[++i];
      char* end = nullptr;
      const long n = std::strtol(v.c_str(), &end, 10);
      if (v.empty() || *end != '\0' || n < 1 || n > 256) {
        std::cerr << "-j " << v << ": must be a whole number of tests at a time in [1, 256]\n";
        return 2;
      }
      jobs = static_cast<int>(n);
    } else if (a == "--quiet") {
      quiet = true;
    } else if (a == "--bus") {
      if (!bus.parse(args[++i])) {
        std::cerr << "--bus " << args[i] << ": must be socketcand:HOST:PORT or lcm:URL (lcm:udpm://239.255.76.67:7667?ttl=0), a port in [1, 65279]\n";
        return 2;
      }
    } else if (a == "--ecu-cmd") {
      bus.ecu_cmd.assign(args.begin() + static_cast<std::ptrdiff_t>(i) + 1, args.end());
      break;
    } else if (!a.empty() && a[0] == '-') {
      std::cerr << "unknown option " << a << "\n" << kTestHelp;
      return 2;
    } else {
      paths.push_back(a);
    }
  }
  if (paths.empty() || out_dir.empty()) {
    std::cerr << kTestHelp;
    return 2;
  }
  if (bus.spec.empty() != bus.ecu_cmd.empty()) {
    std::cerr << "--bus and --ecu-cmd go together: the plant runs on the bus, ehpt starts the ECU there\n";
    return 2;
  }
  bus.enabled = !bus.spec.empty();
  bus.ecu_is_ehpt = bus.enabled && bus.ecu_cmd[0] == "ehpt";
  std::vector<TestCase> tests;
  std::vector<std::string> errors;
  collect(paths, tests, errors);
  // every test checked before any runs: a typo in the tenth is found before the first takes an hour
  for (TestCase& t : tests) {
    hil::Scenario sc;
    std::vector<std::string> e;
    std::string reason;
    if (!hil::load_scenario(t.path, sets, sc, e)) {
      errors.insert(errors.end(), e.begin(), e.end());
      continue;
    }
    if (sc.expects.empty()) {
      errors.push_back(t.path + ": no [[expect]] table: a test states what must hold (docs/testing.md)");
    }
    t.expect_fail = sc.test.expect_fail;
    // bus faults act on CAN frames: in-process (the built-in ECU over an in-process bus) or
    // over socketcand; LCM carries none
    if (!hil::has_bus_faults(sc)) continue;
    if (bus.lcm) {
      const auto f = std::find_if(sc.faults.begin(), sc.faults.end(),
                                  [](const hil::FaultSpec& x) { return x.side == hil::FaultSide::kBus; });
      t.state = TestCase::State::kSkipped;
      t.first_failure = "skipped: " + f->where + ": kind = \"" + hil::fault_effect_name(f->effect) +
                        "\" acts on CAN frames, and LCM carries none (run it without --bus, or over socketcand)";
    } else if (!hil::can_run_on_bus(sc, reason)) {
      errors.push_back(t.path + ": bus faults need a plant with bus messages: " + reason);
    } else {
      // the plant runs on ehpt's own contract: its messages, checked now rather than when
      // the test's turn comes
      std::optional<hil::Binding> binding = hil::default_binding(hil::bus_family(sc), sc.ecu_timing.period_s, e);
      hil::BusFaults faults;
      // (in-process and socketcand: no error frames)
      if (binding) hil::BusFaults::resolve(sc.faults, *binding, sc.solver.step_s, sc.solver.ecu_ratio, false, faults, e);
      errors.insert(errors.end(), e.begin(), e.end());
    }
  }
  if (!errors.empty()) {
    for (const auto& e : errors) std::cerr << e << "\n";
    std::cerr << "nothing was run (" << errors.size() << " problem" << (errors.size() == 1 ? "" : "s") << ")\n";
    return 2;
  }
  std::string error;
  if (!make_dir(out_dir + "/logs", error)) {
    std::cerr << "error: " << error << "\n";
    return 2;
  }
  const std::string self = io::self_executable();
  // each test a slot (its own bus port or LCM prefix while it runs)
  std::vector<bool> slot_busy(static_cast<std::size_t>(jobs), false);
  struct Running {
    std::size_t test = 0, slot = 0;
    int plant = -1, ecu = -1;  // pids (-1: none or ended)
    int plant_status = 0, ecu_status = 0;
    std::chrono::steady_clock::time_point started, plant_ended;
  };
  std::vector<Running> running;
  std::size_t next = 0, done = 0;
  bool start_failed = false;
  const auto finish = [&](Running& r) {
    TestCase& t = tests[r.test];
    t.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - r.started).count();
    judge(t, r.plant_status);
    if (bus.enabled && t.state != TestCase::State::kError) {
      const bool ecu_ok = WIFEXITED(r.ecu_status) && WEXITSTATUS(r.ecu_status) == 0;
      if (!ecu_ok) {
        t.state = TestCase::State::kError;
        t.first_failure = "the ECU " + std::string(WIFEXITED(r.ecu_status) ? "exited with status " + std::to_string(WEXITSTATUS(r.ecu_status))
                                                                           : "was killed by signal " + std::to_string(WTERMSIG(r.ecu_status)));
        t.details += "ECU log (" + t.ecu_log_path + "):\n" + log_tail(t.ecu_log_path);
      }
    } else if (bus.enabled) {
      t.details += "ECU log (" + t.ecu_log_path + "):\n" + log_tail(t.ecu_log_path);
    }
    slot_busy[r.slot] = false;
    ++done;
    if (!quiet || t.state != TestCase::State::kPassed) {
      const char* word = t.state == TestCase::State::kPassed ? "passed" : t.state == TestCase::State::kFailed ? "FAILED" : "ERROR";
      std::cerr << "[" << done << "/" << tests.size() << "] " << word << "  " << t.name << "\n";
    }
  };
  while (done < tests.size()) {
    while (g_stop.load() == 0 && running.size() < static_cast<std::size_t>(jobs) && next < tests.size()) {
      TestCase& t = tests[next];
      if (t.state == TestCase::State::kSkipped) {  // decided at the check
        ++next;
        ++done;
        if (!quiet) std::cerr << "[" << done << "/" << tests.size() << "] skipped " << t.name << "\n";
        continue;
      }
      Running r;
      r.test = next++;
      r.slot = static_cast<std::size_t>(std::find(slot_busy.begin(), slot_busy.end(), false) - slot_busy.begin());
      r.started = std::chrono::steady_clock::now();
      t.out_dir = out_dir + "/" + t.name;
      t.log_path = out_dir + "/logs/" + t.name + ".log";
      std::vector<std::string> argv{self, bus.enabled ? "plant" : "run", t.path, "--out", t.out_dir, "--quiet"};
      std::vector<std::string> ecu_argv;
      if (bus.enabled) {
        // lockstep: the plant waits for each command, so the verdict is the same every time
        const std::string spec = bus.spec_for(r.slot), prefix = bus.prefix_for(r.slot);
        for (const std::string& a : {std::string("--bus"), spec, std::string("--lockstep"), std::string("--ecu-wait-s"),
                                     std::string("20")}) {
          argv.push_back(a);
        }
        if (bus.lcm) {
          argv.push_back("--lcm-prefix");
          argv.push_back(prefix);
        }
        t.ecu_log_path = out_dir + "/logs/" + t.name + ".ecu.log";
        for (const std::string& a : bus.ecu_cmd) ecu_argv.push_back(substitute(a, t.path, spec, prefix));
        if (ecu_argv[0] == "ehpt") {
          ecu_argv[0] = self;
        } else if (const std::string found = io::find_program(ecu_argv[0]); !found.empty()) {
          ecu_argv[0] = found;
        }
      }
      for (const auto& x : sets) {
        argv.push_back("--set");
        argv.push_back(x);
        if (bus.enabled && bus.ecu_is_ehpt) {
          ecu_argv.push_back("--set");  // the built-in ECU reads the same scenario
          ecu_argv.push_back(x);
        }
      }
      std::string reason;
      r.plant = io::start_program(argv, t.log_path, t.log_path, true, reason);
      if (r.plant >= 0 && bus.enabled) {
        r.ecu = io::start_program(ecu_argv, t.ecu_log_path, t.ecu_log_path, true, reason);
        if (r.ecu < 0) {
          ::killpg(r.plant, SIGTERM);
          int st = 0;
          ::waitpid(r.plant, &st, 0);
          r.plant = -1;
          reason = "the ECU (" + ecu_argv[0] + "): " + reason;
        }
      }
      if (r.plant < 0) {
        t.state = TestCase::State::kError;
        t.first_failure = "could not start: " + reason;
        start_failed = true;
        ++done;
        continue;
      }
      slot_busy[r.slot] = true;
      running.push_back(r);
    }
    if (running.empty()) {
      if (g_stop.load() != 0 || next >= tests.size()) break;
      continue;
    }
    // reap what ended; an ECU still running kEcuGrace_s after its plant ended is stopped
    bool any = false;
    for (std::size_t i = 0; i < running.size();) {
      Running& r = running[i];
      int status = 0;
      if (r.plant > 0 && ::waitpid(r.plant, &status, WNOHANG) == r.plant) {
        r.plant_status = status;
        r.plant = -1;
        r.plant_ended = std::chrono::steady_clock::now();
        any = true;
      }
      if (r.ecu > 0 && ::waitpid(r.ecu, &status, WNOHANG) == r.ecu) {
        r.ecu_status = status;
        r.ecu = -1;
        any = true;
      }
      if (g_stop.load() != 0) {
        if (r.plant > 0) ::killpg(r.plant, g_stop.load());
        if (r.ecu > 0) ::killpg(r.ecu, g_stop.load());
      }
      if (r.plant < 0 && r.ecu > 0) {
        const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - r.plant_ended).count();
        if (waited > kEcuGrace_s + 2.0) {
          ::killpg(r.ecu, SIGKILL);
        } else if (waited > kEcuGrace_s) {
          ::killpg(r.ecu, SIGTERM);
        }
      }
      if (r.plant < 0 && r.ecu < 0) {
        finish(r);
        running.erase(running.begin() + static_cast<std::ptrdiff_t>(i));
        continue;
      }
      ++i;
    }
    if (!any) ::usleep(2000);
  }

  // the table: test, verdict, first failed expectation with its time and value
  std::size_t passed = 0, failed = 0, broken = 0, not_run = 0, skipped = 0;
  std::size_t width = 4;
  for (const TestCase& t : tests) width = std::max(width, t.name.size());
  std::string table = "test" + std::string(width - 4 + 2, ' ') + "verdict  first failure\n";
  std::vector<io::JunitCase> cases;
  for (const TestCase& t : tests) {
    std::string word;
    io::JunitCase c;
    c.name = t.name;
    c.classname = t.group;
    c.time_s = t.wall_s;
    switch (t.state) {
      case TestCase::State::kPassed:
        ++passed;
        word = t.expect_fail ? "xfail  " : "passed ";
        c.details = t.details;
        break;
      case TestCase::State::kFailed:
        ++failed;
        word = "FAILED ";
        c.result = io::JunitCase::Result::kFailed;
        c.message = t.first_failure;
        c.details = t.details;
        break;
      case TestCase::State::kError:
        ++broken;
        word = "ERROR  ";
        c.result = io::JunitCase::Result::kError;
        c.message = t.first_failure;
        c.details = t.details;
        break;
      case TestCase::State::kSkipped:
        ++skipped;
        word = "skipped";
        c.result = io::JunitCase::Result::kSkipped;
        c.message = t.first_failure;
        break;
      case TestCase::State::kPending:
        ++not_run;
        word = "not run";
        c.result = io::JunitCase::Result::kError;
        c.message = "not run: stopped by a signal";
        break;
    }
    cases.push_back(c);
    if (quiet && t.state == TestCase::State::kPassed) continue;
    table += t.name + std::string(width - t.name.size() + 2, ' ') + word + "  " +
             (t.state == TestCase::State::kPassed && !t.expect_fail ? std::string() : t.first_failure) + "\n";
  }
  table += std::to_string(tests.size()) + " test" + (tests.size() == 1 ? "" : "s") + ": " + std::to_string(passed) +
           " passed, " + std::to_string(failed) + " failed, " + std::to_string(broken) + " errors" +
           (skipped > 0 ? ", " + std::to_string(skipped) + " skipped" : std::string()) +
           (not_run > 0 ? ", " + std::to_string(not_run) + " not run" : std::string()) + "; runs in " + out_dir + "\n";
  const bool printed = out(table);
  if (!junit.empty()) {
    if (!io::write_file_atomically(junit, io::junit_xml("ehpt test", cases), error)) {
      std::cerr << "error: " << error << "\n";
      return 1;
    }
  }
  if (g_stop.load() != 0) return 128 + g_stop.load();
  if (broken > 0 || start_failed) return 3;
  if (failed > 0) return 1;
  return printed ? 0 : 1;
}

}  // namespace ehpt::cli
