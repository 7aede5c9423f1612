/* fmi2.c: depsim's FMI 2.0 Co-Simulation wrapper around the integrator core (docs/fmu.md).
 *
 * One instance keeps one open run (dep_open) from fmi2ExitInitializationMode to
 * fmi2Terminate; fmi2DoStep advances it with the integrator's own steps, latches, stops and
 * stick-slip inside. FMU time t is depsim time t - startTime. Every fmi2Error is logged
 * (category logError) and leaves the instance in its error state: only fmi2Get*, the status
 * functions, fmi2Reset and fmi2FreeInstance work then. No global state.
 *
 * The same source serves every model: an FMU's sources/ hold it beside the model's generated
 * model.h and fmu_variables.c (its GUID and the tables of its variables, fmu.h) and the core
 * under core/. The variables' values are got and set in fmi2_variables.c, the FMU state is
 * saved and put back in fmi2_state.c.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmu.h"
#include "model.h"

/* The names of the log categories (enum LOG_*, modelDescription.xml). */
static const char *const log_categories[] = {"logError", "logEvents", "logCalls"};

/* Format a message and hand it to the importer's logger; '#' is doubled, as FMI's logger
   reads "#r12#" as a variable reference. */
static void vlog_message(const fmu_instance *fmu, fmi2Status status, int category,
                         const char *format, va_list args)
{
    char text[2048], escaped[4096];
    size_t k = 0;
    vsnprintf(text, sizeof text, format, args);
    for (const char *c = text; *c && k + 2 < sizeof escaped; ++c) {
        if (*c == '#')
            escaped[k++] = '#';
        escaped[k++] = *c;
    }
    escaped[k] = '\0';
    int bit = 0;
    while ((1 << bit) != category)
        ++bit;
    fmu->logger(fmu->environment, fmu->name, status, log_categories[bit], "%s", escaped);
}

void fmu_log(const fmu_instance *fmu, int category, const char *format, ...)
{
    if (!(fmu->logging & (unsigned)category))
        return;
    va_list args;
    va_start(args, format);
    vlog_message(fmu, fmi2OK, category, format, args);
    va_end(args);
}

/* Report an error: logged (logError), the instance enters its error state. */
fmi2Status fmu_fail(fmu_instance *fmu, const char *format, ...)
{
    va_list args;
    va_start(args, format);
    vlog_message(fmu, fmi2Error, LOG_ERROR, format, args);
    va_end(args);
    fmu->phase = PHASE_ERROR;
    return fmi2Error;
}

static const char *phase_name(enum fmu_phase phase)
{
    switch (phase) {
    case PHASE_INSTANTIATED: return "instantiated";
    case PHASE_INITIALIZATION: return "initialization mode";
    case PHASE_STEPPING: return "step complete";
    case PHASE_TERMINATED: return "terminated";
    case PHASE_ERROR: return "error (after an earlier fmi2Error; fmi2Reset starts again)";
    }
    return "unknown";
}

/* The instance, if `function` may be called in its phase (a bit mask of enum fmu_phase);
   else NULL, after reporting why (a NULL instance cannot report). */
fmu_instance *fmu_enter(fmi2Component c, const char *function, unsigned phases)
{
    fmu_instance *fmu = (fmu_instance *)c;
    if (fmu == NULL)
        return NULL;
    if (!(phases & (unsigned)fmu->phase)) {
        fmu_fail(fmu, "%s is not allowed in state %s", function, phase_name(fmu->phase));
        return NULL;
    }
    fmu_log(fmu, LOG_CALLS, "%s", function);
    return fmu;
}

static void clear_results(fmu_instance *fmu)
{
    for (int j = 0; j < MODEL_NOUT; ++j)
        fmu->outputs[j] = NAN;
    for (int h = 0; h < MODEL_NH; ++h) {
        dep_hinge_state unknown = {NAN, NAN, NAN, NAN, NAN, NAN, 0, 0};
        fmu->hinges[h] = unknown;
    }
}

/* The run's outputs and hinge observables at its current state; logs latches that engaged
   since the last refresh (logEvents). */
static void refresh(fmu_instance *fmu)
{
    int was_latched[MODEL_NH + 1];
    for (int h = 0; h < MODEL_NH; ++h)
        was_latched[h] = fmu->hinges[h].latched;
    dep_outputs(fmu->run, fmu->outputs);
    dep_hinge_states(fmu->run, fmu->hinges);
    for (int h = 0; h < MODEL_NH; ++h)
        if (fmu->hinges[h].latched && !was_latched[h])
            fmu_log(fmu, LOG_EVENTS, "hinge %s latched (by t = %.9g s)",
                        depsim_model.hinge_names[h], fmu->time);
}

