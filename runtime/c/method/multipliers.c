/* multipliers.c: the accelerated multiplier iteration, the paper's eq. (6):
 *
 *     lambda^m = lambda^{m-1} - alpha * A v^{m-1} / C
 *
 * v is one level's constraint error, C that level's sensitivity to lambda_{i+1}, A ~ S^-1
 * with S = Phi_q G Phi_q^T (schur.c). The constraint system itself is never solved: A only
 * preconditions the iteration, which measures the error and corrects. The step is halved while
 * a trial does not reduce max|v| (docs/method.md, 2; method.h).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "method.h"

/* An update by a nearby Jacobian's factor that leaves more than this of the error: the
   Jacobian's own factor for the rest of the pass. */
#define SLOW_CONTRACTION 0.01
#define REUSE_MARGIN 0.1 /* a nearby Jacobian's factor serves while what an update leaves falls
                            this far below the limit */
/* A residual within this many DEP_EPS of the size of the terms it is computed from is at the
   level of their round-off: a pass that stalls there has converged as far as double precision
   resolves the rows at this state. (Each term passes a handful of operations, each rounding by
   DEP_EPS relative, on the way from lambda to v: the force J^T lambda, M^-1, the step's sums,
   Phi or J x.) */
#define ROUNDOFF_TERMS 64
/* S's condition (1 / its smallest relative pivot) from which a pass that fails is said to fail
   for it: the update's first-order miss, magnified this much, no longer contracts. */
#define ILL_CONDITIONED 1e8

const char *const dep_stage_names[3] = {"position", "velocity", "acceleration"};

int dep_measurement_init(dep_measurement *m, const dep_model *model, int capacity, int ny,
                         int own_jacobian, dep_arena *arena)
{
    memset(m, 0, sizeof *m);
    m->v = dep_doubles(arena, (size_t)capacity);
    m->size = dep_doubles(arena, (size_t)capacity);
    m->magnitude = dep_doubles(arena, (size_t)capacity);
    m->x = dep_doubles(arena, (size_t)model->nq);
    if (own_jacobian) {
        m->J_own = dep_doubles(arena, DEP_JACOBIAN_SIZE(model));
        m->J = m->J_own;
    }
    if (ny > 0 && dep_rk_init(&m->rk, ny, arena) != DEP_OK) {
        return DEP_MEMORY_ERROR;
    }
    return arena->failed ? DEP_MEMORY_ERROR : DEP_OK;
}

void dep_pass_magnitude(dep_multipliers *mp, const double *J, int nc, const double *lam,
                        double c, const double *x, const double *b, double *magnitude)
{
    int nq = mp->nq;
    double *force = mp->column, *moved = mp->work;
    dep_cs_abs_transpose_times(mp->cs, J, lam, force);
    dep_mass_solve(mp->mass, force, moved);
    for (int j = 0; j < nq; ++j) {
        moved[j] = fabs(x[j]) + c * fabs(moved[j]);
    }
    dep_cs_abs_times(mp->cs, J, moved, magnitude);
    memset(force, 0, (size_t)nq * sizeof *force);
    for (int i = 0; b != NULL && i < nc; ++i) {
        magnitude[i] += fabs(b[i]);
    }
}

/* max_i |v_i| / size_i, the error in units of each row's size (NaN kept); the row in *row.
   With null vectors n of S at hand (a singular position, redundant rows: dep_schur_nulls), v
   less its part along them, n (n . v): no multiplier reaches that part (docs/method.md, 2). */
/* The round-off level of the rows' residuals: ROUNDOFF_TERMS eps of their largest term, times
   sqrt(nc) for the update's solve with S, which couples the nc rows and sums their roundings
   (which grow as the square root of their number; the accordion's fully latched array, 39
   rows, stalls at 86 eps of its largest term). */
static double roundoff_level(const dep_measurement *m, int nc)
{
    return ROUNDOFF_TERMS * DEP_EPS * sqrt((double)nc) * dep_max_abs(m->magnitude, nc);
}

static double relative_error(const dep_multipliers *mp, const dep_measurement *m, int nc,
                             int *row)
{
    double worst = 0.0, *v = mp->range;
    memcpy(v, m->v, (size_t)nc * sizeof *v);
    dep_schur_deflate(mp, nc, v);
    *row = 0;
    for (int i = 0; i < nc; ++i) {
        double a = fabs(v[i]), r = a == 0.0 ? 0.0 : a / m->size[i];
        if (isnan(r) || r > worst) {
            worst = r;
            *row = i;
            if (isnan(r)) {
                break;
            }
        }
    }
    return worst;
}

