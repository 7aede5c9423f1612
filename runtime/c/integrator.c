/* integrator.c: dep_simulate, the iterative Lagrange-multiplier integrator of the seed paper
 * (docs/method.md):
 *
 * check the initial state, find lambda_0 (acceleration pass), then take steps (stepper.c),
 * control the step with the ODE and interpolation errors (controller.c), sample outputs on
 * the dense output (recording.c), and handle events (events.c).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "runtime.h"

/* Build with -DDEP_TRACE to print every attempted step to stderr (where two runs part). */
#ifdef DEP_TRACE
#define TRACE(...) fprintf(stderr, __VA_ARGS__)
#else
#define TRACE(...) ((void)0)
#endif

#define MAX_FAILURES 12 /* consecutive non-converged steps (h / 4 each) before giving up */
#define STIFF_BOUND 2.0 /* h |lambda| this near DOPRI5's stability bound (3.3 on the real
                           axis): where the PI controller holds a stiff run's step */
#define STIFF_STEPS 15   /* accepted steps at the bound, with fewer than 6 free in between */
#define STIFF_OMEGA_H 0.5 /* h omega_max above this: DOPRI's step is bound by stability */
/* The multipliers' profile under the linearly implicit step: a quadratic. The multipliers
   carry the reactions of the stiff modes that step damps; a cubic's error estimate, a fourth
   divided difference, amplifies them and holds the step (two_link_flex at 16 elements: 198,500
   steps with a cubic, 116,200 with a quadratic at the same tol, every output within the
   issue's accuracy; a linear profile takes 21,300 but misses the low-passed tip by 3e-5 m). */
#define IMPLICIT_PROFILE_NODES 2
/* The linearly implicit step keeps its size while the controller would change it by a factor
   within [HOLD_LOW, HOLD_HIGH], so that K, D, W's factorisation, the unit responses and the
   filter's J G J^T serve many steps (rosenbrock.c, stepper.c): a new W costs about as much as
   a step. Held 3 % longer than the controller wants, a step of order q misses its aim by about
   1.03^(q + 1), a tenth. A change the controller wants within [SMALL_LOW, SMALL_HIGH] is taken
   at half its gain (its square root) before that test: where a resolved mode's error rises and
   falls with its phase (two_link_flex: the links' first axial mode, about 10 steps to its
   period), the step followed it, and W was new in a step of three; large changes (a start, an
   event, a new phase of the motion) are followed at once. two_link_flex at 16 elements, tol
   1e-8: 2.12 s without the half gain, 1.85 s with it (medians of 11), 27,000 and 31,600 steps,
   chord2's error against the 64-element reference 5.7e-6 and 4.3e-6 rad (3.0e-5 against
   2.2e-5 at tol 1e-7). Without the half gain, the window from 1 (Hairer & Wanner's RADAU5)
   took 2.51 s, from 0.95 2.16 s, but at tol 1e-7 the step's errors then alternate from step to
   step and chord2's error grows: 1.8e-5 rad from 1, 2.7e-5 from 0.95, 6.4e-5 from 0.9. A wider
   upper bound holds a step that wants to grow by a little each step (the half gain on all
   changes, or a window to 1.5: about 580 steps instead of 248 at tol 1e-6 over 0.2 s at 8
   elements). */
#define HOLD_LOW 0.97
#define HOLD_HIGH 1.2
#define SMALL_LOW 0.9
#define SMALL_HIGH 1.5
/* The friction torques' profile through the accepted ones is stable (as an Adams-Moulton
   method's) while h times the fastest rate c / I their damping c gives the mechanism stays
   below about 3: this near it, friction holds the step (docs/method.md, 9). */
#define FRICTION_BOUND 2.0
#define GRIND_FACTOR 100 /* a run whose steps would pass max_steps that many times over... */
#define GRIND_STEPS 1000 /* ...for that many steps in a row stops */
#define CAP_RELAX 1.2

/* ---- errors ----------------------------------------------------------------------------- */

/* _solver_error: a pass failure as the SolverError the user sees. */
int dep_run_pass_error(dep_run *run, const dep_failure *failure, double t)
{
    char joint[DEP_NAME_MAX + 8], what[400], hint[400];
    if (failure->row < 0) { /* not a constraint row: the step itself */
        return dep_solver_error(run->error, 1, t, dep_stage_names[failure->stage], NULL, NULL,
                                0, 0.0, failure->reason, failure->hint[0] != '\0'
                                ? failure->hint : "the state may no longer be finite; "
                                "check the beams' properties, or try a tighter tol");
    }
    dep_cs_describe(&run->cs, failure->row, joint, sizeof joint);
    if (failure->residual <= 1e3 * DEP_EPS * fmax(1.0, failure->scale)) {
        snprintf(hint, sizeof hint, "the residual is at the level of round-off: tol is tighter "
                 "than double precision reaches here; try tol >= %.0e", 10 * run->settings.tol);
    } else {
        snprintf(hint, sizeof hint, "Phi_q may be singular here (a dead point, a joint at the "
                 "end of its travel) or constraints redundant and inconsistent; check %s and "
                 "the joints in its loop, or try a looser tol", joint);
    }
    snprintf(what, sizeof what, "%s; residual %.3g", failure->reason, failure->residual);
    return dep_solver_error(run->error, 1, t, dep_stage_names[failure->stage],
                            run->cs.row_names[failure->row], joint, 1, failure->residual, what,
                            hint);
}

/* ---- states ------------------------------------------------------------------------------ */

