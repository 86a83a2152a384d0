// SPDX-License-Identifier: BSD-3-Clause
// The bus plant (hil/bus/bus_plant.hpp) against an ECU that lives inside a fake transport: the
// whole loop in one thread, deterministic, so that timing rules are checked to the step and
// the run phase's allocations are counted.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <deque>
#include <filesystem>
#include <stdlib.h>  // mkdtemp
#include <unistd.h>

#include "alloc_counter.hpp"
#include "hil/run/batch.hpp"
#include "io/json_value.hpp"
#include "hil/bus/bus_plant.hpp"
#include "hil/run/simulation.hpp"
#include "io/can/codec.hpp"
#include "io/output_dir.hpp"
#include "test_plants.hpp"

namespace ehpt::hil {
namespace {

using io::can::Frame;

// The EV's follower behind a transport: answers each PlantStatus (while alive) with the
// command the built-in ECU would send. Fixed rings: no allocation after construction.
class FollowerBus final : public io::can::Transport {
 public:
  std::int64_t silent_from_step = -1;  // >= 0: no answer to samples at or after this step
  std::int64_t silent_until_step = -1;  // and answers again from this step on
  bool hostile = false;                 // add one malformed frame of each kind per sample
  // each answer arrives later: once the plant waits or sends its next frames, as over a real
  // wire (a plant that does not wait sees it only at its next sample)
  bool late = false;
  // what the transport reports on top (error frames, sends it could not make)
  std::int64_t extra_error_frames = 0, extra_send_dropped = 0;

  bool send(const Frame& f) override {
    land();  // the plant's next frames: time has passed since the last ones
    ++counters_.frames_out;
    if (f.id == io::can::kEvSensors1 || f.id == io::can::kEvSensors2) io::can::apply(f, sensors_);
    if (f.id != io::can::kPlantStatus) return true;
    io::can::PlantStatus st;
    io::can::apply(f, st);
    if (st.ecu_timeout) {
      first_flagged_step = first_flagged_step < 0 ? st.step : first_flagged_step;
      max_drive_power_while_flagged_W = std::max(max_drive_power_while_flagged_W, std::abs(sensors_.drivePowDel_W));
    } else {
      max_drive_power_W = std::max(max_drive_power_W, std::abs(sensors_.drivePowDel_W));
    }
    const auto step = static_cast<std::int64_t>(st.step);
    if (silent_from_step >= 0 && step >= silent_from_step && (silent_until_step < 0 || step < silent_until_step)) {
      restarted_ = true;
      return true;
    }
    if (restarted_) {  // a new ECU process: its counters start anew
      tx_ = io::can::TxCounters{};
      restarted_ = false;
    }
    msgs::EvCommand c;
    c.driveTauRef_Nm = sensors_.driverRequest_Nm;
    c.stamp.step = step;
    std::array<Frame, 1> frames;
    io::can::encode(c, tx_, frames);
    if (hostile) {
      Frame unknown = frames[0];
      unknown.id = 0x7FF;
      push(unknown);
      Frame short_frame = frames[0];
      short_frame.len = 7;
      push(short_frame);
      Frame out_of_range = frames[0];
      out_of_range.data[0] = 0xFF;  // raw 524287: 52 428.7 N m > 50 000 N m
      out_of_range.data[1] = 0xFF;
      out_of_range.data[2] = 0x07;
      push(out_of_range);
      if (have_last_) push(last_);  // the previous sample's frame again: stale
    }
    push(frames[0]);
    if (hostile) push(frames[0]);  // the same frame twice: a repeated counter
    last_ = frames[0];
    have_last_ = true;
    return true;
  }
  std::size_t receive(std::span<Frame> out) override {
    std::size_t n = 0;
    while (n < out.size() && count_ > 0) {
      out[n++] = ring_[head_];
      head_ = (head_ + 1) % ring_.size();
      --count_;
    }
    counters_.frames_in += static_cast<std::int64_t>(n);
    return n;
  }
  bool wait(std::int64_t) override {  // time passes: what was in flight arrives
    land();
    return count_ > 0;
  }
  bool has_peer() const override { return true; }
  const io::can::TransportCounters& counters() const override {
    shown_ = counters_;
    shown_.error_frames += extra_error_frames;
    shown_.send_dropped += extra_send_dropped;
    return shown_;
  }
  std::string describe() const override { return "fake"; }

  std::int64_t first_flagged_step = -1;
  double max_drive_power_while_flagged_W = 0.0, max_drive_power_W = 0.0;

