/* depsim.h: depsim's integrator core, the one implementation of the iterative
 * Lagrange-multiplier method (docs/method.md, docs/c-target.md): lambda linear over each step,
 * Dormand-Prince 5(4) for the motion, three passes of the iteration (6) per step (position,
 * velocity, acceleration), step control from the ODE and interpolation errors, dense output,
 * events, and the hinges' friction, latches, hard stops and stick-slip (docs/deployment.md).
 * It reads a model only through `dep_model` (depsim_model.h): a compiled model.c, or a
 * binding's (depsim.runtime.simulate fills one from a generated NumPy module).
 *
 *     dep_settings settings = dep_default_settings(&depsim_model);
 *     dep_result result;
 *     dep_error error;
 *     if (dep_simulate(&depsim_model, NULL, &settings, NULL, 0, &result, &error) != DEP_OK)
 *         fprintf(stderr, "%s\n", error.message);
 *     ...
 *     dep_result_free(&result);
 *
 * Everything is SI (s, m, rad, N, J). No global state: runs in several threads are safe.
 */
#ifndef DEPSIM_H
#define DEPSIM_H

#include <stddef.h>

#include "depsim_model.h"

#define DEP_NAME_MAX 128   /* longest name (row, joint, event, data key) kept, with the NUL */
#define DEP_MAX_ADDED 64   /* constraint rows an event may have added at one time */
#define DEP_MAX_DATA 8     /* numbers a user event's response may attach to its record */

/* Return codes of dep_simulate, also dep_error.code. */
enum dep_status {
    DEP_OK = 0,
    DEP_SOLVER_ERROR = 3,    /* the integration cannot go on (depsim.runtime.SolverError) */
    DEP_SETTINGS_ERROR = 4,  /* a bad setting or parameter value (Python: ValueError) */
    DEP_CALLBACK_ERROR = 5,  /* an event function or callback reported failure */
    DEP_MEMORY_ERROR = 6,    /* out of memory */
    DEP_INTERRUPTED = 7      /* the progress callback asked to stop */
};

#define DEP_PROGRESS_STEPS 64 /* accepted steps between calls of dep_settings.progress */

/* An input of the model (input_names) given as a time table: n points (t_i, u_i), t_i
   non-decreasing (a repeated time is a jump), u linear in between and held beyond the ends. */
typedef struct dep_input_table {
    int input;            /* index into the model's input_names */
    int n;                /* points, >= 1 */
    const double *t, *u;  /* n: s, SI */
} dep_input_table;

/* One run's settings (SI). dep_default_settings gives the model's own. */
typedef struct dep_settings {
    double t_end;  /* s, > 0 */
    double dt_out; /* s, > 0: output every dt_out, and at t_end */
    double tol;    /* integration tolerance, 100 eps <= tol < 1 */
    int mechanics; /* 1: latches, stops, stick-slip from hinge_properties; 0: without */
    /* NULL, or called with the time reached (s) every DEP_PROGRESS_STEPS accepted steps and
       at the end; a non-zero return stops the run with DEP_INTERRUPTED. A binding draws a
       progress bar or honours Ctrl-C here. */
    int (*progress)(void *context, double t);
    void *progress_context;
    /* The most steps a run may take, the rejected and retried ones counted (0: DEP_MAX_STEPS).
       A run that would need more stops with a SolverError: at once when its step is held
       down by stability (a stiff mode) and the steps left would pass the limit, else when it
       is reached, however small its steps. */
    double max_steps;
    /* Inputs given as time tables (dep_simulate; NULL/0: none). An input without a table
       keeps its parameter slots: u(t) = p[slot] + p[slot + 1] t. */
    const dep_input_table *tables;
    int n_tables;
    /* The ODE method under the multiplier iteration (docs/method.md, 10): DEP_STEPPING_AUTO
       (0) DOPRI 5(4), and for a model with beams the linearly implicit step once a stiff mode
       holds DOPRI's step at its stability bound; DEP_STEPPING_EXPLICIT (1) DOPRI throughout;
       DEP_STEPPING_IMPLICIT (2) the linearly implicit step throughout (a model with beams). */
    int stepping;
    /* What each output row keeps: DEP_ROWS_ALL (0) every column of dep_result; DEP_ROWS_OUTPUTS
       (1) the outputs and what the summary reads (multipliers, hinge torques, dissipated work),
       q, qd, the hinge angles and rates, energies and residuals left nought: the standalone
       program, which writes the outputs alone, saves their evaluation at every row. */
    int rows;
    /* Forward sensitivities (docs/method.md, 12): the indices into p of the parameters to
       follow (NULL/0: none). The model needs its tangent functions (dep_model.tangents). */
    const int *sensitivities;
    int n_sensitivities;
} dep_settings;

