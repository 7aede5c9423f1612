/* dopri.c: Dormand-Prince 5(4), one explicit step with its error estimate and continuous
 * extension (Shampine's quartic), and the quintic Hermite interpolant of an accepted step of
 * the multiplier method. Coefficients of Dormand & Prince (1980;
 * Hairer, Norsett & Wanner, Solving ODEs I, II.6).
 */
#include <math.h>
#include <string.h>

#include "method.h"

const double dep_dopri_c[6] = {0, 1.0 / 5, 3.0 / 10, 4.0 / 5, 8.0 / 9, 1};
const double dep_dopri_a[6][5] = {
    {0},
    {1.0 / 5},
    {3.0 / 40, 9.0 / 40},
    {44.0 / 45, -56.0 / 15, 32.0 / 9},
    {19372.0 / 6561, -25360.0 / 2187, 64448.0 / 6561, -212.0 / 729},
    {9017.0 / 3168, -355.0 / 33, 46732.0 / 5247, 49.0 / 176, -5103.0 / 18656},
};
const double dep_dopri_b[6] = {35.0 / 384, 0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784,
                            11.0 / 84};
static const double E[7] = {-71.0 / 57600, 0, 71.0 / 16695, -71.0 / 1920, 17253.0 / 339200,
                            -22.0 / 525, 1.0 / 40};
static const double P[7][4] = {
    {1, -8048581381.0 / 2820520608, 8663915743.0 / 2820520608, -12715105075.0 / 11282082432},
    {0, 0, 0, 0},
    {0, 131558114200.0 / 32700410799, -68118460800.0 / 10900136933,
     87487479700.0 / 32700410799},
    {0, -1754552775.0 / 470086768, 14199869525.0 / 1410260304, -10690763975.0 / 1880347072},
    {0, 127303824393.0 / 49829197408, -318862633887.0 / 49829197408,
     701980252875.0 / 199316789632},
    {0, -282668133.0 / 205662961, 2019193451.0 / 616988883, -1453857185.0 / 822651844},
    {0, 40617522.0 / 29380423, -110615467.0 / 29380423, 69997945.0 / 29380423},
};

int dep_rk_init(dep_rk_step *rk, int n, dep_arena *arena)
{
    memset(rk, 0, sizeof *rk);
    rk->n = n;
    rk->y1 = dep_doubles(arena, (size_t)n);
    rk->error = dep_doubles(arena, (size_t)n);
    rk->K = dep_doubles(arena, 7 * (size_t)n);
    rk->mode = dep_doubles(arena, (size_t)n);
    return arena->failed ? DEP_MEMORY_ERROR : DEP_OK;
}

/* out (n) = y0 + h sum_k coefficients[k] K[k] over the stages k < count (h times the sum
   where y0 is NULL): each component's sum in stage order, as numpy's `coefficients @ K`, in a
   register (a running sum through out would be stored and loaded again for every stage),
   four components at a time so that their independent sums share each coefficient's load and
   fill the processor's pipelines (one component's sum is a chain of dependent additions). */
static void combine(const double *coefficients, int count, const double *K, int n,
                    const double *y0, double h, double *out)
{
    int j = 0;
    for (; j + 4 <= n; j += 4) {
        double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
        for (int k = 0; k < count; ++k) {
            const double c = coefficients[k], *row = K + (size_t)k * (size_t)n + j;
            s0 += c * row[0];
            s1 += c * row[1];
            s2 += c * row[2];
            s3 += c * row[3];
        }
        if (y0 != NULL) {
            out[j] = y0[j] + h * s0;
            out[j + 1] = y0[j + 1] + h * s1;
            out[j + 2] = y0[j + 2] + h * s2;
            out[j + 3] = y0[j + 3] + h * s3;
        } else {
            out[j] = h * s0;
            out[j + 1] = h * s1;
            out[j + 2] = h * s2;
            out[j + 3] = h * s3;
        }
    }
    for (; j < n; ++j) {
        double sum = 0.0;
        for (int k = 0; k < count; ++k) {
            sum += coefficients[k] * K[(size_t)k * (size_t)n + j];
        }
        out[j] = y0 != NULL ? y0[j] + h * sum : h * sum;
    }
}

/* Advance y' = rhs(t, y) from (t0, y0) over h with first stage k1 = rhs(t0, y0); six
   evaluations. `scratch`: n doubles. */
