/* stepper.c: one step of the paper's method, lambda(t) linear over the step and three passes
 * of the iteration (6) (docs/method.md, 2):
 *
 *   1. position:     re-integrate (DOPRI 5(4)) until v_pos(q_{i+1}) is small, C = h^2/6
 *   2. velocity:     apply the frozen-Phi_q effect -(h/2) M^-1 Phi_q^T d(lambda) on qd_{i+1}
 *                    until v_vel is small, C = h/2
 *   3. acceleration: qdd_{i+1} and lambda_{i+1} from (1) and (2c), C = 1
 *
 * y = (q, qd, work): the dissipated work rides along as quadrature states.
 */
#include <math.h>
#include <string.h>

#include "runtime.h"

#define CONSTRAINT_FRACTION 0.01
#define ROUNDOFF (16 * DEP_EPS)

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

int dep_outcome_init(dep_outcome *outcome, int nq, int capacity, int nd, dep_arena *arena)
{
    memset(outcome, 0, sizeof *outcome);
    outcome->data = dep_doubles(arena, 10 * (size_t)nq);
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
    if (dep_multipliers_init(&stepper->mp, &system->mass, nq, capacity, arena) != DEP_OK) {
        return DEP_MEMORY_ERROR;
    }
    for (int k = 0; k < 6; ++k) { /* position (own J, trajectory), velocity, acceleration */
        if (dep_measurement_init(&stepper->slots[k], nq, capacity, k < 2 ? ny : 0, k < 2,
                                 arena) != DEP_OK) {
            return DEP_MEMORY_ERROR;
        }
    }
    double **vectors[] = {&stepper->y0, &stepper->k1, &stepper->scratch};
    for (size_t i = 0; i < sizeof vectors / sizeof *vectors; ++i) {
        *vectors[i] = dep_doubles(arena, (size_t)ny);
    }
    double **rows[] = {&stepper->slope, &stepper->lam0, &stepper->rhs_lam, &stepper->memo_lam,
                       &stepper->phi_t1, &stepper->lam_pos};
    for (size_t i = 0; i < sizeof rows / sizeof *rows; ++i) {
        *rows[i] = dep_doubles(arena, (size_t)capacity);
    }
    stepper->force = dep_doubles(arena, (size_t)nq);
    stepper->accel.system = system;
    stepper->accel.cs = cs;
    stepper->accel.mp = &stepper->mp;
    stepper->accel.slots[0] = &stepper->slots[4];
    stepper->accel.slots[1] = &stepper->slots[5];
    stepper->accel.f = dep_doubles(arena, (size_t)nq);
    stepper->accel.jt = dep_doubles(arena, (size_t)nq);
    stepper->accel.solved = dep_doubles(arena, (size_t)nq);
    stepper->accel.gamma = dep_doubles(arena, (size_t)capacity);
    stepper->jt_lam = dep_doubles(arena, (size_t)nq);
    stepper->q1 = dep_doubles(arena, (size_t)nq);
    stepper->restart_J = dep_doubles(arena, (size_t)capacity * (size_t)nq);
    return arena->failed ? DEP_MEMORY_ERROR : DEP_OK;
}

/* ---- the motion (1) with lambda(t) given -------------------------------------------------- */

/* lambda(t) = lam0 + (t - t0) (lam1 - lam0) / h for the next rhs calls. */
void dep_stepper_set_rhs(dep_stepper *stepper, double t0, double h, const double *lam0,
                         const double *lam1)
{
    int nc = stepper->constraints->nc;
    stepper->rhs_t0 = t0;
    for (int i = 0; i < nc; ++i) {
        stepper->lam0[i] = lam0[i];
        stepper->slope[i] = (lam1[i] - lam0[i]) / h;
    }
}

static void solve_motion(dep_stepper *stepper, const double *q, const double *qd, double t,
                         const double *jt_lam, double *qdd)
{
    const dep_system *s = stepper->system;
    dep_system_force(s, q, qd, t, stepper->force);
    for (int j = 0; j < stepper->nq; ++j) {
        stepper->force[j] -= jt_lam[j];
    }
    dep_mass_solve(&s->mass, stepper->force, qdd);
}

static void dissipation(const dep_system *s, const double *q, const double *qd, double t,
                        double *out)
{
    if (s->nd > 0) {
        dep_system_dissipation(s, q, qd, t, out);
    }
}

