// SPDX-License-Identifier: BSD-3-Clause
// The CLI's shared helpers (targets/cli.hpp).
#include "targets/cli.hpp"

#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <utility>

#include "hil/config/scenario.hpp"
#include "io/number_format.hpp"

namespace ehpt::cli {

std::atomic<int> g_stop{0};
static_assert(std::atomic<int>::is_always_lock_free);

bool out(const std::string& text) {
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(STDOUT_FILENO, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      std::cerr << "error: cannot write to standard output: " << (n < 0 ? std::strerror(errno) : "no progress") << "\n";
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  return true;
}

bool wants_help(const std::vector<std::string>& args) {
  for (const auto& a : args) {
    if (a == "--help" || a == "-h") return true;
  }
  return false;
}

int load(const std::string& name, const std::vector<std::string>& sets, ehpt::hil::Scenario& sc,
         const std::vector<std::string>& faults) {
  std::string reason;
  const std::string path = ehpt::hil::resolve_scenario(name, reason);
  if (path.empty()) {
    // a hostile name can be very long: print its start
    const std::string shown = name.size() <= 200 ? name : name.substr(0, 80) + "... (" + std::to_string(name.size()) + " characters)";
    std::cerr << shown << ": " << reason << "\n";
    return 2;
  }
  std::vector<std::string> errors;
  if (!ehpt::hil::load_scenario(path, sets, faults, sc, errors)) {
    for (const auto& e : errors) std::cerr << e << "\n";
    std::cerr << errors.size() << (errors.size() == 1 ? " problem" : " problems") << "; nothing was run.\n";
    return 2;
  }
  return 0;
}

namespace {

// A duration: "1ms", "500us", "2s" or plain seconds; (0, 10 s].
bool parse_period(const std::string& text, double& seconds) {
  std::string number = text;
  double unit = 1.0;
  for (const auto& [suffix, scale] : {std::pair<const char*, double>{"us", 1e-6}, {"ms", 1e-3}, {"s", 1.0}}) {
    const std::string sfx = suffix;
    if (number.size() > sfx.size() && number.compare(number.size() - sfx.size(), sfx.size(), sfx) == 0) {
      number.resize(number.size() - sfx.size());
      unit = scale;
      break;
    }
  }
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(number.c_str(), &end);
  if (number.empty() || end == nullptr || *end != '\0' || errno != 0 || !std::isfinite(v) || v <= 0.0 ||
      v * unit > 10.0 || v * unit < 1e-6) {
    std::cerr << "--period " << text << ": must be a duration between 1us and 10s (1ms, 500us, 0.002s, 0.002)\n";
    return false;
  }
  seconds = v * unit;
  return true;
}

// A whole number in [lo, hi].
bool parse_int(const std::string& option, const std::string& text, int lo, int hi, int& out) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || end == nullptr || *end != '\0' || errno != 0 || v < lo || v > hi) {
    std::cerr << option << " " << text << ": must be a whole number from " << lo << " to " << hi << "\n";
    return false;
  }
  out = static_cast<int>(v);
  return true;
}

}  // namespace

int parse_realtime_arg(const std::vector<std::string>& args, std::size_t& i, RealtimeArgs& rt, const char* help) {
  const std::string& o = args[i];
  if (o == "--realtime") {
    rt.realtime = true;
    return 0;
  }
  if (o != "--period" && o != "--cpu" && o != "--priority") return kNotRealtime;
  if (i + 1 >= args.size()) {
    std::cerr << o << " needs a value\n" << help;
    return 1;
  }
  rt.tuned = true;
  const std::string& v = args[++i];
  if (o == "--period") return parse_period(v, rt.opt.period_s) ? 0 : 1;
  if (o == "--priority") return parse_int(o, v, 1, 99, rt.opt.priority) ? 0 : 1;
  if (!parse_int(o, v, 0, 4095, rt.opt.cpu)) return 1;
  std::string allowed;
  if (!ehpt::hil::cpu_allowed(rt.opt.cpu, allowed)) {
    std::cerr << "--cpu " << v << ": not a CPU this process may run on (" << allowed << ")\n";
    return 1;
  }
  return 0;
}

int check_realtime(const RealtimeArgs& rt, const ehpt::hil::Scenario& sc) {
  if (!rt.realtime) {
    if (rt.tuned) {
      std::cerr << "--period, --cpu and --priority belong to --realtime\n";
      return 1;
    }
    return 0;
  }
  if (rt.opt.period_s > 0.0) {
    const double ratio = rt.opt.period_s / sc.solver.step_s;
    if (std::abs(ratio - std::round(ratio)) > 1e-9 * ratio || std::round(ratio) < 1.0) {
      std::cerr << "--period " << ehpt::io::number_text(rt.opt.period_s) << " s: must be a whole number of solver steps (solver.step_s = "
                << ehpt::io::number_text(sc.solver.step_s) << " s)\n";
      return 2;
    }
  }
  return 0;
}

}  // namespace ehpt::cli
