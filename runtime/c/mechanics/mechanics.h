/* mechanics.h: latches, hard stops and stick-slip friction (runtime/c/README.md,
 * docs/deployment.md): the hinges' modes, the events that change them, and what happens at one
 * (the transitions, the plastic impact of the rows that engage, the projection onto the new
 * constraints). It uses the method (method.h) and knows nothing of a run.
 *
 *   modes.c        the modes, their event functions, the start, the hinges' lock torques
 *   impacts.c      the event-time solves: plastic impact, projections of q and qd
 *   settling.c     the state being settled: its rows, records and multipliers
 *   transitions.c  the mode changes of latches, stops and stick-slip hinges
 *   mechanism.c    the mechanism of a system, and settling its modes at an event
 */
#ifndef DEPSIM_MECHANICS_H
#define DEPSIM_MECHANICS_H

#include "../method/method.h"

/* The kinds of a hinge's events: its latch, its stops, stick-slip, and its hold-down's
   release (held from t = 0: engaged when the run starts, released at `release`). */
enum dep_kind { DEP_KIND_LATCH, DEP_KIND_STOP_MIN, DEP_KIND_STOP_MAX, DEP_KIND_STICK,
                DEP_KIND_HOLD, DEP_KINDS };

/* ---- modes.c, mechanism.c: latches, hard stops, stick-slip ------------------------------- */

typedef struct dep_mechanism_event {
    struct dep_mechanism *mechanism;
    dep_hinge_mechanics *hinge;
    int kind;
    char name[DEP_NAME_MAX + 16];
} dep_mechanism_event;

typedef struct dep_mechanism {
    const dep_model *model;
    const dep_system *system; /* its parameters: system->p */
    double tol; /* the passes' tolerance */
    int n_hinges, n_events, n_latches;
    dep_hinge_mechanics *hinges; /* the system's, every hinge */
    dep_mechanism_event *info;
    dep_event *events;
    double *angles, *rates; /* scratch, nh */
    struct dep_settle *settle;
} dep_mechanism;

/* mechanism.c: the mechanism of the system's hinges and its settle context; *out is NULL
   when no hinge has a latch, a stop or static friction (or the system was set up without
   mechanics). */
int dep_mechanism_create(dep_mechanism **out, const dep_system *system, double tol,
                         dep_arena *arena);
/* modes.c: the kinds of h's events (enum dep_kind) into out (DEP_KINDS); their count. */
int dep_hinge_event_kinds(const dep_hinge_mechanics *h, int *out);
/* The mechanism's events (m->info, m->events: one per hinge and kind). */
void dep_mechanism_make_events(dep_mechanism *m);
/* The mechanism event of hinge h's transition `kind`, or -1. */
int dep_mechanism_event_index(const dep_mechanism *m, const dep_hinge_mechanics *h, int kind);
/* Each hinge's lock torque (nh), NAN while free: -lambda of its lock rows, or the compliant
   latch's torque -side P while in contact. */
void dep_mechanism_hinge_torques(dep_mechanism *m, const double *q, const double *qd,
                                 const dep_constraints *cs, const double *lam, double *tau);
double dep_mechanism_angle(dep_mechanism *m, const dep_hinge_mechanics *h, const double *q);
double dep_mechanism_rate(dep_mechanism *m, const dep_hinge_mechanics *h, const double *q,
                          const double *qd);
const char *dep_kind_name(int kind);
/* Mechanism.start: latch sides and slip directions from the initial state; due[] gets the
   events due at once; their count. */
int dep_mechanism_start(dep_mechanism *m, const double *q, const double *qd, int *due);

/* ---- mechanism.c: settling the modes at an event --------------------------------------- */

#define DEP_USER_DATA (DEP_MAX_DATA + 1) /* a user event's numbers and impact_energy_loss */

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
/* settle: apply the transitions of the mechanism events due[] and every one they make due.
   change: cleared by the caller; its records stay valid until the next settle. */
