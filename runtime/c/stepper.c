/* stepper.c: one step of the paper's method, lambda(t) prescribed over the step by its profile
 * (controller.c: the polynomial through the last accepted multipliers and the unknown end
 * value lambda_{i+1}) and three passes of the iteration (6) (docs/method.md, 2):
 *
 *   1. position:     re-integrate until v_pos(q_{i+1}) is small,
 *                    C = h^2 integral (1 - u) l(u) du (h^2/6 for a linear profile)
 *   2. velocity:     apply the frozen-Phi_q effect of d(lambda) on qd_{i+1} until v_vel is
 *                    small
 *   3. acceleration: qdd_{i+1} and lambda_{i+1} from (1) and (2c), C = 1
 *
 * The ODE method is DOPRI 5(4) until, in a model with beams, a stiff mode holds its step at
 * the stability bound (integrator.c switches); then the linearly implicit ROS34PW2
 * (rosenbrock.c). A change d(lambda) of the end value moves the step end
 * by the method's response to adding (Phi_q^T d(lambda)) l(u) to the constraint forces, Phi_q
 * frozen: for DOPRI -h^2 position M^-1 Phi_q^T d(lambda) on q and -h velocity M^-1 Phi_q^T
 * d(lambda) on qd; for the Rosenbrock step the same through its stages, in which the stiff
 * elastic forces answer at once. The passes' S = Phi_q G Phi_q^T take G from that response.
 *
 * y = (q, qd, work): the dissipated work rides along as quadrature states.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "runtime.h"

#define CONSTRAINT_FRACTION 0.01
/* A position-pass trial moves the last integration's end linearly instead of integrating the
   step again while the linearisation is accurate enough for the move:
   - DOPRI: the constraint force's change -Phi_q^T d(lambda) l(u), with Phi_q turning with
     the bodies over the step (linear in time from its value at the start to the end's),
     moves the end by M^-1 times its integrals. What that misses is the rest of the force's
     response to the move, about s^2 of it (s = h |lambda|, the step's stiffness estimate).
     A move within LINEAR_MOST whose s^2 times it is within LINEAR_MISS tolerances is made at
     once. A larger one, up to LINEAR_FAR, is measured: the force's response at the moved end
     (one evaluation), grown over the step like the velocity's move, gives the miss; its
     tangential part (the passes correct the rest, as they do DOPRI's own error) within
     MEASURED_MISS. That miss has the same sign step after step (it is the geometric
     stiffness of the rows' forces answering the move): allowed a tenth of a tolerance, the
     pendulum's energy drifted by 12 to 27 tol over 10 s at tol 3e-6 to 1e-7 (1 to 3 tol when
     every such move integrated again); a hundredth keeps it there.
   - Rosenbrock: its responses run through the step's own T, so they miss only the force's
     departure from T (K's drift, up to DEP_JACOBIAN_DRIFT, and the elastic force's
     nonlinearity; two_link_flex at 16 elements: about a thousandth of the move). The move is
     measured as the step's error is, in the positions, the velocities' move counted by the
     positions it makes over a step (h times it); within ROSENBROCK_MOVE tolerances. */
#define LINEAR_MISS 0.1
#define ROSENBROCK_MOVE 1.0
/* The filter of the multipliers kept under the linearly implicit step (filter_mobility) leaves
   an undamped mode's reaction times 1 - (z / (1 + z))^FILTER_ORDER, z = (gamma h omega)^2:
   off by z^k in the modes the step resolves. With k = 1 (W^-1 alone) or 2, a flexible beam
   swinging down at fixed steps converged with order 2 where the step has order 3
   (tests/c/test_core_parts.py); with 3 it keeps order 3. */
#define FILTER_ORDER 3
/* Up to this many rows history_multipliers applies the filter to every row's J^T in one block
   of solves (filter_rows, kept while W and J are) and solves for the multipliers' change with
   the n x n matrix J G J^T (one update of (6) with A = (J G J^T)^-1: the condition is linear
   in lambda); with more, by the iteration (6) with the Schur cache's A. */
#define FILTER_DIRECT_ROWS 16
#define LINEAR_MOST 10.0
#define LINEAR_FAR 100.0
#define MEASURED_MISS 0.01
#define ROUNDOFF (16 * DEP_EPS)
#define WEIGHT_MATCH 1e-12 /* end weights (of order 1) this close give the same responses */
/* The friction torques' end value is settled when the law at the step's end gives it back to
   within this many tolerances of its effect on the end state (as the passes' constraint
   errors); FRICTION_ROUNDS end values are tried before the step fails. */
#define FRICTION_LIMIT CONSTRAINT_FRACTION
#define FRICTION_ROUNDS 8
/* A hinge whose friction's damping, times h, stays below this on its own inertia (an upper
   bound of its effect on the mechanism) takes its law's value without Newton coupling. */
#define FRICTION_WEAK 1e-3

/* The passes' iteration tolerance for an integration tolerance tol (constraint_tolerance). */
double dep_constraint_tolerance(double tol)
{
    return fmax(CONSTRAINT_FRACTION * tol, ROUNDOFF);
}

int dep_state_init(dep_state *state, int nq, int capacity, int nd, dep_arena *arena)
{
    memset(state, 0, sizeof *state);
    state->q = dep_doubles(arena, (size_t)nq);
    state->qd = dep_doubles(arena, (size_t)nq);
    state->qdd = dep_doubles(arena, (size_t)nq);
    state->lam = dep_doubles(arena, (size_t)capacity);
    state->work = dep_doubles(arena, (size_t)nd);
    return arena->failed ? DEP_MEMORY_ERROR : DEP_OK;
}

void dep_state_copy(dep_state *to, const dep_state *from, int nq, int nc, int nd)
{
    to->t = from->t;
    memcpy(to->q, from->q, (size_t)nq * sizeof(double));
    memcpy(to->qd, from->qd, (size_t)nq * sizeof(double));
    memcpy(to->qdd, from->qdd, (size_t)nq * sizeof(double));
    memcpy(to->lam, from->lam, (size_t)nc * sizeof(double));
    memcpy(to->work, from->work, (size_t)nd * sizeof(double));
}

int dep_outcome_init(dep_outcome *outcome, int nq, int capacity, int nd, int nh,
                     dep_arena *arena)
{
    memset(outcome, 0, sizeof *outcome);
    outcome->data = dep_doubles(arena, 12 * (size_t)nq + 1);
    outcome->friction = dep_doubles(arena, (size_t)nh + 1);
    return dep_state_init(&outcome->state, nq, capacity, nd, arena);
}

