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
#include <chrono>
#include <sstream>
#include <thread>
#include <vector>

#include "alloc_counter.hpp"
#include "hil/bus/bus_ecu.hpp"
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
  ecm.session = 0x7edcba9876543210;
  EXPECT_EQ(round_trip(ecm).session, 0x7edcba9876543210);
  msgs::EvCommand ecb;
  io::lcm::from_lcm(round_trip(ecm), ecb);
  EXPECT_EQ(ecb.driveTauRef_Nm, 10.4166666);

  // the series hybrid: every field a different value, both signs, bit for bit
  msgs::ShevSensors h;
  h.stamp = {267.31, 267310, 26731};
  v = 0.3;
  for (double* f : {&h.driverRequest_Nm, &h.speed_m_s, &h.driveW_rad_s, &h.driveTauLim_Nm, &h.drivePowDc_W,
                    &h.gensetW_rad_s, &h.gensetPowDc_W, &h.batSOC, &h.batPowDel_W, &h.battery_voltage_V,
                    &h.battery_current_A}) {
    *f = (v *= -1.9);
  }
  h.fault = 2;
  h.locked = true;
  ehpt_lcm::shev_sensors_t hm{};
  io::lcm::to_lcm(h, 7, true, hm);
  const auto back_h = round_trip(hm);
  EXPECT_TRUE(back_h.ecuTimeout);
  msgs::ShevSensors hb;
  io::lcm::from_lcm(back_h, hb);
  EXPECT_EQ(hb.stamp.step, 267310);
  EXPECT_EQ(hb.stamp.time_s, 267.31);
  EXPECT_EQ(std::memcmp(&hb.driverRequest_Nm, &h.driverRequest_Nm, 11 * sizeof(double)), 0);
  EXPECT_EQ(hb.fault, 2u);
  EXPECT_TRUE(hb.locked);

  msgs::ShevCommand hc;
  hc.stamp.step = 373250;
  hc.driveTauRef_Nm = -1234.5678;
  hc.gensetPowRef_W = 61234.25;
  hc.gensetON = false;
  ehpt_lcm::shev_command_t hcm{};
  io::lcm::to_lcm(hc, 5, hcm);
  msgs::ShevCommand hcb;
  hcb.gensetON = true;
  io::lcm::from_lcm(round_trip(hcm), hcb);
  EXPECT_EQ(hcb.stamp.step, 373250);
  EXPECT_EQ(hcb.driveTauRef_Nm, -1234.5678);
  EXPECT_EQ(hcb.gensetPowRef_W, 61234.25);
  EXPECT_FALSE(hcb.gensetON);
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
// hostile: per sample also garbage, a command for an old and for a future sample, two for this
// sample naming another plant session and none (each with a torque of 999 N m), and the real
// one twice.
struct FollowerOnLcm {
  io::lcm::LcmBus* bus;
  bool hostile = false;
  std::vector<std::uint8_t> out = std::vector<std::uint8_t>(64);
  std::int64_t session = 0;  // the plant's, from its samples
  void send(std::int64_t step, double torque_Nm, std::int64_t utime, std::int64_t to_session) {
    ehpt_lcm::ev_command_t c{};
    c.utime = utime;
    c.step = step;
    c.session = to_session;
    c.driveTauRef_Nm = torque_Nm;
    const int n = c.encode(out.data(), 0, static_cast<int>(out.size()));
    bus->publish("EHPT_ECU_COMMAND", out.data(), n);
  }
  static void on_sample(const void* data, int size, void* user) {
    auto* self = static_cast<FollowerOnLcm*>(user);
    ehpt_lcm::ev_sensors_t m{};
    if (m.decode(data, 0, size) != size) return;
    EXPECT_NE(m.session, 0);
    if (self->session == 0) self->session = m.session;
    EXPECT_EQ(m.session, self->session);  // one plant session: the same id in every sample
    const std::int64_t own = m.session;
    if (self->hostile) {
      const std::uint8_t garbage[5] = {1, 2, 3, 4, 5};
      self->bus->publish("EHPT_ECU_COMMAND", garbage, sizeof garbage);
      if (m.step >= 10) self->send(m.step - 10, 999.0, m.utime, own);  // the previous sample's
      self->send(m.step + 10, 999.0, m.utime, own);                    // a sample not sent yet
      self->send(m.step, 999.0, m.utime, own ^ 1);  // this sample's, for another plant on the URL
      self->send(m.step, 999.0, m.utime, 0);        // this sample's, from an ECU that names no plant
      // this sample's, but not a number the plant may apply (first: it must not take the slot)
      for (const double bad : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                               -std::numeric_limits<double>::infinity()}) {
        self->send(m.step, bad, m.utime, own);
      }
    }
    self->send(m.step, m.driverRequest_Nm, m.utime, own);  // what ecu::EvFollower does
    if (self->hostile) self->send(m.step, m.driverRequest_Nm, m.utime, own);  // again: a repeat
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
  // per sample (3001): garbage, an old and a future sample's command, two for another (or no)
  // plant session, NaN, +inf and -inf for this sample, the real one twice
  for (const char* want : {"\"malformed\": 3001", "\"stale\": 6001", "\"repeated\": 3001", "\"non_finite\": 9003",
                           "\"foreign\": 6002", "\"messages_accepted\": 3001"}) {
    EXPECT_NE(j.find(want), std::string::npos) << want << " in " << j;
  }
}