/* The largest part of the positions' residual along a null vector of S, in tol units of the
   rows it spans: (n . v) / (tol sum_i |n_i| size_i). Consistent rows leave it second-order
   small; above 1, the constraints cannot all hold here. */
static double inconsistency(const dep_multipliers *mp, const dep_measurement *m, int nc,
                            double tol)
{
    double worst = 0.0;
    for (int k = 0; k < mp->n_nulls; ++k) {
        const double *n = mp->nulls + (size_t)k * (size_t)nc;
        double dot = 0.0, size = 0.0;
        for (int i = 0; i < nc; ++i) {
            dot += n[i] * m->v[i];
            size += fabs(n[i]) * m->size[i];
        }
        worst = fmax(worst, fabs(dot) / (tol * size));
    }
    return worst;
}

static int fail(const dep_multipliers *mp, int stage, const dep_measurement *current, int nc,
                double tol, int sized, int inconsistent, const char *reason,
                dep_failure *failure)
{
    int row = 0;
    double error = relative_error(mp, current, nc, &row);
    memset(failure, 0, sizeof *failure);
    failure->stage = stage;
    failure->row = row;
    failure->residual = fabs(current->v[row]);
    failure->limit = tol * current->size[row];
    failure->roundoff = sized ? roundoff_level(current, nc) : 0.0;
    failure->rows = nc;
    failure->rank = nc - (mp->schur_factored ? mp->schur_dropped : 0);
    failure->weak_row = mp->schur_factored ? mp->schur_min_row : -1;
    failure->condition = mp->schur_factored && mp->schur_min_pivot > 0.0
                         ? 1.0 / mp->schur_min_pivot : 0.0;
    if (!isfinite(error)) {
        failure->kind = DEP_FAILED_NONFINITE;
    } else if (inconsistent && mp->weak_nulls == 0) {
        /* (along a weak row's combination it is a singular position's: ill-conditioned) */
        failure->kind = DEP_FAILED_INCONSISTENT;
    } else if (failure->condition >= ILL_CONDITIONED) {
        failure->kind = DEP_FAILED_CONDITION;
    } else {
        failure->kind = DEP_FAILED_NONLINEAR;
    }
    dep_copy_text(failure->reason, sizeof failure->reason, reason);
    return DEP_PASS_FAILED;
}

static void report_error(dep_pass_report *report, double error)
{
    if (report->n_errors < DEP_MAX_ITERATIONS + 1) {
        report->errors[report->n_errors++] = error;
    }
}

/* out = K v (transposed: K^T v): S^-1 v / C by S's factor for `allowed` (dep_schur_form) and
   the pass's secant corrections u_k z_k^T; 0 when S could not be solved. */
static int step_for(dep_multipliers *mp, const dep_measurement *current, int nc, double C,
                    double allowed, int transposed, const double *v, double *out,
                    dep_pass_report *report)
{
    dep_schur_form(mp, current->J, current->jacobian_id, nc, allowed);
    dep_schur_nulls(mp, nc);
    if (v != out) {
        memcpy(out, v, (size_t)nc * sizeof *out);
    }
    dep_schur_deflate(mp, nc, out);
    if (!dep_schur_solve_formed(mp, current->J, nc, out, out, &report->cg_iterations)) {
        return 0;
    }
    dep_schur_deflate(mp, nc, out);
    for (int i = 0; i < nc; ++i) {
        out[i] /= C;
    }
    for (int k = 0; k < mp->secants; ++k) {
        const double *u = mp->secant_u + (size_t)k * (size_t)nc;
        const double *z = mp->secant_w + (size_t)k * (size_t)nc;
        const double *along = transposed ? u : z, *onto = transposed ? z : u;
        double dot = 0.0;
        for (int i = 0; i < nc; ++i) {
            dot += along[i] * v[i];
        }
        for (int i = 0; i < nc; ++i) {
            out[i] += dot * onto[i];
        }
    }
    return 1;
}

