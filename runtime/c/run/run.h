/* run.h: one run of a model (runtime/c/README.md): the struct dep_run and its methods, from
 * its settings to its result. A run takes the method's steps (method.h) with the mechanism's
 * modes (mechanics.h), locates events on the dense output, applies what they change, and
 * records the outputs, the hinge loads, the event records and the deployment summary.
 *
 *   settings.c   the checks of a run's settings, input tables and parameters' ranges
 *   tally.c      work and accuracy counters
 *   loads.c      hinge forces and lock torques from the multipliers; their peaks
 *   recording.c  outputs at the requested times; the result
 *   summary.c    the deployment, the peak loads and the summary text of a result
 *   state.c      a run's state: restarts, pass errors, records, loads observed, outputs due
 *   changes.c    applying an event's change (rows, state, impact)
 *   assembly.c   the initial state of closed loops from the given values
 *   steps.c      accepted steps: the step's errors, its size, the step budget
 *   firing.c     events: located, the step re-taken to them, fired
 *   inputs.c     inputs: time tables piece by piece, values set from outside
 *   tangents.c   the motion's tangent along the forward sensitivities, their projection
 *   sensitivity.c  forward sensitivities along a run: the start, steps, outputs, the result
 *   jumps.c      forward sensitivities across events: event times, jumps
 *   run.c        a run set up, begun, advanced, finished and freed
 *   snapshot.c   a run's state saved and restored (its memory, or its calls replayed)
 */
#ifndef DEPSIM_RUN_H
#define DEPSIM_RUN_H

#include "../mechanics/mechanics.h"

/* ---- settings.c -------------------------------------------------------------------------- */

/* resolve_settings: ValueError (DEP_SETTINGS_ERROR) for a bad value, SolverError for tol below
   round-off. open: dep_open's settings (t_end may be INFINITY; dt_out and tables unused). */
int dep_check_settings(const dep_model *model, const double *p, const dep_settings *settings,
                       int open, dep_error *error);
/* The model text's range checks of p (dep_check_parameters, depsim.h). */
int dep_check_limits(const dep_model *model, const double *p, const unsigned char *only,
                     dep_error *error);

/* ---- loads.c: hinge forces and lock torques from the multipliers; their peaks -------------- */

typedef struct dep_loads {
    const dep_model *model;
    int nh;
    double *force, *t_force, *torque, *t_torque; /* nh: the running peaks */
    double *forces, *torques;                     /* 2 nh, nh scratch */
    int *rows;                                    /* 2 nh: each hinge's rows x, y, or -1 */
    int *redundant; /* nh: 1 once the hinge's rows were redundant at an accepted state */
} dep_loads;

int dep_loads_init(dep_loads *loads, const dep_model *model, dep_arena *arena);
void dep_hinge_forces(const dep_loads *loads, const double *lam, double *forces);
void dep_loads_observe(dep_loads *loads, double t, const double *forces, const double *torques);
void dep_loads_mark_redundant(dep_loads *loads, const dep_constraints *cs,
                              dep_multipliers *mp);

/* ---- recording.c: outputs at the requested times; the Result --------------------------- */

typedef struct dep_recorder {
    const dep_system *system;
    int n_times, next_index, rows, capacity;
    int outputs_only; /* dep_settings.rows == DEP_ROWS_OUTPUTS */
    double *times;
    double *t, *q, *qd, *hinge_angles, *hinge_rates, *outputs, *residuals, *energy, *work;
    double *system_state;     /* rows x nsys: the model's system_state at each row */
    double *force, *torque;   /* rows x nh x 2, rows x nh: the hinges' loads */
    int *force_rows;          /* DEP_FORCE_ROWS nh: each hinge's reaction rows */
    dep_mechanism *mechanism; /* the hinges' lock torques; NULL: the lock rows' alone */
    int n_names, names_capacity;
    char **names;
    int *lam_start;            /* rows + 1 */
    int *lam_ids;              /* name index per recorded multiplier */
    double *lam_values;
    int lam_count, lam_capacity;
    double *f, *J, *qdd, *v;   /* scratch */
    double *w, *energy_scratch; /* nw: the run values outputs use; ne scratch */
    dep_event_record *const *records; /* the run's records (impact losses), NULL: none */
    const int *n_records;
    int impacts_counted;       /* records whose impact loss is in `impacts` */
    double impacts;            /* kinetic energy the impacts so far removed, J */
    dep_arena *arena;
} dep_recorder;

