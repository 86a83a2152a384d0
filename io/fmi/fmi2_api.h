// SPDX-License-Identifier: BSD-3-Clause
/*
 * FMI 2.0 C API: the part a Co-Simulation FMU and its importer need.
 *
 * Written by the ehpt authors from the text of the FMI 2.0 specification ("Functional Mock-up
 * Interface for Model Exchange and Co-Simulation", document version 2.0, 2014-07-25, and its
 * maintenance releases 2.0.1 .. 2.0.4, https://fmi-standard.org/downloads/): section 2.1
 * "FMI Application Programming Interface" (header files and naming of functions, 2.1.2
 * platform dependent definitions, 2.1.3 status returned by functions, inquire platform and
 * version number, creation/destruction/logging of instances, initialization/termination/reset,
 * getting and setting variable values, getting and setting the complete FMU state, partial
 * derivatives) and the API part of chapter 4 "FMI for Co-Simulation" (transfer of input /
 * output values and parameters, computation (fmi2DoStep, fmi2CancelStep), retrieving status
 * information from the slave). Each declaration was checked against
 * the C declarations the specification gives (those of fmi2TypesPlatform.h,
 * fmi2FunctionTypes.h and fmi2Functions.h as of 2.0.1+). This file is not a copy of those
 * headers: it only has the subset below, in one file, with our own layout and comments.
 *
 * Scope: platform types, enums, callback types and the callback struct, and for every common
 * and Co-Simulation function the function type "<name>TYPE" and the exported prototype.
 * Left out on purpose: Model Exchange only functions (fmi2EnterEventMode, fmi2NewDiscreteStates,
 * fmi2SetTime, fmi2GetDerivatives, ...) and fmi2EventInfo.
 *
 * Use:
 *   FMU (shared library, may be built with -fvisibility=hidden): define the functions with
 *   exactly these signatures; the prototypes carry EHPT_FMI_EXPORT so the plain names
 *   (fmi2DoStep, ...) are exported. No FMI2_FUNCTION_PREFIX name mangling is done.
 *   Importer: dlsym("fmi2DoStep") and cast to fmi2DoStepTYPE* (the TYPE names are function
 *   types, not pointer types, as in the standard). Define EHPT_FMI2_NO_PROTOTYPES before
 *   including this file to get the types only.
 *
 * Points where we were unsure (see also the notes at the declarations):
 *  - fmi2CallbackFunctions: the 2.0 (2014) text declares its five members "const"; 2.0.1
 *    removed the const (FMI issue #216). Layout and order are the same either way, so the ABI
 *    is the same; we follow 2.0.1+ (no const), which lets an importer fill the struct member
 *    by member.
 *  - fmi2SerializeFMUstate: the 2.0.1+ header leaves the byte-array parameter unnamed
 *    ("fmi2Byte[]"); the specification text names it serializedState, which we use.
 *  - The headers of the standard wrap the struct in #pragma pack(push,8) / pack(pop) for MSVC
 *    and GCC; we do the same, so a surrounding #pragma pack of the includer cannot change it.
 */
#pragma once
#ifndef EHPT_FMI2_API_H
#define EHPT_FMI2_API_H

#include <stddef.h> /* size_t */

/* Identification strings, returned by fmi2GetTypesPlatform() and fmi2GetVersion(). */
#define fmi2TypesPlatform "default"
#define fmi2Version "2.0"

/* Symbol visibility for the exported FMI functions (shared with fmi3_api.h). */
#ifndef EHPT_FMI_EXPORT
#if defined(_WIN32) || defined(__CYGWIN__)
#define EHPT_FMI_EXPORT __declspec(dllexport)
#elif defined(__GNUC__) && __GNUC__ >= 4
#define EHPT_FMI_EXPORT __attribute__((visibility("default")))
#else
#define EHPT_FMI_EXPORT
#endif
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* ---------------------------------------------------------------------------------------------
 * Platform dependent definitions (platform "default")
 * ------------------------------------------------------------------------------------------- */

typedef void* fmi2Component;            /* the FMU's own instance data, opaque to the importer */
typedef void* fmi2ComponentEnvironment; /* the importer's data, handed back in callbacks */
typedef void* fmi2FMUstate;             /* a saved copy of the internal FMU state */
typedef unsigned int fmi2ValueReference; /* handle of a variable (valueReference in the XML) */

typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;            /* values fmi2True / fmi2False */
typedef char fmi2Char;
typedef const fmi2Char* fmi2String; /* '\0' terminated, UTF-8 */
typedef char fmi2Byte;              /* smallest addressable unit */