void dep_dopri_step(dep_rk_step *rk, dep_rhs_function rhs, void *context, double t0,
                    const double *y0, const double *k1, double h, double *scratch)
{
    int n = rk->n;
    double *K = rk->K;
    rk->method = DEP_DOPRI;
    rk->order = 5;
    rk->t0 = t0;
    rk->h = h;
    rk->y0 = y0;
    memcpy(K, k1, (size_t)n * sizeof *K);
    for (int s = 1; s < 6; ++s) {
        combine(dep_dopri_a[s], s, K, n, y0, h, scratch);
        rhs(context, t0 + dep_dopri_c[s] * h, scratch, K + (size_t)s * (size_t)n);
    }
    combine(dep_dopri_b, 6, K, n, y0, h, rk->y1);
    rhs(context, t0 + h, rk->y1, K + 6 * (size_t)n);
    double num = 0.0, den = 0.0; /* scratch: the sixth stage's argument, also at t0 + h */
    for (int j = 0; j < n; ++j) {
        double dk = K[6 * (size_t)n + j] - K[5 * (size_t)n + j];
        rk->mode[j] = rk->y1[j] - scratch[j];
        num += dk * dk;
        den += rk->mode[j] * rk->mode[j];
    }
    rk->stiffness = den > 0.0 ? h * sqrt(num / den) : 0.0;
    combine(E, 7, K, n, NULL, h, rk->error);
}

/* Components first..first+count-1 of the continuous extension y(t) of the step: DOPRI's
   (DenseStep, 4th order), or the cubic Hermite interpolant of a Rosenbrock step's ends. */
void dep_dense_components(const dep_rk_step *rk, double t, int first, int count, double *out)
{
    int n = rk->n;
    double x = (t - rk->t0) / rk->h;
    if (rk->method == DEP_ROSENBROCK) {
        double h00 = (1 + 2 * x) * (1 - x) * (1 - x), h10 = x * (1 - x) * (1 - x);
        double h01 = x * x * (3 - 2 * x), h11 = x * x * (x - 1);
        for (int j = first; j < first + count; ++j) {
            out[j - first] = h00 * rk->y0[j] + h01 * rk->y1[j]
                + rk->h * (h10 * rk->K[j] + h11 * rk->K[6 * (size_t)n + j]);
        }
        return;
    }
    double weight[7]; /* y0 + h sum_s b_s(x) K_s, b_s(x) = sum_c P_sc x^(c+1) */
    const double *K[7];
    int used = 0;
    for (int stage = 0; stage < 7; ++stage) { /* the stages of non-zero weight */
        const double *c = P[stage];
        double w = rk->h * x * (c[0] + x * (c[1] + x * (c[2] + x * c[3])));
        if (w != 0.0) {
            weight[used] = w;
            K[used++] = rk->K + (size_t)stage * n + first;
        }
    }
    const double *y0 = rk->y0 + first;
    int j = 0;
    for (; j + 4 <= count; j += 4) { /* in stage order in registers, as combine */
        double s0 = y0[j], s1 = y0[j + 1], s2 = y0[j + 2], s3 = y0[j + 3];
        for (int s = 0; s < used; ++s) {
            const double w = weight[s], *k = K[s] + j;
            s0 += w * k[0];
            s1 += w * k[1];
            s2 += w * k[2];
            s3 += w * k[3];
        }
        out[j] = s0;
        out[j + 1] = s1;
        out[j + 2] = s2;
        out[j + 3] = s3;
    }
    for (; j < count; ++j) {
        double sum = y0[j];
        for (int s = 0; s < used; ++s) {
            sum += weight[s] * K[s][j];
        }
        out[j] = sum;
    }
}

/* The step interpolant's data, DEP_INTERPOLANT_ROWS x nq + DEP_INTERPOLANT_TAIL: the quintic's
   rows (q0, h qd0, h^2 qdd0, q1, h qd1, h^2 qdd1), the velocity interpolant's (qd0, h qdd0,
   qd1, h qdd1, qd_prior, h qdd_prior), then h_prior / h (0 until dep_interpolant_prior gives
   the accepted point before the step) and whether the velocity interpolant takes the
   accelerations at the prior point, the start and the end (1) or leaves a weak one out (0). */
void dep_interpolant_data(double h, const double *q0, const double *qd0, const double *qdd0,
                          int qdd0_weak, const double *q1, const double *qd1,
                          const double *qdd1, int qdd1_weak, int nq, double *data)
{
    double h2 = h * h, *tail = data + DEP_INTERPOLANT_ROWS * nq;
    for (int j = 0; j < nq; ++j) {
        data[j] = q0[j];
        data[nq + j] = h * qd0[j];
        data[2 * nq + j] = h2 * qdd0[j];
        data[3 * nq + j] = q1[j];
        data[4 * nq + j] = h * qd1[j];
        data[5 * nq + j] = h2 * qdd1[j];
        data[6 * nq + j] = qd0[j];
        data[7 * nq + j] = h * qdd0[j];
        data[8 * nq + j] = qd1[j];
        data[9 * nq + j] = h * qdd1[j];
    }
    tail[0] = 0.0;
    tail[1] = 0.0;
    tail[2] = !qdd0_weak;
    tail[3] = !qdd1_weak;
}

