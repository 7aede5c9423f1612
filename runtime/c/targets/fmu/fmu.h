/* fmu.h: the FMI wrapper's own header (fmi2.c, fmi2_variables.c, fmi2_state.c): what it
 * knows of one model's FMU, defined by the model's generated fmu_variables.c
 * (codegen/templates/fmu/fmu_variables.c.j2): its GUID and the tables of its variables in the
 * order of modelDescription.xml's value references; and one instance of it.
 */
#ifndef DEPSIM_FMU_H
#define DEPSIM_FMU_H

#include "core/include/depsim.h"
#include "fmi2.h"

/* What a value reference names. */
enum fmu_kind {
    FMU_TIME,      /* the independent variable */
    FMU_PARAMETER, /* index: into p */
    FMU_INPUT,     /* index: the input; p[fmu_input_slots[index]] its value, the next its rate */
    FMU_OUTPUT,    /* index: into the model's outputs */
    FMU_ANGLE,     /* index: the hinge, for this and the kinds below */
    FMU_RATE,
    FMU_FORCE_X,
    FMU_FORCE_Y,
    FMU_FORCE_Z,
    FMU_TORQUE,
    FMU_LATCHED
};

typedef struct fmu_variable {
    enum fmu_kind kind;
    int index;
    const char *name;
} fmu_variable;

extern const char fmu_guid[];            /* modelDescription.xml's guid */
extern const char fmu_instance_prefix[]; /* the modelIdentifier */
extern const int fmu_nreal, fmu_nboolean, fmu_ni; /* Real and Boolean variables, inputs */
/* Real variables by value reference (fmu_nreal). */
extern const fmu_variable fmu_real_variables[];
/* Boolean variables by value reference (fmu_nboolean; one more entry ends the table). */
extern const fmu_variable fmu_boolean_variables[];
/* Each input's value slot in p; its rate is the next slot (fmu_ni; one more ends it). */
extern const int fmu_input_slots[];

/* ---- one instance (fmi2.c; its values: fmi2_variables.c; its state: fmi2_state.c) ---- */

/* Log categories (modelDescription.xml, LogCategories); errors are always reported. */
enum { LOG_ERROR = 1, LOG_EVENTS = 2, LOG_CALLS = 4, LOG_ALL = 7 };

/* The phases of the FMI 2.0 Co-Simulation state machine this wrapper tracks. */
enum fmu_phase {
    PHASE_INSTANTIATED = 1,
    PHASE_INITIALIZATION = 2,
    PHASE_STEPPING = 4, /* stepComplete */
    PHASE_TERMINATED = 8,
    PHASE_ERROR = 16
};

typedef struct fmu_instance {
    char *name;
    fmi2CallbackLogger logger;
    fmi2ComponentEnvironment environment;
    unsigned logging;           /* LOG_* bits enabled (LOG_ERROR always reports) */
    enum fmu_phase phase;
    int experiment_set;
    double start_time, stop_time, tolerance;
    int stop_defined, tolerance_defined;
    double *params;             /* np: the parameters and the inputs' value and rate slots */
    int inputs_changed;         /* stepping: an input changed since the run last heard */
    dep_run *run;               /* open from fmi2ExitInitializationMode to fmi2Terminate */
    int run_current;            /* initialization: the run was opened with params as they are */
    double time;                /* FMU time (s) */
    double last_successful_time;
    double *outputs;            /* nout, at `time` */
    dep_hinge_state *hinges;    /* nh, at `time` */
    double *input_values, *input_rates; /* fmu_ni: scratch for dep_set_inputs */
    double *trial;              /* np: the parameters a fmi2SetReal would leave, checked first */
    unsigned char *given;       /* np: the parameters that call sets */
} fmu_instance;

#if defined(__GNUC__) || defined(__clang__)
#define FMU_PRINTF(f, a) __attribute__((format(printf, f, a)))
#else
#define FMU_PRINTF(f, a)
#endif

#define ANY_PHASE 31u
#define READABLE (PHASE_INITIALIZATION | PHASE_STEPPING | PHASE_TERMINATED | PHASE_ERROR)

/* A message to the importer's logger when `category` (LOG_*) is enabled. */
void FMU_PRINTF(3, 4) fmu_log(const fmu_instance *fmu, int category, const char *format, ...);
/* Report an error: logged (logError), the instance enters its error state; fmi2Error. */
fmi2Status FMU_PRINTF(2, 3) fmu_fail(fmu_instance *fmu, const char *format, ...);
/* The instance, if `function` may be called in its phase (a bit mask of enum fmu_phase);
   else NULL, after reporting why (a NULL instance cannot report). */
fmu_instance *fmu_enter(fmi2Component c, const char *function, unsigned phases);
/* In initialization mode, outputs follow the parameters and inputs set so far. */
fmi2Status fmu_current_results(fmu_instance *fmu);
/* fmi2Error: `function` is not supported, and why. */
fmi2Status fmu_unsupported(fmi2Component c, const char *function, const char *why);

#endif /* DEPSIM_FMU_H */
