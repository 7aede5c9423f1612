/* runtime.h: the integrator's internal parts, for its own .c files (the public interface is
 * depsim.h). One header per layer, each including the one below:
 *
 *   system.h     memory, errors, the mass matrix, hinge properties, the model bound to p
 *   method.h     constraint rows, Dormand-Prince, the iteration (6), step control, a step
 *   run.h        events, loads, recording, the summary, counters
 *   mechanics.h  latches, hard stops, stick-slip friction
 *
 * and here one run (integrator.c, firing.c).
 */
#ifndef DEPSIM_RUNTIME_H
#define DEPSIM_RUNTIME_H

#include "mechanics.h"

/* ---- integrator.c and firing.c: one run -------------------------------------------- */

#define DEP_USER_DATA (DEP_MAX_DATA + 1) /* a user event's numbers and impact_energy_loss */

/* The accepted point before run->state (for the velocity interpolant, dopri.c); valid is 0
   after a start or an event. */
typedef struct dep_prior {
    int valid;
    double t;
    double *qd, *qdd;
} dep_prior;

struct dep_run { /* typedef in depsim.h */
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
    dep_history friction;      /* the hinges' friction torques at the same points (nh) */
    double *friction_predicted, *friction_table, *friction_d; /* scratch */
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
    double t_stop;   /* the end of the current dep_advance: no step passes it */
    double h_next;   /* the step size to try next; 0: none yet (first_step) */
    int recording;   /* 1: outputs at the output times (dep_simulate); 0: dep_open's runs */
    int stopped;     /* a terminal event ended the run */
};

int dep_run_pass_error(dep_run *run, const dep_failure *failure, double t);
int dep_run_restart(dep_run *run, double t, const double *q, const double *qd,
                    const double *work, const char *stage);
int dep_run_record_until(dep_run *run, double t_until, const dep_outcome *end);
int dep_run_start(dep_run *run, const double *q0, const double *qd0);
int dep_run_assemble(dep_run *run, double *q, double *qd); /* assembly.c */
int dep_run_after_step(dep_run *run, int *stop);
int dep_run_step(dep_run *run, double h, dep_outcome *outcome, dep_failure *failure);
void dep_run_attach_prior(const dep_run *run, dep_outcome *end);
const dep_active_rows *dep_run_rows(dep_run *run, const dep_state *state);
void dep_run_observe_loads(dep_run *run, const dep_state *s);
int dep_run_add_record(dep_run *run, const char *name, double t, const dep_datum *data, int n);
int dep_run_log_event(dep_run *run, const char *name, double t, const dep_change *change);
int dep_run_apply_change(dep_run *run, dep_change *change, const dep_state *here);

#endif /* DEPSIM_RUNTIME_H */
