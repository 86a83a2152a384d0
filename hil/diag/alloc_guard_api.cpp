// SPDX-License-Identifier: BSD-3-Clause
// The allocation guard's state and API (see hil/diag/alloc_guard.hpp). Part of ehpt_hil: it never
// references the hooks (hil/diag/alloc_hooks.cpp), which find this state instead, so a binary
// without the hooks links and simply counts nothing.
//
// Everything reached from an allocation (detail::on_allocation and what it calls) runs inside
// malloc: it must not allocate, throw or take a lock that an allocation could be holding. It
// uses atomics, fixed buffers, write(2), glibc's backtrace() (preloaded by arm()),
// backtrace_symbols_fd() and dladdr() (neither allocates).
#include "hil/diag/alloc_guard.hpp"

#include <dlfcn.h>
#include <execinfo.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>

namespace ehpt::hil::alloc_guard {

namespace detail {
constinit std::atomic<bool> g_armed{false};
}  // namespace detail

namespace {

constexpr int kMaxFrames = 32;
constexpr int kMaxFramesDescribed = 12;

constinit std::atomic<std::int64_t> g_count{0};
constinit std::atomic<bool> g_hooks_linked{false};
constinit std::atomic<bool> g_abort_by_default{false};
constinit std::atomic<int> g_abort_requested{-1};  // set_abort_on_allocation: -1 never called
constinit std::atomic<bool> g_abort{false};         // as decided by the last arm()

// The first allocation since reset(), written by the one call that claims it.
enum : int { kFirstNone = 0, kFirstClaimed = 1, kFirstReady = 2 };
struct First {
  Kind kind = Kind::kNone;
  std::size_t size = 0;
  void* caller = nullptr;
  void* frames[kMaxFrames] = {};
  int depth = 0;
};
constinit std::atomic<int> g_first_state{kFirstNone};
constinit First g_first{};

// Text into a fixed buffer, truncated when full; never allocates.
class Line {
 public:
  Line(char* buf, std::size_t capacity) : buf_(buf), cap_(capacity) { buf_[0] = '\0'; }
  void text(const char* s) {
    while (*s != '\0' && len_ + 1 < cap_) buf_[len_++] = *s++;
    buf_[len_] = '\0';
  }
  void number(std::uint64_t v, unsigned base) {
    char digits[24];
    int n = 0;
    do {
      digits[n++] = "0123456789abcdef"[v % base];
      v /= base;
    } while (v != 0);
    char s[24];
    for (int i = 0; i < n; ++i) s[i] = digits[n - 1 - i];
    s[n] = '\0';
    text(s);
  }
  const char* c_str() const { return buf_; }
  std::size_t size() const { return len_; }

 private:
  char* buf_;
  std::size_t cap_;
  std::size_t len_ = 0;
};

const char* base_name(const char* path) {
  const char* slash = std::strrchr(path, '/');
  return slash != nullptr ? slash + 1 : path;
}

// module(symbol+0xoff) or module(+0xoff), as backtrace_symbols_fd() writes it.
void append_frame(Line& out, void* address) {
  Dl_info info{};
  if (dladdr(address, &info) == 0 || info.dli_fname == nullptr) {
    out.text("0x");
    out.number(reinterpret_cast<std::uintptr_t>(address), 16);
    return;
  }
  const auto at = reinterpret_cast<std::uintptr_t>(address);
  out.text(base_name(info.dli_fname));
  out.text("(");
  if (info.dli_sname != nullptr && info.dli_saddr != nullptr) {
    out.text(info.dli_sname);
    out.text("+0x");
    out.number(at - reinterpret_cast<std::uintptr_t>(info.dli_saddr), 16);
  } else {
    out.text("+0x");
    out.number(at - reinterpret_cast<std::uintptr_t>(info.dli_fbase), 16);
  }
  out.text(")");
}

// "calloc of 24 bytes"
void append_what(Line& out, Kind kind, std::size_t size) {
  out.text(kind_name(kind));
  out.text(" of ");
  out.number(size, 10);
  out.text(size == 1 ? " byte" : " bytes");
}

// The frames from the hook's caller on: the ones above it are the guard's own.
int first_caller_frame(void* const* frames, int depth, void* caller) {
  for (int i = 0; i < depth; ++i) {
    if (frames[i] == caller) return i;
  }
  return 0;
}

void write_all(int fd, const char* s, std::size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, s, n);
    if (w <= 0) return;
    s += w;
    n -= static_cast<std::size_t>(w);
  }
}

// The guard is already disarmed: what this does is not counted.
[[noreturn]] void report_and_abort(Kind kind, std::size_t size, void* caller) noexcept {
  void* frames[kMaxFrames];
  const int depth = backtrace(frames, kMaxFrames);
  const int from = first_caller_frame(frames, depth, caller);
  char buf[1024];
  Line line(buf, sizeof buf);
  line.text("ehpt: heap allocation while the allocation guard is armed: ");
  append_what(line, kind, size);
  line.text(", from ");
  append_frame(line, caller);
  line.text(", thread ");
  line.number(static_cast<std::uint64_t>(::gettid()), 10);
  line.text("; backtrace, innermost first:\n");
  write_all(STDERR_FILENO, line.c_str(), line.size());
  backtrace_symbols_fd(frames + from, depth - from, STDERR_FILENO);
  std::abort();
}

