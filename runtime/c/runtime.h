/* runtime.h: the integrator's internal parts, one section per source file. Each file ports
 * the Python module of the same name in depsim/runtime (system.py, constraints.py, dopri.py,
 * multipliers.py, controller.py, stepper.py, events.py, recording.py, tally.py,
 * integrator.py); names and order of operations follow the Python code.
 */
#ifndef DEPSIM_RUNTIME_H
#define DEPSIM_RUNTIME_H

#include <stddef.h>

#include "depsim.h"

#define DEP_EPS 2.220446049250313e-16 /* double machine epsilon */
#define DEP_PASS_FAILED 100           /* internal: a pass did not converge (Python PassFailure) */

/* ---- system.c: memory, errors, the mass matrix, the model bound to p ------------------ */

typedef struct dep_arena { /* every allocation of a run, freed at once */
    void **blocks;
    int count, capacity;
    int failed;
} dep_arena;

double *dep_doubles(dep_arena *arena, size_t n); /* zeroed; NULL (and arena->failed) on failure */
void *dep_bytes(dep_arena *arena, size_t n);
void dep_arena_free(dep_arena *arena);

void dep_error_clear(dep_error *error);
void dep_copy_text(char *to, size_t size, const char *from);
/* Python's SolverError(what, t=, stage=, row=, joint=, residual=, hint=): fills every field and
   the formatted message. Pass has_t/has_residual 0 and NULL strings for None. */
int dep_solver_error(dep_error *error, int has_t, double t, const char *stage, const char *row,
                     const char *joint, int has_residual, double residual, const char *what,
                     const char *hint);
int dep_plain_error(dep_error *error, int code, const char *message);
void dep_repr(double value, char *out, size_t size); /* Python's repr(float) */
int dep_check_settings(const dep_model *model, const double *p, const dep_settings *settings,
                       dep_error *error);

typedef struct dep_mass {
    int n, diagonal;
    double *matrix;           /* n x n */
    double *inverse_diagonal; /* n, when diagonal */
    double *cholesky;         /* n x n lower factor, otherwise */
} dep_mass;

void dep_mass_solve(const dep_mass *mass, const double *b, double *x); /* x = M^-1 b; x may be b */

struct dep_mechanism;

/* A hinge's runtime properties (from hinge_properties) and its mode. */
enum dep_latch_state { DEP_OPEN, DEP_LATCHED, DEP_CONTACT, DEP_APART };
enum dep_kind { DEP_KIND_LATCH, DEP_KIND_STOP_MIN, DEP_KIND_STOP_MAX, DEP_KIND_STICK };
enum dep_stop_state { DEP_STOP_NONE = 0, DEP_STOP_MIN = 1, DEP_STOP_MAX = 2 };

typedef struct dep_hinge_mechanics {
    int index;
    const char *name;
    int has_latch, compliant, has_stop_min, has_stop_max, has_static, has_friction;
    double latch, latch_stiffness, latch_damping, stop_min, stop_max;
    double kinetic, static_friction, slip_rate; /* friction (N m), static (N m), rad/s */
    double latch_side, direction;
    int latch_state, stop, stuck; /* enum dep_latch_state, enum dep_stop_state, 0/1 */
} dep_hinge_mechanics;

/* The model bound to p, with the forces the integrator applies itself: each hinge's Coulomb
   friction in its mode and the compliant latches' contact torques. Its dissipators are the
   model's, then "friction.<h>" for each hinge with friction, then "latch.<h>" for each
   compliant latch; its energies the model's, then "latch.<h>". */
typedef struct dep_system {
    const dep_model *model;
    const double *p;
    int nq, nd, nh, ne;
    dep_mass mass;
    dep_hinge_mechanics *hinges;     /* nh, every hinge */
    int n_friction, n_compliant;     /* hinges with friction, compliant latches */
    struct dep_mechanism *mechanism; /* NULL: no latch, stop or stick-slip (or mechanics off) */
    const char **dissipator_names;   /* nd */
    const char **energy_names;       /* ne */
    double *angles, *rates, *tau, *hinge_jacobian; /* scratch: nh, nh, nh, nh x nq */
} dep_system;

