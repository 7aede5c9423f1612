/* jumps.c: the forward sensitivities across the events of a run (docs/method.md, 12): each
 * event time's sensitivity by the implicit function theorem on its condition, and the jump of
 * the sensitivities through the change the event makes (run.h).
 *
 * A condition g(x, p) = 0 crossed at tau(p) has dtau/dp = -(g_x s + g_p) / g' (its rate along
 * the motion). The conditions: a latch or a stop reached, a compliant latch's contact made or
 * lost (theta - angle), a hold-down's release (t - release), a sliding hinge at rest (its
 * rate), a stuck hinge's friction reaching static friction (|lambda| - static), a hinge
 * leaving its stop (the stop's multiplier). With D x- = s- + x'- dtau the state after the event
 * x+ = Gamma(x-) gives s+ = Gamma_x D x- + Gamma_p - x'+ dtau: q is continuous, qd jumps only
 * in a plastic impact onto the new rows (M qd+ + J^T mu = M qd-, J qd+ = -Phi_t).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "run.h"

/* ---- events -------------------------------------------------------------------------------- */

/* Before an event's change: what its condition's derivatives need of the state `before` it
   happens in, under the rows active before it (a stuck hinge's stick row, a stop's row):
   the hinge's angular acceleration, the row's multiplier, its tangents and its rate along the
   motion (the motion's own tangent with the inputs' rates as the parameters' direction: the
   rows' explicit time dependence, a driven joint's, is not in it). */
int dep_sensitivity_prepare_event(dep_run *run, int index, const dep_state *before)
{
    dep_sensitivity *x = &run->sens;
    const dep_model *m = run->model;
    if (x->k == 0 || index < run->n_user_events) {
        return DEP_OK;
    }
    const dep_hinge_mechanics *hm = run->mechanism->info[index - run->n_user_events].hinge;
    int h = hm->index, nq = run->nq;
    const double *q = before->q, *qd = before->qd;
    dep_sens_at_state(run, before->t, q);
    dep_sens_motion_tangent(run, before->t, q, qd, x->s, x->stage);
    m->hinge_jacobian(q, run->p, x->Jh);
    m->hinge_gamma(q, qd, run->p, x->gamma_h);
    m->hinge_rates(q, qd, run->p, x->rate);
    double acceleration = -x->gamma_h[h];
    for (int e = 0; e < m->nhnz; ++e) {
        if (m->hinge_jacobian_rows[e] == h) {
            acceleration += x->Jh[e] * x->qdd[m->hinge_jacobian_cols[e]];
        }
    }
    x->event_hinge = h;
    x->event_acceleration = acceleration;
    x->event_rate = x->rate[h];
    int row = dep_cs_lock_index(&run->cs, DEP_LOCK_STICK, h);
    row = row >= 0 ? row : dep_cs_lock_index(&run->cs, DEP_LOCK_STOP, h);
    x->event_row = row;
    if (row < 0) {
        return DEP_OK;
    }
    x->event_lam = x->lam[row];
    for (int i = 0; i < x->k; ++i) {
        x->event_dlam[i] = x->dlam[(size_t)i * (size_t)run->cs.capacity + (size_t)row];
    }
    for (int i = 0; i < m->ni; ++i) { /* u_i(t) = p[slot] + p[slot + 1] t */
        x->dp[m->input_slots[i]] = run->p[m->input_slots[i] + 1];
    }
    dep_sens_direction(run, before->t, q, qd, qd, x->qdd, NULL, NULL, x->k2, x->c);
    x->event_lam_rate = x->c[row];
    for (int i = 0; i < m->ni; ++i) {
        x->dp[m->input_slots[i]] = 0.0;
    }
    (void)nq;
    return DEP_OK;
}

