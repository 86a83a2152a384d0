// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// What the parts of `ehpt bench` share (targets/bench/): the stop signal, small text and file
// helpers, reading the sub-runs' JSON, figures (median, min, max) and the table layout.

#include <arpa/inet.h>
#include <fcntl.h>
#include <net/if.h>
#include <net/route.h>
#include <sched.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/utsname.h>
#include <sys/wait.h>
#include <netinet/in.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "hil/config/config.hpp"
#include "hil/reference/cvode_reference.hpp"
#include "hil/diag/provenance.hpp"
#include "hil/run/realtime.hpp"
#include "hil/config/scenario.hpp"
#include "hil/run/simulation.hpp"
#include "io/json_value.hpp"
#include "io/number_format.hpp"
#include "io/output_dir.hpp"
#include "io/json_writer.hpp"
#include "io/process.hpp"
#include "io/text_file.hpp"

namespace ehpt::bench {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// The number of the signal that asked the bench to stop (its own handler, targets/bench/bench.cpp).
extern std::atomic<int> g_stop;
bool stopping();

double seconds_since(Clock::time_point t0);
// Sleeps s seconds; a signal cuts it short (the callers look at g_stop).
void sleep_s(double s);
// Writes text to stdout; false (and a message on stderr) if it cannot.
bool write_stdout(const std::string& text);
// printf of one number; "-" if it is not finite.
std::string fmt(const char* f, double v);
// A text file of at most 16 MiB; "" if it cannot be read.
std::string read_small_file(const std::string& path);
// The last non-empty line of a text file (a child's stderr), at most 300 characters.
std::string last_line(const std::string& path);
// Without trailing newlines and spaces.
std::string trim(std::string s);

// ---- reading JSON (the sub-runs' summary.json, an earlier bench.json): io/json_value.hpp ---
using Json = ehpt::io::JsonValue;
// a.b.c through nested objects; nullptr if a part is missing
const Json* json_at(const Json& j, std::string_view path);
// The number at path, NaN if it is missing or not a number.
double json_num(const Json& j, std::string_view path);
std::string json_str(const Json& j, std::string_view path);
bool read_json(const std::string& path, Json& out);

// Loads a scenario with overrides; "" or every problem on one line.
std::string load(const std::string& name, const std::vector<std::string>& sets, ehpt::hil::Scenario& sc);

// ---- figures ----------------------------------------------------------------------------
struct Spread {
  double median = NAN, min = NAN, max = NAN;
};
Spread spread(std::vector<double> v);
ehpt::io::JsonObject spread_json(const Spread& s);
// A fixed-width table; align holds one letter per column: 'l' left, 'r' right.
std::string table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows,
                  const std::string& align);
// 100 (a - b) / b; NaN if either is missing or b is 0.
double rel_pct(std::optional<double> a, std::optional<double> b);

// ---- the output folder ------------------------------------------------------------------
inline constexpr const char* kBenchFormat = "ehpt bench, version 1";
// The scenario of (c), (d) and (e): the map EV on Sort1, which moves from t = 0 (NEDC stands
// still for its first 11 s, so a 5 s run would compare trajectories of a car at rest).
inline constexpr const char* kRtScenario = "ev_sort1";
inline const std::vector<std::string> kRunDirs = {"batch_1",  "batch_2", "batch_can", "realtime", "lockstep_socketcand",
                                           "lockstep_socketcand_psecu2", "lockstep_pycan", "lockstep_lcm",
                                           "lockstep_lcm_psecu2", "wallclock_socketcand", "wallclock_pycan", "wallclock_own_dbc", "realtime_own_dbc", "replay"};
// The files a bench writes for its own runs to read (section_speed, section_runs, section_plan):
// an earlier bench holds them, and a bench into its folder writes them again.
inline const std::vector<std::string> kInputFiles = {"psecu2_test.toml", "plan_campaign.toml",
                                                     "wallclock_own_dbc_calibration.json",
                                                     "realtime_own_dbc_calibration.json"};

}  // namespace ehpt::bench