int dep_stepper_init(dep_stepper *stepper, const dep_system *system, dep_constraints *cs,
                     double tol, dep_arena *arena)
{
    int nq = system->nq, capacity = cs->capacity, ny = 2 * system->nq + system->nd;
    memset(stepper, 0, sizeof *stepper);
    stepper->system = system;
    stepper->constraints = cs;
    stepper->nq = nq;
    stepper->ny = ny;
    stepper->capacity = capacity;
    stepper->tol = tol;
    stepper->constraint_tol = dep_constraint_tolerance(tol);
    if (dep_multipliers_init(&stepper->mp, &system->mass, cs, capacity, arena) != DEP_OK) {
        return DEP_MEMORY_ERROR;
    }
    for (int k = 0; k < 6; ++k) { /* position (own J, trajectory), velocity, acceleration */
        if (dep_measurement_init(&stepper->slots[k], system->model, capacity, k < 2 ? ny : 0, k < 2,
                                 arena) != DEP_OK) {
            return DEP_MEMORY_ERROR;
        }
    }
    double **vectors[] = {&stepper->y0, &stepper->k1, &stepper->scratch};
    for (size_t i = 0; i < sizeof vectors / sizeof *vectors; ++i) {
        *vectors[i] = dep_doubles(arena, (size_t)ny);
    }
    double **rows[] = {&stepper->rhs_lam, &stepper->base_lam, &stepper->phi_t1,
                       &stepper->lam_pos, &stepper->lam_first, &stepper->lam_solved,
                       &stepper->lam_shift};
    for (size_t i = 0; i < sizeof rows / sizeof *rows; ++i) {
        *rows[i] = dep_doubles(arena, (size_t)capacity);
    }
    stepper->force = dep_doubles(arena, (size_t)nq);
    stepper->end_force = dep_doubles(arena, (size_t)nq);
    stepper->end_state = dep_doubles(arena, 2 * (size_t)nq);
    stepper->end_t = NAN;
    stepper->base_J = dep_doubles(arena, DEP_JACOBIAN_SIZE(system->model));
    stepper->start_J = dep_doubles(arena, DEP_JACOBIAN_SIZE(system->model));
    stepper->start_Jh = dep_doubles(arena, (size_t)system->model->nhnz + 1);
    stepper->start_force = dep_doubles(arena, 2 * (size_t)nq);
    stepper->miss = dep_doubles(arena, 4 * (size_t)nq + 2 * (size_t)capacity);
    if (dep_rk_init(&stepper->base, ny, arena) != DEP_OK) {
        return DEP_MEMORY_ERROR;
    }
    stepper->accel.system = system;
    stepper->accel.cs = cs;
    stepper->accel.mp = &stepper->mp;
    stepper->accel.slots[0] = &stepper->slots[4];
    stepper->accel.slots[1] = &stepper->slots[5];
    stepper->accel.f = dep_doubles(arena, (size_t)nq);
    stepper->accel.jt = dep_doubles(arena, (size_t)nq);
    stepper->accel.solved = dep_doubles(arena, (size_t)nq);
    stepper->accel.gamma = dep_doubles(arena, (size_t)capacity);
    if (system->model->nkz > 0) { /* history_multipliers' block (models with stiff forces) */
        size_t block = (size_t)nq * FILTER_DIRECT_ROWS;
        stepper->filter_block = dep_doubles(arena, 3 * block); /* x, two scratch */
        stepper->filter_S = dep_doubles(arena, FILTER_DIRECT_ROWS * FILTER_DIRECT_ROWS);
        stepper->filter_JGJ = dep_doubles(arena, FILTER_DIRECT_ROWS * FILTER_DIRECT_ROWS);
        stepper->filter_rhs = dep_doubles(arena, FILTER_DIRECT_ROWS);
        stepper->filter_J = dep_doubles(arena, DEP_JACOBIAN_SIZE(system->model));
        stepper->filter_GJ = dep_doubles(arena, (size_t)nq * FILTER_DIRECT_ROWS);
        stepper->filter_id = -1;
    }
    stepper->jt_lam = dep_doubles(arena, (size_t)nq);
    stepper->q1 = dep_doubles(arena, (size_t)nq);
    stepper->restart_J = dep_doubles(arena, DEP_JACOBIAN_SIZE(system->model));
    stepper->dq = dep_doubles(arena, (size_t)nq);
    stepper->dqd = dep_doubles(arena, (size_t)nq);
    stepper->column = dep_doubles(arena, (size_t)nq);
    size_t nh = (size_t)system->nh + 1, nhnz = (size_t)system->model->nhnz + 1;
    double **hinge_rows[] = {&stepper->friction_end, &stepper->friction_base,
                             &stepper->friction_now, &stepper->law, &stepper->residual,
                             &stepper->dtau, &stepper->slope, &stepper->residual_end,
                             &stepper->law_scratch};
    for (size_t i = 0; i < sizeof hinge_rows / sizeof *hinge_rows; ++i) {
        *hinge_rows[i] = dep_doubles(arena, nh);
    }
    stepper->base_Jh = dep_doubles(arena, nhnz);
    stepper->Jh = dep_doubles(arena, nhnz);
    stepper->free_hinges = dep_bytes(arena, nh * sizeof *stepper->free_hinges);
    stepper->mobile = dep_doubles(arena, (size_t)system->n_friction * (size_t)nq + 1);
    stepper->mobile_lam = dep_doubles(arena, (size_t)system->n_friction * (size_t)capacity + 1);
    stepper->newton = dep_doubles(arena, (size_t)system->n_friction
                                         * (size_t)(system->n_friction + 1) + 1);
    stepper->implicit = 0;
    if (system->model->nkz > 0 && dep_stepper_prepare_implicit(stepper, arena) != DEP_OK) {
        return DEP_MEMORY_ERROR;
    }
    return arena->failed ? DEP_MEMORY_ERROR : DEP_OK;
}

int dep_stepper_prepare_implicit(dep_stepper *stepper, dep_arena *arena)
{
    int nq = stepper->nq;
    if (dep_implicit_init(&stepper->im, stepper->system, stepper->ny, arena) != DEP_OK) {
        return DEP_MEMORY_ERROR;
    }
    const dep_model *m = stepper->system->model;
    stepper->slot = dep_bytes(arena, (size_t)nq * sizeof *stepper->slot);
    if (stepper->slot == NULL) {
        return DEP_MEMORY_ERROR;
    }
    /* the columns any row can touch: Phi_q's and the hinge Jacobian's (every lock row's) */
    memset(stepper->slot, 0, (size_t)nq * sizeof *stepper->slot);
    for (int k = 0; k < m->nnz; ++k) {
        stepper->slot[m->phi_q_cols[k]] = 1;
    }
    for (int k = 0; k < m->nhnz; ++k) {
        stepper->slot[m->hinge_jacobian_cols[k]] = 1;
    }
    stepper->max_slots = 0;
    for (int j = 0; j < nq; ++j) {
        stepper->max_slots += stepper->slot[j];
    }
    stepper->columns = dep_doubles(arena, 2 * (size_t)nq * (size_t)stepper->max_slots + 1);
    stepper->responses_id = -1;
    return arena->failed ? DEP_MEMORY_ERROR : DEP_OK;
}

