// SPDX-License-Identifier: BSD-3-Clause
// `ehpt bench` sections (d) and (e): the sub-runs (allocations, trajectory hashes across pacers).
#include "targets/bench/pingpong.hpp"
#include "targets/bench/sections.hpp"
#include "targets/bench/supervisor.hpp"

#include <unistd.h>

#include <functional>

#include "hil/config/scenario.hpp"

namespace ehpt::bench {

namespace {

// ehpt run (the map EV on Sort1) as fast as possible, S seconds, into DIR/name.
void batch_run(Bench& b, const std::string& name, const std::vector<std::string>& extra) {
  SubRun& r = b.run(name);
  std::vector<std::string> argv = {b.exe, "run", kRtScenario, "--out", b.dir + "/" + name, "--quiet"};
  for (const auto& a : b.duration_set(b.seconds)) argv.push_back(a);
  for (const auto& a : extra) argv.push_back(a);
  const Outcome o = run_child(argv, b.logs, name, 120.0 + b.seconds);
  r.wall_s = o.wall_s;
  Json j;
  std::string why;
  if (o.stopped) {
    r.status = "stopped";
    return;
  }
  if (!o.ok()) return fail(b, r, o.why);
  if (!read_summary(b.dir + "/" + name, b.started_at, j, why)) return fail(b, r, why);
  take_summary(b, r, j);
}

// The ECU's command line for a plant listening on 127.0.0.1:port.
using EcuArgv = std::function<std::vector<std::string>(int port)>;

// ehpt plant + an ECU over socketcand on 127.0.0.1 (lockstep, or the wall clock): by default
// ehpt ecu on the scenario of (d) and (e).
void socketcand_run(Bench& b, const std::string& name, bool lockstep, double seconds, const char* scenario = kRtScenario,
                    const EcuArgv& ecu_argv = nullptr, const std::vector<std::string>& plant_extra = {}) {
  SubRun& r = b.run(name);
  const auto t0 = Clock::now();
  for (int attempt = 0; attempt < 3 && !stopping(); ++attempt) {
    const int port = free_port();
    if (port <= 0) return fail(b, r, "no free TCP port on 127.0.0.1");
    const std::string bus = "socketcand:127.0.0.1:" + std::to_string(port);
    std::vector<std::string> plant = {b.exe, "plant", scenario, "--bus", bus, "--out", b.dir + "/" + name, "--quiet",
                                      "--ecu-wait-s", "30", "--allow-degraded"};
    if (lockstep) plant.push_back("--lockstep");
    plant.insert(plant.end(), plant_extra.begin(), plant_extra.end());
    std::vector<std::string> ecu = ecu_argv ? ecu_argv(port)
                                            : std::vector<std::string>{b.exe, "ecu", scenario, "--bus", bus, "--quiet",
                                                                       "--idle-timeout-s", "10"};
    for (const auto& a : b.duration_set(seconds)) {
      plant.push_back(a);
      if (!ecu_argv) ecu.push_back(a);
    }
    Child p, e;
    std::string why;
    if (!p.start(plant, b.logs + "/" + name + "_plant.out", b.logs + "/" + name + "_plant.err", why)) return fail(b, r, why);
    // until it listens (or ends: a port taken meanwhile is tried again)
    int code = 0;
    bool ended = false;
    const auto w0 = Clock::now();
    while (!listening(port) && !stopping() && seconds_since(w0) < 20.0) {
      if ((ended = p.poll(code))) break;
      sleep_s(0.02);
    }
    if (stopping()) {
      r.status = "stopped";
      return;
    }
    if (ended || !listening(port)) {
      const std::string line = last_line(b.logs + "/" + name + "_plant.err");
      if (ended && line.find("port in use") != std::string::npos) continue;
      return fail(b, r, "the plant does not listen on " + bus + (line.empty() ? "" : ": " + line));
    }
    if (!e.start(ecu, b.logs + "/" + name + "_ecu.out", b.logs + "/" + name + "_ecu.err", why)) return fail(b, r, why);
    const Outcome po = p.wait(120.0 + 2.0 * seconds);
    const Outcome eo = e.wait(30.0);
    r.wall_s = seconds_since(t0);
    if (po.stopped || eo.stopped) {
      r.status = "stopped";
      return;
    }
    if (po.code != 0 || po.timed_out) {
      const std::string line = last_line(b.logs + "/" + name + "_plant.err");
      return fail(b, r, "ehpt plant: " + (po.why.empty() ? "exit " + std::to_string(po.code) : po.why) +
                            (line.empty() ? "" : ": " + line));
    }
    if (eo.code != 0 || eo.timed_out) {
      const std::string line = last_line(b.logs + "/" + name + "_ecu.err");
      return fail(b, r, (ecu_argv ? "the ECU" : "ehpt ecu") + std::string(": exit ") + std::to_string(eo.code) +
                            (line.empty() ? "" : ": " + line));
    }
    Json j;
    if (!read_summary(b.dir + "/" + name, b.started_at, j, why)) return fail(b, r, why);
    return take_summary(b, r, j);
  }
  if (!stopping()) fail(b, r, "no free port after 3 attempts");
}

// ehpt plant --lockstep + ehpt ecu over LCM udpm in a network namespace of their own, into DIR/name.
void lcm_run(Bench& b, const std::string& name, const char* scenario) {
  SubRun& r = b.run(name);
  const std::string bus = "lcm:udpm://239.255.76.67:7667?ttl=0";
  std::vector<std::string> plant = {b.exe, "plant", scenario, "--bus", bus, "--lockstep", "--out", b.dir + "/" + name,
                                    "--quiet", "--ecu-wait-s", "30", "--allow-degraded"};
  std::vector<std::string> ecu = {b.exe, "ecu", scenario, "--bus", bus, "--quiet", "--idle-timeout-s", "2"};
  for (const auto& a : b.duration_set(b.seconds)) {
    plant.push_back(a);
    ecu.push_back(a);
  }
  const std::string err = b.logs + "/" + name + ".err";
  const double timeout_s = 120.0 + 2.0 * b.seconds;
  // fork, then a new network namespace in the child: only safe while this process has one
  // thread (it has: nothing here starts one; checked, not assumed)
  if (read_small_file("/proc/self/status").find("\nThreads:\t1\n") == std::string::npos) {
    r.status = "not run: the bench process has more than one thread (fork is not safe)";
    return;
  }
  std::fflush(stdout);
  std::fflush(stderr);
  const pid_t pid = ::fork();
  if (pid < 0) return fail(b, r, std::string("fork: ") + std::strerror(errno));
  if (pid == 0) {
    ::setpgid(0, 0);
    const int fd = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd >= 0) {
      ::dup2(fd, STDERR_FILENO);
      ::close(fd);
    }
    lcm_in_netns(name, plant, ecu, b.logs, timeout_s);
  }
  ::setpgid(pid, pid);  // also from here, so that killpg works at once
  Child c;
  c.adopt(pid, true);
  const Outcome o = c.wait(timeout_s + 40.0);
  r.wall_s = o.wall_s;
  if (o.stopped) {
    r.status = "stopped";
    return;
  }
  if (o.code == 77) {
    r.status = "not run: " + last_line(err);
    return;
  }
  if (o.code != 0 || o.timed_out) {
    const std::string line = last_line(err);
    return fail(b, r, (o.timed_out ? o.why : "exit " + std::to_string(o.code)) + (line.empty() ? "" : ": " + line));
  }
  Json j;
  std::string why;
  if (!read_summary(b.dir + "/" + name, b.started_at, j, why)) return fail(b, r, why);
  take_summary(b, r, j);
}

// The transports' floors (targets/bench/pingpong.hpp), just before the lockstep runs they are
// compared with. TCP: a PSecu2 sample's seven socketcand frames one way (48 characters each),
// its two command frames back; UDP: an LCM sensor message one way, a command back (header,
// channel name and payload). At these sizes the round trip hardly depends on them.
void floor_runs(Bench& b) {
  b.tcp_floor = ping_pong(PingPongKind::kTcp, 336, 80, 1.0);
  if (!stopping()) b.udp_floor = ping_pong(PingPongKind::kUdp, 256, 128, 1.0);
}

void replay_run(Bench& b) {
  SubRun& r = b.run("replay");
  // this build has it when `ehpt replay --help` says so
  Child probe;
  std::string why;
  b.replay_available = probe.start({b.exe, "replay", "--help"}, "/dev/null", "/dev/null", why) && probe.wait(10.0).ok();
  if (!b.replay_available) {
    r.status = "not available in this build";
    return;
  }
  if (!b.run("wallclock_socketcand").ok()) {
    r.status = "not run: the wall-clock session failed";
    return;
  }
  const Outcome o = run_child({b.exe, "replay", b.dir + "/wallclock_socketcand", "--out", b.dir + "/replay", "--quiet"},
                              b.logs, "replay", 300.0);
  r.wall_s = o.wall_s;
  if (o.stopped) {
    r.status = "stopped";
    return;
  }
  // exit 1: the replay ran and its hash differs (the comparison below reports it)
  Json j;
  if ((o.code == 0 || o.code == 1) && read_summary(b.dir + "/replay", b.started_at, j, why)) return take_summary(b, r, j);
  fail(b, r, o.why.empty() ? why : o.why);
}

}  // namespace

