// SPDX-License-Identifier: BSD-3-Clause
// The machine's facts (machine.hpp).
#include "targets/bench/machine.hpp"

#include "targets/bench/common.hpp"

namespace ehpt::bench {

std::string loadavg() {
  std::istringstream in(read_small_file("/proc/loadavg"));
  std::string a, b, c;
  in >> a >> b >> c;
  return a.empty() ? "unknown" : a + " " + b + " " + c;
}

std::string cpu_model() {
  std::istringstream in(read_small_file("/proc/cpuinfo"));
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) return trim(line.substr(line.find_first_not_of(" \t", colon + 1)));
    }
  }
  return "unknown";
}

std::string kernel() {
  utsname u{};
  if (::uname(&u) != 0) return "unknown";
  return std::string(u.sysname) + " " + u.release + " " + u.version + " " + u.machine;
}

int allowed_cpus(int& last) {
  cpu_set_t set;
  CPU_ZERO(&set);
  last = -1;
  if (::sched_getaffinity(0, sizeof set, &set) != 0) return 0;
  for (int c = 0; c < CPU_SETSIZE; ++c) {
    if (CPU_ISSET(c, &set)) last = c;
  }
  return CPU_COUNT(&set);
}

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  ::gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

void build_commit(std::string& commit, bool& dirty) {
  std::string git(ehpt::hil::build_info().git);
  const std::string suffix = "-dirty";
  dirty = git.size() > suffix.size() && git.compare(git.size() - suffix.size(), suffix.size(), suffix) == 0;
  if (dirty) git.resize(git.size() - suffix.size());
  commit = git;
}

}  // namespace ehpt::bench
