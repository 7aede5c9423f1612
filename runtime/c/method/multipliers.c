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

#define REUSE_MARGIN 0.1 /* a nearby Jacobian's factor serves while what an update leaves falls
                            this far below the limit */

const char *const dep_stage_names[3] = {"position", "velocity", "acceleration"};

int dep_measurement_init(dep_measurement *m, const dep_model *model, int capacity, int ny,
                         int own_jacobian, dep_arena *arena)
{
    memset(m, 0, sizeof *m);
    m->v = dep_doubles(arena, (size_t)capacity);
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

static int fail(int stage, const dep_measurement *current, int nc, const char *reason,
                dep_failure *failure)
{
    int row = 0;
    for (int i = 0; i < nc; ++i) { /* np.argmax of |v|: the first NaN, else the largest */
        if (isnan(current->v[i])) {
            row = i;
            break;
        }
        row = fabs(current->v[i]) > fabs(current->v[row]) ? i : row;
    }
    failure->stage = stage;
    failure->row = row;
    failure->residual = fabs(current->v[row]);
    failure->scale = current->scale;
    dep_copy_text(failure->reason, sizeof failure->reason, reason);
    return DEP_PASS_FAILED;
}

static void report_error(dep_pass_report *report, double error)
{
    if (report->n_errors < DEP_MAX_ITERATIONS + 1) {
        report->errors[report->n_errors++] = error;
    }
}

/* Iterate (6) from lam (nc, updated in place) until max|v| <= tol * max(1, scale). The two
   slots hold the current and trial measurements; *final points at the last accepted one. */
int dep_iterate_multipliers(dep_multipliers *mp, int stage, double *lam, int nc,
                            dep_measure_function measure, void *context, double C, double tol,
                            dep_measurement *slots[2], dep_measurement **final,
                            dep_pass_report *report, dep_failure *failure)
{
    dep_measurement *current = slots[0], *trial = slots[1];
    char reason[120];
    memset(report, 0, sizeof *report);
    report->stage = stage;
    measure(context, lam, current);
    double error = dep_max_abs(current->v, nc);
    report_error(report, error);
    double limit = tol * fmax(1.0, current->scale);
    while (!(error <= limit)) {
        if (!isfinite(error)) {
            return fail(stage, current, nc, "the state or the forces became non-finite", failure);
        }
        if (report->iterations >= DEP_MAX_ITERATIONS) {
            snprintf(reason, sizeof reason, "not below %.2e after %d iterations", limit,
                     DEP_MAX_ITERATIONS);
            return fail(stage, current, nc, reason, failure);
        }
        /* a factor of a nearby Jacobian while its update still ends within the limit */
        dep_schur_form(mp, current->J, current->jacobian_id, nc,
                       fmin(DEP_SCHUR_REUSE, REUSE_MARGIN * limit / error));
        if (!dep_schur_solve_formed(mp, current->J, nc, current->v, mp->x,
                                    &report->cg_iterations)) {
            return fail(stage, current, nc, "the multiplier system S = Phi_q M^-1 Phi_q^T is "
                        "singular or inconsistent here (conjugate gradients did not converge)",
                        failure);
        }
        double trial_error = 0.0;
        int decreased = 0;
        for (int i = 0; i < nc; ++i) {
            mp->step[i] = 1.0 * mp->x[i] / C;
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
            measure(context, mp->trial_lam, trial);
            trial_error = dep_max_abs(trial->v, nc);
            decreased = trial_error < error;
        }
        if (!decreased) {
            return fail(stage, current, nc, "the error stopped decreasing", failure);
        }
        memcpy(lam, mp->trial_lam, (size_t)nc * sizeof *lam);
        dep_measurement *swap = current;
        current = trial;
        trial = swap;
        error = trial_error;
        report->iterations++;
        report_error(report, error);
        limit = tol * fmax(1.0, current->scale);
    }
    *final = current;
    return DEP_OK;
}