/* Open the run with the parameters and inputs as they are now (the initial state at
   startTime). */
static fmi2Status open_run(fmu_instance *fmu)
{
    dep_settings settings = dep_default_settings(&depsim_model);
    dep_error error;
    if (fmu->tolerance_defined)
        settings.tol = fmu->tolerance;
    settings.t_end = fmu->stop_defined ? fmu->stop_time - fmu->start_time : INFINITY;
    dep_close(fmu->run);
    fmu->run = NULL;
    if (dep_open(&depsim_model, fmu->params, &settings, &fmu->run, &error) != DEP_OK) {
        fmu->run = NULL;
        clear_results(fmu);
        return fmu_fail(fmu, "%s", error.message);
    }
    fmu->run_current = 1;
    fmu->inputs_changed = 0;
    refresh(fmu);
    return fmi2OK;
}

/* In initialization mode, outputs follow the parameters and inputs set so far. */
fmi2Status fmu_current_results(fmu_instance *fmu)
{
    if (fmu->phase == PHASE_INITIALIZATION && !fmu->run_current)
        return open_run(fmu);
    return fmi2OK;
}

static void reset_values(fmu_instance *fmu)
{
    for (int k = 0; k < MODEL_NP; ++k)
        fmu->params[k] = depsim_model.parameter_defaults[k];
    dep_close(fmu->run);
    fmu->run = NULL;
    fmu->run_current = 0;
    fmu->inputs_changed = 0;
    fmu->experiment_set = 0;
    fmu->start_time = fmu->stop_time = fmu->time = fmu->last_successful_time = 0.0;
    fmu->tolerance = 0.0;
    fmu->stop_defined = fmu->tolerance_defined = 0;
    clear_results(fmu);
    fmu->phase = PHASE_INSTANTIATED;
}

static int nonblank(const char *text)
{
    for (; text != NULL && *text; ++text)
        if (*text != ' ' && *text != '\t' && *text != '\n' && *text != '\r')
            return 1;
    return 0;
}

/* ---- inquiry ----------------------------------------------------------------------------- */

const char *fmi2GetTypesPlatform(void)
{
    return fmi2TypesPlatform;
}

const char *fmi2GetVersion(void)
{
    return fmi2Version;
}

/* ---- creation, destruction, logging ------------------------------------------------------ */

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn)
{
    (void)fmuResourceLocation; /* the FMU reads no resources */
    (void)visible;             /* it has no window */
    if (functions == NULL || functions->logger == NULL)
        return NULL; /* nothing to report through */
    fmi2CallbackLogger logger = functions->logger;
    void *environment = functions->componentEnvironment;
    const char *name = nonblank(instanceName) ? instanceName : fmu_instance_prefix;
    if (!nonblank(instanceName)) {
        logger(environment, name, fmi2Error, "logError", "%s",
               "fmi2Instantiate: instanceName must be a non-empty string");
        return NULL;
    }
    if (fmuType != fmi2CoSimulation) {
        logger(environment, name, fmi2Error, "logError", "%s",
               "fmi2Instantiate: this FMU supports Co-Simulation only (no Model Exchange)");
        return NULL;
    }
    if (fmuGUID == NULL || strcmp(fmuGUID, fmu_guid) != 0) {
        logger(environment, name, fmi2Error, "logError",
               "fmi2Instantiate: GUID %s does not match this binary's %s"
               " (modelDescription.xml and binary differ)",
               fmuGUID == NULL ? "(null)" : fmuGUID, fmu_guid);
        return NULL;
    }
    fmu_instance *fmu = calloc(1, sizeof *fmu);
    if (fmu != NULL) {
        fmu->name = malloc(strlen(instanceName) + 1);
        fmu->params = calloc(MODEL_NP + 1, sizeof(double));
        fmu->outputs = calloc(MODEL_NOUT + 1, sizeof(double));
        fmu->hinges = calloc(MODEL_NH + 1, sizeof(dep_hinge_state));
        fmu->input_values = calloc(2 * fmu_ni + 2, sizeof(double));
        fmu->trial = calloc(MODEL_NP + 1, sizeof(double));
        fmu->given = calloc(MODEL_NP + 1, 1);
    }
    if (fmu == NULL || fmu->name == NULL || fmu->params == NULL || fmu->outputs == NULL
        || fmu->hinges == NULL || fmu->input_values == NULL || fmu->trial == NULL
        || fmu->given == NULL) {
        logger(environment, name, fmi2Error, "logError", "%s",
               "fmi2Instantiate: out of memory");
        fmi2FreeInstance(fmu);
        return NULL;
    }
    strcpy(fmu->name, instanceName);
    fmu->input_rates = fmu->input_values + fmu_ni + 1;
    fmu->logger = logger;
    fmu->environment = environment;
    fmu->logging = loggingOn ? LOG_ALL : 0u;
    reset_values(fmu);
    return fmu;
}

