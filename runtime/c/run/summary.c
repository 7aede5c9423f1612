/* summary.c: what a run means for the mechanism, computed once for every caller: the latch
 * hinges, the deployment (each latch's first engagement, deployed or not and when, the
 * energy friction and impacts removed), the peak hinge loads, and the run's summary text
 * (`depsim run` and the standalone program print it).
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "run.h"

#define EVENTS_SHOWN 20
#define DEGREES (180.0 / DEP_PI)

/* ---- event data ----------------------------------------------------------------------------- */

static const dep_datum *datum(const dep_event_record *r, const char *key)
{
    for (int i = 0; i < r->n_data; ++i) {
        if (strcmp(r->data[i].key, key) == 0 && r->data[i].member[0] == '\0') {
            return &r->data[i];
        }
    }
    return NULL;
}

static double number(const dep_event_record *r, const char *key, double fallback)
{
    const dep_datum *d = datum(r, key);
    return d != NULL && d->kind == DEP_NUMBER ? d->number : fallback;
}

/* The first latch record of hinge k, or NULL. */
static const dep_event_record *latch_record(const dep_result *r, int k)
{
    for (int e = 0; e < r->n_events; ++e) {
        if (r->events[e].kind == DEP_RECORD_LATCH && r->events[e].hinge == k) {
            return &r->events[e];
        }
    }
    return NULL;
}

static int by_time(const void *a, const void *b)
{
    double x = ((const dep_latch_summary *)a)->t, y = ((const dep_latch_summary *)b)->t;
    return (x > y) - (x < y);
}

/* ---- the deployment ------------------------------------------------------------------------ */

static int deployment(const dep_model *m, const dep_system *system, dep_result *r)
{
    dep_deployment *d = &r->deployment;
    int nh = m->nh;
    d->latch_hinges = calloc((size_t)(nh ? nh : 1), sizeof *d->latch_hinges);
    d->latches = calloc((size_t)(nh ? nh : 1), sizeof *d->latches);
    if (d->latch_hinges == NULL || d->latches == NULL) {
        return DEP_MEMORY_ERROR;
    }
    for (int k = 0; k < nh; ++k) {
        if (!system->hinges[k].has_latch) {
            continue;
        }
        d->latch_hinges[d->n_latch_hinges++] = k;
        const dep_event_record *e = latch_record(r, k);
        if (e != NULL) {
            const dep_datum *impulse = datum(e, "impulse");
            const dep_datum *rigid = datum(e, "rigid");
            int compliant = impulse == NULL || impulse->kind != DEP_NUMBER;
            dep_latch_summary s = {k, e->t, number(e, "rate", NAN),
                                   rigid == NULL || rigid->number != 0.0,
                                   compliant ? NAN : impulse->number,
                                   compliant ? NAN : number(e, "impact_energy_loss", NAN)};
            d->latches[d->n_latches++] = s;
        }
    }
    qsort(d->latches, (size_t)d->n_latches, sizeof *d->latches, by_time);
    d->deployed = d->n_latch_hinges == 0 ? -1 : d->n_latches == d->n_latch_hinges;
    d->time = d->deployed == 1 ? d->latches[d->n_latches - 1].t : NAN;
    for (int k = m->nd; r->n > 0 && k < m->nd + system->n_friction; ++k) { /* "friction.<h>" */
        d->friction_energy += r->dissipated[(size_t)(r->n - 1) * (size_t)r->nd + (size_t)k];
    }
    for (int e = 0; e < r->n_events; ++e) {
        d->impact_energy += number(&r->events[e], "impact_energy_loss", 0.0);
    }
    return DEP_OK;
}

/* ---- peak loads: the output times' (from lam and hinge_torque) merged with the steps' -------- */

static void observe(dep_peak *p, double t, double force, double torque)
{
    if (isfinite(force) && force > p->force) {
        p->force = force;
        p->t_force = t;
    }
    if (isfinite(torque) && fabs(torque) > p->torque) {
        p->torque = fabs(torque);
        p->t_torque = t;
    }
}

