/* runtime/src/fmu/fmi2.h -- the FMI 2.0 co-simulation interface, as much of it as a
 * co-simulation slave exports, written for indicial from the text of the standard
 * ("Functional Mock-up Interface for Model Exchange and Co-Simulation", version 2.0,
 * sections 2.1.2-2.1.9 and 4.2). Not a copy of the standard's headers: the names, types and
 * values below are the binary interface the standard fixes, so any FMI 2.0 importer finds them.
 *
 * What the standard fixes (and this file therefore must keep)
 * ----------------------------------------------------------
 * - The platform types (fmi2TypesPlatform "default"): fmi2Real is double, fmi2Integer and
 *   fmi2Boolean are int, fmi2Char is char, fmi2String is const char*, fmi2ValueReference is
 *   unsigned int, fmi2Byte is char.
 * - The enumerations' numeric values (fmi2Status 0..5, fmi2Type 0..1, fmi2StatusKind 0..3).
 * - The layout of fmi2CallbackFunctions (logger, allocateMemory, freeMemory, stepFinished,
 *   componentEnvironment, in that order).
 * - The exported function names without prefix: a binary FMU's shared library exports
 *   fmi2Instantiate, fmi2DoStep, ... as plain C symbols (a prefix is for source FMUs only).
 * Functions of Model Exchange only (fmi2SetTime, fmi2GetDerivatives, ...) are not declared:
 * a co-simulation-only FMU does not export them.
 */
#ifndef INDICIAL_FMU_FMI2_H
#define INDICIAL_FMU_FMI2_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(_WIN32)
#define FMI2_Export __declspec(dllexport)
#else
#define FMI2_Export __attribute__((visibility("default")))
#endif

/* Platform types (2.1.2). */
typedef void* fmi2Component;
typedef void* fmi2ComponentEnvironment;
typedef void* fmi2FMUstate;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
typedef char fmi2Char;
typedef const fmi2Char* fmi2String;
typedef char fmi2Byte;

#define fmi2True 1
#define fmi2False 0
#define fmi2TypesPlatform "default"
#define fmi2Version "2.0"

/* Status returned by every function that returns a status (2.1.3). */
typedef enum {
  fmi2OK = 0,
  fmi2Warning = 1,
  fmi2Discard = 2,
  fmi2Error = 3,
  fmi2Fatal = 4,
  fmi2Pending = 5
} fmi2Status;

/* Kind of FMU asked for by fmi2Instantiate (2.1.5). */
typedef enum { fmi2ModelExchange = 0, fmi2CoSimulation = 1 } fmi2Type;

/* What fmi2Get*Status asks about (4.2.3). */
typedef enum {
  fmi2DoStepStatus = 0,
  fmi2PendingStatus = 1,
  fmi2LastSuccessfulTime = 2,
  fmi2Terminated = 3
} fmi2StatusKind;

/* Callbacks the importer gives fmi2Instantiate (2.1.5). In FMI 2.0 allocateMemory and
 * freeMemory must be given (calloc / free semantics); stepFinished is for asynchronous
 * doStep only and may be NULL. */
typedef void (*fmi2CallbackLogger)(fmi2ComponentEnvironment environment, fmi2String instance_name,
                                   fmi2Status status, fmi2String category, fmi2String message, ...);
typedef void* (*fmi2CallbackAllocateMemory)(size_t count, size_t size);
typedef void (*fmi2CallbackFreeMemory)(void* object);
typedef void (*fmi2StepFinished)(fmi2ComponentEnvironment environment, fmi2Status status);

typedef struct {
  const fmi2CallbackLogger logger;
  const fmi2CallbackAllocateMemory allocateMemory;
  const fmi2CallbackFreeMemory freeMemory;
  const fmi2StepFinished stepFinished;
  const fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

/* Common functions (2.1.4 - 2.1.9). */
FMI2_Export const char* fmi2GetTypesPlatform(void);
FMI2_Export const char* fmi2GetVersion(void);
FMI2_Export fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean logging_on,
                                           size_t n_categories, const fmi2String categories[]);
FMI2_Export fmi2Component fmi2Instantiate(fmi2String instance_name, fmi2Type fmu_type,
                                          fmi2String fmu_guid, fmi2String fmu_resource_location,
                                          const fmi2CallbackFunctions* functions,
                                          fmi2Boolean visible, fmi2Boolean logging_on);
FMI2_Export void fmi2FreeInstance(fmi2Component c);
FMI2_Export fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolerance_defined,
                                           fmi2Real tolerance, fmi2Real start_time,
                                           fmi2Boolean stop_time_defined, fmi2Real stop_time);
FMI2_Export fmi2Status fmi2EnterInitializationMode(fmi2Component c);
FMI2_Export fmi2Status fmi2ExitInitializationMode(fmi2Component c);
FMI2_Export fmi2Status fmi2Terminate(fmi2Component c);
FMI2_Export fmi2Status fmi2Reset(fmi2Component c);

FMI2_Export fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                   fmi2Real value[]);
FMI2_Export fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      fmi2Integer value[]);
FMI2_Export fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      fmi2Boolean value[]);
FMI2_Export fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                     fmi2String value[]);
FMI2_Export fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                   const fmi2Real value[]);
FMI2_Export fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      const fmi2Integer value[]);
FMI2_Export fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      const fmi2Boolean value[]);
FMI2_Export fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                     const fmi2String value[]);

FMI2_Export fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* state);
FMI2_Export fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state);
FMI2_Export fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate* state);
FMI2_Export fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t* size);
FMI2_Export fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state,
                                             fmi2Byte serialized[], size_t size);
FMI2_Export fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serialized[],
                                               size_t size, fmi2FMUstate* state);
FMI2_Export fmi2Status fmi2GetDirectionalDerivative(fmi2Component c,
                                                    const fmi2ValueReference unknown[], size_t n_unknown,
                                                    const fmi2ValueReference known[], size_t n_known,
                                                    const fmi2Real known_delta[],
                                                    fmi2Real unknown_delta[]);

/* Co-simulation functions (4.2.2 - 4.2.4). */
FMI2_Export fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                                   size_t nvr, const fmi2Integer order[],
                                                   const fmi2Real value[]);
FMI2_Export fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                                    size_t nvr, const fmi2Integer order[],
                                                    fmi2Real value[]);
FMI2_Export fmi2Status fmi2DoStep(fmi2Component c, fmi2Real current_communication_point,
                                  fmi2Real communication_step_size,
                                  fmi2Boolean no_set_fmu_state_prior_to_current_point);
FMI2_Export fmi2Status fmi2CancelStep(fmi2Component c);
FMI2_Export fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Status* value);
FMI2_Export fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Real* value);
FMI2_Export fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind kind,
                                            fmi2Integer* value);
FMI2_Export fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind kind,
                                            fmi2Boolean* value);
FMI2_Export fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind kind,
                                           fmi2String* value);

#ifdef __cplusplus
}
#endif

#endif /* INDICIAL_FMU_FMI2_H */
