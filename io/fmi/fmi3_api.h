// SPDX-License-Identifier: BSD-3-Clause
/*
 * FMI 3.0 C API: the part a Co-Simulation FMU and its importer need.
 *
 * Written by the ehpt authors from the text of the FMI 3.0 specification
 * (Functional Mock-up Interface Specification 3.0.2, https://fmi-standard.org/docs/3.0.2/),
 * chapter 2 "Common Concepts", section "General Mechanisms" (header files and naming of
 * functions, platform dependent definitions, status returned by functions and logging, inquire
 * version number, getting and setting variable values, FMU state, partial derivatives,
 * dependencies of variables, Clocks) and the common state machine section (instantiation,
 * initialization, Event Mode, Configuration Mode, terminate, reset, discrete states), and
 * chapter 4 "FMI for Co-Simulation", state machine / API section (Step Mode, fmi3DoStep,
 * fmi3GetOutputDerivatives, early return, intermediate update callback). The specification
 * text shows each C declaration as a listing taken from its own headers; we checked every one
 * here against those listings (3.0 release text, with the 3.0.2 change noted below). This file is
 * not a copy of those headers (fmi3PlatformTypes.h / fmi3FunctionTypes.h / fmi3Functions.h):
 * it only has the subset below, in one file, with our own layout and comments.
 *
 * Scope: platform types, the enums used by Co-Simulation, the callback types, and for every
 * function of the common and Co-Simulation interfaces the function type "<name>TYPE" and the
 * exported prototype. Left out on purpose: Model Exchange only functions (fmi3SetTime,
 * fmi3GetContinuousStates, ...), fmi3InstantiateModelExchange and Scheduled Execution
 * (fmi3InstantiateScheduledExecution, fmi3ActivateModelPartition).
 *
 * Use:
 *   FMU (shared library, may be built with -fvisibility=hidden): define the functions with
 *   exactly these signatures; the prototypes below carry EHPT_FMI_EXPORT so the plain names
 *   (fmi3DoStep, ...) are exported. No FMI3_FUNCTION_PREFIX name mangling is done.
 *   Importer: dlsym("fmi3DoStep") and cast to fmi3DoStepTYPE* (the TYPE names are function
 *   types, not pointer types, as in the standard). Define EHPT_FMI3_NO_PROTOTYPES before
 *   including this file to get the types only.
 *
 * Points where we were unsure (see also the notes at the declarations):
 *  - fmi3LockPreemptionCallback / fmi3UnlockPreemptionCallback: 3.0 and 3.0.1 list them with an
 *    empty parameter list "()", 3.0.2 changed this to "(void)". We use "(void)"; in C++ both
 *    mean the same, in C "(void)" is the stricter prototype. Only Scheduled Execution uses them.
 *  - fmi3LogMessageCallback has no instanceName argument in the released 3.0 text (drafts of
 *    3.0 had one, as FMI 2.0 has); we follow the release.
 *  - fmi3Clock is "bool" like fmi3Boolean in the release (drafts used int).
 */
#pragma once
#ifndef EHPT_FMI3_API_H
#define EHPT_FMI3_API_H

#include <stddef.h> /* size_t */
#include <stdint.h> /* intN_t, uintN_t */
#ifndef __cplusplus
#include <stdbool.h> /* bool, true, false (C99..C17; keywords since C23) */
#endif

/* Version of this API, returned by fmi3GetVersion(). */
#define fmi3Version "3.0"

/* Symbol visibility for the exported FMI functions (shared with fmi2_api.h). */
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
 * Platform dependent definitions
 * ------------------------------------------------------------------------------------------- */

typedef void* fmi3Instance;            /* the FMU's own instance data, opaque to the importer */
typedef void* fmi3InstanceEnvironment; /* the importer's data, handed back in callbacks */
typedef void* fmi3FMUState;            /* a saved copy of the internal FMU state */
typedef uint32_t fmi3ValueReference;   /* handle of a variable (valueReference in the XML) */

