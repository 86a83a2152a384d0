// SPDX-License-Identifier: BSD-3-Clause
// The FMI 3.0 co-simulation functions of an ehpt FMU (io/fmi/fmi3_api.h), each a thin map onto
// targets/fmu/fmu_instance.hpp. Every function of the API is exported, as importers look them
// all; what this FMU does not offer (Float32, the integer types and strings, derivatives,
// Scheduled Execution; Event Mode, Binary and Clock variables without a bus terminal; a
// serialised state without the built-in ECU) answers fmi3Error with a message saying so.
// Nothing throws across the C boundary: an exception becomes fmi3Fatal with its text.

#include <cstring>
#include <exception>
#include <memory>
#include <new>
#include <string>

#include "io/fmi/fmi3_api.h"
#include "targets/fmu/fmu_instance.hpp"

namespace {

struct Fmu3 {
  std::string name;
  fmi3InstanceEnvironment environment = nullptr;
  fmi3LogMessageCallback log_message = nullptr;
  bool logging_on = false;
  std::unique_ptr<ehpt::fmu::Instance> instance;
};

// Errors and warnings always reach the importer's logger (if it gave one); the rest only with
// debug logging on.
void write_log(void* context, int status, const char* category, const char* message) {
  auto* f = static_cast<Fmu3*>(context);
  if (f == nullptr || f->log_message == nullptr || (status == fmi3OK && !f->logging_on)) return;
  const std::string text = f->name + ": " + message;
  f->log_message(f->environment, static_cast<fmi3Status>(status), category, text.c_str());
}

fmi3Status refuse(fmi3Instance instance, const char* what) {
  write_log(instance, fmi3Error, "logStatusError", what);
  return fmi3Error;
}

// Runs body; an exception escaping it is fmi3Fatal (with its text), never a crash.
template <class Body>
fmi3Status guarded(fmi3Instance instance, Body&& body) {
  if (instance == nullptr) return fmi3Error;
  try {
    return body(*static_cast<Fmu3*>(instance));
  } catch (const std::exception& e) {
    write_log(instance, fmi3Fatal, "logStatusFatal", e.what());
  } catch (...) {
    write_log(instance, fmi3Fatal, "logStatusFatal", "an unknown exception");
  }
  return fmi3Fatal;
}

fmi3Status ok(bool b) { return b ? fmi3OK : fmi3Error; }

}  // namespace

extern "C" {

const char* fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t, const fmi3String[]) {
  return guarded(instance, [&](Fmu3& f) {
    f.logging_on = loggingOn;
    return fmi3OK;
  });
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
                                         fmi3Boolean, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
                                         fmi3Boolean, const fmi3ValueReference[], size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback) {
  std::unique_ptr<Fmu3> owned;  // outside the try: the catch may still log through it
  Fmu3* f = nullptr;
  try {
    owned = std::make_unique<Fmu3>();
    f = owned.get();
    f->name = instanceName != nullptr && instanceName[0] != '\0' ? instanceName : "ehpt";
    f->environment = instanceEnvironment;
    f->log_message = logMessage;
    f->logging_on = loggingOn;
    if (nRequiredIntermediateVariables > 0) {
      write_log(f, fmi3Error, "logStatusError",
                "requiredIntermediateVariables given: this FMU provides no intermediate update");
      return nullptr;
    }
    if (instantiationToken == nullptr || resourcePath == nullptr) {
      write_log(f, fmi3Error, "logStatusError", "instantiationToken and resourcePath are required");
      return nullptr;
    }
    f->instance = ehpt::fmu::Instance::make(resourcePath, instantiationToken, ehpt::fmu::Log{write_log, f});
    if (!f->instance) return nullptr;
    if (eventModeUsed && !f->instance->has_bus()) {
      write_log(f, fmi3Error, "logStatusError", "eventModeUsed = true: this FMU has no Event Mode (hasEventMode = false)");
      return nullptr;
    }
    if (!eventModeUsed && f->instance->has_bus()) {
      write_log(f, fmi3Error, "logStatusError",
                "eventModeUsed = false: this FMU's CAN terminal (FMI-LS-BUS) exchanges its frames in Event Mode "
                "(hasEventMode = true): instantiate it with eventModeUsed = true");
      return nullptr;
    }
    return owned.release();
  } catch (const std::exception& e) {
    if (f != nullptr) write_log(f, fmi3Fatal, "logStatusFatal", e.what());
  } catch (...) {
  }
  return nullptr;
}

