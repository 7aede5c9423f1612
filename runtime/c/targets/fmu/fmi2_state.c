/* fmi2_state.c: the FMU state (canGetAndSetFMUstate, canSerializeFMUstate): what an instance
 * is at one moment, saved, put back and written as bytes, so that a master can roll a
 * communication step back (docs/fmu.md, FMU state).
 *
 * A state is the wrapper's own values (its phase, the experiment, the parameters and inputs,
 * the time, the outputs at that time) and a snapshot of its open run (dep_save, depsim.h).
 * Put back into the instance it came from, whose run is still open, the run's memory is
 * copied back; anywhere else (another instance, a run closed since, bytes from elsewhere) the
 * run is opened again and its calls repeated (dep_restore). Either way the instance goes on
 * bit for bit as it went on from the save.
 */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "fmu.h"
#include "model.h"

#define STATE_MAGIC "DEPFMUS1"

typedef struct fmu_state {
    char magic[8];  /* STATE_MAGIC: a state of this wrapper */
    int32_t phase, experiment_set, stop_defined, tolerance_defined, run_current, inputs_changed;
    double start_time, stop_time, tolerance, time, last_successful_time;
    double params[MODEL_NP + 1];
    double outputs[MODEL_NOUT + 1];
    dep_hinge_state hinges[MODEL_NH + 1];
    dep_snapshot *run; /* NULL: no run was open */
} fmu_state;

/* The fields of an fmu_state kept as they are in the bytes (all but `run`). */
#define STATE_FIELDS offsetof(fmu_state, run)

static fmu_state *state_of(fmu_instance *fmu, const char *function, fmi2FMUstate state)
{
    fmu_state *s = (fmu_state *)state;
    if (s == NULL || memcmp(s->magic, STATE_MAGIC, 8) != 0) {
        fmu_fail(fmu, "%s: FMUstate is not a state of this FMU (NULL, freed, or another's)",
                 function);
        return NULL;
    }
    return s;
}

static void free_state(fmu_state *s)
{
    if (s != NULL) {
        dep_snapshot_free(s->run);
        memset(s->magic, 0, sizeof s->magic);
        free(s);
    }
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    const char *function = "fmi2GetFMUstate";
    fmu_instance *fmu = fmu_enter(c, function, PHASE_INSTANTIATED | PHASE_INITIALIZATION
                                               | PHASE_STEPPING | PHASE_TERMINATED);
    dep_error error;
    if (fmu == NULL)
        return fmi2Error;
    if (FMUstate == NULL)
        return fmu_fail(fmu, "%s: FMUstate is NULL", function);
    fmu_state *s = *FMUstate != NULL ? state_of(fmu, function, *FMUstate) : calloc(1, sizeof *s);
    if (s == NULL)
        return *FMUstate != NULL ? fmi2Error : fmu_fail(fmu, "%s: out of memory", function);
    dep_snapshot_free(s->run); /* a state given back to be taken again */
    s->run = NULL;
    if (fmu->run != NULL && dep_save(fmu->run, &s->run, &error) != DEP_OK) {
        if (*FMUstate == NULL)
            free_state(s);
        return fmu_fail(fmu, "%s: %s", function, error.message);
    }
    memcpy(s->magic, STATE_MAGIC, 8);
    s->phase = (int32_t)fmu->phase;
    s->experiment_set = fmu->experiment_set;
    s->stop_defined = fmu->stop_defined;
    s->tolerance_defined = fmu->tolerance_defined;
    s->run_current = fmu->run_current;
    s->inputs_changed = fmu->inputs_changed;
    s->start_time = fmu->start_time;
    s->stop_time = fmu->stop_time;
    s->tolerance = fmu->tolerance;
    s->time = fmu->time;
    s->last_successful_time = fmu->last_successful_time;
    memcpy(s->params, fmu->params, sizeof(double) * MODEL_NP);
    memcpy(s->outputs, fmu->outputs, sizeof(double) * MODEL_NOUT);
    memcpy(s->hinges, fmu->hinges, sizeof(dep_hinge_state) * MODEL_NH);
    *FMUstate = s;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate)
{
    const char *function = "fmi2SetFMUstate";
    fmu_instance *fmu = fmu_enter(c, function, ANY_PHASE);
    dep_error error;
    if (fmu == NULL)
        return fmi2Error;
    const fmu_state *s = state_of(fmu, function, FMUstate);
    if (s == NULL)
        return fmi2Error;
    if (s->run != NULL && dep_restore(&fmu->run, s->run, &error) != DEP_OK)
        return fmu_fail(fmu, "%s: the state's run cannot be reached again: %s", function,
                        error.message);
    if (s->run == NULL) {
        dep_close(fmu->run);
        fmu->run = NULL;
    }
    fmu->phase = (enum fmu_phase)s->phase;
    fmu->experiment_set = s->experiment_set;
    fmu->stop_defined = s->stop_defined;
    fmu->tolerance_defined = s->tolerance_defined;
    fmu->run_current = s->run_current;
    fmu->inputs_changed = s->inputs_changed;
    fmu->start_time = s->start_time;
    fmu->stop_time = s->stop_time;
    fmu->tolerance = s->tolerance;
    fmu->time = s->time;
    fmu->last_successful_time = s->last_successful_time;
    memcpy(fmu->params, s->params, sizeof(double) * MODEL_NP);
    memcpy(fmu->outputs, s->outputs, sizeof(double) * MODEL_NOUT);
    memcpy(fmu->hinges, s->hinges, sizeof(dep_hinge_state) * MODEL_NH);
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    fmu_instance *fmu = fmu_enter(c, "fmi2FreeFMUstate", ANY_PHASE);
    if (fmu == NULL)
        return fmi2Error;
    if (FMUstate == NULL)
        return fmu_fail(fmu, "fmi2FreeFMUstate: FMUstate is NULL");
    if (*FMUstate != NULL && state_of(fmu, "fmi2FreeFMUstate", *FMUstate) == NULL)
        return fmi2Error;
    free_state((fmu_state *)*FMUstate);
    *FMUstate = NULL;
    return fmi2OK;
}

