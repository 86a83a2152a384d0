// SPDX-License-Identifier: BSD-3-Clause
// A minimal external ECU for ehpt's EV plant over LCM, written against the generated types
// (io/lcm/*.lcm) and liblcm's C++ API only: no ehpt code. It is what `ehpt ecu` does for an
// EV, reduced to the contract, so it can be the starting point of an ECU of one's own:
//
//   plant -> ECU  <prefix>PLANT_STATUS  ehpt_lcm::ev_sensors_t  one per ECU period
//   ECU -> plant  <prefix>ECU_COMMAND   ehpt_lcm::ev_command_t  step = the sample's step
//
//   lcm_ecu [--url URL] [--prefix P] [--torque-limit-Nm T] [--idle-timeout-s S]
//
// Run it next to `ehpt plant ev_nedc --bus lcm:URL --lockstep` (udpm only inside a private
// network namespace, with ?ttl=0: see README). Without a torque limit its commands are the
// built-in driver-follower's, so the plant's timeseries equal `ehpt run`'s byte for byte.

#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>

#include <ehpt_lcm/ev_command_t.hpp>
#include <ehpt_lcm/ev_sensors_t.hpp>

namespace {

// Set by SIGINT/SIGTERM; the loop below looks at it between short waits, so a Ctrl-C ends
// the ECU within one wait and it still prints its summary.
volatile std::sig_atomic_t g_stop = 0;
void on_signal(int sig) { g_stop = sig; }

std::int64_t utime_now() {
  using namespace std::chrono;
  return duration_cast<microseconds>(system_clock::now().time_since_epoch()).count();
}

struct Ecu {
  lcm::LCM* lcm = nullptr;
  std::string command_channel;
  double torque_limit_Nm = std::numeric_limits<double>::infinity();
  long answered = 0;
  std::int64_t last_step = -1;

  // One command per sample, at once: in lockstep the plant does not advance until it has
  // the command whose step is the sample's, so the step must be echoed, not counted here.
  void on_status(const lcm::ReceiveBuffer*, const std::string&, const ehpt_lcm::ev_sensors_t* s) {
    ehpt_lcm::ev_command_t c{};
    c.utime = utime_now();
    c.step = s->step;
    c.session = s->session;  // names the plant it answers: another plant on this URL ignores it
    // The driver's request, within the limit. std::clamp keeps the value bit for bit when
    // it is inside the limit (no arithmetic), which is what makes runs reproducible.
    c.driveTauRef_Nm = std::clamp(s->driverRequest_Nm, -torque_limit_Nm, torque_limit_Nm);
    lcm->publish(command_channel, &c);
    ++answered;
    last_step = s->step;
  }
};

bool parse_double(const char* text, double& out) {
  char* end = nullptr;
  out = std::strtod(text, &end);
  return end != text && *end == '\0' && out > 0.0;
}

int usage() {
  std::fprintf(stderr,
               "usage: lcm_ecu [--url URL] [--prefix P] [--torque-limit-Nm T] [--idle-timeout-s S]\n"
               "  defaults: --url udpm://239.255.76.67:7667?ttl=0 --prefix EHPT_ --idle-timeout-s 10\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string url = "udpm://239.255.76.67:7667?ttl=0";  // ttl=0: never leaves the host
  std::string prefix = "EHPT_";
  double idle_timeout_s = 10.0;
  Ecu ecu;
  for (int i = 1; i < argc; ++i) {
    const std::string o = argv[i];
    if (i + 1 >= argc) return usage();  // every option takes a value
    const char* v = argv[++i];
    if (o == "--url") {
      url = v;
    } else if (o == "--prefix") {
      prefix = v;
    } else if (o == "--torque-limit-Nm") {
      if (!parse_double(v, ecu.torque_limit_Nm)) return usage();
    } else if (o == "--idle-timeout-s") {
      if (!parse_double(v, idle_timeout_s)) return usage();
    } else {
      return usage();
    }
  }

  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::fprintf(stderr, "lcm_ecu: cannot open LCM at %s\n", url.c_str());
    return 1;
  }
  ecu.lcm = &lcm;
  ecu.command_channel = prefix + "ECU_COMMAND";
  lcm.subscribe(prefix + "PLANT_STATUS", &Ecu::on_status, &ecu);

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);

  // LCM has no connections: "the plant is gone" can only be told by silence. The idle
  // clock starts now, so an ECU started without a plant also ends.
  const auto idle = std::chrono::duration<double>(idle_timeout_s);
  auto last_heard = std::chrono::steady_clock::now();
  const char* why = "the plant went quiet";
  while (g_stop == 0) {
    const int r = lcm.handleTimeout(100);  // > 0: messages handled, 0: nothing within 100 ms
    if (r > 0) {
      last_heard = std::chrono::steady_clock::now();
    } else if (r < 0 && g_stop == 0) {
      why = "LCM error";
      break;
    } else if (std::chrono::steady_clock::now() - last_heard > idle) {
      if (ecu.answered == 0) why = "no plant on the bus";
      break;
    }
  }
  if (g_stop != 0) why = "stopped by a signal";

  std::printf("lcm_ecu: %ld samples answered, last step %lld (%s)\n", ecu.answered,
              static_cast<long long>(ecu.last_step), why);
  if (g_stop != 0) return 128 + g_stop;
  return ecu.answered > 0 ? 0 : 1;
}
