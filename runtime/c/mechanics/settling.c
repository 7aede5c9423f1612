/* settling.c: the state being settled at an event (mechanism.c, transitions.c): its constraint
 * rows (the lock rows of latches, stops and stuck hinges), the event records it writes, and
 * the multipliers of its rows at its state (mechanics.h).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "mechanics.h"

/* The context's row that locks hinge h by `lock` (enum dep_lock), or -1. */
static int row_index(const settle_context *x, const dep_hinge_mechanics *h, int lock)
{
    for (int i = 0; i < x->n_rows; ++i) {
        if (x->rows[i].lock == lock && x->rows[i].hinge == h->index) {
            return i;
        }
    }
    return -1;
}

void dep_settle_remove_row(settle_context *x, const dep_hinge_mechanics *h, int lock)
{
    int i = row_index(x, h, lock);
    if (i >= 0) {
        memmove(&x->rows[i], &x->rows[i + 1], (size_t)(x->n_rows - i - 1) * sizeof *x->rows);
        x->n_rows--;
    }
}

/* A lock row "<h>.<lock's name>" at `angle` (replacing h's row of that lock in place, as a
   dict does). */
void dep_settle_add_lock(settle_context *x, const dep_hinge_mechanics *h, double angle, int lock)
{
    int i = row_index(x, h, lock);
    if (i < 0) {
        i = x->n_rows < DEP_MAX_ADDED ? x->n_rows++ : DEP_MAX_ADDED - 1;
    }
    dep_added_row *r = &x->rows[i];
    memset(r, 0, sizeof *r);
    r->id = --x->new_ids;
    r->kind = DEP_ROW_HINGE_LOCK;
    r->lock = lock;
    r->hinge = h->index;
    r->angle = angle;
    snprintf(r->name, sizeof r->name, "%.*s.%s", DEP_NAME_MAX - 8, h->name, dep_lock_name(lock));
    dep_copy_text(r->joint, sizeof r->joint, h->name);
    x->added = 1;
}

void dep_settle_add_hold(settle_context *x, const dep_hinge_mechanics *h, double angle)
{
    dep_settle_add_lock(x, h, angle, DEP_LOCK_EVENT);
    int i = row_index(x, h, DEP_LOCK_EVENT);
    snprintf(x->rows[i].name, sizeof x->rows[i].name, "%.*s.hold", DEP_NAME_MAX - 8, h->name);
}

/* The context's rows as a constraint set, without the stick rows of the hinges flagged in
   skip_stick (nh flags, or NULL). */
dep_constraints *dep_settle_constraints(settle_context *x, const int *skip_stick)
{
    dep_added_row kept[DEP_MAX_ADDED];
    int n = 0;
    for (int i = 0; i < x->n_rows; ++i) {
        const dep_added_row *r = &x->rows[i];
        if (skip_stick == NULL || r->lock != DEP_LOCK_STICK || !skip_stick[r->hinge]) {
            kept[n++] = *r;
        }
    }
    dep_cs_assign(&x->cs, kept, n);
    return &x->cs;
}

/* A record of hinge h's transition `kind` (enum dep_record_kind), named "<h>.<transition>". */
dep_event_record *dep_settle_record(settle_context *x, const dep_hinge_mechanics *h, int kind)
{
    static const char *const TRANSITIONS[DEP_RECORD_RELEASE + 1] = {
        "", "latch", "latch.contact", "latch.separation", "stop", "stick", "slip", "",
        "hold", "release"};
    dep_event_record *r = &x->records[x->n_records < x->records_capacity ? x->n_records++
                                                                          : x->n_records - 1];
    snprintf(r->name, sizeof r->name, "%.*s.%s", DEP_NAME_MAX - 32, h->name, TRANSITIONS[kind]);
    r->kind = kind;
    r->hinge = h->index;
    r->n_data = 0;
    dep_datum_text(r->data, &r->n_data, x->data_capacity, "hinge", h->name);
    return r;
}

/* A record's number `key`; a slider's record says "position" (m) and "force" (N, along its
   axis) where a hinge's says "angle" and "torque" (its rate is in m/s, its impulse N*s). */
void dep_settle_put_number(settle_context *x, dep_event_record *r, const char *key, double value)
{
    if (r->hinge >= 0 && dep_hinge_slider(x->m->model, r->hinge) >= 0) {
        key = strcmp(key, "angle") == 0 ? "position" : strcmp(key, "torque") == 0 ? "force" : key;
    }
    dep_datum_number(r->data, &r->n_data, x->data_capacity, key, value);
}

void dep_settle_put_text(settle_context *x, dep_event_record *r, const char *key, const char *text)
{
    dep_datum_text(r->data, &r->n_data, x->data_capacity, key, text);
}

void dep_settle_put_kind(settle_context *x, dep_event_record *r, const char *key, int kind,
                         double v)
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
    dep_constraints *cs = dep_settle_constraints(x, NULL);
    dep_pass_report report;
    dep_cs_jacobian(cs, x->q, x->t, x->scratch);
    memset(x->lam, 0, (size_t)cs->nc * sizeof *x->lam);
    x->view = dep_cs_view(cs, x->lam);
    return dep_acceleration_pass(&x->accel, x->q, x->qd, x->t, x->scratch, ++x->jacobian_ids,
                                 x->lam, NULL, x->m->tol, &report, &x->failure);
}

int dep_settle_multiplier_of(settle_context *x, const dep_hinge_mechanics *h, int lock,
                             double *value)
{
    int status = dep_settle_multipliers(x);
    *value = status == DEP_OK ? x->lam[dep_cs_lock_index(&x->cs, lock, h->index)] : NAN;
    return status;
}

/* The mode of hinge h's event `kind` starts on its boundary (g = 0): not re-checked here. */
void dep_settle_starting(settle_context *x, const dep_hinge_mechanics *h, int kind)
{
    int e = dep_mechanism_event_index(x->m, h, kind);
    if (e >= 0) {
        x->starting[e] = 1;
    }
}

double dep_settle_slip_direction(double lam, double previous)
{
    return lam == 0.0 ? previous : lam > 0 ? 1.0 : -1.0;
}