static int peak_loads(const dep_model *m, const dep_loads *loads, dep_result *r)
{
    r->peak_loads = calloc((size_t)(m->nh ? m->nh : 1), sizeof *r->peak_loads);
    if (r->peak_loads == NULL) {
        return DEP_MEMORY_ERROR;
    }
    for (int k = 0; k < m->nh; ++k) {
        dep_peak p = {0.0, NAN, 0.0, NAN, !loads->redundant[k]};
        for (int i = 0; i < r->n; ++i) {
            const double *f = r->hinge_force
                              + ((size_t)i * (size_t)r->nh + (size_t)k) * DEP_FORCE_ROWS;
            double force = hypot(hypot(f[0], f[1]), f[2]);
            observe(&p, r->times[i], force, r->hinge_torque[(size_t)i * (size_t)r->nh + (size_t)k]);
        }
        if (!(p.force >= loads->force[k])) { /* ties keep the output time */
            p.force = loads->force[k];
            p.t_force = loads->t_force[k];
        }
        if (!(p.torque >= loads->torque[k])) {
            p.torque = loads->torque[k];
            p.t_torque = loads->t_torque[k];
        }
        r->peak_loads[k] = p;
    }
    return DEP_OK;
}

/* ---- the summary text ------------------------------------------------------------------------ */

typedef struct text {
    char *data;
    size_t length, capacity;
    int failed;
} text;

static void put(text *out, const char *format, ...)
{
    va_list args;
    va_start(args, format);
    int needed = vsnprintf(NULL, 0, format, args);
    va_end(args);
    if (out->failed || needed < 0) {
        out->failed = 1;
        return;
    }
    if (out->length + (size_t)needed + 1 > out->capacity) {
        size_t capacity = 2 * (out->length + (size_t)needed + 1);
        char *data = realloc(out->data, capacity);
        if (data == NULL) {
            out->failed = 1;
            return;
        }
        out->data = data;
        out->capacity = capacity;
    }
    va_start(args, format);
    vsnprintf(out->data + out->length, out->capacity - out->length, format, args);
    va_end(args);
    out->length += (size_t)needed;
}

static void deployment_lines(const dep_model *m, const dep_result *r, text *out)
{
    const dep_deployment *d = &r->deployment;
    if (d->deployed < 0) {
        return;
    }
    const char *latches = d->n_latch_hinges == 1 ? "latch" : "latches";
    if (d->deployed) {
        put(out, "  DEPLOYED: %s%d %s latched; full deployment at t = %.6g s\n",
            d->n_latch_hinges == 1 ? "" : "all ", d->n_latch_hinges, latches, d->time);
    } else {
        const char **missing = calloc((size_t)d->n_latch_hinges, sizeof *missing);
        int n_missing = 0;
        if (missing == NULL) {
            out->failed = 1;
            return;
        }
        for (int i = 0; i < d->n_latch_hinges; ++i) {
            int found = 0;
            for (int k = 0; k < d->n_latches; ++k) {
                found |= d->latches[k].hinge == d->latch_hinges[i];
            }
            if (!found) {
                missing[n_missing++] = m->hinge_names[d->latch_hinges[i]];
            }
        }
        put(out, "  NOT DEPLOYED by t = %.6g s: %d of %d %s open (", r->t_end, n_missing,
            d->n_latch_hinges, latches);
        for (int i = 0; i < n_missing; ++i) {
            put(out, "%s%s", i ? ", " : "", missing[i]);
        }
        put(out, ")\n");
        free(missing);
    }
    for (int k = 0; k < d->n_latches; ++k) {
        const dep_latch_summary *s = &d->latches[k];
        int slider = dep_hinge_slider(m, s->hinge) >= 0; /* m/s and N*s along its axis */
        put(out, "    latch %s: t = %.9g s, ", m->hinge_names[s->hinge], s->t);
        if (slider) {
            put(out, "rate %.4g m/s, ", s->rate);
        } else {
            put(out, "rate %.4g rad/s (%.4g deg/s), ", s->rate, s->rate * DEGREES);
        }
        if (isnan(s->impulse)) {
            put(out, "compliant\n");
        } else {
            put(out, "impulse %.4g %s, %.4g J lost\n", s->impulse, slider ? "N*s" : "N*m*s",
                s->energy_loss);
        }
    }
}

