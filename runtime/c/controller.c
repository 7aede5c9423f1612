/* controller.c: the multipliers' profile over a step, its predictor, and step size control
 * (docs/method.md, 2-4).
 *
 * lambda(t) over a step is the polynomial through the last accepted multipliers and the
 * step's unknown end value (up to a cubic). The new step h_new = fac h combines the error of
 * that interpolation (~h^(nodes + 3)) with the ODE method's own error (~h^5 for DOPRI, h^3
 * for the Rosenbrock step), both in the weighted RMS norm (1: at tolerance); a step is
 * accepted when err_lam + err_ode <= 1 and fac solves err_lam fac^p + err_ode fac^r = SAFETY, times a proportional-integral factor,
 * clipped to [FAC_MIN, FAC_MAX].
 */
#include <math.h>
#include <string.h>

#include "runtime.h"

#define SAFETY 0.6
#define FAC_MIN 0.2
#define FAC_MAX 5.0
#define PI_BETA 0.08
#define PI_ORDER_BETA 0.2 /* the Rosenbrock step's, over the error's power of h */
#define PI_FLOOR 1e-4
#define RHO_TARGET 0.2 /* wanted contraction rate of the position pass */
#define NEWTON_DONE 1e-9 /* a change of log fac this small ends integral_factor's Newton */

/* 3-point Gauss-Legendre on [0, 1] (exact for polynomials up to degree 5): the nodes and the
   plain weights. */
static const double NODES[3] = {0.1127016653792583, 0.5, 0.8872983346207417};
static const double PLAIN[3] = {0.2777777777777778, 0.4444444444444444, 0.2777777777777778};

