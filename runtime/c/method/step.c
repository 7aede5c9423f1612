/* step.c: one step of the paper's method, lambda(t) prescribed over the step by its profile
 * (profile.c: the polynomial through the last accepted multipliers and the unknown end
 * value lambda_{i+1}) and three passes of the iteration (6) (docs/method.md, 2):
 *
 *   1. position:     re-integrate until v_pos(q_{i+1}) is small,
 *                    C = h^2 integral (1 - u) l(u) du (h^2/6 for a linear profile)
 *   2. velocity:     apply the frozen-Phi_q effect of d(lambda) on qd_{i+1} until v_vel is
 *                    small
 *   3. acceleration: qdd_{i+1} and lambda_{i+1} from (1) and (2c), C = 1
 *
 * The ODE method is DOPRI 5(4) until, in a model with beams, a stiff mode holds its step at
 * the stability bound (the run switches); then the linearly implicit ROS34PW2
 * (rosenbrock.c). A change d(lambda) of the end value moves the step end
 * by the method's response to adding (Phi_q^T d(lambda)) l(u) to the constraint forces, Phi_q
 * frozen: for DOPRI -h^2 position M^-1 Phi_q^T d(lambda) on q and -h velocity M^-1 Phi_q^T
 * d(lambda) on qd; for the Rosenbrock step the same through its stages, in which the stiff
 * elastic forces answer at once (responses.c). The passes' S = Phi_q G Phi_q^T take G from
 * that response (method.h).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "method.h"

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
#define LINEAR_MOST 10.0
#define LINEAR_FAR 100.0
#define MEASURED_MISS 0.01

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
        dep_rosenbrock_step(&stepper->im, &stepper->base, dep_stepper_stage_force, stepper, s->t,
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
    if (stepper->by_force) {
        /* the force's end value Phi_q(q_e)^T lambda_{i+1} changes at the end alone; the
           friction's torques turn with J_h over the step as with the multipliers */
        memset(stepper->rhs_lam, 0, (size_t)nc * sizeof *stepper->rhs_lam);
        moved_force(stepper, stepper->start_J, stepper->start_Jh, f0);
        moved_force(stepper, stepper->base_J, stepper->base_Jh, f1);
        for (int i = 0; i < nc; ++i) {
            stepper->rhs_lam[i] = lam1[i] - stepper->base_lam[i];
        }
        dep_cs_transpose_times(stepper->constraints, stepper->forces.end_J, stepper->rhs_lam,
                               stepper->column);
        dep_mass_solve(&stepper->system->mass, stepper->column, stepper->dq);
        for (int j = 0; j < nq; ++j) {
            double end = stepper->dq[j]; /* M^-1 Phi_q(q_e)^T d(lambda) */
            stepper->dq[j] = -h * h * (p0 * f0[j] + p1 * f1[j] + profile->position * end);
            stepper->dqd[j] = -h * (v0 * f0[j] + v1 * f1[j] + profile->velocity * end);
            f1[j] += end; /* the end's force, for linear_miss */
        }
        return;
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
        double a = mq[j] / (stepper->tol * (stepper->floors[j] + fabs(y1[j])));
        double b = mv[j] / (stepper->tol * (stepper->floors[nq + j] + fabs(y1[nq + j])));
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
    if (stepper->by_force) {
        /* each stage projects the force at its own state, which turns with the weak
           directions near a singular position faster than a linear response follows */
        return 0;
    }
    if (stepper->prescribed) {
        const dep_system *system = stepper->system;
        for (int i = 0; i < system->nh; ++i) {
            stepper->residual[i] = stepper->friction_end[i] - stepper->friction_base[i];
        }
    }
    if (rosenbrock) {
        dep_stepper_lam_column(stepper, stepper->base_J, lam1, stepper->base_lam);
        dep_stepper_respond(stepper, stepper->column);
    } else {
        respond_along(stepper, lam1);
    }
    for (int j = 0; j < nq; ++j) { /* the moves of q and qd in tolerance units */
        double move = stepper->dq[j], rate = stepper->dqd[j];
        double scale = stepper->tol * (stepper->floors[j] + fabs(stepper->base.y1[j]));
        double rate_scale = rosenbrock ? scale / stepper->h
                                       : stepper->tol * (stepper->floors[nq + j]
                                                         + fabs(stepper->base.y1[nq + j]));
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
static void measure_position(void *context, const double *lam1, int sized,
                             dep_measurement *out)
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
    dep_cs_sizes(cs, out->J, q1, out->size);
    if (sized) {
        dep_pass_magnitude(&stepper->mp, out->J, cs->nc, lam1,
                           stepper->h * stepper->h * stepper->profile.position, q1, NULL,
                           out->magnitude);
    }
}