static void load_lines(const dep_model *m, const dep_result *r, text *out)
{
    int header = 0;
    for (int k = 0; k < m->nh; ++k) {
        const dep_peak *p = &r->peak_loads[k];
        if (!(p->force > 0 || p->torque > 0)) {
            continue;
        }
        if (!header++) {
            put(out, "  peak hinge loads (force on member b from a; lock torque; a slider's "
                "lock force along its axis):\n");
        }
        if (dep_hinge_slider(m, k) >= 0) { /* a slider: no pin force, its lock force */
            put(out, "    %s: force along the axis %.4g N at t = %.6g s", m->hinge_names[k],
                p->torque, p->t_torque);
        } else {
            put(out, "    %s: %.4g N at t = %.6g s", m->hinge_names[k], p->force, p->t_force);
        }
        if (p->torque > 0 && dep_hinge_slider(m, k) < 0) {
            put(out, ", torque %.4g N*m at t = %.6g s", p->torque, p->t_torque);
        }
        if (!p->unique) {
            put(out, " (not unique: its rows were redundant; the minimum-norm loads)");
        }
        put(out, "\n");
    }
    const dep_deployment *d = &r->deployment;
    if (d->friction_energy != 0.0 || d->impact_energy != 0.0) {
        put(out, "  energy dissipated: friction %.6g J, latch/stop impacts %.6g J\n",
            d->friction_energy, d->impact_energy);
    }
}

static void solver_lines(const dep_result *r, text *out)
{
    const dep_stats *s = &r->stats;
    int shown = 0, others = 0;
    put(out, "  steps: %lld accepted, %lld rejected, %lld retried; %lld force evaluations\n",
        s->accepted_steps, s->rejected_steps, s->failed_steps, s->rhs_evaluations);
    put(out, "  iterations per step: position %.2f (max %lld), velocity %.2f (max %lld), "
        "acceleration %.2f (max %lld)\n", s->position.mean, s->position.max,
        s->velocity.mean, s->velocity.max, s->acceleration.mean, s->acceleration.max);
    put(out, "  largest constraint residuals at steps: position %.1e, velocity %.1e, "
        "acceleration %.1e\n", s->max_v_pos, s->max_v_vel, s->max_v_acc);
    if (s->force_steps > 0) {
        put(out, "  %lld %s near singular positions prescribed the rows' forces instead of "
            "their multipliers (docs/method.md)\n", s->force_steps,
            s->force_steps == 1 ? "step" : "steps");
    }
    if (!isnan(s->implicit_from) && isnan(s->stiff_rate)) {
        put(out, "  linearly implicit steps throughout (stepping implicit); modes much faster "
            "than the step are damped (docs/method.md)\n");
    } else if (!isnan(s->implicit_from)) {
        put(out, "  linearly implicit steps from t = %.6g s: a mode of rate %.3g 1/s held the "
            "explicit step; modes much faster than the step are damped (docs/method.md)\n",
            s->implicit_from, s->stiff_rate);
    }
    for (int e = 0; e < r->n_events; ++e) {
        if (r->events[e].kind == DEP_RECORD_LATCH || r->events[e].kind == DEP_RECORD_ASSEMBLY) {
            continue;
        }
        ++others;
        if (shown < EVENTS_SHOWN) {
            put(out, "  event %s at t = %.9g s\n", r->events[e].name, r->events[e].t);
            ++shown;
        }
    }
    if (others > shown) {
        put(out, "  ... and %d more event%s (see the JSON summary)\n", others - shown,
            others - shown == 1 ? "" : "s");
    }
}

