/* fmi2.h: the types and functions of FMI 2.0 for Co-Simulation that depsim's FMU wrapper
 * (fmi2.c) implements, declared after the FMI 2.0 specification (sections 2.1 and 4.2), with
 * its "default" platform types. An FMU shipped as a shared object exports the functions
 * under their plain names (no FMI2_FUNCTION_PREFIX); only these names are visible.
 *
 * See docs/fmu.md.
 */
#ifndef DEPSIM_FMI2_H
#define DEPSIM_FMI2_H

#include <stddef.h>

#define fmi2TypesPlatform "default"
#define fmi2Version "2.0"

#if defined(__GNUC__) || defined(__clang__)
#define DEPSIM_FMI2_EXPORT __attribute__((visibility("default")))
#else
#define DEPSIM_FMI2_EXPORT
#endif

/* ---- platform types -------------------------------------------------------------------- */

typedef void *fmi2Component;            /* an instance of the FMU */
typedef void *fmi2ComponentEnvironment; /* the importer's, handed back to its logger */
typedef void *fmi2FMUstate;             /* a saved state (not supported here) */
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
typedef char fmi2Char;
typedef const fmi2Char *fmi2String;
typedef char fmi2Byte;

#define fmi2True 1
#define fmi2False 0

/* ---- status, kinds and callbacks ------------------------------------------------------- */

typedef enum {
    fmi2OK,
    fmi2Warning,
    fmi2Discard,
    fmi2Error,
    fmi2Fatal,
    fmi2Pending
} fmi2Status;

typedef enum {
    fmi2ModelExchange,
    fmi2CoSimulation
} fmi2Type;

typedef enum {
    fmi2DoStepStatus,
    fmi2PendingStatus,
    fmi2LastSuccessfulTime,
    fmi2Terminated
} fmi2StatusKind;

typedef void (*fmi2CallbackLogger)(fmi2ComponentEnvironment environment,
                                   fmi2String instanceName, fmi2Status status,
                                   fmi2String category, fmi2String message, ...);
typedef void *(*fmi2CallbackAllocateMemory)(size_t nobj, size_t size);
typedef void (*fmi2CallbackFreeMemory)(void *obj);
typedef void (*fmi2StepFinished)(fmi2ComponentEnvironment environment, fmi2Status status);

typedef struct {
    fmi2CallbackLogger logger;
    fmi2CallbackAllocateMemory allocateMemory; /* unused: canNotUseMemoryManagementFunctions */
    fmi2CallbackFreeMemory freeMemory;         /* unused, likewise */
    fmi2StepFinished stepFinished;             /* unused: fmi2DoStep runs synchronously */
    fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

typedef struct {
    fmi2Boolean newDiscreteStatesNeeded;
    fmi2Boolean terminateSimulation;
    fmi2Boolean nominalsOfContinuousStatesChanged;
    fmi2Boolean valuesOfContinuousStatesChanged;
    fmi2Boolean nextEventTimeDefined;
    fmi2Real nextEventTime;
} fmi2EventInfo; /* Model Exchange only; declared for completeness */

/* ---- common functions (specification 2.1) ---------------------------------------------- */

DEPSIM_FMI2_EXPORT const char *fmi2GetTypesPlatform(void);
DEPSIM_FMI2_EXPORT const char *fmi2GetVersion(void);
DEPSIM_FMI2_EXPORT fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn,
                                                  size_t nCategories,
                                                  const fmi2String categories[]);
DEPSIM_FMI2_EXPORT fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType,
                                                 fmi2String fmuGUID,
                                                 fmi2String fmuResourceLocation,
                                                 const fmi2CallbackFunctions *functions,
                                                 fmi2Boolean visible, fmi2Boolean loggingOn);