enum dep_stepping { DEP_STEPPING_AUTO = 0, DEP_STEPPING_EXPLICIT = 1, DEP_STEPPING_IMPLICIT = 2 };
enum dep_rows { DEP_ROWS_ALL = 0, DEP_ROWS_OUTPUTS = 1 };

#define DEP_MAX_STEPS 1e6 /* the default of dep_settings.max_steps */

/* Why a run stopped, with the parts of Python's SolverError. `message` is the full text,
   exactly as str(SolverError) (or the ValueError text for DEP_SETTINGS_ERROR). */
typedef struct dep_error {
    int code;                     /* enum dep_status */
    int has_t;
    double t;                     /* s, when has_t */
    char stage[32];               /* "position", "velocity", "acceleration", "initial state",
                                     "step size", "setup", "settings", ... or "" */
    char row[DEP_NAME_MAX];       /* constraint row, e.g. "h3.x", or "" */
    char joint[DEP_NAME_MAX + 8]; /* e.g. "hinge h3", or "" */
    int has_residual;
    double residual;
    char what[512];
    char hint[512];
    char message[1600];
} dep_error;

/* Constraint rows an event callback may add (Python's HingeLock and LinearConstraint). */
enum dep_row_kind { DEP_ROW_HINGE_LOCK = 1, DEP_ROW_LINEAR = 2 };

typedef struct dep_row {
    int kind;                  /* enum dep_row_kind */
    char name[DEP_NAME_MAX];   /* "" for a lock: "<hinge>.lock" */
    char joint[DEP_NAME_MAX];  /* "" for a lock: the hinge */
    int hinge;                 /* DEP_ROW_HINGE_LOCK: index into hinge_names */
    double angle;              /* DEP_ROW_HINGE_LOCK: Phi = theta_hinge(q) - angle (rad) */
    const double *row;         /* DEP_ROW_LINEAR: Phi = row . q - value (nq; copied) */
    double value;
} dep_row;

/* What an event callback sees (valid during the call only). */
typedef struct dep_event_hit {
    const char *name;
    double t;
    const double *q, *qd;          /* nq */
    const double *lam;             /* nc, the active rows' multipliers */
    int nc;
    const char *const *row_names;  /* nc names of the active rows */
    const double *p;               /* np */
    int n_added;
    const dep_row *added;          /* the rows added at run time, in the set's order */
} dep_event_hit;

/* What to do after an event (Python's EventResponse); the integrator clears it to
   {stop = -1, everything else 0/NULL} before the callback. */
typedef struct dep_event_response {
    int stop;                  /* -1: the event's `terminal`; 0: go on; 1: stop the run */
    const double *q, *qd;      /* NULL: keep; else the new state (nq, copied) */
    int n_add;
    dep_row add[DEP_MAX_ADDED];
    int n_remove;
    char remove[DEP_MAX_ADDED][DEP_NAME_MAX];
    int impact;                /* plastic impact onto the new constraint set */
    int n_data;
    char data_names[DEP_MAX_DATA][DEP_NAME_MAX];
    double data_values[DEP_MAX_DATA];
} dep_event_response;

/* What holds a hinge in a lock row added at run time: the mechanism's latch, hard stop or
   stuck friction (docs/deployment.md), or an event callback's HingeLock. */
enum dep_lock { DEP_LOCK_LATCH = 0, DEP_LOCK_STOP = 1, DEP_LOCK_STICK = 2, DEP_LOCK_EVENT = 3 };

/* The active constraint rows and their multipliers, for events that watch them. */
typedef struct dep_active_rows {
    int nc;
    const char *const *names;
    const double *lam;
    const int *locks;  /* nc: a lock row's enum dep_lock, -1 for any other row */
    const int *hinges; /* nc: the hinge a lock row holds (index into hinge_names), else -1 */
} dep_active_rows;

