// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The bench's reports: the table (stdout, bench.txt) and bench.json.

#include <string>

#include "targets/bench/state.hpp"

namespace ehpt::bench {

// Every group of sub-runs that must be bit-identical is (the runs that did not run aside).
bool all_equal(const Bench& b);
std::string report_text(const Bench& b);
std::string report_json(const Bench& b);
// bench.json (and with_text: bench.txt, the table also returned in text), written atomically.
bool write_reports(Bench& b, bool with_text, std::string& text);

}  // namespace ehpt::bench
