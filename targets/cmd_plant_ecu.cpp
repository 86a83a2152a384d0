// SPDX-License-Identifier: BSD-3-Clause
// `ehpt plant` and `ehpt ecu`: the scenario's plant on a bus (CAN or LCM) with its ECU
// outside, and the scenario's built-in ECU as its own process on a bus.
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <span>
#include <sstream>

#include "ecu/psd_ecu.hpp"
#include "ecu/shev_ems.hpp"
#include "hil/bus/bus_ecu.hpp"
#include "hil/bus/bus_plant.hpp"
#include "hil/run/batch.hpp"
#include "io/can/bus_spec.hpp"
#include "io/can/contract.hpp"
#include "io/lcm/lcm_bus.hpp"
#include "targets/cli.hpp"

namespace fs = std::filesystem;

namespace ehpt::cli {

namespace {

const char* kPlantHelp =
    "usage: ehpt plant SCENARIO --bus SPEC [--lockstep] [--out DIR] [--set key=value ...]\n"
    "                  [--fault SPEC ...]\n"
    "                  [--command-timeout-s T] [--lockstep-wait-s W] [--ecu-wait-s S]\n"
    "                  [--allow-degraded] [--bus-log-format candump|asc] [--bus-map FILE]\n"
    "                  [--realtime [--period T] [--cpu N] [--priority P]] [--quiet]\n"
    "\n"
    "Runs the scenario's plant without its built-in ECU: an ECU on the bus reads the sensor\n"
    "frames and sends the command frames of io/can/ehpt.dbc (one sample per ECU period,\n"
    "vehicle.ecu.period_s, default 0.01 s), or those of its own DBC through a binding\n"
    "(--bus-map). Writes timeseries.csv and summary.json as 'ehpt run' does, plus bus.log\n"
    "(every frame in and out, candump -L format) and the bus figures in summary.json (\"bus\").\n"
    "  --bus SPEC       socketcan:IFACE (e.g. socketcan:vcan0), or socketcand:HOST:PORT (the\n"
    "                   plant listens there; python-can's socketcand interface and 'ehpt ecu'\n"
    "                   connect), or lcm:URL (lcm:udpm://239.255.76.67:7667?ttl=0; ttl > 0 warns:\n"
    "                   the messages leave this host)\n"
    "  --lcm-prefix P   LCM channels P + PLANT_STATUS and P + ECU_COMMAND (default EHPT_)\n"
    "  --bus-map FILE   CAN: a binding (TOML, docs/binding.md) of the plant's inputs and outputs\n"
    "                   to the signals of the ECU's own DBC; its messages go out at their DBC\n"
    "                   cycle times (wall clock) and need no echo; default: ehpt's own contract\n"
    "  --lockstep       advance one ECU period only after the ECU's command for it has arrived\n"
    "                   (deterministic SIL); default: wall clock (real time, latest command)\n"
    "  --command-timeout-s T  a command older than T puts the plant in its safe state (torques\n"
    "                   zero, engine ON/OFF held, ecuTimeout in PlantStatus); default 3 ECU periods\n"
    "  --lockstep-wait-s W    lockstep: wall time to wait for a command before going on\n"
    "                   without one (it then ages towards the timeout); default 1; after 10\n"
    "                   waits in a row run out the plant stops waiting until a command comes\n"
    "  --ecu-wait-s S   wall time to wait for an ECU to connect before t = 0; default 60\n"
    "  --realtime, --period, --cpu, --priority  the real-time loop, as for 'ehpt run' (instead\n"
    "                   of the plain wall clock; not with --lockstep)\n"
    "  --allow-degraded exit 0 for a degraded session (its status stays \"degraded\")\n"
    "  --bus-log-format F  asc: bus.asc too (Vector ASC: CANoe, CANalyzer, python-can's\n"
    "                   ASCReader), each frame with its direction; default candump (bus.log only)\n"
    "  --out, --set, --fault, --quiet  as for 'ehpt run' (a --fault is kept in inputs.log\n"
    "                   for 'ehpt replay'); bus faults act on the frames (docs/testing.md)\n"
    "A fault holds the run (reported in PlantStatus) and ends it with exit 3. A session that\n"
    "ran without its ECU is \"degraded\" (summary.json status and degraded, the last line,\n"
    "exit 4): no command at all, commands that timed out, lockstep waits that ran out, error\n"
    "frames, frames the plant could not send.\n";

const char* kEcuHelp =
    "usage: ehpt ecu SCENARIO --bus SPEC [--set key=value ...] [--idle-timeout-s S]\n"
    "                [--max-samples N] [--quiet]\n"
    "\n"
    "Runs the scenario's built-in ECU (MBecu1, MBecu1soc, MBecu2, the EV's follower, the\n"
    "series hybrid's EMS) as its own process: for each PlantStatus frame it computes one\n"
    "command from that sample's sensor frames and sends it. Stops when the plant closes the\n"
    "connection (socketcand), after S seconds without a frame from the plant (default 10), or\n"
    "after N samples.\n"
    "  --bus SPEC       socketcan:IFACE, socketcand:HOST:PORT (connects to 'ehpt plant'), or\n"
    "                   lcm:URL (lcm:udpm://239.255.76.67:7667?ttl=0)\n"
    "  --lcm-prefix P   LCM channel prefix (default EHPT_)\n";

// A positive, finite number of seconds (or a count) from the command line.
bool parse_positive(const std::string& option, const std::string& text, double& out) {
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end == nullptr || *end != '\0' || errno != 0 || !std::isfinite(v) || v <= 0.0 || v > 1e9) {
    std::cerr << option << " " << text << ": must be a positive number (at most 1e9)\n";
    return false;
  }
  out = v;
  return true;
}

// The options 'ehpt plant' and 'ehpt ecu' share, and theirs.
struct BusArgs {
  std::string scenario, out_dir, bus, lcm_prefix = "EHPT_", bus_map;
  std::vector<std::string> sets, faults;  // faults: plant only
  bool lockstep = false, quiet = false, allow_degraded = false, asc_log = false;
  double command_timeout_s = 0.0, lockstep_wait_s = 1.0, ecu_wait_s = 60.0, idle_timeout_s = 10.0, max_samples = 0.0;
  // --bus, checked: an LCM URL, or a CAN transport
  bool lcm = false;
  std::string lcm_url;
  ehpt::io::can::BusSpec spec;
  RealtimeArgs rt;
};

// 0: parsed; else the exit code.
int parse_bus_args(const std::vector<std::string>& args, bool plant, const char* help, BusArgs& a) {
  for (std::size_t i = 0; i < args.size(); ++i) {
    if (plant) {
      if (const int rc = parse_realtime_arg(args, i, a.rt, help); rc != kNotRealtime) {
        if (rc == 0) continue;
        return rc;
      }
    }
    const std::string& o = args[i];
    const bool takes_value = o == "--bus" || o == "--set" || o == "--lcm-prefix" || (plant && (o == "--out" || o == "--fault" || o == "--command-timeout-s" || o == "--bus-log-format" || o == "--bus-map" ||
                                                                        o == "--lockstep-wait-s" || o == "--ecu-wait-s")) ||
                             (!plant && (o == "--idle-timeout-s" || o == "--max-samples"));
    if (takes_value && i + 1 >= args.size()) {
      std::cerr << o << " needs a value\n" << help;
      return 1;
    }
    if (o == "--bus") {
      a.bus = args[++i];
    } else if (o == "--set") {
      a.sets.push_back(args[++i]);
    } else if (plant && o == "--fault") {
      a.faults.push_back(args[++i]);
    } else if (o == "--lcm-prefix") {
      a.lcm_prefix = args[++i];
      if (a.lcm_prefix.size() > 100 || a.lcm_prefix.find_first_of(" \t\n") != std::string::npos) {
        std::cerr << "--lcm-prefix: at most 100 characters, no spaces\n";
        return 1;
      }
    } else if (plant && o == "--out") {
      a.out_dir = args[++i];
      if (a.out_dir.empty()) {
        std::cerr << "--out needs a folder name (got an empty one)\n";
        return 1;
      }
    } else if (plant && o == "--bus-map") {
      a.bus_map = args[++i];
      if (a.bus_map.empty()) {
        std::cerr << "--bus-map needs a binding file (got an empty name)\n";
        return 1;
      }
    } else if (plant && o == "--lockstep") {
      a.lockstep = true;
    } else if (plant && o == "--allow-degraded") {
      a.allow_degraded = true;
    } else if (plant && o == "--bus-log-format") {
      const std::string& f = args[++i];
      if (f != "candump" && f != "asc") {
        std::cerr << "--bus-log-format " << f << ": must be candump or asc\n" << help;
        return 1;
      }
      a.asc_log = f == "asc";
    } else if (plant && o == "--command-timeout-s") {
      if (!parse_positive(o, args[++i], a.command_timeout_s)) return 1;
    } else if (plant && o == "--lockstep-wait-s") {
      if (!parse_positive(o, args[++i], a.lockstep_wait_s)) return 1;
    } else if (plant && o == "--ecu-wait-s") {
      if (!parse_positive(o, args[++i], a.ecu_wait_s)) return 1;
    } else if (!plant && o == "--idle-timeout-s") {
      if (!parse_positive(o, args[++i], a.idle_timeout_s)) return 1;
    } else if (!plant && o == "--max-samples") {
      if (!parse_positive(o, args[++i], a.max_samples) || a.max_samples != std::floor(a.max_samples)) {
        std::cerr << "--max-samples must be a whole number\n";
        return 1;
      }
    } else if (o == "--quiet") {
      a.quiet = true;
    } else if (!o.empty() && o[0] == '-') {
      std::cerr << "unknown option " << o << "\n" << help;
      return 1;
    } else if (a.scenario.empty()) {
      a.scenario = o;
    } else {
      std::cerr << "one scenario per run (got " << a.scenario << " and " << o << ")\n";
      return 1;
    }
  }
  if (a.scenario.empty() || a.bus.empty()) {
    std::cerr << (a.scenario.empty() ? "a scenario is needed\n" : "--bus is needed\n") << help;
    return 1;
  }
  a.lcm = a.bus.rfind("lcm:", 0) == 0;
  std::string error;
  if (a.lcm ? !ehpt::io::lcm::parse_lcm_spec(a.bus, a.lcm_url, error)
            : !ehpt::io::can::parse_bus_spec(a.bus, a.spec, error)) {
    std::cerr << error << "\n";
    return 1;
  }
  if (a.lcm && !a.bus_map.empty()) {
    std::cerr << "--bus-map: a binding maps the plant onto a DBC's CAN frames; over LCM the messages are ehpt's "
                 "LCM types (docs/lcm.md)\n";
    return 1;
  }
  if (a.lcm && a.asc_log) {
    std::cerr << "--bus-log-format asc: an ASC log is of CAN frames; over LCM record with lcm-logger (docs/lcm.md)\n";
    return 1;
  }
  if (a.lcm && a.lcm_url.rfind("memq://", 0) == 0) {
    // memq is a queue inside one process: 'ehpt plant' and an ECU in another process never meet
    std::cerr << "--bus " << a.bus << ": lcm:memq:// is in-process only, so an ECU in another process can never "
              << "hear this " << (plant ? "plant" : "ECU") << "; use lcm:udpm://239.255.76.67:7667?ttl=0\n";
    return 1;
  }
  if (a.lcm) {
    const int ttl = ehpt::io::lcm::lcm_ttl(a.lcm_url);
    if (ttl < 0) {
      std::cerr << "--bus " << a.bus << ": ttl must be a whole number 0..255\n";
      return 1;
    }
    if (ttl > 0) {
      std::cerr << "warning: --bus " << a.bus << ": ttl=" << ttl << " lets the multicast leave this host (" << ttl
                << (ttl == 1 ? " router hop" : " router hops")
                << "): the plant's messages reach the local network; ttl=0 keeps them on this machine\n";
    }
  }
  return 0;
}

// The ids the ECU's side of the contract accepts, by vehicle family (the plant's: its binding's).
std::span<const std::uint32_t> ecu_rx_ids(const ehpt::hil::Scenario& sc) {
  namespace can = ehpt::io::can;
  if (sc.ecu.holds<ehpt::ecu::PsdEcuParams>()) return can::kPsdSensorIds;
  if (sc.ecu.holds<ehpt::ecu::ShevEmsParams>()) return can::kShevSensorIds;
  return can::kEvSensorIds;
}

}  // namespace