double dep_max_output_times(const dep_system *system);
int dep_recorder_init(dep_recorder *rec, const dep_system *system, dep_mechanism *mechanism,
                      const dep_settings *settings, int capacity, dep_arena *arena);
int dep_recorder_pending(dep_recorder *rec, double t_until, int *first);
int dep_record(dep_recorder *rec, double t, const double *q, const double *qd, const double *lam,
               const double *work, dep_constraints *cs);
/* The run values' layout (model->nw of them in a generated model): nh lock torques, nd
   works, then friction, latches, impacts and the latches' energy. */
#define DEP_RUN_VALUES(m) ((size_t)(m)->nh + (size_t)(m)->nd + 4)
/* The energy impacts removed, summed over records[0..n) (`impact_energy_loss`), J. */
double dep_impact_loss(const dep_event_record *records, int n);
/* The run values w (model->nw, depsim_model.h run_value_names) at a state: each hinge's lock
   torque (torques: nh, NAN while free; 0 in w), the work of the model's dissipators, then of friction, of the
   compliant latches and of impacts (`impacts`, J), and the compliant latches' potential
   energy (energy: ne scratch). */
void dep_run_values(const dep_system *system, const double *q, const double *torques,
                    const double *work, double impacts, double *energy, double *w);
double dep_recorder_last_time(const dep_recorder *rec);
/* A malloc'ed copy of n doubles (at least one allocated); *failed set when it cannot be. */
double *dep_copy_doubles(const double *from, size_t n, int *failed);
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

/* ---- the run ------------------------------------------------------------------------------ */

/* The multipliers' profile under the linearly implicit step: a quadratic. The multipliers
   carry the reactions of the stiff modes that step damps; a cubic's error estimate, a fourth
   divided difference, amplifies them and holds the step (two_link_flex at 16 elements: 198,500
   steps with a cubic, 116,200 with a quadratic at the same tol, every output within the
   accuracy bar of docs/beams.md; a linear profile takes 21,300 but misses the low-passed tip
   by 3e-5 m). */
#define DEP_IMPLICIT_PROFILE_NODES 2

/* ---- sensitivity.c: forward sensitivities (docs/method.md, 12) ------------------------- */

/* Above this stiffness indicator (h |lambda|, dep_rk_step) a step's sensitivities are taken on
   its own DOPRI stages (sensitivity.c): the classical fourth-order method is stable to
   h |lambda| = 2.8 on the real axis, DOPRI to 3.3. */
#define DEP_SENSITIVITY_STIFF 2.0

typedef struct dep_sensitivity {
    int k;                 /* parameters followed (dep_settings.sensitivities); 0: none */
    int *params;           /* k: their indices into p */
    /* k x 2 nq each: s = (dq/dp, dqd/dp) per parameter at run->state and its rate ds; s0, ds0
       at the start of the step followed last (t0 .. t1: the dense output); stage, k2 .. k4
       the Runge-Kutta stages */
    double *s, *ds, *s0, *ds0, *stage, *k2, *k3, *k4;
    double *stages;        /* 6 x k x 2 nq: a DOPRI step's stages (sensitivity.c) */
    double t0, t1;
    double *dlam;          /* k x capacity: the multipliers' tangent at the last state solved */
    double *dM, *dH;       /* k x (nmz + 1), k x (nh + 1) x DEP_HINGE_PROPERTIES: constants */
    double *dp;            /* np: the unit direction of the parameter being followed */
    dep_multipliers mp;    /* S = J M^-1 J^T of the states it visits (its own Schur cache) */
    double *J, *dJ;        /* the active rows' Jacobian and its tangent (DEP_JACOBIAN_SIZE) */
    long long ids, J_id, base_id; /* base_id: the J_id lam and qdd were solved at */
    int unsolved;          /* a solve with S failed (a singular S): the values are unreliable */
    /* scratch: rows (capacity), coordinates (nq), hinges (nh), hinge Jacobians (nhnz) */
    double *gamma, *lam, *r2, *y, *b, *c;
    double *f, *qdd, *r1, *u, *v, *Dq, *Dqd, *Q, *QD;
    double *tau, *theta, *rate, *dtheta, *drate, *dtau, *gamma_h, *Jh, *dJh;
    /* the sensitivities of the added rows' angles (DEP_MAX_ADDED x k), by the rows' ids */
    long long row_ids[DEP_MAX_ADDED];
    double *row_angles, *saved_angles;
    int n_rows;
    /* recorded: per output row k x 2 nq, k x (nout + 1) and k x (nc + 1) (the model's rows'
       multipliers); per event record k dtau/dp */
    double *out_q, *out_y, *out_lam, *w, *dw, *energy, *torques;
    double *event_times;
    int event_capacity;
    /* the event being fired (jumps.c): its hinge, angular rate and acceleration, its stick or
       stop row (-1: none) with the row's multiplier, its tangents (k) and rate */
    int event_hinge, event_row;
    double event_rate, event_acceleration, event_lam, event_lam_rate, *event_dlam;
} dep_sensitivity;