/* ---- the motion (1) with lambda(t) given -------------------------------------------------- */

/* lambda(t) by `profile` with end value lam_end for the next rhs calls (both kept by
   reference). */
void dep_stepper_set_rhs(dep_stepper *stepper, const dep_profile *profile,
                         const double *lam_end)
{
    if (&stepper->profile != profile) {
        stepper->profile = *profile;
    }
    stepper->rhs_end = lam_end;
}

static void dissipation(const dep_system *s, const double *q, const double *qd, double t,
                        double *out)
{
    if (s->nd > 0) {
        dep_system_dissipation(s, q, qd, t, out);
    }
}

/* (qd, f - Phi_q^T lambda(t), work rates) at y = (q, qd, work) into out; with
   `accelerations` the middle part is M^-1 (f - Phi_q^T lambda(t)), qdd. */
static void right_side(dep_stepper *stepper, double t, const double *y, double *out,
                       int accelerations)
{
    dep_constraints *cs = stepper->constraints;
    const dep_system *s = stepper->system;
    int nq = stepper->nq;
    const double *q = y, *qd = y + nq;
    dep_profile_value(&stepper->profile, stepper->rhs_end, t, cs->nc, stepper->rhs_lam);
    dep_cs_jacobian_transpose_times(cs, q, t, stepper->rhs_lam, stepper->jt_lam);
    memcpy(out, qd, (size_t)nq * sizeof *out);
    if (stepper->known_force != NULL) { /* f given (stage 1 of the linearly implicit step) */
        memcpy(stepper->force, stepper->known_force, (size_t)nq * sizeof *stepper->force);
        dissipation(s, q, qd, t, out + 2 * nq);
    } else if (s->nd > 0) { /* the work rates too, from the same hinge rates and friction torques */
        const double *friction = NULL;
        if (stepper->prescribed) {
            dep_profile_value(&stepper->friction_profile, stepper->friction_end, t, s->nh,
                              stepper->friction_now);
            friction = stepper->friction_now;
        }
        dep_system_force_power(s, q, qd, t, friction, stepper->force, out + 2 * nq);
        stepper->rhs_evaluations++;
    } else {
        dep_system_force(s, q, qd, t, stepper->force);
        stepper->rhs_evaluations++;
    }
    for (int j = 0; j < nq; ++j) {
        stepper->force[j] -= stepper->jt_lam[j];
    }
    if (accelerations) {
        dep_mass_solve(&s->mass, stepper->force, out + nq);
    } else {
        memcpy(out + nq, stepper->force, (size_t)nq * sizeof *out);
    }
}

void dep_stepper_rhs(void *context, double t, const double *y, double *dy)
{
    right_side(context, t, y, dy, 1);
}

/* v (nq, in place) less what the pass's correction at J moves along the rows:
   v - G J^T S^-1 J v with S = J G J^T, G the multipliers' (M^-1: the M-orthogonal projection
   onto the tangent space); 0 (v as it was) where S is singular. scratch: 2 nc + 2 nq. */
int dep_stepper_tangential(dep_stepper *stepper, const double *J, long long J_id, double *v,
                           double *scratch)
{
    int nq = stepper->nq, nc = stepper->constraints->nc;
    double *Jv = scratch, *mu = Jv + nc, *column = mu + nc, *solved = column + nq;
    if (nc == 0) {
        return 1;
    }
    dep_cs_times(stepper->constraints, J, v, Jv);
    if (!dep_schur_solve(&stepper->mp, J, J_id, nc, Jv, mu)) {
        return 0;
    }
    dep_cs_transpose_times(stepper->constraints, J, mu, column);
    dep_multipliers_apply(&stepper->mp, column, solved);
    for (int j = 0; j < nq; ++j) {
        v[j] -= solved[j];
    }
    return 1;
}

/* g = (qd, f - Phi_q^T lambda(t), work rates): the Rosenbrock step's right side. */
static void stage_force(void *context, double t, const double *y, double *g)
{
    right_side(context, t, y, g, 0);
}

/* dy/dt at an accepted state: the first RK stage (qdd is known). */
void dep_stepper_derivative(dep_stepper *stepper, const dep_state *state, double *dy)
{
    int nq = stepper->nq;
    memcpy(dy, state->qd, (size_t)nq * sizeof *dy);
    memcpy(dy + nq, state->qdd, (size_t)nq * sizeof *dy);
    dissipation(stepper->system, state->q, state->qd, state->t, dy + 2 * nq);
}

/* ---- pass 3, also for initial and post-event states ------------------------------------- */

/* lambda (in: the guess) and qdd at (q, qd, t) from (1) and (2c); J: Phi_q there. */
int dep_acceleration(dep_stepper *stepper, const double *q, const double *qd, double t,
                     double *lam, const double *J, long long jacobian_id, double *qdd,
                     dep_pass_report *report, dep_failure *failure)
{
    return dep_acceleration_pass(&stepper->accel, q, qd, t, J, jacobian_id, lam, qdd,
                                 stepper->constraint_tol, report, failure);
}

static void filter_mobility(void *context, const double *x, double *out);

static void solve_small(int n, double *A, double *b);

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
    double *power = stepper->filter_block + (size_t)stepper->nq * FILTER_DIRECT_ROWS;
    double *product = power + (size_t)stepper->nq * FILTER_DIRECT_ROWS;
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

/* Under the linearly implicit step, the multipliers the new state keeps (the profile's node
   at t_{i+1}, docs/method.md, 10): those for which J G (f - J^T lambda) = gamma with G the
   filter of filter_block, from the acceleration pass's; and qdd = M^-1 (f - J^T lambda) at them.
   The acceleration pass's multipliers carry the reactions of the stiff modes' tol-sized
   displacements, which the step damps; a profile through them drives those modes, and their
   reactions come back in the next multipliers: a loop that held the step where h omega_max
   is about 5 (two_link_flex at 16 elements: 4.3e-5 s). G leaves the modes the step resolves
   as M^-1 does and the stiff ones out. */
