/* responses.c: what the linearly implicit step needs of the passes (docs/method.md, 10): the
 * step end's response to a change of the multipliers (DOPRI's in closed form, the Rosenbrock
 * step's through its stages, from unit responses kept while W and the rows are the same), the
 * passes' G from it, and the filter that keeps the stiff modes' reactions out of the
 * multipliers the new state hands on (method.h).
 */
#include <math.h>
#include <string.h>

#include "method.h"

/* The filter of the multipliers kept under the linearly implicit step (filter_mobility) leaves
   an undamped mode's reaction times 1 - (z / (1 + z))^FILTER_ORDER, z = (gamma h omega)^2:
   off by z^k in the modes the step resolves. With k = 1 (W^-1 alone) or 2, a flexible beam
   swinging down at fixed steps converged with order 2 where the step has order 3
   (tests/c/test_core_parts.py); with 3 it keeps order 3. */
#define FILTER_ORDER 3
#define WEIGHT_MATCH 1e-12 /* end weights (of order 1) this close give the same responses */

/* The acceleration a force x gets with the stiff modes left out (history_multipliers):
   (1 - (1 - B)^k) M^-1 x with B = W^-1 M, W = M + gamma h D + gamma^2 h^2 K the linearly
   implicit step's matrix and k = FILTER_ORDER, as the sum over j = 1..k of binomial(k, j)
   (-1)^(j+1) (W^-1 M)^(j-1) W^-1 x: k solves with W's factor. In an undamped mode of frequency
   omega, B is 1 / (1 + z), z = (gamma h omega)^2: M^-1 x to z^k in the modes the step
   resolves, about k / z of it in the stiff ones.
   On `count` vectors at once (entry j of vector v at [j count + v]): x into out, through
   the block's own scratch. */
static void filter_block(dep_stepper *stepper, int count, const double *x, double *out)
{
    const dep_mass *mass = &stepper->system->mass;
    size_t size = (size_t)stepper->nq * (size_t)count;
    double *power = stepper->filter_block + (size_t)stepper->nq * DEP_FILTER_DIRECT_ROWS;
    double *product = power + (size_t)stepper->nq * DEP_FILTER_DIRECT_ROWS;
    double coefficient = FILTER_ORDER;
    dep_envelope_solve_block(&stepper->im.W, count, x, power);
    for (size_t i = 0; i < size; ++i) {
        out[i] = coefficient * power[i];
    }
    for (int k = 2; k <= FILTER_ORDER; ++k) {
        coefficient *= -(double)(FILTER_ORDER - k + 1) / k;
        memset(product, 0, size * sizeof *product);
        for (int e = 0; e < mass->nnz; ++e) {
            double m = mass->values[e];
            const double *from = power + (size_t)mass->cols[e] * (size_t)count;
            double *to = product + (size_t)mass->rows[e] * (size_t)count;
            for (int v = 0; v < count; ++v) {
                to[v] += m * from[v];
            }
        }
        dep_envelope_solve_block(&stepper->im.W, count, product, power);
        for (size_t i = 0; i < size; ++i) {
            out[i] += coefficient * power[i];
        }
    }
}

/* G J^T (stepper->filter_GJ, nq x nc interleaved) and J G J^T (filter_JGJ, row-major) for
   the active rows at J: every row's G J^T in one block of solves, kept while W and the rows'
   Jacobian stay the same (pins between beam nodes have a constant one). G is symmetric, so
   J G r = (G J^T)^T r then costs no solve. */
