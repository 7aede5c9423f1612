/* events.c: zero crossings of g(t, q, qd) located on a step's dense output, the root
 * by Brent's method (as in scipy's brentq, scipy/optimize/Zeros/brentq.c).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "method.h"

#define EVENT_TIME_TOL 1e-12 /* s */
#define BRENT_RTOL (4 * DEP_EPS)
#define BRENT_MAXITER 100

/* The user's events followed by `more` (the mechanism's), checked. */
int dep_watch_init(dep_watch *watch, const dep_event *events, int count,
                   const dep_event *more, int n_more, dep_arena *arena, dep_error *error)
{
    int total = count + n_more;
    memset(watch, 0, sizeof *watch);
    watch->count = total;
    watch->events = dep_bytes(arena, (size_t)(total ? total : 1) * sizeof *watch->events);
    watch->hits = dep_bytes(arena, (size_t)(total ? total : 1) * sizeof *watch->hits);
    watch->values = dep_doubles(arena, (size_t)total);
    if (arena->failed) {
        return dep_plain_error(error, DEP_MEMORY_ERROR, "out of memory");
    }
    for (int k = 0; k < total; ++k) {
        watch->events[k] = k < count ? events[k] : more[k - count];
    }
    for (int k = 0; k < total; ++k) {
        const dep_event *e = &watch->events[k];
        if (e->function == NULL || e->name == NULL) {
            return dep_plain_error(error, DEP_SETTINGS_ERROR,
                                   "an event needs a name and a function");
        }
        if (e->direction < -1 || e->direction > 1) {
            char message[DEP_NAME_MAX + 60];
            snprintf(message, sizeof message, "event '%.*s': direction must be -1, 0 or +1",
                     DEP_NAME_MAX, e->name);
            return dep_plain_error(error, DEP_SETTINGS_ERROR, message);
        }
        for (int j = 0; j < k; ++j) {
            if (strcmp(watch->events[j].name, e->name) == 0) {
                return dep_plain_error(error, DEP_SETTINGS_ERROR, "event names must be distinct");
            }
        }
        watch->needs_multipliers |= e->multipliers != 0;
    }
    return DEP_OK;
}

/* g of `event` at (t, q, qd), with the multipliers when it watches them. */
int dep_event_value(const dep_event *event, double t, const double *q, const double *qd,
                    const dep_active_rows *rows, double *g, dep_error *error)
{
    if (event->function(event->context, t, q, qd, event->multipliers ? rows : NULL, g) != 0) {
        char message[DEP_NAME_MAX + 40];
        snprintf(message, sizeof message, "event '%.*s': its function failed", DEP_NAME_MAX,
                 event->name);
        return dep_plain_error(error, DEP_CALLBACK_ERROR, message);
    }
    return DEP_OK;
}

/* Evaluate every g at (t, q, qd) (rows: the multipliers there); event `fired` (or -1) is
   put on `side` of zero (it was just located there; its value is round-off). */
int dep_watch_reset(dep_watch *watch, double t, const double *q, const double *qd, int fired,
                    double side, const dep_active_rows *rows, dep_error *error)
{
    for (int k = 0; k < watch->count; ++k) {
        int status = dep_event_value(&watch->events[k], t, q, qd, rows, &watch->values[k],
                                     error);
        if (status != DEP_OK) {
            return status;
        }
    }
    if (fired >= 0) {
        watch->values[fired] = side * 1e-300;
    }
    return DEP_OK;
}

static int armed(const dep_watch *watch, int k)
{
    return watch->events[k].max_hits < 0 || watch->hits[k] < watch->events[k].max_hits;
}

static int crosses(double g0, double g1, int direction)
{
    if (g0 == 0.0) {
        return 0;
    }
    int rising = g0 < 0.0 && 0.0 <= g1, falling = g0 > 0.0 && 0.0 >= g1;
    return direction > 0 ? rising : direction < 0 ? falling : rising || falling;
}

typedef struct root_function {
    const dep_event *event;
    dep_dense_function dense;
    void *context;
    double *q, *qd;
    dep_active_rows *rows;
    dep_error *error;
    int status;
} root_function;

/* g on the dense output at t (with the multipliers there for an event that watches them). */
static double g_on_dense(root_function *f, double t)
{
    double g = NAN;
    dep_active_rows *rows = f->event->multipliers ? f->rows : NULL;
    if (f->status == DEP_OK) {
        f->status = f->dense(f->context, t, f->q, f->qd, rows);
    }
    if (f->status == DEP_OK) {
        f->status = dep_event_value(f->event, t, f->q, f->qd, rows, &g, f->error);
    }
    return g;
}

