// SPDX-License-Identifier: BSD-3-Clause
// lcm_log_check LOGFILE [PREFIX [PERIOD_STEPS]]: reads an LCM log (lcm-logger's format) of an
// EV lockstep session and checks the contract on the wire with the generated types:
//   - every <prefix>PLANT_STATUS event decodes as ehpt_lcm::ev_sensors_t, every
//     <prefix>ECU_COMMAND event as ehpt_lcm::ev_command_t (the whole event, no bytes left);
//   - the status steps are 0, P, 2P, ... with none missing (P = PERIOD_STEPS, default 10:
//     a 10 ms ECU period at the 1 ms step); sample 0 may repeat before the next one, as the
//     plant re-sends it until a first ECU answers;
//   - every status sample names one plant session (the same non-zero id throughout), and
//     every command names that session;
//   - each command's step is the step of a status sample logged before it. One exception,
//     measured: multicast on loopback delivers each datagram to each socket in turn, so the
//     logger may get a command a few microseconds before the sample it answers when the ECU
//     is quicker than the kernel's delivery to the logger. Such a command is taken if the next
//     status event is its sample and the command was sent after it (utime, the senders' clock:
//     one host), which an ECU answering a sample not yet sent can never be.
// Prints "status N command M first_step A last_step B" (A, B: the status steps) and exits 0,
// or prints the first violation to stderr and exits 1 (2: usage or unreadable log).
// Events on other channels are ignored.

#include <lcm/eventlog.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <ehpt_lcm/ev_command_t.hpp>
#include <ehpt_lcm/ev_sensors_t.hpp>

namespace {

int fail(const lcm_eventlog_event_t* e, const std::string& why) {
  std::fprintf(stderr, "lcm_log_check: event %lld on %s: %s\n", static_cast<long long>(e->eventnum), e->channel,
               why.c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || argc > 4) {
    std::fprintf(stderr, "usage: lcm_log_check LOGFILE [PREFIX [PERIOD_STEPS]]\n");
    return 2;
  }
  const std::string prefix = argc > 2 ? argv[2] : "EHPT_";
  const std::int64_t period = argc > 3 ? std::atoll(argv[3]) : 10;
  if (period <= 0) {
    std::fprintf(stderr, "lcm_log_check: PERIOD_STEPS must be positive\n");
    return 2;
  }
  const std::string status_channel = prefix + "PLANT_STATUS";
  const std::string command_channel = prefix + "ECU_COMMAND";

  lcm_eventlog_t* log = lcm_eventlog_create(argv[1], "r");
  if (log == nullptr) {
    std::fprintf(stderr, "lcm_log_check: cannot read %s\n", argv[1]);
    return 2;
  }

  long status = 0, command = 0, reordered = 0;
  bool held = false;  // a command logged just before its sample (see above)
  ehpt_lcm::ev_command_t held_command{};
  std::int64_t first_step = -1, last_step = -1, session = 0;
  int rc = 0;
  while (lcm_eventlog_event_t* e = lcm_eventlog_read_next_event(log)) {
    const std::string channel(e->channel, static_cast<std::size_t>(e->channellen));
    if (channel == status_channel) {
      ehpt_lcm::ev_sensors_t m{};
      if (m.decode(e->data, 0, e->datalen) != e->datalen) {
        rc = fail(e, "does not decode as ev_sensors_t");
      } else if (m.session == 0 || (session != 0 && m.session != session)) {
        rc = fail(e, "status session " + std::to_string(m.session) +
                         (session == 0 ? " (0 names no plant)" : " after " + std::to_string(session)));
      } else if (status == 0 && m.step != 0) {
        rc = fail(e, "the first status step is " + std::to_string(m.step) + ", not 0");
      } else if (status > 0 && !(m.step == last_step + period || (m.step == 0 && last_step == 0))) {
        rc = fail(e, "status step " + std::to_string(m.step) + " after " + std::to_string(last_step) +
                         " (expected " + std::to_string(last_step + period) + ")");
      } else if (held && (m.step != held_command.step || held_command.utime < m.utime || held_command.session != m.session)) {
        rc = fail(e, "a command for step " + std::to_string(held_command.step) +
                         " was logged before its sample, and is not this sample's answer sent after it");
      } else {
        if (status == 0) first_step = m.step;
        session = m.session;
        last_step = m.step;
        ++status;
        if (held) {
          held = false;
          ++command;
          ++reordered;
        }
      }
    } else if (channel == command_channel) {
      ehpt_lcm::ev_command_t m{};
      if (m.decode(e->data, 0, e->datalen) != e->datalen) {
        rc = fail(e, "does not decode as ev_command_t");
      } else if (session != 0 && m.session != session) {  // (a first command held before any sample: below)
        rc = fail(e, "command session " + std::to_string(m.session) + ", the plant's is " + std::to_string(session));
      } else if (!held && m.step == (status == 0 ? 0 : last_step + period)) {
        held = true;  // its sample must come next (see above)
        held_command = m;
      } else if (status == 0 || m.step < 0 || m.step > last_step || m.step % period != 0) {
        // the status steps seen so far are exactly 0, P, ..., last_step (checked above)
        rc = fail(e, "command step " + std::to_string(m.step) + " answers no status sample logged before it");
      } else {
        ++command;
      }
    }
    lcm_eventlog_free_event(e);
    if (rc != 0) break;
  }
  lcm_eventlog_destroy(log);
  if (rc == 0 && held) {
    std::fprintf(stderr, "lcm_log_check: the last command (step %lld) answers no status sample in the log\n",
                 static_cast<long long>(held_command.step));
    rc = 1;
  }
  if (reordered > 0) {
    std::fprintf(stderr, "lcm_log_check: %ld command(s) logged just before their sample (delivery order)\n",
                 reordered);
  }

  std::printf("status %ld command %ld first_step %lld last_step %lld\n", status, command,
              static_cast<long long>(first_step), static_cast<long long>(last_step));
  return rc;
}
