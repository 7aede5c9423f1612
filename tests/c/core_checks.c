/* Checks of the integrator core's parts that a whole run does not expose, built with the core
 * sources and one generated model (tests/c/test_core_parts.py drives it):
 *
 *   core_checks iteration H      one step of size H from the initial state with the worst
 *                                prediction lambda_{i+1} = 0 at tol 1e-12: prints each
 *                                pass's error after every iteration of (6)
 *   core_checks fixed N T [TOL]  N fixed steps to T without step control (tol 1e-14 unless
 *                                given): prints the final q, then qd
 *   core_checks fixed_implicit N T [TOL]  the same with the linearly implicit step
 *   core_checks predictor N T TOL  N fixed steps to T with the predictor learning its miss and
 *                                without: prints each step's first position error both ways,
 *                                then the largest difference of the final states and the
 *                                passes' limit (constraint_tol)
 *   core_checks project NQ NC    reads M (NQ x NQ), J (NC x NQ) and qd (NQ) from stdin, prints
 *                                the plastic-impact projection of qd onto J qd+ = 0
 *   core_checks interpolant N    reads t_prior t0 t1, then (q, qd, qdd) at t0 and t1 and (qd,
 *                                qdd) at t_prior for one coordinate, then N times in [t0, t1];
 *                                prints q, qd on the step interpolant at each time, with the
 *                                prior point and without it
 *   core_checks interpolant N W  the same with the accelerations W (three of 0 or 1: at the
 *                                prior point, the start, the end) marked weak by a 1
 *   core_checks law F S          reads rates (rad/s) from stdin; prints the regularised
 *                                Coulomb law's torque and slope at each, for a sliding hinge
 *                                of friction F (N m) and slip rate S (rad/s)
 *   core_checks rows T           the model to T with every row column (DEP_ROWS_ALL) and with
 *                                the outputs' alone (DEP_ROWS_OUTPUTS): prints the largest
 *                                difference of the columns both keep, then the largest value
 *                                of those the second leaves nought
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "model.h"
#include "core/run/run.h"

typedef struct parts {
    dep_arena arena;
    dep_error error;
    dep_system system;
    dep_constraints cs;
    dep_stepper stepper;
    dep_history history;
    dep_state state;
    dep_outcome outcome;
} parts;

static int fail(const char *what)
{
    fprintf(stderr, "core_checks: %s\n", what);
    return 1;
}

/* The generated model at its defaults, its consistent initial state and lambda_0. */
static int start(parts *x, double tol)
{
    const dep_model *m = &depsim_model;
    dep_pass_report report;
    dep_failure failure;
    memset(x, 0, sizeof *x);
    if (dep_system_init(&x->system, m, m->parameter_defaults, 0, &x->arena, &x->error) != DEP_OK
        || dep_constraints_init(&x->cs, &x->system, &x->arena) != DEP_OK
        || dep_stepper_init(&x->stepper, &x->system, &x->cs, tol, &x->arena) != DEP_OK
        || dep_history_init(&x->history, x->cs.capacity, &x->arena) != DEP_OK
        || dep_state_init(&x->state, m->nq, x->cs.capacity, x->system.nd, &x->arena) != DEP_OK
        || dep_outcome_init(&x->outcome, m->nq, x->cs.capacity, x->system.nd, m->nh,
                            &x->arena)) {
        return fail("setup");
    }
    double *v = dep_doubles(&x->arena, (size_t)m->nv + 1);
    double *vd = dep_doubles(&x->arena, (size_t)m->nv + 1);
    if (x->arena.failed) {
        return fail("setup");
    }
    m->tree_values(m->parameter_defaults, v, vd);
    m->tree_pose(v, m->parameter_defaults, x->state.q);
    m->tree_tangent(v, vd, m->parameter_defaults, x->state.qd);
    dep_cs_jacobian(&x->cs, x->state.q, 0.0, x->stepper.restart_J);
    if (dep_acceleration(&x->stepper, x->state.q, x->state.qd, 0.0, x->state.lam,
                         x->stepper.restart_J, 1, x->state.qdd, &report, &failure) != DEP_OK) {
        return fail("acceleration pass");
    }
    dep_history_reset(&x->history, 0.0, x->state.lam, x->cs.nc);
    return 0;
}