/* ---- as bytes: STATE_MAGIC, the GUID, the wrapper's fields, the run's snapshot ----------- */

static size_t state_size(const fmu_state *s)
{
    return 8 + strlen(fmu_guid) + 1 + STATE_FIELDS + sizeof(uint64_t)
           + (s->run != NULL ? dep_snapshot_size(s->run) : 0);
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size)
{
    const char *function = "fmi2SerializedFMUstateSize";
    fmu_instance *fmu = fmu_enter(c, function, ANY_PHASE);
    if (fmu == NULL)
        return fmi2Error;
    const fmu_state *s = state_of(fmu, function, FMUstate);
    if (s == NULL)
        return fmi2Error;
    if (size == NULL)
        return fmu_fail(fmu, "%s: size is NULL", function);
    *size = state_size(s);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate,
                                 fmi2Byte serializedState[], size_t size)
{
    const char *function = "fmi2SerializeFMUstate";
    fmu_instance *fmu = fmu_enter(c, function, ANY_PHASE);
    if (fmu == NULL)
        return fmi2Error;
    const fmu_state *s = state_of(fmu, function, FMUstate);
    if (s == NULL)
        return fmi2Error;
    size_t needed = state_size(s), guid = strlen(fmu_guid) + 1;
    if (serializedState == NULL || size < needed)
        return fmu_fail(fmu, "%s: the state takes %lu bytes; serializedState has %lu",
                        function, (unsigned long)needed,
                        serializedState == NULL ? 0ul : (unsigned long)size);
    unsigned char *at = (unsigned char *)serializedState;
    uint64_t run = s->run != NULL ? (uint64_t)dep_snapshot_size(s->run) : 0;
    memcpy(at, STATE_MAGIC, 8);
    memcpy(at += 8, fmu_guid, guid);
    memcpy(at += guid, s, STATE_FIELDS);
    memcpy(at += STATE_FIELDS, &run, sizeof run);
    if (s->run != NULL)
        dep_snapshot_write(s->run, at + sizeof run);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[],
                                   size_t size, fmi2FMUstate *FMUstate)
{
    const char *function = "fmi2DeSerializeFMUstate";
    fmu_instance *fmu = fmu_enter(c, function, ANY_PHASE);
    size_t guid = strlen(fmu_guid) + 1, head = 8 + guid + STATE_FIELDS + sizeof(uint64_t);
    const unsigned char *bytes = (const unsigned char *)serializedState;
    uint64_t run = 0;
    dep_error error;
    if (fmu == NULL)
        return fmi2Error;
    if (FMUstate == NULL)
        return fmu_fail(fmu, "%s: FMUstate is NULL", function);
    if (bytes != NULL && size >= head)
        memcpy(&run, bytes + head - sizeof run, sizeof run);
    if (bytes == NULL || size < head || memcmp(bytes, STATE_MAGIC, 8) != 0
        || memcmp(bytes + 8, fmu_guid, guid) != 0 || run != (uint64_t)(size - head))
        return fmu_fail(fmu, "%s: these %lu bytes are not a state of this FMU (guid %s)",
                        function, (unsigned long)size, fmu_guid);
    if (*FMUstate != NULL && state_of(fmu, function, *FMUstate) == NULL)
        return fmi2Error;
    fmu_state *s = calloc(1, sizeof *s);
    if (s == NULL)
        return fmu_fail(fmu, "%s: out of memory", function);
    memcpy(s, bytes + 8 + guid, STATE_FIELDS);
    if (memcmp(s->magic, STATE_MAGIC, 8) != 0 || s->phase < PHASE_INSTANTIATED
        || s->phase > PHASE_TERMINATED || (s->phase & (s->phase - 1)) != 0) {
        free(s);
        return fmu_fail(fmu, "%s: these bytes are not a state of this FMU: damaged", function);
    }
    if (run > 0 && dep_snapshot_read(&depsim_model, bytes + head, (size_t)run, &s->run,
                                     &error) != DEP_OK) {
        free(s);
        return fmu_fail(fmu, "%s: %s", function, error.message);
    }
    free_state((fmu_state *)*FMUstate); /* a state given to be overwritten */
    *FMUstate = s;
    return fmi2OK;
}