/* g(t, q, qd) crossing zero in `direction` (+1 rising, -1 falling, 0 both). With
   `multipliers` set, `rows` holds the active rows' multipliers (else it is NULL): at a step
   end the step's lambda, inside a step lambda from the acceleration pass there. Functions
   return 0, or non-zero to abort the run with DEP_CALLBACK_ERROR. */
typedef struct dep_event {
    const char *name;
    int (*function)(void *context, double t, const double *q, const double *qd,
                    const dep_active_rows *rows, double *g);
    int direction;
    int (*callback)(void *context, const dep_event_hit *hit, dep_event_response *response);
    void *context;             /* passed to function and callback */
    int terminal;              /* stop unless the callback decides */
    int max_hits;              /* < 0: unlimited */
    int multipliers;           /* 1: function reads `rows` */
} dep_event;

typedef struct dep_pass_stats {
    double mean;      /* iterations of (6) per accepted step */
    long long max;
    long long total;
} dep_pass_stats;

/* Python's Stats, field by field. */
typedef struct dep_stats {
    long long accepted_steps, rejected_steps, failed_steps, integrations, rhs_evaluations;
    dep_pass_stats position, velocity, acceleration;
    long long cg_iterations, factorizations;
    double max_v_pos, max_v_vel, max_v_acc;
    double min_step, max_step;
    long long events;
    /* The time from which a stiff mode (of rate stiff_rate, 1/s) made the run take the
       linearly implicit step (docs/method.md, 10); nan for a run that never did. */
    double implicit_from, stiff_rate;
    /* Accepted steps that prescribed the rows' forces instead of their multipliers, near a
       singular position (docs/method.md, 6a). */
    long long force_steps;
} dep_stats;

/* One entry of an event record's data (Python's EventRecord.data): `key` -> a number, a
   text, a truth value or None; entries with a `member` form the dict under `key` (e.g. the
   impulse of every joint in "joint_impulses"). */
enum dep_datum_kind { DEP_NUMBER = 0, DEP_TEXT = 1, DEP_BOOL = 2, DEP_NONE = 3 };

typedef struct dep_datum {
    char key[DEP_NAME_MAX];
    char member[DEP_NAME_MAX]; /* "" unless the value belongs to the dict under `key` */
    int kind;                  /* enum dep_datum_kind */
    double number;             /* DEP_NUMBER, DEP_BOOL (0 or 1) */
    char text[DEP_NAME_MAX];   /* DEP_TEXT */
} dep_datum;

/* What an event record is: an event of the caller's, a transition of a hinge's mode (its name
   "<hinge>.latch", "<hinge>.latch.contact", ...: docs/deployment.md) or the assembly at t = 0. */
enum dep_record_kind {
    DEP_RECORD_EVENT = 0, DEP_RECORD_LATCH = 1, DEP_RECORD_LATCH_CONTACT = 2,
    DEP_RECORD_LATCH_SEPARATION = 3, DEP_RECORD_STOP = 4, DEP_RECORD_STICK = 5,
    DEP_RECORD_SLIP = 6, DEP_RECORD_ASSEMBLY = 7, DEP_RECORD_HOLD = 8, DEP_RECORD_RELEASE = 9
};

typedef struct dep_event_record {
    char name[DEP_NAME_MAX];
    double t;
    int kind;  /* enum dep_record_kind */
    int hinge; /* a transition's hinge (index into hinge_names), else -1 */
    int n_data;
    dep_datum *data;
} dep_event_record;

/* Largest hinge force magnitude (N) and lock torque magnitude (N m) over a run, with their
   times (s): force 0 / t_force NAN when the hinge never carried a force; torque 0 /
   t_torque NAN when nothing ever held it. unique 0: the hinge's rows were redundant at an
   accepted state (a singular position, or rows that repeat others): its loads there are
   the minimum-norm multipliers', one of many sets that hold the mechanism. */
typedef struct dep_peak {
    double force, t_force, torque, t_torque;
    int unique;
} dep_peak;

/* A latch that engaged (its first engagement). */
typedef struct dep_latch_summary {
    int hinge;          /* index into the model's hinge_names */
    double t;           /* s */
    double rate;        /* hinge rate just before, rad/s */
    int rigid;          /* 0: compliant */
    double impulse;     /* angular impulse of the latch on member b, N m s; NAN if compliant */
    double energy_loss; /* kinetic energy the plastic impact removed, J; NAN if compliant */
} dep_latch_summary;