int dep_settle(dep_mechanism *m, double t, const double *q, const double *qd,
               const dep_constraints *cs, const int *due, int n_due, dep_change *change,
               dep_error *error);

/* impacts.c: the event-time solves. scratch: DEP_JACOBIAN_SIZE + 3 nq + 2 nc doubles. */
int dep_project_positions(dep_constraints *cs, dep_multipliers *mp, dep_measurement *slots[2],
                          double *q, double t, double tol, double *scratch, long long *ids,
                          dep_failure *failure);
int dep_project_velocities(dep_constraints *cs, dep_multipliers *mp, dep_measurement *slots[2],
                           const double *q, double *qd, double t, double tol, double *scratch,
                           long long *ids, double *mu, dep_failure *failure);
/* qd+ projected onto cs's velocity constraints, the stop rows of the hinges stops[k] unilateral
   (signs[k] = +1: may only push with mu >= 0, -1: mu <= 0); a stop whose impulse would pull is
   released (its hinge appended to released[]). mu: the remaining rows' impulses. */
int dep_plastic_impact(dep_constraints *cs, dep_multipliers *mp, dep_measurement *slots[2],
                       const double *q, const double *qd, double *qd_new, double t, double tol,
                       const int *stops, const double *signs, int n_stops, double *scratch,
                       long long *ids, double *mu, int *released, int *n_released,
                       dep_failure *failure);
double dep_energy_loss(const dep_mass *mass, const double *a, const double *b);

/* ---- settling.c, transitions.c: the state being settled ----------------------------------- */

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
    /* the records of the rows that just engaged, and those rows' locks and hinges */
    int n_impacting, impacting[DEP_MAX_ADDED];
    int impacting_locks[DEP_MAX_ADDED], impacting_hinges[DEP_MAX_ADDED];
    int *stops, *released; /* nh: the hinges at a stop in an impact, those it released */
    int *stuck;            /* nh: 1 for a hinge stuck before an impact */
    int *force_rows;       /* DEP_FORCE_ROWS nh: each hinge's reaction rows */
    double *signs;
    int *queue, *starting, queue_capacity; /* starting: g starts at 0 in the new mode */
    dep_constraints cs;
    dep_multipliers mp;
    dep_measurement slots[4];
    dep_acceleration_work accel;
    dep_active_rows view;
    dep_failure failure;
} settle_context;

/* Lock rows by their lock (enum dep_lock) and hinge. */
void dep_settle_remove_row(settle_context *x, const dep_hinge_mechanics *h, int lock);
void dep_settle_add_lock(settle_context *x, const dep_hinge_mechanics *h, double angle, int lock);
/* A hold-down's lock row "<h>.hold" at `angle` (an event lock, enum dep_lock). */
void dep_settle_add_hold(settle_context *x, const dep_hinge_mechanics *h, double angle);
dep_constraints *dep_settle_constraints(settle_context *x, const int *skip_stick);
dep_event_record *dep_settle_record(settle_context *x, const dep_hinge_mechanics *h,
                                    int kind);
void dep_settle_put_number(settle_context *x, dep_event_record *r, const char *key, double v);
void dep_settle_put_text(settle_context *x, dep_event_record *r, const char *key,
                         const char *text);
void dep_settle_put_kind(settle_context *x, dep_event_record *r, const char *key, int kind,
                         double v);
int dep_settle_multipliers(settle_context *x);
int dep_settle_multiplier_of(settle_context *x, const dep_hinge_mechanics *h, int lock,
                             double *value);
void dep_settle_starting(settle_context *x, const dep_hinge_mechanics *h, int kind);
double dep_settle_slip_direction(double lam, double previous);
/* transitions.c */
int dep_settle_transition(settle_context *x, int e, int *queue, int *n_queue);
int dep_settle_impact(settle_context *x, int *follow, int *n_follow);
int dep_settle_project(settle_context *x);

#endif /* DEPSIM_MECHANICS_H */