typedef float fmi3Float32;
typedef double fmi3Float64;
typedef int8_t fmi3Int8;
typedef uint8_t fmi3UInt8;
typedef int16_t fmi3Int16;
typedef uint16_t fmi3UInt16;
typedef int32_t fmi3Int32;
typedef uint32_t fmi3UInt32;
typedef int64_t fmi3Int64;
typedef uint64_t fmi3UInt64;
typedef bool fmi3Boolean;            /* values fmi3True / fmi3False */
typedef char fmi3Char;
typedef const fmi3Char* fmi3String;  /* '\0' terminated, UTF-8 */
typedef uint8_t fmi3Byte;            /* smallest addressable unit */
typedef const fmi3Byte* fmi3Binary;  /* binary data; its length is passed separately */
typedef bool fmi3Clock;              /* values fmi3ClockActive / fmi3ClockInactive */

#define fmi3True true
#define fmi3False false

#define fmi3ClockActive true
#define fmi3ClockInactive false

/* ---------------------------------------------------------------------------------------------
 * Enumerations
 * ------------------------------------------------------------------------------------------- */

/* Returned by almost every function. The order (0..4) is part of the ABI. */
typedef enum {
    fmi3OK,
    fmi3Warning,
    fmi3Discard,
    fmi3Error,
    fmi3Fatal
} fmi3Status;

/* Kind of a dependency, returned by fmi3GetVariableDependencies (values 0..5). */
typedef enum {
    fmi3Independent,
    fmi3Constant,
    fmi3Fixed,
    fmi3Tunable,
    fmi3Discrete,
    fmi3Dependent
} fmi3DependencyKind;

/* Returned per Clock by fmi3GetIntervalDecimal / fmi3GetIntervalFraction (values 0..2). */
typedef enum {
    fmi3IntervalNotYetKnown,
    fmi3IntervalUnchanged,
    fmi3IntervalChanged
} fmi3IntervalQualifier;

/* ---------------------------------------------------------------------------------------------
 * Callbacks provided by the importer
 * ------------------------------------------------------------------------------------------- */

/* Log a message. May be NULL at instantiation, then the FMU must not log. Must not call back
 * into the FMU. */
typedef void (*fmi3LogMessageCallback)(fmi3InstanceEnvironment instanceEnvironment,
                                       fmi3Status status,
                                       fmi3String category,
                                       fmi3String message);

/* Called by the FMU inside fmi3DoStep at intermediate points (Co-Simulation). The importer may
 * ask for an early return through *earlyReturnRequested and *earlyReturnTime. */
typedef void (*fmi3IntermediateUpdateCallback)(fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3Float64 intermediateUpdateTime,
                                               fmi3Boolean intermediateVariableSetRequested,
                                               fmi3Boolean intermediateVariableGetAllowed,
                                               fmi3Boolean intermediateStepFinished,
                                               fmi3Boolean canReturnEarly,
                                               fmi3Boolean* earlyReturnRequested,
                                               fmi3Float64* earlyReturnTime);

/* Scheduled Execution: the FMU signals that a Clock ticked. */
typedef void (*fmi3ClockUpdateCallback)(fmi3InstanceEnvironment instanceEnvironment);

/* Scheduled Execution: enter / leave a critical section. "(void)" as of FMI 3.0.2, see top. */
typedef void (*fmi3LockPreemptionCallback)(void);
typedef void (*fmi3UnlockPreemptionCallback)(void);

/* ---------------------------------------------------------------------------------------------
 * Function types: common functions
 * ------------------------------------------------------------------------------------------- */

/* Inquire version, set logging */
typedef const char* fmi3GetVersionTYPE(void);

typedef fmi3Status fmi3SetDebugLoggingTYPE(fmi3Instance instance,
                                           fmi3Boolean loggingOn,
                                           size_t nCategories,
                                           const fmi3String categories[]);

/* Creation and destruction of instances. Returns NULL on failure. */
typedef fmi3Instance fmi3InstantiateCoSimulationTYPE(
    fmi3String instanceName,
    fmi3String instantiationToken,
    fmi3String resourcePath,
    fmi3Boolean visible,
    fmi3Boolean loggingOn,
    fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed,
    const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables,
    fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage,
    fmi3IntermediateUpdateCallback intermediateUpdate);

