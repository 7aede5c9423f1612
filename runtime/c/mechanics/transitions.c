/* transitions.c: the mode changes of latches, stops and stick-slip hinges, the plastic impact
 * of the rows that engage and the final projection (docs/deployment.md, sections 1-4);
 * mechanism.c drives them.
 *
 * A rigid latch or a stop that engages causes a plastic impact: sticking hinges let go during
 * it (a finite friction torque transmits no impulse) and afterwards slip in the direction of
 * their new rate, or are tested for stick at rest.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "mechanics.h"

#define REST 1e3 /* a hinge rate below REST tol max(1, max|qd|) counts as at rest */

/* ---- the transitions ---------------------------------------------------------------------- */

/* Hinge h's row of `lock` has just engaged (record r): its impact is due. */
static void impacting(settle_context *x, const dep_hinge_mechanics *h, int lock,
                      const dep_event_record *r)
{
    x->impacting_locks[x->n_impacting] = lock;
    x->impacting_hinges[x->n_impacting] = h->index;
    x->impacting[x->n_impacting++] = (int)(r - x->records);
}

/* open -> latched (rigid: lock row, impact) or contact (compliant); contact <-> apart. */
static int latch(settle_context *x, dep_hinge_mechanics *h, int kind, int *follow, int *n_follow)
{
    double rate = dep_mechanism_rate(x->m, h, x->q, x->qd);
    (void)kind, (void)follow, (void)n_follow;
    if (h->latch_state == DEP_OPEN) {
        dep_event_record *r = dep_settle_record(x, h, DEP_RECORD_LATCH);
        dep_settle_put_number(x, r, "angle", h->latch);
        dep_settle_put_number(x, r, "rate", rate);
        dep_settle_put_kind(x, r, "rigid", DEP_BOOL, !h->compliant);
        if (h->compliant) {
            h->latch_state = DEP_CONTACT;
            dep_settle_starting(x, h, DEP_KIND_LATCH);
            dep_settle_put_kind(x, r, "impulse", DEP_NONE, 0.0);
            dep_settle_put_kind(x, r, "impact_energy_loss", DEP_NONE, 0.0);
            return DEP_OK;
        }
        dep_settle_remove_row(x, h, DEP_LOCK_STICK);
        dep_settle_remove_row(x, h, DEP_LOCK_STOP);
        h->stuck = 0;
        h->stop = DEP_STOP_NONE;
        h->latch_state = DEP_LATCHED;
        dep_settle_add_lock(x, h, h->latch, DEP_LOCK_LATCH);
        impacting(x, h, DEP_LOCK_LATCH, r);
    } else if (h->latch_state == DEP_CONTACT || h->latch_state == DEP_APART) {
        h->latch_state = h->latch_state == DEP_CONTACT ? DEP_APART : DEP_CONTACT;
        dep_settle_starting(x, h, DEP_KIND_LATCH);
        int kind = h->latch_state == DEP_APART ? DEP_RECORD_LATCH_SEPARATION
                                                : DEP_RECORD_LATCH_CONTACT;
        dep_event_record *r = dep_settle_record(x, h, kind);
        dep_settle_put_number(x, r, "rate", rate);
    }
    return DEP_OK;
}

/* free -> at the stop (lock row, impact); at the stop -> free, then a stick-or-slip test. */
static int stop(settle_context *x, dep_hinge_mechanics *h, int kind, int *follow, int *n_follow)
{
    int at = kind == DEP_KIND_STOP_MAX ? DEP_STOP_MAX : DEP_STOP_MIN;
    const char *limit = at == DEP_STOP_MAX ? "max" : "min";
    double angle = at == DEP_STOP_MAX ? h->stop_max : h->stop_min;
    if (h->stop == at) {
        dep_settle_remove_row(x, h, DEP_LOCK_STOP);
        h->stop = DEP_STOP_NONE;
        dep_settle_starting(x, h, kind);
        dep_event_record *r = dep_settle_record(x, h, DEP_RECORD_STOP);
        dep_settle_put_text(x, r, "limit", limit);
        dep_settle_put_number(x, r, "angle", angle);
        dep_settle_put_text(x, r, "action", "release");
        if (h->has_static) {
            h->stuck = 0;
            follow[(*n_follow)++] = DEP_KIND_STICK;
        }
        return DEP_OK;
    }
    dep_settle_remove_row(x, h, DEP_LOCK_STICK);
    h->stuck = 0;
    h->stop = at;
    dep_settle_add_lock(x, h, angle, DEP_LOCK_STOP);
    dep_event_record *r = dep_settle_record(x, h, DEP_RECORD_STOP);
    dep_settle_put_text(x, r, "limit", limit);
    dep_settle_put_number(x, r, "angle", angle);
    dep_settle_put_text(x, r, "action", "contact");
    dep_settle_put_number(x, r, "rate", dep_mechanism_rate(x->m, h, x->q, x->qd));
    impacting(x, h, DEP_LOCK_STOP, r);
    return DEP_OK;
}

