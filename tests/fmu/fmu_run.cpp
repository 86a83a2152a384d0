// SPDX-License-Identifier: BSD-3-Clause
// The project's FMI 3.0 and 2.0 importer as a program: runs an FMU from 0 to STOP_S in communication
// steps of K plant steps and prints a CSV as `ehpt run` writes timeseries.csv (time_s, then the
// outputs in modelDescription order, shortest round-trip numbers), one row per step end.
//   fmu_run FILE.fmu K STOP_S [ECU.fmu]
// An FMU with a CAN terminal (ehpt fmu --bus ls-bus) runs in Event Mode, connected directly to
// ECU.fmu's terminal if given (Tx_Data to Rx_Data both ways), alone on its bus if not.
// Exit 0, or 1 with the FMU's log on stderr. Used where nothing of ehpt may be reachable
// (tests/fmu/fmu_e2e_test.py: a mount namespace that hides the source and build trees).
#include <charconv>
#include <cstdio>
#include <iostream>

#include "fmi_importer.hpp"

int main(int argc, char** argv) {
  if (argc != 4 && argc != 5) {
    std::cerr << "usage: fmu_run FILE.fmu K STOP_S [ECU.fmu]\n";
    return 2;
  }
  ehpt::test::Fmi3Fmu fmu;
  std::string error;
  if (!fmu.open(argv[1], error)) {
    std::cerr << "fmu_run: " << error << "\n";
    return 1;
  }
  std::vector<std::vector<double>> rows;
  void* inst = fmu.version == 3 ? fmu.make_instance("fmu_run", nullptr, fmu.has_event_mode) : fmu.make_instance2("fmu_run");
  const std::int64_t k = std::atoll(argv[2]);
  const double stop_s = std::strtod(argv[3], nullptr);
  ehpt::test::Fmi3Fmu ecu;
  fmi3Instance ecu_inst = nullptr;
  if (argc == 5 && (!ecu.open(argv[4], error) || (ecu_inst = ecu.make_instance("fmu_run_ecu", nullptr, true)) == nullptr)) {
    std::cerr << "fmu_run: " << argv[4] << ": " << (error.empty() ? "instantiation failed" : error) << "\n";
    for (const std::string& l : ecu.log) std::cerr << l << "\n";
    return 1;
  }
  ehpt::test::BusRun bus;
  bool done = false;
  if (inst != nullptr) {
    done = fmu.version == 2       ? ehpt::test::run_fmu2(fmu, inst, k, stop_s, rows, error)
           : fmu.has_event_mode ? ehpt::test::run_bus_pair(fmu, inst, ecu_inst ? &ecu : nullptr, ecu_inst, k, stop_s, rows, bus, error)
                                : ehpt::test::run_fmu(fmu, inst, k, stop_s, rows, error);
  }
  if (!done) {
    std::cerr << "fmu_run: " << (inst == nullptr ? "instantiation failed" : error) << "\n";
    for (const std::string& l : fmu.log) std::cerr << l << "\n";
    return 1;
  }
  if (fmu.has_event_mode) {  // the bus's figures, and the plant's warnings (a degraded session)
    std::cerr << "fmu_run: bus: " << bus.events << " event modes, " << bus.transfers << " transfers, " << bus.bytes
              << " bytes; fmi3Terminate " << (bus.terminate_status == fmi3OK ? "OK" : "Warning") << "\n";
    for (const std::string& l : fmu.log) {
      if (l.rfind("1 ", 0) == 0) std::cerr << l << "\n";
    }
  }
  std::string out = "time_s";
  for (const std::string& n : fmu.output_names) out += "," + n;
  out += "\n";
  char buf[40];
  for (const auto& row : rows) {
    for (std::size_t i = 0; i < row.size(); ++i) {
      const auto r = std::to_chars(buf, buf + sizeof buf, row[i]);
      if (i > 0) out += ',';
      out.append(buf, r.ptr);
    }
    out += "\n";
  }
  std::fwrite(out.data(), 1, out.size(), stdout);
  if (ecu_inst != nullptr) ecu.free_instance(ecu_inst);
  if (fmu.version == 3) {
    fmu.free_instance(inst);
  } else {
    fmu.free_instance2(inst);
  }
  return 0;
}
