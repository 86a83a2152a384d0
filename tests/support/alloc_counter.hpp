// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Counts calls to the global operator new (defined in alloc_counter.cpp, linked only into
// alloc_tests), so a test can assert that the run phase allocates nothing.
#include <cstddef>

namespace ehpt::test {
std::size_t allocation_count();
}