static void slip(settle_context *x, dep_hinge_mechanics *h, double lam)
{
    dep_settle_remove_row(x, h, DEP_LOCK_STICK);
    h->stuck = 0;
    h->direction = dep_settle_slip_direction(lam, h->direction);
    dep_settle_starting(x, h, DEP_KIND_STICK);
    dep_event_record *r = dep_settle_record(x, h, DEP_RECORD_SLIP);
    dep_settle_put_number(x, r, "direction", h->direction);
    dep_settle_put_number(x, r, "torque", -lam);
}

/* stuck -> slip (holding torque reached static friction); slipping at rest -> the
   stick-or-slip test with a trial lock row at the current angle (a hinge that still moves
   only takes the direction of its rate). */
static int stick(settle_context *x, dep_hinge_mechanics *h, int kind, int *follow, int *n_follow)
{
    double lam;
    (void)kind, (void)follow, (void)n_follow;
    if (h->latch_state == DEP_LATCHED || h->stop != DEP_STOP_NONE) {
        return DEP_OK;
    }
    if (h->stuck) {
        int status = dep_settle_multiplier_of(x, h, DEP_LOCK_STICK, &lam);
        if (status == DEP_OK) {
            slip(x, h, lam);
        }
        return status;
    }
    double rate = dep_mechanism_rate(x->m, h, x->q, x->qd);
    if (fabs(rate) > REST * x->m->tol * fmax(1.0, dep_max_abs(x->qd, x->nq))) {
        /* not at rest (its rate changed sign in a jump): it slips the way it moves */
        h->direction = rate > 0 ? 1.0 : -1.0;
        dep_event_record *r = dep_settle_record(x, h, DEP_RECORD_SLIP);
        dep_settle_put_number(x, r, "direction", h->direction);
        return DEP_OK;
    }
    double theta = dep_mechanism_angle(x->m, h, x->q);
    dep_settle_add_lock(x, h, theta, DEP_LOCK_STICK);
    h->stuck = 1; /* the trial: friction is carried by the lock row's multiplier */
    int status = dep_settle_multiplier_of(x, h, DEP_LOCK_STICK, &lam);
    if (status != DEP_OK) {
        return status;
    }
    if (fabs(lam) <= h->static_friction) {
        dep_event_record *r = dep_settle_record(x, h, DEP_RECORD_STICK);
        dep_settle_put_number(x, r, "angle", theta);
        dep_settle_put_number(x, r, "torque", -lam);
        return DEP_OK;
    }
    slip(x, h, lam);
    return DEP_OK;
}

/* A hold-down: engaged at the start (lock row "<h>.hold" at the current angle, an impact if
   the hinge moves); at its release time the row goes, and a stick-slip hinge is tested for
   stick (it is at rest). */
static int hold(settle_context *x, dep_hinge_mechanics *h, int kind, int *follow, int *n_follow)
{
    (void)kind;
    if (!h->held) {
        double theta = dep_mechanism_angle(x->m, h, x->q);
        h->held = 1;
        dep_settle_add_hold(x, h, theta);
        dep_event_record *r = dep_settle_record(x, h, DEP_RECORD_HOLD);
        dep_settle_put_number(x, r, "angle", theta);
        dep_settle_put_number(x, r, "release", h->release);
        if (dep_mechanism_rate(x->m, h, x->q, x->qd) != 0.0) {
            impacting(x, h, DEP_LOCK_EVENT, r);
        }
        return DEP_OK;
    }
    double lam;
    int status = dep_settle_multiplier_of(x, h, DEP_LOCK_EVENT, &lam);
    if (status != DEP_OK) {
        return status;
    }
    dep_settle_remove_row(x, h, DEP_LOCK_EVENT);
    h->held = 0;
    dep_event_record *r = dep_settle_record(x, h, DEP_RECORD_RELEASE);
    dep_settle_put_number(x, r, "angle", dep_mechanism_angle(x->m, h, x->q));
    dep_settle_put_number(x, r, "torque", -lam); /* what the hold-down held just before */
    if (h->has_static && h->latch_state != DEP_LATCHED && h->stop == DEP_STOP_NONE) {
        follow[(*n_follow)++] = DEP_KIND_STICK;
    }
    return DEP_OK;
}