/* mechanics 0: every hinge free (friction by the regularised law, no latch or stop modes). */
int dep_system_init(dep_system *system, const dep_model *model, const double *p,
                    int mechanics, dep_arena *arena, dep_error *error);

/* mechanism.c: the hinge torques the integrator applies (friction, compliant contact). */
double dep_friction_torque(const dep_hinge_mechanics *h, double rate);
int dep_hinge_forcing(const dep_system *system);
void dep_hinge_torques(const dep_system *system, const double *q, const double *qd,
                       double *tau);
void dep_hinge_dissipation(const dep_system *system, const double *q, const double *qd,
                           double *power);
void dep_hinge_energy(const dep_system *system, const double *q, double *energy);
const char *dep_joint_kind(const dep_system *system, const char *joint);
void dep_system_force(const dep_system *system, const double *q, const double *qd, double t,
                      double *f);
void dep_system_dissipation(const dep_system *system, const double *q, const double *qd,
                            double t, double *power);
void dep_system_energy(const dep_system *system, const double *q, const double *qd, double t,
                       double *energy);

/* ---- constraints.c: the active rows (the model's and those added by events) ----------- */

typedef struct dep_added_row {
    long long id; /* identity (Python's object identity of a row) */
    int kind, hinge;
    char name[DEP_NAME_MAX], joint[DEP_NAME_MAX];
    double angle, value;
    double *row; /* nq, DEP_ROW_LINEAR */
} dep_added_row;

typedef struct dep_constraints {
    const dep_system *system;
    int nq, nc_module, n_added, nc, capacity;
    long long next_id;
    dep_added_row added[DEP_MAX_ADDED];
    const char **row_names; /* capacity */
    const char **row_joints;
    double *values, *theta, *hinge_jacobian; /* scratch */
} dep_constraints;

int dep_constraints_init(dep_constraints *cs, const dep_system *system, dep_arena *arena);
void dep_cs_phi(dep_constraints *cs, const double *q, double t, double *out);
void dep_cs_jacobian(dep_constraints *cs, const double *q, double t, double *J);
void dep_cs_jacobian_transpose_times(dep_constraints *cs, const double *q, double t,
                                     const double *lam, double *out);
void dep_cs_phi_t(dep_constraints *cs, const double *q, double t, double *out);
void dep_cs_gamma(dep_constraints *cs, const double *q, const double *qd, double t, double *out);
void dep_cs_v_vel(dep_constraints *cs, const double *q, const double *qd, double t,
                  const double *J, double *out);
void dep_cs_v_acc(dep_constraints *cs, const double *q, const double *qd, const double *qdd,
                  double t, const double *J, double *out);
void dep_cs_describe(const dep_constraints *cs, int row, char *joint_text, size_t size);
int dep_cs_remove(dep_constraints *cs, const char *name);
int dep_cs_add(dep_constraints *cs, const dep_row *row, dep_error *error);
int dep_cs_add_row(dep_constraints *cs, const dep_added_row *row, dep_error *error);
int dep_cs_index(const dep_constraints *cs, const char *name); /* -1 when not active */
void dep_cs_assign(dep_constraints *cs, const dep_added_row *rows, int n);
int dep_check_consistency(dep_constraints *cs, double t, const double *q, const double *qd,
                          double tol, const char *stage, double *scratch, dep_error *error);

/* ---- dopri.c: Dormand-Prince 5(4), its dense output, the quintic step interpolant ------- */

typedef void (*dep_rhs_function)(void *context, double t, const double *y, double *dy);

typedef struct dep_rk_step {
    int n;
    double t0, h;
    const double *y0;
    double *y1, *error, *K; /* n, n, 7 x n */
} dep_rk_step;

int dep_rk_init(dep_rk_step *rk, int n, dep_arena *arena);
void dep_dopri_step(dep_rk_step *rk, dep_rhs_function rhs, void *context, double t0,
                    const double *y0, const double *k1, double h, double *scratch);