static void filter_rows(dep_stepper *stepper, const double *J)
{
    const dep_constraints *cs = stepper->constraints;
    int nq = stepper->nq, nc = cs->nc, nnz = cs->row_start[nc];
    if (stepper->filter_id == stepper->im.id && stepper->filter_pattern == cs->pattern
        && memcmp(stepper->filter_J, J, (size_t)nnz * sizeof *J) == 0) {
        return;
    }
    double *x = stepper->filter_block, *gx = stepper->filter_GJ;
    memset(x, 0, (size_t)nq * (size_t)nc * sizeof *x);
    for (int a = 0; a < nc; ++a) {
        for (int k = cs->row_start[a]; k < cs->row_start[a + 1]; ++k) {
            x[(size_t)cs->row_cols[k] * (size_t)nc + (size_t)a] = J[k];
        }
    }
    filter_block(stepper, nc, x, gx);
    for (int b = 0; b < nc; ++b) {
        for (int a = 0; a < nc; ++a) {
            double sum = 0.0;
            for (int k = cs->row_start[b]; k < cs->row_start[b + 1]; ++k) {
                sum += J[k] * gx[(size_t)cs->row_cols[k] * (size_t)nc + (size_t)a];
            }
            stepper->filter_JGJ[b * nc + a] = sum;
        }
    }
    memcpy(stepper->filter_J, J, (size_t)nnz * sizeof *J);
    stepper->filter_id = stepper->im.id;
    stepper->filter_pattern = cs->pattern;
}

/* filter_block on one vector: the mobility of history_multipliers' iteration (more rows). */
static void filter_mobility(void *context, const double *x, double *out)
{
    filter_block(context, 1, x, out);
}

/* Under the linearly implicit step, the multipliers the new state keeps (the profile's node
   at t_{i+1}, docs/method.md, 10): those for which J G (f - J^T lambda) = gamma with G the
   filter of filter_block, from the acceleration pass's; and qdd = M^-1 (f - J^T lambda) at them.
   The acceleration pass's multipliers carry the reactions of the stiff modes' tol-sized
   displacements, which the step damps; a profile through them drives those modes, and their
   reactions come back in the next multipliers: a loop that held the step where h omega_max
   is about 5 (two_link_flex at 16 elements: 4.3e-5 s). G leaves the modes the step resolves
   as M^-1 does and the stiff ones out. */
int dep_stepper_history_multipliers(dep_stepper *stepper, dep_state *new, dep_failure *failure)
{
    dep_acceleration_work *w = &stepper->accel;
    const dep_measurement *pos = stepper->final_position;
    const dep_constraints *cs = stepper->constraints;
    int nq = stepper->nq, nc = cs->nc;
    dep_cs_transpose_times(cs, pos->J, new->lam, w->jt);
    for (int j = 0; j < nq; ++j) { /* the net force r = M qdd */
        w->jt[j] = w->f[j] - w->jt[j];
    }
    if (nc <= DEP_FILTER_DIRECT_ROWS) { /* J G J^T d = J G r - gamma, with filter_rows' */
        double *S = stepper->filter_S, *d = stepper->filter_rhs;
        const double *gx = stepper->filter_GJ;
        filter_rows(stepper, pos->J);
        for (int b = 0; b < nc; ++b) {
            d[b] = -w->gamma[b];
        }
        for (int j = 0; j < nq; ++j) {
            for (int b = 0; b < nc; ++b) {
                d[b] += gx[(size_t)j * (size_t)nc + (size_t)b] * w->jt[j];
            }
        }
        memcpy(S, stepper->filter_JGJ, (size_t)nc * (size_t)nc * sizeof *S);
        dep_solve_small(nc, S, d);
        for (int a = 0; a < nc; ++a) {
            new->lam[a] += d[a];
        }
    } else {
        dep_pass_report report;
        dep_multipliers_set_mobility(&stepper->mp, filter_mobility, stepper,
                                     stepper->mobility_ids - 2);
        int status = dep_filtered_pass(w, filter_mobility, stepper, pos->J, pos->jacobian_id,
                                       new->lam, stepper->constraint_tol, &report, failure);
        dep_stepper_use_mobility(stepper, DEP_ACCELERATION);
        if (status != DEP_OK) {
            return status;
        }
    }
    dep_cs_transpose_times(cs, pos->J, new->lam, w->jt);
    for (int j = 0; j < nq; ++j) {
        w->jt[j] = w->f[j] - w->jt[j];
    }
    dep_mass_solve(&stepper->system->mass, w->jt, new->qdd);
    return DEP_OK;
}