/* ---- the impact and the final projection -------------------------------------------------- */

static int is_stuck(const dep_hinge_mechanics *h)
{
    return h->stuck && h->latch_state != DEP_LATCHED && h->stop == DEP_STOP_NONE;
}

/* Impulses, energy and joint impulses into the records of the rows that just engaged. */
static void impact_records(settle_context *x, const dep_constraints *cs, double loss)
{
    const dep_model *model = x->system->model;
    for (int i = 0; i < x->n_impacting; ++i) {
        dep_event_record *r = &x->records[x->impacting[i]];
        int row = dep_cs_lock_index(cs, x->impacting_locks[i], x->impacting_hinges[i]);
        dep_settle_put_number(x, r, "impulse", -(row >= 0 ? x->mu[row] : 0.0));
        dep_settle_put_number(x, r, "impact_energy_loss", i == 0 ? loss : 0.0);
        for (int k = 0; k < model->nh; ++k) { /* (the model's rows come first in cs) */
            const int *rows = x->force_rows + DEP_FORCE_ROWS * k;
            double impulse[DEP_FORCE_ROWS];
            for (int n = 0; n < DEP_FORCE_ROWS; ++n) {
                impulse[n] = rows[n] >= 0 ? x->mu[rows[n]] : 0.0;
            }
            dep_datum *d = dep_datum_add(r->data, &r->n_data, x->data_capacity,
                                         "joint_impulses", model->hinge_names[k]);
            if (d != NULL) {
                d->kind = DEP_NUMBER;
                d->number = hypot(hypot(impulse[0], impulse[1]), impulse[2]);
            }
        }
    }
    x->n_impacting = 0;
}

/* The stops whose impulse would have pulled, released by the impact. */
static void release_stops(settle_context *x, int n_released)
{
    for (int k = 0; k < n_released; ++k) {
        dep_hinge_mechanics *h = &x->m->hinges[x->released[k]];
        if (h->stop != DEP_STOP_NONE) {
            dep_settle_remove_row(x, h, DEP_LOCK_STOP);
            dep_event_record *r = dep_settle_record(x, h, DEP_RECORD_STOP);
            dep_settle_put_text(x, r, "limit", h->stop == DEP_STOP_MAX ? "max" : "min");
            dep_settle_put_text(x, r, "action", "release");
            dep_settle_put_text(x, r, "cause", "impact");
            h->stop = DEP_STOP_NONE;
        }
    }
}

/* After the impact every stick-slip hinge that is neither latched nor at a stop is classified
   again from its new rate: the hinges that stuck before it (x->stuck, their rows released for
   the impact) and the slipping ones alike. Moving, it slips in the direction of its rate (a
   "slip" record when that is a change); at rest it is due for the stick-or-slip test
   (follow[]: hinge * DEP_KINDS + kind). */
static void reclassify(settle_context *x, int *follow, int *n_follow)
{
    dep_mechanism *m = x->m;
    double at_rest = REST * m->tol * fmax(1.0, dep_max_abs(x->qd, x->nq));
    for (int i = 0; i < m->n_hinges; ++i) {
        dep_hinge_mechanics *h = &m->hinges[i];
        if (!h->has_static || h->latch_state == DEP_LATCHED || h->stop != DEP_STOP_NONE
            || h->held) {
            continue;
        }
        int was_stuck = x->stuck[i];
        if (h->stuck && !was_stuck) {
            continue; /* stuck by a row that took part in the impact: still at rest */
        }
        if (was_stuck) {
            dep_settle_remove_row(x, h, DEP_LOCK_STICK);
            h->stuck = 0;
        }
        double rate = dep_mechanism_rate(m, h, x->q, x->qd);
        if (fabs(rate) <= at_rest) {
            follow[(*n_follow)++] = i * DEP_KINDS + DEP_KIND_STICK;
            continue;
        }
        double direction = rate > 0 ? 1.0 : -1.0;
        if (was_stuck || direction != h->direction) {
            h->direction = direction;
            dep_event_record *r = dep_settle_record(x, h, DEP_RECORD_SLIP);
            dep_settle_put_number(x, r, "direction", h->direction);
            dep_settle_put_text(x, r, "cause", "impact");
        }
    }
}

