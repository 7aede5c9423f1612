/* passes.c: the iteration (6) at one state, with C = 1: the acceleration pass on any
 * constraint set (the new state's lambda and qdd, the holding torques of lock rows, a start's
 * lambda_0), its filtered form under the linearly implicit step, and the M-orthogonal
 * projection of qd onto the velocity constraints (a plastic impact) (method.h).
 */
#include <math.h>
#include <string.h>

#include "method.h"

/* ---- the acceleration pass --------------------------------------------------------------- */

typedef struct acceleration_pass {
    dep_acceleration_work *w;
    const double *J;
    long long jacobian_id;
} acceleration_pass;

static void measure_acceleration(void *context, const double *lam, int sized,
                                 dep_measurement *out)
{
    acceleration_pass *a = context;
    dep_acceleration_work *w = a->w;
    int nq = w->system->nq, nc = w->cs->nc;
    dep_cs_transpose_times(w->cs, a->J, lam, w->jt);
    for (int j = 0; j < nq; ++j) { /* f - J^T lam */
        w->jt[j] = w->f[j] - w->jt[j];
    }
    if (w->filter != NULL) {
        w->filter(w->filter_context, w->jt, out->x);
    } else {
        dep_mass_solve(&w->system->mass, w->jt, out->x);
    }
    dep_cs_times_sized(w->cs, a->J, out->x, out->v, out->size);
    for (int i = 0; i < nc; ++i) {
        out->v[i] = w->gamma[i] - out->v[i];
    }
    out->J = a->J;
    out->jacobian_id = a->jacobian_id;
    if (sized) {
        dep_pass_magnitude(w->mp, a->J, nc, lam, 1.0, out->x, w->gamma, out->magnitude);
    }
}

/* lambda (in: the guess) and qdd at (q, qd, t) from (1) and (2c), J = Phi_q there. */
int dep_acceleration_pass(dep_acceleration_work *w, const double *q, const double *qd,
                          double t, const double *J, long long jacobian_id, double *lam,
                          double *qdd, double tol, dep_pass_report *report,
                          dep_failure *failure)
{
    acceleration_pass a = {w, J, jacobian_id};
    dep_measurement *final = NULL;
    dep_system_force(w->system, q, qd, t, w->f);
    dep_cs_gamma(w->cs, q, qd, t, w->gamma);
    int status = dep_iterate_multipliers(w->mp, DEP_ACCELERATION, lam, w->cs->nc,
                                         measure_acceleration, &a, 1.0, tol, w->slots, &final,
                                         report, failure);
    if (status == DEP_OK && qdd != NULL) {
        memcpy(qdd, final->x, (size_t)w->system->nq * sizeof *qdd);
    }
    return status;
}

int dep_filtered_pass(dep_acceleration_work *w, dep_mobility_function filter, void *context,
                      const double *J, long long jacobian_id, double *lam, double tol,
                      dep_pass_report *report, dep_failure *failure)
{
    acceleration_pass a = {w, J, jacobian_id};
    dep_measurement *final = NULL;
    w->filter = filter;
    w->filter_context = context;
    int status = dep_iterate_multipliers(w->mp, DEP_ACCELERATION, lam, w->cs->nc,
                                         measure_acceleration, &a, 1.0, tol, w->slots, &final,
                                         report, failure);
    w->filter = NULL;
    return status;
}

/* ---- plastic impact: the M-orthogonal projection of qd onto the velocity constraints ---- */

typedef struct projection {
    dep_multipliers *mp;
    const double *J, *qd, *phi_t;
    int nc;
    long long jacobian_id;
} projection;

static void measure_projection(void *context, const double *mu, int sized,
                               dep_measurement *out)
{
    projection *pr = context;
    int nq = pr->mp->nq, nc = pr->nc;
    double *column = pr->mp->column, *solved = pr->mp->work;
    dep_multipliers_transpose_times(pr->mp, pr->J, nc, mu, column);
    dep_multipliers_apply(pr->mp, column, solved);
    memset(column, 0, (size_t)nq * sizeof *column);
    for (int j = 0; j < nq; ++j) {
        out->x[j] = pr->qd[j] - solved[j];
    }
    dep_cs_times_sized(pr->mp->cs, pr->J, out->x, out->v, out->size);
    for (int a = 0; a < nc; ++a) {
        out->v[a] = -out->v[a] - pr->phi_t[a];
    }
    out->J = pr->J;
    out->jacobian_id = pr->jacobian_id;
    if (sized) { /* qd+ is the difference of qd and M^-1 J^T mu: an impact that locks the
                    whole mechanism leaves it near nought (the accordion's last latch) */
        for (int j = 0; j < nq; ++j) {
            column[j] = fabs(pr->qd[j]) + fabs(solved[j]);
        }
        dep_cs_abs_times(pr->mp->cs, pr->J, column, out->magnitude);
        for (int a = 0; a < nc; ++a) {
            out->magnitude[a] += fabs(pr->phi_t[a]);
        }
    }
    memset(column, 0, (size_t)nq * sizeof *column);
}

/* qd+ = qd - M^-1 J^T mu with J qd+ + phi_t = 0 by the iteration (6) with C = 1. */
int dep_project_velocity(dep_multipliers *mp, const double *J, long long jacobian_id, int nc,
                         const double *qd, const double *phi_t, double tol, double *qd_new,
                         double *mu, dep_measurement *slots[2], dep_pass_report *report,
                         dep_failure *failure)
{
    projection pr = {mp, J, qd, phi_t, nc, jacobian_id};
    dep_measurement *final = NULL;
    memset(mu, 0, (size_t)nc * sizeof *mu);
    int status = dep_iterate_multipliers(mp, DEP_VELOCITY, mu, nc, measure_projection, &pr, 1.0,
                                         tol, slots, &final, report, failure);
    if (status == DEP_OK) {
        memcpy(qd_new, final->x, (size_t)mp->nq * sizeof *qd_new);
    }
    return status;
}
