/* modes.c: the modes of the model's hinges with latches, hard stops and stick-slip friction,
 * and the events that change them (docs/deployment.md; mechanics.h).
 *
 * A hinge with a `latch`, `stop_min`/`stop_max` or `static_friction` in hinge_properties()
 * keeps a mode; one event per (hinge, kind) has g > 0 while the mode holds and falls through
 * zero when it must change (transitions.c then applies the change).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "mechanics.h"

static const char *const KIND_NAMES[DEP_KINDS] = {"latch", "stop_min", "stop_max", "stick",
                                                  "release"};

const char *dep_kind_name(int kind)
{
    return KIND_NAMES[kind];
}

/* ---- a hinge's events ------------------------------------------------------------------------ */

int dep_hinge_event_kinds(const dep_hinge_mechanics *h, int *out)
{
    int present[DEP_KINDS] = {h->has_latch, h->has_stop_min, h->has_stop_max, h->has_static,
                              h->has_hold}, n = 0;
    for (int k = 0; k < DEP_KINDS; ++k) {
        if (present[k]) {
            out[n++] = k;
        }
    }
    return n;
}

static int latch_g(void *, double, const double *, const double *, const dep_active_rows *,
                   double *);
static int stop_g(void *, double, const double *, const double *, const dep_active_rows *,
                  double *);
static int stick_g(void *, double, const double *, const double *, const dep_active_rows *,
                   double *);
static int hold_g(void *, double, const double *, const double *, const dep_active_rows *,
                  double *);

void dep_mechanism_make_events(dep_mechanism *m)
{
    int n = 0, list[DEP_KINDS];
    for (int i = 0; i < m->n_hinges; ++i) {
        int count = dep_hinge_event_kinds(&m->hinges[i], list);
        for (int k = 0; k < count; ++k, ++n) {
            dep_mechanism_event *info = &m->info[n];
            info->mechanism = m;
            info->hinge = &m->hinges[i];
            info->kind = list[k];
            snprintf(info->name, sizeof info->name, "%s.%s", m->hinges[i].name,
                     KIND_NAMES[list[k]]);
            dep_event *e = &m->events[n];
            e->name = info->name;
            e->function = list[k] == DEP_KIND_LATCH ? latch_g
                          : list[k] == DEP_KIND_STICK ? stick_g
                          : list[k] == DEP_KIND_HOLD ? hold_g : stop_g;
            e->direction = -1;
            e->context = info;
            e->max_hits = -1;
            e->multipliers = list[k] != DEP_KIND_LATCH && list[k] != DEP_KIND_HOLD;
        }
    }
}

int dep_mechanism_event_index(const dep_mechanism *m, const dep_hinge_mechanics *h, int kind)
{
    for (int e = 0; e < m->n_events; ++e) {
        if (m->info[e].hinge == h && m->info[e].kind == kind) {
            return e;
        }
    }
    return -1;
}

/* ---- kinematics and the event functions ------------------------------------------------ */

double dep_mechanism_angle(dep_mechanism *m, const dep_hinge_mechanics *h, const double *q)
{
    m->model->hinge_angles(q, m->system->p, m->angles);
    return m->angles[h->index];
}

double dep_mechanism_rate(dep_mechanism *m, const dep_hinge_mechanics *h, const double *q,
                          const double *qd)
{
    m->model->hinge_rates(q, qd, m->system->p, m->rates);
    return m->rates[h->index];
}

/* The multiplier of hinge h's row of `lock` (enum dep_lock); non-zero when it is not active. */
static int multiplier(const dep_active_rows *rows, const dep_hinge_mechanics *h, int lock,
                      double *value)
{
    for (int i = 0; rows != NULL && i < rows->nc; ++i) {
        if (rows->locks[i] == lock && rows->hinges[i] == h->index) {
            *value = rows->lam[i];
            return 0;
        }
    }
    return 1;
}

/* open / apart: side (lock - theta); contact: side (theta - lock); latched or stuck (a stuck
   hinge does not move): 1. */
static int latch_g(void *context, double t, const double *q, const double *qd,
                   const dep_active_rows *rows, double *g)
{
    dep_mechanism_event *info = context;
    dep_hinge_mechanics *h = info->hinge;
    (void)t, (void)qd, (void)rows;
    if (h->latch_state == DEP_LATCHED || h->stuck || h->held) {
        *g = 1.0;
        return 0;
    }
    double gap = h->latch_side * (h->latch - dep_mechanism_angle(info->mechanism, h, q));
    *g = h->latch_state == DEP_CONTACT ? -gap : gap;
    return 0;
}

/* free: stop_max - theta or theta - stop_min; at that stop: the pushing multiplier
   (+lambda at stop_max, -lambda at stop_min); latched or stuck: 1. */