/* _restart: a state to step from, checked for consistency, lambda from pass 3. */
int dep_run_restart(dep_run *run, double t, const double *q, const double *qd,
                    const double *work, const char *stage)
{
    dep_stepper *stepper = &run->stepper;
    dep_state *s = &run->state;
    dep_pass_report report;
    dep_failure failure;
    int status = dep_check_consistency(&run->cs, t, q, qd, run->settings.tol, stage,
                                       run->scratch, run->error);
    if (status != DEP_OK) {
        return status;
    }
    memmove(s->q, q, (size_t)run->nq * sizeof *q);
    memmove(s->qd, qd, (size_t)run->nq * sizeof *qd);
    memmove(s->work, work, (size_t)run->nd * sizeof *work);
    memset(s->lam, 0, (size_t)run->cs.nc * sizeof *s->lam);
    s->t = t;
    dep_implicit_forget(&stepper->im); /* new rows, inputs or parameters: K, D and W anew */
    stepper->end_t = NAN;              /* and the force at the last step's end */
    dep_cs_jacobian(&run->cs, s->q, t, stepper->restart_J);
    status = dep_acceleration(stepper, s->q, s->qd, t, s->lam, stepper->restart_J,
                              ++stepper->jacobian_ids, s->qdd, &report, &failure);
    if (status == DEP_PASS_FAILED) {
        return dep_run_pass_error(run, &failure, t);
    }
    dep_tally_observe(&run->tally, &report);
    dep_history_reset(&run->history, t, s->lam, run->cs.nc);
    dep_friction_law(&run->system, s->q, s->qd, run->friction_predicted);
    dep_history_reset(&run->friction, t, run->friction_predicted, run->system.nh);
    run->friction_steps = 0;
    run->prior.valid = 0;
    return DEP_OK;
}

/* Gives the interpolant of `end`, a step from run->state, the accepted point before it. */
void dep_run_attach_prior(const dep_run *run, dep_outcome *end)
{
    if (run->prior.valid) {
        dep_interpolant_prior(end->data, run->nq, end->state.t - run->state.t,
                              run->state.t - run->prior.t, run->prior.qd, run->prior.qdd);
    }
}

/* ---- recording ----------------------------------------------------------------------------- */

/* Record the output times up to t_until: on the step's dense output when `end` is given,
   else at the current state. */
int dep_run_record_until(dep_run *run, double t_until, const dep_outcome *end)
{
    if (!run->recording) {
        return DEP_OK;
    }
    int first, count = dep_recorder_pending(&run->recorder, t_until, &first), nq = run->nq;
    const dep_state *start = &run->state;
    for (int k = first; k < first + count; ++k) {
        double t = run->recorder.times[k];
        int status;
        if (end == NULL) {
            status = dep_record(&run->recorder, t, start->q, start->qd, start->lam, start->work,
                                &run->cs);
        } else {
            const dep_state *new = &end->state;
            dep_interpolate(end->data, start->t, new->t - start->t, nq, t, run->q, run->qd);
            dep_dense_components(end->rk, t, 2 * nq, run->nd, run->work);
            dep_profile_value(&end->profile, new->lam, t, run->cs.nc, run->lam);
            status = dep_record(&run->recorder, t, run->q, run->qd, run->lam, run->work, &run->cs);
        }
        if (status != DEP_OK) {
            return dep_plain_error(run->error, status, "out of memory");
        }
    }
    return DEP_OK;
}

/* ---- steps ------------------------------------------------------------------------------- */

static double first_step(dep_run *run)
{
    const dep_state *s = &run->state;
    int nq = run->nq;
    dep_profile held;
    dep_profile_hold(&held, s->t, s->lam); /* lambda held at lambda_0 */
    dep_stepper_set_rhs(&run->stepper, &held, s->lam);
    memcpy(run->y, s->q, (size_t)nq * sizeof(double));
    memcpy(run->y + nq, s->qd, (size_t)nq * sizeof(double));
    memcpy(run->y + 2 * nq, s->work, (size_t)run->nd * sizeof(double));
    dep_stepper_derivative(&run->stepper, s, run->dy);
    return dep_initial_step(dep_stepper_rhs, &run->stepper, s->t, run->y, run->dy, run->ny,
                            run->stepper.implicit ? 3 : 5, run->settings.tol,
                            run->t_stop - s->t, run->scratch);
}

/* The ODE method's error estimate less what the passes remove: its position and velocity
   parts projected onto the tangent space of the constraints at the step end along what the
   pass's correction moves (tangential; G = M^-1 for DOPRI, the Rosenbrock step's responses
   otherwise), and the prescribed frictions' works less what they move with the positions'
   normal part, -tau d(theta) (the correction moves them so; docs/method.md, 4). Into
   run->tangent. */
static void tangential_error(dep_run *run, const dep_outcome *outcome)
{
    const dep_rk_step *rk = outcome->rk;
    dep_stepper *stepper = &run->stepper;
    int nq = run->nq, solved_all = 1;
    memcpy(run->tangent, rk->error, (size_t)run->ny * sizeof *run->tangent);
    for (int half = 0; half < 2 && solved_all; ++half) {
        dep_stepper_use_mobility(stepper, half == 0 ? DEP_POSITION : DEP_VELOCITY);
        solved_all = dep_stepper_tangential(stepper, outcome->J1, outcome->J1_id,
                                            run->tangent + (size_t)half * (size_t)nq,
                                            run->normal);
    }
    dep_stepper_use_mobility(stepper, DEP_ACCELERATION);
    if (!solved_all) { /* a singular S: measure the whole error */
        memcpy(run->tangent, rk->error, (size_t)run->ny * sizeof *run->tangent);
    } else if (outcome->prescribed) {
        double *removed = run->normal; /* the positions' move that removes their normal part */
        for (int j = 0; j < nq; ++j) {
            removed[j] = run->tangent[j] - rk->error[j];
        }
        dep_stepper_work_move(stepper, outcome->state.q, removed,
                              run->tangent + 2 * nq + run->model->nd);
    }
}

/* qd (nq, in place) at q inside the step moved onto the rows' velocity level, J qd = -Phi_t,
   M-orthogonally: the dense output between the passes' corrections leaves the rows by the
   multipliers' interpolation error, and a hinge rate in a friction's slip band turns a small
   such excursion into a large torque. S is the step end's (its factor at hand). scratch: 2 nc
   + 2 nq. */
