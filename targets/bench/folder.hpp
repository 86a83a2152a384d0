// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The bench's output folder (default bench-out): made fresh, or empty, or an earlier bench
// (bench.json with our format line and nothing but the names of kRunDirs, logs/, bench.json,
// bench.txt, the bench's own input files (kInputFiles), and what ehpt leaves beside a run
// stopped hard); anything else is refused.

#include <string>

namespace ehpt::bench {

// "" if dir may be used (exists says whether it does), else why not.
std::string check_out_dir(const std::string& dir, bool& exists);

}  // namespace ehpt::bench