// Reads DIR/name/summary.json written by this bench (not an earlier one).
bool read_summary(const std::string& dir, std::time_t since, Json& j, std::string& why) {
  const std::string path = dir + "/summary.json";
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    why = path + ": " + std::strerror(errno);
    return false;
  }
  if (st.st_mtime + 1 < since) {
    why = path + ": older than this bench";
    return false;
  }
  if (!read_json(path, j)) {
    why = path + ": not readable JSON";
    return false;
  }
  return true;
}

// A stock python-can 4.1 ECU written the obvious way (tools/pycan_ecu.py: socketcand, two
// command frames per sample, Nagle left on) driving PSecu2, in lockstep (the rate a user's own
// python-can ECU gets) and on the wall clock (how far apart its two frames of a sample come:
// a period, before the plant ACKed at once). Not run where the tool or python3-can is missing
// (said so, not failed).
void pycan_run(Bench& b, const std::string& name, bool lockstep, double seconds) {
  SubRun& r = b.run(name);
  const std::string tool = ehpt::hil::tools_dir() + "/pycan_ecu.py";
  if (access(tool.c_str(), R_OK) != 0) {
    r.status = "not run: " + tool + " not found";
    return;
  }
  const Outcome probe = run_child({"/usr/bin/python3", "-c", "import can"}, b.logs, name + "_probe", 30.0);
  if (!probe.ok()) {
    r.status = "not run: /usr/bin/python3 cannot import can (apt-get install python3-can)";
    return;
  }
  socketcand_run(b, name, lockstep, seconds, "psecu2_nedc", [tool](int port) {
    return std::vector<std::string>{"/usr/bin/python3", tool, "--vehicle", "psd", "--interface", "socketcand",
                                    "--host", "127.0.0.1", "--port", std::to_string(port), "--channel", "can0",
                                    "--idle-timeout", "10"};
  });
}

