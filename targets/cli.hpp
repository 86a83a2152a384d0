// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// What every command of the CLI shares (targets/cli.cpp): the stop signal, writing to stdout,
// --help, loading a scenario with its messages, the real-time options, and the commands'
// entry points (one file each: targets/cmd_*.cpp, targets/bench/, dispatched by
// targets/ehpt_main.cpp). Exit codes: 0 ok, 1 usage / output / system error, 2 bad input
// (nothing was run), 3 run-time fault (outputs kept), 4 degraded bus session (outputs kept),
// 5 an expectation of the scenario failed (ehpt run; outputs kept),
// 128 + N stopped by signal N.

#include <atomic>
#include <cstddef>
#include <string>
#include <vector>

#include "hil/config/config.hpp"
#include "hil/run/realtime.hpp"

namespace ehpt::cli {

// The number of the signal that asked us to stop (set by ehpt_main.cpp's handler; lock-free).
extern std::atomic<int> g_stop;

// Writes text to stdout now. False (and a message on stderr) if it cannot: a full disk,
// a closed pipe. Plain write(2), so that the reason is known.
bool out(const std::string& text);

// --help or -h among the arguments.
bool wants_help(const std::vector<std::string>& args);

// Resolves a scenario name or path and loads it with the --set overrides. 0, or 2 with every
// problem on stderr (nothing is run).
// faults: --fault texts ("kind=stuck target=batSOC at_s=10").
int load(const std::string& name, const std::vector<std::string>& sets, ehpt::hil::Scenario& sc,
         const std::vector<std::string>& faults = {});

// The real-time options of 'ehpt run' and 'ehpt plant'.
struct RealtimeArgs {
  bool realtime = false, tuned = false;  // tuned: --period, --cpu or --priority given
  ehpt::hil::RealtimeOptions opt;
};

// Consumes a real-time option at args[i] (and its value). kNotRealtime: not one of them;
// 0: taken; 1: a missing or bad value (usage, as every option).
constexpr int kNotRealtime = -1;
int parse_realtime_arg(const std::vector<std::string>& args, std::size_t& i, RealtimeArgs& rt, const char* help);

// After loading: the period fits the scenario's step. 0 or the exit code.
int check_realtime(const RealtimeArgs& rt, const ehpt::hil::Scenario& sc);

// Draws the figures of the run in src_dir into out_dir with the plot tool (no shell: an
// argument vector), naming them as if in shown_dir. True on success (targets/cmd_plot.cpp).
bool run_plot_tool(const std::string& src_dir, const std::string& out_dir, const std::string& shown_dir, bool quiet);

// A test run's figures, one per failed expectation (tools/plot_expect.py), into dir; true on
// success or when nothing failed.
bool run_expect_figures(const std::string& dir, bool quiet);

// The commands (args without the command word).
int cmd_run(const std::vector<std::string>& args);      // targets/cmd_run.cpp
int cmd_plant(const std::vector<std::string>& args);    // targets/cmd_plant_ecu.cpp
int cmd_ecu(const std::vector<std::string>& args);      // targets/cmd_plant_ecu.cpp
int cmd_replay(const std::vector<std::string>& args);   // targets/cmd_replay.cpp
int cmd_list(const std::vector<std::string>& args);     // targets/cmd_list_signals.cpp
int cmd_signals(const std::vector<std::string>& args);  // targets/cmd_list_signals.cpp
int cmd_plot(const std::vector<std::string>& args);     // targets/cmd_plot.cpp
int cmd_dbc(const std::vector<std::string>& args);
int cmd_fmu(const std::vector<std::string>& args);      // targets/cmd_fmu.cpp      // targets/cmd_dbc.cpp
int cmd_test(const std::vector<std::string>& args);     // targets/cmd_test.cpp

}  // namespace ehpt::cli
