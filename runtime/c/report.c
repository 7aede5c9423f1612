/* report.c: a run's summary in the words of Python's Result.report() (results.py, loads.py):
 * deployment first (deployed or not, each latch's time, rate and impulse, peak hinge loads,
 * energy dissipated by friction and impacts), then the solver's work.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "depsim.h"

#define EVENTS_SHOWN 20

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

/* The first "<h>.latch" record of latch hinge index k, or NULL. */
static const dep_event_record *latch_record(const dep_model *m, const dep_result *r, int k)
{
    char name[DEP_NAME_MAX + 8];
    snprintf(name, sizeof name, "%s.latch", m->hinge_names[k]);
    for (int e = 0; e < r->n_events; ++e) {
        if (strcmp(r->events[e].name, name) == 0) {
            return &r->events[e];
        }
    }
    return NULL;
}

static int by_time(const void *a, const void *b)
{
    double x = (*(const dep_event_record *const *)a)->t;
    double y = (*(const dep_event_record *const *)b)->t;
    return (x > y) - (x < y);
}

static int by_name(const void *a, const void *b)
{
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}

static void deployment_lines(const dep_model *m, const dep_result *r, FILE *out)
{
    const dep_event_record *found[DEP_MAX_ADDED];
    const char *missing[DEP_MAX_ADDED];
    int n_found = 0, n_missing = 0, n = r->n_latch_hinges < DEP_MAX_ADDED ? r->n_latch_hinges
                                                                          : DEP_MAX_ADDED;
    double last = 0.0;
    for (int i = 0; i < n; ++i) {
        const dep_event_record *e = latch_record(m, r, r->latch_hinges[i]);
        if (e != NULL) {
            found[n_found++] = e;
            last = n_found == 1 || e->t > last ? e->t : last;
        } else {
            missing[n_missing++] = m->hinge_names[r->latch_hinges[i]];
        }
    }
    if (n == 0) {
        return;
    }
    qsort(found, (size_t)n_found, sizeof *found, by_time);
    qsort(missing, (size_t)n_missing, sizeof *missing, by_name);
    if (n_missing == 0) {
        fprintf(out, "  DEPLOYED: all %d latches latched; full deployment at t = %.6g s\n", n, last);
    } else {
        fprintf(out, "  NOT DEPLOYED by t = %.6g s: %d of %d latches open (", r->t_end, n_missing, n);
        for (int i = 0; i < n_missing; ++i) {
            fprintf(out, "%s%s", i ? ", " : "", missing[i]);
        }
        fprintf(out, ")\n");
    }
    for (int i = 0; i < n_found; ++i) {
        const dep_event_record *e = found[i];
        const dep_datum *impulse = datum(e, "impulse");
        double rate = number(e, "rate", NAN);
        fprintf(out, "    latch %.*s: t = %.9g s, rate %.4g rad/s (%.4g deg/s), ",
                (int)(strlen(e->name) - 6), e->name, e->t, rate, rate * (180.0 / 3.141592653589793));
        if (impulse == NULL || impulse->kind == DEP_NONE) {
            fprintf(out, "compliant\n");
        } else {
            fprintf(out, "impulse %.4g N*m*s, %.4g J lost\n", impulse->number,
                    number(e, "impact_energy_loss", 0.0));
        }
    }
}