// ehpt ecu over LCM with two plants on one URL and prefix: it follows the first session it
// hears, answers only that plant's samples, names it in every command, and counts the other's.
struct CommandTap {
  std::vector<ehpt_lcm::ev_command_t> got;
  static void on_command(const void* data, int size, void* user) {
    ehpt_lcm::ev_command_t c{};
    if (c.decode(data, 0, size) == size) static_cast<CommandTap*>(user)->got.push_back(c);
  }
};

TEST(LcmMemq, TheBusEcuFollowsOnePlantSessionAndIgnoresAnother) {
  const hil::Scenario sc = test::load(test::source_path("scenarios/ev_nedc.toml"), {});
  std::string error;
  auto bus = io::lcm::LcmBus::open("memq://", error);
  ASSERT_TRUE(bus) << error;
  CommandTap tap;
  ASSERT_TRUE(bus->subscribe("EHPT_ECU_COMMAND", &CommandTap::on_command, &tap, error)) << error;
  constexpr std::int64_t kA = 0x1111, kB = 0x2222;
  constexpr int kSamples = 12;  // of each plant, interleaved (A first): fits the ECU's drain buffer
  // memq drops what is published before anyone subscribes: the plants publish from a thread
  // once the ECU has subscribed (liblcm's publish is thread-safe)
  std::thread plants([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(150));
    std::vector<std::uint8_t> out(256);
    for (int k = 0; k < kSamples; ++k) {
      for (const std::int64_t session : {kA, kB}) {
        ehpt_lcm::ev_sensors_t m{};
        m.step = 10 * k;
        m.session = session;
        m.driverRequest_Nm = session == kA ? 100.0 + k : -500.0;  // B's request: never answered
        const int n = m.encode(out.data(), 0, static_cast<int>(out.size()));
        if (n > 0) bus->publish("EHPT_PLANT_STATUS", out.data(), n);
      }
    }
  });
  hil::BusEcuOptions opt;
  opt.idle_timeout_s = 0.3;
  opt.max_samples = kSamples;
  std::ostringstream log;
  const hil::BusEcuResult r = hil::run_bus_ecu(sc, *bus, "EHPT_", opt, nullptr, log);
  plants.join();
  bus->handle_now();  // the last commands, if the ECU stopped before its own drain took them
  EXPECT_EQ(r.samples, kSamples) << log.str();
  EXPECT_NE(log.str().find("other plant sessions' samples ignored " + std::to_string(kSamples)), std::string::npos)
      << log.str();
  ASSERT_EQ(tap.got.size(), static_cast<std::size_t>(kSamples));
  for (int k = 0; k < kSamples; ++k) {
    EXPECT_EQ(tap.got[static_cast<std::size_t>(k)].session, kA) << k;
    EXPECT_EQ(tap.got[static_cast<std::size_t>(k)].step, 10 * k) << k;
    EXPECT_EQ(tap.got[static_cast<std::size_t>(k)].driveTauRef_Nm, 100.0 + k) << k;  // the follower: A's request
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