DEPSIM_FMI2_EXPORT void fmi2FreeInstance(fmi2Component c);
DEPSIM_FMI2_EXPORT fmi2Status fmi2SetupExperiment(fmi2Component c,
                                                  fmi2Boolean toleranceDefined,
                                                  fmi2Real tolerance, fmi2Real startTime,
                                                  fmi2Boolean stopTimeDefined,
                                                  fmi2Real stopTime);
DEPSIM_FMI2_EXPORT fmi2Status fmi2EnterInitializationMode(fmi2Component c);
DEPSIM_FMI2_EXPORT fmi2Status fmi2ExitInitializationMode(fmi2Component c);
DEPSIM_FMI2_EXPORT fmi2Status fmi2Terminate(fmi2Component c);
DEPSIM_FMI2_EXPORT fmi2Status fmi2Reset(fmi2Component c);

DEPSIM_FMI2_EXPORT fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[],
                                          size_t nvr, fmi2Real value[]);
DEPSIM_FMI2_EXPORT fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[],
                                             size_t nvr, fmi2Integer value[]);
DEPSIM_FMI2_EXPORT fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[],
                                             size_t nvr, fmi2Boolean value[]);
DEPSIM_FMI2_EXPORT fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[],
                                            size_t nvr, fmi2String value[]);
DEPSIM_FMI2_EXPORT fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[],
                                          size_t nvr, const fmi2Real value[]);
DEPSIM_FMI2_EXPORT fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[],
                                             size_t nvr, const fmi2Integer value[]);
DEPSIM_FMI2_EXPORT fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[],
                                             size_t nvr, const fmi2Boolean value[]);
DEPSIM_FMI2_EXPORT fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[],
                                            size_t nvr, const fmi2String value[]);

DEPSIM_FMI2_EXPORT fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate);
DEPSIM_FMI2_EXPORT fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate);
DEPSIM_FMI2_EXPORT fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate);
DEPSIM_FMI2_EXPORT fmi2Status fmi2SerializedFMUstateSize(fmi2Component c,
                                                         fmi2FMUstate FMUstate, size_t *size);
DEPSIM_FMI2_EXPORT fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate,
                                                    fmi2Byte serializedState[], size_t size);
DEPSIM_FMI2_EXPORT fmi2Status fmi2DeSerializeFMUstate(fmi2Component c,
                                                      const fmi2Byte serializedState[],
                                                      size_t size, fmi2FMUstate *FMUstate);
DEPSIM_FMI2_EXPORT fmi2Status fmi2GetDirectionalDerivative(
    fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
    const fmi2ValueReference vKnown_ref[], size_t nKnown, const fmi2Real dvKnown[],
    fmi2Real dvUnknown[]);

/* ---- Co-Simulation (specification 4.2) -------------------------------------------------- */

DEPSIM_FMI2_EXPORT fmi2Status fmi2SetRealInputDerivatives(fmi2Component c,
                                                          const fmi2ValueReference vr[],
                                                          size_t nvr,
                                                          const fmi2Integer order[],
                                                          const fmi2Real value[]);
DEPSIM_FMI2_EXPORT fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c,
                                                           const fmi2ValueReference vr[],
                                                           size_t nvr,
                                                           const fmi2Integer order[],
                                                           fmi2Real value[]);
DEPSIM_FMI2_EXPORT fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                                         fmi2Real communicationStepSize,
                                         fmi2Boolean noSetFMUStatePriorToCurrentPoint);
DEPSIM_FMI2_EXPORT fmi2Status fmi2CancelStep(fmi2Component c);
DEPSIM_FMI2_EXPORT fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s,
                                            fmi2Status *value);
DEPSIM_FMI2_EXPORT fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s,
                                                fmi2Real *value);
DEPSIM_FMI2_EXPORT fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s,
                                                   fmi2Integer *value);
DEPSIM_FMI2_EXPORT fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s,
                                                   fmi2Boolean *value);
DEPSIM_FMI2_EXPORT fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s,
                                                  fmi2String *value);

#endif /* DEPSIM_FMI2_H */
