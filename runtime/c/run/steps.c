/* steps.c: a run's accepted steps (docs/method.md, 4-6 and 10): the step from the multipliers'
 * and the friction torques' histories (step.c takes it), its errors in tolerance units (the
 * ODE method's tangential part, the interpolation of the multipliers and of prescribed
 * friction), its acceptance and the next size (control.c), the switch to the linearly implicit
 * step when a stiff mode holds DOPRI at its stability bound, and the step budget that stops a
 * run rather than let it grind (run.h).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "run.h"

/* Build with -DDEP_TRACE to print every attempted step to stderr (where two runs part). */
#ifdef DEP_TRACE
#define TRACE(...) fprintf(stderr, __VA_ARGS__)
#else
#define TRACE(...) ((void)0)
#endif
/* Build with -DDEP_DUMP and run with DEP_DUMP=file (DEP_DUMP_FROM, DEP_DUMP_SPAN: the time
   window, 3 and 0.02 s unless set) to write, for every linearly implicit step in the window,
   what its error was measured on: t, h, nq, nc, the end state (q, qd), the positions' weights,
   the filtered error's tangential part and the whole filtered error (q and qd each), and M,
   W's K and Phi_q at the end, dense (doubles, native order). bench/beam_modes.py reads it and
   splits the error by the constrained mechanism's modes. */
#ifdef DEP_DUMP
#include <stdlib.h>
#endif

#define MAX_FAILURES 12 /* consecutive non-converged steps (h / 4 each) before giving up */
#define STIFF_BOUND 2.0 /* h |lambda| this near DOPRI5's stability bound (3.3 on the real
                           axis): where the PI controller holds a stiff run's step */
#define STIFF_STEPS 15   /* accepted steps at the bound, with fewer than 6 free in between */
#define STIFF_OMEGA_H 0.5 /* h omega_max above this: DOPRI's step is bound by stability */
/* The linearly implicit step keeps its size while the controller would change it by a factor
   within [HOLD_LOW, HOLD_HIGH], so that K, D, W's factorisation, the unit responses and the
   filter's J G J^T serve many steps (method/rosenbrock.c, method/responses.c): a new W costs
   about as much as a step. Held 3 % longer than the controller wants, a step of order q misses
   its aim by about 1.03^(q + 1), a tenth. A change the controller wants within [SMALL_LOW,
   SMALL_HIGH] is taken at half its gain (its square root) before that test: where a resolved
   mode's error rises and falls with its phase (two_link_flex: the links' first axial mode, about
   14 steps to its period), the step followed it, and W was new in a step of three; large changes
   (a start, an event, a new phase of the motion) are followed at once. two_link_flex at 16
   elements, tol 1e-8: 2.12 s without the half gain, 1.85 s with it (medians of 11), 27,000 and
   31,600 steps, chord2's error against the 64-element reference 5.7e-6 and 4.3e-6 rad (3.0e-5
   against 2.2e-5 at tol 1e-7). Without the half gain, the window from 1 (Hairer & Wanner's
   RADAU5) took 2.51 s, from 0.95 2.16 s, but at tol 1e-7 the step's errors then alternate from
   step to step and chord2's error grows: 1.8e-5 rad from 1, 2.7e-5 from 0.95, 6.4e-5 from 0.9. A
   wider upper bound holds a step that wants to grow by a little each step (the half gain on all
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
/* The rows' forces' profile (method/forces.c) is looked at where S's smallest pivot is below
   FORCE_CONDITION of its diagonal (its rows within about a tenth of a radian of dependent: a
   singular position's neighbourhood, or members as thin as a tenth of their length) and the
   multipliers' interpolation error leads the step's errors and is at least FORCE_LEADS of
   tol. A step takes it when its error is below the multipliers' by FORCE_MARGIN, and the run
   keeps it until its next event or restart: each of its evaluations factorises S at its own
   state (a reflector arm's thin members: 1.6 times the instructions where it took it
   throughout), so the run pays for it once the multipliers' profile has missed by far, at a
   pole. Handing back to the multipliers' profile between singular positions, by the same
   comparison or by S's pivot, cost a chain of parallelograms 5 to 50 times the error of
   keeping it (bench/NOTES.md, singular positions). */
