// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// What both harnesses do with a loader's answer: print it on request, and treat a broken
// promise of the loader's header like a crash (abort, so that libFuzzer saves the input).

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace ehpt::fuzz {

// EHPT_FUZZ_VERBOSE=1 prints each answer: to see what the loader made of a saved input.
inline void report(const char* harness, bool ok, const std::vector<std::string>& errors) {
  static const bool verbose = std::getenv("EHPT_FUZZ_VERBOSE") != nullptr;
  if (!verbose) return;
  std::fprintf(stderr, "%s: %s, %zu messages\n", harness, ok ? "accepted" : "rejected", errors.size());
  for (const std::string& e : errors) std::fprintf(stderr, "  %s\n", e.c_str());
}

inline void require(const char* harness, bool condition, const char* what) {
  if (!condition) {
    std::fprintf(stderr, "%s: contract broken: %s\n", harness, what);
    std::abort();
  }
}

}  // namespace ehpt::fuzz
