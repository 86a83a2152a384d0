// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// What the bench records about the machine it ran on (bench.json "machine").

#include <string>

namespace ehpt::bench {

// /proc/loadavg's three figures ("0.52 0.61 0.70").
std::string loadavg();
// The CPU model (/proc/cpuinfo "model name").
std::string cpu_model();
// uname: "Linux 6.1.0-... x86_64".
std::string kernel();
// The number of CPUs this process may run on; last: the highest of them (-1 if unknown).
int allowed_cpus(int& last);
// Now, UTC, ISO 8601.
std::string utc_now();
// The commit this binary was built from (`git describe --dirty` at build time): the commit
// and whether the tree was dirty.
void build_commit(std::string& commit, bool& dirty);

}  // namespace ehpt::bench