/* tangents.c: the memory and the constants of the run's sensitivities (none: k = 0) */
int dep_sensitivity_init(dep_run *run);
/* J of the active rows at (q, t) for the solves below, under a new identity */
void dep_sens_at_state(dep_run *run, double t, const double *q);
/* out = S^-1 b, S = J M^-1 J^T (sens->unsolved set where it cannot be solved) */
void dep_sens_schur(dep_run *run, const double *b, double *out);
/* M x + J^T y = r1, J x = r2 */
void dep_sens_solve_motion(dep_run *run, const double *r1, const double *r2, double *xq,
                           double *y);
/* sens->dJ: the active rows' Jacobian's tangent along (dq, sens->dp) */
void dep_sens_jacobian_tangent(dep_run *run, double t, const double *q, const double *dq);
/* lambda, qdd of the motion at the state (sens->lam, qdd; once for each at_state) */
void dep_sens_motion_base(dep_run *run, double t, const double *q, const double *qd);
/* After dep_sens_motion_base: the tangent of the motion along (dq, dqd) and sens->dp, with the
   hinge properties' and the mass matrix's tangents dH, dM (NULL: none): out = (dqd, dqdd),
   dlam the multipliers' */
void dep_sens_direction(dep_run *run, double t, const double *q, const double *qd,
                        const double *dq, const double *dqd, const double *dH,
                        const double *dM, double *out, double *dlam);
/* lambda, qdd of the motion at the state (sens->lam, qdd) and, for every parameter, the rate ds
   of the sensitivities s and the multipliers' tangent (sens->dlam) */
void dep_sens_motion_tangent(dep_run *run, double t, const double *q, const double *qd,
                             const double *s, double *ds);
/* s onto the tangents of the position and velocity constraints at the state */
void dep_sens_project(dep_run *run, double t, const double *q, const double *qd, double *s);
/* The added rows' angle sensitivities after the rows changed (new rows: at q) */
void dep_sens_rows_changed(dep_run *run, const double *q);
/* The event records from `first` on: their times' sensitivities dtau (k; NULL: 0) */
int dep_sens_event_times(dep_run *run, int first, const double *dtau);
/* A SETTINGS error: what the sensitivities cannot follow at t */
int dep_sens_unsupported(dep_run *run, double t, const char *what);
/* sensitivity.c: along the run */
int dep_sensitivity_begin(dep_run *run);
int dep_sensitivity_step(dep_run *run, const dep_outcome *end, double t1);
int dep_sensitivity_retake(dep_run *run, const dep_outcome *fired);
int dep_sensitivity_record(dep_run *run, int row, double t, const double *q, const double *qd,
                           const double *lam, const double *work);
/* jumps.c */
int dep_sensitivity_prepare_event(dep_run *run, int index, const dep_state *before);
int dep_sensitivity_event(dep_run *run, int index, double t_event, const dep_state *before,
                          int first, int stopped);
int dep_sensitivity_result(dep_run *run, dep_result *result);

/* The accepted point before run->state (for the velocity interpolant, method/dopri.c); valid is 0
   after a start or an event. */
