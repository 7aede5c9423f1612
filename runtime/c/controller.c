/* controller.c: step size control and the multiplier predictor (docs/method.md, 3-4).
 *
 * The new step h_new = fac h combines the error of the multiplier interpolation (~h^4) with
 * the ODE method's own error (~h^5), both in the weighted RMS norm (1: at tolerance); a step
 * is accepted when err_lam + err_ode <= 1 and fac solves
 * err_lam fac^4 + err_ode fac^5 = SAFETY, clipped to [FAC_MIN, FAC_MAX].
 */
#include <math.h>
#include <string.h>

#include "runtime.h"

#define SAFETY 0.6
#define FAC_MIN 0.2
#define FAC_MAX 5.0
#define INTERPOLATION_ORDER 4
#define ERROR_ORDER 5
#define RHO_TARGET 0.2 /* wanted contraction rate of the position pass */

/* 3-point Gauss-Legendre on [0, 1] for integral (1 - s) f(s) ds, as numpy's leggauss gives
   them (3-point Gauss-Legendre on [0, 1]). */
static const double NODES[3] = {0.1127016653792583, 0.5, 0.8872983346207417};
static const double WEIGHTS[3] = {0.24647175961687276, 0.2222222222222222,
                                  0.03130601816090509};

void dep_weights(const double *y0, const double *y1, int n, double tol, double *scale)
{
    for (int i = 0; i < n; ++i) {
        scale[i] = tol * (1.0 + fmax(fabs(y0[i]), fabs(y1[i])));
    }
}

double dep_rms(const double *x, const double *scale, int n)
{
    double sum = 0.0;
    if (n == 0) {
        return 0.0;
    }
    for (int i = 0; i < n; ++i) {
        double ratio = x[i] / scale[i];
        sum += ratio * ratio;
    }
    return sqrt(sum / n);
}

/* ---- the multiplier history and predictor ----------------------------------------------- */

int dep_history_init(dep_history *history, int capacity, dep_arena *arena)
{
    memset(history, 0, sizeof *history);
    for (int k = 0; k < DEP_HISTORY; ++k) {
        history->lam[k] = dep_doubles(arena, (size_t)capacity);
    }
    return arena->failed ? DEP_MEMORY_ERROR : DEP_OK;
}

void dep_history_reset(dep_history *history, double t, const double *lam, int nc)
{
    history->count = 1;
    history->nc = nc;
    history->t[0] = t;
    memcpy(history->lam[0], lam, (size_t)nc * sizeof *lam);
}

void dep_history_add(dep_history *history, double t, const double *lam)
{
    if (history->count == DEP_HISTORY) { /* drop the oldest (deque maxlen) */
        double *oldest = history->lam[0];
        for (int k = 1; k < DEP_HISTORY; ++k) {
            history->t[k - 1] = history->t[k];
            history->lam[k - 1] = history->lam[k];
        }
        history->lam[DEP_HISTORY - 1] = oldest;
        history->count--;
    }
    history->t[history->count] = t;
    memcpy(history->lam[history->count], lam, (size_t)history->nc * sizeof *lam);
    history->count++;
}

/* The position pass's starting lambda_{i+1} for a step ending at t: lambda_i +
   6 integral_0^1 (1 - s)(lambda(t_i + s h) - lambda_i) ds for the polynomial through the
   stored points. */
void dep_history_predict(const dep_history *history, double t, double *out)
{
    int n = history->count, nc = history->nc;
    double t_i = history->t[n - 1], coefficients[DEP_HISTORY] = {0};
    if (n == 1) {
        memcpy(out, history->lam[0], (size_t)nc * sizeof *out);
        return;
    }
    double h = t - t_i;
    for (int g = 0; g < 3; ++g) {
        double at = t_i + NODES[g] * h;
        for (int j = 0; j < n; ++j) {
            double weight = 1.0;
            for (int m = 0; m < n; ++m) {
                if (m != j) {
                    weight *= (at - history->t[m]) / (history->t[j] - history->t[m]);
                }
            }
            coefficients[j] += WEIGHTS[g] * weight;
        }
    }
    for (int j = 0; j < n; ++j) {
        coefficients[j] *= 6.0;
    }
    coefficients[n - 1] += 1.0 - 6.0 * (WEIGHTS[0] + WEIGHTS[1] + WEIGHTS[2]);
    for (int i = 0; i < nc; ++i) {
        double sum = 0.0;
        for (int j = 0; j < n; ++j) {
            sum += coefficients[j] * history->lam[j][i];
        }
        out[i] = sum;
    }
}

/* ---- errors and the step factor ---------------------------------------------------------- */

/* err_lam: the position excursion (h^4/24) M^-1 J1^T lambda'' of the linear interpolation,
   lambda'' from the last two accepted lambdas and lam1. scratch: nc + 2 nq. */
