/* mechanics.h: latches, hard stops and stick-slip friction: the hinges' modes, their
 * events and what happens at one (deployment.c, transitions.c, settle.c, impacts.c)
 */
#ifndef DEPSIM_MECHANICS_H
#define DEPSIM_MECHANICS_H

#include "run.h"

/* ---- deployment.c, mechanism.c: latches, hard stops, stick-slip ------------------------ */

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

/* ---- transitions.c: mode changes at an event ------------------------------------------- */

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

/* impacts.c: the event-time solves. scratch: DEP_JACOBIAN_SIZE + 3 nq + 2 nc doubles. */
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


/* settle.c, transitions.c: the state being settled */
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

#endif /* DEPSIM_MECHANICS_H */