int cmd_plant(const std::vector<std::string>& args) {
  if (wants_help(args)) return out(kPlantHelp) ? 0 : 1;
  BusArgs a;
  if (const int rc = parse_bus_args(args, true, kPlantHelp, a); rc != 0) return rc;
  if (a.rt.realtime && a.lockstep) {
    std::cerr << "--realtime and --lockstep: lockstep waits for the ECU at every sample and cannot keep a "
                 "real-time period (use one or the other)\n";
    return 1;
  }
  ehpt::hil::Scenario sc;
  if (const int rc = load(a.scenario, a.sets, sc, a.faults); rc != 0) return rc;
  if (const int rc = check_realtime(a.rt, sc); rc != 0) return rc;
  if (!a.quiet) {
    for (const auto& w : sc.warnings) std::cerr << "warning: " << w << "\n";
  }
  ehpt::hil::BusPlantOptions bo;
  bo.lockstep = a.lockstep;
  bo.realtime = a.rt.realtime;
  bo.command_timeout_s = a.command_timeout_s;
  bo.asc_log = a.asc_log;
  bo.lockstep_wait_s = a.lockstep_wait_s;
  bo.peer_wait_s = a.ecu_wait_s;
  bo.log_interface = a.spec.interface_name;
  bo.lcm_prefix = a.lcm_prefix;
  std::error_code path_ec;
  bo.scenario_path = fs::absolute(sc.path, path_ec).string();
  bo.overrides = a.sets;
  bo.faults = a.faults;
  std::string error, why;
  if (!ehpt::hil::can_run_on_bus(sc, why)) {
    std::cerr << "error: " << why << "\n";
    return 2;
  }
  // the bus first: a bus that cannot open leaves no output folder behind. The driver refers
  // to the bus: declared after it, destroyed before it.
  std::unique_ptr<ehpt::io::can::Transport> bus;
  std::unique_ptr<ehpt::io::lcm::LcmBus> lcm_bus;
  std::unique_ptr<ehpt::hil::ExternalDriver> driver;
  if (a.lcm) {
    lcm_bus = ehpt::io::lcm::LcmBus::open(a.lcm_url, error);
    if (!lcm_bus) {
      std::cerr << "error: " << error << "\n";
      return 2;
    }
    driver = ehpt::hil::make_bus_plant(sc, *lcm_bus, bo, why);
  } else {
    // the binding before the bus: its problems are the user's file's, reported with their lines
    const std::string family = ehpt::hil::bus_family(sc);
    std::vector<std::string> errors;
    std::optional<ehpt::hil::Binding> binding =
        a.bus_map.empty() ? ehpt::hil::default_binding(family, sc.ecu_timing.period_s, errors)
                          : ehpt::hil::load_binding(a.bus_map, family, sc.ecu_timing.period_s, errors);
    for (const auto& e : errors) std::cerr << "error: " << e << "\n";
    if (!binding) return 2;
    if (!a.quiet) {
      for (const auto& w : binding->warnings) std::cerr << "warning: " << w << "\n";
    }
    const std::vector<std::uint32_t> ids = binding->receive_ids();
    bus = ehpt::io::can::open_bus(a.spec, ehpt::io::can::BusRole::kPlant, ids, error);
    if (!bus) {
      std::cerr << "error: " << error << "\n";
      return 2;
    }
    driver = ehpt::hil::make_bus_plant(sc, *bus, bo, std::move(*binding), why);
  }
  if (!driver) {
    std::cerr << "error: " << why << "\n";
    return 2;
  }
  if (!a.quiet) {
    std::cerr << "plant " << sc.name << " on " << a.bus
              << (a.lockstep ? " (lockstep)" : a.rt.realtime ? " (real time)" : " (wall clock)") << "; waiting for an ECU\n";
  }
  ehpt::hil::BatchOptions opt;
  opt.out_dir = a.out_dir.empty() ? "out/" + sc.name : a.out_dir;
  opt.progress = !a.quiet && isatty(STDERR_FILENO);
  opt.stop_signal = &g_stop;
  opt.driver = driver.get();
  opt.allow_degraded = a.allow_degraded;
  if (a.rt.realtime) opt.realtime = &a.rt.opt;
  if (!sc.expects.empty() && sc.output.timeseries) {
    // a test over the bus: a figure per failed expectation, part of the committed session
    opt.before_commit = [&](const std::string& dir) { return run_expect_figures(dir, a.quiet); };
  }
  const ehpt::hil::BatchResult r = ehpt::hil::run_batch(sc, opt, std::cerr);
  if (!a.quiet) {
    for (const auto& w : r.warnings) std::cerr << "warning: " << w << "\n";
  }
  bool printed = true;
  if (!a.quiet) {
    std::string text = r.summary_text;
    if (!r.results_dir.empty()) {
      text += "outputs       " + r.results_dir + "/timeseries.csv, summary.json" + (a.lcm ? "" : ", bus.log") + "\n";
    }
    // the last line: a session without its ECU did not do its job, whatever the rest says
    if (!r.degraded.empty()) {
      text += "DEGRADED      ";
      for (std::size_t k = 0; k < r.degraded.size(); ++k) text += (k ? "; " : "") + r.degraded[k];
      text += "\n";
    }
    printed = out(text);
  }
  if (!r.degraded.empty() && r.exit_code == ehpt::hil::kExitDegraded) {
    std::cerr << "error: the session is degraded (exit 4; --allow-degraded accepts it): " << r.degraded.front() << "\n";
  }
  if (r.exit_code != 0) return r.exit_code;
  return printed ? 0 : 1;
}

