// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// One LCM instance for a provider URL (udpm://239.255.76.67:7667?ttl=0 on a network,
// memq:// inside one process), owned by the target and never called from plant code.
// Start-up (open, subscribe) may allocate and reports one clear line; afterwards publish()
// and handle_now() never block (handle_now dispatches what has arrived to the subscribers,
// in this thread), wait() blocks only as long as asked.
//
// Allocation: liblcm itself allocates per received message (it copies each message into a
// buffer it frees after the handlers ran; measured in tests/io/lcm_bus_test.cpp); ehpt's
// side does not, and none of it runs inside the plant's step.

#include <cstdint>
#include <memory>
#include <string>

struct _lcm_t;  // liblcm's handle (lcm/lcm.h)

namespace ehpt::io::lcm {

// "lcm:URL" -> URL checked: a udpm:// or memq:// provider; false and why if not.
bool parse_lcm_spec(const std::string& text, std::string& url, std::string& error);
// The multicast TTL a udpm URL asks for (?ttl=N; liblcm's default 0), -1 if it is not a number.
int lcm_ttl(const std::string& url);

struct LcmCounters {
  std::int64_t published = 0;
  std::int64_t publish_failed = 0;
  std::int64_t received = 0;  // messages dispatched to a subscriber
};

class LcmBus {
 public:
  // nullptr and one line in error (the URL and the likely fix) if it cannot open.
  static std::unique_ptr<LcmBus> open(const std::string& url, std::string& error);
  ~LcmBus();
  LcmBus(const LcmBus&) = delete;
  LcmBus& operator=(const LcmBus&) = delete;

  // Start-up: handler(data, size, user) for every message on channel.
  using Handler = void (*)(const void* data, int size, void* user);
  bool subscribe(const std::string& channel, Handler handler, void* user, std::string& error);

  // Run phase.
  bool publish(const char* channel, const void* data, int size);
  int handle_now();                     // dispatches what has arrived; the number of messages
  bool wait(std::int64_t timeout_ns);   // until something may have arrived (poll on its fd)
  const LcmCounters& counters() const { return counters_; }
  const std::string& url() const { return url_; }

 private:
  LcmBus(_lcm_t* lcm, std::string url) : lcm_(lcm), url_(std::move(url)) {}
  struct Subscription {
    LcmBus* bus;
    Handler handler;
    void* user;
  };
  static void dispatch(const void* rbuf, const char* channel, void* user);
  _lcm_t* lcm_;
  std::string url_;
  std::unique_ptr<Subscription> subs_[4];
  int sub_count_ = 0;
  LcmCounters counters_;
};

}  // namespace ehpt::io::lcm
