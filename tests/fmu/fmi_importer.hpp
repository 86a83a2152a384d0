// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The project's FMI 3.0 and 2.0 co-simulation importer, written from the standards for the tests
// (no FMI library exists in Debian): unpack an FMU (io/zip) into a folder of its own, read the
// modelDescription.xml attributes an importer needs, dlopen binaries/x86_64-linux/<id>.so and
// look up the functions, then drive the calling sequence (FMI 3.0 §4.2; FMI 2.0 §4.2.4):
// instantiate, (2.0: setup experiment), enter and exit initialization, doStep, get,
// terminate, free. Messages the FMU logs are kept.

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#define EHPT_FMI2_NO_PROTOTYPES  // the importer looks the functions up (dlsym)
#define EHPT_FMI3_NO_PROTOTYPES
#include "io/fmi/fmi2_api.h"
#include "io/fmi/fmi3_api.h"

namespace ehpt::test {

class Fmi3Fmu {
 public:
  ~Fmi3Fmu();
  // Unpacks fmu_path into a new temporary folder (removed again by the destructor) and loads
  // its library; false and why if any of it fails.
  bool open(const std::string& fmu_path, std::string& error);

  std::string dir;                         // where it is unpacked
  int version = 0;                         // 3 or 2 (fmiVersion)
  std::string token, model_identifier;     // token: instantiationToken (3.0) or guid (2.0)
  double step_s = 0.0, stop_s = 0.0;       // fixedInternalStepSize, DefaultExperiment stopTime
  std::string xml;                         // modelDescription.xml
  std::map<std::string, fmi3ValueReference> vr;  // Float64 variables by name
  std::map<std::string, fmi3ValueReference> boolean_vr;  // Boolean variables by name
  std::vector<std::string> output_names;   // causality = "output", in document order

  // every message the FMU logged through the callback: "STATUS CATEGORY: MESSAGE"
  std::vector<std::string> log;

  fmi3InstantiateCoSimulationTYPE* instantiate = nullptr;
  fmi3FreeInstanceTYPE* free_instance = nullptr;
  fmi3EnterInitializationModeTYPE* enter_initialization = nullptr;
  fmi3ExitInitializationModeTYPE* exit_initialization = nullptr;
  fmi3DoStepTYPE* do_step = nullptr;
  fmi3GetFloat64TYPE* get_float64 = nullptr;
  fmi3SetFloat64TYPE* set_float64 = nullptr;
  fmi3GetBooleanTYPE* get_boolean = nullptr;
  fmi3SetBooleanTYPE* set_boolean = nullptr;
  fmi3TerminateTYPE* terminate = nullptr;
  fmi3ResetTYPE* reset = nullptr;
  fmi3GetVersionTYPE* get_version = nullptr;
  fmi3GetFMUStateTYPE* get_state = nullptr;
  fmi3SetFMUStateTYPE* set_state = nullptr;
  fmi3FreeFMUStateTYPE* free_state = nullptr;
  fmi3SerializedFMUStateSizeTYPE* serialized_size = nullptr;
  fmi3SerializeFMUStateTYPE* serialize = nullptr;
  fmi3DeserializeFMUStateTYPE* deserialize = nullptr;
  // Event Mode and the bus terminal (FMI-LS-BUS): an FMU with hasEventMode = "true"
  fmi3EnterEventModeTYPE* enter_event_mode = nullptr;
  fmi3UpdateDiscreteStatesTYPE* update_discrete_states = nullptr;
  fmi3EnterStepModeTYPE* enter_step_mode = nullptr;
  fmi3GetClockTYPE* get_clock = nullptr;
  fmi3SetClockTYPE* set_clock = nullptr;
  fmi3GetBinaryTYPE* get_binary = nullptr;
  fmi3SetBinaryTYPE* set_binary = nullptr;
  bool has_event_mode = false;                   // CoSimulation hasEventMode
  std::map<std::string, fmi3ValueReference> bus_vr;  // Binary and Clock variables by name (CAN.Tx_Data, ...)

