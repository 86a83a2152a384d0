// SPDX-License-Identifier: BSD-3-Clause
// The bench's supervisor (supervisor.hpp).
#include "targets/bench/supervisor.hpp"

namespace ehpt::bench {

// Runs argv to its end (bounded): stdout, stderr into logs/NAME.out and .err.
Outcome run_child(const std::vector<std::string>& argv, const std::string& logs, const std::string& name,
                  double timeout_s) {
  Child c;
  Outcome o;
  if (!c.start(argv, logs + "/" + name + ".out", logs + "/" + name + ".err", o.why)) return o;
  o = c.wait(timeout_s);
  if (!o.ok() && o.why.empty()) {
    const std::string line = last_line(logs + "/" + name + ".err");
    o.why = (o.stopped ? std::string("stopped") : "exit " + std::to_string(o.code)) + (line.empty() ? "" : ": " + line);
  }
  return o;
}

// A free TCP port on 127.0.0.1 (bound to port 0, then released).
int free_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  int port = -1;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) == 0) {
    port = ntohs(a.sin_port);
  }
  ::close(fd);
  return port;
}

// Whether something listens on 127.0.0.1:port (/proc/net/tcp: no probe connection, which
// the plant would count as a peer).
bool listening(int port) {
  std::istringstream in(read_small_file("/proc/net/tcp"));
  char want[32];
  std::snprintf(want, sizeof want, "0100007F:%04X", port);
  char any[32];
  std::snprintf(any, sizeof any, "00000000:%04X", port);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream f(line);
    std::string slot, local, remote, state;
    f >> slot >> local >> remote >> state;
    if ((local == want || local == any) && state == "0A") return true;
  }
  return false;
}

namespace {

// Brings lo up and routes multicast (224.0.0.0/4) to it: `ip link set lo up; ip route add
// 224.0.0.0/4 dev lo`, by ioctl. "" or what failed.
std::string loopback_multicast() {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return std::string("socket: ") + std::strerror(errno);
  ifreq ifr{};
  std::strncpy(ifr.ifr_name, "lo", IFNAMSIZ - 1);
  std::string error;
  if (::ioctl(fd, SIOCGIFFLAGS, &ifr) != 0) {
    error = std::string("lo: SIOCGIFFLAGS: ") + std::strerror(errno);
  } else {
    ifr.ifr_flags = static_cast<short>(ifr.ifr_flags | IFF_UP | IFF_RUNNING);
    if (::ioctl(fd, SIOCSIFFLAGS, &ifr) != 0) error = std::string("lo: cannot bring it up: ") + std::strerror(errno);
  }
  if (error.empty()) {
    rtentry rt{};
    sockaddr_in dst{}, mask{};
    dst.sin_family = mask.sin_family = AF_INET;
    dst.sin_addr.s_addr = htonl(0xE0000000u);   // 224.0.0.0
    mask.sin_addr.s_addr = htonl(0xF0000000u);  // /4
    std::memcpy(&rt.rt_dst, &dst, sizeof dst);
    std::memcpy(&rt.rt_genmask, &mask, sizeof mask);
    rt.rt_flags = RTF_UP;
    char dev[] = "lo";
    rt.rt_dev = dev;
    if (::ioctl(fd, SIOCADDRT, &rt) != 0 && errno != EEXIST) {
      error = std::string("route 224.0.0.0/4 dev lo: ") + std::strerror(errno);
    }
  }
  ::close(fd);
  return error;
}

// The only network interface here is lo (a fresh namespace): nothing can leave the machine.
bool only_loopback(std::string& seen) {
  struct if_nameindex* list = ::if_nameindex();
  if (list == nullptr) return false;
  bool only = true;
  for (struct if_nameindex* i = list; i->if_index != 0; ++i) {
    seen += (seen.empty() ? "" : ", ") + std::string(i->if_name);
    if (std::strcmp(i->if_name, "lo") != 0) only = false;
  }
  ::if_freenameindex(list);
  return only;
}

}  // namespace

[[noreturn]] void lcm_in_netns(const std::string& name, const std::vector<std::string>& plant,
                               const std::vector<std::string>& ecu, const std::string& logs, double timeout_s) {
  if (::unshare(CLONE_NEWNET) != 0) {
    std::fprintf(stderr, "unshare(CLONE_NEWNET): %s (needs root or user namespaces)\n", std::strerror(errno));
    std::fflush(stderr);
    ::_exit(77);
  }
  std::string seen;
  if (!only_loopback(seen)) {
    std::fprintf(stderr, "the new network namespace has interfaces other than lo (%s): LCM not run\n", seen.c_str());
    std::fflush(stderr);
    ::_exit(1);
  }
  const std::string error = loopback_multicast();
  if (!error.empty()) {
    std::fprintf(stderr, "%s\n", error.c_str());
    std::fflush(stderr);
    ::_exit(77);
  }
  int code = 1;
  {
    Child p, e;
    std::string why;
    // in this process's group: the bench ends the whole group
    if (!p.start(plant, logs + "/" + name + "_plant.out", logs + "/" + name + "_plant.err", why, false)) {
      std::fprintf(stderr, "%s\n", why.c_str());
    } else if (!e.start(ecu, logs + "/" + name + "_ecu.out", logs + "/" + name + "_ecu.err", why, false)) {
      std::fprintf(stderr, "%s\n", why.c_str());
    } else {
      const Outcome po = p.wait(timeout_s);
      const Outcome eo = e.wait(30.0);
      code = po.code;
      if (po.code != 0) {
        std::fprintf(stderr, "ehpt plant: %s\n", po.why.empty() ? ("exit " + std::to_string(po.code)).c_str() : po.why.c_str());
      } else if (eo.code != 0) {
        std::fprintf(stderr, "ehpt ecu: exit %d\n", eo.code);
        code = 1;
      }
    }
  }
  std::fflush(stderr);
  ::_exit(code < 0 ? 1 : code);
}

}  // namespace ehpt::bench
