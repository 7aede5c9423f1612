/* settle.c: settling the mechanism's modes at an event (docs/deployment.md,
 * sections 1-4).
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

#include "runtime.h"

#define RECORD_DATA 10 /* data entries of a record besides the joint impulses */

int dep_settle_init(dep_mechanism *m, dep_arena *arena)
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
    x->unilateral = dep_bytes(arena, (size_t)m->n_hinges * DEP_NAME_MAX);
    x->released = dep_bytes(arena, (size_t)m->n_hinges * DEP_NAME_MAX);
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

/* ---- the context: rows, records --------------------------------------------------------- */

int dep_settle_row_index(const settle_context *x, const char *name)
{
    for (int i = 0; i < x->n_rows; ++i) {
        if (strcmp(x->rows[i].name, name) == 0) {
            return i;
        }
    }
    return -1;
}

void dep_settle_remove_row(settle_context *x, const dep_hinge_mechanics *h, const char *kind)
{
    char name[DEP_NAME_MAX + 16];
    snprintf(name, sizeof name, "%s.%s", h->name, kind);
    int i = dep_settle_row_index(x, name);
    if (i >= 0) {
        memmove(&x->rows[i], &x->rows[i + 1], (size_t)(x->n_rows - i - 1) * sizeof *x->rows);
        x->n_rows--;
    }
}

/* A lock row "<h>.<kind>" at `angle` (replacing one of that name in place, as a dict does). */
const char *dep_settle_add_lock(settle_context *x, const dep_hinge_mechanics *h, double angle,
                            const char *kind)
{
    char name[DEP_NAME_MAX + 16];
    snprintf(name, sizeof name, "%s.%s", h->name, kind);
    int i = dep_settle_row_index(x, name);
    if (i < 0) {
        i = x->n_rows < DEP_MAX_ADDED ? x->n_rows++ : DEP_MAX_ADDED - 1;
    }
    dep_added_row *r = &x->rows[i];
    memset(r, 0, sizeof *r);
    r->id = --x->new_ids;
    r->kind = DEP_ROW_HINGE_LOCK;
    r->hinge = h->index;
    r->angle = angle;
    dep_copy_text(r->name, sizeof r->name, name);
    dep_copy_text(r->joint, sizeof r->joint, h->name);
    x->added = 1;
    return r->name;
}

/* The context's rows as a constraint set, without the rows named in skip[]. */
dep_constraints *dep_settle_constraints(settle_context *x, char (*skip)[DEP_NAME_MAX], int n_skip)
{
    dep_added_row kept[DEP_MAX_ADDED];
    int n = 0;
    for (int i = 0; i < x->n_rows; ++i) {
        int skipped = 0;
        for (int k = 0; k < n_skip; ++k) {
            skipped |= strcmp(x->rows[i].name, skip[k]) == 0;
        }
        if (!skipped) {
            kept[n++] = x->rows[i];
        }
    }
    dep_cs_assign(&x->cs, kept, n);
    return &x->cs;
}

dep_event_record *dep_settle_record(settle_context *x, const dep_hinge_mechanics *h, const char *what)
{
    dep_event_record *r = &x->records[x->n_records < x->records_capacity ? x->n_records++
                                                                          : x->n_records - 1];
    snprintf(r->name, sizeof r->name, "%.*s.%s", DEP_NAME_MAX - 32, h->name, what);
    r->n_data = 0;
    dep_datum_text(r->data, &r->n_data, x->data_capacity, "hinge", h->name);
    return r;
}

void dep_settle_put_number(settle_context *x, dep_event_record *r, const char *key, double value)
{
    dep_datum_number(r->data, &r->n_data, x->data_capacity, key, value);
}

void dep_settle_put_text(settle_context *x, dep_event_record *r, const char *key, const char *text)
{
    dep_datum_text(r->data, &r->n_data, x->data_capacity, key, text);
}

void dep_settle_put_kind(settle_context *x, dep_event_record *r, const char *key, int kind, double v)
{
    dep_datum *d = dep_datum_add(r->data, &r->n_data, x->data_capacity, key, "");
    if (d != NULL) {
        d->kind = kind;
        d->number = v;
    }
}