/* What a mechanism engineer asks first (docs/deployment.md). */
typedef struct dep_deployment {
    int n_latch_hinges;
    int *latch_hinges;            /* indices of the hinges with a latch */
    int n_latches;                /* latches that engaged, in time order */
    dep_latch_summary *latches;
    int deployed;                 /* 1: every latch engaged; 0: not; -1: the model has none */
    double time;                  /* s, when the last latch engaged; NAN unless deployed */
    double friction_energy;       /* J dissipated by hinge friction by the end */
    double impact_energy;         /* J removed by latch and stop impacts */
} dep_deployment;

/* A run's results at the n output times (Python's Result); arrays are row-major, one row
   per output time. Free with dep_result_free. */
typedef struct dep_result {
    int n;                         /* output times */
    int nq, nh, nout, ne, nd;
    int n_rows;                    /* constraint rows ever active */
    char **row_names;              /* n_rows */
    double tol, constraint_tol, t_end, dt_out;
    double *params;                /* np, the values used */
    double *times;                 /* n, s */
    double *q, *qd;                /* n x nq */
    double *lam;                   /* n x n_rows, NAN where a row was not active */
    double *hinge_angles, *hinge_rates;              /* n x nh */
    double *outputs;                                 /* n x nout */
    double *residual_pos, *residual_vel, *residual_acc; /* n */
    double *energy;                                  /* n x ne, J */
    double *dissipated;                              /* n x nd, J since t = 0 */
    char **energy_names;           /* ne: the model's, then "latch.<h>" (compliant springs) */
    char **dissipator_names;       /* nd: the model's, then "friction.<h>", then "latch.<h>" */
    double *hinge_force;           /* n x nh x 3, N: force on member b from member a (x, y, z;
                                      ground frame), NAN for a hinge without reaction rows */
    double *hinge_torque;          /* n x nh, N m lock torque on member b, NAN if free */
    int nsys;                      /* the model's system_state columns */
    double *system_state;          /* n x nsys: mass, centre of mass, momentum, angular
                                      momentum (the model's SYSTEM_STATE), SI */
    dep_peak *peak_loads;          /* nh: over the output times and every accepted step */
    dep_deployment deployment;
    dep_stats stats;
    int n_events;
    dep_event_record *events;
    char *report;                  /* the run's summary as `depsim run` prints it */
    /* With dep_settings.n_sensitivities = k > 0: the parameters followed (k indices into p),
       and d/dp of q and qd (n x k x 2 nq: dq then dqd), of the outputs (n x k x nout; NAN for
       an output made of a dissipated work) and of each event record's time (n_events x k; 0
       at t = 0, NAN where not followed), and of the model's rows' multipliers (n x k x nc). */
    int n_sensitivities;
    int *sensitivity_params;
    double *sensitivity_state, *sensitivity_outputs, *sensitivity_events, *sensitivity_lam;
} dep_result;

/* The model's own settings (T_END, DT_OUT, TOL), mechanics on. */
dep_settings dep_default_settings(const dep_model *model);

/* Integrate `model` with parameters `params` (np values, NULL: the defaults) from its
   assembled initial state. Fills `result` on success (DEP_OK) and `error` otherwise; on
   failure `result` holds nothing to free. */
int dep_simulate(const dep_model *model, const double *params, const dep_settings *settings,
                 const dep_event *events, int n_events, dep_result *result, dep_error *error);

void dep_result_free(dep_result *result);

/* ---- one run advanced piece by piece (a co-simulation step, docs/fmu.md) ------------------ */

typedef struct dep_run dep_run; /* opaque */

/* Assemble the initial state at t = 0 and find lambda_0. settings->t_end is the horizon:
   steps and events never pass it; it may be INFINITY (open-ended). dt_out and tables are not
   used: the caller sets the inputs (dep_set_inputs). params: np values, NULL: the defaults.
   On failure *out is NULL and `error` says why. */
int dep_open(const dep_model *model, const double *params, const dep_settings *settings,
             dep_run **out, dep_error *error);

/* Integrate to time t (>= the current time, <= t_end) with the integrator's own steps,
   latches, stops, stick-slip and events inside. DEP_OK, else a dep_status with `error`
   filled; after a failure the run cannot go on (dep_close it). */