typedef void fmi3FreeInstanceTYPE(fmi3Instance instance);

/* Initialization, Event Mode, terminate, reset */
typedef fmi3Status fmi3EnterInitializationModeTYPE(fmi3Instance instance,
                                                   fmi3Boolean toleranceDefined,
                                                   fmi3Float64 tolerance,
                                                   fmi3Float64 startTime,
                                                   fmi3Boolean stopTimeDefined,
                                                   fmi3Float64 stopTime);

typedef fmi3Status fmi3ExitInitializationModeTYPE(fmi3Instance instance);

typedef fmi3Status fmi3EnterEventModeTYPE(fmi3Instance instance);

typedef fmi3Status fmi3TerminateTYPE(fmi3Instance instance);

typedef fmi3Status fmi3ResetTYPE(fmi3Instance instance);

/* Getting variable values.
 * valueReferences: nValueReferences handles; values: the serialized (row-major) values of those
 * variables, nValues of them (== nValueReferences when all are scalars). Strings and binaries
 * returned stay valid only until the next call into the FMU. */
typedef fmi3Status fmi3GetFloat32TYPE(fmi3Instance instance,
                                      const fmi3ValueReference valueReferences[],
                                      size_t nValueReferences,
                                      fmi3Float32 values[],
                                      size_t nValues);
typedef fmi3Status fmi3GetFloat64TYPE(fmi3Instance instance,
                                      const fmi3ValueReference valueReferences[],
                                      size_t nValueReferences,
                                      fmi3Float64 values[],
                                      size_t nValues);
typedef fmi3Status fmi3GetInt8TYPE(fmi3Instance instance,
                                   const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences,
                                   fmi3Int8 values[],
                                   size_t nValues);
typedef fmi3Status fmi3GetUInt8TYPE(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences,
                                    fmi3UInt8 values[],
                                    size_t nValues);
typedef fmi3Status fmi3GetInt16TYPE(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences,
                                    fmi3Int16 values[],
                                    size_t nValues);
typedef fmi3Status fmi3GetUInt16TYPE(fmi3Instance instance,
                                     const fmi3ValueReference valueReferences[],
                                     size_t nValueReferences,
                                     fmi3UInt16 values[],
                                     size_t nValues);
typedef fmi3Status fmi3GetInt32TYPE(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences,
                                    fmi3Int32 values[],
                                    size_t nValues);
typedef fmi3Status fmi3GetUInt32TYPE(fmi3Instance instance,
                                     const fmi3ValueReference valueReferences[],
                                     size_t nValueReferences,
                                     fmi3UInt32 values[],
                                     size_t nValues);
typedef fmi3Status fmi3GetInt64TYPE(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences,
                                    fmi3Int64 values[],
                                    size_t nValues);
typedef fmi3Status fmi3GetUInt64TYPE(fmi3Instance instance,
                                     const fmi3ValueReference valueReferences[],
                                     size_t nValueReferences,
                                     fmi3UInt64 values[],
                                     size_t nValues);
typedef fmi3Status fmi3GetBooleanTYPE(fmi3Instance instance,
                                      const fmi3ValueReference valueReferences[],
                                      size_t nValueReferences,
                                      fmi3Boolean values[],
                                      size_t nValues);
typedef fmi3Status fmi3GetStringTYPE(fmi3Instance instance,
                                     const fmi3ValueReference valueReferences[],
                                     size_t nValueReferences,
                                     fmi3String values[],
                                     size_t nValues);
/* Binary: valueSizes[i] receives the length in bytes of values[i]. */
typedef fmi3Status fmi3GetBinaryTYPE(fmi3Instance instance,
                                     const fmi3ValueReference valueReferences[],
                                     size_t nValueReferences,
                                     size_t valueSizes[],
                                     fmi3Binary values[],
                                     size_t nValues);
/* Clock: Clocks are always scalar, so there is no nValues argument. */
typedef fmi3Status fmi3GetClockTYPE(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences,
                                    fmi3Clock values[]);

/* Setting variable values. Same arguments; the FMU must copy strings and binaries. */
typedef fmi3Status fmi3SetFloat32TYPE(fmi3Instance instance,
                                      const fmi3ValueReference valueReferences[],
                                      size_t nValueReferences,
                                      const fmi3Float32 values[],
                                      size_t nValues);
