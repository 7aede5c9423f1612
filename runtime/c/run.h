/* run.h: what a run records: events located on the dense output, hinge loads,
 * outputs at the output times, the summary, work counters (events.c, loads.c,
 * recording.c, summary.c, tally.c)
 */
#ifndef DEPSIM_RUN_H
#define DEPSIM_RUN_H

#include "method.h"

/* ---- events.c: zero crossings located on the dense output ------------------------------ */

/* The dense output inside a step: q, qd at t and, when `rows` is not NULL, the multipliers
   there (acceleration pass). */
typedef int (*dep_dense_function)(void *context, double t, double *q, double *qd,
                                  dep_active_rows *rows);

typedef struct dep_watch {
    dep_event *events; /* the user's, then the mechanism's */
    int count, needs_multipliers;
    int *hits;
    double *values;
} dep_watch;

int dep_watch_init(dep_watch *watch, const dep_event *events, int count,
                   const dep_event *more, int n_more, dep_arena *arena, dep_error *error);
int dep_event_value(const dep_event *event, double t, const double *q, const double *qd,
                    const dep_active_rows *rows, double *g, dep_error *error);
int dep_watch_reset(dep_watch *watch, double t, const double *q, const double *qd, int fired,
                    double side, const dep_active_rows *rows, dep_error *error);
int dep_first_crossing(dep_watch *watch, double t0, double t1, const double *q1,
                       const double *qd1, const dep_active_rows *rows1,
                       dep_dense_function dense, void *context, double *q, double *qd,
                       dep_active_rows *rows, int *index, double *t_root, double *side,
                       dep_error *error);

/* ---- loads.c: hinge forces and lock torques from the multipliers; their peaks -------------- */

typedef struct dep_loads {
    const dep_model *model;
    int nh;
    double *force, *t_force, *torque, *t_torque; /* nh: the running peaks */
    double *forces, *torques;                     /* 2 nh, nh scratch */
    int *rows;                                    /* 2 nh: each hinge's rows x, y, or -1 */
} dep_loads;

int dep_loads_init(dep_loads *loads, const dep_model *model, dep_arena *arena);
void dep_hinge_forces(const dep_loads *loads, const double *lam, double *forces);
/* The kind (0 latch, 1 stop, 2 stick, 3 lock) of a row named "<hinge>.<kind>", its hinge in
   *hinge; -1 (and -1) for any other name. */
int dep_lock_row(const dep_model *model, const char *name, int *hinge);
void dep_lock_torques(const dep_model *model, const dep_constraints *cs, const double *lam,
                      double *torques);
void dep_loads_observe(dep_loads *loads, double t, const double *forces, const double *torques);

/* ---- recording.c: outputs at the requested times; the Result --------------------------- */

typedef struct dep_recorder {
    const dep_system *system;
    int n_times, next_index, rows, capacity;
    int outputs_only; /* dep_settings.rows == DEP_ROWS_OUTPUTS */
    double *times;
    double *t, *q, *qd, *hinge_angles, *hinge_rates, *outputs, *residuals, *energy, *work;
    double *torque;
    int n_names, names_capacity;
    char **names;
    int *lam_start;            /* rows + 1 */
    int *lam_ids;              /* name index per recorded multiplier */
    double *lam_values;
    int lam_count, lam_capacity;
    double *f, *J, *qdd, *v;   /* scratch */
    dep_arena *arena;
} dep_recorder;

double dep_max_output_times(const dep_system *system);
int dep_recorder_init(dep_recorder *rec, const dep_system *system, const dep_settings *settings,
                      int capacity, dep_arena *arena);
int dep_recorder_pending(dep_recorder *rec, double t_until, int *first);
int dep_record(dep_recorder *rec, double t, const double *q, const double *qd, const double *lam,
               const double *work, dep_constraints *cs);
double dep_recorder_last_time(const dep_recorder *rec);
int dep_recorder_result(dep_recorder *rec, dep_result *result);

/* ---- summary.c: the deployment, the peak loads and the summary text of a result --------- */

int dep_summarize(const dep_model *model, const dep_system *system, const dep_loads *loads,
                  dep_result *result);

/* ---- tally.c: work and accuracy counters ----------------------------------------------- */

typedef struct dep_tally {
    long long accepted, rejected, failed, events, cg_iterations;
    long long totals[3], maxima[3];
    double residuals[3];
    double min_step, max_step;
} dep_tally;

void dep_tally_init(dep_tally *tally);
void dep_tally_accept(dep_tally *tally, const dep_pass_report reports[3], double h);
void dep_tally_observe(dep_tally *tally, const dep_pass_report *report);
dep_stats dep_tally_stats(const dep_tally *tally, long long integrations,
                          long long rhs_evaluations);

#endif /* DEPSIM_RUN_H */
