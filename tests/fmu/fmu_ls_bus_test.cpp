// SPDX-License-Identifier: BSD-3-Clause
// `ehpt fmu --bus ls-bus`: the plant FMU and its ECU FMU (the built-in MBecu2 with the same CAN
// terminal) connected directly by the project's importer, Tx_Data to Rx_Data, give the run of
// the lockstep bus session (`ehpt plant --lockstep` + `ehpt ecu`, which is `ehpt run --set
// vehicle.ecu.codec=can`: tools/main.sh checks it) bit for bit; the plant alone on its bus goes
// to its safe state and says so; the terminal's rules answer wrong calls with fmi3Error.
#include <gtest/gtest.h>

#include <stdlib.h>  // mkdtemp
#include <sys/wait.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <algorithm>
#include <map>
#include <set>
#include <sstream>

#include "fmi_importer.hpp"
#include "hil/diag/alloc_guard.hpp"
#include "io/can/dbc.hpp"
#include "io/can/ls_bus.hpp"
#include "io/process.hpp"

namespace ehpt::test {
namespace {

namespace fs = std::filesystem;

int ehpt(const std::vector<std::string>& args) {
  std::vector<std::string> argv{EHPT_BINARY};
  argv.insert(argv.end(), args.begin(), args.end());
  std::string reason;
  const int pid = io::start_program(argv, "/dev/null", "/dev/null", false, reason);
  int status = 0;
  if (pid < 0 || ::waitpid(pid, &status, 0) != pid) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// timeseries.csv of `ehpt run`: column name -> values, row by row
std::map<std::string, std::vector<double>> columns(const std::string& path) {
  std::map<std::string, std::vector<double>> cols;
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> names;
  std::stringstream hs(line);
  for (std::string n; std::getline(hs, n, ',');) names.push_back(n);
  while (std::getline(in, line)) {
    std::stringstream ls(line);
    std::size_t c = 0;
    for (std::string v; std::getline(ls, v, ',') && c < names.size(); ++c) cols[names[c]].push_back(std::strtod(v.c_str(), nullptr));
  }
  return cols;
}

constexpr double kStop_s = 20.0;

class LsBus : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    std::string base = (fs::temp_directory_path() / "ehpt-lsbus-test-XXXXXX").string();
    ASSERT_NE(::mkdtemp(base.data()), nullptr);
    dir_ = new std::string(base);
    const std::string d = "solver.duration_s=" + std::to_string(static_cast<int>(kStop_s));
    ASSERT_EQ(ehpt({"fmu", "psecu2_nedc", "--bus", "ls-bus", "--set", d, "--out", *dir_ + "/plant.fmu"}), 0);
    ASSERT_EQ(ehpt({"fmu", "psecu2_nedc", "--bus", "ls-bus", "--role", "ecu", "--set", d, "--out", *dir_ + "/ecu.fmu"}), 0);
    // the lockstep bus session's run: the built-in ECU with its signals through the CAN codec
    ASSERT_EQ(ehpt({"run", "psecu2_nedc", "--quiet", "--out", *dir_ + "/ref", "--set", "output.interval_s=0.001", "--set", d,
                    "--set", "vehicle.ecu.codec=can"}),
              0);
    ref_ = new std::map<std::string, std::vector<double>>(columns(*dir_ + "/ref/timeseries.csv"));
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    fs::remove_all(*dir_, ec);  // the folder this suite made
    delete dir_;
    delete ref_;
  }
  static std::string* dir_;
  static std::map<std::string, std::vector<double>>* ref_;
};
std::string* LsBus::dir_ = nullptr;
std::map<std::string, std::vector<double>>* LsBus::ref_ = nullptr;

// Every output at every communication point against the reference row of that step; the
// number of points that differ (0: bit for bit).
int mismatches(const Fmi3Fmu& fmu, const std::vector<std::vector<double>>& rows, std::map<std::string, std::vector<double>>& ref,
               std::int64_t k, std::string& first) {
  int bad = 0;
  for (std::size_t r = 0; r < rows.size(); ++r) {
    const std::size_t step = (r + 1) * static_cast<std::size_t>(k);
    if (step >= ref["time_s"].size() || !same_bits(rows[r][0], ref["time_s"][step])) {
      if (bad++ == 0) first = "time of row " + std::to_string(r);
      continue;
    }
    for (std::size_t j = 0; j < fmu.output_names.size(); ++j) {
      const std::vector<double>& col = ref[fmu.output_names[j]];
      if (col.empty() || !same_bits(rows[r][j + 1], col[step])) {
        if (bad++ == 0) {
          std::ostringstream m;
          m.precision(17);
          m << fmu.output_names[j] << " at t = " << rows[r][0] << ": " << rows[r][j + 1] << " vs "
            << (col.empty() ? NAN : col[step]);
          first = m.str();
        }
        break;
      }
    }
  }
  return bad;
}

TEST_F(LsBus, PlantAndEcuFmusConnectedTxToRxAreTheLockstepBusSessionBitForBit) {
  for (const std::int64_t k : {1, 10}) {  // every plant step, and one ECU period (10 ms)
    Fmi3Fmu plant, ecu;
    std::string error;
    ASSERT_TRUE(plant.open(*dir_ + "/plant.fmu", error)) << error;
    ASSERT_TRUE(ecu.open(*dir_ + "/ecu.fmu", error)) << error;
    EXPECT_TRUE(plant.has_event_mode);
    ASSERT_EQ(plant.bus_vr.size(), 4u);
    fmi3Instance p = plant.make_instance("plant", nullptr, true), e = ecu.make_instance("ecu", nullptr, true);
    ASSERT_TRUE(p && e) << (plant.log.empty() ? "" : plant.log.back()) << (ecu.log.empty() ? "" : ecu.log.back());
    std::vector<std::vector<double>> rows;
    BusRun run;
    ASSERT_TRUE(run_bus_pair(plant, p, &ecu, e, k, kStop_s, rows, run, error)) << error;
    ASSERT_EQ(rows.size(), static_cast<std::size_t>(20000 / k));
    std::string first;
    EXPECT_EQ(mismatches(plant, rows, *ref_, k, first), 0) << "k = " << k << ": first difference " << first;
    // every sample went both ways: 2001 samples (0 .. 20 s), each a plant Tx and an ECU Tx
    EXPECT_EQ(run.events, 2001) << "k = " << k;
    EXPECT_EQ(run.transfers, 2 * 2001) << "k = " << k;
    EXPECT_EQ(run.terminate_status, fmi3OK) << (plant.log.empty() ? "" : plant.log.back());
    plant.free_instance(p);
    ecu.free_instance(e);
  }
  EXPECT_GT(ref_->at("speed_m_s").back(), 3.0);  // the car moved: not a run of zeros
}

// A bus simulation between them that takes one ECU period to carry the ECU's frames: the plant
// applies each command when it comes (the latest fresh one), one period late, and drives on,
// close to the direct run but not equal to it; one that takes 4 periods (past the 3-period
// timeout) leaves it in its safe state, and terminate says so (Warning).
TEST_F(LsBus, ABusThatDelaysTheCommandsDelaysThemAndOnePastTheTimeoutIsSaid) {
  const auto run_with_delay = [&](int delay, std::vector<std::vector<double>>& rows, BusRun& run, Fmi3Fmu& plant) {
    Fmi3Fmu ecu;
    std::string error;
    ASSERT_TRUE(plant.open(*dir_ + "/plant.fmu", error)) << error;
    ASSERT_TRUE(ecu.open(*dir_ + "/ecu.fmu", error)) << error;
    fmi3Instance p = plant.make_instance("plant", nullptr, true), e = ecu.make_instance("ecu", nullptr, true);
    ASSERT_TRUE(run_bus_pair(plant, p, &ecu, e, 10, kStop_s, rows, run, error, delay)) << error;
    plant.free_instance(p);
    ecu.free_instance(e);
  };
  std::vector<std::vector<double>> rows;
  BusRun run;
  Fmi3Fmu plant;
  run_with_delay(1, rows, run, plant);
  ASSERT_EQ(rows.size(), 2000u);
  const std::size_t speed = static_cast<std::size_t>(
      std::find(plant.output_names.begin(), plant.output_names.end(), "speed_m_s") - plant.output_names.begin()) + 1;
  const double want = ref_->at("speed_m_s")[20000];
  EXPECT_GT(want, 3.0);
  EXPECT_NEAR(rows.back()[speed], want, 0.05) << "one period late, the car still follows";
  std::string first;
  EXPECT_GT(mismatches(plant, rows, *ref_, 10, first), 0) << "but not the direct run's";
  EXPECT_EQ(run.terminate_status, fmi3OK) << (plant.log.empty() ? "" : plant.log.back());

  std::vector<std::vector<double>> late_rows;
  BusRun late;
  Fmi3Fmu late_plant;
  run_with_delay(4, late_rows, late, late_plant);
  EXPECT_EQ(late.terminate_status, fmi3Warning);
  bool said = false;
  for (const std::string& l : late_plant.log) said = said || l.find("timed out") != std::string::npos;
  EXPECT_TRUE(said) << "the timeouts are in the log";
  EXPECT_LT(late_rows.back()[speed], 0.5 * want) << "the safe state: the car does not follow";
}

// Sample 0's Tx_Data: a CAN Transmit operation for each sensor frame of ehpt's DBC, nothing else.
TEST_F(LsBus, ThePlantSendsTheContractsSensorFramesAsCanTransmitOperations) {
  Fmi3Fmu plant, ecu;
  std::string error;
  ASSERT_TRUE(plant.open(*dir_ + "/plant.fmu", error)) << error;
  ASSERT_TRUE(ecu.open(*dir_ + "/ecu.fmu", error)) << error;
  fmi3Instance p = plant.make_instance("plant", nullptr, true), e = ecu.make_instance("ecu", nullptr, true);
  std::vector<std::vector<double>> rows;
  BusRun run;
  ASSERT_TRUE(run_bus_pair(plant, p, &ecu, e, 10, 0.05, rows, run, error)) << error;
  std::vector<io::can::Frame> frames;
  const io::can::ls_bus::RxCounts c = io::can::ls_bus::parse(
      std::span<const std::uint8_t>(run.first_plant_tx), [&](const io::can::Frame& f) { frames.push_back(f); },
      [](std::span<const std::uint8_t>) {});
  EXPECT_EQ(c.malformed, 0);
  EXPECT_EQ(c.status + c.bus_errors + c.ignored, 0);
  // the DBC in the FMU names them: the plant's messages (sender Plant), one frame each
  std::ifstream dbc_in(plant.dir + "/extra/org.fmi-standard.fmi-ls-bus/ehpt.dbc");
  std::stringstream dbc_text;
  dbc_text << dbc_in.rdbuf();
  ASSERT_FALSE(dbc_text.str().empty()) << "the FMU carries the contract's DBC";
  std::set<std::uint32_t> sent;
  for (const io::can::Frame& f : frames) sent.insert(f.id);
  EXPECT_EQ(sent.size(), frames.size()) << "one frame per message";
  std::set<std::uint32_t> plant_ids;
  std::istringstream lines(dbc_text.str());
  for (std::string l; std::getline(lines, l);) {
    unsigned id = 0;
    char name[128], sender[128];
    if (std::sscanf(l.c_str(), "BO_ %u %127[^:]: %*d %127s", &id, name, sender) == 3 && std::string(sender) == "Plant" &&
        std::string(name).rfind("Ev", 0) != 0 && std::string(name).rfind("Shev", 0) != 0) {
      // the power-split hybrid's: PlantStatus and PsdSensors1..6
      plant_ids.insert(id);
    }
  }
  EXPECT_FALSE(plant_ids.empty());
  EXPECT_EQ(sent, plant_ids);
  plant.free_instance(p);
  ecu.free_instance(e);
}

// No ECU on the bus: the plant's commands time out, it holds its safe state, and fmi3Terminate
// says the session is not what was asked (fmi3Warning, the reason logged) instead of OK.
TEST_F(LsBus, ThePlantAloneOnItsBusGoesSafeAndTerminateIsAWarningNotOk) {
  Fmi3Fmu plant;
  std::string error;
  ASSERT_TRUE(plant.open(*dir_ + "/plant.fmu", error)) << error;
  fmi3Instance p = plant.make_instance("alone", nullptr, true);
  std::vector<std::vector<double>> rows;
  BusRun run;
  ASSERT_TRUE(run_bus_pair(plant, p, nullptr, nullptr, 10, kStop_s, rows, run, error)) << error;
  EXPECT_EQ(run.terminate_status, fmi3Warning);
  bool said = false;
  for (const std::string& l : plant.log) said = said || l.find("no ECU") != std::string::npos;
  EXPECT_TRUE(said) << "the log says there was no ECU";
  // the safe state: the torque references stay zero while nothing comes, so the car stands
  // while the cycle wants it at speed (NEDC accelerates from 11 s)
  const auto column = [&](const char* name) {
    const auto it = std::find(plant.output_names.begin(), plant.output_names.end(), name);
    EXPECT_NE(it, plant.output_names.end()) << name;
    return static_cast<std::size_t>(it - plant.output_names.begin()) + 1;
  };
  for (const char* name : {"motTauRef_Nm", "genTauRef_Nm", "speed_m_s"}) {
    const std::size_t j = column(name);
    for (const auto& row : rows) ASSERT_EQ(row[j], 0.0) << name << " at t = " << row[0];
  }
  EXPECT_GT(rows.back()[column("speed_ref_m_s")], 3.0);
  plant.free_instance(p);
}

// The bus's run phase allocates nothing: doStep, the clocks, Tx_Data out and Rx_Data in, the
// updates that apply a command and answer a sample, the outputs (the allocation guard counts
// both FMU libraries' malloc and operator new: they are this executable's).
TEST_F(LsBus, TheBusRunPhaseAllocatesNothing) {
  Fmi3Fmu plant, ecu;
  std::string error;
  ASSERT_TRUE(plant.open(*dir_ + "/plant.fmu", error)) << error;
  ASSERT_TRUE(ecu.open(*dir_ + "/ecu.fmu", error)) << error;
  fmi3Instance p = plant.make_instance("plant", nullptr, true), e = ecu.make_instance("ecu", nullptr, true);
  ASSERT_TRUE(p && e);
  Fmi3Fmu* fmus[2] = {&plant, &ecu};
  fmi3Instance insts[2] = {p, e};
  for (int i = 0; i < 2; ++i) {
    ASSERT_EQ(fmus[i]->enter_initialization(insts[i], fmi3False, 0.0, 0.0, fmi3True, kStop_s), fmi3OK);
    ASSERT_EQ(fmus[i]->exit_initialization(insts[i]), fmi3OK);
  }
  fmi3ValueReference tx_clock[2], tx_data[2], rx_clock[2], rx_data[2];
  for (int i = 0; i < 2; ++i) {
    tx_clock[i] = fmus[i]->bus_vr.at("CAN.Tx_Clock");
    tx_data[i] = fmus[i]->bus_vr.at("CAN.Tx_Data");
    rx_clock[i] = fmus[i]->bus_vr.at("CAN.Rx_Clock");
    rx_data[i] = fmus[i]->bus_vr.at("CAN.Rx_Data");
  }
  std::vector<fmi3ValueReference> refs;
  for (const std::string& n : plant.output_names) refs.push_back(plant.vr.at(n));
  std::vector<double> y(refs.size());
  int failed = 0, moved = 0;
  // one Event Mode: plant -> ECU, update both, ECU -> plant, update both
  const auto event_mode = [&] {
    for (const int from : {0, 1}) {
      fmi3Clock ticked = fmi3ClockInactive;
      if (fmus[from]->get_clock(insts[from], &tx_clock[from], 1, &ticked) != fmi3OK) ++failed;
      if (ticked == fmi3ClockActive) {
        size_t size = 0;
        fmi3Binary data = nullptr;
        const int to = 1 - from;
        const fmi3Clock active = fmi3ClockActive;
        if (fmus[from]->get_binary(insts[from], &tx_data[from], 1, &size, &data, 1) != fmi3OK ||
            fmus[to]->set_clock(insts[to], &rx_clock[to], 1, &active) != fmi3OK ||
            fmus[to]->set_binary(insts[to], &rx_data[to], 1, &size, &data, 1) != fmi3OK) {
          ++failed;
        }
        ++moved;
      }
      for (int i = 0; i < 2; ++i) {
        fmi3Boolean a, b, c, d, f;
        fmi3Float64 t;
        if (fmus[i]->update_discrete_states(insts[i], &a, &b, &c, &d, &f, &t) != fmi3OK) ++failed;
      }
    }
  };
  event_mode();  // sample 0, before the guard (a first call may size what it keeps)
  for (int i = 0; i < 2; ++i) ASSERT_EQ(fmus[i]->enter_step_mode(insts[i]), fmi3OK);
  ASSERT_EQ(moved, 2);
  moved = 0;
  hil::alloc_guard::reset();
  hil::alloc_guard::arm();
  for (std::int64_t n = 0; n < 1900; ++n) {  // 19 s of 10 ms samples
    for (int i = 0; i < 2; ++i) {
      fmi3Boolean ev, term, early;
      fmi3Float64 last;
      if (fmus[i]->do_step(insts[i], static_cast<double>(n) * 0.01, 0.01, fmi3True, &ev, &term, &early, &last) != fmi3OK) {
        ++failed;
      }
      if (fmus[i]->enter_event_mode(insts[i]) != fmi3OK) ++failed;
    }
    event_mode();
    for (int i = 0; i < 2; ++i) {
      if (fmus[i]->enter_step_mode(insts[i]) != fmi3OK) ++failed;
    }
    if (plant.get_float64(p, refs.data(), refs.size(), y.data(), y.size()) != fmi3OK) ++failed;
  }
  hil::alloc_guard::disarm();
  EXPECT_EQ(failed, 0) << (plant.log.empty() ? "" : plant.log.back());
  EXPECT_EQ(moved, 2 * 1900) << "every sample crossed both ways";
  ASSERT_TRUE(hil::alloc_guard::active()) << "the hooks are not in this executable";
  EXPECT_EQ(hil::alloc_guard::count(), 0u) << hil::alloc_guard::describe_first();
  plant.free_instance(p);
  ecu.free_instance(e);
}

// Faults on frames act in the LS-BUS plant as on any bus: the ECU's PsdCommand1 lost for 50 ms
// while the car accelerates (examples/tests/command_frames_dropped.toml's fault) gives `ehpt run
// --fault` (the in-process bus, which is the socketcand session: bus_faults_e2e) bit for bit,
// safe state included; error_frames puts one Bus Error operation on the bus per ECU sample,
// bus_off a Status bus-off where it starts and error-active where it ends.
TEST_F(LsBus, BusFaultsActOnTheFramesAndErrorFramesAreBusErrorAndStatusOperations) {
  const std::string d = "solver.duration_s=" + std::to_string(static_cast<int>(kStop_s));
  const std::string drop = "kind=drop target=PsdCommand1 at_s=12 until_s=12.05";
  ASSERT_EQ(ehpt({"fmu", "psecu2_nedc", "--bus", "ls-bus", "--set", d, "--fault", drop, "--out", *dir_ + "/drop.fmu"}), 0);
  ASSERT_EQ(ehpt({"run", "psecu2_nedc", "--quiet", "--out", *dir_ + "/refdrop", "--set", "output.interval_s=0.001", "--set", d,
                  "--fault", drop}),
            0);
  std::map<std::string, std::vector<double>> ref = columns(*dir_ + "/refdrop/timeseries.csv");
  Fmi3Fmu plant, ecu;
  std::string error;
  ASSERT_TRUE(plant.open(*dir_ + "/drop.fmu", error)) << error;
  ASSERT_TRUE(ecu.open(*dir_ + "/ecu.fmu", error)) << error;
  fmi3Instance p = plant.make_instance("plant", nullptr, true), e = ecu.make_instance("ecu", nullptr, true);
  std::vector<std::vector<double>> rows;
  BusRun run;
  ASSERT_TRUE(run_bus_pair(plant, p, &ecu, e, 10, kStop_s, rows, run, error)) << error;
  std::string first;
  EXPECT_EQ(mismatches(plant, rows, ref, 10, first), 0) << "first difference " << first;
  // the safe state came: the motor's torque request 0 at 12.03 s, not 0 just before the fault
  const std::size_t tau = static_cast<std::size_t>(
      std::find(plant.output_names.begin(), plant.output_names.end(), "motTauRef_Nm") - plant.output_names.begin()) + 1;
  EXPECT_GT(rows[1198][tau], 1.0) << "t = " << rows[1198][0];  // 11.99 s
  EXPECT_EQ(rows[1202][tau], 0.0) << "t = " << rows[1202][0];  // 12.03 s
  plant.free_instance(p);
  ecu.free_instance(e);

  // error frames and bus-off: LS-BUS operations from the plant's terminal
  ASSERT_EQ(ehpt({"fmu", "psecu2_nedc", "--bus", "ls-bus", "--set", "solver.duration_s=2", "--fault",
                  "kind=error_frames at_s=0.5 until_s=0.55", "--fault", "kind=bus_off at_s=1 until_s=1.2", "--out",
                  *dir_ + "/errors.fmu"}),
            0);
  ASSERT_TRUE(plant.open(*dir_ + "/errors.fmu", error)) << error;
  Fmi3Fmu ecu2;
  ASSERT_TRUE(ecu2.open(*dir_ + "/ecu.fmu", error)) << error;
  p = plant.make_instance("plant", nullptr, true);
  e = ecu2.make_instance("ecu", nullptr, true);
  BusRun faulted;
  ASSERT_TRUE(run_bus_pair(plant, p, &ecu2, e, 10, 2.0, rows, faulted, error)) << error;
  EXPECT_EQ(faulted.plant_ops[io::can::ls_bus::kOpBusError], 5) << "one per ECU sample of 0.5 .. 0.55 s";
  EXPECT_EQ(faulted.plant_status, (std::vector<std::uint8_t>{io::can::ls_bus::kBusOff, io::can::ls_bus::kErrorActive}));
  EXPECT_EQ(run.plant_ops.count(io::can::ls_bus::kOpBusError), 0u) << "none without the fault";
  // bus-off loses every frame for 0.2 s: the plant's commands time out (a warning at terminate)
  EXPECT_EQ(faulted.terminate_status, fmi3OK) << "timeouts under bus faults are what the faults were for";
  plant.free_instance(p);
  ecu2.free_instance(e);

  // where frames have no bus: refused when the FMU is made, with what to do
  EXPECT_EQ(ehpt({"fmu", "psecu2_nedc", "--fault", drop, "--out", *dir_ + "/nobus.fmu"}), 2);
  EXPECT_FALSE(fs::exists(*dir_ + "/nobus.fmu"));
  EXPECT_EQ(ehpt({"fmu", "psecu2_nedc", "--bus", "ls-bus", "--role", "ecu", "--fault", drop, "--out", *dir_ + "/ecuf.fmu"}), 2);
  EXPECT_EQ(ehpt({"fmu", "psecu2_nedc", "--bus", "ls-bus", "--fault", "kind=drop target=NoSuchFrame at_s=1", "--out",
                  *dir_ + "/badf.fmu"}),
            2);
  EXPECT_FALSE(fs::exists(*dir_ + "/badf.fmu"));
}

// At a sample point the outputs after the Event Mode are those of that point, also when no
// command came (the plant alone): the cycle's wanted speed, which no ECU changes, is `ehpt
// run`'s at every point (outputs left from the step before would be 1 ms behind once NEDC
// moves, from 11 s).
TEST_F(LsBus, OutputsAtASamplePointAreThatPointsEvenWithoutACommand) {
  Fmi3Fmu plant;
  std::string error;
  ASSERT_TRUE(plant.open(*dir_ + "/plant.fmu", error)) << error;
  std::vector<std::vector<double>> rows;
  BusRun run;
  fmi3Instance a = plant.make_instance("a", nullptr, true);
  ASSERT_TRUE(run_bus_pair(plant, a, nullptr, nullptr, 10, 12.0, rows, run, error)) << error;
  plant.free_instance(a);
  ASSERT_EQ(rows.size(), 1200u);
  const std::size_t j = static_cast<std::size_t>(
      std::find(plant.output_names.begin(), plant.output_names.end(), "speed_ref_m_s") - plant.output_names.begin()) + 1;
  ASSERT_LT(j, rows.front().size());
  int differ = 0;
  for (std::size_t r = 0; r < rows.size(); ++r) differ += same_bits(rows[r][j], ref_->at("speed_ref_m_s")[(r + 1) * 10]) ? 0 : 1;
  EXPECT_EQ(differ, 0);
  EXPECT_GT(rows.back()[j], 0.5) << "NEDC moves by 12 s";
}

// The ECU FMU with no plant on its bus answers nothing, and its fmi3Terminate says so (Warning).
TEST_F(LsBus, TheEcuAloneOnItsBusTerminatesWithAWarningNotOk) {
  Fmi3Fmu ecu;
  std::string error;
  ASSERT_TRUE(ecu.open(*dir_ + "/ecu.fmu", error)) << error;
  fmi3Instance e = ecu.make_instance("alone", nullptr, true);
  std::vector<std::vector<double>> rows;
  BusRun run;
  ASSERT_TRUE(run_bus_pair(ecu, e, nullptr, nullptr, 10, 1.0, rows, run, error)) << error;
  EXPECT_EQ(run.terminate_status, fmi3Warning);
  bool said = false;
  for (const std::string& l : ecu.log) said = said || l.find("no plant") != std::string::npos;
  EXPECT_TRUE(said);
  ecu.free_instance(e);
}

TEST_F(LsBus, WrongUseIsAnErrorWithAMessage) {
  Fmi3Fmu plant;
  std::string error;
  ASSERT_TRUE(plant.open(*dir_ + "/plant.fmu", error)) << error;
  const auto said = [&](const char* what) {
    for (const std::string& l : plant.log) {
      if (l.find(what) != std::string::npos) return true;
    }
    return false;
  };
  // without Event Mode the terminal cannot work: refused at instantiation
  EXPECT_EQ(plant.make_instance("no-events"), nullptr);
  EXPECT_TRUE(said("eventModeUsed = false"));

  fmi3Instance p = plant.make_instance("p", nullptr, true);
  ASSERT_NE(p, nullptr);
  ASSERT_EQ(plant.enter_initialization(p, fmi3False, 0.0, 0.0, fmi3True, kStop_s), fmi3OK);
  ASSERT_EQ(plant.exit_initialization(p), fmi3OK);
  // Event Mode follows initialization: doStep is out of order there
  fmi3Boolean event = fmi3False, terminate = fmi3False, early = fmi3False;
  fmi3Float64 last = 0.0;
  EXPECT_EQ(plant.do_step(p, 0.0, 0.001, fmi3True, &event, &terminate, &early, &last), fmi3Error);
  EXPECT_TRUE(said("in Event Mode"));
  plant.free_instance(p);

  p = plant.make_instance("p2", nullptr, true);
  ASSERT_EQ(plant.enter_initialization(p, fmi3False, 0.0, 0.0, fmi3True, kStop_s), fmi3OK);
  ASSERT_EQ(plant.exit_initialization(p), fmi3OK);
  const fmi3ValueReference rx = plant.bus_vr.at("CAN.Rx_Data"), tx = plant.bus_vr.at("CAN.Tx_Data");
  const fmi3ValueReference tx_clock = plant.bus_vr.at("CAN.Tx_Clock");
  // Tx_Clock reports a tick once; Tx_Data keeps its value for every read until the next tick
  fmi3Clock ticked = fmi3ClockInactive;
  ASSERT_EQ(plant.get_clock(p, &tx_clock, 1, &ticked), fmi3OK);
  EXPECT_EQ(ticked, fmi3ClockActive) << "sample 0";
  ASSERT_EQ(plant.get_clock(p, &tx_clock, 1, &ticked), fmi3OK);
  EXPECT_EQ(ticked, fmi3ClockInactive) << "once per tick";
  size_t size = 0, size2 = 0;
  fmi3Binary data = nullptr, data2 = nullptr;
  ASSERT_EQ(plant.get_binary(p, &tx, 1, &size, &data, 1), fmi3OK);
  const std::vector<std::uint8_t> sample0(data, data + size);
  ASSERT_EQ(plant.get_binary(p, &tx, 1, &size2, &data2, 1), fmi3OK);
  EXPECT_EQ(std::vector<std::uint8_t>(data2, data2 + size2), sample0) << "a second read (another connection) gets the same";
  EXPECT_EQ(size, 7u * (16 + 8)) << "PlantStatus and PsdSensors1..6";
  // Rx_Data that is not LS-BUS: a warning, and a Format Error operation back in Tx_Data, with
  // Tx_Clock ticking and discreteStatesNeedUpdate asking the importer to hand it on
  const std::uint8_t junk[] = {0xDE, 0xAD};
  const fmi3Binary junk_ptr = junk;
  const size_t junk_size = sizeof junk;
  const fmi3ValueReference rx_clock = plant.bus_vr.at("CAN.Rx_Clock");
  const fmi3Clock active = fmi3ClockActive;
  EXPECT_EQ(plant.set_clock(p, &rx_clock, 1, &active), fmi3OK);
  EXPECT_EQ(plant.set_binary(p, &rx, 1, &junk_size, &junk_ptr, 1), fmi3OK);
  EXPECT_TRUE(said("not FMI-LS-BUS CAN"));
  fmi3Boolean need = fmi3False, t1, t2, t3, t4;
  fmi3Float64 next = 0.0;
  ASSERT_EQ(plant.update_discrete_states(p, &need, &t1, &t2, &t3, &t4, &next), fmi3OK);
  EXPECT_EQ(need, fmi3True);
  ASSERT_EQ(plant.get_clock(p, &tx_clock, 1, &ticked), fmi3OK);
  EXPECT_EQ(ticked, fmi3ClockActive);
  ASSERT_EQ(plant.get_binary(p, &tx, 1, &size, &data, 1), fmi3OK);
  bool format_error = false;
  for (std::size_t at = 0; at + 8 <= size;) {
    const std::uint32_t op = io::can::ls_bus::read_u32(data + at), len = io::can::ls_bus::read_u32(data + at + 4);
    format_error = format_error || op == io::can::ls_bus::kOpFormatError;
    if (len < 8) break;
    at += len;
  }
  EXPECT_TRUE(format_error);
  // a Binary is not a Float64; Tx_Data is not to be set; an oversized Rx_Data is refused
  double x = 0.0;
  EXPECT_EQ(plant.get_float64(p, &tx, 1, &x, 1), fmi3Error);
  EXPECT_TRUE(said("is a Binary variable"));
  plant.free_instance(p);

  p = plant.make_instance("p3", nullptr, true);
  ASSERT_EQ(plant.enter_initialization(p, fmi3False, 0.0, 0.0, fmi3True, kStop_s), fmi3OK);
  ASSERT_EQ(plant.exit_initialization(p), fmi3OK);
  std::vector<std::uint8_t> big(5000);
  const fmi3Binary big_ptr = big.data();
  const size_t big_size = big.size();
  EXPECT_EQ(plant.set_binary(p, &rx, 1, &big_size, &big_ptr, 1), fmi3Error);
  EXPECT_TRUE(said("maxSize 4096"));
  plant.free_instance(p);

  // a doStep past an ECU sample: the sample's frames could not go out
  p = plant.make_instance("p4", nullptr, true);
  ASSERT_EQ(plant.enter_initialization(p, fmi3False, 0.0, 0.0, fmi3True, kStop_s), fmi3OK);
  ASSERT_EQ(plant.exit_initialization(p), fmi3OK);
  ASSERT_EQ(plant.enter_step_mode(p), fmi3OK);
  EXPECT_EQ(plant.do_step(p, 0.0, 0.02, fmi3True, &event, &terminate, &early, &last), fmi3Error);
  EXPECT_TRUE(said("passes the ECU sample at 0.01 s"));
  plant.free_instance(p);

  // the CAN network parameter: a structural parameter, set before initialization, not after
  p = plant.make_instance("p6", nullptr, true);
  const fmi3ValueReference notify = plant.boolean_vr.at("org.fmi_standard.fmi_ls_bus.Can_BusNotifications");
  const fmi3Boolean yes = fmi3True;
  EXPECT_EQ(plant.set_boolean(p, &notify, 1, &yes, 1), fmi3OK);
  fmi3Boolean got = fmi3False;
  EXPECT_EQ(plant.get_boolean(p, &notify, 1, &got, 1), fmi3OK);
  EXPECT_EQ(got, fmi3True);
  ASSERT_EQ(plant.enter_initialization(p, fmi3False, 0.0, 0.0, fmi3True, kStop_s), fmi3OK);
  EXPECT_EQ(plant.set_boolean(p, &notify, 1, &yes, 1), fmi3Error);
  EXPECT_TRUE(said("is a structural parameter: set it before fmi3EnterInitializationMode"));
  plant.free_instance(p);

  // a saved state would not hold the bus session: refused, said
  p = plant.make_instance("p5", nullptr, true);
  ASSERT_EQ(plant.enter_initialization(p, fmi3False, 0.0, 0.0, fmi3True, kStop_s), fmi3OK);
  ASSERT_EQ(plant.exit_initialization(p), fmi3OK);
  fmi3FMUState state = nullptr;
  EXPECT_EQ(plant.get_state(p, &state), fmi3Error);
  EXPECT_TRUE(said("canGetAndSetFMUState = false"));
  plant.free_instance(p);
}

}  // namespace
}  // namespace ehpt::test