#define FORCE_CONDITION 1e-2
#define FORCE_LEADS 0.1
#define FORCE_MARGIN 4.0

/* Gives the interpolant of `end`, a step from run->state, the accepted point before it. */
void dep_run_attach_prior(const dep_run *run, dep_outcome *end)
{
    if (run->prior.valid) {
        dep_interpolant_prior(end->data, run->nq, end->state.t - run->state.t,
                              run->state.t - run->prior.t, run->prior.qd, run->prior.qdd,
                              run->prior.qdd_weak);
    }
}

double dep_run_first_step(dep_run *run)
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
                            run->stepper.floors, run->t_stop - s->t, run->scratch);
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
    run->friction_moved = 0;
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
    double *add = run->friction_move, *work = add + 2 * nq;
    memset(work, 0, (size_t)run->nd * sizeof *work);
    for (int i = 0, k = run->model->nd; i < nh; ++i) { /* each friction's work: -tau rate */
        if (system->hinges[i].has_friction) {
            work[k++] = -h * defect[i] * system->rates[i]; /* the middle's rates, from the law */
        }
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
    memcpy(add, move, 2 * (size_t)nq * sizeof *add);
    run->friction_moved = 1;
}

/* The rows' forces' profile's interpolation error over the step just taken (method/forces.c),
   weighted as interpolation_errors weighs the multipliers': e(t) = D prod_j (t - t_j) with D
   the divided difference of the accepted forces and the new state's Phi_q^T lambda_{i+1} moves
   the positions by h^2 integral (1 - s) |e| ds M^-1 D and the velocities by h integral |e| ds
   M^-1 D; the projection onto the rows' normal space keeps what of e acts along them, which
   the passes correct, so the positions' move is counted whole (as the multipliers' is) and
   the velocities' by its tangential part, which stays in the step. -1 when there is no
   divided difference yet (right after a start or an event). */
static double force_error(dep_run *run, const dep_outcome *outcome, const double *scale)
{
    const dep_profile *profile = &outcome->profile;
    int nq = run->nq, nc = run->cs.nc, nodes = profile->nodes;
    double h = profile->h, *table = run->scratch, *d = run->normal + 2 * nc;
    double *end = d + nq, *move = end + nq, *projection = move + 2 * nq;
    dep_cs_transpose_times(&run->cs, outcome->J1, outcome->state.lam, end);
    if (!dep_divided_difference(profile, &run->forces, end, d, table)) {
        return -1.0;
    }
    dep_mass_solve(&run->system.mass, d, end);
    double position = pow(h, nodes + 3) * profile->excursion;
    double velocity = pow(h, nodes + 2) * profile->drift;
    for (int j = 0; j < nq; ++j) {
        move[j] = position * end[j];
        move[nq + j] = velocity * end[j];
    }
    dep_stepper_use_mobility(&run->stepper, DEP_VELOCITY);
    dep_stepper_tangential(&run->stepper, outcome->J1, outcome->J1_id, move + nq, projection);
    dep_stepper_use_mobility(&run->stepper, DEP_POSITION);
    return dep_rms(move, scale, 2 * nq) * sqrt(2.0 * nq / run->ny);
}

/* The profile the next step takes (run->by_force_next), from the step just taken: near a
   singular position, where the multipliers grow as one over the distance to it and a
   polynomial misses them, the rows' forces' when their interpolation error is the smaller by
   far (FORCE_CONDITION ... FORCE_MARGIN), and after a step that took the forces' profile the
   same again; else the multipliers'. e->lam becomes the error of the profile this step
   took. */
