/* mechanism.c: the mechanism of a system's latches, hard stops and stick-slip hinges, and
 * settling their modes at an event (docs/deployment.md, sections 1-4; mechanics.h).
 *
 * dep_settle applies the transitions due (transitions.c), then, until none is left, every
 * transition whose event function is already negative at the current state (two hinges
 * latching at once, a stop whose multiplier pulls right after the impact), except for events
 * whose new mode starts on its boundary g = 0 by construction (a slip from rest, a stop's
 * release, a compliant latch's contact or separation: round-off must not switch them back).
 * When rows were added, q and qd are finally projected onto every constraint. The records
 * carry the kinetic energy each impact removed (`impact_energy_loss`).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "mechanics.h"

#define RECORD_DATA 10 /* data entries of a record besides the joint impulses */

/* The settle context of m (m->settle). */
static int settle_init(dep_mechanism *m, dep_arena *arena)
{
    const dep_system *s = m->system;
    size_t nq = (size_t)s->nq, nh = (size_t)s->nh, capacity = (size_t)s->model->nc + DEP_MAX_ADDED;
    settle_context *x = dep_bytes(arena, sizeof *x);
    m->settle = x;
    if (x == NULL || dep_constraints_init(&x->cs, s, arena) != DEP_OK
        || dep_multipliers_init(&x->mp, &s->mass, &x->cs, (int)capacity, arena) != DEP_OK) {
        return DEP_MEMORY_ERROR;
    }
    x->m = m;
    x->system = s;
    x->nq = s->nq;
    x->nh = s->nh;
    for (int k = 0; k < 4; ++k) {
        if (dep_measurement_init(&x->slots[k], s->model, (int)capacity, 0, k < 2, arena)) {
            return DEP_MEMORY_ERROR;
        }
    }
    x->q = dep_doubles(arena, nq);
    x->qd = dep_doubles(arena, nq);
    x->qd_new = dep_doubles(arena, nq);
    x->lam = dep_doubles(arena, capacity);
    x->mu = dep_doubles(arena, capacity);
    x->scratch = dep_doubles(arena, DEP_JACOBIAN_SIZE(s->model) + 4 * nq + 3 * capacity);
    x->queue_capacity = MAX_ROUNDS_PER_EVENT * (m->n_events + 1) * ((int)nh + 2) + 8;
    x->queue = dep_bytes(arena, (size_t)x->queue_capacity * sizeof *x->queue);
    x->starting = dep_bytes(arena, (size_t)m->n_events * sizeof *x->starting);
    x->records_capacity = 3 * x->queue_capacity;
    x->data_capacity = RECORD_DATA + (int)nh;
    x->records = dep_bytes(arena, (size_t)x->records_capacity * sizeof *x->records);
    /* one block for every record's data (2 MB for INTELSAT V), not zeroed: dep_datum_add sets
       each datum it hands out, so a run pays only for the records it writes */
    dep_datum *data = dep_bytes_unset(arena, (size_t)x->records_capacity
                                                 * (size_t)x->data_capacity * sizeof *data);
    for (int r = 0; x->records != NULL && data != NULL && r < x->records_capacity; ++r) {
        x->records[r].data = data + (size_t)r * (size_t)x->data_capacity;
    }
    int **per_hinge[] = {&x->stops, &x->released, &x->stuck};
    for (int k = 0; k < 3; ++k) {
        *per_hinge[k] = dep_bytes(arena, (nh + 1) * sizeof(int));
    }
    x->force_rows = dep_bytes(arena, (DEP_FORCE_ROWS * nh + 1) * sizeof *x->force_rows);
    if (x->force_rows != NULL) {
        dep_hinge_force_rows(s->model, x->force_rows);
    }
    x->signs = dep_doubles(arena, (size_t)m->n_hinges);
    double **accel[] = {&x->accel.f, &x->accel.jt, &x->accel.solved};
    for (int k = 0; k < 3; ++k) {
        *accel[k] = dep_doubles(arena, nq);
    }
    x->accel.gamma = dep_doubles(arena, capacity);
    x->accel.system = s;
    x->accel.cs = &x->cs;
    x->accel.mp = &x->mp;
    x->accel.slots[0] = &x->slots[2];
    x->accel.slots[1] = &x->slots[3];
    return arena->failed ? DEP_MEMORY_ERROR : DEP_OK;
}