/* The responses to unit forces on the coordinates units[0..count) into slots n_slots.. */
static void unit_block(dep_stepper *stepper, const int *units, int count)
{
    int nq = stepper->nq;
    double *x = stepper->im.block_x, *dq = stepper->im.block_dq, *dqd = stepper->im.block_dqd;
    memset(x, 0, (size_t)nq * (size_t)count * sizeof *x);
    for (int v = 0; v < count; ++v) {
        x[(size_t)units[v] * count + v] = 1.0;
    }
    dep_implicit_response(&stepper->im, count, x, stepper->weight, dq, dqd);
    for (int v = 0; v < count; ++v) {
        double *column = stepper->columns + 2 * (size_t)nq * (size_t)(stepper->n_slots + v);
        for (int i = 0; i < nq; ++i) {
            column[i] = dq[(size_t)i * count + v];
            column[nq + i] = dqd[(size_t)i * count + v];
        }
    }
}

/* The Rosenbrock step's responses to a unit force on each coordinate the active rows touch
   (stepper->columns), so that every later response to a constraint force is a sum of them;
   the last step's while W, the profile's end weights and the active rows are the same (the
   rows change only at a restart, which makes W new). The weights of equal steps differ in
   their last bits (the times are sums); WEIGHT_MATCH bounds what is taken as the same.
   New responses (and so a new W) make new mobilities for the passes: new ids for the Schur
   cache (position, velocity, filter_mobility's); the kept ones serve while the responses do. */
void dep_stepper_unit_responses(dep_stepper *stepper)
{
    const dep_constraints *cs = stepper->constraints;
    int nq = stepper->nq, same = stepper->responses_id == stepper->im.id;
    double times[4], weight[4];
    dep_rosenbrock_times(stepper->start->t, stepper->h, times);
    for (int i = 0; i < 4; ++i) {
        weight[i] = dep_profile_end_weight(&stepper->profile, times[i]);
        same = same && fabs(weight[i] - stepper->weight[i]) <= WEIGHT_MATCH;
    }
    if (same) {
        return;
    }
    memcpy(stepper->weight, weight, sizeof weight);
    stepper->responses_id = stepper->im.id;
    stepper->mobility_ids += 3;
    for (int j = 0; j < nq; ++j) {
        stepper->slot[j] = -1;
    }
    stepper->n_slots = 0;
    for (int k = 0; k < cs->row_start[cs->nc]; ++k) {
        int j = cs->row_cols[k];
        if (stepper->slot[j] < 0) {
            stepper->slot[j] = nq; /* touched; numbered below */
        }
    }
    int units[DEP_RESPONSE_BLOCK], count = 0;
    for (int j = 0; j <= nq; ++j) { /* the unit forces, DEP_RESPONSE_BLOCK at a time */
        if (j < nq && stepper->slot[j] == nq && stepper->n_slots + count == stepper->max_slots) {
            stepper->slot[j] = -1; /* no room (no row of the model's patterns touches it) */
        }
        if (j < nq && stepper->slot[j] == nq) {
            stepper->slot[j] = stepper->n_slots + count;
            units[count++] = j;
        }
        if (count == DEP_RESPONSE_BLOCK || (j == nq && count > 0)) {
            unit_block(stepper, units, count);
            stepper->n_slots += count;
            count = 0;
        }
    }
}

/* The step end's response (stepper->dq, dqd) to adding x l(u) to the constraint forces
   Phi_q^T lambda over the step (x: nq, a generalized force). */