/* The plastic impact of the rows that just engaged; appends the rest tests it makes due. */
int dep_settle_impact(settle_context *x, int *follow, int *n_follow)
{
    dep_mechanism *m = x->m;
    int n_stops = 0, n_released = 0;
    for (int i = 0; i < m->n_hinges; ++i) {
        dep_hinge_mechanics *h = &m->hinges[i];
        x->stuck[i] = is_stuck(h);
        if (h->stop != DEP_STOP_NONE) {
            x->stops[n_stops] = i;
            x->signs[n_stops++] = h->stop == DEP_STOP_MAX ? 1.0 : -1.0;
        }
    }
    dep_constraints *cs = dep_settle_constraints(x, x->stuck);
    dep_measurement *slots[2] = {&x->slots[2], &x->slots[3]};
    int status = dep_plastic_impact(cs, &x->mp, slots, x->q, x->qd, x->qd_new, x->t, m->tol,
                                    x->stops, x->signs, n_stops, x->scratch, &x->jacobian_ids,
                                    x->mu, x->released, &n_released, &x->failure);
    if (status != DEP_OK) {
        return status;
    }
    double loss = dep_energy_loss(&x->system->mass, x->qd, x->qd_new);
    memcpy(x->qd, x->qd_new, (size_t)x->nq * sizeof *x->qd);
    impact_records(x, cs, loss);
    release_stops(x, n_released);
    reclassify(x, follow, n_follow);
    return DEP_OK;
}

/* q and qd moved M-orthogonally onto every constraint level (moves of the order of the
   located event's error; the kinetic energy removed is that small too and not recorded). */
int dep_settle_project(settle_context *x)
{
    dep_constraints *cs = dep_settle_constraints(x, NULL);
    dep_measurement *own[2] = {&x->slots[0], &x->slots[1]}, *plain[2] = {&x->slots[2],
                                                                          &x->slots[3]};
    int status = dep_project_positions(cs, &x->mp, own, x->q, x->t, x->m->tol, x->scratch,
                                       &x->jacobian_ids, &x->failure);
    if (status != DEP_OK) {
        return status;
    }
    return dep_project_velocities(cs, &x->mp, plain, x->q, x->qd, x->t, x->m->tol, x->scratch,
                                  &x->jacobian_ids, x->mu, &x->failure);
}

typedef int (*transition_function)(settle_context *, dep_hinge_mechanics *, int, int *, int *);

/* Apply event e's transition; append the events it makes due to the queue. */
int dep_settle_transition(settle_context *x, int e, int *queue, int *n_queue)
{
    static const transition_function TRANSITIONS[DEP_KINDS] = {latch, stop, stop, stick, hold};
    dep_mechanism *m = x->m;
    dep_hinge_mechanics *h = m->info[e].hinge;
    int follow[DEP_MAX_ADDED + 4], n_follow = 0;
    int status = TRANSITIONS[m->info[e].kind](x, h, m->info[e].kind, follow, &n_follow);
    for (int k = 0; k < n_follow; ++k) { /* a kind of this hinge */
        follow[k] = dep_mechanism_event_index(m, h, follow[k]);
    }
    if (status == DEP_OK && x->n_impacting > 0) {
        int more[DEP_MAX_ADDED], n_more = 0;
        status = dep_settle_impact(x, more, &n_more);
        for (int k = 0; k < n_more; ++k) {
            follow[n_follow++] = dep_mechanism_event_index(m, &m->hinges[more[k] / DEP_KINDS],
                                                           more[k] % DEP_KINDS);
        }
    }
    for (int k = 0; k < n_follow && *n_queue < x->queue_capacity; ++k) {
        if (follow[k] >= 0) {
            queue[(*n_queue)++] = follow[k];
        }
    }
    return status;
}