static int stop_g(void *context, double t, const double *q, const double *qd,
                  const dep_active_rows *rows, double *g)
{
    dep_mechanism_event *info = context;
    dep_hinge_mechanics *h = info->hinge;
    int at_max = info->kind == DEP_KIND_STOP_MAX;
    double sign = at_max ? 1.0 : -1.0, lam;
    (void)t, (void)qd;
    if (h->latch_state == DEP_LATCHED || h->stuck || h->held) {
        *g = 1.0;
        return 0;
    }
    if (h->stop == (at_max ? DEP_STOP_MAX : DEP_STOP_MIN)) {
        if (multiplier(rows, h, DEP_LOCK_STOP, &lam) != 0) {
            return 1;
        }
        *g = sign * lam;
        return 0;
    }
    double limit = at_max ? h->stop_max : h->stop_min;
    *g = sign * (limit - dep_mechanism_angle(info->mechanism, h, q));
    return 0;
}

/* slipping: s rate; stuck: static_friction - |lambda_stick|; locked: 1. */
static int stick_g(void *context, double t, const double *q, const double *qd,
                   const dep_active_rows *rows, double *g)
{
    dep_mechanism_event *info = context;
    dep_hinge_mechanics *h = info->hinge;
    double lam;
    (void)t;
    if (dep_hinge_locked(h)) {
        *g = 1.0;
        return 0;
    }
    if (h->stuck) {
        if (multiplier(rows, h, DEP_LOCK_STICK, &lam) != 0) {
            return 1;
        }
        *g = h->static_friction - fabs(lam);
        return 0;
    }
    *g = h->direction * dep_mechanism_rate(info->mechanism, h, q, qd);
    return 0;
}

/* held: release - t (falls through zero at the release time); released: 1. */
static int hold_g(void *context, double t, const double *q, const double *qd,
                  const dep_active_rows *rows, double *g)
{
    dep_mechanism_event *info = context;
    (void)q, (void)qd, (void)rows;
    *g = info->hinge->held ? info->hinge->release - t : 1.0;
    return 0;
}

/* Mechanism.start: latch sides and slip directions from the initial state; due[] gets the
   events due at once (a hold-down engaging, a hinge starting at its latch or at or beyond a
   stop, a stick-slip hinge at rest), per hinge in the order hold, latch, stop_max, stop_min,
   stick. */
int dep_mechanism_start(dep_mechanism *m, const double *q, const double *qd, int *due)
{
    int n_due = 0;
    for (int i = 0; i < m->n_hinges; ++i) {
        dep_hinge_mechanics *h = &m->hinges[i];
        double theta = dep_mechanism_angle(m, h, q), rate = dep_mechanism_rate(m, h, q, qd);
        int kinds_due[DEP_KINDS], n = 0;
        if (h->has_hold) {
            kinds_due[n++] = DEP_KIND_HOLD;
        }
        if (h->has_latch) {
            h->latch_side = theta != h->latch ? (theta < h->latch ? 1.0 : -1.0)
                                              : (rate < 0 ? -1.0 : 1.0);
            if (theta == h->latch) {
                kinds_due[n++] = DEP_KIND_LATCH;
            }
        }
        if (h->has_stop_max && theta >= h->stop_max) {
            kinds_due[n++] = DEP_KIND_STOP_MAX;
        }
        if (h->has_stop_min && theta <= h->stop_min) {
            kinds_due[n++] = DEP_KIND_STOP_MIN;
        }
        if (h->has_static) {
            h->direction = rate == 0.0 ? 1.0 : rate > 0 ? 1.0 : -1.0;
            if (rate == 0.0 && !h->has_hold) {
                kinds_due[n++] = DEP_KIND_STICK;
            }
        }
        for (int k = 0; k < n; ++k) {
            due[n_due++] = dep_mechanism_event_index(m, h, kinds_due[k]);
        }
    }
    return n_due;
}

/* ---- the hinges' lock torques ---------------------------------------------------------- */

void dep_mechanism_hinge_torques(dep_mechanism *m, const double *q, const double *qd,
                                 const dep_constraints *cs, const double *lam, double *tau)
{
    int have = 0;
    dep_lock_torques(m->model, cs, lam, tau);
    for (int i = 0; i < m->n_hinges; ++i) {
        const dep_hinge_mechanics *h = &m->hinges[i];
        if (h->latch_state != DEP_CONTACT) {
            continue;
        }
        if (!have) {
            m->model->hinge_angles(q, m->system->p, m->angles);
            m->model->hinge_rates(q, qd, m->system->p, m->rates);
            have = 1;
        }
        tau[i] = -h->latch_side * dep_contact_push(h, m->angles[i], m->rates[i]);
    }
}