void dep_stepper_respond(dep_stepper *stepper, const double *x)
{
    int nq = stepper->nq;
    double h = stepper->h;
    if (stepper->implicit) {
        memset(stepper->dq, 0, (size_t)nq * sizeof *stepper->dq);
        memset(stepper->dqd, 0, (size_t)nq * sizeof *stepper->dqd);
        for (int j = 0; j < nq; ++j) {
            if (x[j] == 0.0) {
                continue;
            }
            if (stepper->slot[j] < 0) { /* not a constraint force: through the stages */
                dep_implicit_response(&stepper->im, 1, x, stepper->weight, stepper->dq,
                                      stepper->dqd);
                return;
            }
            const double *column = stepper->columns + 2 * (size_t)nq * (size_t)stepper->slot[j];
            for (int i = 0; i < nq; ++i) {
                stepper->dq[i] += x[j] * column[i];
                stepper->dqd[i] += x[j] * column[nq + i];
            }
        }
        return;
    }
    dep_mass_solve(&stepper->system->mass, x, stepper->force);
    for (int j = 0; j < nq; ++j) {
        stepper->dq[j] = -h * h * stepper->profile.position * stepper->force[j];
        stepper->dqd[j] = -h * stepper->profile.velocity * stepper->force[j];
    }
}

/* The constraint force of lambda_{i+1} changed by lam - from, Phi_q frozen at J, into
   stepper->column. */
void dep_stepper_lam_column(dep_stepper *stepper, const double *J, const double *lam,
                       const double *from)
{
    int nc = stepper->constraints->nc;
    for (int i = 0; i < nc; ++i) {
        stepper->rhs_lam[i] = lam[i] - from[i];
    }
    dep_cs_transpose_times(stepper->constraints, J, stepper->rhs_lam, stepper->column);
}

/* The response to lambda_{i+1} changed by lam - from, Phi_q frozen at J: nought without a
   change (a velocity pass's first measurement, at the position pass's lambda). */
void dep_stepper_respond_to(dep_stepper *stepper, const double *J, const double *lam,
                       const double *from)
{
    int nc = stepper->constraints->nc, changed = 0;
    for (int i = 0; i < nc; ++i) {
        changed |= lam[i] != from[i];
    }
    if (!changed) {
        memset(stepper->dq, 0, (size_t)stepper->nq * sizeof *stepper->dq);
        memset(stepper->dqd, 0, (size_t)stepper->nq * sizeof *stepper->dqd);
        return;
    }
    dep_stepper_lam_column(stepper, J, lam, from);
    dep_stepper_respond(stepper, stepper->column);
}

/* The passes' G for the Rosenbrock step: -(response of q) / (h^2 position) and
   -(response of qd) / (h velocity), M^-1 x where the elastic forces are soft. */
static void position_mobility(void *context, const double *x, double *out)
{
    dep_stepper *stepper = context;
    double c = stepper->h * stepper->h * stepper->profile.position;
    dep_stepper_respond(stepper, x);
    for (int j = 0; j < stepper->nq; ++j) {
        out[j] = -stepper->dq[j] / c;
    }
}

static void velocity_mobility(void *context, const double *x, double *out)
{
    dep_stepper *stepper = context;
    double c = stepper->h * stepper->profile.velocity;
    dep_stepper_respond(stepper, x);
    for (int j = 0; j < stepper->nq; ++j) {
        out[j] = -stepper->dqd[j] / c;
    }
}

void dep_stepper_use_mobility(dep_stepper *stepper, int stage)
{
    if (!stepper->implicit || (stage != DEP_POSITION && stage != DEP_VELOCITY)) {
        dep_multipliers_set_mobility(&stepper->mp, NULL, NULL, 0);
    } else if (stage == DEP_POSITION) {
        dep_multipliers_set_mobility(&stepper->mp, position_mobility, stepper,
                                     stepper->mobility_ids - 1);
    } else {
        dep_multipliers_set_mobility(&stepper->mp, velocity_mobility, stepper,
                                     stepper->mobility_ids);
    }
}