double dep_interpolation_error(double h, const dep_history *history, const double *lam1,
                               const double *J1, const dep_mass *mass, const double *scale_q,
                               int nq, double *scratch)
{
    int nc = history->nc, n = history->count;
    if (n < 2 || nc == 0) {
        return 0.0;
    }
    double t_a = history->t[n - 2], t_b = history->t[n - 1];
    const double *lam_a = history->lam[n - 2], *lam_b = history->lam[n - 1];
    double h_prev = t_b - t_a, factor = pow(h, 4) / 24.0;
    double *second = scratch, *column = scratch + nc, *excursion = scratch + nc + nq;
    for (int i = 0; i < nc; ++i) {
        second[i] = 2.0 * ((lam1[i] - lam_b[i]) / h - (lam_b[i] - lam_a[i]) / h_prev)
                    / (h + h_prev);
    }
    for (int j = 0; j < nq; ++j) {
        double sum = 0.0;
        for (int i = 0; i < nc; ++i) {
            sum += J1[i * nq + j] * second[i];
        }
        column[j] = sum;
    }
    dep_mass_solve(mass, column, excursion);
    for (int j = 0; j < nq; ++j) {
        excursion[j] = factor * excursion[j];
    }
    return dep_rms(excursion, scale_q, nq);
}

static double excess(double err_lam, double err_ode, double fac)
{
    return err_lam * pow(fac, INTERPOLATION_ORDER) + err_ode * pow(fac, ERROR_ORDER) - SAFETY;
}

/* fac = h_new / h solving err_lam fac^4 + err_ode fac^5 = SAFETY by Newton's method in
   log fac, clipped to [FAC_MIN, FAC_MAX] (to 1 after a rejection). */
double dep_step_factor(double err_lam, double err_ode, int accepted)
{
    double high = accepted ? FAC_MAX : 1.0, start = INFINITY;
    if (excess(err_lam, err_ode, high) <= 0.0) {
        return high;
    }
    if (excess(err_lam, err_ode, FAC_MIN) >= 0.0) {
        return FAC_MIN;
    }
    if (err_lam > 0.0) {
        start = fmin(start, pow(SAFETY / err_lam, 1.0 / INTERPOLATION_ORDER));
    }
    if (err_ode > 0.0) {
        start = fmin(start, pow(SAFETY / err_ode, 1.0 / ERROR_ORDER));
    }
    double x = log(start);
    for (int k = 0; k < 6; ++k) {
        double a = err_lam * exp(INTERPOLATION_ORDER * x);
        double b = err_ode * exp(ERROR_ORDER * x);
        x -= (a + b - SAFETY) / (INTERPOLATION_ORDER * a + ERROR_ORDER * b);
    }
    return fmin(fmax(exp(x), FAC_MIN), high);
}

/* The largest fac the position pass's contraction rate rho allows (rho ~ (omega h)^2). */
double dep_convergence_factor(const dep_pass_report *report)
{
    double rho = 0.0;
    for (int k = 1; k < report->n_errors; ++k) {
        if (report->errors[k - 1] > 0) {
            rho = fmax(rho, report->errors[k] / report->errors[k - 1]);
        }
    }
    if (rho <= RHO_TARGET) {
        return FAC_MAX;
    }
    return fmax(0.5, sqrt(RHO_TARGET / rho));
}

/* Hairer-Norsett-Wanner's starting step (Solving ODEs I, II.4). scratch: 3 n. */
double dep_initial_step(dep_rhs_function rhs, void *context, double t0, const double *y0,
                        const double *f0, int n, double tol, double span, double *scratch)
{
    double *scale = scratch, *y1 = scratch + n, *f1 = scratch + 2 * (size_t)n;
    dep_weights(y0, y0, n, tol, scale);
    double d0 = dep_rms(y0, scale, n), d1 = dep_rms(f0, scale, n);
    double h0 = d0 < 1e-5 || d1 < 1e-5 ? 1e-6 : 0.01 * d0 / d1, h1;
    h0 = fmin(h0, span);
    for (int i = 0; i < n; ++i) {
        y1[i] = y0[i] + h0 * f0[i];
    }
    rhs(context, t0 + h0, y1, f1);
    for (int i = 0; i < n; ++i) {
        f1[i] -= f0[i];
    }
    double d2 = dep_rms(f1, scale, n) / h0;
    if (fmax(d1, d2) <= 1e-15) {
        h1 = fmax(1e-6, h0 * 1e-3);
    } else {
        h1 = pow(0.01 / fmax(d1, d2), 1.0 / ERROR_ORDER);
    }
    return fmin(fmin(100 * h0, h1), span);
}