void dep_weights(const double *y0, const double *y1, int n, double tol, double *scale)
{
    for (int i = 0; i < n; ++i) { /* (a comparison, not fmax: a libm call on x86-64) */
        double a = fabs(y0[i]), b = fabs(y1[i]);
        scale[i] = tol * (1.0 + (a > b ? a : b));
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
    history->miss = dep_doubles(arena, (size_t)capacity);
    return arena->failed ? DEP_MEMORY_ERROR : DEP_OK;
}

void dep_history_reset(dep_history *history, double t, const double *lam, int nc)
{
    history->count = 1;
    history->nc = nc;
    history->miss_h = 0.0;
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

/* ---- the profile ------------------------------------------------------------------------ */

/* The Lagrange basis at `at` of the profile's nodes u[0..n-1] and 1 (the end): w[0..n].
   w_j = inverse_j prod_{m != j} (at - u_m), the products from both sides (the denominators
   are the profile's, set_inverse): a basis evaluated at every force evaluation. */
static void basis(const dep_profile *profile, double at, double *w)
{
    int n = profile->nodes;
    double d[DEP_PROFILE_NODES + 1], left = 1.0, right = 1.0;
    for (int m = 0; m < n; ++m) {
        d[m] = at - profile->u[m];
    }
    d[n] = at - 1.0;
    for (int j = 0; j <= n; ++j) { /* prod_{m < j} */
        w[j] = left;
        left *= d[j];
    }
    for (int j = n; j >= 0; --j) { /* times prod_{m > j} */
        w[j] *= right * profile->inverse[j];
        right *= d[j];
    }
}

static void set_inverse(dep_profile *profile)
{
    int n = profile->nodes;
    for (int j = 0; j <= n; ++j) {
        double uj = j < n ? profile->u[j] : 1.0, product = 1.0;
        for (int m = 0; m <= n; ++m) {
            if (m != j) {
                product *= uj - (m < n ? profile->u[m] : 1.0);
            }
        }
        profile->inverse[j] = 1.0 / product;
    }
}

/* The profile of a step of size h from the last accepted point: after a (re)start with one
   accepted multiplier, linear; with more, the polynomial through all but the oldest of them
   (so that the oldest measures its error, dep_divided_difference), up to `most` nodes (a
   polynomial of that degree; at most DEP_PROFILE_NODES, a cubic). */
void dep_profile_set(dep_profile *profile, const dep_history *history, double h, int most)
{
    int n = history->count, nodes = n == 1 ? 1 : n - 1;
    double t0 = history->t[n - 1], w[DEP_PROFILE_NODES + 1];
    nodes = nodes < most ? nodes : most;
    nodes = nodes < DEP_PROFILE_NODES ? nodes : DEP_PROFILE_NODES;
    profile->t0 = t0;
    profile->h = h;
    profile->nodes = nodes;
    for (int j = 0; j < nodes; ++j) {
        int k = n - nodes + j;
        profile->u[j] = (history->t[k] - t0) / h;
        profile->lam[j] = history->lam[k];
    }
    set_inverse(profile);
    profile->position = profile->velocity = profile->excursion = 0.0;
    profile->position_start = profile->velocity_start = profile->lagged = 0.0;
    for (int g = 0; g < 3; ++g) {
        double s = NODES[g], product = s - 1.0;
        basis(profile, s, w);
        profile->position += PLAIN[g] * (1.0 - s) * w[nodes];
        profile->velocity += PLAIN[g] * w[nodes];
        profile->position_start += PLAIN[g] * (1.0 - s) * (1.0 - s) * w[nodes];
        profile->velocity_start += PLAIN[g] * (1.0 - s) * w[nodes];
        profile->lagged += PLAIN[g] * 0.5 * (1.0 - s) * (1.0 - s) * w[nodes];
        for (int j = 0; j < nodes; ++j) {
            product *= s - profile->u[j];
        }
        profile->excursion += PLAIN[g] * (1.0 - s) * fabs(product);
    }
}

/* The profile `from` (set from a history with the same times as `history`) through
   `history`'s values: the friction torques' profile of the step the multipliers' was set for. */
void dep_profile_share(dep_profile *to, const dep_profile *from, const dep_history *history)
{
    *to = *from;
    for (int j = 0; j < to->nodes; ++j) {
        to->lam[j] = history->lam[history->count - to->nodes + j];
    }
}

/* lambda held at `lam` over the step from t0 (the first step's trial). */
void dep_profile_hold(dep_profile *profile, double t0, const double *lam)
{
    profile->t0 = t0;
    profile->h = 1.0;
    profile->nodes = 1;
    profile->u[0] = 0.0;
    profile->lam[0] = lam;
    set_inverse(profile);
    profile->position = 1.0 / 6.0;
    profile->velocity = 0.5;
    profile->position_start = 1.0 / 12.0;
    profile->velocity_start = 1.0 / 6.0;
    profile->lagged = 1.0 / 24.0;
    profile->excursion = 1.0 / 12.0;
}

/* lambda(t) (nc) of the profile with end value lam_end. */
void dep_profile_value(const dep_profile *profile, const double *lam_end, double t, int nc,
                       double *out)
{
    double w[DEP_PROFILE_NODES + 1];
    int n = profile->nodes;
    basis(profile, (t - profile->t0) / profile->h, w);
    int i = 0;
    for (; i + 4 <= nc; i += 4) { /* four rows' sums at a time, each in node order */
        double s0 = w[n] * lam_end[i], s1 = w[n] * lam_end[i + 1], s2 = w[n] * lam_end[i + 2],
               s3 = w[n] * lam_end[i + 3];
        for (int j = 0; j < n; ++j) {
            const double *lam = profile->lam[j] + i;
            s0 += w[j] * lam[0];
            s1 += w[j] * lam[1];
            s2 += w[j] * lam[2];
            s3 += w[j] * lam[3];
        }
        out[i] = s0;
        out[i + 1] = s1;
        out[i + 2] = s2;
        out[i + 3] = s3;
    }
    for (; i < nc; ++i) {
        double sum = w[n] * lam_end[i];
        for (int j = 0; j < n; ++j) {
            sum += w[j] * profile->lam[j][i];
        }
        out[i] = sum;
    }
}

double dep_profile_end_weight(const dep_profile *profile, double t)
{
    double w[DEP_PROFILE_NODES + 1];
    basis(profile, (t - profile->t0) / profile->h, w);
    return w[profile->nodes];
}

/* The position pass's starting lambda_{i+1}: the end value for which the profile pushes the
   step end as the multipliers extrapolated from every accepted point would (for frozen
   Phi_q): integral (1 - s) (profile(s) - extrapolation(s)) ds = 0, a sum of the accepted
   values with these weights (history->count of them, to divide by profile->position). They
   depend on the times alone: a history kept in step with this one (the friction torques')
   shares them (dep_profile_share). */
void dep_history_weights(const dep_history *history, const dep_profile *profile,
                         double *weights)
{
    int n = history->count, nodes = profile->nodes;
    double w[DEP_PROFILE_NODES + 1];
    memset(weights, 0, (size_t)n * sizeof *weights);
    for (int g = 0; g < 3; ++g) {
        double s = NODES[g], at = profile->t0 + s * profile->h, weight = PLAIN[g] * (1.0 - s);
        for (int j = 0; j < n; ++j) { /* the extrapolation through every accepted point */
            double value = 1.0;
            for (int m = 0; m < n; ++m) {
                if (m != j) {
                    value *= (at - history->t[m]) / (history->t[j] - history->t[m]);
                }
            }
            weights[j] += weight * value;
        }
        basis(profile, s, w); /* less the profile's own accepted part */
        for (int j = 0; j < nodes; ++j) {
            weights[n - nodes + j] -= weight * w[j];
        }
    }
}

/* That end value by dep_history_weights' weights, plus the miss of this guess at the last
   accepted step (dep_history_learn), scaled by (h / its h)^4, when that step's guess was made
   from as many points. The miss is the extrapolation's O(h^4) error and DOPRI's own normal
   error over h^2: both smooth from step to step, so the last one foretells the next
   (docs/method.md, 3). */
void dep_history_predict(dep_history *history, const dep_profile *profile,
                         const double *weights, double *out)
{
    int n = history->count, nc = history->nc;
    for (int i = 0; i < nc; ++i) {
        double sum = 0.0;
        for (int j = 0; j < n; ++j) {
            sum += weights[j] * history->lam[j][i];
        }
        out[i] = sum / profile->position;
    }
    history->applied = 0.0;
    if (history->miss_h > 0.0 && history->miss_count == n) {
        double r = profile->h / history->miss_h;
        history->applied = r * r * r * r;
        for (int i = 0; i < nc; ++i) {
            out[i] += history->applied * history->miss[i];
        }
    }
}

/* After an accepted step of size h: its guess of lambda_{i+1} (dep_history_predict's) missed
   the value the position pass found by found - guess; kept as the miss of the guess without
   the part of the last miss it applied. Before dep_history_add. */
void dep_history_learn(dep_history *history, double h, const double *guess, const double *found)
{
    for (int i = 0; i < history->nc; ++i) {
        history->miss[i] = found[i] - guess[i] + history->applied * history->miss[i];
    }
    history->miss_h = h;
    history->miss_count = history->count;
}

/* ---- errors and the step factor ---------------------------------------------------------- */

/* The divided difference D (n, into d) of a history's accepted values and the step's `end`
   of the order the profile misses: the profile's interpolation error is
   e(t) = D prod_j (t - t_j) (t - t_end) over the step, the t_j its nodes (for a linear
   profile D = lambda'' / 2). 0 (d untouched) right after a (re)start, with one accepted value
   (or fewer than the profile's nodes and one). scratch: n (nodes + 2). */
int dep_divided_difference(const dep_profile *profile, const dep_history *history,
                           const double *end, double *d, double *scratch)
{
    int n = history->nc, used = profile->nodes + 1, first = history->count - used;
    int points = used + 1; /* the profile's nodes, the point before them, and the end */
    if (history->count < 2 || first < 0) {
        return 0;
    }
    double times[DEP_HISTORY + 1], *table = scratch;
    for (int k = 0; k < used; ++k) {
        times[k] = history->t[first + k];
        memcpy(table + (size_t)k * n, history->lam[first + k], (size_t)n * sizeof *table);
    }
    times[used] = profile->t0 + profile->h;
    memcpy(table + (size_t)used * n, end, (size_t)n * sizeof *table);
    for (int level = 1; level < points; ++level) { /* divided differences, in place */
        for (int k = points - 1; k >= level; --k) {
            double span = times[k] - times[k - level];
            for (int i = 0; i < n; ++i) {
                table[(size_t)k * n + i] = (table[(size_t)k * n + i]
                                            - table[(size_t)(k - 1) * n + i]) / span;
            }
        }
    }
    memcpy(d, table + (size_t)(points - 1) * n, (size_t)n * sizeof *d);
    return 1;
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
            if (pass == 0) {
                return high;
            }
            break;
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
                        const double *f0, int n, int order, double tol, double span,
                        double *scratch)
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
        h1 = pow(0.01 / fmax(d1, d2), 1.0 / order);
    }
    return fmin(fmin(100 * h0, h1), span);
}