void fmi3FreeInstance(fmi3Instance instance) { delete static_cast<Fmu3*>(instance); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean, fmi3Float64, fmi3Float64 startTime,
                                       fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
  return guarded(instance, [&](Fmu3& f) { return ok(f.instance->enter_initialization(stopTimeDefined, startTime, stopTime)); });
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
  return guarded(instance, [&](Fmu3& f) { return ok(f.instance->exit_initialization()); });
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
  return guarded(instance, [&](Fmu3& f) { return ok(f.instance->enter_event_mode()); });
}

fmi3Status fmi3Terminate(fmi3Instance instance) {
  return guarded(instance, [&](Fmu3& f) {
    if (!f.instance->terminate()) return fmi3Error;
    return f.instance->degraded() ? fmi3Warning : fmi3OK;  // a bus session without its ECU is not "OK"
  });
}

fmi3Status fmi3Reset(fmi3Instance instance) {
  return guarded(instance, [&](Fmu3& f) { return ok(f.instance->reset()); });
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Float64 values[], size_t nValues) {
  return guarded(instance,
                 [&](Fmu3& f) { return ok(f.instance->get_float64(valueReferences, nValueReferences, values, nValues)); });
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Float64 values[], size_t nValues) {
  return guarded(instance,
                 [&](Fmu3& f) { return ok(f.instance->set_float64(valueReferences, nValueReferences, values, nValues)); });
}

fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Boolean values[], size_t nValues) {
  return guarded(instance,
                 [&](Fmu3& f) { return ok(f.instance->get_boolean(valueReferences, nValueReferences, values, nValues)); });
}

fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Boolean values[], size_t nValues) {
  return guarded(instance,
                 [&](Fmu3& f) { return ok(f.instance->set_boolean(valueReferences, nValueReferences, values, nValues)); });
}

// The types this FMU has no variable of: a call with references is an error that says so.
#define EHPT_NO_VARIABLES_OF(TYPE, CONST)                                                                        \
  fmi3Status fmi3Get##TYPE(fmi3Instance instance, const fmi3ValueReference[], size_t n, fmi3##TYPE[], size_t) {   \
    if (n == 0) return instance != nullptr ? fmi3OK : fmi3Error;                                                 \
    return refuse(instance, "fmi3Get" #TYPE ": this FMU has no " #TYPE " variable (only Float64 and Boolean)"); \
  }                                                                                                              \
  fmi3Status fmi3Set##TYPE(fmi3Instance instance, const fmi3ValueReference[], size_t n, CONST fmi3##TYPE[], size_t) { \
    if (n == 0) return instance != nullptr ? fmi3OK : fmi3Error;                                                 \
    return refuse(instance, "fmi3Set" #TYPE ": this FMU has no " #TYPE " variable (only Float64 and Boolean)"); \
  }
EHPT_NO_VARIABLES_OF(Float32, const)
EHPT_NO_VARIABLES_OF(Int8, const)
EHPT_NO_VARIABLES_OF(UInt8, const)
EHPT_NO_VARIABLES_OF(Int16, const)
EHPT_NO_VARIABLES_OF(UInt16, const)
EHPT_NO_VARIABLES_OF(Int32, const)
EHPT_NO_VARIABLES_OF(UInt32, const)
EHPT_NO_VARIABLES_OF(Int64, const)
EHPT_NO_VARIABLES_OF(UInt64, const)
EHPT_NO_VARIABLES_OF(String, const)
#undef EHPT_NO_VARIABLES_OF