static void consistent_rates(dep_run *run, const dep_outcome *outcome, const double *q,
                             double *qd, double t, double *scratch)
{
    int nq = run->nq, nc = run->cs.nc;
    double *r = scratch, *mu = r + nc, *column = mu + nc, *solved = column + nq;
    if (nc == 0) {
        return;
    }
    dep_cs_jacobian(&run->cs, q, t, run->dense_J);
    dep_cs_phi_t(&run->cs, q, t, r);
    dep_cs_times(&run->cs, run->dense_J, qd, mu);
    for (int i = 0; i < nc; ++i) {
        r[i] += mu[i];
    }
    if (dep_schur_solve(&run->stepper.mp, outcome->J1, outcome->J1_id, nc, r, mu)) {
        dep_cs_transpose_times(&run->cs, run->dense_J, mu, column);
        dep_mass_solve(&run->system.mass, column, solved);
        for (int j = 0; j < nq; ++j) {
            qd[j] -= solved[j];
        }
    }
}

/* The interpolation errors inside the step (docs/method.md, 4), weighted (1: at tolerance).
   e->lam: the position excursion h^2 integral (1 - s) |e(s)| ds G Phi_q^T D that the
   multipliers' profile error e(t) = D prod_j (t - t_j) causes (D: dep_divided_difference),
   which the passes correct at the step's end. Right after a (re)start, with one accepted
   point, the linear profile's end value that the position pass found undercuts the true
   lambda_{i+1} (lam1, from the acceleration pass) by (h^2 / 4) lambda'', so the excursion is
   (h^2 / 6) G Phi_q^T (lam1 - lam_position).
   e->friction, when the step prescribed the friction torques: the step's trajectory solves
   the motion perturbed by the defect d(t) = law(rate(t)) - profile(t) along it, which moves
   the end state by about h integral |d| du in the velocities and half h^2 times that in the
   positions, times Mc^-1 J_h^T (Mc^-1: M^-1 along the tangent space; friction moves the
   mechanism). d is measured at the step's middle on its dense output, the rates first made
   consistent where a hinge's damping matters, and integrated by Simpson's rule, d being
   nought at both ends: integral_0^1 d du = (2/3) d(1/2). It sees a friction's turn that
   starts inside the step, which the accepted torques cannot foretell. */
static void interpolation_errors(dep_run *run, const dep_outcome *outcome,
                                 const double *scale, dep_step_errors *e)
{
    const dep_system *system = &run->system;
    const dep_state *new = &outcome->state, *start = &run->state;
    const dep_profile *profile = &outcome->profile, *friction = &outcome->friction_profile;
    int nq = run->nq, nc = run->cs.nc, nh = system->nh, nodes = profile->nodes;
    double h = profile->h, *table = run->scratch, *d = run->normal;
    double *column = d + 2 * nc, *excursion = column + nq, *move = excursion + nq;
    double *projection = move + 2 * nq;
    e->lam_order = nodes + 3;
    e->lam = e->friction = 0.0;
    e->friction_order = 0;
    if (nc > 0) {
        if (dep_divided_difference(profile, &run->history, new->lam, d, table)) {
            double factor = pow(h, nodes + 3) * profile->excursion;
            for (int i = 0; i < nc; ++i) {
                d[i] *= factor;
            }
        } else {
            for (int i = 0; i < nc; ++i) {
                d[i] = h * h / 6.0 * (new->lam[i] - outcome->lam_position[i]);
            }
        }
        dep_cs_transpose_times(&run->cs, outcome->J1, d, column);
        dep_multipliers_apply(&run->stepper.mp, column, excursion);
        e->lam = dep_rms(excursion, scale, nq) * sqrt((double)nq / run->ny);
    }
    if (!outcome->prescribed) {
        return;
    }
    dep_stepper_use_mobility(&run->stepper, DEP_ACCELERATION);
    double *defect = run->friction_d, *law = run->friction_table, *prescribed = law + nh;
    double middle = start->t + 0.5 * h, *q = run->tangent, *qd = q + nq;
    dep_dense_components(outcome->rk, middle, 0, 2 * nq, q);
    if (outcome->friction_coupled > 0) { /* a rate error matters where the law is steep */
        consistent_rates(run, outcome, q, qd, middle, projection);
    }
    dep_friction_law(system, q, qd, law); /* the law along the step's trajectory */
    dep_profile_value(friction, outcome->friction, middle, nh, prescribed);
    for (int i = 0; i < nh; ++i) {
        defect[i] = 2.0 / 3.0 * (law[i] - prescribed[i]);
    }
    system->model->hinge_jacobian(new->q, system->p, system->hinge_jacobian);
    dep_hinge_transpose_times(system, system->hinge_jacobian, defect, column);
    dep_mass_solve(&system->mass, column, excursion);
    dep_stepper_tangential(&run->stepper, outcome->J1, outcome->J1_id, excursion, projection);
    dep_stepper_use_mobility(&run->stepper, DEP_POSITION);
    for (int j = 0; j < nq; ++j) { /* h^2 integral (1 - u) |defect|, h integral |defect| */
        move[j] = 0.5 * h * h * excursion[j];
        move[nq + j] = h * excursion[j];
    }
    e->friction = dep_rms(move, scale, 2 * nq) * sqrt(2.0 * nq / run->ny);
    e->friction_order = friction->nodes + 2;
}

