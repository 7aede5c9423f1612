/* impacts.c: the event-time solves of latches and stops, all by the iteration (6) with C = 1
 * (no factorisation): the plastic impact with unilateral stop rows (an active-set loop), and
 * the M-orthogonal projections of q and qd onto the constraints (mechanics.h).
 */
#include <math.h>
#include <string.h>

#include "mechanics.h"

typedef struct position_projection {
    dep_constraints *cs;
    const dep_mass *mass;
    const double *q, *J0;
    double t, *column, *solved;
    long long *ids;
} position_projection;

/* q+ = q - M^-1 J(q)^T mu, v = -Phi(q+). */
static void measure_position(void *context, const double *mu, int sized,
                             dep_measurement *out)
{
    position_projection *pp = context;
    int nq = pp->cs->nq, nc = pp->cs->nc;
    dep_cs_transpose_times(pp->cs, pp->J0, mu, pp->column);
    dep_mass_solve(pp->mass, pp->column, pp->solved);
    for (int j = 0; j < nq; ++j) {
        out->x[j] = pp->q[j] - pp->solved[j];
    }
    dep_cs_phi(pp->cs, out->x, pp->t, out->v);
    for (int i = 0; i < nc; ++i) {
        out->v[i] = -out->v[i];
    }
    dep_cs_jacobian(pp->cs, out->x, pp->t, out->J_own);
    out->J = out->J_own;
    out->jacobian_id = ++*pp->ids;
    dep_cs_sizes(pp->cs, out->J, out->x, out->size);
    if (sized) { /* q+ is the difference of q and M^-1 J^T mu */
        for (int j = 0; j < nq; ++j) {
            pp->solved[j] = fabs(pp->q[j]) + fabs(pp->solved[j]);
        }
        dep_cs_abs_times(pp->cs, out->J, pp->solved, out->magnitude);
    }
}

/* q moved M-orthogonally onto Phi(q) = 0 (project_positions). */
int dep_project_positions(dep_constraints *cs, dep_multipliers *mp, dep_measurement *slots[2],
                          double *q, double t, double tol, double *scratch, long long *ids,
                          dep_failure *failure)
{
    int nq = cs->nq, nc = cs->nc;
    double *J0 = scratch, *mu = J0 + DEP_JACOBIAN_SIZE(cs->system->model), *column = mu + nc;
    position_projection pp = {cs, mp->mass, q, J0, t, column, column + nq, ids};
    dep_measurement *final = NULL;
    dep_pass_report report;
    mp->cs = cs;
    dep_cs_jacobian(cs, q, t, J0);
    memset(mu, 0, (size_t)nc * sizeof *mu);
    int status = dep_iterate_multipliers(mp, DEP_POSITION, mu, nc, measure_position, &pp, 1.0,
                                         tol, slots, &final, &report, failure);
    if (status == DEP_OK) {
        memcpy(q, final->x, (size_t)nq * sizeof *q);
    }
    return status;
}

/* qd moved M-orthogonally onto Phi_q qd + Phi_t = 0 (project_velocities); mu: nc. */
int dep_project_velocities(dep_constraints *cs, dep_multipliers *mp, dep_measurement *slots[2],
                           const double *q, double *qd, double t, double tol, double *scratch,
                           long long *ids, double *mu, dep_failure *failure)
{
    int nq = cs->nq, nc = cs->nc;
    double *J = scratch, *phi_t = J + DEP_JACOBIAN_SIZE(cs->system->model), *moved = phi_t + nc;
    dep_pass_report report;
    mp->cs = cs;
    dep_cs_jacobian(cs, q, t, J);
    dep_cs_phi_t(cs, q, t, phi_t);
    int status = dep_project_velocity(mp, J, ++*ids, nc, qd, phi_t, tol, moved, mu, slots,
                                      &report, failure);
    if (status == DEP_OK) {
        memcpy(qd, moved, (size_t)nq * sizeof *qd);
    }
    return status;
}

/* 0.5 (a M a - b M b): the kinetic energy removed going from qd a to qd b (J). */
double dep_energy_loss(const dep_mass *mass, const double *a, const double *b)
{
    return 0.5 * (dep_mass_quadratic(mass, a) - dep_mass_quadratic(mass, b));
}

/* plastic_impact: the active-set loop of the projection, a pulling stop released at a time
   (mechanics.h). */
int dep_plastic_impact(dep_constraints *cs, dep_multipliers *mp, dep_measurement *slots[2],
                       const double *q, const double *qd, double *qd_new, double t, double tol,
                       const int *stops, const double *signs, int n_stops, double *scratch,
                       long long *ids, double *mu, int *released, int *n_released,
                       dep_failure *failure)
{
    *n_released = 0;
    for (;;) {
        memcpy(qd_new, qd, (size_t)cs->nq * sizeof *qd);
        int status = dep_project_velocities(cs, mp, slots, q, qd_new, t, tol, scratch, ids, mu,
                                            failure);
        if (status != DEP_OK) {
            return status;
        }
        int worst = -1;
        double worst_pull = 0.0;
        for (int k = 0; k < n_stops; ++k) { /* min over the pulling rows, first wins */
            int row = dep_cs_lock_index(cs, DEP_LOCK_STOP, stops[k]);
            double pull = row >= 0 ? signs[k] * mu[row] : 0.0;
            if (row >= 0 && pull < 0 && (worst < 0 || pull < worst_pull)) {
                worst = k;
                worst_pull = pull;
            }
        }
        if (worst < 0) {
            return DEP_OK;
        }
        released[(*n_released)++] = stops[worst];
        dep_cs_remove_lock(cs, DEP_LOCK_STOP, stops[worst]);
    }
}