// Binary and Clock: the CAN terminal's (--bus ls-bus); an FMU without one refuses them by name.
fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues) {
  return guarded(instance, [&](Fmu3& f) {
    if (nValueReferences == 0) return fmi3OK;
    if (valueReferences == nullptr || valueSizes == nullptr || values == nullptr) return refuse(instance, "fmi3GetBinary: NULL arrays");
    return ok(f.instance->get_binary(valueReferences, nValueReferences, valueSizes, values, nValues));
  });
}
fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
  return guarded(instance, [&](Fmu3& f) {
    if (nValueReferences == 0) return fmi3OK;
    if (valueReferences == nullptr || valueSizes == nullptr || values == nullptr) return refuse(instance, "fmi3SetBinary: NULL arrays");
    return ok(f.instance->set_binary(valueReferences, nValueReferences, valueSizes, values, nValues));
  });
}
fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Clock values[]) {
  return guarded(instance, [&](Fmu3& f) {
    if (nValueReferences == 0) return fmi3OK;
    if (valueReferences == nullptr || values == nullptr) return refuse(instance, "fmi3GetClock: NULL arrays");
    for (size_t i = 0; i < nValueReferences; ++i) {
      bool active = false;
      if (!f.instance->get_clock(&valueReferences[i], 1, &active)) return fmi3Error;
      values[i] = active ? fmi3ClockActive : fmi3ClockInactive;
    }
    return fmi3OK;
  });
}
fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[]) {
  return guarded(instance, [&](Fmu3& f) {
    if (nValueReferences == 0) return fmi3OK;
    if (valueReferences == nullptr || values == nullptr) return refuse(instance, "fmi3SetClock: NULL arrays");
    for (size_t i = 0; i < nValueReferences; ++i) {
      const bool active = values[i] == fmi3ClockActive;
      if (!f.instance->set_clock(&valueReferences[i], 1, &active)) return fmi3Error;
    }
    return fmi3OK;
  });
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference, size_t*) {
  return refuse(instance, "fmi3GetNumberOfVariableDependencies: not provided (the outputs depend on the state alone)");
}
fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference, size_t[], fmi3ValueReference[], size_t[],
                                       fmi3DependencyKind[], size_t) {
  return refuse(instance, "fmi3GetVariableDependencies: not provided");
}