typedef fmi3Status fmi3SetFloat64TYPE(fmi3Instance instance,
                                      const fmi3ValueReference valueReferences[],
                                      size_t nValueReferences,
                                      const fmi3Float64 values[],
                                      size_t nValues);
typedef fmi3Status fmi3SetInt8TYPE(fmi3Instance instance,
                                   const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences,
                                   const fmi3Int8 values[],
                                   size_t nValues);
typedef fmi3Status fmi3SetUInt8TYPE(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences,
                                    const fmi3UInt8 values[],
                                    size_t nValues);
typedef fmi3Status fmi3SetInt16TYPE(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences,
                                    const fmi3Int16 values[],
                                    size_t nValues);
typedef fmi3Status fmi3SetUInt16TYPE(fmi3Instance instance,
                                     const fmi3ValueReference valueReferences[],
                                     size_t nValueReferences,
                                     const fmi3UInt16 values[],
                                     size_t nValues);
typedef fmi3Status fmi3SetInt32TYPE(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences,
                                    const fmi3Int32 values[],
                                    size_t nValues);
typedef fmi3Status fmi3SetUInt32TYPE(fmi3Instance instance,
                                     const fmi3ValueReference valueReferences[],
                                     size_t nValueReferences,
                                     const fmi3UInt32 values[],
                                     size_t nValues);
typedef fmi3Status fmi3SetInt64TYPE(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences,
                                    const fmi3Int64 values[],
                                    size_t nValues);
typedef fmi3Status fmi3SetUInt64TYPE(fmi3Instance instance,
                                     const fmi3ValueReference valueReferences[],
                                     size_t nValueReferences,
                                     const fmi3UInt64 values[],
                                     size_t nValues);
typedef fmi3Status fmi3SetBooleanTYPE(fmi3Instance instance,
                                      const fmi3ValueReference valueReferences[],
                                      size_t nValueReferences,
                                      const fmi3Boolean values[],
                                      size_t nValues);
typedef fmi3Status fmi3SetStringTYPE(fmi3Instance instance,
                                     const fmi3ValueReference valueReferences[],
                                     size_t nValueReferences,
                                     const fmi3String values[],
                                     size_t nValues);
typedef fmi3Status fmi3SetBinaryTYPE(fmi3Instance instance,
                                     const fmi3ValueReference valueReferences[],
                                     size_t nValueReferences,
                                     const size_t valueSizes[],
                                     const fmi3Binary values[],
                                     size_t nValues);
typedef fmi3Status fmi3SetClockTYPE(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences,
                                    const fmi3Clock values[]);

/* Variable dependency information */
typedef fmi3Status fmi3GetNumberOfVariableDependenciesTYPE(fmi3Instance instance,
                                                           fmi3ValueReference valueReference,
                                                           size_t* nDependencies);

typedef fmi3Status fmi3GetVariableDependenciesTYPE(fmi3Instance instance,
                                                   fmi3ValueReference dependent,
                                                   size_t elementIndicesOfDependent[],
                                                   fmi3ValueReference independents[],
                                                   size_t elementIndicesOfIndependents[],
                                                   fmi3DependencyKind dependencyKinds[],
                                                   size_t nDependencies);

/* Getting and setting the complete FMU state */
typedef fmi3Status fmi3GetFMUStateTYPE(fmi3Instance instance, fmi3FMUState* FMUState);

typedef fmi3Status fmi3SetFMUStateTYPE(fmi3Instance instance, fmi3FMUState FMUState);

typedef fmi3Status fmi3FreeFMUStateTYPE(fmi3Instance instance, fmi3FMUState* FMUState);

typedef fmi3Status fmi3SerializedFMUStateSizeTYPE(fmi3Instance instance,
                                                  fmi3FMUState FMUState,
                                                  size_t* size);

typedef fmi3Status fmi3SerializeFMUStateTYPE(fmi3Instance instance,
                                             fmi3FMUState FMUState,
                                             fmi3Byte serializedState[],
                                             size_t size);

