// SPDX-License-Identifier: BSD-3-Clause
#include "io/lcm/lcm_bus.hpp"

#include <fcntl.h>
#include <lcm/lcm.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace ehpt::io::lcm {

bool parse_lcm_spec(const std::string& text, std::string& url, std::string& error) {
  const std::string shown = text.substr(0, 200);
  if (text.rfind("lcm:", 0) != 0) {
    error = "--bus " + shown + ": not an LCM bus (use lcm:udpm://239.255.76.67:7667?ttl=0; lcm:memq:// works only within one process)";
    return false;
  }
  url = text.substr(4);
  const bool udpm = url.rfind("udpm://", 0) == 0, memq = url.rfind("memq://", 0) == 0;
  if (!udpm && !memq) {
    error = "--bus " + shown + ": unknown LCM provider (use lcm:udpm://ADDRESS:PORT?ttl=0; lcm:memq:// works only within one process)";
    return false;
  }
  if (udpm) {
    // udpm://ADDRESS:PORT[?options]: ADDRESS a multicast IPv4 address, PORT 1..65535
    const std::string rest = url.substr(7, url.find('?') == std::string::npos ? std::string::npos : url.find('?') - 7);
    const std::size_t colon = rest.rfind(':');
    const std::string address = colon == std::string::npos ? rest : rest.substr(0, colon);
    int a = -1, b = -1, c = -1, d = -1;
    char tail = 0;
    const bool dotted = std::sscanf(address.c_str(), "%d.%d.%d.%d%c", &a, &b, &c, &d, &tail) == 4 && a >= 224 &&
                        a <= 239 && b >= 0 && b <= 255 && c >= 0 && c <= 255 && d >= 0 && d <= 255;
    bool port_ok = colon != std::string::npos && colon + 1 < rest.size() && rest.size() - colon - 1 <= 5;
    long port = 0;
    for (std::size_t i = colon + 1; port_ok && i < rest.size(); ++i) {
      port_ok = rest[i] >= '0' && rest[i] <= '9';
      port = port * 10 + (rest[i] - '0');
    }
    if (!dotted || !port_ok || port < 1 || port > 65535) {
      error = "--bus " + shown + ": a udpm URL is udpm://MULTICAST_ADDRESS:PORT?ttl=0 (address 224.0.0.0 to " +
              "239.255.255.255, port 1 to 65535), e.g. lcm:udpm://239.255.76.67:7667?ttl=0";
      return false;
    }
  }
  return true;
}

int lcm_ttl(const std::string& url) {
  const std::size_t q = url.find('?');
  if (q == std::string::npos) return 0;
  for (std::size_t at = q + 1; at < url.size();) {
    const std::size_t end = std::min(url.find('&', at), url.size());
    const std::string opt = url.substr(at, end - at);
    if (opt.rfind("ttl=", 0) == 0) {
      const std::string v = opt.substr(4);
      if (v.empty() || v.size() > 3 || v.find_first_not_of("0123456789") != std::string::npos) return -1;
      return std::stoi(v);
    }
    at = end + 1;
  }
  return 0;
}

std::unique_ptr<LcmBus> LcmBus::open(const std::string& url, std::string& error) {
  // liblcm prints its own diagnostics on stderr (a failed self test, a missing route): keep
  // them out of the one line we give, by sending stderr to /dev/null while it starts
  const int saved = ::dup(STDERR_FILENO);
  const int devnull = ::open("/dev/null", O_WRONLY | O_CLOEXEC);
  if (saved >= 0 && devnull >= 0) ::dup2(devnull, STDERR_FILENO);
  lcm_t* lcm = lcm_create(url.c_str());
  if (saved >= 0) {
    ::dup2(saved, STDERR_FILENO);
    ::close(saved);
  }
  if (devnull >= 0) ::close(devnull);
  if (lcm == nullptr) {
    error = "lcm:" + url + ": cannot open";
    if (url.rfind("udpm://", 0) == 0) {
      error += " (usually no multicast route: 'ip route add 224.0.0.0/4 dev lo' for loopback, in a private "
               "network namespace: unshare -n; see the README)";
    }
    return nullptr;
  }
  return std::unique_ptr<LcmBus>(new LcmBus(lcm, url));
}

LcmBus::~LcmBus() { lcm_destroy(lcm_); }

void LcmBus::dispatch(const void* rbuf, const char*, void* user) {
  auto* sub = static_cast<Subscription*>(user);
  const auto* buf = static_cast<const lcm_recv_buf_t*>(rbuf);
  ++sub->bus->counters_.received;
  sub->handler(buf->data, static_cast<int>(buf->data_size), sub->user);
}

bool LcmBus::subscribe(const std::string& channel, Handler handler, void* user, std::string& error) {
  if (sub_count_ == static_cast<int>(std::size(subs_))) {
    error = "lcm: too many subscriptions";
    return false;
  }
  auto sub = std::make_unique<Subscription>(Subscription{this, handler, user});
  const auto c_handler = [](const lcm_recv_buf_t* rbuf, const char* ch, void* u) { dispatch(rbuf, ch, u); };
  if (lcm_subscribe(lcm_, channel.c_str(), c_handler, sub.get()) == nullptr) {
    error = "lcm:" + url_ + ": cannot subscribe to " + channel;
    return false;
  }
  subs_[sub_count_++] = std::move(sub);
  return true;
}

bool LcmBus::publish(const char* channel, const void* data, int size) {
  const bool ok = lcm_publish(lcm_, channel, data, static_cast<unsigned>(size)) == 0;
  ++(ok ? counters_.published : counters_.publish_failed);
  return ok;
}

int LcmBus::handle_now() {
  int n = 0;
  while (lcm_handle_timeout(lcm_, 0) > 0) ++n;
  return n;
}

bool LcmBus::wait(std::int64_t timeout_ns) {
  pollfd p{lcm_get_fileno(lcm_), POLLIN, 0};
  const int ms = timeout_ns <= 0 ? 0 : static_cast<int>(std::min<std::int64_t>((timeout_ns + 999'999) / 1'000'000, 60'000));
  return ::poll(&p, 1, ms) > 0;
}

}  // namespace ehpt::io::lcm
