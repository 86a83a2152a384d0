// SPDX-License-Identifier: BSD-3-Clause
// LCM (io/lcm/): the generated types' round trips, the URL rules, and the plant in lockstep
// with an ECU over memq in one thread (the ECU answers inside its subscription handler):
// bit-identical to the in-process run, and what liblcm allocates per message, measured.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <limits>
#include <vector>

#include "alloc_counter.hpp"
#include "hil/bus/bus_plant.hpp"
#include "hil/run/simulation.hpp"
#include "io/lcm/lcm_bus.hpp"
#include "io/lcm/lcm_codec.hpp"
#include "io/output_dir.hpp"
#include "test_plants.hpp"

// malloc itself counted (liblcm and glib allocate with malloc, not operator new): glibc lets
// a program interpose malloc; these forward to glibc's own.
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
}
namespace {
std::atomic<std::size_t> g_mallocs{0};
}
extern "C" void* malloc(std::size_t n) {
  g_mallocs.fetch_add(1, std::memory_order_relaxed);
  return __libc_malloc(n);
}
extern "C" void* calloc(std::size_t a, std::size_t b) {
  g_mallocs.fetch_add(1, std::memory_order_relaxed);
  return __libc_calloc(a, b);
}
extern "C" void* realloc(void* p, std::size_t n) {
  g_mallocs.fetch_add(1, std::memory_order_relaxed);
  return __libc_realloc(p, n);
}