static int iteration(double h)
{
    parts x;
    dep_failure failure;
    if (start(&x, 1e-12) != 0) {
        return 1;
    }
    double *zero = calloc((size_t)x.cs.capacity, sizeof *zero);
    dep_profile profile;
    dep_profile_set(&profile, &x.history, h, DEP_PROFILE_NODES);
    if (zero == NULL
        || dep_step(&x.stepper, &x.state, &profile, zero, NULL, NULL, &x.outcome, &failure)
               != DEP_OK) {
        return fail("step");
    }
    for (int k = 0; k < 3; ++k) {
        const dep_pass_report *r = &x.outcome.reports[k];
        printf("%s %d", dep_stage_names[r->stage], r->iterations);
        for (int i = 0; i < r->n_errors; ++i) {
            printf(" %.17g", r->errors[i]);
        }
        printf("\n");
    }
    printf("constraint_tol %.17g\n", x.stepper.constraint_tol);
    free(zero);
    dep_arena_free(&x.arena);
    return 0;
}

/* n fixed steps to t_end at tol, the predictor learning its miss as a run's does (learn) or
   not; implicit: with the linearly implicit step and its quadratic profile (the model's T is
   then whatever stiff forces it has, none for a rigid one), which keeps K, D and W over up to
   DEP_JACOBIAN_AGE steps of the same size. first (n, or NULL): each step's first position
   error, that of the predicted lambda_{i+1}. Leaves the final state in x. */
static int steps(parts *x, int n, double t_end, double tol, int implicit, int learn,
                 double *first)
{
    dep_failure failure;
    int nq = depsim_model.nq, nodes = implicit ? 2 : DEP_PROFILE_NODES;
    if (start(x, tol) != 0) {
        return 1;
    }
    if (implicit) {
        if (dep_stepper_prepare_implicit(&x->stepper, &x->arena) != DEP_OK) {
            return fail("implicit setup");
        }
        x->stepper.implicit = 1;
    }
    double h = t_end / n, *predicted = calloc((size_t)x->cs.capacity, sizeof *predicted);
    if (predicted == NULL) {
        return fail("memory");
    }
    for (int k = 0; k < n; ++k) {
        dep_profile profile;
        double weights[DEP_HISTORY];
        dep_profile_set(&profile, &x->history, h, nodes);
        dep_history_weights(&x->history, &profile, weights);
        dep_history_predict(&x->history, &profile, weights, predicted);
        if (dep_step(&x->stepper, &x->state, &profile, predicted, NULL, NULL, &x->outcome,
                     &failure)
            != DEP_OK) {
            fprintf(stderr, "core_checks: step %d, %s pass: %s\n", k,
                    dep_stage_names[failure.stage], failure.reason);
            free(predicted);
            return 1;
        }
        if (first != NULL) {
            first[k] = x->outcome.reports[0].errors[0];
        }
        dep_state_copy(&x->state, &x->outcome.state, nq, x->cs.nc, x->system.nd);
        if (learn) {
            dep_history_learn(&x->history, h, predicted, x->stepper.lam_first);
        }
        dep_history_add(&x->history, x->state.t, x->state.lam);
    }
    free(predicted);
    return 0;
}

static int fixed(int n, double t_end, double tol, int implicit)
{
    parts x;
    int nq = depsim_model.nq;
    if (steps(&x, n, t_end, tol, implicit, 1, NULL) != 0) {
        return 1;
    }
    for (int j = 0; j < 2 * nq; ++j) {
        printf("%.17g%s", j < nq ? x.state.q[j] : x.state.qd[j - nq], j + 1 < 2 * nq ? " " : "\n");
    }
    dep_arena_free(&x.arena);
    return 0;
}

/* n fixed steps to t_end at tol, with the predictor learning its miss and without: prints each
   step's first position error (that of the predicted lambda_{i+1}) both ways, a line a step,
   then the largest difference of the final states and the passes' limit. */
static int predictor(int n, double t_end, double tol)
{
    parts learned, plain;
    int nq = depsim_model.nq;
    double *first = calloc(2 * (size_t)n, sizeof *first);
    if (first == NULL) {
        return fail("memory");
    }
    if (steps(&learned, n, t_end, tol, 0, 1, first) != 0
        || steps(&plain, n, t_end, tol, 0, 0, first + n) != 0) {
        free(first);
        return 1;
    }
    for (int k = 0; k < n; ++k) {
        printf("%.17g %.17g\n", first[k], first[n + k]);
    }
    double most = 0.0;
    for (int j = 0; j < nq; ++j) {
        most = fmax(most, fabs(learned.state.q[j] - plain.state.q[j]));
        most = fmax(most, fabs(learned.state.qd[j] - plain.state.qd[j]));
    }
    printf("%.17g %.17g\n", most, learned.stepper.constraint_tol);
    free(first);
    dep_arena_free(&learned.arena);
    dep_arena_free(&plain.arena);
    return 0;
}

/* ---- the projection, on a mass matrix and Jacobian read from stdin ------------------------ */

static double *read_numbers(int n)
{
    double *v = malloc((size_t)n * sizeof *v);
    for (int i = 0; v != NULL && i < n; ++i) {
        if (scanf("%lf", &v[i]) != 1) {
            free(v);
            return NULL;
        }
    }
    return v;
}