static double sign_of(double x)
{
    return x > 0 ? 1.0 : x < 0 ? -1.0 : x == 0 ? 0.0 : NAN;
}

/* scipy's brentq, statement for statement: the root of f in [xa, xb]; returns 0 or -1. */
static int brentq(root_function *f, double xa, double xb, double xtol, double rtol, double *root)
{
    double xpre = xa, xcur = xb, xblk = 0., fpre, fcur, fblk = 0., spre = 0., scur = 0.;
    fpre = g_on_dense(f, xpre);
    fcur = g_on_dense(f, xcur);
    if (fpre == 0 || fcur == 0) {
        *root = fpre == 0 ? xpre : xcur;
        return 0;
    }
    if (signbit(fpre) == signbit(fcur)) {
        return -1;
    }
    for (int i = 0; i < BRENT_MAXITER; ++i) {
        if (fpre != 0 && fcur != 0 && signbit(fpre) != signbit(fcur)) {
            xblk = xpre;
            fblk = fpre;
            spre = scur = xcur - xpre;
        }
        if (fabs(fblk) < fabs(fcur)) {
            xpre = xcur; xcur = xblk; xblk = xpre;
            fpre = fcur; fcur = fblk; fblk = fpre;
        }
        double delta = (xtol + rtol * fabs(xcur)) / 2, sbis = (xblk - xcur) / 2, stry;
        if (fcur == 0 || fabs(sbis) < delta) {
            *root = xcur;
            return 0;
        }
        if (fabs(spre) > delta && fabs(fcur) < fabs(fpre)) {
            if (xpre == xblk) { /* interpolate */
                stry = -fcur * (xcur - xpre) / (fcur - fpre);
            } else { /* extrapolate */
                double dpre = (fpre - fcur) / (xpre - xcur), dblk = (fblk - fcur) / (xblk - xcur);
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre));
            }
            if (2 * fabs(stry) < fmin(fabs(spre), 3 * fabs(sbis) - delta)) {
                spre = scur; /* good short step */
                scur = stry;
            } else {
                spre = sbis; /* bisect */
                scur = sbis;
            }
        } else {
            spre = sbis;
            scur = sbis;
        }
        xpre = xcur;
        fpre = fcur;
        xcur += fabs(scur) > delta ? scur : (sbis > 0 ? delta : -delta);
        fcur = g_on_dense(f, xcur);
    }
    return -1;
}

/* The earliest crossing in (t0, t1] of an armed event: *index (or -1), its time and the sign
   of g just after it. rows1: the multipliers at t1; q, qd, rows: scratch for the dense output.
   A crossing whose g, re-evaluated at t0 on the dense output, is already on g1's side (within
   round-off of zero at the step's start) is at t0. */
int dep_first_crossing(dep_watch *watch, double t0, double t1, const double *q1,
                       const double *qd1, const dep_active_rows *rows1,
                       dep_dense_function dense, void *context, double *q, double *qd,
                       dep_active_rows *rows, int *index, double *t_root, double *side,
                       dep_error *error)
{
    *index = -1;
    for (int k = 0; k < watch->count; ++k) {
        const dep_event *event = &watch->events[k];
        double g1, root = t1;
        int status = dep_event_value(event, t1, q1, qd1, rows1, &g1, error);
        if (status != DEP_OK) {
            return status;
        }
        double g0 = watch->values[k];
        watch->values[k] = g1;
        if (!armed(watch, k) || !crosses(g0, g1, event->direction)) {
            continue;
        }
        if (g1 != 0.0) {
            root_function f = {event, dense, context, q, qd, rows, error, DEP_OK};
            double start = g_on_dense(&f, t0);
            int found = 0;
            if (f.status == DEP_OK && sign_of(start) == sign_of(g1)) {
                root = t0;
            } else if (f.status == DEP_OK) {
                found = brentq(&f, t0, t1, EVENT_TIME_TOL, BRENT_RTOL, &root);
            }
            if (f.status != DEP_OK) {
                return f.status;
            }
            if (found != 0) {
                char message[DEP_NAME_MAX + 160];
                snprintf(message, sizeof message, "event '%.*s': its crossing could not be "
                         "located on the step (%.9g s, %.9g s)", DEP_NAME_MAX, event->name, t0,
                         t1);
                return dep_plain_error(error, DEP_CALLBACK_ERROR, message);
            }
        }
        if (*index < 0 || root < *t_root) {
            *index = k;
            *t_root = root;
            *side = g0 > 0 ? -1.0 : 1.0;
        }
    }
    return DEP_OK;
}