namespace ehpt {
namespace {

template <class Msg>
Msg round_trip(const Msg& in) {
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(in.getEncodedSize()));
  EXPECT_EQ(in.encode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  Msg out{};
  EXPECT_EQ(out.decode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  return out;
}

TEST(LcmTypes, EveryFieldRoundTripsExactly) {
  msgs::PsdSensors s;
  s.stamp = {123.456, 123456, 7};
  double v = 0.1;
  for (double* f : {&s.driverRequest, &s.speed_m_s, &s.iceW_rad_s, &s.icePowDel_W, &s.genW_rad_s, &s.genPowDel_W,
                    &s.genTauLim_Nm, &s.motW_rad_s, &s.motPowDelA_W, &s.motPowDelB_W, &s.motPowDelAB_W,
                    &s.motTauLim_Nm, &s.batSOC, &s.batPowDel_W, &s.battery_voltage_V, &s.battery_current_A}) {
    *f = (v *= -1.7);  // every field a different value, both signs, no two alike
  }
  s.fault = 5;
  s.locked = true;
  ehpt_lcm::psd_sensors_t m{};
  io::lcm::to_lcm(s, 1700000000000000, true, m);
  const auto back_m = round_trip(m);
  EXPECT_EQ(back_m.utime, 1700000000000000);
  EXPECT_TRUE(back_m.ecuTimeout);
  msgs::PsdSensors back;
  io::lcm::from_lcm(back_m, back);
  EXPECT_EQ(back.stamp.step, 123456);
  EXPECT_EQ(back.stamp.time_s, 123.456);
  EXPECT_EQ(std::memcmp(&back.driverRequest, &s.driverRequest, 16 * sizeof(double)), 0);  // bit for bit
  EXPECT_EQ(back.fault, 5u);
  EXPECT_TRUE(back.locked);

  msgs::EvSensors e;
  e.stamp.step = 99;
  e.driverRequest_Nm = -11800.25;
  e.battery_current_A = 1e-300;
  ehpt_lcm::ev_sensors_t em{};
  io::lcm::to_lcm(e, 5, false, em);
  msgs::EvSensors eb;
  io::lcm::from_lcm(round_trip(em), eb);
  EXPECT_EQ(eb.driverRequest_Nm, -11800.25);
  EXPECT_EQ(eb.battery_current_A, 1e-300);
  EXPECT_EQ(eb.stamp.step, 99);

  msgs::PsdCommand c;
  c.stamp.step = 4242;
  c.icePowRef_W = 12345.678;
  c.iceTauRef_Nm = -1.5;
  c.genTauRef_Nm = 33.25;
  c.motTauRef_Nm = -79.125;
  c.iceON = false;
  ehpt_lcm::psd_command_t cm{};
  io::lcm::to_lcm(c, 5, cm);
  msgs::PsdCommand cb;
  io::lcm::from_lcm(round_trip(cm), cb);
  EXPECT_EQ(cb.stamp.step, 4242);
  EXPECT_EQ(cb.icePowRef_W, 12345.678);
  EXPECT_EQ(cb.iceTauRef_Nm, -1.5);
  EXPECT_EQ(cb.genTauRef_Nm, 33.25);
  EXPECT_EQ(cb.motTauRef_Nm, -79.125);
  EXPECT_FALSE(cb.iceON);

  msgs::EvCommand ec;
  ec.stamp.step = 1;
  ec.driveTauRef_Nm = 10.4166666;  // the value the strict-aliasing bug turned into 0
  ehpt_lcm::ev_command_t ecm{};
  io::lcm::to_lcm(ec, 5, ecm);
  msgs::EvCommand ecb;
  io::lcm::from_lcm(round_trip(ecm), ecb);
  EXPECT_EQ(ecb.driveTauRef_Nm, 10.4166666);
}

TEST(LcmSpec, UrlsAreCheckedBeforeAnythingOpens) {
  std::string url, error;
  EXPECT_TRUE(io::lcm::parse_lcm_spec("lcm:udpm://239.255.76.67:7667?ttl=0", url, error));
  EXPECT_EQ(url, "udpm://239.255.76.67:7667?ttl=0");
  EXPECT_TRUE(io::lcm::parse_lcm_spec("lcm:memq://", url, error));
  for (const char* bad : {"lcm:udpm://1.2.3.4:7667", "lcm:udpm://239.255.76.67", "lcm:udpm://239.255.76.67:0",
                          "lcm:udpm://239.255.76.67:70000", "lcm:udpm://x:1", "lcm:tcpq://1.2.3.4:1", "lcm:"}) {
    error.clear();
    EXPECT_FALSE(io::lcm::parse_lcm_spec(bad, url, error)) << bad;
    EXPECT_NE(error.find(std::string("--bus ") + bad), std::string::npos) << error;
  }
}

// The EV's follower as an LCM subscriber: it answers each sample inside the handler.
// hostile: per sample also garbage, a command for an old and for a future sample (each with
// a torque of 999 N m), and the real one twice.
struct FollowerOnLcm {
  io::lcm::LcmBus* bus;
  bool hostile = false;
  std::vector<std::uint8_t> out = std::vector<std::uint8_t>(64);
  void send(std::int64_t step, double torque_Nm, std::int64_t utime) {
    ehpt_lcm::ev_command_t c{};
    c.utime = utime;
    c.step = step;
    c.driveTauRef_Nm = torque_Nm;
    const int n = c.encode(out.data(), 0, static_cast<int>(out.size()));
    bus->publish("EHPT_ECU_COMMAND", out.data(), n);
  }
  static void on_sample(const void* data, int size, void* user) {
    auto* self = static_cast<FollowerOnLcm*>(user);
    ehpt_lcm::ev_sensors_t m{};
    if (m.decode(data, 0, size) != size) return;
    if (self->hostile) {
      const std::uint8_t garbage[5] = {1, 2, 3, 4, 5};
      self->bus->publish("EHPT_ECU_COMMAND", garbage, sizeof garbage);
      if (m.step >= 10) self->send(m.step - 10, 999.0, m.utime);  // the previous sample's
      self->send(m.step + 10, 999.0, m.utime);                    // a sample not sent yet
      // this sample's, but not a number the plant may apply (first: it must not take the slot)
      for (const double bad : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                               -std::numeric_limits<double>::infinity()}) {
        self->send(m.step, bad, m.utime);
      }
    }
    self->send(m.step, m.driverRequest_Nm, m.utime);  // what ecu::EvFollower does
    if (self->hostile) self->send(m.step, m.driverRequest_Nm, m.utime);  // again: a repeat
  }
};

// The plant in lockstep with the in-handler follower over `url`; returns mallocs per message.
double lockstep_in_one_process(const std::string& url, bool hostile = false, std::string* report = nullptr) {
  const hil::Scenario sc = test::load(test::source_path("scenarios/ev_nedc.toml"), {"solver.duration_s=30"});
  std::string error;
  auto bus = io::lcm::LcmBus::open(url, error);
  EXPECT_TRUE(bus) << error;
  if (!bus) return -1.0;
  FollowerOnLcm ecu{bus.get(), hostile};
  EXPECT_TRUE(bus->subscribe("EHPT_PLANT_STATUS", &FollowerOnLcm::on_sample, &ecu, error)) << error;

  hil::SimulationOptions opt;
  opt.external_ecu = true;
  opt.fault_policy = hil::FaultPolicy::kHold;
  opt.chunk_steps = 5000;
  auto sim = hil::make_simulation(sc, opt);
  hil::BusPlantOptions bo;
  bo.lockstep = true;
  auto driver = hil::make_bus_plant(sc, *bus, bo, error);
  EXPECT_TRUE(driver) << error;
  if (!driver) return -1.0;
  driver->start(*sim, nullptr);  // start-up: the ECU answers sample 0, the port is attached
  sim->run();                 // the first chunk
  sim->clear_rows();
  const std::int64_t messages_before = bus->counters().received + bus->counters().published;
  const std::size_t before = test::allocation_count();
  const std::size_t mallocs_before = g_mallocs.load();
  while (!sim->finished()) {
    sim->run();
    sim->clear_rows();
  }
  const std::size_t allocations = test::allocation_count() - before;  // operator new: ehpt's
  const std::size_t mallocs = g_mallocs.load() - mallocs_before;          // everyone's
  const std::int64_t messages = bus->counters().received + bus->counters().published - messages_before;
  io::JsonObject summary;
  std::string text;
  driver->report(summary, text);
  EXPECT_NE(summary.str().find("\"commands_applied\": 3001"), std::string::npos) << summary.str();
  if (report != nullptr) *report = summary.str();

  auto ref = hil::make_simulation(sc, hil::SimulationOptions{});
  while (!ref->finished()) ref->run();
  const auto a = sim->outputs(), b = ref->outputs();
  EXPECT_EQ(a.size(), b.size());
  EXPECT_EQ(std::memcmp(a.data(), b.data(), std::min(a.size(), b.size()) * sizeof(double)), 0);
  // ehpt allocates nothing in the run phase; liblcm (memq) copies each message
  EXPECT_EQ(allocations, 0u);
  const double per_message = static_cast<double>(mallocs) / static_cast<double>(messages);
  std::printf("%s: %zu mallocs (liblcm, glib) over %lld messages: %.2f per message; operator new: %zu\n",
              url.c_str(), mallocs, static_cast<long long>(messages), per_message, allocations);
  return per_message;
}

TEST(LcmMemq, LockstepInOneProcessIsBitIdenticalToTheInProcessRun) {
  const double per_message = lockstep_in_one_process("memq://");
  EXPECT_GT(per_message, 0.0);  // the counter counts (liblcm copies every message it queues)
  EXPECT_LE(per_message, 4.0);
}

TEST(LcmMemq, HostileMessagesAreCountedByReasonAndChangeNothing) {
  std::string j;
  lockstep_in_one_process("memq://", true, &j);  // bit-identical: checked inside
  // per sample (3001): garbage, an old and a future sample's command, NaN, +inf and -inf for
  // this sample, the real one twice
  for (const char* want : {"\"malformed\": 3001", "\"stale\": 6001", "\"repeated\": 3001", "\"non_finite\": 9003",
                           "\"messages_accepted\": 3001"}) {
    EXPECT_NE(j.find(want), std::string::npos) << want << " in " << j;
  }
}

// udpm only inside tests/targets/in_netns.sh (ctest: lcm_udpm_in_netns): the same, over the
// network stack (liblcm receives its own multicast on loopback)
TEST(LcmUdpm, LockstepInOneProcessIsBitIdenticalToTheInProcessRun) {
  if (std::getenv("EHPT_IN_NETNS") == nullptr) GTEST_SKIP() << "needs tests/targets/in_netns.sh";
  const double per_message = lockstep_in_one_process("udpm://239.255.76.67:7667?ttl=0");
  // measured with liblcm 1.3.1: udpm receives into a ring buffer made at start-up, so the
  // whole run phase allocates nothing (a newer liblcm that does would show here)
  EXPECT_EQ(per_message, 0.0);
}

}  // namespace
}  // namespace ehpt