int dep_advance(dep_run *run, double t, dep_error *error);

/* The model's inputs from now on: u_k(s) = values[k] + rates[k] (s - now), k < ni (rates
   NULL: 0). A change restarts the step sequence (lambda found again); a hinge the new load
   frees (stick-slip, a stop) changes mode in the next step. */
int dep_set_inputs(dep_run *run, const double *values, const double *rates, dep_error *error);

double dep_time(const dep_run *run);

/* A hinge at the current state. */
typedef struct dep_hinge_state {
    double angle, rate;      /* rad, rad/s */
    double force_x, force_y, force_z; /* N: force on member b from member a, ground frame
                                         (force_z 0 in a planar model) */
    double torque;           /* N m: lock torque on member b (latched, at a stop, stuck), else 0 */
    int latched;             /* 1 once its latch engaged, else 0 (also without a latch) */
    int has_latch;
} dep_hinge_state;

void dep_outputs(dep_run *run, double *outputs);          /* nout, at the current state */
void dep_hinge_states(dep_run *run, dep_hinge_state *out); /* nh */
void dep_close(dep_run *run);                            /* NULL is fine */

/* ---- a run's state saved and put back (a co-simulation step rolled back, docs/fmu.md) ---- */

typedef struct dep_snapshot dep_snapshot; /* opaque */

/* The whole state of `run`: its time and state, the integrator's histories and caches, the
   mechanism's modes and rows, the inputs. DEP_OK with *out, or DEP_MEMORY_ERROR. */
int dep_save(const dep_run *run, dep_snapshot **out, dep_error *error);

/* *run back in the state of `snapshot`, after which it goes on bit for bit as it went on from
   the save. Into the run it was taken of (still open): its memory copied back. Into another
   run, NULL or one closed since (or from bytes read in another process): a run of
   dep_open is opened again with the snapshot's parameters and settings (not its progress
   callback) and its dep_advance and dep_set_inputs calls are made again, the same steps to
   the same state at the cost of the run so far; *run is then that run, the old one closed.
   On failure *run is left as it was and `error` says why. */
int dep_restore(dep_run **run, const dep_snapshot *snapshot, dep_error *error);
void dep_snapshot_free(dep_snapshot *snapshot); /* NULL is fine */

/* A snapshot as bytes (dep_snapshot_size of them, written by dep_snapshot_write) and back:
   dep_snapshot_read refuses (DEP_SETTINGS_ERROR) bytes that are not a snapshot of this
   model's run made by this depsim on this kind of machine, or damaged (a checksum). */
size_t dep_snapshot_size(const dep_snapshot *snapshot);
void dep_snapshot_write(const dep_snapshot *snapshot, unsigned char *bytes);
int dep_snapshot_read(const dep_model *model, const unsigned char *bytes, size_t size,
                      dep_snapshot **out, dep_error *error);

/* The index of parameter `name`, or -1. */
int dep_parameter_index(const dep_model *model, const char *name);

/* The model text's range checks (a length > 0, a friction >= 0, stop_min < stop_max, ...: the
   model's limit_* tables) for the parameters p (np values): DEP_OK, else DEP_SETTINGS_ERROR
   with every check p breaks in `error`, worded as depsim.dsl.check_parameters words them and
   joined by "; ", e.g. "rod.length must be positive, got -2 m (from L = -1 m)". only: NULL
   to apply every check; else np flags, and only the checks whose parameters are all flagged
   are applied. dep_simulate and dep_open apply every check before anything runs. */
int dep_check_parameters(const dep_model *model, const double *p, const unsigned char *only,
                         dep_error *error);

/* x as printf's "%.17g" writes it (the same characters: enough digits to read x back exactly),
   into out (DEP_FORMAT_SIZE chars); returns its length. decimal.c: several times faster. */
#define DEP_FORMAT_SIZE 32
int dep_format_double(double x, char *out);

/* x as Python's repr(float) writes it: the shortest digits that read back exactly, placed as
   Python places them ("0.05", "1e-09", "100.0", "inf", "nan"), into out (size bytes;
   DEP_FORMAT_SIZE is enough). base/errors.c. */
void dep_repr(double value, char *out, size_t size);

#endif /* DEPSIM_H */