/* Adds the accepted point before the step (h_prior before its start) to the velocity
   interpolant. */
void dep_interpolant_prior(double *data, int nq, double h, double h_prior, const double *qd,
                           const double *qdd, int qdd_weak)
{
    double *tail = data + DEP_INTERPOLANT_ROWS * nq;
    for (int j = 0; j < nq; ++j) {
        data[10 * nq + j] = qd[j];
        data[11 * nq + j] = h * qdd[j];
    }
    tail[0] = h_prior / h;
    tail[1] = !qdd_weak;
}

/* The weights at x of the velocity interpolant's six values (qd at the prior point, the start
   and the end, then h qdd at the same): the Hermite interpolant (Newton's form on the nodes,
   a node doubled where its acceleration is taken) through qd at x = -r (when r > 0), 0 and 1
   and h qdd where `taken`: quintic with all three points and accelerations, cubic with the
   step's ends alone; a weak acceleration left out lowers the degree by one. */
static void rate_weights(double x, double r, const int taken[3], double weights[6])
{
    const double at[3] = {-r, 0.0, 1.0};
    for (int m = 0; m < 6; ++m) { /* value m: qd at point m (m < 3), else h qdd at m - 3 */
        double z[6], f[6], c[6];
        int n = 0;
        for (int p = r > 0.0 ? 0 : 1; p < 3; ++p) {
            z[n] = at[p];
            f[n] = m == p;
            c[n++] = 0.0;
            if (taken[p]) { /* the node doubled: its first difference is the derivative */
                z[n] = at[p];
                f[n] = m == p;
                c[n++] = m == p + 3;
            }
        }
        c[0] = f[0];
        for (int k = n - 1; k > 0; --k) {
            if (z[k] != z[k - 1]) {
                c[k] = (f[k] - f[k - 1]) / (z[k] - z[k - 1]);
            }
        }
        for (int level = 2; level < n; ++level) {
            for (int k = n - 1; k >= level; --k) {
                c[k] = (c[k] - c[k - 1]) / (z[k] - z[k - level]);
            }
        }
        double p = c[n - 1];
        for (int k = n - 2; k >= 0; --k) {
            p = p * (x - z[k]) + c[k];
        }
        weights[m] = p;
    }
}

/* q at t on the quintic Hermite interpolant of the two accepted states (q, qd, qdd at both
   ends); qd on the quintic Hermite interpolant of (qd, qdd) at the step's ends and the
   accepted point before it, or after a start or an event on the cubic Hermite interpolant of
   the step's ends, each without the accelerations marked weak (rate_weights; docs/method.md,
   5). */
void dep_interpolate(const double *data, double t0, double h, int nq, double t, double *q,
                     double *qd)
{
    const double *tail = data + DEP_INTERPOLANT_ROWS * nq;
    const int taken[3] = {tail[1] != 0.0, tail[2] != 0.0, tail[3] != 0.0};
    double x = (t - t0) / h, r = tail[0];
    double x2 = x * x, x3 = x2 * x;
    double x4 = x3 * x, x5 = x3 * x2;
    double quintic[6] = {1 - 10 * x3 + 15 * x4 - 6 * x5, x - 6 * x3 + 8 * x4 - 3 * x5,
                         0.5 * (x2 - 3 * x3 + 3 * x4 - x5), 10 * x3 - 15 * x4 + 6 * x5,
                         -4 * x3 + 7 * x4 - 3 * x5, 0.5 * (x3 - 2 * x4 + x5)};
    double through[6]; /* the rate's weights of qd (prior, start, end), then of h qdd */
    if (r > 0.0 || !taken[1] || !taken[2]) {
        rate_weights(x, r, taken, through);
    } else { /* the cubic Hermite of the step's ends, its weights written out */
        through[0] = through[3] = 0.0;
        through[1] = 2 * x3 - 3 * x2 + 1;
        through[4] = x3 - 2 * x2 + x;
        through[2] = 3 * x2 - 2 * x3;
        through[5] = x3 - x2;
    }
    for (int j = 0; j < nq; ++j) {
        double value = 0.0;
        for (int k = 0; k < 6; ++k) {
            value += quintic[k] * data[k * nq + j];
        }
        q[j] = value;
        if (r > 0.0) {
            qd[j] = through[0] * data[10 * nq + j] + through[1] * data[6 * nq + j]
                    + through[2] * data[8 * nq + j] + through[3] * data[11 * nq + j]
                    + through[4] * data[7 * nq + j] + through[5] * data[9 * nq + j];
        } else {
            /* (summed from 0.0 in the rows' order: a sum of signed zeros reads +0) */
            qd[j] = 0.0 + through[1] * data[6 * nq + j] + through[4] * data[7 * nq + j]
                    + through[2] * data[8 * nq + j] + through[5] * data[9 * nq + j];
        }
    }
}
