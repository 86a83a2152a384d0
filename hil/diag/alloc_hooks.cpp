// SPDX-License-Identifier: BSD-3-Clause
// The allocation guard's hooks (see hil/diag/alloc_guard.hpp): the malloc family and every global
// operator new/delete, interposed for the whole process (glibc lets a program replace malloc:
// libc's own strdup/fopen, libstdc++, liblcm and glib all call these), each noting the call
// (alloc_guard::detail::note_allocation: one relaxed load while disarmed) and forwarding to
// glibc's own allocator through its exported __libc_* entry points. Same heap as glibc's, so
// memory from an entry not replaced here (or allocated before) is freed correctly.
//
// Only in the CMake target ehpt_alloc_guard: an executable gets the hooks by linking it.
// The CMake target forces this object in (-Wl,--undefined=ehpt_alloc_hooks_anchor) and exports
// the hooks from the executable's dynamic symbol table, so that every shared library binds to
// them.
//
// Safe before main: the state they read is constant-initialised (no constructor to wait for),
// and while disarmed they only forward. No dlsym (which can allocate), no recursion: they call
// __libc_* directly, never the replaced names; what on_allocation does is in
// hil/diag/alloc_guard_api.cpp. Compiled with -fno-builtin (CMake), so that the compiler does not
// turn code here into a call to the function being defined.
#include <malloc.h>

#include <cerrno>
#include <cstddef>
#include <cstdlib>
#include <new>

#include "hil/diag/alloc_guard.hpp"

#ifndef EHPT_ALLOC_ABORT_DEFAULT
#define EHPT_ALLOC_ABORT_DEFAULT 0
#endif

// glibc's allocator under its own names (exported, GLIBC_2.2.5). aligned_alloc and
// posix_memalign have none: glibc 2.36's aligned_alloc is __libc_memalign itself.
extern "C" {
void* __libc_malloc(std::size_t size) noexcept;
void* __libc_calloc(std::size_t count, std::size_t size) noexcept;
void* __libc_realloc(void* p, std::size_t size) noexcept;
void __libc_free(void* p) noexcept;
void* __libc_memalign(std::size_t alignment, std::size_t size) noexcept;
void* __libc_valloc(std::size_t size) noexcept;
void* __libc_pvalloc(std::size_t size) noexcept;
}

namespace {

using ehpt::hil::alloc_guard::Kind;
using ehpt::hil::alloc_guard::detail::note_allocation;

// The hooks are in this process (active()), with the build's abort default. A static
// initialiser: only allocations after main are ever armed, so it need not run first.
[[maybe_unused]] const bool g_registered = [] {
  ehpt::hil::alloc_guard::detail::register_hooks(EHPT_ALLOC_ABORT_DEFAULT != 0);
  return true;
}();

// operator new: counted once, then as the standard says: on failure call the new_handler and
// retry, or throw std::bad_alloc when there is none.
void* new_impl(std::size_t size, std::size_t alignment, Kind kind, void* caller) {
  note_allocation(kind, size, caller);
  if (size == 0) size = 1;
  for (;;) {
    void* p = alignment == 0 ? __libc_malloc(size) : __libc_memalign(alignment, size);
    if (p != nullptr) return p;
    const std::new_handler handler = std::get_new_handler();
    if (handler == nullptr) throw std::bad_alloc();
    handler();
  }
}

// The nothrow forms: as if calling the throwing form and catching (the standard's wording).
void* new_nothrow_impl(std::size_t size, std::size_t alignment, Kind kind, void* caller) noexcept {
  try {
    return new_impl(size, alignment, kind, caller);
  } catch (...) {
    return nullptr;
  }
}

}  // namespace

// Referenced by the link option of ehpt_alloc_guard, so the archive member is always linked.
extern "C" void ehpt_alloc_hooks_anchor() {}

// ---- the C allocator ----

extern "C" void* malloc(std::size_t size) noexcept {
  note_allocation(Kind::kMalloc, size, __builtin_return_address(0));
  return __libc_malloc(size);
}

