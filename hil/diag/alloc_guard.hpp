// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The allocation guard: heap allocations counted at the malloc level, for the whole process,
// between arm() and disarm(); in a debug build (or with EHPT_ABORT_ON_ALLOC=1) the first one
// aborts the process, naming where.
//
// What is counted: every call, from any thread and any library (libc's own strdup/fopen,
// libstdc++, liblcm, glib), to malloc, calloc, realloc, aligned_alloc, posix_memalign,
// memalign, valloc, pvalloc and every form of the global operator new / new[] (plain, nothrow,
// std::align_val_t, aligned nothrow). Each call counts once (operator new does not count again
// in malloc). free and operator delete are not counted. mmap, and the stacks of new threads,
// are not heap allocations and are not counted.
//
// Two pieces, so that a library can use the API without taking the hooks:
//  * this API (hil/diag/alloc_guard_api.cpp, part of ehpt_hil): the flag, the counter, arm/disarm,
//    the report of the first allocation. Without the hooks it does nothing: active() is false,
//    count() stays 0.
//  * the hooks (hil/diag/alloc_hooks.cpp, CMake target ehpt_alloc_guard): the interposed malloc
//    family and operator new/delete, forwarding to glibc's own allocator (__libc_malloc...).
//    Only an executable that links ehpt_alloc_guard has them (the ehpt CLI,
//    alloc_guard_tests); ehpt_hil, the other tests and the fuzzers do not. Not to be combined
//    with another malloc replacement (ASan, tests/support/alloc_counter.cpp, tcmalloc).
//
// Cost: while disarmed, one relaxed atomic load per allocation; while armed, a relaxed atomic
// increment as well (and, for the first allocation after reset(), one backtrace()).
//
// Use (start-up, then the run phase):
//   alloc_guard::reset();
//   alloc_guard::arm();                       // after start-up: every buffer is sized
//   ... run phase ...
//   alloc_guard::disarm();
//   if (alloc_guard::active()) n = alloc_guard::count(), where = alloc_guard::describe_first();
//
// Threads: the flag and the counter are process-wide. An allocation by any thread while armed
// counts (that is the point: an IO or logging thread allocating during the run is found too).
// count() is exact for the allocations that happen-before the call (e.g. threads joined, or
// after disarm() in the thread that armed); a thread allocating concurrently with disarm() may
// or may not be counted.
//
// Abort on allocation, decided by arm() (later changes take effect at the next arm()), the
// first that applies:
//   1. the environment variable EHPT_ABORT_ON_ALLOC: "0" off, any other non-empty value on;
//   2. set_abort_on_allocation(bool), if called;
//   3. the build's default: on when ehpt_alloc_guard is built with EHPT_ALLOC_ABORT (CMake
//      option, AUTO = Debug builds), otherwise off.
// When on, the first armed allocation disarms the guard, writes to stderr one line naming the
// allocation (kind, size, caller) and then a backtrace (one line per frame), and calls abort().

#include <atomic>
#include <cstddef>
#include <cstdint>

namespace ehpt::hil::alloc_guard {

// What was called. Names: kind_name().
enum class Kind : int {
  kNone = 0,
  kMalloc,
  kCalloc,
  kRealloc,
  kAlignedAlloc,
  kPosixMemalign,
  kMemalign,
  kValloc,
  kPvalloc,
  kNew,
  kNewArray,
  kNewNothrow,
  kNewArrayNothrow,
  kNewAligned,
  kNewArrayAligned,
  kNewAlignedNothrow,
  kNewArrayAlignedNothrow,
};
const char* kind_name(Kind kind);  // "malloc", "operator new[](align_val_t)", ...

// Whether the hooks are linked into this process (ehpt_alloc_guard). Without them nothing is
// ever counted.
bool active();

// Start-up: starts counting (the count is not reset: see reset()). Decides abort-on-allocation
// (see above: reads EHPT_ABORT_ON_ALLOC) and calls backtrace() once, so that glibc loads
// libgcc_s now (a first backtrace() allocates) and not inside the first counted allocation.
// Does nothing to allocations if !active().
void arm();
// Stops counting. Run phase: no allocation.
void disarm();
bool armed();

// Allocations counted while armed since the start of the process or the last reset().
// Run phase: no allocation.
std::int64_t count();
// Count to 0 and the first allocation forgotten. Call while disarmed.
void reset();

// The program's choice for the next arm() (the environment variable overrides it).
void set_abort_on_allocation(bool abort_on_allocation);
// Whether the guard, as last armed, aborts on an allocation (false before the first arm()).
bool abort_on_allocation();
// The build's default (EHPT_ALLOC_ABORT); false without the hooks.
bool abort_on_allocation_by_default();

// The first allocation counted since reset(), on one line: kind, size and the calling frames,
// innermost first, each as module(symbol+0xoffset) or module(+0xoffset) (an offset for
// `addr2line -e module`), e.g.
//   "calloc of 24 bytes, from ehpt(+0x3a4f1) <- ehpt(+0x2b210) <- libc.so.6(__libc_start_main+0x85)"
// "" when nothing was counted. Points into a static buffer, valid until the next call; call from
// one thread at a time. Does not allocate (safe while armed).
const char* describe_first();

// For the hooks (hil/diag/alloc_hooks.cpp) only. The state is constant-initialised, so the hooks
// can read it from the first allocation of the process, before any static constructor runs.
namespace detail {
extern constinit std::atomic<bool> g_armed;
// Counts one armed allocation; the first since reset() is recorded (or aborts). caller: the
// hook's return address. Never allocates, never throws.
void on_allocation(Kind kind, std::size_t size, void* caller) noexcept;
// Called once by the hooks' static initialiser: they are linked, with this build default.
void register_hooks(bool abort_by_default) noexcept;

// The hooks' fast path: one relaxed load while disarmed.
inline void note_allocation(Kind kind, std::size_t size, void* caller) noexcept {
  if (g_armed.load(std::memory_order_relaxed)) [[unlikely]] {
    on_allocation(kind, size, caller);
  }
}
}  // namespace detail

}  // namespace ehpt::hil::alloc_guard