void fmi2FreeInstance(fmi2Component c)
{
    fmu_instance *fmu = (fmu_instance *)c;
    if (fmu == NULL)
        return;
    dep_close(fmu->run);
    free(fmu->name);
    free(fmu->params);
    free(fmu->outputs);
    free(fmu->hinges);
    free(fmu->input_values);
    free(fmu->trial);
    free(fmu->given);
    free(fmu);
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    fmu_instance *fmu = fmu_enter(c, "fmi2SetDebugLogging", ANY_PHASE);
    if (fmu == NULL)
        return fmi2Error;
    if (nCategories == 0) {
        fmu->logging = loggingOn ? LOG_ALL : 0u;
        return fmi2OK;
    }
    if (categories == NULL)
        return fmu_fail(fmu, "fmi2SetDebugLogging: categories is NULL");
    for (size_t k = 0; k < nCategories; ++k) {
        unsigned bit = 0;
        for (int j = 0; j < 3; ++j)
            if (categories[k] != NULL && strcmp(categories[k], log_categories[j]) == 0)
                bit = 1u << j;
        if (bit == 0)
            return fmu_fail(fmu, "fmi2SetDebugLogging: unknown log category '%s' (logError, "
                        "logEvents, logCalls)", categories[k] ? categories[k] : "(null)");
        fmu->logging = loggingOn ? fmu->logging | bit : fmu->logging & ~bit;
    }
    return fmi2OK;
}

/* ---- initialization, termination, reset ------------------------------------------------- */

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    fmu_instance *fmu = fmu_enter(c, "fmi2SetupExperiment", PHASE_INSTANTIATED);
    if (fmu == NULL)
        return fmi2Error;
    if (!isfinite(startTime))
        return fmu_fail(fmu, "fmi2SetupExperiment: startTime %g is not a finite number",
                    startTime);
    if (stopTimeDefined && !(stopTime > startTime && isfinite(stopTime)))
        return fmu_fail(fmu, "fmi2SetupExperiment: stopTime %.17g must be a finite time after "
                    "startTime %.17g", stopTime, startTime);
    if (toleranceDefined && !(tolerance > 0.0 && tolerance < 1.0))
        return fmu_fail(fmu, "fmi2SetupExperiment: tolerance %g must lie between 0 and 1",
                    tolerance);
    fmu->tolerance_defined = toleranceDefined != 0;
    fmu->tolerance = tolerance;
    fmu->start_time = fmu->time = fmu->last_successful_time = startTime;
    fmu->stop_defined = stopTimeDefined != 0;
    fmu->stop_time = stopTime;
    fmu->experiment_set = 1;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    fmu_instance *fmu = fmu_enter(c, "fmi2EnterInitializationMode", PHASE_INSTANTIATED);
    if (fmu == NULL)
        return fmi2Error;
    if (!fmu->experiment_set)
        return fmu_fail(fmu, "fmi2EnterInitializationMode: call fmi2SetupExperiment first");
    fmu->phase = PHASE_INITIALIZATION;
    fmu->run_current = 0;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    fmu_instance *fmu = fmu_enter(c, "fmi2ExitInitializationMode", PHASE_INITIALIZATION);
    if (fmu == NULL)
        return fmi2Error;
    if (!fmu->run_current && open_run(fmu) != fmi2OK)
        return fmi2Error;
    fmu->phase = PHASE_STEPPING;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c)
{
    fmu_instance *fmu = fmu_enter(c, "fmi2Terminate", PHASE_STEPPING);
    if (fmu == NULL)
        return fmi2Error;
    dep_close(fmu->run); /* the outputs at the last time stay readable */
    fmu->run = NULL;
    fmu->phase = PHASE_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c)
{
    fmu_instance *fmu = fmu_enter(c, "fmi2Reset", ANY_PHASE);
    if (fmu == NULL)
        return fmi2Error;
    reset_values(fmu);
    return fmi2OK;
}

/* ---- unsupported: directional and output derivatives, asynchronous steps ----------------- */

fmi2Status fmu_unsupported(fmi2Component c, const char *function, const char *why)
{
    fmu_instance *fmu = (fmu_instance *)c;
    if (fmu == NULL)
        return fmi2Error;
    return fmu_fail(fmu, "%s is not supported: %s", function, why);
}

/* ---- Co-Simulation ------------------------------------------------------------------------ */