extern "C" void* calloc(std::size_t count, std::size_t size) noexcept {
  std::size_t bytes = 0;  // an overflowing request (which __libc_calloc fails) as SIZE_MAX
  if (__builtin_mul_overflow(count, size, &bytes)) bytes = static_cast<std::size_t>(-1);
  note_allocation(Kind::kCalloc, bytes, __builtin_return_address(0));
  return __libc_calloc(count, size);
}

// Every call counts, also one that shrinks in place or frees (size 0): a run phase calls none.
extern "C" void* realloc(void* p, std::size_t size) noexcept {
  note_allocation(Kind::kRealloc, size, __builtin_return_address(0));
  return __libc_realloc(p, size);
}

extern "C" void free(void* p) noexcept { __libc_free(p); }

extern "C" void* aligned_alloc(std::size_t alignment, std::size_t size) noexcept {
  note_allocation(Kind::kAlignedAlloc, size, __builtin_return_address(0));
  return __libc_memalign(alignment, size);
}

// glibc's checks: a power of two multiple of sizeof(void*), else EINVAL (nothing allocated).
extern "C" int posix_memalign(void** out, std::size_t alignment, std::size_t size) noexcept {
  note_allocation(Kind::kPosixMemalign, size, __builtin_return_address(0));
  const std::size_t words = alignment / sizeof(void*);
  if (alignment % sizeof(void*) != 0 || words == 0 || (words & (words - 1)) != 0) return EINVAL;
  void* p = __libc_memalign(alignment, size);
  if (p == nullptr) return ENOMEM;
  *out = p;
  return 0;
}

extern "C" void* memalign(std::size_t alignment, std::size_t size) noexcept {
  note_allocation(Kind::kMemalign, size, __builtin_return_address(0));
  return __libc_memalign(alignment, size);
}

extern "C" void* valloc(std::size_t size) noexcept {
  note_allocation(Kind::kValloc, size, __builtin_return_address(0));
  return __libc_valloc(size);
}

extern "C" void* pvalloc(std::size_t size) noexcept {
  note_allocation(Kind::kPvalloc, size, __builtin_return_address(0));
  return __libc_pvalloc(size);
}

// ---- operator new / delete, every replaceable form ----

void* operator new(std::size_t size) { return new_impl(size, 0, Kind::kNew, __builtin_return_address(0)); }
void* operator new[](std::size_t size) {
  return new_impl(size, 0, Kind::kNewArray, __builtin_return_address(0));
}
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  return new_nothrow_impl(size, 0, Kind::kNewNothrow, __builtin_return_address(0));
}
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept {
  return new_nothrow_impl(size, 0, Kind::kNewArrayNothrow, __builtin_return_address(0));
}
void* operator new(std::size_t size, std::align_val_t alignment) {
  return new_impl(size, static_cast<std::size_t>(alignment), Kind::kNewAligned, __builtin_return_address(0));
}
void* operator new[](std::size_t size, std::align_val_t alignment) {
  return new_impl(size, static_cast<std::size_t>(alignment), Kind::kNewArrayAligned, __builtin_return_address(0));
}
void* operator new(std::size_t size, std::align_val_t alignment, const std::nothrow_t&) noexcept {
  return new_nothrow_impl(size, static_cast<std::size_t>(alignment), Kind::kNewAlignedNothrow,
                          __builtin_return_address(0));
}
void* operator new[](std::size_t size, std::align_val_t alignment, const std::nothrow_t&) noexcept {
  return new_nothrow_impl(size, static_cast<std::size_t>(alignment), Kind::kNewArrayAlignedNothrow,
                          __builtin_return_address(0));
}

void operator delete(void* p) noexcept { __libc_free(p); }
void operator delete[](void* p) noexcept { __libc_free(p); }
void operator delete(void* p, std::size_t) noexcept { __libc_free(p); }
void operator delete[](void* p, std::size_t) noexcept { __libc_free(p); }
void operator delete(void* p, std::align_val_t) noexcept { __libc_free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { __libc_free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { __libc_free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { __libc_free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { __libc_free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { __libc_free(p); }
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept { __libc_free(p); }
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept { __libc_free(p); }