// The VCU that knows only its own DBC (examples/own_dbc/vcu_ecu.py, python-can + canmatrix,
// E2E on its torques, no echo) answering PSecu2 through its binding, on the wall clock or in
// the real-time loop: whether it keeps up (stale samples, timeouts) on this machine. Its
// calibration is the scenario's, written by the Python module of this build (or the installed
// one). Not run where the example, canmatrix or the module is missing (said so).
void own_dbc_run(Bench& b, const std::string& name, bool realtime) {
  SubRun& r = b.run(name);
  const std::string tools = ehpt::hil::tools_dir();
  std::string folder;
  for (const std::string& candidate : {tools + "/../examples/own_dbc", tools + "/../../share/doc/ehpt/examples/own_dbc"}) {
    if (access((candidate + "/vcu_ecu.py").c_str(), R_OK) == 0) {
      folder = candidate;
      break;
    }
  }
  if (folder.empty()) {
    r.status = "not run: examples/own_dbc/vcu_ecu.py not found beside " + tools;
    return;
  }
  const std::string module_dir = b.exe.substr(0, b.exe.rfind('/') + 1) + "python";
  const std::string cal = b.dir + "/" + name + "_calibration.json";
  const Outcome o = run_child({"/usr/bin/python3", "-c",
                               "import sys, json; sys.path.insert(0, sys.argv[1]); import canmatrix, can, ehpt; "
                               "json.dump(dict(ehpt.Simulation('psecu2_nedc', external_ecu=True).ecu_parameters), "
                               "open(sys.argv[2], 'w'))",
                               module_dir, cal},
                              b.logs, name + "_calibration", 60.0);
  if (!o.ok()) {
    r.status = "not run: /usr/bin/python3 cannot import canmatrix, can and ehpt (python3-canmatrix, python3-can, the "
               "module of this build)";
    return;
  }
  std::vector<std::string> plant_extra = {"--bus-map", folder + "/vcu.binding.toml"};
  if (realtime) {
    for (const std::string& a : {std::string("--realtime"), std::string("--cpu"), std::to_string(b.cpu),
                                 std::string("--priority"), std::to_string(b.opt.priority)}) {
      plant_extra.push_back(a);
    }
  }
  const std::string vcu = folder + "/vcu_ecu.py";
  socketcand_run(
      b, name, false, b.wall_clock_s, "psecu2_nedc",
      [vcu, cal](int port) {
        return std::vector<std::string>{"/usr/bin/python3", vcu, "--port", std::to_string(port), "--calibration", cal,
                                        "--idle-timeout-s", "10"};
      },
      plant_extra);
}