typedef struct dep_prior {
    int valid;
    double t;
    double *qd, *qdd;
    int qdd_weak;
} dep_prior;

/* The calls that brought an open run (dep_open) where it is: its parameters and settings at
   the start, then each dep_advance (DEP_REPLAY_ADVANCE, t) and dep_set_inputs
   (DEP_REPLAY_INPUTS, ni values, ni rates) that succeeded, as doubles. Repeated on a run
   opened again, they give the same steps: the same state bit for bit (snapshot.c). */
enum { DEP_REPLAY_ADVANCE = 1, DEP_REPLAY_INPUTS = 2 };

typedef struct dep_replay {
    int open;           /* 1: a dep_open run (the calls are kept) */
    dep_settings settings;
    double *p;          /* np */
    double *entries;
    long n, capacity;
} dep_replay;

struct dep_run { /* typedef in depsim.h */
    const dep_model *model;
    dep_settings settings;
    dep_error *error;
    dep_arena arena;
    dep_system system;
    dep_mechanism *mechanism;  /* NULL: no latch, stop or stick-slip (or mechanics off) */
    dep_constraints cs;
    dep_stepper stepper;
    dep_recorder recorder;
    dep_watch watch;
    int n_user_events;
    dep_tally tally;
    dep_history history;
    dep_history friction;      /* the hinges' friction torques at the same points (nh) */
    dep_history forces;        /* the rows' forces Phi_q^T lambda at the same points (nq) */
    double *force_now;         /* nq: the newest of them */
    int by_force, by_force_next; /* the next step prescribes the forces (method/forces.c):
                                    as the last accepted step's errors chose, and as this
                                    step's choose */
    long long force_steps;       /* accepted steps that did */
    double *friction_predicted, *friction_table, *friction_d; /* scratch */
    double *friction_move; /* ny: what the prescribed frictions' defect moves the step's end
                              by (steps.c), added to it when the step is accepted */
    int friction_moved;    /* whether friction_move holds the last step's move */
    int friction_steps;   /* accepted steps in a row held by friction's damping (step_budget) */
    dep_prior prior;
    dep_loads loads;
    dep_state state;
    dep_outcome outcome, fired;
    dep_change change;
    dep_event_response *response;
    dep_row *response_rows; /* DEP_MAX_ADDED: the added rows a callback sees */
    double h_min, h_cap;
    int nq, nd, ny;
    double *p_spare; /* np: the other parameter buffer (inputs changing, take_parameters) */
    double *p, *scratch, *y, *dy, *q, *qd, *lam, *work, *predicted, *mass_qd;
    double *dense_J, *dense_lam;
    double *tangent, *normal; /* ny, 2 capacity + 2 nq: the step error's tangential part */
    double err_previous;      /* the last accepted step's error (the PI step control) */
    int stiff_steps, free_steps, grind_steps; /* step_budget's counts */
    double implicit_from, stiff_rate; /* when the linearly implicit step took over, and why */
    double omega_max;                 /* the stiff forces' fastest mode (rad/s), 0: unknown */
    int bound_steps;                  /* accepted steps in a row with h omega_max > bound */
    int profile_nodes;                /* the multipliers' profile's most nodes (its degree) */
    dep_active_rows state_rows, dense_rows;
    dep_event_record *records;
    int n_records, records_capacity;
    double *run_values, *run_energy; /* nw, ne: dep_run_outputs' scratch */
    int n_wraps;   /* hinges whose angle is measured within half a turn (hinge_wraps) */
    double *turns; /* 4 nh: their angles and rates at a step's ends (steps.c, turned_past) */
    double t_stop;   /* the end of the current dep_advance: no step passes it */
    double h_next;   /* the step size to try next; 0: none yet (first_step) */
    int recording;   /* 1: outputs at the output times (dep_simulate); 0: dep_open's runs */
    int stopped;     /* a terminal event ended the run */
    dep_replay replay;
    double *tree_v, *tree_vd; /* nv: the assembly tree's values and rates at t = 0 */
    dep_sensitivity sens;
};


/* ---- the methods of a run ------------------------------------------------------------------ */

/* run.c: a new run of `model` with these settings: checked, its system, events and (when
   `recording`) its recorder set up. NULL with `error` filled on failure. */
