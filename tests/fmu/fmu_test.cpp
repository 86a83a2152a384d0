// SPDX-License-Identifier: BSD-3-Clause
// `ehpt fmu` checked by the project's own FMI 3.0 importer (fmi_importer.hpp): the FMU's
// trajectory is `ehpt run`'s, bit for bit, at communication steps of 1, 10 and 100 plant steps;
// instances in one process are independent; a wrong call is an fmi3Error with a message
// through the logger, never a crash.
#include <gtest/gtest.h>

#include <stdlib.h>  // mkdtemp
#include <sys/wait.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "fmi_importer.hpp"
#include "hil/config/config.hpp"
#include "hil/diag/alloc_guard.hpp"
#include "hil/run/simulation.hpp"
#include "io/process.hpp"
#include "msgs/psd.hpp"
#include "msgs/shev.hpp"
#include "test_plants.hpp"

namespace ehpt::test {
namespace {

namespace fs = std::filesystem;

std::string fresh_dir() {
  std::string base = (fs::temp_directory_path() / "ehpt-fmu-test-XXXXXX").string();
  EXPECT_NE(::mkdtemp(base.data()), nullptr);
  return base;
}

int ehpt(const std::vector<std::string>& args) {
  std::vector<std::string> argv{EHPT_BINARY};
  argv.insert(argv.end(), args.begin(), args.end());
  std::string reason;
  const int pid = io::start_program(argv, "/dev/null", "/dev/null", false, reason);
  int status = 0;
  if (pid < 0 || ::waitpid(pid, &status, 0) != pid) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

// timeseries.csv of `ehpt run` with every plant step recorded: column name -> values by step
std::map<std::string, std::vector<double>> reference(const std::string& dir, const std::vector<std::string>& sets) {
  std::vector<std::string> args{"run", "psecu2_nedc", "--quiet", "--out", dir, "--set", "output.interval_s=0.001"};
  for (const std::string& s : sets) {
    args.push_back("--set");
    args.push_back(s);
  }
  EXPECT_EQ(ehpt(args), 0);
  std::ifstream in(dir + "/timeseries.csv");
  std::string line;
  std::getline(in, line);
  std::vector<std::string> names;
  std::stringstream hs(line);
  for (std::string n; std::getline(hs, n, ',');) names.push_back(n);
  std::map<std::string, std::vector<double>> cols;
  while (std::getline(in, line)) {
    std::stringstream ls(line);
    std::size_t c = 0;
    for (std::string v; std::getline(ls, v, ','); ++c) cols[names[c]].push_back(std::strtod(v.c_str(), nullptr));
  }
  return cols;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Rows of run_fmu against the reference: every output, bit for bit, at every point.
void expect_equal(const Fmi3Fmu& fmu, const std::vector<std::vector<double>>& rows,
                  std::map<std::string, std::vector<double>>& ref, std::int64_t k, const std::string& what) {
  ASSERT_FALSE(rows.empty()) << what;
  int mismatches = 0;
  for (std::size_t r = 0; r < rows.size(); ++r) {
    const std::size_t step = std::min((r + 1) * static_cast<std::size_t>(k), ref["time_s"].size() - 1);
    ASSERT_TRUE(same_bits(rows[r][0], ref["time_s"][step])) << what << ": time " << rows[r][0] << " row " << r;
    for (std::size_t j = 0; j < fmu.output_names.size(); ++j) {
      const std::vector<double>& col = ref.at(fmu.output_names[j]);
      if (!same_bits(rows[r][j + 1], col[step]) && ++mismatches <= 5) {
        ADD_FAILURE() << what << ": " << fmu.output_names[j] << " at t = " << rows[r][0] << ": FMU " << rows[r][j + 1]
                      << ", ehpt run " << col[step];
      }
    }
  }
  EXPECT_EQ(mismatches, 0) << what;
}

bool logged(const Fmi3Fmu& fmu, const std::string& text) {
  for (const std::string& l : fmu.log) {
    if (l.find(text) != std::string::npos) return true;
  }
  return false;
}

class Fmu3 : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new std::string(fresh_dir());
    ASSERT_EQ(ehpt({"fmu", "psecu2_nedc", "--set", "solver.duration_s=20", "--out", *dir_ + "/p.fmu"}), 0);
    ASSERT_EQ(ehpt({"fmu", "psecu2_nedc", "--set", "solver.duration_s=20", "--set", "vehicle.vehicle.mass_kg=1800", "--out",
                    *dir_ + "/pheavy.fmu"}),
              0);
    ref_ = new std::map<std::string, std::vector<double>>(reference(*dir_ + "/ref", {"solver.duration_s=20"}));
    refheavy_ = new std::map<std::string, std::vector<double>>(
        reference(*dir_ + "/refheavy", {"solver.duration_s=20", "vehicle.vehicle.mass_kg=1800"}));
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    fs::remove_all(*dir_, ec);  // the folder this suite made
    delete dir_;
    delete ref_;
    delete refheavy_;
  }
  static std::string* dir_;
  static std::map<std::string, std::vector<double>>*ref_, *refheavy_;
};
std::string* Fmu3::dir_ = nullptr;
std::map<std::string, std::vector<double>>* Fmu3::ref_ = nullptr;
std::map<std::string, std::vector<double>>* Fmu3::refheavy_ = nullptr;

TEST_F(Fmu3, TheTrajectoryIsEhptRunsBitForBitAtCommunicationStepsOf1_10And100PlantSteps) {
  Fmi3Fmu fmu;
  std::string error;
  ASSERT_TRUE(fmu.open(*dir_ + "/p.fmu", error)) << error;
  EXPECT_STREQ(fmu.get_version(), "3.0");
  EXPECT_EQ(fmu.step_s, 0.001);
  EXPECT_EQ(fmu.stop_s, 20.0);
  EXPECT_EQ(fmu.output_names.size(), 34u);
  for (const std::int64_t k : {1, 10, 100}) {
    fmi3Instance inst = fmu.make_instance("p");
    ASSERT_NE(inst, nullptr) << (fmu.log.empty() ? "" : fmu.log.back());
    std::vector<std::vector<double>> rows;
    ASSERT_TRUE(run_fmu(fmu, inst, k, 20.0, rows, error)) << error;
    EXPECT_EQ(rows.size(), static_cast<std::size_t>(20000 / k));
    expect_equal(fmu, rows, *ref_, k, "k = " + std::to_string(k));
    fmu.free_instance(inst);
  }
  // the run moved: the car is at speed at 20 s and SOC has changed (not a run of zeros)
  EXPECT_GT(ref_->at("speed_m_s").back(), 3.0);
}

// Two FMUs of different parameters, and two instances of one, all in this process and stepped
// in turn: each gives its own `ehpt run`.
TEST_F(Fmu3, InstancesInOneProcessAreIndependent) {
  Fmi3Fmu a, b;
  std::string error;
  ASSERT_TRUE(a.open(*dir_ + "/p.fmu", error)) << error;
  ASSERT_TRUE(b.open(*dir_ + "/pheavy.fmu", error)) << error;
  fmi3Instance a1 = a.make_instance("a1"), a2 = a.make_instance("a2"), b1 = b.make_instance("b1");
  ASSERT_TRUE(a1 && a2 && b1);
  for (auto [fmu, inst] : {std::pair{&a, a1}, std::pair{&a, a2}, std::pair{&b, b1}}) {
    ASSERT_EQ(fmu->enter_initialization(inst, fmi3False, 0.0, 0.0, fmi3True, 20.0), fmi3OK);
    ASSERT_EQ(fmu->exit_initialization(inst), fmi3OK);
  }
  const fmi3ValueReference soc = a.vr.at("soc"), soc_b = b.vr.at("soc");
  std::vector<double> soc_a1, soc_a2, soc_b1;
  for (std::int64_t n = 0; n < 200; ++n) {
    const double t = static_cast<double>(n) * 0.1;
    fmi3Boolean e, term, early;
    fmi3Float64 last;
    double v = 0.0;
    for (auto [fmu, inst, vr, out] : {std::tuple{&a, a1, soc, &soc_a1}, std::tuple{&b, b1, soc_b, &soc_b1},
                                      std::tuple{&a, a2, soc, &soc_a2}}) {
      ASSERT_EQ(fmu->do_step(inst, t, 0.1, fmi3True, &e, &term, &early, &last), fmi3OK);
      ASSERT_EQ(fmu->get_float64(inst, &vr, 1, &v, 1), fmi3OK);
      out->push_back(v);
    }
  }
  for (std::size_t i = 0; i < soc_a1.size(); ++i) {
    const std::size_t step = (i + 1) * 100;
    ASSERT_TRUE(same_bits(soc_a1[i], ref_->at("soc")[step])) << i;
    ASSERT_TRUE(same_bits(soc_a2[i], ref_->at("soc")[step])) << i;
    ASSERT_TRUE(same_bits(soc_b1[i], refheavy_->at("soc")[step])) << i;
  }
  EXPECT_NE(ref_->at("soc").back(), refheavy_->at("soc").back());  // the parameter changed the run
  a.free_instance(a1);
  a.free_instance(a2);
  b.free_instance(b1);
}

// Wrong calls: fmi3Error (or NULL) with the reason in the log, never a crash; the instance
// then refuses everything but free.
TEST_F(Fmu3, WrongCallsAreErrorsWithAMessage) {
  Fmi3Fmu fmu;
  std::string error;
  ASSERT_TRUE(fmu.open(*dir_ + "/p.fmu", error)) << error;
  fmi3Boolean e, term, early;
  fmi3Float64 last;
  {  // doStep before initialization
    fmi3Instance i = fmu.make_instance("order");
    ASSERT_NE(i, nullptr);
    EXPECT_EQ(fmu.do_step(i, 0.0, 0.001, fmi3True, &e, &term, &early, &last), fmi3Error);
    EXPECT_TRUE(logged(fmu, "3 logStatusError: order: fmi3DoStep called in Instantiated (FMI's calling sequence)"));
    EXPECT_EQ(fmu.enter_initialization(i, fmi3False, 0.0, 0.0, fmi3True, 20.0), fmi3Error);  // in error now
    fmu.free_instance(i);
  }
  const auto initialized = [&](const char* name) {
    fmi3Instance i = fmu.make_instance(name);
    EXPECT_EQ(fmu.enter_initialization(i, fmi3False, 0.0, 0.0, fmi3True, 20.0), fmi3OK);
    EXPECT_EQ(fmu.exit_initialization(i), fmi3OK);
    return i;
  };
  {  // not a whole number of plant steps
    fmi3Instance i = initialized("grid");
    EXPECT_EQ(fmu.do_step(i, 0.0, 0.0015, fmi3True, &e, &term, &early, &last), fmi3Error);
    EXPECT_TRUE(logged(fmu, "communicationStepSize = 0.0015 s is not a whole number of plant steps (0.001 s"));
    fmu.free_instance(i);
  }
  {  // NaN, a point that is not where the FMU is, and past the stop time
    fmi3Instance i = initialized("nan");
    EXPECT_EQ(fmu.do_step(i, std::nan(""), 0.001, fmi3True, &e, &term, &early, &last), fmi3Error);
    EXPECT_TRUE(logged(fmu, "currentCommunicationPoint = nan s, but the FMU is at 0 s"));
    fmu.free_instance(i);
    i = initialized("late");
    EXPECT_EQ(fmu.do_step(i, 0.5, 0.001, fmi3True, &e, &term, &early, &last), fmi3Error);
    fmu.free_instance(i);
    i = initialized("past");
    EXPECT_EQ(fmu.do_step(i, 0.0, 20.001, fmi3True, &e, &term, &early, &last), fmi3Error);
    EXPECT_TRUE(logged(fmu, "past the stop time 20 s"));
    fmu.free_instance(i);
  }
  {  // an output cannot be set; an unknown value reference cannot be read
    fmi3Instance i = initialized("set");
    const fmi3ValueReference vr = 1, bad = 999;
    const double v = 1.0;
    double got = 0.0;
    EXPECT_EQ(fmu.set_float64(i, &vr, 1, &v, 1), fmi3Error);
    EXPECT_TRUE(logged(fmu, "fmi3SetFloat64: speed_ref_m_s is an output (this FMU has no inputs: its built-in ECU"))
        << fmu.log.back();
    EXPECT_EQ(fmu.get_float64(i, &vr, 1, &got, 1), fmi3Error);  // the instance is in error now
    fmu.free_instance(i);
    i = initialized("get");
    EXPECT_EQ(fmu.get_float64(i, &bad, 1, &got, 1), fmi3Error);
    EXPECT_TRUE(logged(fmu, "value reference 999 is not one of this FMU's"));
    fmu.free_instance(i);
  }
  // instantiation: another FMU's token, a start time other than 0
  EXPECT_EQ(fmu.make_instance("token", "{0000}"), nullptr);
  EXPECT_TRUE(logged(fmu, "instantiationToken \"{0000}\" is not this FMU's"));
  fmi3Instance i = fmu.make_instance("start");
  EXPECT_EQ(fmu.enter_initialization(i, fmi3False, 0.0, 1.0, fmi3False, 0.0), fmi3Error);
  EXPECT_TRUE(logged(fmu, "startTime = 1: an ehpt FMU starts at 0 s"));
  fmu.free_instance(i);
  // a resource missing: NULL, the file named
  fs::remove(fmu.dir + "/resources/vehicles/psecu2.toml");
  EXPECT_EQ(fmu.make_instance("missing"), nullptr);
  EXPECT_TRUE(logged(fmu, "psecu2.toml")) << (fmu.log.empty() ? "" : fmu.log.back());
}

// FMU state (for importers that roll back): run to 12 s, save, run to 18 s, restore, run to
// 18 s again: the same outputs bit for bit, and both are `ehpt run`'s. A state saved, then
// overwritten by a later save (the standard's reuse), restores the later point. Through FMI
// 2.0 the same. A state is not taken before initialization.
TEST_F(Fmu3, AStateSavedAndRestoredGoesOnBitForBit) {
  for (const char* file : {"/p.fmu", "/s2.fmu"}) {
    if (std::string(file) == "/s2.fmu") {
      ASSERT_EQ(ehpt({"fmu", "psecu2_nedc", "--fmi", "2", "--set", "solver.duration_s=20", "--out", *dir_ + file}), 0);
    }
    Fmi3Fmu fmu;
    std::string error;
    ASSERT_TRUE(fmu.open(*dir_ + file, error)) << error;
    ASSERT_NE(fmu.xml.find(fmu.version == 3 ? "canGetAndSetFMUState=\"true\"" : "canGetAndSetFMUstate=\"true\""),
              std::string::npos);
    const bool v3 = fmu.version == 3;
    void* inst = v3 ? fmu.make_instance("state") : fmu.make_instance2("state");
    ASSERT_NE(inst, nullptr);
    void* early = nullptr;
    if (v3) {
      EXPECT_EQ(fmu.get_state(inst, &early), fmi3Error);  // before initialization
      EXPECT_TRUE(logged(fmu, "fmi3GetFMUState called in Instantiated"));
      fmu.free_instance(inst);
      inst = fmu.make_instance("state");
      ASSERT_EQ(fmu.enter_initialization(inst, fmi3False, 0.0, 0.0, fmi3True, 20.0), fmi3OK);
      ASSERT_EQ(fmu.exit_initialization(inst), fmi3OK);
    } else {
      ASSERT_EQ(fmu.setup_experiment2(inst, fmi2False, 0.0, 0.0, fmi2True, 20.0), fmi2OK);
      ASSERT_EQ(fmu.enter_initialization2(inst), fmi2OK);
      ASSERT_EQ(fmu.exit_initialization2(inst), fmi2OK);
    }
    std::vector<fmi3ValueReference> refs;
    for (const std::string& n : fmu.output_names) refs.push_back(fmu.vr.at(n));
    // steps of 10 ms from point a to point b, the outputs after each
    const auto run = [&](std::int64_t a, std::int64_t b, std::vector<std::vector<double>>& rows) {
      for (std::int64_t n = a; n < b; ++n) {
        std::vector<double> y(refs.size());
        bool okay;
        if (v3) {
          fmi3Boolean e, term, er;
          fmi3Float64 last;
          okay = fmu.do_step(inst, static_cast<double>(n) * 0.01, 0.01, fmi3False, &e, &term, &er, &last) == fmi3OK &&
                 fmu.get_float64(inst, refs.data(), refs.size(), y.data(), y.size()) == fmi3OK;
        } else {
          okay = fmu.do_step2(inst, static_cast<double>(n) * 0.01, 0.01, fmi2False) == fmi2OK &&
                 fmu.get_real2(inst, refs.data(), refs.size(), y.data()) == fmi2OK;
        }
        if (!okay) return false;
        y.insert(y.begin(), static_cast<double>(n + 1) * 0.01);
        rows.push_back(std::move(y));
      }
      return true;
    };
    std::vector<std::vector<double>> to5, first, second, scratch;
    ASSERT_TRUE(run(0, 1100, scratch));
    void* state = nullptr;
    ASSERT_EQ(v3 ? static_cast<int>(fmu.get_state(inst, &state)) : static_cast<int>(fmu.get_state2(inst, &state)), 0);  // at 11 s, then overwritten:
    ASSERT_TRUE(run(1100, 1200, to5));
    void* same = state;
    ASSERT_EQ(v3 ? static_cast<int>(fmu.get_state(inst, &state)) : static_cast<int>(fmu.get_state2(inst, &state)), 0);  // at 12 s
    EXPECT_EQ(state, same);  // the state given was reused
    ASSERT_TRUE(run(1200, 1800, first));
    ASSERT_EQ(v3 ? static_cast<int>(fmu.set_state(inst, state)) : static_cast<int>(fmu.set_state2(inst, state)), 0);
    ASSERT_TRUE(run(1200, 1800, second));
    ASSERT_EQ(first.size(), second.size());
    int differ = 0;
    for (std::size_t r = 0; r < first.size(); ++r) {
      for (std::size_t j = 0; j < first[r].size(); ++j) differ += same_bits(first[r][j], second[r][j]) ? 0 : 1;
    }
    EXPECT_EQ(differ, 0) << file;
    int off_run = 0;  // and ehpt run's: row r is plant step 12 010 + 10 r
    for (std::size_t r = 0; r < second.size(); ++r) {
      const std::size_t step = (1200 + r + 1) * 10;
      for (std::size_t j = 0; j < fmu.output_names.size(); ++j) {
        off_run += same_bits(second[r][j + 1], ref_->at(fmu.output_names[j])[step]) ? 0 : 1;
      }
    }
    EXPECT_EQ(off_run, 0) << file;
    // the car accelerates from 11 s: a restore to the overwritten 11 s state would show
    EXPECT_GT(first.front()[2], to5.front()[2]);
    if (v3) {
      EXPECT_EQ(fmu.free_state(inst, &state), fmi3OK);
      EXPECT_EQ(state, nullptr);
      fmu.free_instance(inst);
    } else {
      EXPECT_EQ(fmu.free_state2(inst, &state), fmi2OK);
      fmu.free_instance2(inst);
    }
  }
}

// A serialised state (FMI 3.0 and 2.0) is the way to its point: deserialised in another
// instance, one at another time and with other parameters, it goes on bit for bit as the run
// it was taken from, parameters included (a heavy car's 12 s state goes on as ehpt run of the
// heavy car). A damaged state, another FMU's and one whose re-run does not reach its digest are
// refused with a message; without the built-in ECU there is none (canSerializeFMUState false).
TEST_F(Fmu3, ASerialisedStateGoesOnInAnotherInstanceBitForBit) {
  ASSERT_EQ(ehpt({"fmu", "psecu2_nedc", "--fmi", "2", "--set", "solver.duration_s=20", "--out", *dir_ + "/ser2.fmu"}), 0);
  for (const char* file : {"/p.fmu", "/ser2.fmu"}) {
    Fmi3Fmu fmu;
    std::string error;
    ASSERT_TRUE(fmu.open(*dir_ + file, error)) << error;
    const bool v3 = fmu.version == 3;
    ASSERT_NE(fmu.xml.find(v3 ? "canSerializeFMUState=\"true\"" : "canSerializeFMUstate=\"true\""), std::string::npos);
    std::vector<fmi3ValueReference> refs;
    for (const std::string& n : fmu.output_names) refs.push_back(fmu.vr.at(n));
    const fmi3ValueReference mass = fmu.vr.at("vehicle.vehicle.mass_kg");
    const auto start = [&](const char* name, double mass_kg) -> void* {
      void* inst = v3 ? fmu.make_instance(name) : fmu.make_instance2(name);
      if (inst == nullptr) return nullptr;
      const bool ok = v3 ? fmu.enter_initialization(inst, fmi3False, 0.0, 0.0, fmi3True, 20.0) == fmi3OK &&
                               fmu.set_float64(inst, &mass, 1, &mass_kg, 1) == fmi3OK &&
                               fmu.exit_initialization(inst) == fmi3OK
                         : fmu.setup_experiment2(inst, fmi2False, 0.0, 0.0, fmi2True, 20.0) == fmi2OK &&
                               fmu.enter_initialization2(inst) == fmi2OK && fmu.set_real2(inst, &mass, 1, &mass_kg) == fmi2OK &&
                               fmu.exit_initialization2(inst) == fmi2OK;
      return ok ? inst : nullptr;
    };
    const auto run = [&](void* inst, std::int64_t a, std::int64_t b, std::vector<std::vector<double>>* rows) {
      for (std::int64_t n = a; n < b; ++n) {
        std::vector<double> y(refs.size());
        fmi3Boolean e, term, er;
        fmi3Float64 last;
        const bool okay = v3 ? fmu.do_step(inst, static_cast<double>(n) * 0.01, 0.01, fmi3False, &e, &term, &er, &last) == fmi3OK &&
                                   fmu.get_float64(inst, refs.data(), refs.size(), y.data(), y.size()) == fmi3OK
                             : fmu.do_step2(inst, static_cast<double>(n) * 0.01, 0.01, fmi2False) == fmi2OK &&
                                   fmu.get_real2(inst, refs.data(), refs.size(), y.data()) == fmi2OK;
        if (!okay) return false;
        if (rows != nullptr) rows->push_back(std::move(y));
      }
      return true;
    };
    // the heavy car to 12 s, its state as bytes; the instance and the state then freed
    void* a = start("a", 1800.0);
    ASSERT_NE(a, nullptr) << (fmu.log.empty() ? "" : fmu.log.back());
    ASSERT_TRUE(run(a, 0, 1200, nullptr));
    void* state = nullptr;
    std::size_t size = 0;
    std::vector<char> bytes;
    if (v3) {
      ASSERT_EQ(fmu.get_state(a, &state), fmi3OK);
      ASSERT_EQ(fmu.serialized_size(a, state, &size), fmi3OK);
      bytes.resize(size);
      EXPECT_EQ(fmu.serialize(a, state, reinterpret_cast<fmi3Byte*>(bytes.data()), size - 1), fmi3Error);  // too small
      ASSERT_EQ(fmu.serialize(a, state, reinterpret_cast<fmi3Byte*>(bytes.data()), size), fmi3OK);
      fmu.free_state(a, &state);
      fmu.free_instance(a);
    } else {
      ASSERT_EQ(fmu.get_state2(a, &state), fmi2OK);
      ASSERT_EQ(fmu.serialized_size2(a, state, &size), fmi2OK);
      bytes.resize(size);
      ASSERT_EQ(fmu.serialize2(a, state, bytes.data(), size), fmi2OK);
      fmu.free_state2(a, &state);
      fmu.free_instance2(a);
    }
    ASSERT_GT(size, 20u);
    // another instance, of the standard car, at 3 s: the bytes make it the heavy car at 12 s
    void* b = start("b", 1500.0);
    ASSERT_NE(b, nullptr);
    ASSERT_TRUE(run(b, 0, 300, nullptr));
    void* restored = nullptr;
    if (v3) {
      ASSERT_EQ(fmu.deserialize(b, reinterpret_cast<const fmi3Byte*>(bytes.data()), size, &restored), fmi3OK);
      ASSERT_EQ(fmu.set_state(b, restored), fmi3OK) << (fmu.log.empty() ? "" : fmu.log.back());
    } else {
      ASSERT_EQ(fmu.deserialize2(b, bytes.data(), size, &restored), fmi2OK);
      ASSERT_EQ(fmu.set_state2(b, restored), fmi2OK) << (fmu.log.empty() ? "" : fmu.log.back());
    }
    std::vector<std::vector<double>> rows;
    ASSERT_TRUE(run(b, 1200, 1800, &rows));
    int off_run = 0;  // ehpt run of the heavy car: row r is plant step 12 010 + 10 r
    for (std::size_t r = 0; r < rows.size(); ++r) {
      for (std::size_t j = 0; j < fmu.output_names.size(); ++j) {
        off_run += same_bits(rows[r][j], refheavy_->at(fmu.output_names[j])[(1200 + r + 1) * 10]) ? 0 : 1;
      }
    }
    EXPECT_EQ(off_run, 0) << file;
    int off_light = 0;  // and not the standard car's
    for (std::size_t j = 0; j < fmu.output_names.size(); ++j) {
      off_light += same_bits(rows.back()[j], ref_->at(fmu.output_names[j])[18000]) ? 0 : 1;
    }
    EXPECT_GT(off_light, 0) << file;
    double m = 0.0;
    EXPECT_EQ(v3 ? static_cast<int>(fmu.get_float64(b, &mass, 1, &m, 1)) : static_cast<int>(fmu.get_real2(b, &mass, 1, &m)), 0);
    EXPECT_EQ(m, 1800.0) << "the parameter came with the state";
    if (v3) {
      fmu.free_state(b, &restored);
      fmu.free_instance(b);
    } else {
      fmu.free_state2(b, &restored);
      fmu.free_instance2(b);
    }
    if (!v3) continue;
    // refused, each with its message: bytes that are not a state, another FMU's, a wrong digest
    const auto refused = [&](std::string text, const char* why, bool at_set) {
      void* c = start("c", 1500.0);
      void* st = nullptr;
      const fmi3Status d = fmu.deserialize(c, reinterpret_cast<const fmi3Byte*>(text.data()), text.size(), &st);
      const fmi3Status set = d == fmi3OK ? fmu.set_state(c, st) : fmi3Error;
      EXPECT_EQ(at_set ? set : d, fmi3Error) << why;
      EXPECT_TRUE(logged(fmu, why)) << why << ": " << (fmu.log.empty() ? "" : fmu.log.back());
      if (st != nullptr) fmu.free_state(c, &st);
      fmu.free_instance(c);
    };
    const std::string good(bytes.begin(), bytes.end());
    refused("hello", "is not a serialised state's", false);
    std::string other = good;
    other.replace(other.find("token {") + 7, 4, "dead");
    refused(other, "a state of another FMU", false);
    std::string digest = good;
    const std::size_t at = digest.find("digest ") + 7;
    digest[at] = digest[at] == '1' ? '2' : '1';
    refused(digest, "does not run again to the same point", true);
    std::string far = good;
    far.replace(far.find("step ") + 5, far.find('\n', far.find("step ")) - far.find("step ") - 5, "99999999");
    refused(far, "past this scenario's end", true);
  }
  // without the built-in ECU: no serialised state, and the FMU says so in its description
  ASSERT_EQ(ehpt({"fmu", "psecu2_nedc", "--ecu", "none", "--set", "solver.duration_s=20", "--out", *dir_ + "/nser.fmu"}), 0);
  Fmi3Fmu none;
  std::string error;
  ASSERT_TRUE(none.open(*dir_ + "/nser.fmu", error)) << error;
  EXPECT_NE(none.xml.find("canSerializeFMUState=\"false\""), std::string::npos);
  fmi3Instance inst = none.make_instance("n");
  ASSERT_EQ(none.enter_initialization(inst, fmi3False, 0.0, 0.0, fmi3True, 20.0), fmi3OK);
  ASSERT_EQ(none.exit_initialization(inst), fmi3OK);
  fmi3FMUState st = nullptr;
  ASSERT_EQ(none.get_state(inst, &st), fmi3OK);  // a state in memory: yes
  std::size_t n = 0;
  EXPECT_EQ(none.serialized_size(inst, st, &n), fmi3Error);
  EXPECT_TRUE(logged(none, "depends on the inputs the importer gave"));
  none.free_state(inst, &st);
  none.free_instance(inst);
}

// A plant fault that stops `ehpt run` (exit 3: here the SOC leaves its window at 14.574 s)
// ends the FMU's run where it ends the CLI's: fmi3Discard with terminateSimulation and
// lastSuccessfulTime there, the fault in the log, and fmi3Terminate still answers OK.
TEST_F(Fmu3, APlantFaultEndsTheRunWhereEhptRunEndsIt) {
  const std::vector<std::string> sets{"--set", "solver.duration_s=200", "--set", "vehicle.battery.soc_initial=0.1001",
                                      "--set", "vehicle.battery.soc_min=0.1"};
  std::vector<std::string> args{"fmu", "ev_nedc", "--out", *dir_ + "/fault.fmu"};
  args.insert(args.end(), sets.begin(), sets.end());
  ASSERT_EQ(ehpt(args), 0);
  std::vector<std::string> run{"run", "ev_nedc", "--quiet", "--out", *dir_ + "/fault_run"};
  run.insert(run.end(), sets.begin(), sets.end());
  EXPECT_EQ(ehpt(run), 3);  // the CLI's plant fault
  Fmi3Fmu fmu;
  std::string error;
  ASSERT_TRUE(fmu.open(*dir_ + "/fault.fmu", error)) << error;
  fmi3Instance inst = fmu.make_instance("fault");
  ASSERT_EQ(fmu.enter_initialization(inst, fmi3False, 0.0, 0.0, fmi3False, 0.0), fmi3OK);
  ASSERT_EQ(fmu.exit_initialization(inst), fmi3OK);
  fmi3Status status = fmi3OK;
  fmi3Boolean e = fmi3False, term = fmi3False, early = fmi3False;
  fmi3Float64 last = 0.0;
  std::int64_t n = 0;
  for (; n < 20000 && status == fmi3OK; ++n) {
    status = fmu.do_step(inst, static_cast<double>(n) * 0.01, 0.01, fmi3True, &e, &term, &early, &last);
  }
  EXPECT_EQ(status, fmi3Discard);
  EXPECT_TRUE(term);
  EXPECT_EQ(last, 14.574);  // the step ehpt run stopped at (step 14574)
  EXPECT_EQ(n, 1458);       // the call over 14.57 .. 14.58 s
  EXPECT_TRUE(logged(fmu, "2 logStatusDiscard: fault: ev_nedc: the plant stopped on a fault at t = 14.574 s: "));
  EXPECT_EQ(fmu.terminate(inst), fmi3OK);
  fmu.free_instance(inst);
}

// doStep allocates nothing: counted at the malloc level for the whole process (the FMU
// library's malloc and operator new are this executable's, hil/diag/alloc_guard.hpp), from
// the first doStep to the last, with every output read and, without the ECU, the inputs set
// at each point. Instantiation and initialization may allocate.
TEST_F(Fmu3, DoStepAllocatesNothing) {
  ASSERT_EQ(ehpt({"fmu", "psecu2_nedc", "--ecu", "none", "--set", "solver.duration_s=20", "--out", *dir_ + "/na.fmu"}), 0);
  for (const char* file : {"/p.fmu", "/na.fmu"}) {
    Fmi3Fmu fmu;
    std::string error;
    ASSERT_TRUE(fmu.open(*dir_ + file, error)) << error;
    fmi3Instance inst = fmu.make_instance("alloc");
    ASSERT_NE(inst, nullptr);
    ASSERT_EQ(fmu.enter_initialization(inst, fmi3False, 0.0, 0.0, fmi3True, 20.0), fmi3OK);
    ASSERT_EQ(fmu.exit_initialization(inst), fmi3OK);
    std::vector<fmi3ValueReference> refs;
    for (const std::string& n : fmu.output_names) refs.push_back(fmu.vr.at(n));
    std::vector<double> y(refs.size());
    const bool inputs = fmu.vr.count("command.motTauRef_Nm") > 0;
    const fmi3ValueReference mot = inputs ? fmu.vr.at("command.motTauRef_Nm") : 0;
    int failed = 0;
    hil::alloc_guard::reset();
    hil::alloc_guard::arm();
    for (std::int64_t n = 0; n < 20000; ++n) {
      fmi3Boolean e, term, early;
      fmi3Float64 last;
      const double torque = 10.0;
      if (inputs && fmu.set_float64(inst, &mot, 1, &torque, 1) != fmi3OK) ++failed;
      if (fmu.do_step(inst, static_cast<double>(n) * 0.001, 0.001, fmi3True, &e, &term, &early, &last) != fmi3OK) ++failed;
      if (fmu.get_float64(inst, refs.data(), refs.size(), y.data(), y.size()) != fmi3OK) ++failed;
    }
    hil::alloc_guard::disarm();
    EXPECT_EQ(failed, 0) << file;
    ASSERT_TRUE(hil::alloc_guard::active()) << "the hooks are not in this executable";
    EXPECT_EQ(hil::alloc_guard::count(), 0u) << file << ": " << hil::alloc_guard::describe_first();
    fmu.free_instance(inst);
  }
}

// The vehicle's numbers are parameters: two instances of one FMU in one process, one with
// vehicle.vehicle.mass_kg set to 1800 before initialization, give `ehpt run` without and with
// --set vehicle.vehicle.mass_kg=1800, bit for bit. A value the loader refuses is refused at
// fmi3ExitInitializationMode with ehpt run's message; a fixed parameter cannot change later.
TEST_F(Fmu3, TheVehiclesNumbersAreParametersCheckedAsEhptRunChecksThem) {
  Fmi3Fmu fmu;
  std::string error;
  ASSERT_TRUE(fmu.open(*dir_ + "/p.fmu", error)) << error;
  const fmi3ValueReference mass = fmu.vr.at("vehicle.vehicle.mass_kg");
  ASSERT_NE(fmu.xml.find("name=\"vehicle.vehicle.mass_kg\" valueReference=\"" + std::to_string(mass) + "\""),
            std::string::npos);
  fmi3Instance light = fmu.make_instance("light"), heavy = fmu.make_instance("heavy");
  ASSERT_TRUE(light && heavy);
  double start = 0.0;
  ASSERT_EQ(fmu.get_float64(heavy, &mass, 1, &start, 1), fmi3OK);
  EXPECT_GT(start, 500.0);  // the vehicle file's mass
  EXPECT_NE(start, 1800.0);
  const double m = 1800.0;
  ASSERT_EQ(fmu.set_float64(heavy, &mass, 1, &m, 1), fmi3OK);
  std::vector<std::vector<double>> rows_light, rows_heavy;
  ASSERT_TRUE(run_fmu(fmu, light, 10, 20.0, rows_light, error)) << error;
  ASSERT_TRUE(run_fmu(fmu, heavy, 10, 20.0, rows_heavy, error)) << error;
  expect_equal(fmu, rows_light, *ref_, 10, "default mass");
  expect_equal(fmu, rows_heavy, *refheavy_, 10, "mass 1800 kg as a parameter");
  fmu.free_instance(light);
  fmu.free_instance(heavy);

  fmi3Instance bad = fmu.make_instance("bad");
  const double negative = -5.0;
  ASSERT_EQ(fmu.set_float64(bad, &mass, 1, &negative, 1), fmi3OK);  // checked when initialization ends
  ASSERT_EQ(fmu.enter_initialization(bad, fmi3False, 0.0, 0.0, fmi3True, 20.0), fmi3OK);
  EXPECT_EQ(fmu.exit_initialization(bad), fmi3Error);
  EXPECT_TRUE(logged(fmu, "vehicle.vehicle.mass_kg = -5: must be a finite number > 0"));
  EXPECT_TRUE(logged(fmu, "fmi3ExitInitializationMode: the scenario does not load with the parameters set "
                          "(vehicle.vehicle.mass_kg = -5)"));
  fmu.free_instance(bad);
  fmi3Instance late = fmu.make_instance("late");
  ASSERT_EQ(fmu.enter_initialization(late, fmi3False, 0.0, 0.0, fmi3True, 20.0), fmi3OK);
  ASSERT_EQ(fmu.exit_initialization(late), fmi3OK);
  EXPECT_EQ(fmu.set_float64(late, &mass, 1, &m, 1), fmi3Error);
  EXPECT_TRUE(logged(fmu, "vehicle.vehicle.mass_kg is a fixed parameter: set it before fmi3ExitInitializationMode"));
  fmu.free_instance(late);
}

// FMI 2.0: the same library core behind FMI 2.0's calls, the same trajectory bit for bit; its own
// ways to be called wrong (another guid, a resource location that is not a file URI) refused.
TEST_F(Fmu3, Fmi2GivesTheSameTrajectoryAndRefusesWhatFmi2CallsWrong) {
  ASSERT_EQ(ehpt({"fmu", "psecu2_nedc", "--fmi", "2", "--set", "solver.duration_s=20", "--out", *dir_ + "/p2.fmu"}), 0);
  Fmi3Fmu fmu;
  std::string error;
  ASSERT_TRUE(fmu.open(*dir_ + "/p2.fmu", error)) << error;
  EXPECT_EQ(fmu.version, 2);
  EXPECT_STREQ(fmu.get_version2(), "2.0");
  EXPECT_EQ(fmu.output_names.size(), 34u);
  for (const std::int64_t k : {1, 10, 100}) {
    fmi2Component c = fmu.make_instance2("p2");
    ASSERT_NE(c, nullptr) << (fmu.log.empty() ? "" : fmu.log.back());
    std::vector<std::vector<double>> rows;
    ASSERT_TRUE(run_fmu2(fmu, c, k, 20.0, rows, error)) << error;
    expect_equal(fmu, rows, *ref_, k, "FMI 2.0, k = " + std::to_string(k));
    fmu.free_instance2(c);
  }
  EXPECT_EQ(fmu.make_instance2("guid", "{0}"), nullptr);
  EXPECT_TRUE(logged(fmu, "guid \"{0}\" is not this FMU's"));
  static fmi2CallbackFunctions callbacks{};  // no logger: refused quietly, never a crash
  EXPECT_EQ(fmu.instantiate2("uri", fmi2CoSimulation, fmu.token.c_str(), "/not/a/uri", &callbacks, fmi2False, fmi2False),
            nullptr);
  fmi2Component c = fmu.make_instance2("order");
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(fmu.do_step2(c, 0.0, 0.001, fmi2True), fmi2Error);
  EXPECT_TRUE(logged(fmu, "fmi2DoStep called in Instantiated (FMI's calling sequence)"));
  fmu.free_instance2(c);
  c = fmu.make_instance2("set");
  const fmi2ValueReference out = 1;
  const double v = 1.0;
  EXPECT_EQ(fmu.set_real2(c, &out, 1, &v), fmi2Error);
  EXPECT_TRUE(logged(fmu, "fmi2SetReal: speed_ref_m_s is an output"));
  fmu.free_instance2(c);
}

// --ecu none: the importer is the ECU. A simple controller (motor torque from the driver's
// request, engine off) through the FMU's command inputs and sensor outputs gives, bit for bit,
// what the same controller gives through the Simulation facade's external ECU (the path of the
// Python module and of a bus ECU): every output and every sensor field at every ECU sample.
TEST_F(Fmu3, WithoutItsEcuTheImporterDrivesThePlantThroughTheMessageFields) {
  ASSERT_EQ(ehpt({"fmu", "psecu2_nedc", "--ecu", "none", "--set", "solver.duration_s=20", "--out", *dir_ + "/n.fmu"}), 0);
  Fmi3Fmu fmu;
  std::string error;
  ASSERT_TRUE(fmu.open(*dir_ + "/n.fmu", error)) << error;
  EXPECT_EQ(fmu.model_identifier, "ehpt_psecu2_nedc_plant");
  const fmi3ValueReference request = fmu.vr.at("sensors.driverRequest"), mot = fmu.vr.at("command.motTauRef_Nm");
  fmi3ValueReference ice_on = 0;
  ASSERT_NE(fmu.xml.find("<Boolean name=\"command.iceON\""), std::string::npos);
  ice_on = fmu.boolean_vr.at("command.iceON");
  fmi3Instance inst = fmu.make_instance("plant");
  ASSERT_NE(inst, nullptr) << (fmu.log.empty() ? "" : fmu.log.back());
  // before initialization an input takes a value; a NaN is refused and changes nothing
  const double nan = std::nan("");
  EXPECT_EQ(fmu.set_float64(inst, &mot, 1, &nan, 1), fmi3Error);
  EXPECT_TRUE(logged(fmu, "fmi3SetFloat64: command.motTauRef_Nm = nan: not a finite number (refused, not applied)"));
  fmu.free_instance(inst);
  inst = fmu.make_instance("plant");
  ASSERT_EQ(fmu.enter_initialization(inst, fmi3False, 0.0, 0.0, fmi3True, 20.0), fmi3OK);
  ASSERT_EQ(fmu.exit_initialization(inst), fmi3OK);

  hil::Scenario sc = test::load(test::source_path("scenarios/psecu2_nedc.toml"), {"solver.duration_s=20"});
  hil::SimulationOptions opt;
  opt.external_ecu = true;
  auto sim = hil::make_simulation(sc, opt);
  std::vector<fmi3ValueReference> refs;
  for (const std::string& n : fmu.output_names) refs.push_back(fmu.vr.at(n));
  std::vector<double> y(refs.size());
  int compared = 0;
  for (std::int64_t n = 0; n < 2000; ++n) {
    // the reference: what an external ECU does through the facade
    msgs::PsdSensors s;
    ASSERT_TRUE(sim->read_sensors(s));
    msgs::PsdCommand c;
    c.motTauRef_Nm = 60.0 * s.driverRequest;
    c.iceON = false;
    c.stamp = s.stamp;
    ASSERT_TRUE(sim->write_command(c));
    ASSERT_EQ(sim->step(10), 10);
    // the FMU: the same from its outputs to its inputs
    double r = 0.0;
    ASSERT_EQ(fmu.get_float64(inst, &request, 1, &r, 1), fmi3OK);
    ASSERT_TRUE(same_bits(r, s.driverRequest)) << n;
    const double torque = 60.0 * r;
    const fmi3Boolean off = fmi3False;
    ASSERT_EQ(fmu.set_float64(inst, &mot, 1, &torque, 1), fmi3OK);
    ASSERT_EQ(fmu.set_boolean(inst, &ice_on, 1, &off, 1), fmi3OK);
    fmi3Boolean e, term, early;
    fmi3Float64 last;
    ASSERT_EQ(fmu.do_step(inst, static_cast<double>(n) * 0.01, 0.01, fmi3True, &e, &term, &early, &last), fmi3OK)
        << (fmu.log.empty() ? "" : fmu.log.back());
    ASSERT_EQ(fmu.get_float64(inst, refs.data(), refs.size(), y.data(), y.size()), fmi3OK);
    const std::span<const double> want = sim->outputs();
    for (std::size_t j = 0; j < fmu.output_names.size(); ++j) {
      const std::string& name = fmu.output_names[j];
      if (name.rfind("sensors.", 0) == 0) continue;  // below
      const auto& signals = sim->signals();
      const auto it = std::find_if(signals.begin(), signals.end(), [&](const auto& x) { return x.name == name; });
      ASSERT_NE(it, signals.end()) << name;
      ASSERT_TRUE(same_bits(y[j], want[static_cast<std::size_t>(it - signals.begin())]))
          << name << " at step " << (n + 1) * 10 << ": FMU " << y[j];
      ++compared;
    }
  }
  EXPECT_GT(compared, 2000 * 30);
  EXPECT_GT(sim->outputs()[2], 3.0);  // speed_m_s: the car moved under the importer's torque
  // the sensor message as the ECU reads it: batSOC equals the plant's soc at the sample
  const fmi3ValueReference bat = fmu.vr.at("sensors.batSOC");
  double soc = 0.0;
  ASSERT_EQ(fmu.get_float64(inst, &bat, 1, &soc, 1), fmi3OK);
  msgs::PsdSensors last_sensors;
  ASSERT_TRUE(sim->read_sensors(last_sensors));
  EXPECT_TRUE(same_bits(soc, last_sensors.batSOC));
  // an output is not an input; a Boolean is not a Float64
  const double v = 1.0;
  EXPECT_EQ(fmu.set_float64(inst, &bat, 1, &v, 1), fmi3Error);
  EXPECT_TRUE(logged(fmu, "fmi3SetFloat64: sensors.batSOC is an output"));
  fmu.free_instance(inst);
}

// --ecu none for the series hybrid: the importer is its EMS (the driver's request to the drive,
// a fixed 30 kW asked of the genset, on), through ShevSensors/ShevCommand as FMU variables,
// bit for bit the same EMS through the facade.
TEST_F(Fmu3, TheSeriesHybridsEmsIsTheImportersWithoutItsEcu) {
  ASSERT_EQ(ehpt({"fmu", "shev_oo_sort1", "--ecu", "none", "--set", "solver.duration_s=20", "--out", *dir_ + "/s.fmu"}),
            0);
  Fmi3Fmu fmu;
  std::string error;
  ASSERT_TRUE(fmu.open(*dir_ + "/s.fmu", error)) << error;
  const fmi3ValueReference request = fmu.vr.at("sensors.driverRequest_Nm"), drive = fmu.vr.at("command.driveTauRef_Nm"),
                           power = fmu.vr.at("command.gensetPowRef_W"), genset_dc = fmu.vr.at("sensors.gensetPowDc_W");
  const fmi3ValueReference on = fmu.boolean_vr.at("command.gensetON");
  fmi3Instance inst = fmu.make_instance("plant");
  ASSERT_NE(inst, nullptr) << (fmu.log.empty() ? "" : fmu.log.back());
  ASSERT_EQ(fmu.enter_initialization(inst, fmi3False, 0.0, 0.0, fmi3True, 20.0), fmi3OK);
  ASSERT_EQ(fmu.exit_initialization(inst), fmi3OK);

  hil::Scenario sc = test::load(test::source_path("scenarios/shev_oo_sort1.toml"), {"solver.duration_s=20"});
  hil::SimulationOptions opt;
  opt.external_ecu = true;
  auto sim = hil::make_simulation(sc, opt);
  std::vector<fmi3ValueReference> refs;
  for (const std::string& n : fmu.output_names) {
    if (n.rfind("sensors.", 0) != 0) refs.push_back(fmu.vr.at(n));
  }
  std::vector<double> y(refs.size());
  double last_genset_dc_W = 0.0;
  for (std::int64_t n = 0; n < 2000; ++n) {
    msgs::ShevSensors s;
    ASSERT_TRUE(sim->read_sensors(s));
    msgs::ShevCommand c;
    c.driveTauRef_Nm = s.driverRequest_Nm;
    c.gensetPowRef_W = 30000.0;
    c.gensetON = true;
    c.stamp = s.stamp;
    ASSERT_TRUE(sim->write_command(c));
    ASSERT_EQ(sim->step(10), 10);
    double r = 0.0;
    ASSERT_EQ(fmu.get_float64(inst, &request, 1, &r, 1), fmi3OK);
    ASSERT_TRUE(same_bits(r, s.driverRequest_Nm)) << n;
    const double p = 30000.0;
    const fmi3Boolean yes = fmi3True;
    ASSERT_EQ(fmu.set_float64(inst, &drive, 1, &r, 1), fmi3OK);
    ASSERT_EQ(fmu.set_float64(inst, &power, 1, &p, 1), fmi3OK);
    ASSERT_EQ(fmu.set_boolean(inst, &on, 1, &yes, 1), fmi3OK);
    fmi3Boolean e, term, early;
    fmi3Float64 last;
    ASSERT_EQ(fmu.do_step(inst, static_cast<double>(n) * 0.01, 0.01, fmi3True, &e, &term, &early, &last), fmi3OK)
        << (fmu.log.empty() ? "" : fmu.log.back());
    ASSERT_EQ(fmu.get_float64(inst, refs.data(), refs.size(), y.data(), y.size()), fmi3OK);
    const std::span<const double> want = sim->outputs();
    std::size_t j = 0;
    for (const std::string& name : fmu.output_names) {
      if (name.rfind("sensors.", 0) == 0) continue;
      const auto& signals = sim->signals();
      const auto it = std::find_if(signals.begin(), signals.end(), [&](const auto& x) { return x.name == name; });
      ASSERT_NE(it, signals.end()) << name;
      ASSERT_TRUE(same_bits(y[j], want[static_cast<std::size_t>(it - signals.begin())]))
          << name << " at step " << (n + 1) * 10 << ": FMU " << y[j];
      ++j;
    }
    ASSERT_EQ(fmu.get_float64(inst, &genset_dc, 1, &last_genset_dc_W, 1), fmi3OK);
  }
  EXPECT_GT(last_genset_dc_W, 20000.0);  // the genset delivers what the importer asked for
  fmu.free_instance(inst);
}

}  // namespace
}  // namespace ehpt::test