/* The mechanism of the system's hinges and its settle context; *out is NULL when none has a
   latch, a stop or static friction (or the system was set up without mechanics). */
int dep_mechanism_create(dep_mechanism **out, const dep_system *system, double tol,
                         dep_arena *arena)
{
    const dep_model *model = system->model;
    int nh = system->nh, list[DEP_KINDS], n_events = 0, n_latches = 0;
    *out = NULL;
    for (int i = 0; i < nh; ++i) {
        n_events += dep_hinge_event_kinds(&system->hinges[i], list);
        n_latches += system->hinges[i].has_latch;
    }
    if (n_events == 0) {
        return DEP_OK;
    }
    dep_mechanism *m = dep_bytes(arena, sizeof *m);
    if (m == NULL) {
        return DEP_MEMORY_ERROR;
    }
    m->model = model;
    m->system = system;
    m->tol = tol;
    m->hinges = system->hinges;
    m->n_hinges = nh;
    m->n_events = n_events;
    m->n_latches = n_latches;
    m->info = dep_bytes(arena, (size_t)n_events * sizeof *m->info);
    m->events = dep_bytes(arena, (size_t)n_events * sizeof *m->events);
    m->angles = dep_doubles(arena, (size_t)nh);
    m->rates = dep_doubles(arena, (size_t)nh);
    if (arena->failed) {
        return DEP_MEMORY_ERROR;
    }
    dep_mechanism_make_events(m);
    *out = m;
    return settle_init(m, arena);
}

int dep_change_init(dep_change *change, int nq, int nh, dep_arena *arena)
{
    (void)nh;
    memset(change, 0, sizeof *change);
    change->q = dep_doubles(arena, (size_t)nq);
    change->qd = dep_doubles(arena, (size_t)nq);
    change->add = dep_bytes(arena, DEP_MAX_ADDED * sizeof *change->add);
    change->remove = dep_bytes(arena, DEP_MAX_ADDED * sizeof *change->remove);
    change->data_capacity = DEP_USER_DATA;
    change->data = dep_bytes(arena, DEP_USER_DATA * sizeof *change->data);
    return arena->failed ? DEP_MEMORY_ERROR : DEP_OK;
}

void dep_change_clear(dep_change *change)
{
    change->stop = -1;
    change->has_q = change->has_qd = change->impact = 0;
    change->n_add = change->n_remove = change->n_records = change->n_data = 0;
    change->records = NULL;
}

/* ---- settle ------------------------------------------------------------------------------- */

/* A hold-down whose release time is within this much (relative, s) of the instant is
   released now: hinges held until one time are released together, wherever the located
   event time fell within its tolerance. */
#define RELEASE_SLACK 1e-9

/* Events whose g is already negative at the context's state (except those whose mode has
   just started on its boundary), and hold-downs due for release. */
static int violated(settle_context *x, int *pending, int *n_pending, dep_error *error)
{
    dep_mechanism *m = x->m;
    int have_lam = 0;
    for (int e = 0; e < m->n_events; ++e) {
        double g;
        if (x->starting[e]) {
            continue;
        }
        if (m->events[e].multipliers && !have_lam) {
            int status = dep_settle_multipliers(x);
            if (status != DEP_OK) {
                return status;
            }
            have_lam = 1;
        }
        int status = dep_event_value(&m->events[e], x->t, x->q, x->qd,
                                     m->events[e].multipliers ? &x->view : NULL, &g, error);
        if (status != DEP_OK) {
            return status;
        }
        if (g < 0 || (m->info[e].kind == DEP_KIND_HOLD
                      && g <= RELEASE_SLACK * fmax(1.0, fabs(x->t)))) {
            pending[(*n_pending)++] = e;
        }
    }
    return DEP_OK;
}