static const double *given_mass;
static int given_nq;

static void mass_matrix(const double *p, double *M)
{
    (void)p;
    memcpy(M, given_mass, (size_t)given_nq * (size_t)given_nq * sizeof *M);
}

static void unit_scales(const double *p, double *s)
{
    (void)p;
    for (int j = 0; j < given_nq; ++j) {
        s[j] = 1.0; /* the test's coordinates are of unit size */
    }
}

static int project(int nq, int nc)
{
    double *M = read_numbers(nq * nq), *J = read_numbers(nc * nq), *qd = read_numbers(nq);
    if (M == NULL || J == NULL || qd == NULL) {
        return fail("bad input");
    }
    given_mass = M;
    given_nq = nq;
    int *every_row = calloc((size_t)nq * (size_t)nq, sizeof *every_row);
    int *every_col = calloc((size_t)nq * (size_t)nq, sizeof *every_col);
    for (int k = 0; every_row != NULL && every_col != NULL && k < nq * nq; ++k) {
        every_row[k] = k / nq; /* M given whole: its pattern is every entry */
        every_col[k] = k % nq;
    }
    dep_model model = {.abi = DEP_MODEL_ABI, .name = "projection", .nq = nq, .nc = nc,
                       .nnz = nc * nq, .nmz = nq * nq, .mass_rows = every_row,
                       .mass_cols = every_col, .mass_matrix = mass_matrix,
                       .coordinate_scales = unit_scales};
    parts x;
    memset(&x, 0, sizeof x);
    dep_constraints cs; /* the rows' pattern: every coordinate, so J is its own storage */
    memset(&cs, 0, sizeof cs);
    cs.system = &x.system;
    cs.nq = nq;
    cs.nc = cs.nc_module = nc;
    int *start = calloc((size_t)nc + 1, sizeof *start);
    int *cols = calloc((size_t)nc * (size_t)nq, sizeof *cols);
    for (int i = 0; i <= nc; ++i) {
        start[i] = i * nq;
    }
    for (int k = 0; k < nc * nq; ++k) {
        cols[k] = k % nq;
    }
    cs.row_start = start;
    cs.row_cols = cols;
    dep_multipliers mp;
    dep_measurement slots[2], *pair[2] = {&slots[0], &slots[1]};
    dep_pass_report report;
    dep_failure failure;
    double *phi_t = calloc((size_t)nc, sizeof *phi_t), *mu = calloc((size_t)nc, sizeof *mu);
    double *out = calloc((size_t)nq, sizeof *out);
    if (dep_system_init(&x.system, &model, NULL, 0, &x.arena, &x.error) != DEP_OK
        || dep_multipliers_init(&mp, &x.system.mass, &cs, nc, &x.arena) != DEP_OK
        || dep_measurement_init(&slots[0], &model, nc, 0, 0, &x.arena) != DEP_OK
        || dep_measurement_init(&slots[1], &model, nc, 0, 0, &x.arena) != DEP_OK
        || phi_t == NULL || mu == NULL || out == NULL || start == NULL || cols == NULL
        || every_row == NULL || every_col == NULL) {
        return fail("setup");
    }
    if (dep_project_velocity(&mp, J, 1, nc, qd, phi_t, 1e-14, out, mu, pair, &report,
                             &failure) != DEP_OK) {
        return fail(failure.reason);
    }
    for (int j = 0; j < nq; ++j) {
        printf("%.17g%s", out[j], j + 1 < nq ? " " : "\n");
    }
    printf("iterations %d\n", report.iterations);
    free(M), free(J), free(qd), free(phi_t), free(mu), free(out), free(start), free(cols);
    free(every_row), free(every_col);
    dep_arena_free(&x.arena);
    return 0;
}

/* ---- the step interpolant ------------------------------------------------------------------ */

static int interpolant(int n, const char *weak)
{
    double *given = read_numbers(3 + 8 + n), data[DEP_INTERPOLANT_ROWS + DEP_INTERPOLANT_TAIL];
    double with[2], without[2];
    if (given == NULL) {
        return fail("bad input");
    }
    double t_prior = given[0], t0 = given[1], h = given[2] - given[1];
    const double *v = given + 3, *times = given + 11;
    dep_interpolant_data(h, &v[0], &v[1], &v[2], weak[1] == '1', &v[3], &v[4], &v[5],
                         weak[2] == '1', 1, data);
    for (int k = 0; k < n; ++k) {
        dep_interpolate(data, t0, h, 1, times[k], &without[0], &without[1]);
        dep_interpolant_prior(data, 1, h, t0 - t_prior, &v[6], &v[7], weak[0] == '1');
        dep_interpolate(data, t0, h, 1, times[k], &with[0], &with[1]);
        data[DEP_INTERPOLANT_ROWS] = 0.0;
        printf("%.17g %.17g %.17g %.17g\n", with[0], with[1], without[0], without[1]);
    }
    free(given);
    return 0;
}