typedef fmi3Status fmi3DeserializeFMUStateTYPE(fmi3Instance instance,
                                               const fmi3Byte serializedState[],
                                               size_t size,
                                               fmi3FMUState* FMUState);

/* Partial derivatives */
typedef fmi3Status fmi3GetDirectionalDerivativeTYPE(fmi3Instance instance,
                                                    const fmi3ValueReference unknowns[],
                                                    size_t nUnknowns,
                                                    const fmi3ValueReference knowns[],
                                                    size_t nKnowns,
                                                    const fmi3Float64 seed[],
                                                    size_t nSeed,
                                                    fmi3Float64 sensitivity[],
                                                    size_t nSensitivity);

typedef fmi3Status fmi3GetAdjointDerivativeTYPE(fmi3Instance instance,
                                                const fmi3ValueReference unknowns[],
                                                size_t nUnknowns,
                                                const fmi3ValueReference knowns[],
                                                size_t nKnowns,
                                                const fmi3Float64 seed[],
                                                size_t nSeed,
                                                fmi3Float64 sensitivity[],
                                                size_t nSensitivity);

/* Configuration / Reconfiguration Mode (structural parameters) */
typedef fmi3Status fmi3EnterConfigurationModeTYPE(fmi3Instance instance);

typedef fmi3Status fmi3ExitConfigurationModeTYPE(fmi3Instance instance);

/* Clock intervals and shifts (no nValues: Clocks are scalar) */
typedef fmi3Status fmi3GetIntervalDecimalTYPE(fmi3Instance instance,
                                              const fmi3ValueReference valueReferences[],
                                              size_t nValueReferences,
                                              fmi3Float64 intervals[],
                                              fmi3IntervalQualifier qualifiers[]);

typedef fmi3Status fmi3GetIntervalFractionTYPE(fmi3Instance instance,
                                               const fmi3ValueReference valueReferences[],
                                               size_t nValueReferences,
                                               fmi3UInt64 counters[],
                                               fmi3UInt64 resolutions[],
                                               fmi3IntervalQualifier qualifiers[]);

typedef fmi3Status fmi3GetShiftDecimalTYPE(fmi3Instance instance,
                                           const fmi3ValueReference valueReferences[],
                                           size_t nValueReferences,
                                           fmi3Float64 shifts[]);

typedef fmi3Status fmi3GetShiftFractionTYPE(fmi3Instance instance,
                                            const fmi3ValueReference valueReferences[],
                                            size_t nValueReferences,
                                            fmi3UInt64 counters[],
                                            fmi3UInt64 resolutions[]);

typedef fmi3Status fmi3SetIntervalDecimalTYPE(fmi3Instance instance,
                                              const fmi3ValueReference valueReferences[],
                                              size_t nValueReferences,
                                              const fmi3Float64 intervals[]);

typedef fmi3Status fmi3SetIntervalFractionTYPE(fmi3Instance instance,
                                               const fmi3ValueReference valueReferences[],
                                               size_t nValueReferences,
                                               const fmi3UInt64 counters[],
                                               const fmi3UInt64 resolutions[]);

typedef fmi3Status fmi3SetShiftDecimalTYPE(fmi3Instance instance,
                                           const fmi3ValueReference valueReferences[],
                                           size_t nValueReferences,
                                           const fmi3Float64 shifts[]);

typedef fmi3Status fmi3SetShiftFractionTYPE(fmi3Instance instance,
                                            const fmi3ValueReference valueReferences[],
                                            size_t nValueReferences,
                                            const fmi3UInt64 counters[],
                                            const fmi3UInt64 resolutions[]);

/* Discrete states (Event Mode) */
typedef fmi3Status fmi3EvaluateDiscreteStatesTYPE(fmi3Instance instance);

typedef fmi3Status fmi3UpdateDiscreteStatesTYPE(fmi3Instance instance,
                                                fmi3Boolean* discreteStatesNeedUpdate,
                                                fmi3Boolean* terminateSimulation,
                                                fmi3Boolean* nominalsOfContinuousStatesChanged,
                                                fmi3Boolean* valuesOfContinuousStatesChanged,
                                                fmi3Boolean* nextEventTimeDefined,
                                                fmi3Float64* nextEventTime);

