/* profile.c: the multipliers' profile over a step and its predictor (docs/method.md, 2-3).
 *
 * lambda(t) over a step is the polynomial through the last accepted multipliers and the
 * step's unknown end value (up to a cubic); the predictor extrapolates that end value from the
 * accepted ones and learns its own miss. The hinges' friction torques, when the step
 * prescribes them, share the profile's times and weights (method.h).
 */
#include <math.h>
#include <string.h>

#include "method.h"

/* 3-point Gauss-Legendre on [0, 1] (exact for polynomials up to degree 5): the nodes and the
   plain weights. */
static const double NODES[3] = {0.1127016653792583, 0.5, 0.8872983346207417};
static const double PLAIN[3] = {0.2777777777777778, 0.4444444444444444, 0.2777777777777778};

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
    profile->position = profile->velocity = profile->excursion = profile->drift = 0.0;
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
        profile->drift += PLAIN[g] * fabs(product);
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
    profile->drift = 1.0 / 6.0;
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