/* {row name: lambda} at the context's state and modes (acceleration pass from zero). */
int dep_settle_multipliers(settle_context *x)
{
    dep_constraints *cs = dep_settle_constraints(x, NULL, 0);
    dep_pass_report report;
    dep_cs_jacobian(cs, x->q, x->t, x->scratch);
    memset(x->lam, 0, (size_t)cs->nc * sizeof *x->lam);
    x->view.nc = cs->nc;
    x->view.names = cs->row_names;
    x->view.lam = x->lam;
    return dep_acceleration_pass(&x->accel, x->q, x->qd, x->t, x->scratch, ++x->jacobian_ids,
                                 x->lam, NULL, x->m->tol, &report, &x->failure);
}

int dep_settle_multiplier_of(settle_context *x, const dep_hinge_mechanics *h, const char *kind,
                         double *value)
{
    char name[DEP_NAME_MAX + 16];
    int status = dep_settle_multipliers(x);
    snprintf(name, sizeof name, "%s.%s", h->name, kind);
    *value = status == DEP_OK ? x->lam[dep_cs_index(&x->cs, name)] : NAN;
    return status;
}

/* The mode of hinge h's event `kind` starts on its boundary (g = 0): not re-checked here. */
void dep_settle_starting(settle_context *x, const dep_hinge_mechanics *h, int kind)
{
    int e = dep_settle_event_index(x->m, h, kind);
    if (e >= 0) {
        x->starting[e] = 1;
    }
}

double dep_settle_slip_direction(double lam, double previous)
{
    return lam == 0.0 ? previous : lam > 0 ? 1.0 : -1.0;
}

/* ---- settle ------------------------------------------------------------------------------- */

/* The mechanism event of hinge h's transition `kind`, or -1. */
int dep_settle_event_index(const dep_mechanism *m, const dep_hinge_mechanics *h, int kind)
{
    for (int e = 0; e < m->n_events; ++e) {
        if (m->info[e].hinge == h && m->info[e].kind == kind) {
            return e;
        }
    }
    return -1;
}

/* Events whose g is already negative at the context's state (except those whose mode has
   just started on its boundary). */
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
        if (g < 0) {
            pending[(*n_pending)++] = e;
        }
    }
    return DEP_OK;
}

static int settle_error(settle_context *x, int status, double t, int limit, dep_error *error)
{
    char what[400];
    if (status == DEP_PASS_FAILED) {
        snprintf(what, sizeof what, "a mechanism transition did not converge: %s",
                 x->failure.reason);
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

/* ---- event record data -------------------------------------------------------------------- */

/* The entry (key, member) of data (n entries, room for capacity): the existing one, or a
   new one at the end (a dict's assignment); NULL when full. */
dep_datum *dep_datum_add(dep_datum *data, int *n, int capacity, const char *key,
                         const char *member)
{
    for (int i = 0; i < *n; ++i) {
        if (strcmp(data[i].key, key) == 0 && strcmp(data[i].member, member) == 0) {
            return &data[i];
        }
    }
    if (*n == capacity) {
        return NULL;
    }
    dep_datum *d = &data[(*n)++];
    memset(d, 0, sizeof *d);
    dep_copy_text(d->key, sizeof d->key, key);
    dep_copy_text(d->member, sizeof d->member, member);
    return d;
}

void dep_datum_number(dep_datum *data, int *n, int capacity, const char *key, double value)
{
    dep_datum *d = dep_datum_add(data, n, capacity, key, "");
    if (d != NULL) {
        d->kind = DEP_NUMBER;
        d->number = value;
    }
}

void dep_datum_text(dep_datum *data, int *n, int capacity, const char *key, const char *text)
{
    dep_datum *d = dep_datum_add(data, n, capacity, key, "");
    if (d != NULL) {
        d->kind = DEP_TEXT;
        dep_copy_text(d->text, sizeof d->text, text);
    }
}