void dep_stepper_rhs(void *context, double t, const double *y, double *dy)
{
    dep_stepper *stepper = context;
    dep_constraints *cs = stepper->constraints;
    int nq = stepper->nq;
    const double *q = y, *qd = y + nq;
    stepper->rhs_evaluations++;
    for (int i = 0; i < cs->nc; ++i) {
        stepper->rhs_lam[i] = stepper->lam0[i] + (t - stepper->rhs_t0) * stepper->slope[i];
    }
    dep_cs_jacobian_transpose_times(cs, q, t, stepper->rhs_lam, stepper->jt_lam);
    memcpy(dy, qd, (size_t)nq * sizeof *dy);
    solve_motion(stepper, q, qd, t, stepper->jt_lam, dy + nq);
    dissipation(stepper->system, q, qd, t, dy + 2 * nq);
}

/* dy/dt at an accepted state: the first RK stage (qdd is known). */
void dep_stepper_derivative(dep_stepper *stepper, const dep_state *state, double *dy)
{
    int nq = stepper->nq;
    memcpy(dy, state->qd, (size_t)nq * sizeof *dy);
    memcpy(dy + nq, state->qdd, (size_t)nq * sizeof *dy);
    dissipation(stepper->system, state->q, state->qd, state->t, dy + 2 * nq);
}