// An FMU state is an ehpt::fmu::SavedState; *FMUState given is overwritten, as the standard asks.
fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState* FMUState) {
  return guarded(instance, [&](Fmu3& f) {
    if (FMUState == nullptr) return refuse(instance, "fmi3GetFMUState: FMUState is NULL");
    std::unique_ptr<ehpt::fmu::SavedState> state(static_cast<ehpt::fmu::SavedState*>(*FMUState));
    const bool done = f.instance->get_state(state);
    *FMUState = state.release();
    return ok(done);
  });
}
fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
  return guarded(instance, [&](Fmu3& f) {
    if (FMUState == nullptr) return refuse(instance, "fmi3SetFMUState: FMUState is NULL");
    return ok(f.instance->set_state(*static_cast<const ehpt::fmu::SavedState*>(FMUState)));
  });
}
fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState* FMUState) {
  if (instance == nullptr) return fmi3Error;
  if (FMUState != nullptr) {
    delete static_cast<ehpt::fmu::SavedState*>(*FMUState);
    *FMUState = nullptr;
  }
  return fmi3OK;
}
// A serialised state is the way to the point (targets/fmu/fmu_instance.hpp: SavedState), as text.
fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t* size) {
  return guarded(instance, [&](Fmu3& f) {
    if (FMUState == nullptr || size == nullptr) return refuse(instance, "fmi3SerializedFMUStateSize: NULL arguments");
    auto& state = *static_cast<ehpt::fmu::SavedState*>(FMUState);
    if (!f.instance->serialize(state)) return fmi3Error;
    *size = state.bytes.size();
    return fmi3OK;
  });
}
fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[], size_t size) {
  return guarded(instance, [&](Fmu3& f) {
    if (FMUState == nullptr || serializedState == nullptr) return refuse(instance, "fmi3SerializeFMUState: NULL arguments");
    auto& state = *static_cast<ehpt::fmu::SavedState*>(FMUState);
    if (!f.instance->serialize(state)) return fmi3Error;
    if (size < state.bytes.size()) {
      return refuse(instance, ("fmi3SerializeFMUState: size " + std::to_string(size) + " but the state is " +
                               std::to_string(state.bytes.size()) + " bytes (fmi3SerializedFMUStateSize)")
                                  .c_str());
    }
    std::memcpy(serializedState, state.bytes.data(), state.bytes.size());
    return fmi3OK;
  });
}
fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState* FMUState) {
  return guarded(instance, [&](Fmu3& f) {
    if (FMUState == nullptr) return refuse(instance, "fmi3DeserializeFMUState: FMUState is NULL");
    std::unique_ptr<ehpt::fmu::SavedState> state;
    if (!f.instance->deserialize(serializedState, size, state)) return fmi3Error;
    if (*FMUState != nullptr) {  // a state given is overwritten, as fmi3GetFMUState does
      *static_cast<ehpt::fmu::SavedState*>(*FMUState) = std::move(*state);
    } else {
      *FMUState = state.release();
    }
    return fmi3OK;
  });
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference[], size_t, const fmi3ValueReference[],
                                        size_t, const fmi3Float64[], size_t, fmi3Float64[], size_t) {
  return refuse(instance, "fmi3GetDirectionalDerivative: not provided (providesDirectionalDerivatives = false)");
}
fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference[], size_t, const fmi3ValueReference[],
                                    size_t, const fmi3Float64[], size_t, fmi3Float64[], size_t) {
  return refuse(instance, "fmi3GetAdjointDerivative: not provided (providesAdjointDerivatives = false)");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
  return refuse(instance, "fmi3EnterConfigurationMode: not provided (an LS-BUS FMU's structural parameter, Can_BusNotifications, "
                          "is set before fmi3EnterInitializationMode)");
}
fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
  return refuse(instance, "fmi3ExitConfigurationMode: not provided (no Configuration Mode)");
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference[], size_t, fmi3Float64[],
                                  fmi3IntervalQualifier[]) {
  return refuse(instance, "fmi3GetIntervalDecimal: this FMU has no clock");
}
fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference[], size_t, fmi3UInt64[], fmi3UInt64[],
                                   fmi3IntervalQualifier[]) {
  return refuse(instance, "fmi3GetIntervalFraction: this FMU has no clock");
}
fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference[], size_t, fmi3Float64[]) {
  return refuse(instance, "fmi3GetShiftDecimal: this FMU has no clock");
}
fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference[], size_t, fmi3UInt64[], fmi3UInt64[]) {
  return refuse(instance, "fmi3GetShiftFraction: this FMU has no clock");
}
fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference[], size_t, const fmi3Float64[]) {
  return refuse(instance, "fmi3SetIntervalDecimal: this FMU has no clock");
}
fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference[], size_t, const fmi3UInt64[],
                                   const fmi3UInt64[]) {
  return refuse(instance, "fmi3SetIntervalFraction: this FMU has no clock");
}
fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference[], size_t, const fmi3Float64[]) {
  return refuse(instance, "fmi3SetShiftDecimal: this FMU has no clock");
}
fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference[], size_t, const fmi3UInt64[],
                                const fmi3UInt64[]) {
  return refuse(instance, "fmi3SetShiftFraction: this FMU has no clock");
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) {
  return refuse(instance, "fmi3EvaluateDiscreteStates: this FMU has no Event Mode");
}
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean* discreteStatesNeedUpdate,
                                    fmi3Boolean* terminateSimulation, fmi3Boolean* nominalsOfContinuousStatesChanged,
                                    fmi3Boolean* valuesOfContinuousStatesChanged, fmi3Boolean* nextEventTimeDefined,
                                    fmi3Float64* nextEventTime) {
  return guarded(instance, [&](Fmu3& f) {
    bool need = false;
    const bool done = f.instance->update_discrete_states(need);
    // one update takes all that came; it asks for another when it sent operations (Tx_Clock
    // ticked: the importer hands them on); the next event is a doStep's
    for (fmi3Boolean* b : {discreteStatesNeedUpdate, terminateSimulation, nominalsOfContinuousStatesChanged,
                           valuesOfContinuousStatesChanged, nextEventTimeDefined}) {
      if (b != nullptr) *b = fmi3False;
    }
    if (discreteStatesNeedUpdate != nullptr) *discreteStatesNeedUpdate = need ? fmi3True : fmi3False;
    if (nextEventTime != nullptr) *nextEventTime = 0.0;
    return ok(done);
  });
}
fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
  return guarded(instance, [&](Fmu3& f) { return ok(f.instance->enter_step_mode()); });
}
fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference[], size_t, const fmi3Int32[],
                                    fmi3Float64[], size_t) {
  return refuse(instance, "fmi3GetOutputDerivatives: not provided (maxOutputDerivativeOrder = 0)");
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean, fmi3Boolean* eventHandlingNeeded, fmi3Boolean* terminateSimulation,
                      fmi3Boolean* earlyReturn, fmi3Float64* lastSuccessfulTime) {
  return guarded(instance, [&](Fmu3& f) {
    double reached = 0.0;
    bool stopped = false, event = false;
    const bool done = f.instance->do_step(currentCommunicationPoint, communicationStepSize, reached, stopped, event);
    if (eventHandlingNeeded != nullptr) *eventHandlingNeeded = event ? fmi3True : fmi3False;  // Tx_Clock ticked
    if (earlyReturn != nullptr) *earlyReturn = fmi3False;
    if (terminateSimulation != nullptr) *terminateSimulation = stopped ? fmi3True : fmi3False;
    if (lastSuccessfulTime != nullptr) *lastSuccessfulTime = reached;
    if (!done) return fmi3Error;
    return stopped ? fmi3Discard : fmi3OK;
  });
}

}  // extern "C"