/* ---------------------------------------------------------------------------------------------
 * Function types: Co-Simulation
 * ------------------------------------------------------------------------------------------- */

typedef fmi3Status fmi3EnterStepModeTYPE(fmi3Instance instance);

/* orders[i]: order (>= 1) of the derivative of variable valueReferences[i]. */
typedef fmi3Status fmi3GetOutputDerivativesTYPE(fmi3Instance instance,
                                                const fmi3ValueReference valueReferences[],
                                                size_t nValueReferences,
                                                const fmi3Int32 orders[],
                                                fmi3Float64 values[],
                                                size_t nValues);

/* Advance from currentCommunicationPoint by communicationStepSize (> 0). */
typedef fmi3Status fmi3DoStepTYPE(fmi3Instance instance,
                                  fmi3Float64 currentCommunicationPoint,
                                  fmi3Float64 communicationStepSize,
                                  fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                  fmi3Boolean* eventHandlingNeeded,
                                  fmi3Boolean* terminateSimulation,
                                  fmi3Boolean* earlyReturn,
                                  fmi3Float64* lastSuccessfulTime);

/* ---------------------------------------------------------------------------------------------
 * Exported functions (plain names, no prefix). Declared through the TYPE typedefs so that a
 * definition with a different signature is a compile error.
 * ------------------------------------------------------------------------------------------- */

#ifndef EHPT_FMI3_NO_PROTOTYPES

/* Common */
EHPT_FMI_EXPORT fmi3GetVersionTYPE fmi3GetVersion;
EHPT_FMI_EXPORT fmi3SetDebugLoggingTYPE fmi3SetDebugLogging;
EHPT_FMI_EXPORT fmi3InstantiateCoSimulationTYPE fmi3InstantiateCoSimulation;
EHPT_FMI_EXPORT fmi3FreeInstanceTYPE fmi3FreeInstance;
EHPT_FMI_EXPORT fmi3EnterInitializationModeTYPE fmi3EnterInitializationMode;
EHPT_FMI_EXPORT fmi3ExitInitializationModeTYPE fmi3ExitInitializationMode;
EHPT_FMI_EXPORT fmi3EnterEventModeTYPE fmi3EnterEventMode;
EHPT_FMI_EXPORT fmi3TerminateTYPE fmi3Terminate;
EHPT_FMI_EXPORT fmi3ResetTYPE fmi3Reset;

EHPT_FMI_EXPORT fmi3GetFloat32TYPE fmi3GetFloat32;
EHPT_FMI_EXPORT fmi3GetFloat64TYPE fmi3GetFloat64;
EHPT_FMI_EXPORT fmi3GetInt8TYPE fmi3GetInt8;
EHPT_FMI_EXPORT fmi3GetUInt8TYPE fmi3GetUInt8;
EHPT_FMI_EXPORT fmi3GetInt16TYPE fmi3GetInt16;
EHPT_FMI_EXPORT fmi3GetUInt16TYPE fmi3GetUInt16;
EHPT_FMI_EXPORT fmi3GetInt32TYPE fmi3GetInt32;
EHPT_FMI_EXPORT fmi3GetUInt32TYPE fmi3GetUInt32;
EHPT_FMI_EXPORT fmi3GetInt64TYPE fmi3GetInt64;
EHPT_FMI_EXPORT fmi3GetUInt64TYPE fmi3GetUInt64;
EHPT_FMI_EXPORT fmi3GetBooleanTYPE fmi3GetBoolean;
EHPT_FMI_EXPORT fmi3GetStringTYPE fmi3GetString;
EHPT_FMI_EXPORT fmi3GetBinaryTYPE fmi3GetBinary;
EHPT_FMI_EXPORT fmi3GetClockTYPE fmi3GetClock;