/* Whether a tree value (depsim_model.h, tree_joints) is an angle: a hinge's, or one named
   JOINT.angle..., JOINT.turn_... (a free, ball, cylindrical or universal joint's turn);
   else a length. */
static int angle_value(const dep_model *m, const char *name)
{
    for (int h = 0; h < m->nh; ++h) { /* (a slider's entry is in m) */
        if (strcmp(m->hinge_names[h], name) == 0) {
            return dep_hinge_slider(m, h) < 0;
        }
    }
    const char *dot = strrchr(name, '.');
    return dot != NULL && (strncmp(dot + 1, "angle", 5) == 0 || strncmp(dot + 1, "turn_", 5) == 0);
}

/* "assembled at t = 0: knee = -33.06 deg (-2.468 rad/s), rest = 92.04 deg (0.6014 rad/s)" */
static void assembly_line(const dep_model *m, const dep_result *r, text *out)
{
    for (int e = 0; e < r->n_events; ++e) {
        const dep_event_record *record = &r->events[e];
        if (record->kind != DEP_RECORD_ASSEMBLY) {
            continue;
        }
        put(out, "  assembled at t = 0 (the loops closed from the given initial values):");
        int first = 1;
        for (int i = 0; i < record->n_data; ++i) {
            const dep_datum *d = &record->data[i];
            if (strcmp(d->key, "values") != 0) {
                continue;
            }
            int angle = angle_value(m, d->member);
            put(out, "%s %s = %.6g %s", first ? "" : ",", d->member,
                angle ? d->number * 180.0 / DEP_PI : d->number,
                angle ? "deg" : "m");
            first = 0;
        }
        put(out, "\n");
    }
}

/* One warning per output that is not finite at some output time: its expression left its
   functions' domain (both targets compute outputs with IEEE arithmetic: nan, inf). */
static void output_lines(const dep_model *m, const dep_result *r, text *out)
{
    for (int k = 0; k < r->nout; ++k) {
        int bad = 0, first = -1;
        for (int i = 0; i < r->n; ++i) {
            double y = r->outputs[(size_t)i * (size_t)r->nout + (size_t)k];
            if (!isfinite(y)) {
                first = first < 0 ? i : first;
                ++bad;
            }
        }
        if (bad) {
            double y = r->outputs[(size_t)first * (size_t)r->nout + (size_t)k];
            put(out, "  warning: output %s is %s at %d of %d output times, first at t = %.9g s: "
                "its expression leaves its domain there (sqrt or log of a negative number, "
                "acos or asin beyond 1, a division by zero)\n", m->output_names[k],
                isnan(y) ? "nan" : "infinite", bad, r->n, r->times[first]);
        }
    }
}

static int report(const dep_model *m, dep_result *r)
{
    text out = {NULL, 0, 0, 0};
    put(&out, "%s: %d output times to t = %.6g s (iterative, tol = %.1e)\n", m->name, r->n,
        r->n ? r->times[r->n - 1] : 0.0, r->tol);
    assembly_line(m, r, &out);
    deployment_lines(m, r, &out);
    load_lines(m, r, &out);
    solver_lines(r, &out);
    output_lines(m, r, &out);
    if (out.failed) {
        free(out.data);
        return DEP_MEMORY_ERROR;
    }
    r->report = out.data;
    return DEP_OK;
}

/* The deployment, the peak loads and the summary text of a finished result (after its
   arrays, events and statistics). */
int dep_summarize(const dep_model *model, const dep_system *system, const dep_loads *loads,
                  dep_result *result)
{
    if (deployment(model, system, result) != DEP_OK || peak_loads(model, loads, result) != DEP_OK
        || report(model, result) != DEP_OK) {
        return DEP_MEMORY_ERROR;
    }
    return DEP_OK;
}
