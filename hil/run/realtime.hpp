// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The real-time loop's set-up on Linux (start-up only): SCHED_FIFO for the calling thread,
// CPU affinity, memory locked and prefaulted. Each step that is not permitted is a warning
// with its reason, and the run goes on without it (an HIL bench without root still runs,
// with the figures to show what it cost).

#include <cstdint>
#include <string>
#include <vector>

namespace ehpt::hil {

struct RealtimeOptions {
  double period_s = 0.0;  // the tick; a whole number of solver steps (0: one step)
  int cpu = -1;           // pin the loop to this CPU (-1: leave it)
  int priority = 80;      // SCHED_FIFO priority, 1..99
};

// What the set-up achieved (for summary.json and the terminal).
struct RealtimeSetup {
  bool fifo = false;           // SCHED_FIFO at the requested priority
  bool memory_locked = false;  // mlockall(MCL_CURRENT | MCL_FUTURE)
  bool pinned = false;         // on the requested CPU
  // /dev/cpu_dma_latency held at 0 us while the loop runs (as cyclictest does): the CPU
  // stays out of deep idle states, whose exit costs wake-up latency
  bool dma_latency_zero = false;
  int dma_latency_fd = -1;
  std::vector<std::string> warnings;
};

// Start-up, on the loop's thread: pins it, locks and prefaults memory, then SCHED_FIFO.
RealtimeSetup enter_realtime(const RealtimeOptions& opt);
// After the loop: back to SCHED_OTHER (the summary and the plots are not real-time work),
// the idle states released.
void leave_realtime(RealtimeSetup& setup);

// Whether cpu is one this process may run on; else false and the allowed ones ("0-1").
bool cpu_allowed(int cpu, std::string& allowed);

// Peak resident set size of this process so far, bytes (VmHWM of /proc/self/status: this
// image's own, not the one it was exec'd from; getrusage where there is no /proc).
std::int64_t peak_rss_bytes();

}  // namespace ehpt::hil
