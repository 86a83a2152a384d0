// SPDX-License-Identifier: BSD-3-Clause
// The CAN codec, per frame: encode (sensor message -> frames), and the receive side (check,
// counter, apply). Google Benchmark; the figures are in the README ("Speed").
#include <benchmark/benchmark.h>

#include <array>

#include "io/can/codec.hpp"

namespace {

using namespace ehpt;

msgs::PsdSensors sample_sensors() {
  msgs::PsdSensors s;
  s.stamp.step = 12340;
  s.driverRequest = 0.42;
  s.speed_m_s = 13.9;
  s.iceW_rad_s = 210.5;
  s.icePowDel_W = 15000.0;
  s.genW_rad_s = -120.25;
  s.genPowDel_W = -4000.0;
  s.genTauLim_Nm = 80.0;
  s.motW_rad_s = 380.0;
  s.motPowDelA_W = 1000.0;
  s.motPowDelB_W = 9000.0;
  s.motPowDelAB_W = 10000.0;
  s.motTauLim_Nm = 400.0;
  s.batSOC = 0.6;
  s.batPowDel_W = 3000.0;
  s.battery_voltage_V = 220.0;
  s.battery_current_A = 13.6;
  return s;
}

// 7 frames per iteration (PsdSensors1..6 + PlantStatus)
void BM_EncodePsdSensors(benchmark::State& state) {
  const msgs::PsdSensors s = sample_sensors();
  io::can::TxCounters tx;
  std::array<io::can::Frame, io::can::kPsdSensorIds.size()> frames;
  for (auto _ : state) {
    benchmark::DoNotOptimize(io::can::encode(s, {12340, 0, false, false}, tx, frames));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(frames.size()));
  state.SetLabel("items = frames");
}
BENCHMARK(BM_EncodePsdSensors);

// the ECU's receive side for the same 7 frames: filter (id, length, ranges, counter) + apply
void BM_DecodePsdSensors(benchmark::State& state) {
  const msgs::PsdSensors s = sample_sensors();
  io::can::TxCounters tx;
  io::can::FrameFilter filter(io::can::kPsdSensorIds);
  // 16 samples, counters 0..15: cycling through them keeps every counter fresh
  std::array<std::array<io::can::Frame, io::can::kPsdSensorIds.size()>, 16> samples;
  for (auto& frames : samples) io::can::encode(s, {12340, 0, false, false}, tx, frames);
  msgs::PsdSensors out;
  io::can::PlantStatus status;
  std::size_t k = 0;
  const std::size_t per_sample = samples[0].size();
  for (auto _ : state) {
    for (const auto& f : samples[k++ % samples.size()]) {
      if (filter.accept(f) != io::can::Reject::kNone) continue;
      io::can::apply(f, out);
      io::can::apply(f, status);
    }
    benchmark::DoNotOptimize(out);
  }
  if (filter.stats().accepted != static_cast<std::int64_t>(state.iterations() * per_sample)) {
    state.SkipWithError("a frame was rejected");
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(per_sample));
  state.SetLabel("items = frames");
}
BENCHMARK(BM_DecodePsdSensors);

// the plant's side of one command: encode (ECU) + filter with freshness + apply, 2 frames
void BM_PsdCommandRoundTrip(benchmark::State& state) {
  msgs::PsdCommand c;
  c.icePowRef_W = 12000.0;
  c.genTauRef_Nm = -35.5;
  c.motTauRef_Nm = 60.25;
  io::can::TxCounters tx;
  io::can::FrameFilter filter(io::can::kPsdCommandIds);
  std::array<io::can::Frame, io::can::kPsdCommandIds.size()> frames;
  msgs::PsdCommand out;
  std::uint32_t step = 0;
  for (auto _ : state) {
    c.stamp.step = step;
    io::can::encode(c, tx, frames);
    const io::can::Freshness fresh{step, 0};
    for (const auto& f : frames) {
      if (filter.accept(f, &fresh) == io::can::Reject::kNone) io::can::apply(f, out);
    }
    step += 10;
    benchmark::DoNotOptimize(out);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(frames.size()));
  state.SetLabel("items = frames");
}
BENCHMARK(BM_PsdCommandRoundTrip);

}  // namespace
