// SPDX-License-Identifier: BSD-3-Clause
// The allocation guard (hil/diag/alloc_guard.hpp) with its hooks linked (ehpt_alloc_guard): every
// allocating entry counted exactly once while armed, and only then; from any thread; libc's
// own allocations too; the first one described; abort on allocation, by choice or by the
// environment, naming the kind and with a backtrace.
//
// Each allocation is stored in a volatile global, so that the compiler cannot elide a
// malloc/free or new/delete pair, and is freed after disarm(). Between arm() and disarm() the
// tests do nothing but the allocation under test: gtest's own work happens outside.
#include <gtest/gtest.h>
#include <malloc.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <new>
#include <string>
#include <thread>

#include "hil/diag/alloc_guard.hpp"

namespace ehpt::hil {
namespace {

namespace ag = alloc_guard;

void* volatile g_sink = nullptr;

struct alignas(64) Aligned64 {
  char bytes[64];
};

// Made before main, through the hooks (disarmed): they work during static initialisation.
const std::string g_made_before_main(1000, 'x');

class AllocGuard : public ::testing::Test {
 protected:
  void SetUp() override {
    ::unsetenv("EHPT_ABORT_ON_ALLOC");
    ag::disarm();
    ag::set_abort_on_allocation(false);
    ag::reset();
  }
  void TearDown() override { ag::disarm(); }
};

// One allocating call under test and how to free what it returned (outside the armed window).
struct Case {
  const char* kind;  // kind_name() of the first allocation
  void (*allocate)();
  void (*release)();
  std::int64_t expected = 1;
};

void free_sink() { std::free(g_sink); }

const Case kCases[] = {
    {"malloc", [] { g_sink = std::malloc(24); }, free_sink},
    {"calloc", [] { g_sink = std::calloc(3, 8); }, free_sink},
    {"aligned_alloc", [] { g_sink = std::aligned_alloc(64, 128); }, free_sink},
    {"posix_memalign",
     [] {
       void* p = nullptr;
       if (::posix_memalign(&p, 64, 100) == 0) g_sink = p;
     },
     free_sink},
    {"memalign", [] { g_sink = ::memalign(64, 100); }, free_sink},
    {"valloc", [] { g_sink = ::valloc(100); }, free_sink},
    {"pvalloc", [] { g_sink = ::pvalloc(100); }, free_sink},
    {"operator new", [] { g_sink = new int(7); }, [] { delete static_cast<int*>(g_sink); }},
    {"operator new[]", [] { g_sink = new char[10]; }, [] { delete[] static_cast<char*>(g_sink); }},
    {"operator new(nothrow)", [] { g_sink = new (std::nothrow) int(7); },
     [] { delete static_cast<int*>(g_sink); }},
    {"operator new[](nothrow)", [] { g_sink = new (std::nothrow) char[10]; },
     [] { delete[] static_cast<char*>(g_sink); }},
    {"operator new(align_val_t)", [] { g_sink = new Aligned64; }, [] { delete static_cast<Aligned64*>(g_sink); }},
    {"operator new[](align_val_t)", [] { g_sink = new Aligned64[3]; },
     [] { delete[] static_cast<Aligned64*>(g_sink); }},
    {"operator new(align_val_t, nothrow)", [] { g_sink = new (std::nothrow) Aligned64; },
     [] { delete static_cast<Aligned64*>(g_sink); }},
    {"operator new[](align_val_t, nothrow)", [] { g_sink = new (std::nothrow) Aligned64[3]; },
     [] { delete[] static_cast<Aligned64*>(g_sink); }},
    // libc's own allocations are malloc calls too (the malloc level, not only our code)
    {"malloc", [] { g_sink = ::strdup("a string libc copies with malloc"); }, free_sink},
    // libstdc++ allocates through operator new: the object, then its buffer
    {"operator new", [] { g_sink = new std::string(100, 's'); }, [] { delete static_cast<std::string*>(g_sink); },
     2},
};

TEST_F(AllocGuard, TheHooksAreLinkedAndWorkedBeforeMain) {
  EXPECT_TRUE(ag::active());
  EXPECT_EQ(g_made_before_main.size(), 1000u);
  EXPECT_EQ(ag::count(), 0);
  EXPECT_STREQ(ag::describe_first(), "");
}

TEST_F(AllocGuard, EveryAllocatingEntryCountsExactlyOnceAndIsNamed) {
  for (const Case& c : kCases) {
    SCOPED_TRACE(c.kind);
    ag::reset();
    ag::arm();
    c.allocate();
    ag::disarm();
    const std::int64_t n = ag::count();
    const std::string first = ag::describe_first();
    c.release();
    ASSERT_NE(g_sink, nullptr);
    EXPECT_EQ(n, c.expected) << first;
    // "calloc of 24 bytes, from alloc_guard_tests(+0x...) <- ..."
    EXPECT_EQ(first.rfind(std::string(c.kind) + " of ", 0), 0u) << first;
    EXPECT_NE(first.find(", from "), std::string::npos) << first;
  }
}

TEST_F(AllocGuard, ReallocCountsEachCall) {
  void* p = std::malloc(16);
  ag::arm();
  p = std::realloc(p, 4096);  // grows: moves
  g_sink = p;
  p = std::realloc(p, 8);  // shrinks: may stay, still a call
  g_sink = p;
  ag::disarm();
  std::free(p);
  EXPECT_EQ(ag::count(), 2);
  EXPECT_EQ(std::string(ag::describe_first()).rfind("realloc of 4096 bytes", 0), 0u) << ag::describe_first();
}

TEST_F(AllocGuard, FreeAndDeleteAreNotCounted) {
  void* p = std::malloc(32);
  int* q = new int(1);
  g_sink = q;
  ag::arm();
  std::free(p);
  delete q;
  ag::disarm();
  EXPECT_EQ(ag::count(), 0);
}

TEST_F(AllocGuard, NothingIsCountedWhileDisarmed) {
  g_sink = std::malloc(24);  // before arm
  std::free(g_sink);
  ag::arm();
  ag::disarm();
  g_sink = std::malloc(24);  // after disarm
  std::free(g_sink);
  g_sink = new int(3);
  delete static_cast<int*>(g_sink);
  EXPECT_EQ(ag::count(), 0);
  EXPECT_STREQ(ag::describe_first(), "");
}

TEST_F(AllocGuard, CountsAccumulateOverArmingsUntilReset) {
  for (int i = 0; i < 3; ++i) {
    ag::arm();
    g_sink = std::malloc(8);
    ag::disarm();
    std::free(g_sink);
  }
  EXPECT_EQ(ag::count(), 3);
  ag::reset();
  EXPECT_EQ(ag::count(), 0);
  EXPECT_STREQ(ag::describe_first(), "");
}

// The count is process-wide: an allocation by another thread while armed counts too.
TEST_F(AllocGuard, AnotherThreadsAllocationCounts) {
  std::atomic<int> phase{0};  // 1: allocate, 2: done
  void* theirs = nullptr;
  std::thread other([&] {  // made while disarmed (std::thread allocates its state)
    while (phase.load() != 1) std::this_thread::yield();
    theirs = std::calloc(5, 10);
    phase.store(2);
  });
  ag::arm();
  phase.store(1);
  while (phase.load() != 2) std::this_thread::yield();
  ag::disarm();
  other.join();
  g_sink = theirs;
  std::free(theirs);
  EXPECT_EQ(ag::count(), 1);
  EXPECT_EQ(std::string(ag::describe_first()).rfind("calloc of 50 bytes", 0), 0u) << ag::describe_first();
}

TEST_F(AllocGuard, ManyThreadsCountExactly) {
  constexpr int kThreads = 4, kEach = 1000;
  std::atomic<int> go{0};
  std::atomic<int> done{0};
  std::thread threads[kThreads];
  for (auto& t : threads) {
    t = std::thread([&] {
      while (go.load() == 0) std::this_thread::yield();
      for (int i = 0; i < kEach; ++i) {
        void* p = std::malloc(static_cast<std::size_t>(16 + i));
        g_sink = p;
        std::free(p);
      }
      done.fetch_add(1);
    });
  }
  ag::arm();
  go.store(1);
  while (done.load() != kThreads) std::this_thread::yield();
  ag::disarm();
  for (auto& t : threads) t.join();
  EXPECT_EQ(ag::count(), kThreads * kEach);
}

TEST_F(AllocGuard, TheEnvironmentDecidesAtArmTime) {
  ag::set_abort_on_allocation(true);
  ::setenv("EHPT_ABORT_ON_ALLOC", "0", 1);
  ag::arm();
  EXPECT_FALSE(ag::abort_on_allocation());
  g_sink = std::malloc(8);  // counted, no abort
  ag::disarm();
  std::free(g_sink);
  EXPECT_EQ(ag::count(), 1);
  ::unsetenv("EHPT_ABORT_ON_ALLOC");
  ag::set_abort_on_allocation(false);
  ag::arm();
  ag::disarm();
  EXPECT_FALSE(ag::abort_on_allocation());
}

TEST_F(AllocGuard, TheBuildDefaultAppliesWhenNothingIsChosen) {
  EXPECT_EQ(ag::abort_on_allocation_by_default(), EHPT_ALLOC_ABORT_DEFAULT != 0);
}

using AllocGuardDeathTest = AllocGuard;

// The first armed allocation aborts: one line naming it and where, then the backtrace
// (backtrace_symbols_fd: "path(symbol+0x..)[0x...]", innermost first, from the caller).
TEST_F(AllocGuardDeathTest, AbortsOnTheFirstArmedAllocationNamingWhere) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        ag::set_abort_on_allocation(true);
        ag::arm();
        g_sink = std::calloc(3, 8);
      },
      ::testing::KilledBySignal(SIGABRT),
      "heap allocation while the allocation guard is armed: calloc of 24 bytes, from "
      "alloc_guard_tests\\(.*\\), thread [0-9]+; backtrace, innermost first:\n"
      ".*alloc_guard_tests\\(.*\\)\\[0x[0-9a-f]+\\]\n");
}

TEST_F(AllocGuardDeathTest, TheEnvironmentForcesTheAbort) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        ::setenv("EHPT_ABORT_ON_ALLOC", "1", 1);
        ag::set_abort_on_allocation(false);
        ag::arm();
        g_sink = new Aligned64;
      },
      ::testing::KilledBySignal(SIGABRT), "armed: operator new\\(align_val_t\\) of 64 bytes, from .*\\[0x");
}

TEST_F(AllocGuardDeathTest, NoAbortWhileDisarmed) {
  ag::set_abort_on_allocation(true);
  ag::arm();
  ag::disarm();
  g_sink = std::malloc(8);
  std::free(g_sink);
  EXPECT_TRUE(ag::abort_on_allocation());
  EXPECT_EQ(ag::count(), 0);
}

}  // namespace
}  // namespace ehpt::hil