static double largest_difference(const double *a, const double *b, size_t n)
{
    double most = 0.0;
    for (size_t i = 0; i < n; ++i) {
        double d = fabs(a[i] - b[i]);
        most = d > most || (d != d && a[i] == a[i]) ? d : most; /* (NaN in both: equal) */
    }
    return most;
}

static int rows(double t_end)
{
    const dep_model *m = &depsim_model;
    dep_result all, lean;
    dep_error error;
    dep_settings settings = dep_default_settings(m);
    settings.t_end = t_end;
    if (dep_simulate(m, NULL, &settings, NULL, 0, &all, &error) != DEP_OK) {
        return fail(error.message);
    }
    settings.rows = DEP_ROWS_OUTPUTS;
    if (dep_simulate(m, NULL, &settings, NULL, 0, &lean, &error) != DEP_OK) {
        return fail(error.message);
    }
    size_t n = (size_t)all.n;
    double kept = fabs((double)all.n - (double)lean.n);
    kept = fmax(kept, largest_difference(all.times, lean.times, n));
    kept = fmax(kept, largest_difference(all.outputs, lean.outputs, n * (size_t)all.nout));
    kept = fmax(kept, largest_difference(all.lam, lean.lam, n * (size_t)all.n_rows));
    kept = fmax(kept, largest_difference(all.hinge_torque, lean.hinge_torque, n * (size_t)all.nh));
    kept = fmax(kept, largest_difference(all.dissipated, lean.dissipated, n * (size_t)all.nd));
    double *zero = calloc(n * (size_t)(all.nq + all.nh + all.ne) + 1, sizeof *zero), left = 0.0;
    if (zero == NULL) {
        return fail("out of memory");
    }
    left = fmax(left, largest_difference(lean.q, zero, n * (size_t)all.nq));
    left = fmax(left, largest_difference(lean.qd, zero, n * (size_t)all.nq));
    left = fmax(left, largest_difference(lean.hinge_angles, zero, n * (size_t)all.nh));
    left = fmax(left, largest_difference(lean.energy, zero, n * (size_t)all.ne));
    left = fmax(left, largest_difference(lean.residual_pos, zero, n));
    printf("%.17g %.17g\n", kept, left);
    free(zero);
    dep_result_free(&all);
    dep_result_free(&lean);
    return 0;
}

static int law(double friction, double slip_rate)
{
    dep_hinge_mechanics h;
    memset(&h, 0, sizeof h);
    h.has_friction = 1;
    h.kinetic = friction;
    h.slip_rate = slip_rate;
    h.latch_state = DEP_OPEN;
    h.stop = DEP_STOP_NONE;
    double rate;
    while (scanf("%lf", &rate) == 1) {
        printf("%.17g %.17g\n", dep_friction_torque(&h, rate), dep_friction_slope(&h, rate));
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc == 3 && strcmp(argv[1], "rows") == 0) {
        return rows(atof(argv[2]));
    }
    if (argc == 3 && strcmp(argv[1], "iteration") == 0) {
        return iteration(atof(argv[2]));
    }
    if ((argc == 4 || argc == 5) && strcmp(argv[1], "fixed") == 0) {
        return fixed(atoi(argv[2]), atof(argv[3]), argc == 5 ? atof(argv[4]) : 1e-14, 0);
    }
    if ((argc == 4 || argc == 5) && strcmp(argv[1], "fixed_implicit") == 0) {
        return fixed(atoi(argv[2]), atof(argv[3]), argc == 5 ? atof(argv[4]) : 1e-14, 1);
    }
    if (argc == 5 && strcmp(argv[1], "predictor") == 0) {
        return predictor(atoi(argv[2]), atof(argv[3]), atof(argv[4]));
    }
    if (argc == 4 && strcmp(argv[1], "project") == 0) {
        return project(atoi(argv[2]), atoi(argv[3]));
    }
    if (argc == 4 && strcmp(argv[1], "law") == 0) {
        return law(atof(argv[2]), atof(argv[3]));
    }
    if ((argc == 3 || (argc == 4 && strlen(argv[3]) == 3))
        && strcmp(argv[1], "interpolant") == 0) {
        return interpolant(atoi(argv[2]), argc == 4 ? argv[3] : "000");
    }
    return fail("usage: core_checks iteration H | fixed N T [TOL] | fixed_implicit N T [TOL] | "
                "predictor N T TOL | project NQ NC | law F S | interpolant N [WEAK] | rows T");
}