/* The step's errors in tolerance units (1 = at tolerance; controller.c). */
static void step_errors(dep_run *run, const dep_outcome *outcome, dep_step_errors *e)
{
    const dep_rk_step *rk = outcome->rk;
    double *scale = run->y;
    int nq = run->nq;
    dep_weights(rk->y0, rk->y1, run->ny, run->settings.tol, scale);
    tangential_error(run, outcome);
    if (rk->method == DEP_ROSENBROCK) {
        /* positions and work: a velocity error shows in the positions a step later, and
           would otherwise hold the step to the period of a beam mode whose displacement is
           far below tol (docs/method.md, 10) */
        double pos = dep_rms(run->tangent, scale, nq), work = dep_rms(run->tangent + 2 * nq,
                                                                    scale + 2 * nq, run->nd);
        e->ode = sqrt((pos * pos * nq + work * work * run->nd) / (nq + run->nd));
    } else {
        e->ode = dep_rms(run->tangent, scale, run->ny);
    }
    e->ode_order = rk->order;
    dep_stepper_use_mobility(&run->stepper, DEP_POSITION);
    interpolation_errors(run, outcome, scale, e);
    dep_stepper_use_mobility(&run->stepper, DEP_ACCELERATION);
    if (!isfinite(e->ode + e->lam + e->friction)) {
        e->ode = INFINITY;
        e->lam = e->friction = 0.0;
    }
}

/* The coordinate a motion moves most: its velocity components weighted by sqrt(M_jj). */
static const char *moving_most(const dep_run *run, const double *qd)
{
    int nq = run->nq, best = 0;
    double largest = -1.0;
    for (int j = 0; j < nq; ++j) {
        double size = fabs(qd[j]) * sqrt(fabs(run->system.mass.entry_diagonal[j]));
        if (size > largest) {
            largest = size;
            best = j;
        }
    }
    return run->model->coordinate_names[best];
}

/* After an accepted step of size h: a model with beams whose step a stiff mode holds at
   DOPRI's stability bound (Hairer's test, STIFF_STEPS steps with h |lambda| > STIFF_BOUND)
   goes on with the linearly implicit step (rosenbrock.c, docs/method.md, 10). Otherwise a run
   stops rather than grind when its steps would pass max_steps: at once when a stiff mode
   holds the step at the stability bound (DOPRI's, or the prescribed friction's:
   FRICTION_BOUND) and the steps left at this size would pass the limit; when the steps left at this size would pass it GRIND_FACTOR times over for
   GRIND_STEPS steps in a row; and when the limit is reached. */
static int step_budget(dep_run *run, double h)
{
    const dep_rk_step *rk = run->outcome.rk;
    const dep_state *s = &run->outcome.state;
    double limit = run->settings.max_steps > 0 ? run->settings.max_steps : DEP_MAX_STEPS;
    double end = isfinite(run->settings.t_end) ? run->settings.t_end : run->t_stop;
    double taken = (double)run->tally.accepted, span = end - s->t;
    double left = span / h;
    if (rk->stiffness > STIFF_BOUND) {
        run->stiff_steps++;
        run->free_steps = 0;
    } else if (++run->free_steps >= 6) {
        run->stiff_steps = 0;
    }
    if (run->settings.stepping == DEP_STEPPING_AUTO && run->model->nkz > 0
        && !run->stepper.implicit) {
        /* the stiff forces have a Jacobian: the linearly implicit step from here on once
           their fastest mode (omega_max, a lower bound by power iteration) or Hairer's test
           says the explicit step is at its stability bound */
        if (run->omega_max == 0.0) {
            run->omega_max = dep_implicit_fastest(&run->stepper.im, s->q);
        }
        run->bound_steps = h * run->omega_max > STIFF_OMEGA_H ? run->bound_steps + 1 : 0;
        if (run->stiff_steps >= STIFF_STEPS || run->bound_steps >= STIFF_STEPS) {
            run->stepper.implicit = 1;
            run->profile_nodes = IMPLICIT_PROFILE_NODES;
            run->implicit_from = s->t;
            run->stiff_rate = fmax(rk->stiffness / h, run->omega_max);
            run->stiff_steps = 0;
        }
    }
    const dep_outcome *o = &run->outcome;
    int friction = o->prescribed && o->friction_hinge >= 0
                   && h * o->friction_rate > FRICTION_BOUND;
    run->friction_steps = friction ? run->friction_steps + 1 : 0;
    run->grind_steps = taken + left > GRIND_FACTOR * limit ? run->grind_steps + 1 : 0;
    friction = run->friction_steps >= STIFF_STEPS && taken + left > limit;
    int stiff = friction || (run->stiff_steps >= STIFF_STEPS && taken + left > limit);
    if (!stiff && run->grind_steps < GRIND_STEPS && !(taken >= limit && span > run->h_min)) {
        return DEP_OK;
    }
    char what[512], hint[300];
    if (friction) {
        const dep_hinge_mechanics *hinge = &run->system.hinges[o->friction_hinge];
        snprintf(what, sizeof what, "the model is stiff here: hinge %s's friction damps its "
                 "motion at a rate of about %.3g 1/s (friction / slip_rate = %.3g N m s/rad), "
                 "which holds the step at %.3g s; the %.4g s left would take about %.3g more "
                 "steps, over max_steps = %.0f", hinge->name, o->friction_rate,
                 hinge->kinetic / hinge->slip_rate, h, span, left, limit);
        snprintf(hint, sizeof hint, "a larger slip_rate on %s (the regularised friction law's "
                 "width) softens it; or raise max_steps (--max-steps) to run it as it is",
                 hinge->name);
    } else if (stiff) {
        double rate = rk->stiffness / h;
        snprintf(what, sizeof what, "the model is stiff here: a mode of rate about %.3g 1/s "
                 "(time scale %.3g s), moving %s most, holds the explicit step at %.3g s; the "
                 "%.4g s left would take about %.3g more steps, over max_steps = %.0f", rate,
                 1.0 / rate, moving_most(run, rk->mode + run->nq), h, span, left, limit);
        snprintf(hint, sizeof hint, "soften what moves it (a hinge or latch stiffness, a "
                 "beam's EA or EI, or fewer beam elements), or raise max_steps (--max-steps) to "
                 "run it as it is");
    } else if (run->grind_steps >= GRIND_STEPS) {
        snprintf(what, sizeof what, "the step has been about %.3g s for %d steps, with %s "
                 "moving most: the %.4g s left would take about %.3g more steps, over "
                 "max_steps = %.0f", h, run->grind_steps, moving_most(run, s->qd), span, left,
                 limit);
        snprintf(hint, sizeof hint, "a motion this fast needs steps this small; check the "
                 "model's stiffnesses and initial rates, shorten t_end, or raise max_steps "
                 "(--max-steps)");
    } else {
        snprintf(what, sizeof what, "max_steps = %.0f steps taken, with %.4g s left at steps "
                 "of about %.3g s (%s moving most)", limit, span, h, moving_most(run, s->qd));
        snprintf(hint, sizeof hint, "raise max_steps (--max-steps), or shorten t_end");
    }
    return dep_solver_error(run->error, 1, s->t, "step size", NULL, NULL, 0, 0.0, what, hint);
}