/* 1 when it learned the secant condition for the step just taken, mp->step, which reduced the residual by
   y = current->v - trial->v: K y = step, by Broyden's first ("good") update, K += (step - K y)
   step^T K / (step^T K y). K = S^-1 / C is the first-order model; what it misses near a
   singular position (the Jacobian along the step differs from its end's in the weak
   direction, where the update then overshoots or turns away) the corrections learn. */
static int learn_secant(dep_multipliers *mp, const dep_measurement *current,
                        const dep_measurement *trial, int nc, double C, double allowed,
                        dep_pass_report *report)
{
    if (mp->secants == DEP_SECANTS) {
        return 0;
    }
    double *y = mp->secant_y, *u = mp->secant_u + (size_t)mp->secants * (size_t)nc;
    double *z = mp->secant_w + (size_t)mp->secants * (size_t)nc, sKy = 0.0;
    for (int i = 0; i < nc; ++i) {
        y[i] = current->v[i] - trial->v[i];
    }
    if (!step_for(mp, current, nc, C, allowed, 0, y, u, report)
        || !step_for(mp, current, nc, C, allowed, 1, mp->step, z, report)) {
        return 0;
    }
    for (int i = 0; i < nc; ++i) {
        sKy += mp->step[i] * u[i];
    }
    if (!(fabs(sKy) > 0.0) || !isfinite(sKy)) {
        return 0;
    }
    for (int i = 0; i < nc; ++i) {
        u[i] = mp->step[i] - u[i];
        z[i] /= sKy;
    }
    mp->secants++;
    return 1;
}

/* One update of (6) from lam: the step K v (step_for), halved while the trial does not reduce
   the error, into mp->step, mp->trial_lam and `trial` (its error in *trial_error); 1 when it
   reduced the error, 0 when not, -1 when S could not be solved. */
static int update(dep_multipliers *mp, const double *lam, int nc, dep_measure_function measure,
                  void *context, double C, const dep_measurement *current, double error,
                  double allowed, dep_measurement *trial, double *trial_error,
                  dep_pass_report *report)
{
    int decreased = 0, row;
    if (!step_for(mp, current, nc, C, allowed, 0, current->v, mp->step, report)) {
        return -1;
    }
    for (int halving = 0; halving <= DEP_MAX_HALVINGS && !decreased; ++halving) {
        if (halving > 0) {
            for (int i = 0; i < nc; ++i) {
                mp->step[i] = 0.5 * mp->step[i];
            }
        }
        for (int i = 0; i < nc; ++i) {
            mp->trial_lam[i] = lam[i] - mp->step[i];
        }
        dep_schur_deflate(mp, nc, mp->trial_lam); /* the minimum-norm multipliers */
        measure(context, mp->trial_lam, 0, trial);
        *trial_error = relative_error(mp, trial, nc, &row);
        decreased = *trial_error < error;
    }
    return decreased;
}

/* 1 when at lam every row's residual is within tol of its size or at the round-off of the
   terms the residuals are computed from (current measured anew, sized). The largest terms set
   every row's round-off: the update solves with S, which couples the rows, so what rounds off
   in one row's huge multiplier (near a singular position) spreads to the others. */
static int at_roundoff(dep_multipliers *mp, dep_measure_function measure, void *context,
                       const double *lam, int nc, double tol, dep_measurement *current)
{
    int row;
    measure(context, lam, 1, current);
    relative_error(mp, current, nc, &row); /* (its range part into mp->range) */
    double roundoff = roundoff_level(current, nc);
    for (int i = 0; i < nc; ++i) {
        double v = fabs(mp->range[i]);
        if (!(v <= tol * current->size[i] || v <= roundoff)) {
            return 0;
        }
    }
    return 1;
}

/* Iterate (6) from lam (nc, updated in place) until every row's residual is within tol of its
   size, |v_i| <= tol size_i, or the iteration stalls at the round-off of the rows' terms. The
   two slots hold the current and trial measurements; *final points at the last accepted one. */