#define fmi2True 1
#define fmi2False 0

/* ---------------------------------------------------------------------------------------------
 * Enumerations
 * ------------------------------------------------------------------------------------------- */

/* Returned by almost every function. The order (0..5) is part of the ABI. fmi2Pending is only
 * used by asynchronous Co-Simulation (fmi2DoStep returning before the step is done). */
typedef enum {
    fmi2OK,
    fmi2Warning,
    fmi2Discard,
    fmi2Error,
    fmi2Fatal,
    fmi2Pending
} fmi2Status;

/* fmuType argument of fmi2Instantiate. */
typedef enum {
    fmi2ModelExchange,
    fmi2CoSimulation
} fmi2Type;

/* Which status fmi2Get*Status reports. */
typedef enum {
    fmi2DoStepStatus,       /* fmi2GetStatus: status of the asynchronous fmi2DoStep */
    fmi2PendingStatus,      /* fmi2GetStringStatus: description of the pending step */
    fmi2LastSuccessfulTime, /* fmi2GetRealStatus: end time of the last successful step */
    fmi2Terminated          /* fmi2GetBooleanStatus: the slave wants to end the simulation */
} fmi2StatusKind;

/* ---------------------------------------------------------------------------------------------
 * Callbacks provided by the importer
 * ------------------------------------------------------------------------------------------- */

/* Log a message; message is a printf-style format for the variadic arguments, and may hold
 * "#<Type><valueReference>#" references to variables. */
typedef void (*fmi2CallbackLogger)(fmi2ComponentEnvironment componentEnvironment,
                                   fmi2String instanceName,
                                   fmi2Status status,
                                   fmi2String category,
                                   fmi2String message,
                                   ...);

/* calloc-like: nobj objects of size bytes each, zero-initialized. */
typedef void* (*fmi2CallbackAllocateMemory)(size_t nobj, size_t size);

typedef void (*fmi2CallbackFreeMemory)(void* obj);

/* Asynchronous Co-Simulation only: fmi2DoStep, which returned fmi2Pending, has finished.
 * May be NULL. */
typedef void (*fmi2StepFinished)(fmi2ComponentEnvironment componentEnvironment,
                                 fmi2Status status);

#if defined(_MSC_VER) || defined(__GNUC__)
#pragma pack(push, 8)
#endif