int cmd_ecu(const std::vector<std::string>& args) {
  if (wants_help(args)) return out(kEcuHelp) ? 0 : 1;
  BusArgs a;
  if (const int rc = parse_bus_args(args, false, kEcuHelp, a); rc != 0) return rc;
  ehpt::hil::Scenario sc;
  if (const int rc = load(a.scenario, a.sets, sc); rc != 0) return rc;
  std::string error;
  if (!ehpt::hil::has_bus_ecu(sc, error)) {
    std::cerr << "error: " << error << "\n";
    return 2;
  }
  ehpt::hil::BusEcuOptions eo;
  eo.idle_timeout_s = a.idle_timeout_s;
  eo.max_samples = static_cast<std::int64_t>(a.max_samples);
  if (a.lcm) {
    const auto lcm_bus = ehpt::io::lcm::LcmBus::open(a.lcm_url, error);
    if (!lcm_bus) {
      std::cerr << "error: " << error << "\n";
      return 2;
    }
    std::ostringstream log;
    const ehpt::hil::BusEcuResult r = ehpt::hil::run_bus_ecu(sc, *lcm_bus, a.lcm_prefix, eo, &g_stop, log);
    if (!a.quiet && !out(log.str())) return 1;
    return r.exit_code;
  }
  const auto bus = ehpt::io::can::open_bus(a.spec, ehpt::io::can::BusRole::kEcu, ecu_rx_ids(sc), error);
  if (!bus) {
    std::cerr << "error: " << error << "\n";
    return 2;
  }
  std::ostringstream log;
  const ehpt::hil::BusEcuResult r = ehpt::hil::run_bus_ecu(sc, *bus, eo, &g_stop, log);
  if (!a.quiet && !out(log.str())) return 1;
  return r.exit_code;
}

}  // namespace ehpt::cli