static void choose_profile(dep_run *run, const dep_outcome *outcome, const double *scale,
                           dep_step_errors *e)
{
    const dep_multipliers *mp = &run->stepper.mp;
    int by_force = run->stepper.by_force;
    run->by_force_next = 0;
    if (run->cs.nc == 0 || run->stepper.implicit
        || (!by_force && (e->lam < e->ode || e->lam < FORCE_LEADS
                          || (mp->schur_factored && !(mp->schur_min_pivot < FORCE_CONDITION))))) {
        return;
    }
    double error = force_error(run, outcome, scale);
    if (error < 0.0) {
        return;
    }
    run->by_force_next = by_force || FORCE_MARGIN * error < e->lam;
    if (by_force) {
        e->lam = error;
        e->lam_order = outcome->profile.nodes + 2;
    }
}

/* An accepted step that prescribed the friction torques ends where the law's torques would
   have taken it, to the accuracy of the defect's estimate: its end moves by the tangential
   move e->friction measured (h^2 integral (1 - u) d in q, h integral d in qd, Mc^-1 J_h^T)
   and each friction's work by h integral d rate, and the law's torques at the moved end are
   the step's accepted ones. What is left is the estimate's own error, of higher order, as
   DOPRI keeps its fifth-order solution and controls the fourth's error: the run's error then
   falls in proportion to tol (docs/method.md, 4). */
static void add_friction_move(dep_run *run)
{
    if (!run->friction_moved) {
        return;
    }
    dep_state *end = &run->outcome.state;
    const double *add = run->friction_move;
    int nq = run->nq;
    for (int j = 0; j < nq; ++j) {
        end->q[j] += add[j];
        end->qd[j] += add[nq + j];
    }
    for (int k = 0; k < run->nd; ++k) {
        end->work[k] += add[2 * nq + k];
    }
    dep_friction_law(&run->system, end->q, end->qd, run->outcome.friction);
    run->friction_moved = 0;
}

#ifdef DEP_DUMP
static void dump_step(dep_run *run, const dep_outcome *outcome, const double *scale)
{
    static FILE *file = NULL;
    static int opened = 0;
    const dep_rk_step *rk = outcome->rk;
    const dep_implicit *im = &run->stepper.im;
    int nq = run->nq, nc = run->cs.nc;
    if (!opened) {
        const char *path = getenv("DEP_DUMP");
        opened = 1;
        file = path != NULL ? fopen(path, "wb") : NULL;
    }
    const char *from = getenv("DEP_DUMP_FROM"), *span = getenv("DEP_DUMP_SPAN");
    double t0 = from != NULL ? atof(from) : 3.0, t1 = t0 + (span != NULL ? atof(span) : 0.02);
    if (file == NULL || rk->method != DEP_ROSENBROCK || rk->t0 < t0 || rk->t0 >= t1) {
        return;
    }
    size_t n = (size_t)nq;
    double header[4] = {rk->t0, rk->h, (double)nq, (double)nc};
    double *dense = malloc(sizeof(double) * (2 * n * n + (size_t)nc * n + n + (size_t)nc));
    if (dense == NULL) {
        return;
    }
    fwrite(header, sizeof(double), 4, file);
    fwrite(rk->y1, sizeof(double), 2 * n, file);
    fwrite(scale, sizeof(double), n, file);
    fwrite(run->tangent, sizeof(double), 2 * n, file);
    fwrite(rk->error, sizeof(double), 2 * n, file);
    for (int a = 0; a < 2; ++a) { /* M, K from W's envelope (lower triangles, mirrored) */
        const double *values = a == 0 ? im->mass_envelope : im->K_envelope;
        for (int i = 0; i < nq; ++i) {
            for (int j = 0; j < nq; ++j) {
                int r = i > j ? i : j, c = i > j ? j : i;
                dense[(size_t)a * n * n + (size_t)i * n + j] =
                    c >= im->W.first[r] ? DEP_ENVELOPE_AT(&im->W, values, r, c) : 0.0;
            }
        }
    }
    double *rows = dense + 2 * n * n, *unit = rows + (size_t)nc * n;
    for (int i = 0; i < nc; ++i) { /* Phi_q's row i: J^T e_i */
        for (int k = 0; k < nc; ++k) {
            unit[k] = k == i;
        }
        dep_cs_transpose_times(&run->cs, outcome->J1, unit, rows + (size_t)i * n);
    }
    fwrite(dense, sizeof(double), 2 * n * n + (size_t)nc * n, file);
    fflush(file);
    free(dense);
}
#endif

