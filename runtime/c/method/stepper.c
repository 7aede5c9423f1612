/* stepper.c: the stepper of the paper's method: its state, the step's start and outcome, and
 * the motion (1) with lambda(t) given, the right side every integration evaluates
 * (method.h). y = (q, qd, work): the dissipated work rides along as quadrature states.
 */
#include <math.h>
#include <string.h>

#include "method.h"

#define ROUNDOFF (16 * DEP_EPS)

/* The passes' iteration tolerance for an integration tolerance tol (constraint_tolerance). */
double dep_constraint_tolerance(double tol)
{
    return fmax(DEP_CONSTRAINT_FRACTION * tol, ROUNDOFF);
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
    to->qdd_weak = from->qdd_weak;
}

int dep_outcome_init(dep_outcome *outcome, int nq, int capacity, int nd, int nh,
                     dep_arena *arena)
{
    memset(outcome, 0, sizeof *outcome);
    outcome->data = dep_doubles(arena, DEP_INTERPOLANT_ROWS * (size_t)nq + DEP_INTERPOLANT_TAIL);
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
    stepper->floors = dep_doubles(arena, (size_t)ny);
    if (stepper->floors == NULL) {
        return DEP_MEMORY_ERROR;
    }
    for (int j = 0; j < ny; ++j) {
        stepper->floors[j] = j < 2 * nq ? system->scales[j % nq] : system->energy_scale;
    }
    if (dep_multipliers_init(&stepper->mp, &system->mass, cs, capacity, arena) != DEP_OK) {
        return DEP_MEMORY_ERROR;
    }
    stepper->mp.rank_drop = DEP_RANK_WEAK;
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
        size_t block = (size_t)nq * DEP_FILTER_DIRECT_ROWS;
        stepper->filter_block = dep_doubles(arena, 3 * block); /* x, two scratch */
        stepper->filter_S = dep_doubles(arena, DEP_FILTER_DIRECT_ROWS * DEP_FILTER_DIRECT_ROWS);
        stepper->filter_JGJ = dep_doubles(arena, DEP_FILTER_DIRECT_ROWS * DEP_FILTER_DIRECT_ROWS);
        stepper->filter_rhs = dep_doubles(arena, DEP_FILTER_DIRECT_ROWS);
        stepper->filter_J = dep_doubles(arena, DEP_JACOBIAN_SIZE(system->model));
        stepper->filter_GJ = dep_doubles(arena, (size_t)nq * DEP_FILTER_DIRECT_ROWS);
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
    if (cs->capacity > 0 && dep_forces_init(&stepper->forces, system, cs, arena) != DEP_OK) {
        return DEP_MEMORY_ERROR;
    }
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
   reference); a step that prescribes the constraint forces takes their end value from
   lam_end now. */
void dep_stepper_set_rhs(dep_stepper *stepper, const dep_profile *profile,
                         const double *lam_end)
{
    if (&stepper->profile != profile) {
        stepper->profile = *profile;
    }
    stepper->rhs_end = lam_end;
    if (stepper->by_force) {
        dep_forces_end(&stepper->forces, stepper->constraints, lam_end);
    }
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
    if (stepper->by_force) {
        dep_forces_value(&stepper->forces, cs, &s->mass, q, t, ++stepper->jacobian_ids,
                         stepper->jt_lam);
    } else {
        dep_profile_value(&stepper->profile, stepper->rhs_end, t, cs->nc, stepper->rhs_lam);
        dep_cs_jacobian_transpose_times(cs, q, t, stepper->rhs_lam, stepper->jt_lam);
    }
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
void dep_stepper_stage_force(void *context, double t, const double *y, double *g)
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

int dep_acceleration_weak(const dep_stepper *stepper)
{
    const dep_multipliers *mp = &stepper->mp;
    return stepper->constraints->nc > 0 && mp->schur_factored
           && mp->schur_min_pivot < DEP_WEAK_ACCELERATION;
}