/* A step of size h from run->state into outcome, the profiles through the histories (the
   friction torques' kept at the multipliers' times: the same weights). */
int dep_run_step(dep_run *run, double h, dep_outcome *outcome, dep_failure *failure)
{
    dep_profile profile, friction;
    double weights[DEP_HISTORY];
    dep_profile_set(&profile, &run->history, h, run->profile_nodes);
    dep_history_weights(&run->history, &profile, weights);
    dep_history_predict(&run->history, &profile, weights, run->predicted);
    if (run->system.n_friction == 0) {
        return dep_step(&run->stepper, &run->state, &profile, run->predicted, NULL, NULL,
                        outcome, failure);
    }
    dep_profile_share(&friction, &profile, &run->friction);
    dep_history_predict(&run->friction, &friction, weights, run->friction_predicted);
    return dep_step(&run->stepper, &run->state, &profile, run->predicted, &friction,
                    run->friction_predicted, outcome, failure);
}

/* One accepted step from run->state into run->outcome; *h: in the size to try, out the next. */
static int advance(dep_run *run, double *h)
{
    int failures = 0;
    for (;;) {
        double remaining = run->t_stop - run->state.t;
        dep_step_errors errors;
        dep_failure failure;
        *h = fmin(*h, run->h_cap);
        double proposed = *h; /* before a cut to t_stop: what the next step starts from */
        int cut = *h >= remaining - run->h_min;
        *h = cut ? remaining : *h;
        int status = dep_run_step(run, *h, &run->outcome, &failure);
        if (status == DEP_PASS_FAILED) {
            TRACE("step t=%.17g h=%.17g failed %s row %d\n", run->state.t, *h,
                  dep_stage_names[failure.stage], failure.row);
            run->tally.failed++;
            if (++failures >= MAX_FAILURES || *h / 4 < run->h_min) {
                return dep_run_pass_error(run, &failure, run->state.t + *h);
            }
            run->h_cap = *h / 2;
            *h /= 4;
            continue;
        }
        step_errors(run, &run->outcome, &errors);
        int accepted = dep_step_error(&errors) <= 1.0;
        double fac = dep_step_factor(&errors, run->err_previous, accepted);
        TRACE("step t=%.17g h=%.17g ode=%.17g lam=%.17g iterations %d %d %d "
              "integrations %d %s\n", run->state.t, *h, errors.ode, errors.lam,
              run->outcome.reports[0].iterations,
              run->outcome.reports[1].iterations, run->outcome.reports[2].iterations,
              run->outcome.integrations, accepted ? "accepted" : "rejected");
        if (accepted) {
            dep_tally_accept(&run->tally, run->outcome.reports, *h);
            dep_history_learn(&run->history, *h, run->predicted, run->stepper.lam_first);
            dep_run_attach_prior(run, &run->outcome);
            run->err_previous = dep_step_error(&errors);
            run->h_cap = run->h_cap < 1e300 ? run->h_cap * CAP_RELAX : INFINITY;
            double taken = *h;
            if (run->stepper.implicit && fac > SMALL_LOW && fac < SMALL_HIGH) {
                fac = sqrt(fac); /* a small change at half the gain (HOLD_LOW's comment) */
            }
            double change = fmin(fac, dep_convergence_factor(&run->outcome.reports[0]));
            int hold = run->stepper.implicit && change >= HOLD_LOW && change <= HOLD_HIGH;
            *h = hold ? taken : taken * change;
            if (cut && (hold || *h > taken)) {
                /* a step cut short to land on t_stop (an output of dep_advance, a table's
                   point) says nothing against the size it was cut from */
                *h = hold ? proposed : fmax(*h, proposed);
                taken = fmax(taken, proposed);
            }
            return step_budget(run, taken);
        }
        run->tally.rejected++;
        *h *= fac;
        if (*h < run->h_min) {
            char what[80];
            snprintf(what, sizeof what, "step size fell below %.1e s", run->h_min);
            return dep_solver_error(run->error, 1, run->state.t, "step size", NULL, NULL, 0, 0.0,
                                    what, "the model may be stiff or discontinuous here; try a "
                                    "looser tol");
        }
    }
}

/* ---- the run ------------------------------------------------------------------------------ */

dep_settings dep_default_settings(const dep_model *model)
{
    dep_settings settings = {model->t_end, model->dt_out, model->tol, 1, NULL, NULL, 0.0,
                             NULL, 0, DEP_STEPPING_AUTO, DEP_ROWS_ALL};
    return settings;
}

int dep_parameter_index(const dep_model *model, const char *name)
{
    for (int i = 0; i < model->np; ++i) {
        if (strcmp(model->parameter_names[i], name) == 0) {
            return i;
        }
    }
    return -1;
}

/* The system, with the mechanism of the hinges' latches, stops and stick-slip friction
   when the settings ask for it and the model has any. */
