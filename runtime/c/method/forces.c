/* forces.c: the constraint forces' profile (docs/method.md, 6a, singular positions).
 *
 * Near a singular position the multipliers grow as one over the distance to it (a chain of
 * parallelograms lying flat: its couplers' forces along the pivots' line), while the force
 * they exert, F = Phi_q^T lambda, stays smooth: a polynomial in time follows F where it cannot
 * follow lambda's pole. A step may therefore prescribe F instead of lambda: over the step F is
 * the polynomial through the accepted states' forces F_k = Phi_q(q_k)^T lambda_k and the end
 * value Phi_q(q_e)^T lambda_{i+1}, Phi_q taken at the step's predicted end q_e, and at every
 * evaluation it is projected onto the rows' normal space at the stage's own q,
 *
 *     F(q, t) = Phi_q^T S^-1 Phi_q M^-1 F(t),   S = Phi_q M^-1 Phi_q^T at q,
 *
 * so that, as the multipliers' force does, it acts normal to the constraints (no work along
 * the motion) whatever the profile's interpolation error. The unknown of the passes stays
 * lambda_{i+1}: its force enters the profile through the fixed Phi_q(q_e), a change of it
 * moves the step's end by -h^2 P M^-1 Phi_q(q_e)^T d(lambda) and -h V M^-1 Phi_q(q_e)^T
 * d(lambda). Each evaluation forms and factorises S at its stage (the stage's own factor,
 * apart from the passes'), so the run takes such steps only where the multipliers' profile
 * would miss more (run/steps.c).
 */
#include <math.h>
#include <string.h>

#include "method.h"

int dep_forces_init(dep_forces *forces, const dep_system *system, dep_constraints *cs,
                    dep_arena *arena)
{
    int nq = system->nq, capacity = cs->capacity;
    memset(forces, 0, sizeof *forces);
    if (dep_multipliers_init(&forces->stage, &system->mass, cs, capacity, arena) != DEP_OK) {
        return DEP_MEMORY_ERROR;
    }
    forces->stage.rank_drop = DEP_RANK_WEAK;
    forces->end = dep_doubles(arena, (size_t)nq);
    forces->end_J = dep_doubles(arena, DEP_JACOBIAN_SIZE(system->model));
    forces->stage_J = dep_doubles(arena, DEP_JACOBIAN_SIZE(system->model));
    forces->predicted = dep_doubles(arena, (size_t)nq);
    forces->moved = dep_doubles(arena, (size_t)nq);
    forces->rows = dep_doubles(arena, (size_t)capacity + 1);
    return arena->failed ? DEP_MEMORY_ERROR : DEP_OK;
}

/* Phi_q at the step's predicted end, q + h qd + h^2/2 qdd + h^3/6 qddd (qddd from the
   accepted state before, when there is one: prior_qdd, prior_h > 0), for the whole step: its
   error, O(h^4) (O(h^3) after a start or an event), turns the end force by that much. */
void dep_forces_begin(dep_forces *forces, dep_constraints *cs, const dep_state *start,
                      double h, const double *prior_qdd, double prior_h)
{
    int nq = cs->nq;
    double *q = forces->predicted;
    for (int j = 0; j < nq; ++j) {
        double jerk = prior_qdd != NULL && prior_h > 0.0
                      ? (start->qdd[j] - prior_qdd[j]) / prior_h : 0.0;
        q[j] = start->q[j] + h * (start->qd[j] + h * (0.5 * start->qdd[j] + h / 6.0 * jerk));
    }
    dep_cs_jacobian(cs, q, start->t + h, forces->end_J);
}

/* The multipliers whose force at q_e is closest to `force` (nq) in M^-1's metric, the least
   norm ones, S^-1 Phi_q M^-1 force at q_e, into lam: the step's first lambda_{i+1} from the
   forces' extrapolation, where the multipliers' own misses their pole. */
void dep_forces_multipliers(dep_forces *forces, dep_constraints *cs, const dep_mass *mass,
                            const double *force, long long jacobian_id, double *lam)
{
    int nc = cs->nc;
    long long iterations = 0;
    dep_multipliers *mp = &forces->stage;
    dep_mass_solve(mass, force, forces->moved);
    dep_cs_times(cs, forces->end_J, forces->moved, lam);
    dep_schur_form(mp, forces->end_J, jacobian_id, nc, 0.0);
    dep_schur_nulls(mp, nc);
    dep_schur_deflate(mp, nc, lam);
    if (dep_schur_solve_formed(mp, forces->end_J, nc, lam, lam, &iterations)) {
        dep_schur_deflate(mp, nc, lam);
    }
}

/* The profile's end value Phi_q(q_e)^T lam_end. */
void dep_forces_end(dep_forces *forces, const dep_constraints *cs, const double *lam_end)
{
    dep_cs_transpose_times(cs, forces->end_J, lam_end, forces->end);
}

/* The prescribed force at (q, t), projected onto the normal space of the rows there, into out
   (nq); the rows' S at q is factorised with the passes' rank tolerance (a dropped row's and a
   weak direction's share deflated: the least-squares force). */
void dep_forces_value(dep_forces *forces, dep_constraints *cs, const dep_mass *mass,
                      const double *q, double t, long long jacobian_id, double *out)
{
    int nc = cs->nc, nq = cs->nq;
    long long iterations = 0;
    dep_multipliers *mp = &forces->stage;
    double *lam = forces->rows, *moved = forces->moved;
    dep_profile_value(&forces->profile, forces->end, t, nq, out);
    if (nc == 0) {
        return;
    }
    dep_cs_jacobian(cs, q, t, forces->stage_J);
    dep_mass_solve(mass, out, moved);
    dep_cs_times(cs, forces->stage_J, moved, lam);
    dep_schur_form(mp, forces->stage_J, jacobian_id, nc, 0.0);
    dep_schur_nulls(mp, nc);
    dep_schur_deflate(mp, nc, lam);
    if (!dep_schur_solve_formed(mp, forces->stage_J, nc, lam, lam, &iterations)) {
        return; /* (S not solved: the force as prescribed) */
    }
    dep_schur_deflate(mp, nc, lam);
    dep_cs_transpose_times(cs, forces->stage_J, lam, out);
}