bool decide_abort() {
  const char* env = std::getenv("EHPT_ABORT_ON_ALLOC");
  if (env != nullptr && env[0] != '\0') return std::strcmp(env, "0") != 0;
  const int requested = g_abort_requested.load(std::memory_order_relaxed);
  if (requested >= 0) return requested == 1;
  return g_abort_by_default.load(std::memory_order_relaxed);
}

}  // namespace

const char* kind_name(Kind kind) {
  switch (kind) {
    case Kind::kNone: return "nothing";
    case Kind::kMalloc: return "malloc";
    case Kind::kCalloc: return "calloc";
    case Kind::kRealloc: return "realloc";
    case Kind::kAlignedAlloc: return "aligned_alloc";
    case Kind::kPosixMemalign: return "posix_memalign";
    case Kind::kMemalign: return "memalign";
    case Kind::kValloc: return "valloc";
    case Kind::kPvalloc: return "pvalloc";
    case Kind::kNew: return "operator new";
    case Kind::kNewArray: return "operator new[]";
    case Kind::kNewNothrow: return "operator new(nothrow)";
    case Kind::kNewArrayNothrow: return "operator new[](nothrow)";
    case Kind::kNewAligned: return "operator new(align_val_t)";
    case Kind::kNewArrayAligned: return "operator new[](align_val_t)";
    case Kind::kNewAlignedNothrow: return "operator new(align_val_t, nothrow)";
    case Kind::kNewArrayAlignedNothrow: return "operator new[](align_val_t, nothrow)";
  }
  return "allocation";
}

bool active() { return g_hooks_linked.load(std::memory_order_relaxed); }

void arm() {
  // glibc's first backtrace() dlopens libgcc_s (which allocates): here, not in a hook
  void* preload[4];
  (void)backtrace(preload, 4);
  g_abort.store(decide_abort(), std::memory_order_relaxed);
  // release: a thread whose allocation sees the flag sees the mode too (on_allocation's fence)
  detail::g_armed.store(true, std::memory_order_release);
}

void disarm() { detail::g_armed.store(false, std::memory_order_relaxed); }

bool armed() { return detail::g_armed.load(std::memory_order_relaxed); }

std::int64_t count() { return g_count.load(std::memory_order_relaxed); }

void reset() {
  g_count.store(0, std::memory_order_relaxed);
  g_first_state.store(kFirstNone, std::memory_order_release);
}

void set_abort_on_allocation(bool abort_on_allocation) {
  g_abort_requested.store(abort_on_allocation ? 1 : 0, std::memory_order_relaxed);
}

bool abort_on_allocation() { return g_abort.load(std::memory_order_relaxed); }

bool abort_on_allocation_by_default() { return g_abort_by_default.load(std::memory_order_relaxed); }

const char* describe_first() {
  static char buf[2048];
  if (g_first_state.load(std::memory_order_acquire) != kFirstReady) return "";
  Line line(buf, sizeof buf);
  append_what(line, g_first.kind, g_first.size);
  line.text(", from ");
  const int from = first_caller_frame(g_first.frames, g_first.depth, g_first.caller);
  if (from == 0) {  // the caller is not among the frames (should not happen): name it alone
    append_frame(line, g_first.caller);
    return line.c_str();
  }
  for (int i = from; i < g_first.depth && i < from + kMaxFramesDescribed; ++i) {
    if (i > from) line.text(" <- ");
    append_frame(line, g_first.frames[i]);
  }
  return line.c_str();
}

namespace detail {

void register_hooks(bool abort_by_default) noexcept {
  g_abort_by_default.store(abort_by_default, std::memory_order_relaxed);
  g_hooks_linked.store(true, std::memory_order_relaxed);
}

void on_allocation(Kind kind, std::size_t size, void* caller) noexcept {
  std::atomic_thread_fence(std::memory_order_acquire);  // pairs with arm()'s release
  g_count.fetch_add(1, std::memory_order_relaxed);
  if (g_abort.load(std::memory_order_relaxed)) {
    // one reporter: the allocations of the others (and the report's own) are not counted
    bool was_armed = true;
    if (g_armed.compare_exchange_strong(was_armed, false, std::memory_order_relaxed)) {
      report_and_abort(kind, size, caller);
    }
    return;
  }
  int expected = kFirstNone;
  if (!g_first_state.compare_exchange_strong(expected, kFirstClaimed, std::memory_order_acquire)) return;
  g_first.kind = kind;
  g_first.size = size;
  g_first.caller = caller;
  // still armed: an allocation inside backtrace() (none once arm() preloaded it) would be
  // counted and find the first already claimed, so there is no recursion
  g_first.depth = backtrace(g_first.frames, kMaxFrames);
  g_first_state.store(kFirstReady, std::memory_order_release);
}

}  // namespace detail

}  // namespace ehpt::hil::alloc_guard
