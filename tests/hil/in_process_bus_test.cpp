// SPDX-License-Identifier: BSD-3-Clause
// The in-process CAN bus (io/can/memory_bus.hpp) and the built-in ECU on it
// (hil/bus/in_process_bus.hpp): what a run with bus faults and no ECU outside runs on.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdlib.h>  // mkdtemp

#include "hil/bus/in_process_bus.hpp"
#include "hil/config/scenario.hpp"
#include "hil/run/batch.hpp"
#include "io/can/memory_bus.hpp"
#include "io/json_value.hpp"
#include "test_plants.hpp"

namespace ehpt::hil {
namespace {

using io::can::Frame;

Frame frame(std::uint32_t id) {
  Frame f;
  f.id = id;
  f.len = 1;
  f.data[0] = static_cast<std::uint8_t>(id);
  return f;
}

// Each end hears the other's frames, in order, never its own; a full ring refuses and counts.
TEST(MemoryBus, EachEndHearsTheOthersFramesInOrderAndAFullRingCounts) {
  io::can::MemoryBus bus(3);
  io::can::Transport& a = bus.end(0);
  io::can::Transport& b = bus.end(1);
  EXPECT_TRUE(a.send(frame(1)));
  EXPECT_TRUE(a.send(frame(2)));
  EXPECT_TRUE(b.send(frame(9)));
  Frame got[8];
  ASSERT_EQ(b.receive(got), 2u);
  EXPECT_EQ(got[0], frame(1));
  EXPECT_EQ(got[1], frame(2));
  ASSERT_EQ(a.receive(got), 1u);
  EXPECT_EQ(got[0], frame(9));
  EXPECT_EQ(a.receive(got), 0u);
  for (std::uint32_t id = 3; id <= 5; ++id) EXPECT_TRUE(a.send(frame(id)));
  EXPECT_FALSE(a.send(frame(6)));  // three in the ring: full
  EXPECT_EQ(a.counters().send_dropped, 1);
  EXPECT_EQ(a.counters().frames_out, 5);
  ASSERT_EQ(b.receive(std::span<Frame>(got, 2)), 2u);  // no more than asked
  EXPECT_EQ(got[0], frame(3));
  ASSERT_EQ(b.receive(got), 1u);
  EXPECT_EQ(got[0], frame(5));
  EXPECT_EQ(b.counters().frames_in, 5);
}

// The pump runs before an end hands out frames or waits: what the other side sends in it is
// received in the same call (the ECU answers within the plant's receive).
TEST(MemoryBus, ThePumpLetsTheOtherSideAnswerWithinTheReceive) {
  io::can::MemoryBus bus;
  struct Echo {
    io::can::Transport* self;
    int pumps = 0;
  } echo{&bus.end(1)};
  bus.set_pump(0, [](void* p) {
    auto* e = static_cast<Echo*>(p);
    ++e->pumps;
    Frame in[4];
    const std::size_t k = e->self->receive(in);
    for (std::size_t i = 0; i < k; ++i) e->self->send(frame(in[i].id + 100));
  }, &echo);
  bus.end(0).send(frame(7));
  EXPECT_EQ(echo.pumps, 0);  // sending does not pump
  Frame got[4];
  ASSERT_EQ(bus.end(0).receive(got), 1u);
  EXPECT_EQ(got[0].id, 107u);
  EXPECT_FALSE(bus.end(0).wait(1'000'000'000));  // nothing more: at once, not after a second
  EXPECT_EQ(echo.pumps, 2);
}

std::string fresh(const char* name) {
  std::string base = (std::filesystem::temp_directory_path() / "ehpt-in-process-bus-XXXXXX").string();
  EXPECT_NE(::mkdtemp(base.data()), nullptr);
  return base + "/" + name;
}

io::JsonValue run(const std::vector<std::string>& sets, const std::vector<std::string>& faults, bool in_process_bus,
                  std::string& log_text, const char* scenario = "ev_nedc", std::string* out_dir = nullptr) {
  Scenario sc;
  std::vector<std::string> errors;
  EXPECT_TRUE(load_scenario(test::source_path("scenarios/" + std::string(scenario) + ".toml"), sets, faults, sc, errors))
      << (errors.empty() ? "" : errors[0]);
  std::string error;
  std::unique_ptr<ExternalDriver> bus;
  BatchOptions opt;
  opt.out_dir = fresh("run");
  if (out_dir != nullptr) *out_dir = opt.out_dir;
  if (in_process_bus) {
    bus = make_in_process_bus(sc, BusPlantOptions{}, error);
    EXPECT_NE(bus, nullptr) << error;
    opt.driver = bus.get();
  }
  std::ostringstream log;
  const BatchResult r = run_batch(sc, opt, log);
  log_text = log.str();
  io::JsonValue v;
  EXPECT_TRUE(io::parse_json(r.summary.str(), v, error)) << error << log_text;
  return v;
}

std::string at(const io::JsonValue& v, std::initializer_list<const char*> path) {
  const io::JsonValue* x = &v;
  for (const char* k : path) {
    x = x->find(k);
    if (x == nullptr) return "(missing " + std::string(k) + ")";
  }
  return x->text;
}

// Without a fault the bus changes nothing: the same trajectory as the built-in ECU through the
// CAN codec. With the EV's command frames lost for 50 ms: the plant's safe state once, the
// frames counted, the ECU's side complete (it got every sample), nothing allocated.
TEST(InProcessBus, EqualsTheCodecRunAndActsOutABusFault) {
  std::string log;
  const io::JsonValue codec = run({"solver.duration_s=20", "vehicle.ecu.codec=can"}, {}, false, log);
  const io::JsonValue clean = run({"solver.duration_s=20"}, {}, true, log);
  EXPECT_EQ(at(clean, {"trajectory_hash"}), at(codec, {"trajectory_hash"}));
  EXPECT_EQ(at(clean, {"bus", "transport"}), "in-process");
  EXPECT_EQ(at(clean, {"bus", "timeouts"}), "0");
  EXPECT_EQ(at(clean, {"ecu_in_process", "samples_answered"}), "2001");

  const io::JsonValue faulted =
      run({"solver.duration_s=20"}, {"kind=drop target=EvCommand at_s=12 until_s=12.05"}, true, log);
  EXPECT_NE(at(faulted, {"trajectory_hash"}), at(codec, {"trajectory_hash"}));
  EXPECT_EQ(at(faulted, {"status"}), "ok") << log;
  EXPECT_EQ(at(faulted, {"bus", "timeouts"}), "1");
  EXPECT_EQ(at(faulted, {"bus", "timeouts_under_bus_faults"}), "1");
  EXPECT_EQ(at(faulted, {"bus", "commands_lost_to_faults"}), "5");
  EXPECT_EQ(at(faulted, {"bus", "lockstep_waits_timed_out"}), "0");
  EXPECT_EQ(at(faulted, {"bus", "safe_state_time_s"}), "0.029");
  EXPECT_EQ(at(faulted, {"ecu_in_process", "samples_answered"}), "2001");
  EXPECT_EQ(at(faulted, {"ecu_in_process", "incomplete_samples"}), "0");
  EXPECT_EQ(at(faulted, {"provenance", "commands"}),
            "built-in ECU over an in-process CAN bus (bus faults), lockstep");

  // the other way: the plant's EvSensors1 lost for 5 samples; the ECU's counter rule refuses
  // the first frame after the gap too (a jump of 6 > 3), so 6 samples reach it incomplete
  const io::JsonValue sensors_lost =
      run({"solver.duration_s=20"}, {"kind=drop target=EvSensors1 at_s=12 until_s=12.05"}, true, log);
  EXPECT_EQ(at(sensors_lost, {"ecu_in_process", "incomplete_samples"}), "6");
  EXPECT_EQ(at(sensors_lost, {"ecu_in_process", "frames_rejected"}), "1");
  EXPECT_EQ(at(sensors_lost, {"ecu_in_process", "samples_answered"}), "1995");
  EXPECT_EQ(at(sensors_lost, {"bus", "samples_not_awaited"}), "6");
}

// The series hybrid's EMS over the in-process bus: its frames (ShevSensors1..4, PlantStatus,
// ShevCommand) carry the run of the codec reference through a genset start (267.31 s), and a
// lost ShevCommand puts the plant in its safe state.
TEST(InProcessBus, TheSeriesHybridEqualsItsCodecRunAndActsOutABusFault) {
  std::string log;
  const std::vector<std::string> sets = {"solver.duration_s=300"};
  std::vector<std::string> codec_sets = sets;
  codec_sets.emplace_back("vehicle.ecu.codec=can");
  const io::JsonValue codec = run(codec_sets, {}, false, log, "shev_oo_sort1");
  const io::JsonValue plain = run(sets, {}, false, log, "shev_oo_sort1");
  const io::JsonValue clean = run(sets, {}, true, log, "shev_oo_sort1");
  EXPECT_EQ(at(clean, {"trajectory_hash"}), at(codec, {"trajectory_hash"}));
  EXPECT_NE(at(plain, {"trajectory_hash"}), at(codec, {"trajectory_hash"}));  // the codec's quantisation shows
  EXPECT_EQ(at(clean, {"status"}), "ok") << log;
  EXPECT_EQ(at(clean, {"bus", "timeouts"}), "0");
  EXPECT_EQ(at(clean, {"ecu_in_process", "samples_answered"}), "30001");
  EXPECT_EQ(at(clean, {"ecu_in_process", "incomplete_samples"}), "0");
  EXPECT_EQ(at(clean, {"ecu_in_process", "saturated_signals"}), "0");

  std::string dir;
  const io::JsonValue faulted =
      run(sets, {"kind=drop target=ShevCommand at_s=280 until_s=280.05"}, true, log, "shev_oo_sort1", &dir);
  EXPECT_NE(at(faulted, {"trajectory_hash"}), at(codec, {"trajectory_hash"}));
  EXPECT_EQ(at(faulted, {"status"}), "ok") << log;
  EXPECT_EQ(at(faulted, {"bus", "timeouts"}), "1");
  EXPECT_EQ(at(faulted, {"bus", "commands_lost_to_faults"}), "5");
  EXPECT_EQ(at(faulted, {"ecu_in_process", "samples_answered"}), "30001");
  // the safe state, as inputs.log recorded it: no torque, no genset power, and the genset left
  // on (it was running: a stale message must not stop it), between two commands of the EMS
  // that had it on with power asked
  std::ifstream in(dir + "/inputs.log");
  ASSERT_TRUE(in) << dir;
  std::vector<std::vector<std::string>> around;
  for (std::string line; std::getline(in, line);) {
    std::istringstream ls(line);
    std::vector<std::string> t;
    for (std::string w; ls >> w;) t.push_back(w);
    if (t.size() == 8 && t[0] == "shev" && std::stoll(t[1]) >= 279990 && std::stoll(t[1]) <= 280100) around.push_back(t);
  }
  ASSERT_GE(around.size(), 3u);
  int safe = 0;
  for (std::size_t i = 0; i < around.size(); ++i) {
    const auto& t = around[i];
    if (t[5] == "0" && t[6] == "0") {
      ++safe;
      EXPECT_EQ(t[7], "1") << "gensetON in the safe state at step " << t[1];
      ASSERT_GT(i, 0u);
      EXPECT_GT(std::stod(around[i - 1][6]), 30000.0) << "the EMS's command before: " << around[i - 1][1];
      EXPECT_EQ(around[i - 1][7], "1");
    }
  }
  EXPECT_EQ(safe, 1);
}

// What the in-process bus cannot run, it says before anything runs.
TEST(InProcessBus, RefusesWhatItCannotRun) {
  Scenario sc;
  std::vector<std::string> errors;
  ASSERT_TRUE(load_scenario(test::source_path("scenarios/ev_nedc.toml"), {"vehicle.ecu.latency_s=0.001"},
                            {"kind=drop target=EvCommand at_s=1"}, sc, errors));
  std::string error;
  EXPECT_EQ(make_in_process_bus(sc, BusPlantOptions{}, error), nullptr);
  EXPECT_NE(error.find("bus faults run the built-in ECU over an in-process CAN bus, and"), std::string::npos) << error;
  EXPECT_NE(error.find("latency_s"), std::string::npos) << error;
  errors.clear();
  ASSERT_TRUE(load_scenario(test::source_path("scenarios/ev_nedc.toml"), {}, {"kind=drop target=EvCommnd at_s=1"}, sc,
                            errors));
  error.clear();
  EXPECT_EQ(make_in_process_bus(sc, BusPlantOptions{}, error), nullptr);
  EXPECT_NE(error.find("did you mean \"EvCommand\""), std::string::npos) << error;
}

}  // namespace
}  // namespace ehpt::hil