/* Passed by pointer to fmi2Instantiate; the member order is part of the ABI. */
typedef struct {
    fmi2CallbackLogger logger;
    fmi2CallbackAllocateMemory allocateMemory;
    fmi2CallbackFreeMemory freeMemory;
    fmi2StepFinished stepFinished;
    fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

#if defined(_MSC_VER) || defined(__GNUC__)
#pragma pack(pop)
#endif

/* ---------------------------------------------------------------------------------------------
 * Function types: common functions
 * ------------------------------------------------------------------------------------------- */

/* Inquire platform and version, set logging */
typedef const char* fmi2GetTypesPlatformTYPE(void);

typedef const char* fmi2GetVersionTYPE(void);

typedef fmi2Status fmi2SetDebugLoggingTYPE(fmi2Component c,
                                           fmi2Boolean loggingOn,
                                           size_t nCategories,
                                           const fmi2String categories[]);

/* Creation and destruction of instances. Returns NULL on failure. */
typedef fmi2Component fmi2InstantiateTYPE(fmi2String instanceName,
                                          fmi2Type fmuType,
                                          fmi2String fmuGUID,
                                          fmi2String fmuResourceLocation,
                                          const fmi2CallbackFunctions* functions,
                                          fmi2Boolean visible,
                                          fmi2Boolean loggingOn);

typedef void fmi2FreeInstanceTYPE(fmi2Component c);

/* Initialization, termination, reset */
typedef fmi2Status fmi2SetupExperimentTYPE(fmi2Component c,
                                           fmi2Boolean toleranceDefined,
                                           fmi2Real tolerance,
                                           fmi2Real startTime,
                                           fmi2Boolean stopTimeDefined,
                                           fmi2Real stopTime);

typedef fmi2Status fmi2EnterInitializationModeTYPE(fmi2Component c);

typedef fmi2Status fmi2ExitInitializationModeTYPE(fmi2Component c);

typedef fmi2Status fmi2TerminateTYPE(fmi2Component c);

typedef fmi2Status fmi2ResetTYPE(fmi2Component c);

/* Getting variable values: vr holds nvr value references, value receives one value each.
 * Returned strings stay valid only until the next call into the FMU. */
typedef fmi2Status fmi2GetRealTYPE(fmi2Component c,
                                   const fmi2ValueReference vr[],
                                   size_t nvr,
                                   fmi2Real value[]);
typedef fmi2Status fmi2GetIntegerTYPE(fmi2Component c,
                                      const fmi2ValueReference vr[],
                                      size_t nvr,
                                      fmi2Integer value[]);
typedef fmi2Status fmi2GetBooleanTYPE(fmi2Component c,
                                      const fmi2ValueReference vr[],
                                      size_t nvr,
                                      fmi2Boolean value[]);
typedef fmi2Status fmi2GetStringTYPE(fmi2Component c,
                                     const fmi2ValueReference vr[],
                                     size_t nvr,
                                     fmi2String value[]);

/* Setting variable values. The FMU must copy strings. */
typedef fmi2Status fmi2SetRealTYPE(fmi2Component c,
                                   const fmi2ValueReference vr[],
                                   size_t nvr,
                                   const fmi2Real value[]);
typedef fmi2Status fmi2SetIntegerTYPE(fmi2Component c,
                                      const fmi2ValueReference vr[],
                                      size_t nvr,
                                      const fmi2Integer value[]);
typedef fmi2Status fmi2SetBooleanTYPE(fmi2Component c,
                                      const fmi2ValueReference vr[],
                                      size_t nvr,
                                      const fmi2Boolean value[]);
typedef fmi2Status fmi2SetStringTYPE(fmi2Component c,
                                     const fmi2ValueReference vr[],
                                     size_t nvr,
                                     const fmi2String value[]);

/* Getting and setting the complete FMU state (note the lower-case "s" in "FMUstate") */
typedef fmi2Status fmi2GetFMUstateTYPE(fmi2Component c, fmi2FMUstate* FMUstate);

typedef fmi2Status fmi2SetFMUstateTYPE(fmi2Component c, fmi2FMUstate FMUstate);

typedef fmi2Status fmi2FreeFMUstateTYPE(fmi2Component c, fmi2FMUstate* FMUstate);

typedef fmi2Status fmi2SerializedFMUstateSizeTYPE(fmi2Component c,
                                                  fmi2FMUstate FMUstate,
                                                  size_t* size);

typedef fmi2Status fmi2SerializeFMUstateTYPE(fmi2Component c,
                                             fmi2FMUstate FMUstate,
                                             fmi2Byte serializedState[],
                                             size_t size);

/* Capital "S" in "DeSerialize", as in the standard. */
typedef fmi2Status fmi2DeSerializeFMUstateTYPE(fmi2Component c,
                                               const fmi2Byte serializedState[],
                                               size_t size,
                                               fmi2FMUstate* FMUstate);

/* Partial derivatives: dvUnknown = (d unknowns / d knowns) * dvKnown */
typedef fmi2Status fmi2GetDirectionalDerivativeTYPE(fmi2Component c,
                                                    const fmi2ValueReference vUnknown_ref[],
                                                    size_t nUnknown,
                                                    const fmi2ValueReference vKnown_ref[],
                                                    size_t nKnown,
                                                    const fmi2Real dvKnown[],
                                                    fmi2Real dvUnknown[]);

/* ---------------------------------------------------------------------------------------------
 * Function types: Co-Simulation
 * ------------------------------------------------------------------------------------------- */

/* Time derivatives of real inputs / outputs; order[i] >= 1 applies to vr[i]. */
typedef fmi2Status fmi2SetRealInputDerivativesTYPE(fmi2Component c,
                                                   const fmi2ValueReference vr[],
                                                   size_t nvr,
                                                   const fmi2Integer order[],
                                                   const fmi2Real value[]);

typedef fmi2Status fmi2GetRealOutputDerivativesTYPE(fmi2Component c,
                                                    const fmi2ValueReference vr[],
                                                    size_t nvr,
                                                    const fmi2Integer order[],
                                                    fmi2Real value[]);

/* Advance from currentCommunicationPoint by communicationStepSize (> 0). */
typedef fmi2Status fmi2DoStepTYPE(fmi2Component c,
                                  fmi2Real currentCommunicationPoint,
                                  fmi2Real communicationStepSize,
                                  fmi2Boolean noSetFMUStatePriorToCurrentPoint);

/* Asynchronous Co-Simulation: cancel a step that returned fmi2Pending. */
typedef fmi2Status fmi2CancelStepTYPE(fmi2Component c);

/* Status of the slave, selected by s (see fmi2StatusKind). */
typedef fmi2Status fmi2GetStatusTYPE(fmi2Component c, const fmi2StatusKind s, fmi2Status* value);

typedef fmi2Status fmi2GetRealStatusTYPE(fmi2Component c, const fmi2StatusKind s, fmi2Real* value);

typedef fmi2Status fmi2GetIntegerStatusTYPE(fmi2Component c,
                                            const fmi2StatusKind s,
                                            fmi2Integer* value);

typedef fmi2Status fmi2GetBooleanStatusTYPE(fmi2Component c,
                                            const fmi2StatusKind s,
                                            fmi2Boolean* value);

typedef fmi2Status fmi2GetStringStatusTYPE(fmi2Component c,
                                           const fmi2StatusKind s,
                                           fmi2String* value);

/* ---------------------------------------------------------------------------------------------
 * Exported functions (plain names, no prefix). Declared through the TYPE typedefs so that a
 * definition with a different signature is a compile error.
 * ------------------------------------------------------------------------------------------- */

#ifndef EHPT_FMI2_NO_PROTOTYPES

/* Common */
EHPT_FMI_EXPORT fmi2GetTypesPlatformTYPE fmi2GetTypesPlatform;
EHPT_FMI_EXPORT fmi2GetVersionTYPE fmi2GetVersion;
EHPT_FMI_EXPORT fmi2SetDebugLoggingTYPE fmi2SetDebugLogging;
EHPT_FMI_EXPORT fmi2InstantiateTYPE fmi2Instantiate;
EHPT_FMI_EXPORT fmi2FreeInstanceTYPE fmi2FreeInstance;
EHPT_FMI_EXPORT fmi2SetupExperimentTYPE fmi2SetupExperiment;
EHPT_FMI_EXPORT fmi2EnterInitializationModeTYPE fmi2EnterInitializationMode;
EHPT_FMI_EXPORT fmi2ExitInitializationModeTYPE fmi2ExitInitializationMode;
EHPT_FMI_EXPORT fmi2TerminateTYPE fmi2Terminate;
EHPT_FMI_EXPORT fmi2ResetTYPE fmi2Reset;

EHPT_FMI_EXPORT fmi2GetRealTYPE fmi2GetReal;
EHPT_FMI_EXPORT fmi2GetIntegerTYPE fmi2GetInteger;
EHPT_FMI_EXPORT fmi2GetBooleanTYPE fmi2GetBoolean;
EHPT_FMI_EXPORT fmi2GetStringTYPE fmi2GetString;
EHPT_FMI_EXPORT fmi2SetRealTYPE fmi2SetReal;
EHPT_FMI_EXPORT fmi2SetIntegerTYPE fmi2SetInteger;
EHPT_FMI_EXPORT fmi2SetBooleanTYPE fmi2SetBoolean;
EHPT_FMI_EXPORT fmi2SetStringTYPE fmi2SetString;

EHPT_FMI_EXPORT fmi2GetFMUstateTYPE fmi2GetFMUstate;
EHPT_FMI_EXPORT fmi2SetFMUstateTYPE fmi2SetFMUstate;
EHPT_FMI_EXPORT fmi2FreeFMUstateTYPE fmi2FreeFMUstate;
EHPT_FMI_EXPORT fmi2SerializedFMUstateSizeTYPE fmi2SerializedFMUstateSize;
EHPT_FMI_EXPORT fmi2SerializeFMUstateTYPE fmi2SerializeFMUstate;
EHPT_FMI_EXPORT fmi2DeSerializeFMUstateTYPE fmi2DeSerializeFMUstate;

EHPT_FMI_EXPORT fmi2GetDirectionalDerivativeTYPE fmi2GetDirectionalDerivative;

/* Co-Simulation */
EHPT_FMI_EXPORT fmi2SetRealInputDerivativesTYPE fmi2SetRealInputDerivatives;
EHPT_FMI_EXPORT fmi2GetRealOutputDerivativesTYPE fmi2GetRealOutputDerivatives;
EHPT_FMI_EXPORT fmi2DoStepTYPE fmi2DoStep;
EHPT_FMI_EXPORT fmi2CancelStepTYPE fmi2CancelStep;
EHPT_FMI_EXPORT fmi2GetStatusTYPE fmi2GetStatus;
EHPT_FMI_EXPORT fmi2GetRealStatusTYPE fmi2GetRealStatus;
EHPT_FMI_EXPORT fmi2GetIntegerStatusTYPE fmi2GetIntegerStatus;
EHPT_FMI_EXPORT fmi2GetBooleanStatusTYPE fmi2GetBooleanStatus;
EHPT_FMI_EXPORT fmi2GetStringStatusTYPE fmi2GetStringStatus;

#endif /* EHPT_FMI2_NO_PROTOTYPES */

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* EHPT_FMI2_API_H */
