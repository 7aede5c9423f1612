/* friction.c: hinge friction prescribed over a DOPRI step like the multipliers (docs/method.md,
 * 9): its profile through the accepted friction torques and an end value, iterated until the
 * friction law at the step's end gives that end value back; the hinges whose damping matters
 * at this step are solved together by Newton's method, the others take their law's value
 * (method.h).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "method.h"

/* The friction torques' end value is settled when the law at the step's end gives it back to
   within this many tolerances of its effect on the end state (as the passes' constraint
   errors); DEP_FRICTION_ROUNDS end values are tried before the step fails. */
#define FRICTION_LIMIT DEP_CONSTRAINT_FRACTION
/* A hinge whose friction's damping, times h, stays below this on its own inertia (an upper
   bound of its effect on the mechanism) takes its law's value without Newton coupling. */
#define FRICTION_WEAK 1e-3

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
        dep_hinge_times(system, stepper->Jh, stepper->force, stepper->friction_now);
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
        dep_hinge_times(system, stepper->Jh, out, stepper->friction_now);
        if (slope[i] * stepper->friction_now[i] > stepper->friction_rate) {
            stepper->friction_rate = slope[i] * stepper->friction_now[i];
            stepper->friction_hinge = i;
        }
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
   of r and d. Newton's matrix keeps round 0's J_h (the state moves by the rounds' small
   corrections); the law itself is evaluated at each round's state. */
int dep_stepper_friction_settled(dep_stepper *stepper, const double *q1, const double *qd1,
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
        double move = h * h * P * total / (stepper->tol * (stepper->floors[j] + fabs(q1[j])));
        double rate = h * V * total / (stepper->tol * (stepper->floors[nq + j] + fabs(qd1[j])));
        sum += move * move + rate * rate;
    }
    if (sqrt(sum / (2 * nq)) <= FRICTION_LIMIT) {
        return 1;
    }
    if (nf > 0) { /* the coupled hinges' Newton system, with the others' effect on them */
        dep_hinge_times(system, stepper->Jh, response, stepper->law_scratch);
        for (int a = 0; a < nf; ++a) {
            int i = stepper->free_hinges[a];
            d[a] = r[i] - h * V * slope[i] * stepper->law_scratch[i];
        }
        for (int b = 0; b < nf; ++b) { /* column b: h V C_F J_h,F Mc^-1 J_h^T e_b, then I */
            dep_hinge_times(system, stepper->Jh, stepper->mobile + (size_t)b * (size_t)nq,
                            stepper->law_scratch);
            for (int a = 0; a < nf; ++a) {
                int i = stepper->free_hinges[a];
                G[a * nf + b] = h * V * slope[i] * stepper->law_scratch[i] + (a == b ? 1.0 : 0.0);
            }
        }
        dep_solve_small(nf, G, d);
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

int dep_stepper_friction_failure(const dep_stepper *stepper, dep_failure *failure)
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
    memset(failure, 0, sizeof *failure);
    failure->stage = DEP_VELOCITY;
    failure->row = -1;
    failure->residual = off;
    snprintf(failure->reason, sizeof failure->reason, "the friction torques at the step's end "
             "did not settle in %d trials (hinge %s: %.3g N m off its law)", DEP_FRICTION_ROUNDS,
             system->hinges[worst].name, off);
    snprintf(failure->hint, sizeof failure->hint, "the friction changes faster than the step "
             "can follow; a larger slip_rate on that hinge, or a tighter tol, may help");
    return DEP_PASS_FAILED;
}