void dep_dense_components(const dep_rk_step *rk, double t, int first, int count, double *out);
void dep_interpolant_data(double h, const double *q0, const double *qd0, const double *qdd0,
                          const double *q1, const double *qd1, const double *qdd1, int nq,
                          double *data);
void dep_interpolate(const double *data, double t0, double h, int nq, double t, double *q,
                     double *qd);

/* ---- multipliers.c: the iteration (6) with conjugate gradients on S = J M^-1 J^T -------- */

enum dep_stage { DEP_POSITION = 0, DEP_VELOCITY = 1, DEP_ACCELERATION = 2 };
extern const char *const dep_stage_names[3];

#define DEP_MAX_ITERATIONS 25
#define DEP_MAX_HALVINGS 4

typedef struct dep_pass_report {
    int stage, iterations, n_errors;
    long long cg_iterations;
    double errors[DEP_MAX_ITERATIONS + 1];
} dep_pass_report;

typedef struct dep_failure {
    int stage, row;
    double residual, scale;
    char reason[256];
} dep_failure;

typedef struct dep_measurement {
    double *v;                 /* nc */
    double *J_own;             /* nc x nq storage when the pass measures its own Jacobian */
    const double *J;           /* the Jacobian of v */
    long long jacobian_id;     /* identity of J's contents (the Schur cache key) */
    double scale;
    double *x;                 /* nq: the pass's vector (qd1, qdd, qd+) */
    dep_rk_step rk;            /* the position pass's trajectory */
} dep_measurement;

typedef void (*dep_measure_function)(void *context, const double *lam, dep_measurement *out);

typedef struct dep_multipliers { /* scratch of the iteration and its Schur-complement cache */
    int nq, capacity;
    const dep_mass *mass;
    long long schur_id;
    int schur_nc, schur_explicit;
    double *S, *diag, *MinvJT, *column;
    double *x, *r, *z, *d, *Sd, *inv_diag, *step, *trial_lam, *work;
} dep_multipliers;

int dep_multipliers_init(dep_multipliers *mp, const dep_mass *mass, int nq, int capacity,
                         dep_arena *arena);
int dep_measurement_init(dep_measurement *m, int nq, int capacity, int ny, int own_jacobian,
                         dep_arena *arena);
int dep_iterate_multipliers(dep_multipliers *mp, int stage, double *lam, int nc,
                            dep_measure_function measure, void *context, double C, double tol,
                            dep_measurement *slots[2], dep_measurement **final,
                            dep_pass_report *report, dep_failure *failure);
double dep_max_abs(const double *v, int n);
double dep_product_scale(const double *J, int nc, int nq, const double *x);
int dep_project_velocity(dep_multipliers *mp, const double *J, long long jacobian_id, int nc,
                         const double *qd, const double *phi_t, double tol, double *qd_new,
                         double *mu, dep_measurement *slots[2], dep_pass_report *report,
                         dep_failure *failure);

/* ---- controller.c: step size control and the multiplier predictor --------------------- */

#define DEP_HISTORY 4

typedef struct dep_history {
    int count, nc;
    double t[DEP_HISTORY];
    double *lam[DEP_HISTORY]; /* oldest first; capacity each */
} dep_history;

int dep_history_init(dep_history *history, int capacity, dep_arena *arena);
void dep_history_reset(dep_history *history, double t, const double *lam, int nc);
void dep_history_add(dep_history *history, double t, const double *lam);
void dep_history_predict(const dep_history *history, double t, double *out);
void dep_weights(const double *y0, const double *y1, int n, double tol, double *scale);
double dep_rms(const double *x, const double *scale, int n);
double dep_interpolation_error(double h, const dep_history *history, const double *lam1,
                               const double *J1, const dep_mass *mass, const double *scale_q,
                               int nq, double *scratch);
