// SPDX-License-Identifier: BSD-3-Clause
// The cost of a plant step inside an FMU against the same step in the runner (Google
// Benchmark; figures, never test assertions). Side by side, psecu2 on NEDC, 20 s (20 000 steps
// of 1 ms) per iteration:
//   BM_SimulationSteps/k: the Simulation facade stepping k plant steps at a time (what `ehpt
//                         run` does, without its CSV), all outputs read after each k
//   BM_Fmi3DoStep/k:      the FMI 3.0 FMU `ehpt fmu` builds, loaded by the project's importer
//                         (tests/fmu/fmi_importer.hpp): fmi3DoStep of k steps, then
//                         fmi3GetFloat64 of every output
// Counter ns_per_step: wall time per plant step. Instantiation is outside the timing.
#include <benchmark/benchmark.h>
#include <stdlib.h>  // mkdtemp
#include <sys/wait.h>

#include <filesystem>
#include <memory>

#include "fmi_importer.hpp"
#include "hil/config/config.hpp"
#include "hil/run/simulation.hpp"
#include "io/process.hpp"

namespace {

using namespace ehpt;

constexpr double kSeconds = 20.0;
constexpr std::int64_t kSteps = 20000;

// The FMU, built once by the ehpt of this build tree into a folder of our own.
test::Fmi3Fmu& fmu() {
  static std::unique_ptr<test::Fmi3Fmu> f = [] {
    std::string dir = (std::filesystem::temp_directory_path() / "ehpt-bench-fmu-XXXXXX").string();
    if (::mkdtemp(dir.data()) == nullptr) std::abort();
    const std::string path = dir + "/p.fmu";
    std::string reason;
    const int pid = io::start_program({EHPT_BINARY, "fmu", "psecu2_nedc", "--set", "solver.duration_s=20", "--out", path},
                                      "/dev/null", "", false, reason);
    int status = 0;
    if (pid < 0 || ::waitpid(pid, &status, 0) != pid || !WIFEXITED(status) || WEXITSTATUS(status) != 0) std::abort();
    auto loaded = std::make_unique<test::Fmi3Fmu>();
    std::string error;
    if (!loaded->open(path, error)) std::abort();
    std::filesystem::remove_all(dir);  // unpacked already; the archive was ours
    return loaded;
  }();
  return *f;
}

void BM_SimulationSteps(benchmark::State& state) {
  const std::int64_t k = state.range(0);
  hil::Scenario sc;
  std::vector<std::string> errors;
  if (!hil::load_scenario(std::string(EHPT_SOURCE_DIR) + "/scenarios/psecu2_nedc.toml", {"solver.duration_s=20"}, sc,
                          errors)) {
    std::abort();
  }
  hil::SimulationOptions opt;
  opt.columns = {0};
  opt.chunk_steps = 100000;
  double sink = 0.0;
  for (auto _ : state) {
    state.PauseTiming();
    auto sim = hil::make_simulation(sc, opt);
    state.ResumeTiming();
    for (std::int64_t done = 0; done < kSteps; done += k) {
      sim->step(k);
      sim->clear_rows();
      for (const double v : sim->outputs()) sink += v;
    }
  }
  benchmark::DoNotOptimize(sink);
  state.counters["ns_per_step"] =
      benchmark::Counter(static_cast<double>(kSteps), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_SimulationSteps)->Arg(1)->Arg(10)->Arg(100)->Unit(benchmark::kMillisecond);

void BM_Fmi3DoStep(benchmark::State& state) {
  const std::int64_t k = state.range(0);
  test::Fmi3Fmu& f = fmu();
  std::vector<fmi3ValueReference> refs;
  for (const std::string& n : f.output_names) refs.push_back(f.vr.at(n));
  std::vector<double> y(refs.size());
  double sink = 0.0;
  for (auto _ : state) {
    state.PauseTiming();
    fmi3Instance inst = f.make_instance("bench");
    if (inst == nullptr || f.enter_initialization(inst, fmi3False, 0.0, 0.0, fmi3True, kSeconds) != fmi3OK ||
        f.exit_initialization(inst) != fmi3OK) {
      std::abort();
    }
    state.ResumeTiming();
    fmi3Boolean e, term, early;
    fmi3Float64 last;
    for (std::int64_t done = 0; done < kSteps; done += k) {
      f.do_step(inst, static_cast<double>(done) * 0.001, static_cast<double>(k) * 0.001, fmi3True, &e, &term, &early, &last);
      f.get_float64(inst, refs.data(), refs.size(), y.data(), y.size());
      sink += y[0];
    }
    state.PauseTiming();
    f.free_instance(inst);
    state.ResumeTiming();
  }
  benchmark::DoNotOptimize(sink);
  state.counters["ns_per_step"] =
      benchmark::Counter(static_cast<double>(kSteps), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_Fmi3DoStep)->Arg(1)->Arg(10)->Arg(100)->Unit(benchmark::kMillisecond);

}  // namespace