EHPT_FMI_EXPORT fmi3SetFloat32TYPE fmi3SetFloat32;
EHPT_FMI_EXPORT fmi3SetFloat64TYPE fmi3SetFloat64;
EHPT_FMI_EXPORT fmi3SetInt8TYPE fmi3SetInt8;
EHPT_FMI_EXPORT fmi3SetUInt8TYPE fmi3SetUInt8;
EHPT_FMI_EXPORT fmi3SetInt16TYPE fmi3SetInt16;
EHPT_FMI_EXPORT fmi3SetUInt16TYPE fmi3SetUInt16;
EHPT_FMI_EXPORT fmi3SetInt32TYPE fmi3SetInt32;
EHPT_FMI_EXPORT fmi3SetUInt32TYPE fmi3SetUInt32;
EHPT_FMI_EXPORT fmi3SetInt64TYPE fmi3SetInt64;
EHPT_FMI_EXPORT fmi3SetUInt64TYPE fmi3SetUInt64;
EHPT_FMI_EXPORT fmi3SetBooleanTYPE fmi3SetBoolean;
EHPT_FMI_EXPORT fmi3SetStringTYPE fmi3SetString;
EHPT_FMI_EXPORT fmi3SetBinaryTYPE fmi3SetBinary;
EHPT_FMI_EXPORT fmi3SetClockTYPE fmi3SetClock;

EHPT_FMI_EXPORT fmi3GetNumberOfVariableDependenciesTYPE fmi3GetNumberOfVariableDependencies;
EHPT_FMI_EXPORT fmi3GetVariableDependenciesTYPE fmi3GetVariableDependencies;

EHPT_FMI_EXPORT fmi3GetFMUStateTYPE fmi3GetFMUState;
EHPT_FMI_EXPORT fmi3SetFMUStateTYPE fmi3SetFMUState;
EHPT_FMI_EXPORT fmi3FreeFMUStateTYPE fmi3FreeFMUState;
EHPT_FMI_EXPORT fmi3SerializedFMUStateSizeTYPE fmi3SerializedFMUStateSize;
EHPT_FMI_EXPORT fmi3SerializeFMUStateTYPE fmi3SerializeFMUState;
EHPT_FMI_EXPORT fmi3DeserializeFMUStateTYPE fmi3DeserializeFMUState;

EHPT_FMI_EXPORT fmi3GetDirectionalDerivativeTYPE fmi3GetDirectionalDerivative;
EHPT_FMI_EXPORT fmi3GetAdjointDerivativeTYPE fmi3GetAdjointDerivative;

EHPT_FMI_EXPORT fmi3EnterConfigurationModeTYPE fmi3EnterConfigurationMode;
EHPT_FMI_EXPORT fmi3ExitConfigurationModeTYPE fmi3ExitConfigurationMode;

EHPT_FMI_EXPORT fmi3GetIntervalDecimalTYPE fmi3GetIntervalDecimal;
EHPT_FMI_EXPORT fmi3GetIntervalFractionTYPE fmi3GetIntervalFraction;
EHPT_FMI_EXPORT fmi3GetShiftDecimalTYPE fmi3GetShiftDecimal;
EHPT_FMI_EXPORT fmi3GetShiftFractionTYPE fmi3GetShiftFraction;
EHPT_FMI_EXPORT fmi3SetIntervalDecimalTYPE fmi3SetIntervalDecimal;
EHPT_FMI_EXPORT fmi3SetIntervalFractionTYPE fmi3SetIntervalFraction;
EHPT_FMI_EXPORT fmi3SetShiftDecimalTYPE fmi3SetShiftDecimal;
EHPT_FMI_EXPORT fmi3SetShiftFractionTYPE fmi3SetShiftFraction;

EHPT_FMI_EXPORT fmi3EvaluateDiscreteStatesTYPE fmi3EvaluateDiscreteStates;
EHPT_FMI_EXPORT fmi3UpdateDiscreteStatesTYPE fmi3UpdateDiscreteStates;

/* Co-Simulation */
EHPT_FMI_EXPORT fmi3EnterStepModeTYPE fmi3EnterStepMode;
EHPT_FMI_EXPORT fmi3GetOutputDerivativesTYPE fmi3GetOutputDerivatives;
EHPT_FMI_EXPORT fmi3DoStepTYPE fmi3DoStep;

#endif /* EHPT_FMI3_NO_PROTOTYPES */

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* EHPT_FMI3_API_H */