double dep_step_factor(double err_lam, double err_ode, int accepted);
double dep_convergence_factor(const dep_pass_report *report);
double dep_initial_step(dep_rhs_function rhs, void *context, double t0, const double *y0,
                        const double *f0, int n, double tol, double span, double *scratch);

/* ---- stepper.c: one step of the method, and pass 3 alone --------------------------------- */

/* Pass 3 on any constraint set: lambda (in: the guess) and qdd at (q, qd, t) from (1) and
   (2c). Buffers: f, jt, solved (nq), gamma (nc). */
typedef struct dep_acceleration_work {
    const dep_system *system;
    dep_constraints *cs;
    dep_multipliers *mp;
    dep_measurement *slots[2];
    double *f, *jt, *solved, *gamma;
} dep_acceleration_work;

int dep_acceleration_pass(dep_acceleration_work *w, const double *q, const double *qd,
                          double t, const double *J, long long jacobian_id, double *lam,
                          double *qdd, double tol, dep_pass_report *report,
                          dep_failure *failure);

typedef struct dep_state {
    double t;
    double *q, *qd, *qdd, *lam, *work;
} dep_state;

typedef struct dep_outcome {
    dep_state state;
    const dep_rk_step *rk;   /* the trajectory (valid until the next step) */
    const double *J1;        /* Phi_q at the new state */
    double *data;            /* 10 x nq: the step interpolant (dep_interpolant_data) */
    dep_pass_report reports[3];
    int integrations;
} dep_outcome;

typedef struct dep_stepper {
    const dep_system *system;
    dep_constraints *constraints;
    dep_multipliers mp;
    int nq, ny, capacity;
    double tol, constraint_tol;
    long long rhs_evaluations, integrations, jacobian_ids;
    dep_measurement slots[6], *final_position;
    /* the step being taken */
    const dep_state *start;
    double h, t1, rhs_t0;
    double *y0, *k1, *slope, *lam0, *rhs_lam, *force, *jt_lam, *scratch;
    double *memo_lam;
    double *q1, *phi_t1, *lam_pos;
    const dep_rk_step *memo_rk;
    int memo_valid, integrations_this_step;
    double *restart_J;
    dep_acceleration_work accel;
} dep_stepper;

double dep_constraint_tolerance(double tol);
int dep_stepper_init(dep_stepper *stepper, const dep_system *system, dep_constraints *cs,
                     double tol, dep_arena *arena);
int dep_state_init(dep_state *state, int nq, int capacity, int nd, dep_arena *arena);
void dep_state_copy(dep_state *to, const dep_state *from, int nq, int nc, int nd);
int dep_outcome_init(dep_outcome *outcome, int nq, int capacity, int nd, dep_arena *arena);
void dep_stepper_derivative(dep_stepper *stepper, const dep_state *state, double *dy);
void dep_stepper_rhs(void *context, double t, const double *y, double *dy);
void dep_stepper_set_rhs(dep_stepper *stepper, double t0, double h, const double *lam0,
                         const double *lam1);
int dep_acceleration(dep_stepper *stepper, const double *q, const double *qd, double t,
                     double *lam, const double *J, long long jacobian_id, double *qdd,
                     dep_pass_report *report, dep_failure *failure);


int dep_step(dep_stepper *stepper, const dep_state *state, double h, const double *lam_predicted,
             dep_outcome *outcome, dep_failure *failure);

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
void dep_lock_torques(const dep_model *model, const dep_constraints *cs, const double *lam,
                      double *torques);
void dep_loads_observe(dep_loads *loads, double t, const double *forces, const double *torques);

/* ---- recording.c: outputs at the requested times; the Result --------------------------- */