int dep_iterate_multipliers(dep_multipliers *mp, int stage, double *lam, int nc,
                            dep_measure_function measure, void *context, double C, double tol,
                            dep_measurement *slots[2], dep_measurement **final,
                            dep_pass_report *report, dep_failure *failure)
{
    dep_measurement *current = slots[0], *trial = slots[1];
    char reason[120];
    int row;
    memset(report, 0, sizeof *report);
    report->stage = stage;
    measure(context, lam, 0, current);
    if (mp->n_nulls > 0) { /* near a singular position: S's null vectors here */
        dep_schur_form(mp, current->J, current->jacobian_id, nc, 0.0);
        dep_schur_nulls(mp, nc);
    }
    double error = relative_error(mp, current, nc, &row);
    report_error(report, error);
    int exact = 0; /* 1: only the factor of each Jacobian itself */
    mp->secants = 0;
    while (!(error <= tol)) {
        if (!isfinite(error)) {
            return fail(mp, stage, current, nc, tol, 0, 0, "the state or the forces became "
                        "non-finite", failure);
        }
        int status = -2; /* -2: the iterations are spent */
        double trial_error = 0.0;
        double allowed = exact ? 0.0 : fmin(DEP_SCHUR_REUSE, REUSE_MARGIN * tol / error);
        if (report->iterations < DEP_MAX_ITERATIONS) {
            /* a factor of a nearby Jacobian while its update still ends within the limit;
               once one does not contract the error by SLOW_CONTRACTION (an ill-conditioned S
               magnifies the difference), the factor of this Jacobian itself */
            status = update(mp, lam, nc, measure, context, C, current, error, allowed, trial,
                            &trial_error, report);
            if (status >= 0 && !mp->schur_exact && !(trial_error <= SLOW_CONTRACTION * error)) {
                exact = 1;
                allowed = 0.0;
                if (status == 0) {
                    status = update(mp, lam, nc, measure, context, C, current, error, 0.0,
                                    trial, &trial_error, report);
                }
            }
            while (status == 0 && learn_secant(mp, current, trial, nc, C, allowed, report)) {
                /* what the last trial showed corrects the step: once more with it */
                status = update(mp, lam, nc, measure, context, C, current, error, allowed,
                                trial, &trial_error, report);
            }
        }
        if (status == -1) {
            return fail(mp, stage, current, nc, tol, 0, 0, "the multiplier system S = Phi_q M^-1 "
                        "Phi_q^T could not be solved here (conjugate gradients did not "
                        "converge)", failure);
        }
        if (status != 1) { /* stalled: converged as far as round-off allows, or failed */
            if (at_roundoff(mp, measure, context, lam, nc, tol, current)) {
                report->roundoff = 1;
                break;
            }
            if (status == 0) {
                return fail(mp, stage, current, nc, tol, 1, 0, "the error stopped decreasing",
                            failure);
            }
            snprintf(reason, sizeof reason, "not within tol after %d iterations",
                     DEP_MAX_ITERATIONS);
            return fail(mp, stage, current, nc, tol, 1, 0, reason, failure);
        }
        /* in the acceleration pass, the factor of this Jacobian itself contracting by less
           than SLOW_CONTRACTION: the residual is near the round-off of the rows' terms (a
           chain of hundreds of spatial bodies), where further updates and secants only
           wander: looked at below. (The position and velocity passes go on while they gain:
           near a dead point their round-off level, set by the multipliers' large terms, is
           above what the branch's positions are held to.) */
        int slow_exact = stage == DEP_ACCELERATION && mp->schur_exact
                         && trial_error > SLOW_CONTRACTION * error;
        if (!(trial_error <= tol) && trial_error > SLOW_CONTRACTION * error && !slow_exact) {
            learn_secant(mp, current, trial, nc, C, allowed, report); /* a slow contraction */
        }
        memcpy(lam, mp->trial_lam, (size_t)nc * sizeof *lam);
        dep_measurement *swap = current;
        current = trial;
        trial = swap;
        error = trial_error;
        report->iterations++;
        report_error(report, error);
        if (slow_exact && !(error <= tol)
            && at_roundoff(mp, measure, context, lam, nc, tol, current)) {
            report->roundoff = 1;
            break;
        }
    }
    if (stage == DEP_POSITION && mp->n_nulls > 0 && !(inconsistency(mp, current, nc, tol) <= 1.0)) {
        snprintf(reason, sizeof reason, "the rows' residual along a combination no multiplier "
                 "reaches is %.3g tol", inconsistency(mp, current, nc, tol));
        return fail(mp, stage, current, nc, tol, 0, 1, reason, failure);
    }
    report->residual = dep_max_abs(current->v, nc);
    *final = current;
    return DEP_OK;
}