static int history_multipliers(dep_stepper *stepper, dep_state *new, dep_failure *failure)
{
    dep_acceleration_work *w = &stepper->accel;
    const dep_measurement *pos = stepper->final_position;
    const dep_constraints *cs = stepper->constraints;
    int nq = stepper->nq, nc = cs->nc;
    dep_cs_transpose_times(cs, pos->J, new->lam, w->jt);
    for (int j = 0; j < nq; ++j) { /* the net force r = M qdd */
        w->jt[j] = w->f[j] - w->jt[j];
    }
    if (nc <= FILTER_DIRECT_ROWS) { /* J G J^T d = J G r - gamma, with filter_rows' */
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
        solve_small(nc, S, d);
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

/* ---- one step ---------------------------------------------------------------------------- */

/* One step of the ODE method with lambda_{i+1} = lam1 into the stepper's base, and Phi_q at
   its end. */
static void integrate(dep_stepper *stepper, const double *lam1)
{
    int nc = stepper->constraints->nc;
    const dep_state *s = stepper->start;
    stepper->integrations_this_step++;
    stepper->integrations++;
    dep_stepper_set_rhs(stepper, &stepper->profile, lam1);
    if (stepper->implicit) {
        dep_rosenbrock_step(&stepper->im, &stepper->base, stage_force, stepper, s->t,
                            stepper->y0, stepper->h);
    } else {
        dep_dopri_step(&stepper->base, dep_stepper_rhs, stepper, s->t, stepper->y0,
                       stepper->k1, stepper->h, stepper->scratch);
    }
    memcpy(stepper->base_lam, lam1, (size_t)nc * sizeof *lam1);
    dep_cs_jacobian(stepper->constraints, stepper->base.y1, stepper->t1, stepper->base_J);
    if (stepper->prescribed) {
        const dep_system *system = stepper->system;
        memcpy(stepper->friction_base, stepper->friction_end,
               (size_t)system->nh * sizeof(double));
        system->model->hinge_jacobian(stepper->base.y1, system->p, stepper->base_Jh);
    }
    stepper->base_valid = 1;
}

static void copy_base(const dep_stepper *stepper, dep_rk_step *to)
{
    size_t ny = (size_t)stepper->ny;
    to->method = stepper->base.method;
    to->order = stepper->base.order;
    to->t0 = stepper->base.t0;
    to->h = stepper->base.h;
    to->y0 = stepper->base.y0;
    memcpy(to->y1, stepper->base.y1, ny * sizeof(double));
    memcpy(to->error, stepper->base.error, ny * sizeof(double));
    memcpy(to->K, stepper->base.K, 7 * ny * sizeof(double));
    memcpy(to->mode, stepper->base.mode, ny * sizeof(double));
    to->stiffness = stepper->base.stiffness;
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
static void unit_responses(dep_stepper *stepper)
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
static void respond(dep_stepper *stepper, const double *x)
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
static void lam_column(dep_stepper *stepper, const double *J, const double *lam,
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
static void respond_to(dep_stepper *stepper, const double *J, const double *lam,
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
    lam_column(stepper, J, lam, from);
    respond(stepper, stepper->column);
}

/* The passes' G for the Rosenbrock step: -(response of q) / (h^2 position) and
   -(response of qd) / (h velocity), M^-1 x where the elastic forces are soft. */
static void position_mobility(void *context, const double *x, double *out)
{
    dep_stepper *stepper = context;
    double c = stepper->h * stepper->h * stepper->profile.position;
    respond(stepper, x);
    for (int j = 0; j < stepper->nq; ++j) {
        out[j] = -stepper->dq[j] / c;
    }
}

static void velocity_mobility(void *context, const double *x, double *out)
{
    dep_stepper *stepper = context;
    double c = stepper->h * stepper->profile.velocity;
    respond(stepper, x);
    for (int j = 0; j < stepper->nq; ++j) {
        out[j] = -stepper->dqd[j] / c;
    }
}

/* filter_block on one vector: the mobility of history_multipliers' iteration (more rows). */
static void filter_mobility(void *context, const double *x, double *out)
{
    filter_block(context, 1, x, out);
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

/* Phi_q and J_h at the step's start (once a step, when a correction first needs them). */
static void start_jacobians(dep_stepper *stepper)
{
    const dep_system *system = stepper->system;
    if (stepper->start_made) {
        return;
    }
    dep_cs_jacobian(stepper->constraints, stepper->start->q, stepper->start->t, stepper->start_J);
    if (stepper->prescribed) {
        system->model->hinge_jacobian(stepper->start->q, system->p, stepper->start_Jh);
    }
    stepper->start_made = 1;
}

/* M^-1 (Phi_q^T d(lambda) - J_h^T d(tau)) at J, Jh into out: d(lambda) in rhs_lam, d(tau)
   (prescribed friction) in residual. */
static void moved_force(dep_stepper *stepper, const double *J, const double *Jh, double *out)
{
    const dep_system *system = stepper->system;
    int nq = stepper->nq;
    dep_cs_transpose_times(stepper->constraints, J, stepper->rhs_lam, stepper->column);
    if (stepper->prescribed) {
        dep_hinge_transpose_times(system, Jh, stepper->residual, stepper->jt_lam);
        for (int j = 0; j < nq; ++j) {
            stepper->column[j] -= stepper->jt_lam[j];
        }
    }
    dep_mass_solve(&system->mass, stepper->column, out);
}

/* The DOPRI step end's response (stepper->dq, dqd) to lambda_{i+1} changed from the base's by
   lam1 - base_lam and, with the friction prescribed, its end value by friction_end -
   friction_base (stepper->residual): the force -(Phi_q^T d(lambda) - J_h^T d(tau)) l(u), with
   Phi_q and J_h linear in time from the step's start to the base's end (the profile's
   position_start and velocity_start weigh the start's part). stepper->start_force: M^-1 of
   the force's start and end values. */
static void respond_along(dep_stepper *stepper, const double *lam1)
{
    int nq = stepper->nq, nc = stepper->constraints->nc;
    const dep_profile *profile = &stepper->profile;
    double h = stepper->h, *f0 = stepper->start_force, *f1 = f0 + nq;
    double p0 = profile->position_start, p1 = profile->position - p0;
    double v0 = profile->velocity_start, v1 = profile->velocity - v0;
    start_jacobians(stepper);
    for (int i = 0; i < nc; ++i) {
        stepper->rhs_lam[i] = lam1[i] - stepper->base_lam[i];
    }
    moved_force(stepper, stepper->start_J, stepper->start_Jh, f0);
    moved_force(stepper, stepper->base_J, stepper->base_Jh, f1);
    for (int j = 0; j < nq; ++j) {
        stepper->dq[j] = -h * h * (p0 * f0[j] + p1 * f1[j]);
        stepper->dqd[j] = -h * (v0 * f0[j] + v1 * f1[j]);
    }
}

/* The measured miss of a DOPRI correction to y1 (the base's end moved by dq, dqd): the
   force's response at the moved end, e = a(y1, lam1) - a(base end, base_lam) + M^-1 (Phi_q^T
   d(lambda) - J_h^T d(tau)) (less the part the correction made), grown over the step like the
   velocity's move, integral_0^u l: it misses h (position / velocity) e in qd and h^2 (lagged /
   velocity) e in q (a force growing later, like the position's move, misses less). Its
   tangential part, RMS in tolerances. */
static double linear_miss(dep_stepper *stepper, const double *lam1, const double *y1)
{
    int nq = stepper->nq, ny = stepper->ny;
    double h = stepper->h, *dy = stepper->scratch, *mq = stepper->miss, *mv = mq + nq;
    const double *end = stepper->base.K + 6 * (size_t)ny + nq;
    const dep_profile *profile = &stepper->profile;
    const double *made = stepper->start_force + nq; /* respond_along's end force */
    dep_stepper_set_rhs(stepper, &stepper->profile, lam1);
    dep_stepper_rhs(stepper, stepper->t1, y1, dy);
    for (int j = 0; j < nq; ++j) {
        double e = dy[nq + j] - end[j] + made[j];
        mq[j] = h * h * profile->lagged / profile->velocity * e;
        mv[j] = h * profile->position / profile->velocity * e;
    }
    for (int half = 0; half < 2; ++half) { /* (along the base's end rows: an estimate) */
        dep_stepper_tangential(stepper, stepper->base_J, stepper->base_J_id, mq + half * nq,
                               mq + 2 * nq);
    }
    double sum = 0.0;
    for (int j = 0; j < nq; ++j) {
        double a = mq[j] / (stepper->tol * (1.0 + fabs(y1[j])));
        double b = mv[j] / (stepper->tol * (1.0 + fabs(y1[nq + j])));
        sum += a * a + b * b;
    }
    return sqrt(sum / (2 * nq));
}

void dep_stepper_work_move(dep_stepper *stepper, const double *q, const double *dq,
                           double *work)
{
    const dep_system *system = stepper->system;
    double *turn = stepper->friction_now;
    system->model->hinge_rates(q, dq, system->p, turn);
    for (int i = 0, k = 0; i < system->nh; ++i) {
        if (system->hinges[i].has_friction) {
            work[k++] -= stepper->friction_end[i] * turn[i];
        }
    }
}

/* The base trajectory's end moved to lambda_{i+1} = lam1 (and the friction's end value) by
   the linear response (DOPRI: respond_along; Rosenbrock: through its stages, Phi_q frozen at
   the end), into out with its Jacobian; 0 (out not valid) when the linearisation is not
   accurate enough for the move (the limits above): the step is integrated again instead. */
static int correct_base(dep_stepper *stepper, const double *lam1, dep_measurement *out)
{
    int nq = stepper->nq;
    double sum = 0.0;
    int rosenbrock = stepper->base.method == DEP_ROSENBROCK;
    if (stepper->prescribed) {
        const dep_system *system = stepper->system;
        for (int i = 0; i < system->nh; ++i) {
            stepper->residual[i] = stepper->friction_end[i] - stepper->friction_base[i];
        }
    }
    if (rosenbrock) {
        lam_column(stepper, stepper->base_J, lam1, stepper->base_lam);
        respond(stepper, stepper->column);
    } else {
        respond_along(stepper, lam1);
    }
    for (int j = 0; j < nq; ++j) { /* the moves of q and qd in tolerance units */
        double move = stepper->dq[j], rate = stepper->dqd[j];
        double scale = stepper->tol * (1.0 + fabs(stepper->base.y1[j]));
        double rate_scale = rosenbrock ? scale / stepper->h
                                       : stepper->tol * (1.0 + fabs(stepper->base.y1[nq + j]));
        sum += (move / scale) * (move / scale) + (rate / rate_scale) * (rate / rate_scale);
    }
    double s2 = stepper->base.stiffness * stepper->base.stiffness, limit = ROSENBROCK_MOVE;
    double move = sqrt(sum / (2 * nq));
    if (!rosenbrock) {
        limit = s2 * LINEAR_MOST > LINEAR_MISS ? LINEAR_MISS / s2 : LINEAR_MOST;
    }
    if (!(move <= (rosenbrock ? limit : LINEAR_FAR))) {
        return 0;
    }
    dep_rk_step *rk = &out->rk;
    copy_base(stepper, rk);
    for (int j = 0; j < nq; ++j) {
        rk->y1[j] += stepper->dq[j];
        rk->y1[nq + j] += stepper->dqd[j];
    }
    if (stepper->prescribed) { /* each friction's work: -tau d(theta), -d(tau) l(u) rate dt */
        const dep_system *system = stepper->system;
        double *work = rk->y1 + 2 * nq + system->model->nd;
        dep_stepper_work_move(stepper, rk->y1, stepper->dq, work);
        system->model->hinge_rates(rk->y1, rk->y1 + nq, system->p, stepper->law);
        for (int i = 0, k = 0; i < system->nh; ++i) {
            if (system->hinges[i].has_friction) {
                work[k++] -= stepper->h * stepper->profile.velocity * stepper->residual[i]
                             * stepper->law[i];
            }
        }
    }
    if (move > limit && !(linear_miss(stepper, lam1, rk->y1) <= MEASURED_MISS)) {
        return 0;
    }
    dep_cs_jacobian(stepper->constraints, rk->y1, stepper->t1, out->J_own);
    return 1;
}

/* The position pass's measurement for a trial lambda_{i+1}: the step's end by correcting the
   last integration when the change is small, else by integrating again. */
static void measure_position(void *context, const double *lam1, dep_measurement *out)
{
    dep_stepper *stepper = context;
    dep_constraints *cs = stepper->constraints;
    const double *q1 = out->rk.y1;
    out->jacobian_id = ++stepper->jacobian_ids;
    if (!stepper->base_valid || !correct_base(stepper, lam1, out)) {
        integrate(stepper, lam1);
        copy_base(stepper, &out->rk);
        memcpy(out->J_own, stepper->base_J, (size_t)cs->row_start[cs->nc] * sizeof *out->J_own);
        stepper->base_J_id = out->jacobian_id;
    }
    dep_cs_phi(cs, q1, stepper->t1, out->v);
    for (int i = 0; i < cs->nc; ++i) {
        out->v[i] = -out->v[i];
    }
    out->J = out->J_own;
    out->scale = dep_max_abs(q1, stepper->nq);
}

/* qd_{i+1} = qd of the position pass's trajectory plus the response of qd to
   lambda - lambda_pos, Phi_q frozen at its end (DOPRI: -h velocity M^-1 J1^T (lambda -
   lambda_pos)). */
static void measure_velocity(void *context, const double *lam1, dep_measurement *out)
{
    dep_stepper *stepper = context;
    const dep_measurement *pos = stepper->final_position;
    int nq = stepper->nq, nc = stepper->constraints->nc;
    respond_to(stepper, pos->J, lam1, stepper->lam_pos);
    for (int j = 0; j < nq; ++j) {
        out->x[j] = pos->rk.y1[nq + j] + stepper->dqd[j];
    }
    out->scale = dep_cs_times_scale(stepper->constraints, pos->J, out->x, out->v);
    for (int i = 0; i < nc; ++i) {
        out->v[i] = -out->v[i] - stepper->phi_t1[i];
    }
    out->J = pos->J;
    out->jacobian_id = pos->jacobian_id;
}

/* The new state's work and the step's interpolant. */
static void finish_step(dep_stepper *stepper, const dep_state *state, dep_outcome *outcome)
{
    int nq = stepper->nq, nd = stepper->system->nd;
    dep_state *new = &outcome->state;
    dep_rk_step *rk = &stepper->final_position->rk;
    memcpy(new->work, rk->y1 + 2 * nq, (size_t)nd * sizeof(double));
    if (rk->method == DEP_ROSENBROCK) { /* the work rates at the end, for the dense output */
        dissipation(stepper->system, new->q, new->qd, new->t, rk->K + 6 * (size_t)rk->n + 2 * nq);
    }
    dep_interpolant_data(new->t - state->t, state->q, state->qd, state->qdd, new->q, new->qd,
                         new->qdd, nq, outcome->data);
    outcome->rk = rk;
    outcome->J1 = stepper->final_position->J;
    outcome->J1_id = stepper->final_position->jacobian_id;
    outcome->lam_position = stepper->lam_pos;
    outcome->integrations = stepper->integrations_this_step;
}

/* ---- friction prescribed over the step ----------------------------------------------------- */

/* out (nq) = Mc^-1 J_h^T tau, the end velocity's response per h V to friction end values
   changed by tau (nh) once the passes restore the rows, Mc^-1 = M^-1 - M^-1 J^T S^-1 J M^-1
   (J: Phi_q at the end, J_h: stepper->Jh; M^-1 alone where S is singular); lam (nc, or NULL)
   the change of lambda_{i+1} that restores them, S^-1 J M^-1 J_h^T tau. */
static void constrained_response(dep_stepper *stepper, const dep_measurement *pos,
                                 const double *tau, double *out, double *lam)
{
    const dep_system *system = stepper->system;
    dep_constraints *cs = stepper->constraints;
    int nq = stepper->nq, nc = cs->nc, moved = 0;
    double *solved = lam != NULL ? lam : stepper->lam_solved;
    for (int i = 0; i < system->nh; ++i) {
        moved |= tau[i] != 0.0;
    }
    if (!moved) { /* none (after a Newton round, the hinges sliding outside their slip band
                     keep their law's value: a third of the calls on INTELSAT V) */
        memset(out, 0, (size_t)nq * sizeof *out);
        memset(solved, 0, (size_t)nc * sizeof *solved);
        return;
    }
    dep_hinge_transpose_times(system, stepper->Jh, tau, stepper->column);
    dep_mass_solve(&system->mass, stepper->column, out);
    memset(solved, 0, (size_t)nc * sizeof *solved);
    if (nc == 0) {
        return;
    }
    dep_cs_times(cs, pos->J, out, stepper->rhs_lam);
    if (dep_schur_solve(&stepper->mp, pos->J, pos->jacobian_id, nc, stepper->rhs_lam, solved)) {
        dep_cs_transpose_times(cs, pos->J, solved, stepper->column);
        dep_mass_solve(&system->mass, stepper->column, stepper->force);
        for (int j = 0; j < nq; ++j) {
            out[j] -= stepper->force[j];
        }
    } else {
        memset(solved, 0, (size_t)nc * sizeof *solved);
    }
}

/* At round 0: J_h at the new state, the hinges whose friction can act (free), each one's law
   damping C_k and an upper bound of its rate on the mechanism, C_k (J_h M^-1 J_h^T)_kk (Mc^-1
   <= M^-1); the coupled ones, whose bound times h exceeds FRICTION_WEAK, get their exact
   response columns Mc^-1 J_h^T e_k (mobile) and the multipliers' S^-1 J M^-1 J_h^T e_k
   (mobile_lam), and friction_rate max_k C_k (J_h Mc^-1 J_h^T)_kk over them (else the largest
   bound). */
static void friction_mobility(dep_stepper *stepper, const double *q1, const dep_measurement *pos,
                              const double *slope)
{
    const dep_system *system = stepper->system;
    int nq = stepper->nq, nh = system->nh;
    double *unit = stepper->residual, *bound = stepper->dtau;
    system->model->hinge_jacobian(q1, system->p, stepper->Jh);
    memset(unit, 0, (size_t)nh * sizeof *unit);
    stepper->n_free = 0;
    stepper->friction_rate = 0.0;
    stepper->friction_hinge = -1;
    for (int i = 0; i < nh; ++i) {
        const dep_hinge_mechanics *h = &system->hinges[i];
        bound[i] = 0.0;
        if (!h->has_friction || h->kinetic == 0.0 || dep_hinge_locked(h) || h->stuck
            || slope[i] == 0.0) {
            continue;
        }
        unit[i] = 1.0; /* (J_h M^-1 J_h^T)_ii */
        dep_hinge_transpose_times(system, stepper->Jh, unit, stepper->column);
        dep_mass_solve(&system->mass, stepper->column, stepper->force);
        system->model->hinge_rates(q1, stepper->force, system->p, stepper->friction_now);
        unit[i] = 0.0;
        bound[i] = slope[i] * stepper->friction_now[i];
        if (stepper->h * bound[i] > FRICTION_WEAK) {
            stepper->free_hinges[stepper->n_free++] = i;
        } else if (bound[i] > stepper->friction_rate) {
            stepper->friction_rate = bound[i];
            stepper->friction_hinge = i;
        }
    }
    for (int k = 0; k < stepper->n_free; ++k) {
        int i = stepper->free_hinges[k];
        double *out = stepper->mobile + (size_t)k * (size_t)nq;
        unit[i] = 1.0;
        constrained_response(stepper, pos, unit, out,
                             stepper->mobile_lam + (size_t)k * (size_t)stepper->capacity);
        unit[i] = 0.0;
        system->model->hinge_rates(q1, out, system->p, stepper->friction_now);
        if (slope[i] * stepper->friction_now[i] > stepper->friction_rate) {
            stepper->friction_rate = slope[i] * stepper->friction_now[i];
            stepper->friction_hinge = i;
        }
    }
}

/* x = A^-1 b for the n x n matrix A (row-major, overwritten), by elimination with partial
   pivoting; b is overwritten by x. */
static void solve_small(int n, double *A, double *b)
{
    for (int c = 0; c < n; ++c) {
        int pivot = c;
        for (int r = c + 1; r < n; ++r) {
            pivot = fabs(A[r * n + c]) > fabs(A[pivot * n + c]) ? r : pivot;
        }
        if (pivot != c) {
            for (int m = 0; m < n; ++m) {
                double swap = A[c * n + m];
                A[c * n + m] = A[pivot * n + m];
                A[pivot * n + m] = swap;
            }
            double swap = b[c];
            b[c] = b[pivot];
            b[pivot] = swap;
        }
        for (int r = c + 1; r < n; ++r) {
            double factor = A[r * n + c] / A[c * n + c];
            for (int m = c; m < n; ++m) {
                A[r * n + m] -= factor * A[c * n + m];
            }
            b[r] -= factor * b[c];
        }
    }
    for (int c = n - 1; c >= 0; --c) {
        double sum = b[c];
        for (int m = c + 1; m < n; ++m) {
            sum -= A[c * n + m] * b[m];
        }
        b[c] = sum / A[c * n + c];
    }
}

/* After the velocity pass of round `round`: 1 when the friction law at the new state (q1, qd1)
   gives back the end value the step prescribed, to within FRICTION_LIMIT tolerances of the
   difference r's effect on the end state (h^2 P and h V times Mc^-1 J_h^T r); else 0, with
   the end value moved by Newton's step for law(rate(tau_end)) = tau_end, the rates' response
   being h V J_h Mc^-1 J_h^T d(tau_end) and the law's damping C = -d law / d rate: the coupled
   hinges F solve (I + h V C_F G_FF) d_F = r_F - h V C_F J_h,F Mc^-1 J_h^T r_Z with
   G = J_h Mc^-1 J_h^T, the others (Z, damping too weak to matter) take d_Z = r_Z; and
   lambda_{i+1} moves with d so that the rows stay restored. The responses are linear: one
   constrained solve, for r_Z, and the coupled hinges' columns (friction_mobility) give those
   of r and d. */
static int friction_settled(dep_stepper *stepper, const double *q1, const double *qd1,
                            int round, const dep_measurement *pos)
{
    const dep_system *system = stepper->system;
    int nq = stepper->nq, nh = system->nh, nc = stepper->constraints->nc, nf;
    double h = stepper->h, V = stepper->profile.velocity, P = stepper->profile.position;
    double sum = 0.0, *G = stepper->newton, *slope = stepper->slope, *r = stepper->residual_end;
    double *d = stepper->dtau, *rZ = stepper->friction_now, *response = stepper->dqd;
    dep_friction_law(system, q1, qd1, stepper->law); /* leaves the rates in system->rates */
    for (int i = 0; i < nh; ++i) {
        r[i] = stepper->law[i] - stepper->friction_end[i];
    }
    if (round == 0) { /* every hinge's damping decides which are coupled */
        for (int i = 0; i < nh; ++i) {
            const dep_hinge_mechanics *hinge = &system->hinges[i];
            slope[i] = hinge->has_friction ? -dep_friction_slope(hinge, system->rates[i]) : 0.0;
        }
        friction_mobility(stepper, q1, pos, slope);
    } else { /* then only the coupled hinges' enters Newton's system */
        for (int k = 0; k < stepper->n_free; ++k) {
            int i = stepper->free_hinges[k];
            slope[i] = -dep_friction_slope(&system->hinges[i], system->rates[i]);
        }
    }
    nf = stepper->n_free;
    memcpy(rZ, r, (size_t)nh * sizeof *rZ);
    for (int k = 0; k < nf; ++k) {
        rZ[stepper->free_hinges[k]] = 0.0;
    }
    constrained_response(stepper, pos, rZ, response, stepper->lam_shift);
    for (int j = 0; j < nq; ++j) { /* r's move: r_Z's and the coupled hinges' columns */
        double total = response[j];
        for (int k = 0; k < nf; ++k) {
            total += r[stepper->free_hinges[k]] * stepper->mobile[(size_t)k * (size_t)nq + j];
        }
        double move = h * h * P * total / (stepper->tol * (1.0 + fabs(q1[j])));
        double rate = h * V * total / (stepper->tol * (1.0 + fabs(qd1[j])));
        sum += move * move + rate * rate;
    }
    if (sqrt(sum / (2 * nq)) <= FRICTION_LIMIT) {
        return 1;
    }
    if (nf > 0) { /* the coupled hinges' Newton system, with the others' effect on them */
        system->model->hinge_rates(q1, response, system->p, stepper->law_scratch);
        for (int a = 0; a < nf; ++a) {
            int i = stepper->free_hinges[a];
            d[a] = r[i] - h * V * slope[i] * stepper->law_scratch[i];
        }
        for (int b = 0; b < nf; ++b) { /* column b: h V C_F J_h,F Mc^-1 J_h^T e_b, then I */
            system->model->hinge_rates(q1, stepper->mobile + (size_t)b * (size_t)nq,
                                       system->p, stepper->law_scratch);
            for (int a = 0; a < nf; ++a) {
                int i = stepper->free_hinges[a];
                G[a * nf + b] = h * V * slope[i] * stepper->law_scratch[i] + (a == b ? 1.0 : 0.0);
            }
        }
        solve_small(nf, G, d);
    }
    for (int k = 0; k < nf; ++k) { /* the whole step d: d_F solved, d_Z = r_Z */
        rZ[stepper->free_hinges[k]] = d[k];
    }
    for (int i = 0; i < nh; ++i) {
        stepper->friction_end[i] += rZ[i];
    }
    for (int i = 0; i < nc; ++i) { /* lambda's move: r_Z's and d_F times the columns' */
        double shift = stepper->lam_shift[i];
        for (int k = 0; k < nf; ++k) {
            shift += d[k] * stepper->mobile_lam[(size_t)k * (size_t)stepper->capacity + i];
        }
        stepper->lam_pos[i] += shift;
    }
    return 0;
}

static int friction_failure(const dep_stepper *stepper, dep_failure *failure)
{
    const dep_system *system = stepper->system;
    int worst = 0;
    double off = -1.0;
    for (int i = 0; i < system->nh; ++i) {
        double d = fabs(stepper->law[i] - stepper->friction_end[i]);
        if (d > off) {
            off = d;
            worst = i;
        }
    }
    failure->stage = DEP_VELOCITY;
    failure->row = -1;
    failure->residual = off;
    failure->scale = 0.0;
    snprintf(failure->reason, sizeof failure->reason, "the friction torques at the step's end "
             "did not settle in %d trials (hinge %s: %.3g N m off its law)", FRICTION_ROUNDS,
             system->hinges[worst].name, off);
    snprintf(failure->hint, sizeof failure->hint, "the friction changes faster than the step "
             "can follow; a larger slip_rate on that hinge, or a tighter tol, may help");
    return DEP_PASS_FAILED;
}

/* ---- one step ---------------------------------------------------------------------------- */

/* The force at `state` when the acceleration pass of the step that ended there computed it
   (the same t, q and qd, no restart since: dep_run_restart forgets it), else NULL: the
   linearly implicit step's first stage then costs no evaluation. */
static const double *start_force(const dep_stepper *stepper, const dep_state *state)
{
    size_t size = (size_t)stepper->nq * sizeof(double);
    if (state->t != stepper->end_t || memcmp(state->q, stepper->end_state, size) != 0
        || memcmp(state->qd, stepper->end_state + stepper->nq, size) != 0) {
        return NULL;
    }
    return stepper->end_force;
}

/* Advance `state` by the profile's h (s) from the predicted lambda_{i+1}; DEP_PASS_FAILED
   when a pass does not converge. The outcome is valid until the next step. */
static int take_step(dep_stepper *stepper, const dep_state *state, const dep_profile *profile,
                     const double *lam_predicted, dep_outcome *outcome, dep_failure *failure)
{
    double h = profile->h;
    dep_constraints *cs = stepper->constraints;
    int nq = stepper->nq, nc = cs->nc, nd = stepper->system->nd, status;
    dep_state *new = &outcome->state;
    dep_measurement *final = NULL;
    stepper->start = state;
    stepper->h = h;
    stepper->profile = *profile;
    outcome->profile = *profile;
    stepper->t1 = state->t + h;
    stepper->base_valid = stepper->start_made = 0;
    stepper->integrations_this_step = 0;
    memcpy(stepper->y0, state->q, (size_t)nq * sizeof(double));
    memcpy(stepper->y0 + nq, state->qd, (size_t)nq * sizeof(double));
    memcpy(stepper->y0 + 2 * nq, state->work, (size_t)nd * sizeof(double));
    dep_stepper_derivative(stepper, state, stepper->k1);
    memcpy(new->lam, lam_predicted, (size_t)nc * sizeof(double));
    if (stepper->implicit) {
        if (!dep_implicit_prepare(&stepper->im, state->q, h)) {
            failure->stage = DEP_POSITION;
            failure->row = -1;
            failure->residual = failure->scale = 0.0;
            failure->hint[0] = '\0';
            snprintf(failure->reason, sizeof failure->reason, "the linearly implicit step's "
                     "matrix M + gamma h D + gamma^2 h^2 K is not positive definite");
            return DEP_PASS_FAILED;
        }
        dep_stepper_set_rhs(stepper, &stepper->profile, new->lam); /* lambda(t0): history */
        stepper->known_force = start_force(stepper, state);
        stage_force(stepper, state->t, stepper->y0, stepper->im.g0);
        stepper->known_force = NULL;
        unit_responses(stepper);
    }
    for (int round = 0;; ++round) { /* a round for each end value of the friction torques */
        dep_stepper_use_mobility(stepper, DEP_POSITION);
        dep_measurement *position[2] = {&stepper->slots[0], &stepper->slots[1]};
        status = dep_iterate_multipliers(&stepper->mp, DEP_POSITION, new->lam, nc,
                                         measure_position, stepper, h * h * profile->position,
                                         stepper->constraint_tol, position,
                                         &stepper->final_position, &outcome->reports[0],
                                         failure);
        if (status != DEP_OK) {
            dep_stepper_use_mobility(stepper, DEP_ACCELERATION);
            return status;
        }
        dep_stepper_use_mobility(stepper, DEP_VELOCITY);
        memcpy(new->q, stepper->final_position->rk.y1, (size_t)nq * sizeof(double));
        dep_cs_phi_t(cs, new->q, stepper->t1, stepper->phi_t1);
        memcpy(stepper->lam_pos, new->lam, (size_t)nc * sizeof(double));
        if (round == 0) {
            memcpy(stepper->lam_first, new->lam, (size_t)nc * sizeof(double));
        }

        dep_measurement *velocity[2] = {&stepper->slots[2], &stepper->slots[3]};
        status = dep_iterate_multipliers(&stepper->mp, DEP_VELOCITY, new->lam, nc,
                                         measure_velocity, stepper, h * profile->velocity,
                                         stepper->constraint_tol, velocity, &final,
                                         &outcome->reports[1], failure);
        dep_stepper_use_mobility(stepper, DEP_ACCELERATION);
        if (status != DEP_OK) {
            return status;
        }
        memcpy(new->qd, final->x, (size_t)nq * sizeof(double));
        if (!stepper->prescribed
            || friction_settled(stepper, new->q, new->qd, round, stepper->final_position)) {
            break;
        }
        if (round + 1 == FRICTION_ROUNDS) {
            return friction_failure(stepper, failure);
        }
        memcpy(new->lam, stepper->lam_pos, (size_t)nc * sizeof(double));
    }
    status = dep_acceleration(stepper, new->q, new->qd, stepper->t1, new->lam,
                              stepper->final_position->J, stepper->final_position->jacobian_id,
                              new->qdd, &outcome->reports[2], failure);
    if (status == DEP_OK && stepper->implicit) { /* f at the new state: the next start's */
        memcpy(stepper->end_force, stepper->accel.f, (size_t)nq * sizeof(double));
        memcpy(stepper->end_state, new->q, (size_t)nq * sizeof(double));
        memcpy(stepper->end_state + nq, new->qd, (size_t)nq * sizeof(double));
        stepper->end_t = stepper->t1;
    }
    if (status == DEP_OK && stepper->implicit && stepper->system->model->nkz > 0) {
        status = history_multipliers(stepper, new, failure); /* (nkz = 0: W = M, G = M^-1) */
    }
    if (status != DEP_OK) {
        return status;
    }
    new->t = stepper->t1;
    finish_step(stepper, state, outcome);
    return DEP_OK;
}

int dep_step(dep_stepper *stepper, const dep_state *state, const dep_profile *profile,
             const double *lam_predicted, const dep_profile *friction_profile,
             const double *friction_predicted, dep_outcome *outcome, dep_failure *failure)
{
    const dep_system *system = stepper->system;
    stepper->prescribed = friction_profile != NULL && !stepper->implicit;
    outcome->prescribed = stepper->prescribed;
    if (stepper->prescribed) {
        stepper->friction_profile = *friction_profile;
        outcome->friction_profile = *friction_profile;
        memcpy(stepper->friction_end, friction_predicted, (size_t)system->nh * sizeof(double));
    }
    int status = take_step(stepper, state, profile, lam_predicted, outcome, failure);
    if (status == DEP_OK && system->n_friction > 0) { /* the law at the new state */
        if (stepper->prescribed) {
            memcpy(outcome->friction, stepper->law, (size_t)system->nh * sizeof(double));
            outcome->friction_rate = stepper->friction_rate;
            outcome->friction_hinge = stepper->friction_hinge;
            outcome->friction_coupled = stepper->n_free;
        } else {
            dep_friction_law(system, outcome->state.q, outcome->state.qd, outcome->friction);
        }
    }
    stepper->prescribed = 0; /* other callers of the right side: the law */
    return status;
}