 private:
  void push(const Frame& f) {
    if (!late) return put(f);
    if (in_flight_count_ < in_flight_.size()) in_flight_[in_flight_count_++] = f;
  }
  void land() {
    for (std::size_t i = 0; i < in_flight_count_; ++i) put(in_flight_[i]);
    in_flight_count_ = 0;
  }
  void put(const Frame& f) {
    if (count_ < ring_.size()) ring_[(head_ + count_++) % ring_.size()] = f;
  }
  std::array<Frame, 16> in_flight_{};
  std::size_t in_flight_count_ = 0;
  msgs::EvSensors sensors_;
  io::can::TxCounters tx_;
  std::array<Frame, 64> ring_{};
  std::size_t head_ = 0, count_ = 0;
  Frame last_;
  bool have_last_ = false, restarted_ = false;
  io::can::TransportCounters counters_;
  mutable io::can::TransportCounters shown_;
};

struct BusRun {
  std::vector<std::string> degraded;  // ExternalDriver::degraded_reasons
  std::unique_ptr<Simulation> sim;
  io::JsonObject summary;
  std::string text;
  std::size_t run_phase_allocations = 0;
};

Scenario scenario(double duration_s) {
  return test::load(test::source_path("scenarios/ev_nedc.toml"), {"solver.duration_s=" + std::to_string(duration_s)});
}

// The plant in lockstep with the fake ECU; allocations counted after the first chunk.
BusRun run_on(FollowerBus& bus, const Scenario& sc, const std::string& out_dir) {
  BusRun r;
  SimulationOptions opt;
  opt.external_ecu = true;
  opt.fault_policy = FaultPolicy::kHold;
  opt.chunk_steps = 5000;
  r.sim = make_simulation(sc, opt);
  BusPlantOptions bo;
  bo.lockstep = true;
  bo.lockstep_wait_s = 1e-4;  // a silent ECU costs 0.1 ms of wall time per sample
  bo.peer_wait_s = 0.05;      // one that never answers sample 0 costs 50 ms
  std::string error;
  std::vector<std::string> errors;
  auto binding = default_binding(bus_family(sc), sc.ecu_timing.period_s, errors);
  EXPECT_TRUE(binding);
  auto driver = make_bus_plant(sc, bus, bo, std::move(binding.value()), error);
  EXPECT_TRUE(driver) << error;
  io::OutputDir dir;
  EXPECT_TRUE(dir.open(out_dir, error)) << error;
  EXPECT_TRUE(driver->open(dir, error)) << error;
  driver->start(*r.sim, nullptr);  // start-up: the ECU answers sample 0, the port is attached
  r.sim->run();                 // the first chunk
  r.sim->clear_rows();
  const std::size_t before = test::allocation_count();
  while (!r.sim->finished()) {
    r.sim->run();
    r.sim->clear_rows();
  }
  r.run_phase_allocations = test::allocation_count() - before;
  EXPECT_TRUE(driver->flush(error)) << error;
  driver->report(r.summary, r.text);
  r.degraded = driver->degraded_reasons();
  return r;
}

// an output folder name inside a folder this process made (mkdtemp): nothing else is touched
std::string fresh(const char* name) {
  std::string base = (std::filesystem::temp_directory_path() / "ehpt-bus-plant-XXXXXX").string();
  EXPECT_NE(::mkdtemp(base.data()), nullptr);
  return base + "/" + name;
}

// the in-process reference: the built-in follower through the same codec
std::unique_ptr<Simulation> reference(double duration_s) {
  Scenario sc = test::load(test::source_path("scenarios/ev_nedc.toml"),
                           {"solver.duration_s=" + std::to_string(duration_s), "vehicle.ecu.codec=can"});
  auto sim = make_simulation(sc, SimulationOptions{});
  while (!sim->finished()) sim->run();
  return sim;
}

bool same_outputs(Simulation& a, Simulation& b) {
  const auto x = a.outputs(), y = b.outputs();
  return x.size() == y.size() && std::memcmp(x.data(), y.data(), x.size() * sizeof(double)) == 0;
}

TEST(BusPlant, LockstepEqualsTheCodecReferenceAndAllocatesNothing) {
  FollowerBus bus;
  BusRun r = run_on(bus, scenario(30), fresh("clean"));
  auto ref = reference(30);
  EXPECT_TRUE(same_outputs(*r.sim, *ref));
  EXPECT_EQ(r.run_phase_allocations, 0u);
  EXPECT_NE(r.summary.str().find("\"commands_applied\": 3001"), std::string::npos) << r.summary.str();
  EXPECT_NE(r.summary.str().find("\"timeouts\": 0"), std::string::npos);
  EXPECT_EQ(bus.first_flagged_step, -1);
  EXPECT_TRUE(r.degraded.empty()) << r.degraded.front();  // an ECU that answered every sample: not degraded
}

// An ECU that comes back after the plant stopped waiting for it is heard again: its answers,
// which arrive after the plant (no longer waiting) has looked, are taken as in wall-clock
// mode until one is, and then the plant waits for each sample again.
TEST(BusPlant, AnEcuThatComesBackAfterThePlantStoppedWaitingIsHeardAgain) {
  FollowerBus bus;
  bus.late = true;
  bus.silent_from_step = 12000;
  bus.silent_until_step = 14000;
  BusRun r = run_on(bus, scenario(16), fresh("back"));
  const std::string j = r.summary.str();
  // 1 601 samples, 200 silent: every answer after the silence applied (without the recovery,
  // none after 12 000)
  io::JsonValue v;
  std::string error;
  ASSERT_TRUE(io::parse_json(j, v, error)) << error;
  const long long applied = std::stoll(v.find("bus")->find("commands_applied")->text);
  EXPECT_GE(applied, 1399) << j;
  EXPECT_NE(j.find("\"timeouts\": 1,"), std::string::npos) << j;
  EXPECT_NE(j.find("\"lockstep_waits_timed_out\": 10,"), std::string::npos) << j;
}

// Every reason of a degraded session on its own: each is named, and a clean session has none.
TEST(BusPlant, EachReasonOfADegradedSessionIsNamed) {
  {
    FollowerBus bus;
    bus.extra_error_frames = 3;
    EXPECT_EQ(run_on(bus, scenario(2), fresh("errors")).degraded,
              std::vector<std::string>{"3 error frames on the bus"});
  }
  {
    FollowerBus bus;
    bus.extra_send_dropped = 1;
    EXPECT_EQ(run_on(bus, scenario(2), fresh("dropped")).degraded,
              std::vector<std::string>{"1 frames the plant could not send (no ECU connected, or one too slow)"});
  }
  {
    FollowerBus bus;  // never answers (from sample 0 on)
    bus.silent_from_step = 0;
    const auto degraded = run_on(bus, scenario(2), fresh("alone")).degraded;
    ASSERT_GE(degraded.size(), 1u);
    EXPECT_EQ(degraded[0], "no ECU: not one command in the whole session (none connected, or it never answered)");
  }
  {
    FollowerBus bus;
    EXPECT_TRUE(run_on(bus, scenario(2), fresh("clean2")).degraded.empty());
  }
}

TEST(BusPlant, HostileFramesAreCountedByReasonAndChangeNothing) {
  FollowerBus bus;
  bus.hostile = true;
  BusRun r = run_on(bus, scenario(30), fresh("hostile"));
  auto ref = reference(30);
  EXPECT_TRUE(same_outputs(*r.sim, *ref));
  EXPECT_EQ(r.run_phase_allocations, 0u);
  const std::string j = r.summary.str();
  // one of each per sample (3001 samples; no stale frame before the second)
  for (const char* want : {"\"unknown_id\": 3001", "\"wrong_length\": 3001", "\"out_of_range\": 3001",
                           "\"stale\": 3000", "\"bad_counter\": 3001", "\"commands_applied\": 3001"}) {
    EXPECT_NE(j.find(want), std::string::npos) << want << " in " << j;
  }
  // every frame in lands in exactly one counter: accepted, or one reason
  io::JsonValue v;
  std::string error;
  ASSERT_TRUE(io::parse_json(j, v, error)) << error;
  const io::JsonValue& bus_json = *v.find("bus");
  const auto n = [](const io::JsonValue& o, const char* key) { return std::stoll(o.find(key)->text); };
  long long reasons = 0;
  for (const auto& m : bus_json.find("rejected")->members) reasons += std::stoll(m.value.text);
  EXPECT_EQ(n(bus_json, "frames_in"), n(bus_json, "frames_accepted") + reasons) << j;
}

TEST(BusPlant, ASilentEcuGivesTheSafeStateAtTheStepItsCommandTimesOutAndAnAnswerEndsIt) {
  FollowerBus bus;
  // silent while NEDC's first acceleration (11-15 s) asks for torque
  bus.silent_from_step = 12000;   // the last answered sample: 11990
  bus.silent_until_step = 14000;  // a new ECU (counters from 0) answers again from sample 14000
  BusRun r = run_on(bus, scenario(16), fresh("silent"));
  const std::string j = r.summary.str();
  // the command of 11990 is older than 30 ms (3 periods) from step 11990 + 31 = 12021 until
  // the answer of sample 14000: 1979 steps
  EXPECT_NE(j.find("\"timeouts\": 1,"), std::string::npos) << j;
  EXPECT_NE(j.find("\"safe_state_time_s\": 1.979,"), std::string::npos) << j;
  EXPECT_NE(j.find("\"longest_command_gap_s\": 2.01"), std::string::npos) << j;  // 2010 steps
  // 200 silent samples: the plant waits for 10 of them, then stops waiting (an ECU that is gone
  // must not cost a wait per sample) until the answer of 14000, after which it waits again
  EXPECT_NE(j.find("\"lockstep_waits_timed_out\": 10,"), std::string::npos) << j;
  // a degraded session: each reason named
  EXPECT_EQ(r.degraded, (std::vector<std::string>{
                            "the ECU's commands timed out 1 time: 1.979 s in the safe state",
                            "10 lockstep waits for the ECU timed out; the plant stopped waiting at t = 12.09 s after 10 in a row"}));
  // the first sample after 12021 says so on the bus
  EXPECT_EQ(bus.first_flagged_step, 12030);
  // and meanwhile the drive delivers nothing (its torque reference is zero), though it did
  // before and after
  EXPECT_EQ(bus.max_drive_power_while_flagged_W, 0.0);
  EXPECT_GT(bus.max_drive_power_W, 3000.0);
  EXPECT_EQ(r.run_phase_allocations, 0u);
}

}  // namespace
}  // namespace ehpt::hil
