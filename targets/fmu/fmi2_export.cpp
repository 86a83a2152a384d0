// SPDX-License-Identifier: BSD-3-Clause
// The FMI 2.0 co-simulation functions of an ehpt FMU (io/fmi/fmi2_api.h): the same instance
// (targets/fmu/fmu_instance.hpp) as FMI 3.0's, behind FMI 2.0's calls. Every function is
// exported; what this FMU does not offer (Integer and String variables, a serialised FMU state, derivatives,
// asynchronous steps) answers fmi2Error with a message saying so. Nothing throws across the C
// boundary: an exception becomes fmi2Fatal with its text.

#include <cstdlib>
#include <cstring>
#include <exception>
#include <memory>
#include <string>

#include "io/fmi/fmi2_api.h"
#include "targets/fmu/fmu_instance.hpp"

namespace {

struct Fmu2 {
  std::string name;
  fmi2CallbackFunctions callbacks{};
  bool logging_on = false;
  double start_s = 0.0, stop_s = 0.0;  // fmi2SetupExperiment, for fmi2EnterInitializationMode
  bool stop_defined = false;
  bool terminated = false;             // a plant fault ended it (fmi2GetBooleanStatus)
  double last_successful_s = 0.0;      // fmi2GetRealStatus(fmi2LastSuccessfulTime)
  std::unique_ptr<ehpt::fmu::Instance> instance;
};

// Errors and warnings always reach the logger; the rest only with debug logging on. The
// message goes through "%s": FMI 2.0's logger reads it as a printf format.
void write_log(void* context, int status, const char* category, const char* message) {
  auto* f = static_cast<Fmu2*>(context);
  if (f == nullptr || f->callbacks.logger == nullptr || (status == fmi2OK && !f->logging_on)) return;
  f->callbacks.logger(f->callbacks.componentEnvironment, f->name.c_str(), static_cast<fmi2Status>(status), category,
                      "%s", message);
}

fmi2Status refuse(fmi2Component c, const char* what) {
  write_log(c, fmi2Error, "logStatusError", what);
  return fmi2Error;
}

template <class Body>
fmi2Status guarded(fmi2Component c, Body&& body) {
  if (c == nullptr) return fmi2Error;
  try {
    return body(*static_cast<Fmu2*>(c));
  } catch (const std::exception& e) {
    write_log(c, fmi2Fatal, "logStatusFatal", e.what());
  } catch (...) {
    write_log(c, fmi2Fatal, "logStatusFatal", "an unknown exception");
  }
  return fmi2Fatal;
}

fmi2Status ok(bool b) { return b ? fmi2OK : fmi2Error; }

int hex(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// fmuResourceLocation, a file URI (file:///abs/path or file:/abs/path, percent-encoded), as a
// path; "" if it is not one.
std::string path_of(const std::string& uri) {
  std::string rest;
  if (uri.rfind("file:///", 0) == 0) {
    rest = uri.substr(7);
  } else if (uri.rfind("file://localhost/", 0) == 0) {
    rest = uri.substr(16);
  } else if (uri.rfind("file:/", 0) == 0) {
    rest = uri.substr(5);
  } else {
    return "";
  }
  std::string path;
  for (std::size_t i = 0; i < rest.size(); ++i) {
    if (rest[i] == '%' && i + 2 < rest.size() && hex(rest[i + 1]) >= 0 && hex(rest[i + 2]) >= 0) {
      path += static_cast<char>(hex(rest[i + 1]) * 16 + hex(rest[i + 2]));
      i += 2;
    } else {
      path += rest[i];
    }
  }
  return path;
}

}  // namespace

extern "C" {

const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char* fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t, const fmi2String[]) {
  return guarded(c, [&](Fmu2& f) {
    f.logging_on = loggingOn != fmi2False;
    return fmi2OK;
  });
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions* functions, fmi2Boolean,
                              fmi2Boolean loggingOn) {
  std::unique_ptr<Fmu2> owned;  // outside the try: the catch may still log through it
  try {
    owned = std::make_unique<Fmu2>();
    Fmu2* f = owned.get();
    f->name = instanceName != nullptr && instanceName[0] != '\0' ? instanceName : "ehpt";
    if (functions != nullptr) f->callbacks = *functions;
    f->logging_on = loggingOn != fmi2False;
    if (fmuType != fmi2CoSimulation) {
      write_log(f, fmi2Error, "logStatusError", "fmuType: this FMU is for co-simulation only (fmi2CoSimulation)");
      return nullptr;
    }
    if (fmuGUID == nullptr || fmuResourceLocation == nullptr) {
      write_log(f, fmi2Error, "logStatusError", "fmuGUID and fmuResourceLocation are required");
      return nullptr;
    }
    const std::string resources = path_of(fmuResourceLocation);
    if (resources.empty()) {
      write_log(f, fmi2Error, "logStatusError",
                (std::string("fmuResourceLocation \"") + fmuResourceLocation +
                 "\" is not a file URI (file:///path/to/resources)")
                    .c_str());
      return nullptr;
    }
    f->instance = ehpt::fmu::Instance::make(resources, fmuGUID, ehpt::fmu::Log{write_log, f}, ehpt::fmu::Fmi::k2);
    if (!f->instance) return nullptr;
    if (f->instance->has_bus()) {  // ehpt fmu makes none: FMI-LS-BUS is FMI 3.0's (clocks, Event Mode)
      write_log(f, fmi2Error, "logStatusError", "a CAN terminal (FMI-LS-BUS) needs FMI 3.0: this FMU is damaged");
      return nullptr;
    }
    return owned.release();
  } catch (const std::exception& e) {
    if (owned) write_log(owned.get(), fmi2Fatal, "logStatusFatal", e.what());
  } catch (...) {
  }
  return nullptr;
}

void fmi2FreeInstance(fmi2Component c) { delete static_cast<Fmu2*>(c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean, fmi2Real, fmi2Real startTime, fmi2Boolean stopTimeDefined,
                               fmi2Real stopTime) {
  return guarded(c, [&](Fmu2& f) {
    f.start_s = startTime;
    f.stop_defined = stopTimeDefined != fmi2False;
    f.stop_s = stopTime;
    return fmi2OK;
  });
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
  return guarded(c, [&](Fmu2& f) { return ok(f.instance->enter_initialization(f.stop_defined, f.start_s, f.stop_s)); });
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
  return guarded(c, [&](Fmu2& f) { return ok(f.instance->exit_initialization()); });
}

fmi2Status fmi2Terminate(fmi2Component c) {
  return guarded(c, [&](Fmu2& f) { return ok(f.instance->terminate()); });
}

fmi2Status fmi2Reset(fmi2Component c) {
  return guarded(c, [&](Fmu2& f) {
    f.terminated = false;
    f.last_successful_s = 0.0;
    return ok(f.instance->reset());
  });
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
  return guarded(c, [&](Fmu2& f) { return ok(f.instance->get_float64(vr, nvr, value, nvr)); });
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
  return guarded(c, [&](Fmu2& f) { return ok(f.instance->set_float64(vr, nvr, value, nvr)); });
}

// fmi2Boolean is an int: converted in chunks on the stack (nothing allocated)
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
  return guarded(c, [&](Fmu2& f) {
    bool chunk[64];
    for (size_t at = 0; at < nvr; at += 64) {
      const size_t n = nvr - at < 64 ? nvr - at : 64;
      if (!f.instance->get_boolean(vr + at, n, chunk, n)) return fmi2Error;
      for (size_t i = 0; i < n; ++i) value[at + i] = chunk[i] ? fmi2True : fmi2False;
    }
    return fmi2OK;
  });
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
  return guarded(c, [&](Fmu2& f) {
    bool chunk[64];
    for (size_t at = 0; at < nvr; at += 64) {
      const size_t n = nvr - at < 64 ? nvr - at : 64;
      for (size_t i = 0; i < n; ++i) chunk[i] = value[at + i] != fmi2False;
      if (!f.instance->set_boolean(vr + at, n, chunk, n)) return fmi2Error;
    }
    return fmi2OK;
  });
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference[], size_t nvr, fmi2Integer[]) {
  if (nvr == 0) return c != nullptr ? fmi2OK : fmi2Error;
  return refuse(c, "fmi2GetInteger: this FMU has no Integer variable (only Real and Boolean)");
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference[], size_t nvr, const fmi2Integer[]) {
  if (nvr == 0) return c != nullptr ? fmi2OK : fmi2Error;
  return refuse(c, "fmi2SetInteger: this FMU has no Integer variable (only Real and Boolean)");
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference[], size_t nvr, fmi2String[]) {
  if (nvr == 0) return c != nullptr ? fmi2OK : fmi2Error;
  return refuse(c, "fmi2GetString: this FMU has no String variable (only Real and Boolean)");
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference[], size_t nvr, const fmi2String[]) {
  if (nvr == 0) return c != nullptr ? fmi2OK : fmi2Error;
  return refuse(c, "fmi2SetString: this FMU has no String variable (only Real and Boolean)");
}

// An FMU state is an ehpt::fmu::SavedState; *FMUstate given is overwritten, as the standard asks.
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* FMUstate) {
  return guarded(c, [&](Fmu2& f) {
    if (FMUstate == nullptr) return refuse(c, "fmi2GetFMUstate: FMUstate is NULL");
    std::unique_ptr<ehpt::fmu::SavedState> state(static_cast<ehpt::fmu::SavedState*>(*FMUstate));
    const bool done = f.instance->get_state(state);
    *FMUstate = state.release();
    return ok(done);
  });
}
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
  return guarded(c, [&](Fmu2& f) {
    if (FMUstate == nullptr) return refuse(c, "fmi2SetFMUstate: FMUstate is NULL");
    f.terminated = false;
    return ok(f.instance->set_state(*static_cast<const ehpt::fmu::SavedState*>(FMUstate)));
  });
}
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate* FMUstate) {
  if (c == nullptr) return fmi2Error;
  if (FMUstate != nullptr) {
    delete static_cast<ehpt::fmu::SavedState*>(*FMUstate);
    *FMUstate = nullptr;
  }
  return fmi2OK;
}
// A serialised state is the way to the point (targets/fmu/fmu_instance.hpp: SavedState), as text.
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t* size) {
  return guarded(c, [&](Fmu2& f) {
    if (FMUstate == nullptr || size == nullptr) return refuse(c, "fmi2SerializedFMUstateSize: NULL arguments");
    auto& state = *static_cast<ehpt::fmu::SavedState*>(FMUstate);
    if (!f.instance->serialize(state)) return fmi2Error;
    *size = state.bytes.size();
    return fmi2OK;
  });
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size) {
  return guarded(c, [&](Fmu2& f) {
    if (FMUstate == nullptr || serializedState == nullptr) return refuse(c, "fmi2SerializeFMUstate: NULL arguments");
    auto& state = *static_cast<ehpt::fmu::SavedState*>(FMUstate);
    if (!f.instance->serialize(state)) return fmi2Error;
    if (size < state.bytes.size()) {
      return refuse(c, ("fmi2SerializeFMUstate: size " + std::to_string(size) + " but the state is " +
                        std::to_string(state.bytes.size()) + " bytes (fmi2SerializedFMUstateSize)")
                           .c_str());
    }
    std::memcpy(serializedState, state.bytes.data(), state.bytes.size());
    return fmi2OK;
  });
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size, fmi2FMUstate* FMUstate) {
  return guarded(c, [&](Fmu2& f) {
    if (FMUstate == nullptr) return refuse(c, "fmi2DeSerializeFMUstate: FMUstate is NULL");
    std::unique_ptr<ehpt::fmu::SavedState> state;
    if (!f.instance->deserialize(reinterpret_cast<const std::uint8_t*>(serializedState), size, state)) return fmi2Error;
    if (*FMUstate != nullptr) {
      *static_cast<ehpt::fmu::SavedState*>(*FMUstate) = std::move(*state);
    } else {
      *FMUstate = state.release();
    }
    return fmi2OK;
  });
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference[], size_t, const fmi2ValueReference[],
                                        size_t, const fmi2Real[], fmi2Real[]) {
  return refuse(c, "fmi2GetDirectionalDerivative: not provided (providesDirectionalDerivative = false)");
}
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference[], size_t, const fmi2Integer[],
                                       const fmi2Real[]) {
  return refuse(c, "fmi2SetRealInputDerivatives: not provided (canInterpolateInputs = false)");
}
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference[], size_t, const fmi2Integer[],
                                        fmi2Real[]) {
  return refuse(c, "fmi2GetRealOutputDerivatives: not provided (maxOutputDerivativeOrder = 0)");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize, fmi2Boolean) {
  return guarded(c, [&](Fmu2& f) {
    double reached = 0.0;
    bool stopped = false, event = false;  // (no bus terminal in FMI 2.0: no event)
    const bool done = f.instance->do_step(currentCommunicationPoint, communicationStepSize, reached, stopped, event);
    f.last_successful_s = reached;
    f.terminated = stopped;
    if (!done) return fmi2Error;
    return stopped ? fmi2Discard : fmi2OK;
  });
}

fmi2Status fmi2CancelStep(fmi2Component c) {
  return refuse(c, "fmi2CancelStep: doStep never returns fmi2Pending here (canRunAsynchronuously = false)");
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind, fmi2Status*) {
  return refuse(c, "fmi2GetStatus: no asynchronous step to ask about");
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real* value) {
  return guarded(c, [&](Fmu2& f) {
    if (s != fmi2LastSuccessfulTime || value == nullptr) return refuse(c, "fmi2GetRealStatus: only fmi2LastSuccessfulTime");
    *value = f.last_successful_s;
    return fmi2OK;
  });
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind, fmi2Integer*) {
  return refuse(c, "fmi2GetIntegerStatus: no integer status");
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean* value) {
  return guarded(c, [&](Fmu2& f) {
    if (s != fmi2Terminated || value == nullptr) return refuse(c, "fmi2GetBooleanStatus: only fmi2Terminated");
    *value = f.terminated ? fmi2True : fmi2False;
    return fmi2OK;
  });
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind, fmi2String*) {
  return refuse(c, "fmi2GetStringStatus: no string status");
}

}  // extern "C"