dep_run *dep_run_new(const dep_model *model, const double *params, const dep_settings *settings,
                     const dep_event *events, int n_events, int recording, dep_error *error);
void dep_run_free(dep_run *run);                     /* NULL is fine */
int dep_run_begin(dep_run *run);     /* the assembled initial state at t = 0, its modes, lambda_0 */
int dep_run_until(dep_run *run, double t);           /* steps to t (or a stopping event) */
int dep_run_integrate(dep_run *run); /* dep_simulate's run: to t_end, piece by piece of tables */
int dep_run_finish(dep_run *run, dep_result *result); /* the result of a finished run */
/* The model's outputs (nout) at the run's current state (dep_outputs). */
void dep_run_outputs(dep_run *run, double *outputs);

/* state.c */
int dep_run_pass_error(dep_run *run, const dep_failure *failure, double t);
int dep_run_restart(dep_run *run, double t, const double *q, const double *qd,
                    const double *work, const char *stage);
int dep_run_record_until(dep_run *run, double t_until, const dep_outcome *end);
const dep_active_rows *dep_run_rows(dep_run *run, const dep_state *state);
void dep_run_observe_loads(dep_run *run, const dep_state *s);
int dep_run_add_record(dep_run *run, const char *name, int kind, int hinge, double t,
                       const dep_datum *data, int n); /* kind: enum dep_record_kind */
int dep_run_log_event(dep_run *run, const char *name, double t, const dep_change *change);
/* changes.c */
int dep_run_apply_change(dep_run *run, dep_change *change, const dep_state *here);
/* assembly.c */
int dep_run_assemble(dep_run *run, double *q, double *qd);
/* steps.c */
double dep_run_first_step(dep_run *run);
int dep_run_step(dep_run *run, double h, dep_outcome *outcome, dep_failure *failure);
int dep_run_advance(dep_run *run, double *h); /* one accepted step; *h: in tried, out next */
void dep_run_attach_prior(const dep_run *run, dep_outcome *end);
/* firing.c */
int dep_run_start(dep_run *run, const double *q0, const double *qd0);
int dep_run_after_step(dep_run *run, int *stop);
/* inputs.c */
void dep_run_start_tables(dep_run *run);              /* the tables' values at t = 0 */
double dep_run_next_break(const dep_run *run, double t); /* where a table's piece ends */
int dep_run_apply_tables(dep_run *run);               /* the tables' pieces from now on */
int dep_run_set_inputs(dep_run *run, const double *values, const double *rates,
                       dep_error *error);
/* snapshot.c: a run's state saved and put back (dep_save, dep_restore, depsim.h) */
struct dep_snapshot { /* typedef in depsim.h */
    const dep_model *model;
    /* the memory of the run: valid in the run it was taken of, while it is open */
    const dep_run *run;        /* that run */
    const void *core;          /* where this core's data lies: the same process and core */
    struct dep_run image;      /* the run's struct */
    int n_blocks;              /* its arena's blocks (-1: no memory, a snapshot read back
                                  whose struct is not this core's) */
    void **addresses;          /* n_blocks */
    size_t *sizes;             /* n_blocks */
    unsigned char *bytes;      /* their contents, one after the other */
    size_t n_bytes;
    /* the calls since dep_open, repeated on a run opened again */
    dep_replay replay;
};
int dep_run_replay_open(dep_run *run); /* a dep_open run: keep its calls from now on */
/* One call kept: `kind`, n values a and, for DEP_REPLAY_INPUTS, n values b (NULL: zeros). */
int dep_run_replay_add(dep_run *run, int kind, const double *a, const double *b, int n);
int dep_run_save(const dep_run *run, dep_snapshot **out, dep_error *error);
int dep_run_restore(dep_run **run, const dep_snapshot *snapshot, dep_error *error);
void dep_snapshot_destroy(dep_snapshot *snapshot);
size_t dep_snapshot_bytes(const dep_snapshot *snapshot);
void dep_snapshot_serialize(const dep_snapshot *snapshot, unsigned char *bytes);
int dep_snapshot_deserialize(const dep_model *model, const unsigned char *bytes, size_t size,
                             dep_snapshot **out, dep_error *error);

#endif /* DEPSIM_RUN_H */