/* Is record r a transition the sensitivities follow? NULL, or what it is in words. */
static const char *refused(const dep_run *run, int r)
{
    int kind = run->records[r].kind, h = run->records[r].hinge;
    if (h >= 0 && run->system.hinges[h].compliant
        && (kind == DEP_RECORD_LATCH || kind == DEP_RECORD_LATCH_CONTACT
            || kind == DEP_RECORD_LATCH_SEPARATION)) {
        /* its push max(0, k delta + c delta') switches inside a contact, where no event
           marks it (measured: 1e-4 to 3e-3 off the differences after a bounce) */
        return "a compliant latch's contact";
    }
    return kind == DEP_RECORD_LATCH || kind == DEP_RECORD_STOP || kind == DEP_RECORD_RELEASE
        || kind == DEP_RECORD_STICK || kind == DEP_RECORD_SLIP
        ? NULL : "a transition of this kind";
}

/* dtau/dp_i of the event of `kind` (enum dep_kind) of the hinge dep_sensitivity_prepare_event
   saw, `before`: the state it happens in. */
static double event_time(dep_run *run, int i, int kind, const dep_state *before)
{
    dep_sensitivity *x = &run->sens;
    const dep_model *m = run->model;
    int h = x->event_hinge;
    const double *dh = x->dH + ((size_t)i * ((size_t)m->nh + 1) + (size_t)h)
        * DEP_HINGE_PROPERTIES;
    const double *s = x->s + (size_t)i * 2 * (size_t)run->nq;
    if (kind == DEP_KIND_HOLD) {
        return dh[DEP_HINGE_RELEASE];
    }
    if (x->event_row >= 0 && (kind == DEP_KIND_STICK || kind == DEP_KIND_STOP_MIN
                              || kind == DEP_KIND_STOP_MAX)) {
        /* stuck -> slip: |lambda| - static; at a stop -> free: the stop's lambda */
        double sign = x->event_lam >= 0 ? 1.0 : -1.0;
        double limit = kind == DEP_KIND_STICK ? dh[DEP_HINGE_STATIC_FRICTION] : 0.0;
        return -(sign * x->event_dlam[i] - limit) / (sign * x->event_lam_rate);
    }
    x->dp[x->params[i]] = 1.0;
    m->hinge_angles_tangent(before->q, run->p, s, x->dp, x->dtheta);
    m->hinge_rates_tangent(before->q, before->qd, run->p, s, s + run->nq, x->dp, x->drate);
    x->dp[x->params[i]] = 0.0;
    if (kind == DEP_KIND_STICK) { /* sliding -> at rest: its rate */
        return -x->drate[h] / x->event_acceleration;
    }
    double angle = kind == DEP_KIND_LATCH ? dh[DEP_HINGE_LATCH]
        : kind == DEP_KIND_STOP_MAX ? dh[DEP_HINGE_STOP_MAX] : dh[DEP_HINGE_STOP_MIN];
    /* a latch, a stop reached; a compliant latch's contact made or lost */
    return -(x->dtheta[h] - angle) / x->event_rate;
}

/* Event `index` of the watch fired at t_event: `before` the state it happened in, run->state
   the state after it (its rows, its restart), the records from `first` on its own. dtau and
   the jump of s; `stopped`: the run ends here (only dtau). */