typedef struct dep_recorder {
    const dep_system *system;
    int n_times, next_index, rows, capacity;
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

/* ---- deployment.c, mechanism.c: latches, hard stops, stick-slip (deployment.py) --------- */

typedef struct dep_mechanism_event {
    struct dep_mechanism *mechanism;
    dep_hinge_mechanics *hinge;
    int kind;
    char name[DEP_NAME_MAX + 16];
} dep_mechanism_event;

typedef struct dep_mechanism {
    const dep_model *model;
    const double *p;
    const dep_system *system;
    double tol; /* the passes' tolerance */
    int n_hinges, n_events, n_latches;
    dep_hinge_mechanics *hinges; /* the system's, every hinge */
    dep_mechanism_event *info;
    dep_event *events;
    double *angles, *rates; /* scratch, nh */
    struct dep_settle *settle;
} dep_mechanism;

/* *out is NULL when no hinge has a latch, a stop or static friction. */
int dep_mechanism_create(dep_mechanism **out, dep_system *system, double tol,
                         dep_arena *arena);
int dep_hinge_locked(const dep_hinge_mechanics *h);   /* by a latch or a stop */
int dep_hinge_sliding(const dep_hinge_mechanics *h);  /* stick-slip, slipping */
void dep_mechanism_hinge_torques(dep_mechanism *m, const double *q, const double *qd,
                                 const dep_constraints *cs, const double *lam, double *tau);
double dep_mechanism_angle(dep_mechanism *m, const dep_hinge_mechanics *h, const double *q);
double dep_mechanism_rate(dep_mechanism *m, const dep_hinge_mechanics *h, const double *q,
                          const double *qd);
const char *dep_kind_name(int kind);

/* ---- transitions.c: mode changes at an event (transitions.py, latches.py) ---------------- */

/* An event's outcome for the integrator (Python's EventResponse): rows to add and remove,
   the new state, records (NULL: the event's own, with `data`). */
typedef struct dep_change {
    int stop;
    int has_q, has_qd, impact;
    double *q, *qd;
    int n_add, n_remove;
    dep_added_row *add;
    char (*remove)[DEP_NAME_MAX];
    dep_event_record *records; /* NULL: one record, the event's, with data below */
    int n_records;
    dep_datum *data;
    int n_data, data_capacity;
} dep_change;

int dep_change_init(dep_change *change, int nq, int nh, dep_arena *arena);
void dep_change_clear(dep_change *change);
int dep_settle(dep_mechanism *m, double t, const double *q, const double *qd,
               const dep_constraints *cs, const int *due, int n_due, dep_change *change,
               dep_error *error);
int dep_settle_init(dep_mechanism *m, dep_arena *arena);

/* impacts.c: the event-time solves (latches.py). scratch: (nc + 3) nq + 2 nc doubles. */
int dep_project_positions(dep_constraints *cs, dep_multipliers *mp, dep_measurement *slots[2],
                          double *q, double t, double tol, double *scratch, long long *ids,
                          dep_failure *failure);
int dep_project_velocities(dep_constraints *cs, dep_multipliers *mp, dep_measurement *slots[2],
                           const double *q, double *qd, double t, double tol, double *scratch,
                           long long *ids, double *mu, dep_failure *failure);
int dep_plastic_impact(dep_constraints *cs, dep_multipliers *mp, dep_measurement *slots[2],
                       const double *q, const double *qd, double *qd_new, double t, double tol,
                       const char (*names)[DEP_NAME_MAX], const double *signs, int n_unilateral,
                       double *scratch, long long *ids, double *mu,
                       char (*released)[DEP_NAME_MAX], int *n_released, dep_failure *failure);
double dep_energy_loss(const dep_mass *mass, const double *a, const double *b);

/* Event record data. */
dep_datum *dep_datum_add(dep_datum *data, int *n, int capacity, const char *key,
                         const char *member);
void dep_datum_number(dep_datum *data, int *n, int capacity, const char *key, double value);
void dep_datum_text(dep_datum *data, int *n, int capacity, const char *key, const char *text);


/* settle.c, transitions.c: the state being settled (transitions.py's Context). */
#define MAX_ROUNDS_PER_EVENT 4 /* transitions allowed per mechanism event in one settle */
typedef struct dep_settle {
    dep_mechanism *m;
    const dep_system *system;
    int nq, nh;
    double t, *q, *qd, *qd_new, *lam, *mu, *scratch;
    int n_rows, added;
    dep_added_row rows[DEP_MAX_ADDED];
    long long new_ids, jacobian_ids;
    dep_event_record *records;
    int n_records, records_capacity, data_capacity;
    int n_impacting, impacting[DEP_MAX_ADDED];
    char impacting_rows[DEP_MAX_ADDED][DEP_NAME_MAX];
    char (*unilateral)[DEP_NAME_MAX], (*released)[DEP_NAME_MAX];
    double *signs;
    int *queue, *starting, queue_capacity; /* starting: g starts at 0 in the new mode */
    dep_constraints cs;
    dep_multipliers mp;
    dep_measurement slots[4];
    dep_acceleration_work accel;
    dep_active_rows view;
    dep_failure failure;
} settle_context;



int dep_settle_row_index(const settle_context *x, const char *name);
void dep_settle_remove_row(settle_context *x, const dep_hinge_mechanics *h, const char *kind);
const char *dep_settle_add_lock(settle_context *x, const dep_hinge_mechanics *h, double angle,
                                const char *kind);
dep_constraints *dep_settle_constraints(settle_context *x, char (*skip)[DEP_NAME_MAX],
                                        int n_skip);
dep_event_record *dep_settle_record(settle_context *x, const dep_hinge_mechanics *h,
                                    const char *what);
void dep_settle_put_number(settle_context *x, dep_event_record *r, const char *key, double v);
void dep_settle_put_text(settle_context *x, dep_event_record *r, const char *key,
                         const char *text);
void dep_settle_put_kind(settle_context *x, dep_event_record *r, const char *key, int kind,
                         double v);
int dep_settle_multipliers(settle_context *x);
int dep_settle_multiplier_of(settle_context *x, const dep_hinge_mechanics *h, const char *kind,
                             double *value);
void dep_settle_starting(settle_context *x, const dep_hinge_mechanics *h, int kind);
double dep_settle_slip_direction(double lam, double previous);
int dep_settle_event_index(const dep_mechanism *m, const dep_hinge_mechanics *h, int kind);
int dep_settle_transition(settle_context *x, int e, int *queue, int *n_queue);
int dep_settle_impact(settle_context *x, int *follow, int *n_follow);
int dep_settle_project(settle_context *x);

int dep_mechanism_start(dep_mechanism *m, const double *q, const double *qd, int *due);
int dep_cs_prepare_row(const dep_constraints *cs, const dep_row *row, dep_added_row *out,
                       dep_error *error);

/* ---- integrator.c and firing.c: one run (integrator.py's IterativeRun) --------------------- */

typedef struct dep_run {
    const dep_model *model;
    dep_settings settings;
    dep_error *error;
    dep_arena arena;
    dep_system system;
    dep_constraints cs;
    dep_stepper stepper;
    dep_recorder recorder;
    dep_watch watch;
    int n_user_events;
    dep_tally tally;
    dep_history history;
    dep_loads loads;
    dep_state state;
    dep_outcome outcome, fired;
    dep_change change;
    dep_event_response *response;
    dep_row *response_rows; /* DEP_MAX_ADDED: the added rows a callback sees */
    double h_min, h_cap;
    int nq, nd, ny;
    double *p, *scratch, *y, *dy, *q, *qd, *lam, *work, *predicted, *mass_qd;
    double *dense_J, *dense_lam;
    dep_active_rows state_rows, dense_rows;
    dep_event_record *records;
    int n_records, records_capacity;
} dep_run;

int dep_run_pass_error(dep_run *run, const dep_failure *failure, double t);
int dep_run_restart(dep_run *run, double t, const double *q, const double *qd,
                    const double *work, const char *stage);
int dep_run_record_until(dep_run *run, double t_until, const dep_outcome *end);
int dep_run_start(dep_run *run, const double *q0, const double *qd0);
int dep_run_after_step(dep_run *run, int *stop);
const dep_active_rows *dep_run_rows(dep_run *run, const dep_state *state);

#endif /* DEPSIM_RUNTIME_H */
