/* stepper.c: one step of the paper's method, lambda(t) prescribed over the step by its profile
 * (controller.c: the polynomial through the last accepted multipliers and the unknown end
 * value lambda_{i+1}) and three passes of the iteration (6) (docs/method.md, 2):
 *
 *   1. position:     re-integrate (DOPRI 5(4)) until v_pos(q_{i+1}) is small,
 *                    C = h^2 integral (1 - u) l(u) du (h^2/6 for a linear profile)
 *   2. velocity:     apply the frozen-Phi_q effect -h integral l(u) du M^-1 Phi_q^T d(lambda)
 *                    on qd_{i+1} until v_vel is small
 *   3. acceleration: qdd_{i+1} and lambda_{i+1} from (1) and (2c), C = 1
 *
 * y = (q, qd, work): the dissipated work rides along as quadrature states.
 */
#include <math.h>
#include <string.h>

#include "runtime.h"

#define CONSTRAINT_FRACTION 0.01
#define LINEAR_LIMIT 0.1 /* tolerances: larger position-pass moves integrate the step again */
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
    outcome->data = dep_doubles(arena, 12 * (size_t)nq + 1);
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
    double **rows[] = {&stepper->rhs_lam, &stepper->base_lam, &stepper->phi_t1,
                       &stepper->lam_pos};
    for (size_t i = 0; i < sizeof rows / sizeof *rows; ++i) {
        *rows[i] = dep_doubles(arena, (size_t)capacity);
    }
    stepper->force = dep_doubles(arena, (size_t)nq);
    stepper->base_J = dep_doubles(arena, (size_t)capacity * (size_t)nq);
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
    stepper->jt_lam = dep_doubles(arena, (size_t)nq);
    stepper->q1 = dep_doubles(arena, (size_t)nq);
    stepper->restart_J = dep_doubles(arena, (size_t)capacity * (size_t)nq);
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
    dep_profile_value(&stepper->profile, stepper->rhs_end, t, cs->nc, stepper->rhs_lam);
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

/* One DOPRI step with lambda_{i+1} = lam1 into the stepper's base, and Phi_q at its end. */
static void integrate(dep_stepper *stepper, const double *lam1)
{
    int nc = stepper->constraints->nc;
    const dep_state *s = stepper->start;
    stepper->integrations_this_step++;
    stepper->integrations++;
    dep_stepper_set_rhs(stepper, &stepper->profile, lam1);
    dep_dopri_step(&stepper->base, dep_stepper_rhs, stepper, s->t, stepper->y0, stepper->k1,
                   stepper->h, stepper->scratch);
    memcpy(stepper->base_lam, lam1, (size_t)nc * sizeof *lam1);
    dep_cs_jacobian(stepper->constraints, stepper->base.y1, stepper->t1, stepper->base_J);
    stepper->base_valid = 1;
}

static void copy_base(const dep_stepper *stepper, dep_rk_step *to)
{
    size_t ny = (size_t)stepper->ny;
    to->t0 = stepper->base.t0;
    to->h = stepper->base.h;
    to->y0 = stepper->base.y0;
    memcpy(to->y1, stepper->base.y1, ny * sizeof(double));
    memcpy(to->error, stepper->base.error, ny * sizeof(double));
    memcpy(to->K, stepper->base.K, 7 * ny * sizeof(double));
    memcpy(to->mode, stepper->base.mode, ny * sizeof(double));
    to->stiffness = stepper->base.stiffness;
}

/* The base trajectory's end moved to lambda_{i+1} = lam1 by the frozen-Phi_q effect of the
   change d = lam1 - base_lam: q by -h^2 position M^-1 Phi_q^T d, qd by -h velocity
   M^-1 Phi_q^T d; 0 (nothing done) when those moves exceed LINEAR_LIMIT tolerances, where the
   part of the true response the linearisation misses (tangential, a fraction of the move)
   could cost accuracy: the step is integrated again instead. */
static int correct_base(dep_stepper *stepper, const double *lam1, dep_rk_step *out)
{
    int nq = stepper->nq, nc = stepper->constraints->nc;
    double h = stepper->h, sum = 0.0;
    for (int i = 0; i < nc; ++i) {
        stepper->rhs_lam[i] = lam1[i] - stepper->base_lam[i];
    }
    dep_cs_transpose_times(stepper->constraints, stepper->base_J, stepper->rhs_lam, stepper->jt_lam);
    dep_mass_solve(&stepper->system->mass, stepper->jt_lam, stepper->force);
    for (int j = 0; j < nq; ++j) { /* the moves of q and qd in tolerance units */
        double move = h * h * stepper->profile.position * stepper->force[j];
        double rate = h * stepper->profile.velocity * stepper->force[j];
        double scale = stepper->tol * (1.0 + fabs(stepper->base.y1[j]));
        double rate_scale = stepper->tol * (1.0 + fabs(stepper->base.y1[nq + j]));
        sum += (move / scale) * (move / scale) + (rate / rate_scale) * (rate / rate_scale);
    }
    if (!(sqrt(sum / (2 * nq)) <= LINEAR_LIMIT)) {
        return 0;
    }
    copy_base(stepper, out);
    for (int j = 0; j < nq; ++j) {
        out->y1[j] -= h * h * stepper->profile.position * stepper->force[j];
        out->y1[nq + j] -= h * stepper->profile.velocity * stepper->force[j];
    }
    return 1;
}

