/* control.c: step size control (docs/method.md, 4).
 *
 * The new step h_new = fac h combines the error of the multipliers' interpolation
 * (~h^(nodes + 3)) with the ODE method's own error (~h^5 for DOPRI, h^3 for the Rosenbrock
 * step), both in the weighted RMS norm (1: at tolerance); a step is accepted when
 * err_lam + err_ode <= 1 and fac solves err_lam fac^p + err_ode fac^r = SAFETY, times a
 * proportional-integral factor, clipped to [FAC_MIN, FAC_MAX] (method.h).
 */
#include <math.h>

#include "method.h"

#define SAFETY 0.6
#define FAC_MIN 0.2
#define FAC_MAX 5.0
#define PI_BETA 0.08
#define PI_ORDER_BETA 0.2 /* the Rosenbrock step's, over the error's power of h */
#define PI_FLOOR 1e-4
#define RHO_TARGET 0.2 /* wanted contraction rate of the position pass */
#define NEWTON_DONE 1e-9 /* a change of log fac this small ends integral_factor's Newton */

void dep_weights(const double *y0, const double *y1, int n, double tol, const double *floors,
                 double *scale)
{
    for (int i = 0; i < n; ++i) { /* (a comparison, not fmax: a libm call on x86-64) */
        double a = fabs(y0[i]), b = fabs(y1[i]);
        scale[i] = tol * (floors[i] + (a > b ? a : b));
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

/* The step errors and their powers of h: the ODE method's and the multipliers'
   interpolation (dep_step_errors). */
/* The step's errors and their powers of h, as terms (the friction's only when it has one). */
static int terms(const dep_step_errors *e, double size[3], int order[3])
{
    size[0] = e->ode;
    order[0] = e->ode_order;
    size[1] = e->lam;
    order[1] = e->lam_order;
    size[2] = e->friction;
    order[2] = e->friction_order;
    return e->friction_order > 0 ? 3 : 2;
}

/* r^n for a small integer power n (the errors' powers of h). */
static double power(double r, int n)
{
    double out = 1.0;
    for (int k = 0; k < n; ++k) {
        out *= r;
    }
    return out;
}

static double excess(const dep_step_errors *e, double fac)
{
    double size[3], sum = -SAFETY;
    int order[3], n = terms(e, size, order);
    for (int k = 0; k < n; ++k) {
        sum += size[k] * power(fac, order[k]);
    }
    return sum;
}

static double slope(const dep_step_errors *e, double fac)
{
    double size[3], sum = 0.0;
    int order[3], n = terms(e, size, order);
    for (int k = 0; k < n; ++k) {
        sum += order[k] * size[k] * power(fac, order[k]);
    }
    return sum;
}

/* The fac solving excess(fac) = 0, clipped to [FAC_MIN, high]. In x = log fac the sum of the
   terms is increasing and convex, and each term alone reaches SAFETY at x_k = log(SAFETY /
   size_k) / order_k, so the root is at most min x_k: Newton's method from there (or from
   log high) approaches it from above without overshooting (one exp a pass, the terms' powers
   by products). */
static double integral_factor(const dep_step_errors *e, double high)
{
    double x = log(high), size[3];
    int order[3], n = terms(e, size, order);
    for (int k = 0; k < n; ++k) {
        if (size[k] > 0.0) {
            x = fmin(x, (log(SAFETY) - log(size[k])) / order[k]);
        }
    }
    for (int pass = 0; pass < 8 && x > log(FAC_MIN); ++pass) {
        double r = exp(x), sum = -SAFETY, derivative = 0.0;
        for (int k = 0; k < n; ++k) {
            double term = size[k] * power(r, order[k]);
            sum += term;
            derivative += order[k] * term;
        }
        if (sum <= 0.0) { /* at the start: excess(high) <= 0; later: at the root */
            if (pass == 0 && x == log(high)) {
                return high;
            }
            break; /* (at a term's own root when the others are nought: no constraint rows) */
        }
        double dx = sum / derivative;
        x -= dx;
        if (dx < NEWTON_DONE) {
            break;
        }
    }
    return fmin(fmax(exp(x), FAC_MIN), high);
}

/* fac = h_new / h: the factor for which err_lam fac^p + err_ode fac^r = SAFETY, and after an
   accepted step the proportional-integral correction of Hairer's DOPRI5 (Lund
   stabilisation), (err^0.75 err_previous)^beta with err the sum of the errors: it damps the
   alternation of accepted and rejected steps where the step is bounded by stability rather
   than accuracy (a stiff friction damper). beta = PI_BETA with DOPRI; with the Rosenbrock step
   PI_ORDER_BETA / q, q the errors' effective power of h, which holds the error near the same
   fraction of tol whichever error leads (PI_BETA held the order-6 multiplier error at a few
   percent of tol and the step at a tenth of what the tolerance allows). Clipped to
   [FAC_MIN, FAC_MAX] (to 1 after a rejection). */
double dep_step_factor(const dep_step_errors *errors, double err_previous, int accepted)
{
    double high = accepted ? FAC_MAX : 1.0;
    double fac = integral_factor(errors, high);
    if (accepted) {
        double err = fmax(dep_step_error(errors), PI_FLOOR);
        double beta = PI_BETA;
        if (errors->ode_order != 5) { /* the Rosenbrock step: scaled by its effective order */
            double size = excess(errors, fac) + SAFETY, order = slope(errors, fac) / size;
            beta = size > 0.0 && order > 0.0 ? PI_ORDER_BETA / order : 0.0;
        }
        fac *= pow(pow(err, 0.75) * fmax(err_previous, PI_FLOOR), beta);
    }
    return fmin(fmax(fac, FAC_MIN), high);
}

double dep_step_error(const dep_step_errors *errors)
{
    return errors->ode + errors->lam + errors->friction;
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
                        const double *f0, int n, int order, double tol,
                        const double *floors, double span, double *scratch)
{
    double *scale = scratch, *y1 = scratch + n, *f1 = scratch + 2 * (size_t)n;
    dep_weights(y0, y0, n, tol, floors, scale);
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
        h1 = pow(0.01 / fmax(d1, d2), 1.0 / order);
    }
    return fmin(fmin(100 * h0, h1), span);
}