static int setup_system(dep_run *run, const double *params)
{
    dep_arena *arena = &run->arena;
    const dep_model *m = run->model;
    dep_mechanism *mechanism = NULL;
    int status;
    run->p = dep_doubles(arena, (size_t)m->np);
    run->p_spare = dep_doubles(arena, (size_t)m->np);
    if (run->p == NULL || run->p_spare == NULL) {
        return dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory");
    }
    memcpy(run->p, params != NULL ? params : m->parameter_defaults, (size_t)m->np * sizeof(double));
    if ((status = dep_check_settings(m, run->p, &run->settings, !run->recording,
                                     run->error)) != DEP_OK
        || (status = dep_system_init(&run->system, m, run->p, run->settings.mechanics != 0,
                                     arena, run->error)) != DEP_OK) {
        return status;
    }
    if (dep_mechanism_create(&mechanism, &run->system,
                             dep_constraint_tolerance(run->settings.tol), arena) != DEP_OK) {
        return dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory");
    }
    run->nq = m->nq;
    run->nd = run->system.nd;
    run->ny = 2 * m->nq + run->nd;
    return DEP_OK;
}

static int setup(dep_run *run, const double *params, const dep_event *events, int n_events)
{
    dep_arena *arena = &run->arena;
    const dep_model *m = run->model;
    int status = setup_system(run, params);
    dep_mechanism *mechanism = run->system.mechanism;
    if (status != DEP_OK
        || (status = dep_watch_init(&run->watch, events, n_events,
                                    mechanism ? mechanism->events : NULL,
                                    mechanism ? mechanism->n_events : 0, arena,
                                    run->error)) != DEP_OK) {
        return status;
    }
    run->n_user_events = n_events;
    if (run->settings.stepping == DEP_STEPPING_IMPLICIT) {
        run->implicit_from = 0.0;
    }
    if (dep_constraints_init(&run->cs, &run->system, arena) != DEP_OK
        || dep_stepper_init(&run->stepper, &run->system, &run->cs, run->settings.tol, arena)
        || dep_history_init(&run->history, run->cs.capacity, arena)
        || dep_history_init(&run->friction, m->nh + 1, arena)
        || (run->prior.qd = dep_doubles(arena, (size_t)m->nq)) == NULL
        || (run->prior.qdd = dep_doubles(arena, (size_t)m->nq)) == NULL
        || dep_state_init(&run->state, m->nq, run->cs.capacity, run->nd, arena)
        || dep_outcome_init(&run->outcome, m->nq, run->cs.capacity, run->nd, m->nh, arena)
        || dep_outcome_init(&run->fired, m->nq, run->cs.capacity, run->nd, m->nh, arena)
        || dep_loads_init(&run->loads, m, arena)
        || dep_change_init(&run->change, m->nq, m->nh, arena)) {
        return dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory");
    }
    run->stepper.implicit = run->settings.stepping == DEP_STEPPING_IMPLICIT;
    if (run->stepper.implicit) {
        run->profile_nodes = IMPLICIT_PROFILE_NODES;
    }
    status = run->recording ? dep_recorder_init(&run->recorder, &run->system, &run->settings,
                                                run->cs.capacity, arena) : DEP_OK;
    if (status == DEP_SETTINGS_ERROR) {
        char what[200];
        snprintf(what, sizeof what, "t_end / dt_out = %.6g / %.6g asks for %.4g output times; "
                 "this model records at most %.0f (1 GiB of results): use a larger dt_out",
                 run->settings.t_end, run->settings.dt_out,
                 floor(run->settings.t_end / run->settings.dt_out) + 1,
                 dep_max_output_times(&run->system));
        return dep_plain_error(run->error, status, what);
    }
    size_t capacity = (size_t)run->cs.capacity, nq = (size_t)m->nq, ny = (size_t)run->ny;
    run->scratch = dep_doubles(arena, DEP_JACOBIAN_SIZE(m) + (DEP_HISTORY + 2) * capacity
                                      + 3 * ny + 2 * nq);
    run->dense_J = dep_doubles(arena, DEP_JACOBIAN_SIZE(m));
    run->dense_lam = dep_doubles(arena, capacity);
    run->tangent = dep_doubles(arena, ny); /* also the defect's (q, qd) */
    size_t nh = (size_t)m->nh + 1;
    run->friction_predicted = dep_doubles(arena, nh);
    run->friction_d = dep_doubles(arena, nh);
    run->friction_table = dep_doubles(arena, 2 * (size_t)nh);
    run->normal = dep_doubles(arena, 4 * capacity + 6 * nq);
    double **vectors[] = {&run->y, &run->dy, &run->work};
    for (size_t i = 0; i < 3; ++i) {
        *vectors[i] = dep_doubles(arena, ny);
    }
    double **rows[] = {&run->q, &run->qd, &run->mass_qd, &run->lam, &run->predicted};
    for (size_t i = 0; i < 5; ++i) {
        *rows[i] = dep_doubles(arena, capacity + nq);
    }
    run->response = dep_bytes(arena, sizeof *run->response);
    run->response_rows = dep_bytes(arena, DEP_MAX_ADDED * sizeof *run->response_rows);
    return status != DEP_OK || arena->failed
        ? dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory") : DEP_OK;
}

/* The progress callback, if any: DEP_INTERRUPTED when it asks to stop. */
static int report_progress(dep_run *run)
{
    const dep_settings *s = &run->settings;
    if (s->progress == NULL || s->progress(s->progress_context, run->state.t) == 0) {
        return DEP_OK;
    }
    char message[80];
    snprintf(message, sizeof message, "stopped at t = %.9g s", run->state.t);
    return dep_plain_error(run->error, DEP_INTERRUPTED, message);
}

/* The assembled initial state at t = 0, its modes and lambda_0, recorded. */
static int begin(dep_run *run)
{
    int status;
    if ((status = dep_run_assemble(run, run->q, run->qd)) != DEP_OK
        || (status = dep_run_start(run, run->q, run->qd)) != DEP_OK
        || (status = dep_run_record_until(run, 0.0, NULL)) != DEP_OK) {
        return status;
    }
    return dep_watch_reset(&run->watch, 0.0, run->state.q, run->state.qd, -1, 0.0,
                           dep_run_rows(run, &run->state), run->error);
}