/* The step's errors in tolerance units (1 = at tolerance; method/control.c). */
static void step_errors(dep_run *run, const dep_outcome *outcome, dep_step_errors *e)
{
    const dep_rk_step *rk = outcome->rk;
    double *scale = run->y;
    int nq = run->nq;
    dep_weights(rk->y0, rk->y1, run->ny, run->settings.tol, run->stepper.floors, scale);
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
#ifdef DEP_DUMP
    dump_step(run, outcome, scale);
#endif
    e->ode_order = rk->order;
    dep_stepper_use_mobility(&run->stepper, DEP_POSITION);
    interpolation_errors(run, outcome, scale, e);
    choose_profile(run, outcome, scale, e);
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

/* The most steps a run may take, counting the rejected and retried ones (settings.max_steps,
   0: DEP_MAX_STEPS). */
static double step_limit(const dep_run *run)
{
    return run->settings.max_steps > 0 ? run->settings.max_steps : DEP_MAX_STEPS;
}

static long long attempts(const dep_run *run)
{
    return run->tally.accepted + run->tally.rejected + run->tally.failed;
}

/* A run whose steps are all rejected or retried, however small, stops at max_steps too. */
static int attempts_spent(dep_run *run, double h)
{
    if ((double)attempts(run) < step_limit(run)) {
        return DEP_OK;
    }
    char what[400];
    snprintf(what, sizeof what, "max_steps = %.0f steps taken (%lld accepted, %lld rejected, "
             "%lld retried), the last tried at %.3g s", step_limit(run), run->tally.accepted,
             run->tally.rejected, run->tally.failed, h);
    return dep_solver_error(run->error, 1, run->state.t, "step size", NULL, NULL, 0, 0.0, what,
                            "raise max_steps (--max-steps), or shorten t_end");
}

/* After an accepted step of size h: a model with beams whose step a stiff mode holds at
   DOPRI's stability bound (Hairer's test, STIFF_STEPS steps with h |lambda| > STIFF_BOUND)
   goes on with the linearly implicit step (method/rosenbrock.c, docs/method.md, 10).
   Otherwise a run stops rather than grind when its steps would pass max_steps: at once when a
   stiff mode holds the step at the stability bound (DOPRI's, or the prescribed friction's:
   FRICTION_BOUND) and the steps left at this size would pass the limit; when the steps left
   at this size would pass it GRIND_FACTOR times over for GRIND_STEPS steps in a row; and when
   the limit is reached. */
static int step_budget(dep_run *run, double h)
{
    const dep_rk_step *rk = run->outcome.rk;
    const dep_state *s = &run->outcome.state;
    double limit = step_limit(run);
    double end = isfinite(run->settings.t_end) ? run->settings.t_end : run->t_stop;
    double taken = (double)attempts(run), span = end - s->t;
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
            run->profile_nodes = DEP_IMPLICIT_PROFILE_NODES;
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
        snprintf(what, sizeof what, "max_steps = %.0f steps taken (%lld accepted, %lld rejected, "
                 "%lld retried), with %.4g s left at steps of about %.3g s (%s moving most)",
                 limit, run->tally.accepted, run->tally.rejected, run->tally.failed, span, h,
                 moving_most(run, s->qd));
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
    dep_stepper *stepper = &run->stepper;
    dep_profile_set(&profile, &run->history, h, run->profile_nodes);
    dep_history_weights(&run->history, &profile, weights);
    dep_history_predict(&run->history, &profile, weights, run->predicted);
    stepper->by_force = run->by_force && !stepper->implicit && run->cs.nc > 0;
    if (stepper->by_force) { /* the rows' forces over the step (method/forces.c) */
        dep_forces *forces = &stepper->forces;
        dep_profile_share(&forces->profile, &profile, &run->forces);
        dep_forces_begin(forces, &run->cs, &run->state, h, run->prior.valid ? run->prior.qdd
                         : NULL, run->prior.valid ? run->state.t - run->prior.t : 0.0);
        dep_history_predict(&run->forces, &forces->profile, weights, run->force_now);
        dep_forces_multipliers(forces, &run->cs, &run->system.mass, run->force_now,
                               ++stepper->jacobian_ids, run->predicted);
    }
    if (run->system.n_friction == 0) {
        return dep_step(&run->stepper, &run->state, &profile, run->predicted, NULL, NULL,
                        outcome, failure);
    }
    dep_profile_share(&friction, &profile, &run->friction);
    dep_history_predict(&run->friction, &friction, weights, run->friction_predicted);
    return dep_step(&run->stepper, &run->state, &profile, run->predicted, &friction,
                    run->friction_predicted, outcome, failure);
}

/* A spatial hinge's angle is measured within half a turn of the middle of its travel
   (atan2); past that it reads a whole turn off. For a hinge whose spring, cable, latch or
   stops read it (dep_model.hinge_wraps), an accepted step in which its angle moved by more
   than half a turn against what its rates at the ends say (the trapezoid rule, whose error
   is of the step's third order) crossed there: the run stops with the hinge named, not with
   a torque or an event a turn off. */
static int turned_past(dep_run *run, const dep_state *start, const dep_state *end)
{
    const dep_model *m = run->model;
    if (run->n_wraps == 0) {
        return DEP_OK;
    }
    double *a0 = run->turns, *a1 = a0 + m->nh, *r0 = a1 + m->nh, *r1 = r0 + m->nh;
    m->hinge_angles(start->q, run->p, a0);
    m->hinge_angles(end->q, run->p, a1);
    m->hinge_rates(start->q, start->qd, run->p, r0);
    m->hinge_rates(end->q, end->qd, run->p, r1);
    double h = end->t - start->t;
    for (int i = 0; i < m->nh; ++i) {
        if (m->hinge_wraps[i] && fabs(a1[i] - a0[i] - 0.5 * h * (r0[i] + r1[i])) > DEP_PI) {
            char what[400];
            const double deg = 180.0 / DEP_PI;
            snprintf(what, sizeof what, "hinge %s turned more than half a turn from the middle "
                     "of its travel (about %.4g deg): its angle, measured within half a turn "
                     "of that, went from %.6g to %.6g deg in the step from t = %.9g s",
                     m->hinge_names[i], 0.5 * (a0[i] + a1[i]) * deg, a0[i] * deg, a1[i] * deg,
                     start->t);
            return dep_solver_error(run->error, 1, end->t, "hinge angle", NULL,
                                    m->hinge_names[i], 0, 0.0, what,
                                    "a spatial hinge is measured about the middle of its "
                                    "travel: between its initial angle and its latch, else "
                                    "between its stops, else about its initial angle; give "
                                    "it a latch or stops that bound where it turns (within "
                                    "half a turn of their middle)");
        }
    }
    return DEP_OK;
}

/* One accepted step from run->state into run->outcome; *h: in the size to try, out the next. */
int dep_run_advance(dep_run *run, double *h)
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
        int status = attempts_spent(run, *h);
        if (status != DEP_OK) {
            return status;
        }
        status = dep_run_step(run, *h, &run->outcome, &failure);
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
        TRACE("step t=%.17g h=%.17g ode=%.17g lam=%.17g fac=%.4g rho_fac=%.4g iterations "
              "%d %d %d integrations %d %s\n", run->state.t, *h, errors.ode, errors.lam, fac,
              dep_convergence_factor(&run->outcome.reports[0]),
              run->outcome.reports[0].iterations,
              run->outcome.reports[1].iterations, run->outcome.reports[2].iterations,
              run->outcome.integrations, accepted ? "accepted" : "rejected");
        if (accepted) {
            status = turned_past(run, &run->state, &run->outcome.state);
            if (status != DEP_OK) {
                return status;
            }
            run->force_steps += run->stepper.by_force;
            run->by_force = run->by_force_next;
            add_friction_move(run);
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