  // FMI 2.0
  fmi2InstantiateTYPE* instantiate2 = nullptr;
  fmi2FreeInstanceTYPE* free_instance2 = nullptr;
  fmi2SetupExperimentTYPE* setup_experiment2 = nullptr;
  fmi2EnterInitializationModeTYPE* enter_initialization2 = nullptr;
  fmi2ExitInitializationModeTYPE* exit_initialization2 = nullptr;
  fmi2DoStepTYPE* do_step2 = nullptr;
  fmi2GetRealTYPE* get_real2 = nullptr;
  fmi2SetRealTYPE* set_real2 = nullptr;
  fmi2GetBooleanTYPE* get_boolean2 = nullptr;
  fmi2SetBooleanTYPE* set_boolean2 = nullptr;
  fmi2TerminateTYPE* terminate2 = nullptr;
  fmi2GetBooleanStatusTYPE* get_boolean_status2 = nullptr;
  fmi2GetVersionTYPE* get_version2 = nullptr;
  fmi2GetFMUstateTYPE* get_state2 = nullptr;
  fmi2SetFMUstateTYPE* set_state2 = nullptr;
  fmi2FreeFMUstateTYPE* free_state2 = nullptr;
  fmi2SerializedFMUstateSizeTYPE* serialized_size2 = nullptr;
  fmi2SerializeFMUstateTYPE* serialize2 = nullptr;
  fmi2DeSerializeFMUstateTYPE* deserialize2 = nullptr;
  // instantiate (FMI 2.0) with this FMU's guid and resources as a file URI, logging into `log`
  fmi2Component make_instance2(const char* name, const char* guid_override = nullptr);

  // instantiate with this FMU's token and resources, the log callback collecting into `log`
  fmi3Instance make_instance(const char* name, const char* token_override = nullptr, bool event_mode = false);

 private:
  void* library_ = nullptr;
  bool made_dir_ = false;
};

// Runs an instance from 0 to stop_s in communication steps of k plant steps; rows: the outputs
// (output_names order) after each step, preceded by the time. false and why on any non-OK.
bool run_fmu(Fmi3Fmu& fmu, fmi3Instance instance, std::int64_t k, double stop_s, std::vector<std::vector<double>>& rows,
             std::string& error);
// Two FMI-LS-BUS FMUs connected directly (FMI-LS-BUS §2.2.2 "direct communication"): each
// one's CAN.Tx_Data to the other's CAN.Rx_Data, Rx_Clock ticking with it, at every point where
// a Tx_Clock ticked, in Event Mode until nothing moves; both stepped by k plant steps. rows: the
// plant's outputs after each point's Event Mode (time first). a: the plant, b: its ECU (nullptr:
// none, the plant alone on its bus). Counts what moved; false and why on an error status
// (terminate's fmi3Warning is returned in terminate_status, not an error).
struct BusRun {
  std::int64_t events = 0, transfers = 0, bytes = 0;
  fmi3Status terminate_status = fmi3OK;
  std::vector<std::uint8_t> first_plant_tx;  // the plant's first Tx_Data (sample 0)
  std::map<std::uint32_t, std::int64_t> plant_ops;  // the plant's Tx operations by OP code
  std::vector<std::uint8_t> plant_status;           // the Status values the plant sent, in order
};
// delay_events: b's operations reach a that many Event Modes later (a bus simulation that
// takes time to carry them; 0: a direct connection).
bool run_bus_pair(Fmi3Fmu& a, fmi3Instance ia, Fmi3Fmu* b, fmi3Instance ib, std::int64_t k, double stop_s,
                  std::vector<std::vector<double>>& rows, BusRun& run, std::string& error, int delay_events = 0);
// The same through FMI 2.0 (the time is the importer's own communication point).
bool run_fmu2(Fmi3Fmu& fmu, fmi2Component instance, std::int64_t k, double stop_s, std::vector<std::vector<double>>& rows,
              std::string& error);

}  // namespace ehpt::test