/* Peak hinge loads: the output times' (from lam and hinge_torque) merged with the steps'. */
static void peak_lines(const dep_model *m, const dep_result *r, FILE *out)
{
    int header = 0;
    for (int k = 0; k < m->nh; ++k) {
        char name[DEP_NAME_MAX + 8];
        int ix = -1, iy = -1;
        for (int c = 0; c < r->n_rows; ++c) {
            snprintf(name, sizeof name, "%s.x", m->hinge_names[k]);
            ix = strcmp(r->row_names[c], name) == 0 ? c : ix;
            snprintf(name, sizeof name, "%s.y", m->hinge_names[k]);
            iy = strcmp(r->row_names[c], name) == 0 ? c : iy;
        }
        dep_peak p = {0.0, NAN, 0.0, NAN};
        for (int i = 0; i < r->n; ++i) {
            double force = ix >= 0 && iy >= 0 ? hypot(r->lam[(size_t)i * (size_t)r->n_rows + (size_t)ix],
                                                      r->lam[(size_t)i * (size_t)r->n_rows + (size_t)iy])
                                              : NAN;
            double torque = fabs(r->hinge_torque[(size_t)i * (size_t)r->nh + (size_t)k]);
            if (isfinite(force) && force > p.force) {
                p.force = force;
                p.t_force = r->times[i];
            }
            if (isfinite(torque) && torque > p.torque) {
                p.torque = torque;
                p.t_torque = r->times[i];
            }
        }
        const dep_peak *s = &r->peaks[k];
        if (!(p.force >= s->force)) {
            p.force = s->force;
            p.t_force = s->t_force;
        }
        if (!(p.torque >= s->torque)) {
            p.torque = s->torque;
            p.t_torque = s->t_torque;
        }
        if (!(p.force > 0 || p.torque > 0)) {
            continue;
        }
        if (!header++) {
            fprintf(out, "  peak hinge loads (force on member b from a; lock torque):\n");
        }
        fprintf(out, "    %s: %.4g N at t = %.6g s", m->hinge_names[k], p.force, p.t_force);
        if (p.torque > 0) {
            fprintf(out, ", torque %.4g N*m at t = %.6g s", p.torque, p.t_torque);
        }
        fprintf(out, "\n");
    }
}

static void energy_line(const dep_result *r, FILE *out)
{
    double friction = 0.0, impacts = 0.0;
    for (int d = 0; r->n > 0 && d < r->nd; ++d) {
        if (strncmp(r->dissipator_names[d], "friction.", 9) == 0) {
            friction += r->dissipated[(size_t)(r->n - 1) * (size_t)r->nd + (size_t)d];
        }
    }
    for (int e = 0; e < r->n_events; ++e) {
        impacts += number(&r->events[e], "impact_energy_loss", 0.0);
    }
    if (friction != 0.0 || impacts != 0.0) {
        fprintf(out, "  energy dissipated: friction %.6g J, latch/stop impacts %.6g J\n",
                friction, impacts);
    }
}

static int is_latch_event(const dep_model *m, const dep_result *r, const char *name)
{
    for (int i = 0; i < r->n_latch_hinges; ++i) {
        const char *hinge = m->hinge_names[r->latch_hinges[i]];
        size_t length = strlen(hinge);
        if (strncmp(name, hinge, length) == 0 && strcmp(name + length, ".latch") == 0) {
            return 1;
        }
    }
    return 0;
}

static void solver_lines(const dep_model *m, const dep_result *r, FILE *out)
{
    const dep_stats *s = &r->stats;
    int shown = 0, others = 0;
    fprintf(out, "  steps: %lld accepted, %lld rejected, %lld retried; %lld force evaluations\n",
            s->accepted_steps, s->rejected_steps, s->failed_steps, s->rhs_evaluations);
    fprintf(out, "  iterations per step: position %.2f (max %lld), velocity %.2f (max %lld), "
            "acceleration %.2f (max %lld)\n", s->position.mean, s->position.max,
            s->velocity.mean, s->velocity.max, s->acceleration.mean, s->acceleration.max);
    fprintf(out, "  largest constraint residuals at steps: position %.1e, velocity %.1e, "
            "acceleration %.1e\n", s->max_v_pos, s->max_v_vel, s->max_v_acc);
    for (int e = 0; e < r->n_events; ++e) {
        if (is_latch_event(m, r, r->events[e].name)) {
            continue;
        }
        ++others;
        if (shown < EVENTS_SHOWN) {
            fprintf(out, "  event %s at t = %.9g s\n", r->events[e].name, r->events[e].t);
            ++shown;
        }
    }
    if (others > shown) {
        fprintf(out, "  ... and %d more events (see the JSON summary)\n", others - shown);
    }
}

void dep_report(const dep_model *model, const dep_result *result, FILE *out)
{
    fprintf(out, "%s: %d output times to t = %.6g s (iterative, tol = %.1e)\n", model->name,
            result->n, result->n ? result->times[result->n - 1] : 0.0, result->tol);
    deployment_lines(model, result, out);
    peak_lines(model, result, out);
    energy_line(result, out);
    solver_lines(model, result, out);
}
