// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The bench's supervisor: every program it starts (this ehpt, cyclictest) with an argument
// vector, in a process group of its own, waited for with a deadline and ended (SIGINT, then
// SIGKILL) on a timeout or a stop signal; and the private network namespace of the LCM run.

#include "targets/bench/common.hpp"

namespace ehpt::bench {

struct Outcome {
  bool started = false;
  int code = -1;  // exit status, 128 + N for signal N
  bool timed_out = false, stopped = false;
  std::string why;  // when it did not start, or what went wrong
  double wall_s = 0.0;
  bool ok() const { return started && !timed_out && !stopped && code == 0; }
};

// One program started by the bench. Its own process group (group = true) lets end() reach
// whatever it started; the destructor ends and reaps it whatever happens (an exception too).
class Child {
 public:
  Child() = default;
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;
  ~Child() {
    if (pid_ > 0) end();
  }

  bool start(const std::vector<std::string>& argv, const std::string& out, const std::string& err, std::string& why,
             bool group = true) {
    group_ = group;
    t0_ = Clock::now();
    pid_ = ehpt::io::start_program(argv, out, err, group, why);
    return pid_ > 0;
  }
  // Adopts a process made otherwise (fork), already in its own group when group is true.
  void adopt(pid_t pid, bool group) {
    pid_ = pid;
    group_ = group;
    t0_ = Clock::now();
  }
  // True when it has ended (code set); never blocks.
  bool poll(int& code) {
    if (pid_ <= 0) return true;
    int status = 0;
    const pid_t r = ::waitpid(pid_, &status, WNOHANG);
    if (r == 0) return false;
    if (r < 0 && errno == EINTR) return false;
    code = r < 0 ? -1 : WIFEXITED(status) ? WEXITSTATUS(status) : WIFSIGNALED(status) ? 128 + WTERMSIG(status) : -1;
    pid_ = -1;
    return true;
  }

  // Waits until it ends, timeout_s passes or a stop signal comes (then it is ended).
  Outcome wait(double timeout_s) {
    Outcome o;
    o.started = true;
    while (true) {
      if (poll(o.code)) break;
      if (stopping()) {
        o.stopped = true;
        o.code = end();
        break;
      }
      if (seconds_since(t0_) > timeout_s) {
        o.timed_out = true;
        o.why = "no end after " + fmt("%.0f", timeout_s) + " s: stopped";
        o.code = end();
        break;
      }
      // 100 polls a second at first (short runs), then 10: little noise beside (c)
      sleep_s(seconds_since(t0_) < 1.0 ? 0.01 : 0.1);
    }
    o.wall_s = seconds_since(t0_);
    return o;
  }

  // SIGINT (ehpt commits what it has, cyclictest prints), 3 s, then SIGKILL; reaps it.
  int end() {
    int code = -1;
    if (pid_ <= 0) return code;
    signal_it(SIGINT);
    for (int i = 0; i < 300; ++i) {
      if (poll(code)) return code;
      sleep_s(0.01);
    }
    signal_it(SIGKILL);
    for (int i = 0; i < 500; ++i) {
      if (poll(code)) return code;
      sleep_s(0.01);
    }
    pid_ = -1;  // unkillable (D state): give up on it rather than hang the bench
    return code;
  }

 private:
  void signal_it(int sig) {
    if (group_) {
      ::killpg(pid_, sig);
    } else {
      ::kill(pid_, sig);
    }
  }
  pid_t pid_ = -1;
  bool group_ = true;
  Clock::time_point t0_;
};

// Runs argv to its end (bounded): stdout, stderr into logs/NAME.out and .err.
Outcome run_child(const std::vector<std::string>& argv, const std::string& logs, const std::string& name,
                  double timeout_s);

// A free TCP port on 127.0.0.1 (bound to port 0, then released).
int free_port();
// Something listens on 127.0.0.1:port.
bool listening(int port);

// The forked child: a new network namespace holding only lo, then ehpt plant --lockstep and
// ehpt ecu over LCM udpm (ttl=0) there; their output in logs/NAME_plant.* and NAME_ecu.*.
// Never returns. Exit 77: no namespace here (stderr says why); else the plant's exit code, or 1.
[[noreturn]] void lcm_in_netns(const std::string& name, const std::vector<std::string>& plant,
                               const std::vector<std::string>& ecu, const std::string& logs, double timeout_s);

}  // namespace ehpt::bench