/* Hand the inputs to the run: u(s) = value + rate (s - now) from now on. */
static fmi2Status send_inputs(fmu_instance *fmu)
{
    dep_error error;
    for (int k = 0; k < fmu_ni; ++k) {
        fmu->input_values[k] = fmu->params[fmu_input_slots[k]];
        fmu->input_rates[k] = fmu->params[fmu_input_slots[k] + 1];
    }
    if (dep_set_inputs(fmu->run, fmu->input_values, fmu->input_rates, &error) != DEP_OK)
        return fmu_fail(fmu, "%s", error.message);
    fmu->inputs_changed = 0;
    return fmi2OK;
}

/* After a step of length h, each input's value is where its rate took it (the run keeps
   the same law: nothing to send). */
static void advance_inputs(fmu_instance *fmu, double h)
{
    for (int k = 0; k < fmu_ni; ++k)
        fmu->params[fmu_input_slots[k]] += fmu->params[fmu_input_slots[k] + 1] * h;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    (void)noSetFMUStatePriorToCurrentPoint; /* a state keeps what it needs (fmi2_state.c) */
    fmu_instance *fmu = fmu_enter(c, "fmi2DoStep", PHASE_STEPPING);
    if (fmu == NULL)
        return fmi2Error;
    double t0 = currentCommunicationPoint, h = communicationStepSize;
    double slack = 1e-9 * fmax(1.0, fabs(fmu->time));
    if (!(h > 0.0) || !isfinite(h))
        return fmu_fail(fmu, "fmi2DoStep: communicationStepSize %g must be a positive number", h);
    if (!(fabs(t0 - fmu->time) <= slack))
        return fmu_fail(fmu, "fmi2DoStep: currentCommunicationPoint %.17g is not the FMU's time "
                    "%.17g", t0, fmu->time);
    double t1 = t0 + h;
    if (fmu->stop_defined && t1 > fmu->stop_time) {
        if (t1 - fmu->stop_time > slack)
            return fmu_fail(fmu, "fmi2DoStep: the step to t = %.17g passes stopTime %.17g "
                        "(fmi2SetupExperiment)", t1, fmu->stop_time);
        t1 = fmu->stop_time;
    }
    if (fmu->inputs_changed && send_inputs(fmu) != fmi2OK)
        return fmi2Error;
    double target = t1 - fmu->start_time;
    if (target < dep_time(fmu->run))
        target = dep_time(fmu->run);
    dep_error error;
    if (dep_advance(fmu->run, target, &error) != DEP_OK)
        return fmu_fail(fmu, "%s", error.message); /* the values stay those of the last step */
    advance_inputs(fmu, t1 - fmu->time);
    fmu->time = fmu->last_successful_time = t1;
    refresh(fmu);
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c)
{
    return fmu_unsupported(c, "fmi2CancelStep",
                       "fmi2DoStep runs synchronously, so no step is ever pending");
}

#define STATUS_PHASES (PHASE_STEPPING | PHASE_TERMINATED | PHASE_ERROR)

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
{
    fmu_instance *fmu = fmu_enter(c, "fmi2GetStatus", STATUS_PHASES);
    if (fmu == NULL)
        return fmi2Error;
    if (value == NULL)
        return fmu_fail(fmu, "fmi2GetStatus: value is NULL");
    (void)s; /* fmi2DoStepStatus only follows fmi2Pending, which never happens */
    return fmi2Discard;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    fmu_instance *fmu = fmu_enter(c, "fmi2GetRealStatus", STATUS_PHASES);
    if (fmu == NULL)
        return fmi2Error;
    if (value == NULL)
        return fmu_fail(fmu, "fmi2GetRealStatus: value is NULL");
    if (s != fmi2LastSuccessfulTime)
        return fmi2Discard;
    *value = fmu->last_successful_time;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value)
{
    fmu_instance *fmu = fmu_enter(c, "fmi2GetIntegerStatus", STATUS_PHASES);
    if (fmu == NULL)
        return fmi2Error;
    if (value == NULL)
        return fmu_fail(fmu, "fmi2GetIntegerStatus: value is NULL");
    (void)s; /* no Integer status is defined */
    return fmi2Discard;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value)
{
    fmu_instance *fmu = fmu_enter(c, "fmi2GetBooleanStatus", STATUS_PHASES);
    if (fmu == NULL)
        return fmi2Error;
    if (value == NULL)
        return fmu_fail(fmu, "fmi2GetBooleanStatus: value is NULL");
    if (s != fmi2Terminated)
        return fmi2Discard;
    *value = fmi2False; /* the slave never asks to end the run */
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value)
{
    fmu_instance *fmu = fmu_enter(c, "fmi2GetStringStatus", STATUS_PHASES);
    if (fmu == NULL)
        return fmi2Error;
    if (value == NULL)
        return fmu_fail(fmu, "fmi2GetStringStatus: value is NULL");
    (void)s; /* fmi2PendingStatus only follows fmi2Pending, which never happens */
    return fmi2Discard;
}
