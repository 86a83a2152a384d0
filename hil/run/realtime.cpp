// SPDX-License-Identifier: BSD-3-Clause
#include "hil/run/realtime.hpp"

#include <malloc.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

namespace ehpt::hil {

namespace {

// Touches this much of the stack now, so that the loop's deepest calls never fault a page in.
constexpr std::size_t kStackPrefaultBytes = 256 * 1024;
// Heap kept mapped and touched for the writer's and the bus's growth (small: the run phase
// allocates nothing; the target for the whole process is a peak RSS of 16 MB).
constexpr std::size_t kHeapPrefaultBytes = 2 * 1024 * 1024;

[[gnu::noinline]] void prefault_stack() {
  unsigned char stack[kStackPrefaultBytes];
  for (std::size_t i = 0; i < kStackPrefaultBytes; i += 4096) stack[i] = 0;
  asm volatile("" : : "r"(stack) : "memory");  // the writes happen: the pages are touched
}

void prefault_heap() {
  // freed memory stays in the process (no trim, no mmap for big blocks), so that touching it
  // once now means no page fault when it is used again
  mallopt(M_TRIM_THRESHOLD, -1);
  mallopt(M_MMAP_MAX, 0);
  if (void* p = std::malloc(kHeapPrefaultBytes)) {
    std::memset(p, 0, kHeapPrefaultBytes);
    std::free(p);
  }
}

std::string reason(const char* what, int err) { return std::string(what) + ": " + std::strerror(err); }

}  // namespace

bool cpu_allowed(int cpu, std::string& allowed) {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) != 0) return false;
  // the allowed CPUs as ranges: "0-1", "0,2-3"
  allowed.clear();
  for (int c = 0; c < CPU_SETSIZE; ++c) {
    if (!CPU_ISSET(c, &set)) continue;
    int last = c;
    while (last + 1 < CPU_SETSIZE && CPU_ISSET(last + 1, &set)) ++last;
    allowed += (allowed.empty() ? "" : ",") + std::to_string(c) + (last > c ? "-" + std::to_string(last) : "");
    c = last;
  }
  return cpu >= 0 && cpu < CPU_SETSIZE && CPU_ISSET(cpu, &set);
}

RealtimeSetup enter_realtime(const RealtimeOptions& opt) {
  RealtimeSetup s;
  if (opt.cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(opt.cpu, &set);
    const int rc = pthread_setaffinity_np(pthread_self(), sizeof set, &set);
    s.pinned = rc == 0;
    if (rc != 0) s.warnings.push_back(reason(("cannot pin the loop to CPU " + std::to_string(opt.cpu)).c_str(), rc));
  }
  if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
    s.memory_locked = true;
  } else {
    s.warnings.push_back(reason("mlockall (memory stays pageable; needs root, CAP_IPC_LOCK or a memlock limit)", errno));
  }
  prefault_stack();
  prefault_heap();
  // the PM QoS request lasts while the file stays open
  s.dma_latency_fd = ::open("/dev/cpu_dma_latency", O_WRONLY | O_CLOEXEC);
  const std::int32_t zero_us = 0;
  if (s.dma_latency_fd >= 0 && ::write(s.dma_latency_fd, &zero_us, sizeof zero_us) == sizeof zero_us) {
    s.dma_latency_zero = true;
  } else {
    s.warnings.push_back(reason("/dev/cpu_dma_latency (deep idle states stay allowed)", errno));
    if (s.dma_latency_fd >= 0) ::close(s.dma_latency_fd);
    s.dma_latency_fd = -1;
  }
  sched_param sp{};
  sp.sched_priority = opt.priority;
  const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
  s.fifo = rc == 0;
  if (rc != 0) {
    s.warnings.push_back(reason(("SCHED_FIFO priority " + std::to_string(opt.priority) +
                                 " not permitted, running under SCHED_OTHER (needs root, CAP_SYS_NICE or an rtprio limit)")
                                    .c_str(),
                                rc));
  }
  return s;
}

void leave_realtime(RealtimeSetup& setup) {
  if (setup.dma_latency_fd >= 0) {
    ::close(setup.dma_latency_fd);
    setup.dma_latency_fd = -1;
  }
  if (setup.fifo) {
    sched_param sp{};
    sp.sched_priority = 0;
    pthread_setschedparam(pthread_self(), SCHED_OTHER, &sp);
  }
}

std::int64_t peak_rss_bytes() {
  // VmHWM, this process's own high-water mark: getrusage's ru_maxrss keeps the peak of the
  // image before exec, so a run started from Python reported Python's 14 MB, from a shell 6.7
  const int fd = ::open("/proc/self/status", O_RDONLY | O_CLOEXEC);
  if (fd >= 0) {
    char buf[4096];
    std::size_t got = 0;
    for (ssize_t n; got + 1 < sizeof buf && (n = ::read(fd, buf + got, sizeof buf - 1 - got)) > 0;) {
      got += static_cast<std::size_t>(n);
    }
    ::close(fd);
    buf[got] = '\0';
    if (const char* at = std::strstr(buf, "\nVmHWM:")) {
      char* end = nullptr;
      const long long kib = std::strtoll(at + 7, &end, 10);
      if (end != at + 7 && kib >= 0) return static_cast<std::int64_t>(kib) * 1024;
    }
  }
  rusage ru{};  // no /proc: the rusage figure, with its caveat
  if (getrusage(RUSAGE_SELF, &ru) != 0) return 0;
  return static_cast<std::int64_t>(ru.ru_maxrss) * 1024;  // Linux: kilobytes
}

}  // namespace ehpt::hil