int dep_sensitivity_event(dep_run *run, int index, double t_event, const dep_state *before,
                          int first, int stopped)
{
    dep_sensitivity *x = &run->sens;
    const dep_model *m = run->model;
    if (x->k == 0) {
        return DEP_OK;
    }
    if (index < run->n_user_events && stopped) {
        return DEP_OK; /* a user's terminal event: its time's sensitivity is not known */
    }
    if (index < run->n_user_events) {
        return dep_sens_unsupported(run, t_event, "an event with a callback changes the run in "
                                    "ways they cannot follow");
    }
    int kind = run->mechanism->info[index - run->n_user_events].kind, nq = run->nq;
    size_t k = (size_t)x->k, n2 = 2 * (size_t)nq;
    for (int r = first; r < run->n_records; ++r) {
        const char *what = refused(run, r);
        if (what != NULL) {
            char message[DEP_NAME_MAX + 160];
            snprintf(message, sizeof message, "event '%.*s' is %s, which they do not follow",
                     DEP_NAME_MAX, run->records[r].name, what);
            return dep_sens_unsupported(run, t_event, message);
        }
    }
    double dtau[64], *dt = k <= 64 ? dtau : malloc(k * sizeof *dt);
    if (dt == NULL) {
        return dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory");
    }
    m->hinge_angles(before->q, run->p, x->theta);
    for (size_t i = 0; i < k; ++i) {
        dt[i] = event_time(run, (int)i, kind, before);
    }
    int status = dep_sens_event_times(run, first, dt);
    if (status != DEP_OK || stopped) {
        if (dt != dtau) {
            free(dt);
        }
        return status;
    }
    /* the jump: D x- = s- + x'- dtau; q continuous; qd+ by the impact onto the new rows */
    const dep_state *after = &run->state;
    dep_sens_rows_changed(run, after->q);
    dep_sens_at_state(run, t_event, after->q);
    int impact = 0;
    for (int j = 0; j < nq; ++j) {
        impact |= after->qd[j] != before->qd[j];
    }
    if (impact) { /* mu: M qd+ + J^T mu = M qd-, J qd+ = -Phi_t */
        dep_cs_phi_t(&run->cs, after->q, t_event, x->b);
        dep_cs_times(&run->cs, x->J, before->qd, x->gamma);
        for (int a = 0; a < run->cs.nc; ++a) {
            x->gamma[a] += x->b[a];
        }
        dep_sens_schur(run, x->gamma, x->lam);
    }
    for (size_t i = 0; i < k; ++i) {
        double *dq = x->s + i * n2, *dqd = dq + nq;
        for (int j = 0; j < nq; ++j) {
            x->Dq[j] = dq[j] + before->qd[j] * dt[i];
            x->Dqd[j] = dqd[j] + before->qdd[j] * dt[i];
        }
        if (impact) {
            const dep_mass *mass = &run->system.mass;
            x->dp[x->params[i]] = 1.0;
            dep_sens_jacobian_tangent(run, t_event, after->q, x->Dq);
            memset(x->r1, 0, (size_t)nq * sizeof(double));
            for (int e = 0; e < m->nmz; ++e) { /* M D qd- + dM (qd- - qd+) - dJ^T mu */
                int row = m->mass_rows[e], col = m->mass_cols[e];
                x->r1[row] += mass->values[e] * x->Dqd[col] + x->dM[i * ((size_t)m->nmz + 1) + e]
                    * (before->qd[col] - after->qd[col]);
            }
            dep_cs_transpose_times(&run->cs, x->dJ, x->lam, x->u);
            for (int j = 0; j < nq; ++j) {
                x->r1[j] -= x->u[j];
            }
            m->phi_t_tangent(after->q, t_event, run->p, x->Dq, x->dp, x->r2);
            for (int a = run->cs.nc_module; a < run->cs.nc; ++a) {
                x->r2[a] = 0.0;
            }
            dep_cs_times(&run->cs, x->dJ, after->qd, x->b);
            for (int a = 0; a < run->cs.nc; ++a) {
                x->r2[a] = -(x->r2[a] + x->b[a]);
            }
            dep_sens_solve_motion(run, x->r1, x->r2, x->Dqd, x->gamma);
            x->dp[x->params[i]] = 0.0;
        }
        for (int j = 0; j < nq; ++j) {
            dq[j] = x->Dq[j] - after->qd[j] * dt[i];
            dqd[j] = x->Dqd[j] - after->qdd[j] * dt[i];
        }
    }
    if (dt != dtau) {
        free(dt);
    }
    dep_sens_project(run, t_event, after->q, after->qd, x->s);
    dep_sens_motion_tangent(run, t_event, after->q, after->qd, x->s, x->ds);
    x->t0 = x->t1 = t_event;
    memcpy(x->s0, x->s, k * n2 * sizeof(double));
    memcpy(x->ds0, x->ds, k * n2 * sizeof(double));
    return DEP_OK;
}