void take_summary(Bench& b, SubRun& r, const Json& j) {
  r.samples_per_s = json_num(j, "bus.samples_per_s");
  r.round_trip_p50_us = json_num(j, "bus.round_trip_us.p50");
  r.round_trip_p99_us = json_num(j, "bus.round_trip_us.p99");
  r.spread_p50_us = json_num(j, "bus.command_frames_spread_us.p50");
  r.spread_p99_us = json_num(j, "bus.command_frames_spread_us.p99");
  r.spread_max_us = json_num(j, "bus.command_frames_spread_us.max");
  r.stale_samples = json_num(j, "bus.stale_samples");
  r.timeouts = json_num(j, "bus.timeouts");
  r.hash = json_str(j, "trajectory_hash");
  // a bus session without its ECU the whole time (the plant runs with --allow-degraded so that
  // its summary is kept): its figures are not the exchange's, so the run did not do its job
  if (json_str(j, "status") == "degraded") {
    const Json* why = json_at(j, "degraded");
    fail(b, r, "the session was degraded" +
                   (why != nullptr && !why->items.empty() ? " (" + why->items.front().text + ")" : std::string()));
    return;
  }
  const double allocations = json_num(j, "heap_allocations_after_startup");
  r.allocations_reported = std::isfinite(allocations);
  if (r.allocations_reported) r.allocations = static_cast<long long>(allocations);
  r.peak_rss_MB = json_num(j, "peak_rss_MB");
  r.status = "ok";
}

void section_runs(Bench& b) {
  b.progress("(d, e) determinism and allocations: " + std::string(kRtScenario) + ", " + std::to_string(b.seconds) +
             " s as fast as possible (x3), the TCP and UDP ping-pong floors, lockstep over socketcand (ehpt ecu on it "
             "and on psecu2_nedc, and a python-can ECU on psecu2_nedc) and LCM (both); a " + fmt("%.0f", b.wall_clock_s) +
             " s wall-clock session over socketcand (ehpt ecu, and the python-can ECU) and its replay, the own-DBC VCU on "
             "the wall clock and in real time (about " + fmt("%.0f", 4.0 * b.wall_clock_s + 10.0) + " s)");
  batch_run(b, "batch_1", {});
  if (!stopping()) batch_run(b, "batch_2", {});
  if (!stopping()) batch_run(b, "batch_can", {"--set", "vehicle.ecu.codec=can"});
  if (!stopping()) floor_runs(b);
  if (!stopping()) socketcand_run(b, "lockstep_socketcand", true, b.seconds);
  if (!stopping()) socketcand_run(b, "lockstep_socketcand_psecu2", true, b.seconds, "psecu2_nedc");
  if (!stopping()) pycan_run(b, "lockstep_pycan", true, b.seconds);
  if (!stopping()) lcm_run(b, "lockstep_lcm", kRtScenario);
  if (!stopping()) lcm_run(b, "lockstep_lcm_psecu2", "psecu2_nedc");
  if (!stopping()) socketcand_run(b, "wallclock_socketcand", false, b.wall_clock_s);
  if (!stopping()) pycan_run(b, "wallclock_pycan", false, b.wall_clock_s);
  if (!stopping()) own_dbc_run(b, "wallclock_own_dbc", false);
  if (!stopping()) own_dbc_run(b, "realtime_own_dbc", true);
  if (!stopping()) replay_run(b);
}

}  // namespace ehpt::bench