static int settle_error(settle_context *x, int status, double t, int limit, dep_error *error)
{
    char what[700];
    if (status == DEP_PASS_FAILED) {
        const dep_failure *f = &x->failure;
        snprintf(what, sizeof what, "a mechanism transition did not converge: %s; residual "
                 "%.3g, limit %.3g, round-off %.2g, condition of Phi_q M^-1 Phi_q^T about "
                 "%.1e (rank %d of %d rows)", f->reason, f->residual, f->limit, f->roundoff,
                 f->condition, f->rank, f->rows);
        return dep_solver_error(error, 1, t, "event", NULL, NULL, 1, x->failure.residual, what,
                                "a latch or stop made the constraints redundant and "
                                "inconsistent, or Phi_q singular");
    }
    if (status != DEP_OK) {
        return status;
    }
    snprintf(what, sizeof what, "latches, stops and stick-slip friction did not settle after "
             "%d transitions at one instant", limit);
    return dep_solver_error(error, 1, t, "event", NULL, NULL, 0, 0.0, what,
                            "the hinges switch modes endlessly (chattering); check "
                            "static_friction against the driving torques");
}

/* The change for the integrator: rows added and removed against cs, the state, records. */
static void response(settle_context *x, const dep_constraints *cs, dep_change *change)
{
    change->has_q = change->has_qd = 1;
    memcpy(change->q, x->q, (size_t)x->nq * sizeof *x->q);
    memcpy(change->qd, x->qd, (size_t)x->nq * sizeof *x->qd);
    for (int i = 0; i < cs->n_added; ++i) {
        int kept = 0;
        for (int k = 0; k < x->n_rows; ++k) {
            kept |= x->rows[k].id == cs->added[i].id;
        }
        if (!kept) {
            dep_copy_text(change->remove[change->n_remove++], DEP_NAME_MAX, cs->added[i].name);
        }
    }
    for (int k = 0; k < x->n_rows; ++k) {
        int old = 0;
        for (int i = 0; i < cs->n_added; ++i) {
            old |= x->rows[k].id == cs->added[i].id;
        }
        if (!old) {
            change->add[change->n_add++] = x->rows[k];
        }
    }
    change->records = x->records;
    change->n_records = x->n_records;
}

/* settle: apply the transitions of the mechanism events due[] and every one they make due.
   change: cleared by the caller; its records stay valid until the next settle. */
int dep_settle(dep_mechanism *m, double t, const double *q, const double *qd,
               const dep_constraints *cs, const int *due, int n_due, dep_change *change,
               dep_error *error)
{
    settle_context *x = m->settle;
    int limit = MAX_ROUNDS_PER_EVENT * (m->n_events > 1 ? m->n_events : 1), head = 0;
    int n_queue = 0, status = DEP_OK, round = 0;
    x->t = t;
    x->added = x->n_records = x->n_impacting = 0;
    memcpy(x->q, q, (size_t)x->nq * sizeof *q);
    memcpy(x->qd, qd, (size_t)x->nq * sizeof *qd);
    x->n_rows = cs->n_added;
    memcpy(x->rows, cs->added, (size_t)cs->n_added * sizeof *x->rows);
    memset(x->starting, 0, (size_t)m->n_events * sizeof *x->starting);
    for (int k = 0; k < n_due; ++k) {
        x->queue[n_queue++] = due[k];
    }
    for (; round < limit && status == DEP_OK; ++round) {
        if (head == n_queue) {
            head = n_queue = 0;
            status = violated(x, x->queue, &n_queue, error);
            if (status != DEP_OK || n_queue == 0) {
                break;
            }
        }
        int e = x->queue[head++];
        x->starting[e] = 0;
        status = dep_settle_transition(x, e, x->queue, &n_queue);
    }
    if (status == DEP_OK && round == limit) {
        return settle_error(x, DEP_OK, t, limit, error);
    }
    if (status == DEP_OK && x->added) {
        status = dep_settle_project(x);
    }
    if (status != DEP_OK) {
        return settle_error(x, status, t, limit, error);
    }
    response(x, cs, change);
    return DEP_OK;
}