/* The position pass's measurement for a trial lambda_{i+1}: the step's end by correcting the
   last integration when the change is small, else by integrating again. */
static void measure_position(void *context, const double *lam1, dep_measurement *out)
{
    dep_stepper *stepper = context;
    dep_constraints *cs = stepper->constraints;
    const double *q1 = out->rk.y1;
    if (stepper->base_valid && correct_base(stepper, lam1, &out->rk)) {
        dep_cs_jacobian(cs, q1, stepper->t1, out->J_own);
    } else {
        integrate(stepper, lam1);
        copy_base(stepper, &out->rk);
        memcpy(out->J_own, stepper->base_J,
               (size_t)cs->nc * (size_t)stepper->nq * sizeof *out->J_own);
    }
    dep_cs_phi(cs, q1, stepper->t1, out->v);
    for (int i = 0; i < cs->nc; ++i) {
        out->v[i] = -out->v[i];
    }
    out->J = out->J_own;
    out->jacobian_id = ++stepper->jacobian_ids;
    out->scale = dep_max_abs(q1, stepper->nq);
}

/* qd_{i+1} = qd of the position pass's trajectory
              - h velocity M^-1 J1^T (lambda - lambda_pos). */
static void measure_velocity(void *context, const double *lam1, dep_measurement *out)
{
    dep_stepper *stepper = context;
    const dep_measurement *pos = stepper->final_position;
    int nq = stepper->nq, nc = stepper->constraints->nc;
    for (int i = 0; i < nc; ++i) {
        stepper->rhs_lam[i] = lam1[i] - stepper->lam_pos[i];
    }
    dep_cs_transpose_times(stepper->constraints, pos->J, stepper->rhs_lam, stepper->jt_lam);
    dep_mass_solve(&stepper->system->mass, stepper->jt_lam, stepper->force);
    for (int j = 0; j < nq; ++j) {
        out->x[j] = pos->rk.y1[nq + j] - stepper->h * stepper->profile.velocity * stepper->force[j];
    }
    dep_cs_times(stepper->constraints, pos->J, out->x, out->v);
    for (int i = 0; i < nc; ++i) {
        out->v[i] = -out->v[i] - stepper->phi_t1[i];
    }
    out->J = pos->J;
    out->jacobian_id = pos->jacobian_id;
    out->scale = dep_cs_product_scale(stepper->constraints, pos->J, out->x);
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
    outcome->J1_id = stepper->final_position->jacobian_id;
    outcome->lam_position = stepper->lam_pos;
    outcome->integrations = stepper->integrations_this_step;
}

/* Advance `state` by the profile's h (s) from the predicted lambda_{i+1}; DEP_PASS_FAILED
   when a pass does not converge. The outcome is valid until the next step. */
int dep_step(dep_stepper *stepper, const dep_state *state, const dep_profile *profile,
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
    stepper->base_valid = 0;
    stepper->integrations_this_step = 0;
    memcpy(stepper->y0, state->q, (size_t)nq * sizeof(double));
    memcpy(stepper->y0 + nq, state->qd, (size_t)nq * sizeof(double));
    memcpy(stepper->y0 + 2 * nq, state->work, (size_t)nd * sizeof(double));
    dep_stepper_derivative(stepper, state, stepper->k1);
    memcpy(new->lam, lam_predicted, (size_t)nc * sizeof(double));

    dep_measurement *position[2] = {&stepper->slots[0], &stepper->slots[1]};
    status = dep_iterate_multipliers(&stepper->mp, DEP_POSITION, new->lam, nc, measure_position,
                                     stepper, h * h * profile->position,
                                     stepper->constraint_tol, position,
                                     &stepper->final_position, &outcome->reports[0], failure);
    if (status != DEP_OK) {
        return status;
    }
    memcpy(new->q, stepper->final_position->rk.y1, (size_t)nq * sizeof(double));
    dep_cs_phi_t(cs, new->q, stepper->t1, stepper->phi_t1);
    memcpy(stepper->lam_pos, new->lam, (size_t)nc * sizeof(double));

    dep_measurement *velocity[2] = {&stepper->slots[2], &stepper->slots[3]};
    status = dep_iterate_multipliers(&stepper->mp, DEP_VELOCITY, new->lam, nc, measure_velocity,
                                     stepper, h * profile->velocity, stepper->constraint_tol,
                                     velocity, &final,
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