/* Steps to t (or a stopping event). */
static int run_until(dep_run *run, double t)
{
    long long steps = 0;
    int status;
    run->t_stop = t;
    if (!isfinite(run->settings.t_end)) {
        run->h_min = 64 * DEP_EPS * fmax(1.0, t);
    }
    while (t - run->state.t > run->h_min && !run->stopped) {
        if (run->h_next == 0.0) {
            run->h_next = first_step(run);
        }
        if ((status = advance(run, &run->h_next)) != DEP_OK
            || (status = dep_run_after_step(run, &run->stopped)) != DEP_OK
            || (++steps % DEP_PROGRESS_STEPS == 0 && (status = report_progress(run)) != DEP_OK)) {
            return status;
        }
    }
    return DEP_OK;
}

/* Input k's parameter slots from now on: u(s) = value + rate (s - now), into `p`. */
static void put_input(const dep_run *run, double *p, int k, double value, double rate)
{
    int slot = run->model->input_slots[k];
    p[slot] = value - rate * run->state.t;
    p[slot + 1] = rate;
}

/* Makes `p` (filled from run->p, then changed) the run's parameters if it differs from
   them. A change takes the other buffer, so a binding that converts p once per pointer
   sees it. 1 if it changed. */
static int take_parameters(dep_run *run, double *p)
{
    if (memcmp(p, run->p, (size_t)run->model->np * sizeof *p) == 0) {
        return 0;
    }
    run->p_spare = run->p;
    run->p = p;
    run->system.p = p;
    if (run->system.mechanism != NULL) {
        run->system.mechanism->p = p;
    }
    return 1;
}

/* The spare parameter buffer, filled with the run's parameters. */
static double *spare_parameters(dep_run *run)
{
    memcpy(run->p_spare, run->p, (size_t)run->model->np * sizeof *run->p);
    return run->p_spare;
}

/* After the inputs changed at the current state: lambda and the step sequence anew. The
   events' last values stay those before the change, so a mode the new load ends (a stuck
   hinge it frees, a stop it pulls away from) is found crossing in the next step. */
static int inputs_changed(dep_run *run)
{
    dep_state *s = &run->state;
    memcpy(run->q, s->q, (size_t)run->nq * sizeof(double));
    memcpy(run->qd, s->qd, (size_t)run->nq * sizeof(double));
    memcpy(run->work, s->work, (size_t)run->nd * sizeof(double));
    run->h_next = 0.0;
    return dep_run_restart(run, s->t, run->q, run->qd, run->work, "inputs");
}

/* A table's value and slope on the piece starting at t (right-continuous at a jump). */
static void table_piece(const dep_input_table *table, double t, double *value, double *rate)
{
    int n = table->n, i = 0;
    while (i + 1 < n && table->t[i + 1] <= t) {
        ++i;
    }
    *rate = 0.0;
    if (t < table->t[0] || i == n - 1) {
        *value = t < table->t[0] ? table->u[0] : table->u[n - 1];
        return;
    }
    *rate = (table->u[i + 1] - table->u[i]) / (table->t[i + 1] - table->t[i]);
    *value = table->u[i] + *rate * (t - table->t[i]);
}

/* The next time after t where a table's piece ends (t_end if none). */
static double next_break(const dep_run *run, double t)
{
    double next = run->settings.t_end;
    for (int k = 0; k < run->settings.n_tables; ++k) {
        const dep_input_table *table = &run->settings.tables[k];
        for (int i = 0; i < table->n; ++i) {
            if (table->t[i] > t + run->h_min) {
                next = fmin(next, table->t[i]);
                break;
            }
        }
    }
    return next;
}

/* The tables' pieces at the current time into the inputs' slots. */
static int apply_tables(dep_run *run)
{
    double *p = spare_parameters(run);
    for (int k = 0; k < run->settings.n_tables; ++k) {
        const dep_input_table *table = &run->settings.tables[k];
        double value, rate;
        table_piece(table, run->state.t, &value, &rate);
        put_input(run, p, table->input, value, rate);
    }
    return take_parameters(run, p) ? inputs_changed(run) : DEP_OK;
}

/* From the assembled initial state to t_end or a stopping event, piece by piece of the
   input tables. */
static int integrate_run(dep_run *run)
{
    double *p = spare_parameters(run);
    int status;
    for (int k = 0; k < run->settings.n_tables; ++k) { /* the tables' values at t = 0 */
        const dep_input_table *table = &run->settings.tables[k];
        double value, rate;
        table_piece(table, 0.0, &value, &rate);
        put_input(run, p, table->input, value, rate);
    }
    take_parameters(run, p);
    if ((status = begin(run)) != DEP_OK) {
        return status;
    }
    while (run->settings.t_end - run->state.t > run->h_min && !run->stopped) {
        if ((status = run_until(run, next_break(run, run->state.t))) != DEP_OK
            || (run->settings.n_tables > 0 && !run->stopped
                && (status = apply_tables(run)) != DEP_OK)) {
            return status;
        }
    }
    return report_progress(run);
}

/* The event records into the result (malloc'ed). */
static int finish_events(dep_run *run, dep_result *result)
{
    result->n_events = run->n_records;
    result->events = calloc((size_t)(run->n_records ? run->n_records : 1), sizeof *result->events);
    if (result->events == NULL) {
        return DEP_MEMORY_ERROR;
    }
    for (int k = 0; k < run->n_records; ++k) {
        const dep_event_record *r = &run->records[k];
        result->events[k] = *r;
        result->events[k].data = malloc((size_t)(r->n_data ? r->n_data : 1) * sizeof(dep_datum));
        if (result->events[k].data == NULL) {
            result->events[k].n_data = 0;
            return DEP_MEMORY_ERROR;
        }
        if (r->n_data) {
            memcpy(result->events[k].data, r->data, (size_t)r->n_data * sizeof(dep_datum));
        }
    }
    return DEP_OK;
}