/* qd_{i+1} = qd of the position pass's trajectory plus the response of qd to
   lambda - lambda_pos, Phi_q frozen at its end (DOPRI: -h velocity M^-1 J1^T (lambda -
   lambda_pos)). */
static void measure_velocity(void *context, const double *lam1, int sized,
                             dep_measurement *out)
{
    dep_stepper *stepper = context;
    const dep_measurement *pos = stepper->final_position;
    int nq = stepper->nq, nc = stepper->constraints->nc;
    dep_stepper_respond_to(stepper, pos->J, lam1, stepper->lam_pos);
    for (int j = 0; j < nq; ++j) {
        out->x[j] = pos->rk.y1[nq + j] + stepper->dqd[j];
    }
    dep_cs_times_sized(stepper->constraints, pos->J, out->x, out->v, out->size);
    for (int i = 0; i < nc; ++i) {
        out->v[i] = -out->v[i] - stepper->phi_t1[i];
    }
    out->J = pos->J;
    out->jacobian_id = pos->jacobian_id;
    if (sized) {
        dep_pass_magnitude(&stepper->mp, out->J, nc, lam1, stepper->h * stepper->profile.velocity,
                           out->x, stepper->phi_t1, out->magnitude);
    }
}

/* The new state's work and the step's interpolant. */
static void finish_step(dep_stepper *stepper, const dep_state *state, dep_outcome *outcome)
{
    int nq = stepper->nq, nd = stepper->system->nd;
    dep_state *new = &outcome->state;
    dep_rk_step *rk = &stepper->final_position->rk;
    memcpy(new->work, rk->y1 + 2 * nq, (size_t)nd * sizeof(double));
    if (rk->method == DEP_ROSENBROCK) { /* the work rates at the end, for the dense output */
        dep_system_dissipation(stepper->system, new->q, new->qd, new->t,
                               rk->K + 6 * (size_t)rk->n + 2 * nq);
    }
    dep_interpolant_data(new->t - state->t, state->q, state->qd, state->qdd, state->qdd_weak,
                         new->q, new->qd, new->qdd, new->qdd_weak, nq, outcome->data);
    outcome->rk = rk;
    outcome->J1 = stepper->final_position->J;
    outcome->J1_id = stepper->final_position->jacobian_id;
    outcome->lam_position = stepper->lam_pos;
    outcome->integrations = stepper->integrations_this_step;
}

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
            memset(failure, 0, sizeof *failure);
            failure->stage = DEP_POSITION;
            failure->row = -1;
            snprintf(failure->reason, sizeof failure->reason, "the linearly implicit step's "
                     "matrix M + gamma h D + gamma^2 h^2 K is not positive definite");
            return DEP_PASS_FAILED;
        }
        dep_stepper_set_rhs(stepper, &stepper->profile, new->lam); /* lambda(t0): history */
        stepper->known_force = start_force(stepper, state);
        dep_stepper_stage_force(stepper, state->t, stepper->y0, stepper->im.g0);
        stepper->known_force = NULL;
        dep_stepper_unit_responses(stepper);
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
            || dep_stepper_friction_settled(stepper, new->q, new->qd, round,
                                            stepper->final_position)) {
            break;
        }
        if (round + 1 == DEP_FRICTION_ROUNDS) {
            return dep_stepper_friction_failure(stepper, failure);
        }
        memcpy(new->lam, stepper->lam_pos, (size_t)nc * sizeof(double));
    }
    status = dep_acceleration(stepper, new->q, new->qd, stepper->t1, new->lam,
                              stepper->final_position->J, stepper->final_position->jacobian_id,
                              new->qdd, &outcome->reports[2], failure);
    new->qdd_weak = status == DEP_OK && dep_acceleration_weak(stepper);
    if (status == DEP_OK && stepper->implicit) { /* f at the new state: the next start's */
        memcpy(stepper->end_force, stepper->accel.f, (size_t)nq * sizeof(double));
        memcpy(stepper->end_state, new->q, (size_t)nq * sizeof(double));
        memcpy(stepper->end_state + nq, new->qd, (size_t)nq * sizeof(double));
        stepper->end_t = stepper->t1;
    }
    if (status == DEP_OK && stepper->implicit && stepper->system->model->nkz > 0) {
        /* (nkz = 0: W = M, G = M^-1) */
        status = dep_stepper_history_multipliers(stepper, new, failure);
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