static void transpose_times(const double *J, int nc, int nq, const double *x, double *out)
{
    for (int j = 0; j < nq; ++j) {
        double sum = 0.0;
        for (int i = 0; i < nc; ++i) {
            sum += J[i * nq + j] * x[i];
        }
        out[j] = sum;
    }
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

/* ---- one step ---------------------------------------------------------------------------- */

/* The trajectory for a trial lambda_{i+1}: one DOPRI step into the slot, unless the same
   lambda was integrated last. */
static void integrate(dep_stepper *stepper, const double *lam1, dep_measurement *out)
{
    int nc = stepper->constraints->nc;
    const dep_state *s = stepper->start;
    if (stepper->memo_valid && memcmp(lam1, stepper->memo_lam, (size_t)nc * sizeof *lam1) == 0) {
        if (stepper->memo_rk != &out->rk) {
            const dep_rk_step *memo = stepper->memo_rk;
            size_t ny = (size_t)stepper->ny;
            out->rk.t0 = memo->t0;
            out->rk.h = memo->h;
            out->rk.y0 = memo->y0;
            memcpy(out->rk.y1, memo->y1, ny * sizeof(double));
            memcpy(out->rk.error, memo->error, ny * sizeof(double));
            memcpy(out->rk.K, memo->K, 7 * ny * sizeof(double));
        }
    } else {
        stepper->integrations_this_step++;
        stepper->integrations++;
        dep_stepper_set_rhs(stepper, s->t, stepper->h, s->lam, lam1);
        dep_dopri_step(&out->rk, dep_stepper_rhs, stepper, s->t, stepper->y0, stepper->k1,
                       stepper->h, stepper->scratch);
        memcpy(stepper->memo_lam, lam1, (size_t)nc * sizeof *lam1);
    }
    stepper->memo_valid = 1;
    stepper->memo_rk = &out->rk;
}

static void measure_position(void *context, const double *lam1, dep_measurement *out)
{
    dep_stepper *stepper = context;
    dep_constraints *cs = stepper->constraints;
    integrate(stepper, lam1, out);
    const double *q1 = out->rk.y1;
    dep_cs_phi(cs, q1, stepper->t1, out->v);
    for (int i = 0; i < cs->nc; ++i) {
        out->v[i] = -out->v[i];
    }
    dep_cs_jacobian(cs, q1, stepper->t1, out->J_own);
    out->J = out->J_own;
    out->jacobian_id = ++stepper->jacobian_ids;
    out->scale = dep_max_abs(q1, stepper->nq);
}

/* qd_{i+1} = qd of the position pass's trajectory - (h/2) M^-1 J1^T (lambda - lambda_pos). */
static void measure_velocity(void *context, const double *lam1, dep_measurement *out)
{
    dep_stepper *stepper = context;
    const dep_measurement *pos = stepper->final_position;
    int nq = stepper->nq, nc = stepper->constraints->nc;
    for (int i = 0; i < nc; ++i) {
        stepper->rhs_lam[i] = lam1[i] - stepper->lam_pos[i];
    }
    transpose_times(pos->J, nc, nq, stepper->rhs_lam, stepper->jt_lam);
    dep_mass_solve(&stepper->system->mass, stepper->jt_lam, stepper->force);
    for (int j = 0; j < nq; ++j) {
        out->x[j] = pos->rk.y1[nq + j] - (stepper->h / 2) * stepper->force[j];
    }
    for (int i = 0; i < nc; ++i) {
        double sum = 0.0;
        for (int j = 0; j < nq; ++j) {
            sum += pos->J[i * nq + j] * out->x[j];
        }
        out->v[i] = -sum - stepper->phi_t1[i];
    }
    out->J = pos->J;
    out->jacobian_id = pos->jacobian_id;
    out->scale = dep_product_scale(pos->J, nc, nq, out->x);
}

/* The new state's work and the step's interpolant. */
static void finish_step(dep_stepper *stepper, const dep_state *state, dep_outcome *outcome)
{
    int nq = stepper->nq, nd = stepper->system->nd;
    dep_state *new = &outcome->state;
    const dep_rk_step *rk = &stepper->final_position->rk;
    memcpy(new->work, rk->y1 + 2 * nq, (size_t)nd * sizeof(double));
    dep_interpolant_data(new->t - state->t, state->q, state->qd, state->qdd, new->q, new->qd,
                         new->qdd, nq, outcome->data);
    outcome->rk = rk;
    outcome->J1 = stepper->final_position->J;
    outcome->integrations = stepper->integrations_this_step;
}

/* Advance `state` by h (s) from the predicted lambda_{i+1}; DEP_PASS_FAILED when a pass
   does not converge. The outcome is valid until the next step. */
int dep_step(dep_stepper *stepper, const dep_state *state, double h, const double *lam_predicted,
             dep_outcome *outcome, dep_failure *failure)
{
    dep_constraints *cs = stepper->constraints;
    int nq = stepper->nq, nc = cs->nc, nd = stepper->system->nd, status;
    dep_state *new = &outcome->state;
    dep_measurement *final = NULL;
    stepper->start = state;
    stepper->h = h;
    stepper->t1 = state->t + h;
    stepper->memo_valid = 0;
    stepper->integrations_this_step = 0;
    memcpy(stepper->y0, state->q, (size_t)nq * sizeof(double));
    memcpy(stepper->y0 + nq, state->qd, (size_t)nq * sizeof(double));
    memcpy(stepper->y0 + 2 * nq, state->work, (size_t)nd * sizeof(double));
    dep_stepper_derivative(stepper, state, stepper->k1);
    memcpy(new->lam, lam_predicted, (size_t)nc * sizeof(double));

    dep_measurement *position[2] = {&stepper->slots[0], &stepper->slots[1]};
    status = dep_iterate_multipliers(&stepper->mp, DEP_POSITION, new->lam, nc, measure_position,
                                     stepper, h * h / 6.0, stepper->constraint_tol, position,
                                     &stepper->final_position, &outcome->reports[0], failure);
    if (status != DEP_OK) {
        return status;
    }
    memcpy(new->q, stepper->final_position->rk.y1, (size_t)nq * sizeof(double));
    dep_cs_phi_t(cs, new->q, stepper->t1, stepper->phi_t1);
    memcpy(stepper->lam_pos, new->lam, (size_t)nc * sizeof(double));

    dep_measurement *velocity[2] = {&stepper->slots[2], &stepper->slots[3]};
    status = dep_iterate_multipliers(&stepper->mp, DEP_VELOCITY, new->lam, nc, measure_velocity,
                                     stepper, h / 2.0, stepper->constraint_tol, velocity, &final,
                                     &outcome->reports[1], failure);
    if (status != DEP_OK) {
        return status;
    }
    memcpy(new->qd, final->x, (size_t)nq * sizeof(double));
    status = dep_acceleration(stepper, new->q, new->qd, stepper->t1, new->lam,
                              stepper->final_position->J, stepper->final_position->jacobian_id,
                              new->qdd, &outcome->reports[2], failure);
    if (status != DEP_OK) {
        return status;
    }
    new->t = stepper->t1;
    finish_step(stepper, state, outcome);
    return DEP_OK;
}