static int finish(dep_run *run, dep_result *result)
{
    if (dep_recorder_result(&run->recorder, result) != DEP_OK
        || finish_events(run, result) != DEP_OK) {
        dep_result_free(result);
        return dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory");
    }
    result->tol = run->settings.tol;
    result->constraint_tol = run->stepper.constraint_tol;
    result->t_end = run->settings.t_end;
    result->dt_out = run->settings.dt_out;
    result->stats = dep_tally_stats(&run->tally, run->stepper.integrations,
                                    run->stepper.rhs_evaluations);
    result->stats.implicit_from = run->implicit_from;
    result->stats.stiff_rate = run->stiff_rate;
    if (dep_summarize(run->model, &run->system, &run->loads, result) != DEP_OK) {
        dep_result_free(result);
        return dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory");
    }
    return DEP_OK;
}

/* A new run of `model`: its settings checked, its system, events and (when `recording`)
   its recorder set up. NULL with `error` filled on failure. */
static dep_run *new_run(const dep_model *model, const double *params,
                        const dep_settings *settings, const dep_event *events, int n_events,
                        int recording, dep_error *error)
{
    dep_run *run = calloc(1, sizeof *run);
    dep_error_clear(error);
    if (run == NULL) {
        dep_plain_error(error, DEP_MEMORY_ERROR, "out of memory");
        return NULL;
    }
    if (model->abi != DEP_MODEL_ABI) {
        free(run);
        dep_plain_error(error, DEP_SETTINGS_ERROR, "the model was generated for another "
                        "version of depsim_model.h; regenerate it");
        return NULL;
    }
    run->model = model;
    run->settings = settings != NULL ? *settings : dep_default_settings(model);
    run->error = error;
    run->recording = recording;
    run->t_stop = run->settings.t_end;
    run->h_min = 64 * DEP_EPS * fmax(1.0, isfinite(run->settings.t_end) ? run->settings.t_end
                                                                          : 1.0);
    run->h_cap = INFINITY;
    run->err_previous = 1.0;
    run->implicit_from = run->stiff_rate = NAN;
    run->omega_max = 0.0;
    run->profile_nodes = DEP_PROFILE_NODES;
    dep_tally_init(&run->tally);
    if (setup(run, params, events, n_events) != DEP_OK) {
        dep_close(run);
        return NULL;
    }
    return run;
}

int dep_simulate(const dep_model *model, const double *params, const dep_settings *settings,
                 const dep_event *events, int n_events, dep_result *result, dep_error *error)
{
    memset(result, 0, sizeof *result);
    dep_run *run = new_run(model, params, settings, events, n_events, 1, error);
    if (run == NULL) {
        return error->code;
    }
    int status = integrate_run(run);
    if (status == DEP_OK) {
        status = finish(run, result);
    }
    dep_close(run);
    return status;
}

/* ---- one run advanced piece by piece ------------------------------------------------------- */

int dep_open(const dep_model *model, const double *params, const dep_settings *settings,
             dep_run **out, dep_error *error)
{
    dep_run *run = new_run(model, params, settings, NULL, 0, 0, error);
    *out = NULL;
    if (run == NULL) {
        return error->code;
    }
    int status = begin(run);
    if (status != DEP_OK) {
        dep_close(run);
        return status;
    }
    *out = run;
    return DEP_OK;
}

int dep_advance(dep_run *run, double t, dep_error *error)
{
    char message[160];
    dep_error_clear(error);
    run->error = error;
    if (!(t >= run->state.t - run->h_min && t <= run->settings.t_end)) {
        snprintf(message, sizeof message, "cannot advance to t = %.17g s: the run is at "
                 "t = %.17g s and ends at %.17g s", t, run->state.t, run->settings.t_end);
        return dep_plain_error(error, DEP_SETTINGS_ERROR, message);
    }
    return run_until(run, t);
}

int dep_set_inputs(dep_run *run, const double *values, const double *rates, dep_error *error)
{
    double *p = spare_parameters(run);
    dep_error_clear(error);
    run->error = error;
    for (int k = 0; k < run->model->ni; ++k) {
        double rate = rates != NULL ? rates[k] : 0.0;
        if (!isfinite(values[k]) || !isfinite(rate)) {
            char message[200];
            snprintf(message, sizeof message, "input %s: its value and rate must be finite "
                     "numbers", run->model->input_names[k]);
            return dep_plain_error(error, DEP_SETTINGS_ERROR, message);
        }
        put_input(run, p, k, values[k], rate);
    }
    return take_parameters(run, p) ? inputs_changed(run) : DEP_OK;
}

double dep_time(const dep_run *run)
{
    return run->state.t;
}

void dep_outputs(dep_run *run, double *outputs)
{
    const dep_state *s = &run->state;
    if (run->model->nout > 0) {
        run->model->outputs(s->q, s->qd, s->t, run->p, outputs);
    }
}

void dep_hinge_states(dep_run *run, dep_hinge_state *out)
{
    const dep_model *m = run->model;
    const dep_state *s = &run->state;
    int nh = m->nh;
    if (nh == 0) {
        return;
    }
    double *angles = run->loads.forces, *rates = run->loads.torques;
    m->hinge_angles(s->q, run->p, angles);
    m->hinge_rates(s->q, s->qd, run->p, rates);
    for (int k = 0; k < nh; ++k) {
        const dep_hinge_mechanics *h = &run->system.hinges[k];
        out[k].angle = angles[k];
        out[k].rate = rates[k];
        out[k].has_latch = h->has_latch;
        out[k].latched = h->has_latch && h->latch_state == DEP_LATCHED;
    }
    dep_hinge_forces(&run->loads, s->lam, run->loads.forces);
    for (int k = 0; k < nh; ++k) {
        out[k].force_x = run->loads.forces[2 * k];
        out[k].force_y = run->loads.forces[2 * k + 1];
    }
    dep_lock_torques(m, &run->cs, s->lam, run->loads.torques);
    for (int k = 0; k < nh; ++k) {
        out[k].torque = isnan(run->loads.torques[k]) ? 0.0 : run->loads.torques[k];
    }
}

void dep_close(dep_run *run)
{
    if (run != NULL) {
        dep_arena_free(&run->arena);
        free(run);
    }
}
