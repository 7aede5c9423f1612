/* intelsat_hand.c: a tight hand-written solver of the INTELSAT V deployment, the baseline
 * depsim is measured against (bench/bench_intelsat.py) and the test suite's reference
 * (tests/examples/test_intelsat5.py). Nothing is shared with depsim.
 *
 * The mechanism (examples/intelsat5.dep, Lee & Kim's Table 1): a yoke and three panels in a
 * planar chain from the ground, no gravity. Four joint coordinates, the hinge angles
 * theta1..4, give the members' absolute angles
 *
 *     phi_Y = theta1, phi_P1 = phi_Y + theta2 - pi, phi_P2 = phi_P1 - theta3 + pi,
 *     phi_P3 = phi_P2 + theta4 - pi,        phi = A theta + c,
 *
 * each member's centre of mass at mid-length. Written in the absolute angles the kinetic
 * energy of a chain is T = 1/2 sum_ij mu_ij cos(phi_i - phi_j) phi'_i phi'_j with constant
 * mu_ij (below), so the equations of motion in theta are
 *
 *     A^T Mphi(theta) A theta'' = Q(theta, theta') - A^T b(theta, theta'),
 *     Mphi_ij = mu_ij cos(phi_i - phi_j),  b_i = sum_j mu_ij sin(phi_i - phi_j) phi'_j^2.
 *
 * Only the relative angles phi_i - phi_j enter: the three hinge angles theta2..4, one sincos
 * each, the other three by the addition formulas. Q holds the springs (T0 - k theta), the
 * closed cable loops (-k_c C^T C theta, T1 = k_c (2 theta1 - theta2), T2 = k_c (theta2 -
 * theta3), T3 = k_c (theta3 - theta4)) and the hinges' friction -F tanh(theta' / 1e-3 rad/s),
 * tanh from one exp (four an evaluation, none for a hinge turning faster than 0.02 rad/s).
 * About 170 flops and one 4 x 4 LDL^T solve an evaluation.
 *
 * Dormand-Prince 5(4) as in Hairer & Wanner's DOPRI5: atol = rtol = tol in the RMS norm,
 * the proportional-integral step control (beta 0.04, safety 0.9, factor in [0.2, 10]) and the
 * initial step guess. A hinge reaching its deployed angle (theta1 = 90 deg, theta2..4 = 180
 * deg) latches: the crossing is located on the continuous extension, the step re-taken
 * exactly to it (Newton on the hinge angle), the angle set to the latch value and the impact
 * made plastic: theta'+_F = theta'-_F + M_FF^-1 M_FL theta'-_L, theta'+_L = 0. A locked
 * coordinate leaves the equations (its row and column of the mass matrix replaced by the
 * identity's, its force by nought: theta''_L = 0).
 *
 *     cc -O2 -std=c99 -o intelsat_hand intelsat_hand.c -lm
 *     ./intelsat_hand [--t-end T] [--tol TOL] [--dt-out DT] [-o out.csv] [--time-rhs]
 *
 * Writes t,theta1..4 every dt_out to out.csv (nothing without -o). Prints on stderr the latch
 * times ("latch h1 t ..."), "steps S rejected R evaluations E" and the run's time without
 * the process start: "time T ms, X ns per evaluation" (the run's time over its evaluations,
 * step control and rows included). --time-rhs adds the right side's own cost, timed in a
 * second run, each call between two clock readings ("rhs in the run X ns per evaluation"),
 * and in a loop over the states of the run's steps ("rhs in a loop X ns per evaluation").
 */
#define _POSIX_C_SOURCE 199309L /* clock_gettime */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define N 4        /* joint coordinates */
#define NY (2 * N) /* state: theta, theta' */
#define PI 3.141592653589793

/* The members (yoke, panel 1, 2, 3) and the hinge at each one's inboard end. */
static const double L[N] = {1.090, 1.965, 1.965, 1.936};
static const double MASS[N] = {2.222, 12.377, 9.982, 8.920};
static const double INERTIA[N] = {0.2798, 4.2009, 3.8773, 2.9316}; /* about the centre */
static const double FRICTION[N] = {0.68, 0.64, 0.69, 0.70};
static const double STIFFNESS[N] = {0.1273, 0.1305, 0.1305, 0.1305};
static const double PRELOAD[N] = {1.70, 0.85, 0.85, 0.85};
static const double LATCH[N] = {PI / 2, PI, PI, PI};
#define CABLE_K (4500.0 * 0.01835 * 0.01835) /* cable stiffness times pulley radius^2 */
#define SLIP_RATE 1e-3

/* mu_ij = sum over members k >= max(i, j) of m_k a_ki a_kj, a_kj the arm of member j in the
   position of k's centre (L_j for j < k, L_k / 2 for j = k); plus the member's own inertia
   about its centre on the diagonal. */
static double MU[N][N];

static void setup(void)
{
    for (int i = 0; i < N; ++i) {
        for (int j = 0; j < N; ++j) {
            double sum = i == j ? INERTIA[i] : 0.0;
            for (int k = i > j ? i : j; k < N; ++k) {
                double ai = i < k ? L[i] : L[i] / 2, aj = j < k ? L[j] : L[j] / 2;
                sum += MASS[k] * ai * aj;
            }
            MU[i][j] = sum;
        }
    }
}

static int locked[N]; /* hinge latched */
static int any_locked;
static long evaluations;
static int timing_calls; /* --time-rhs: rhs passes each call to timed_rhs */
static void timed_rhs(const double *restrict y, double *restrict dy);

/* The cosines and sines of the relative angles phi_i - phi_j, from theta2..4 (three sincos,
   the rest by the addition formulas): [0..2] of phi1 - phi0, phi2 - phi1, phi3 - phi2 (=
   theta2 - pi, pi - theta3, theta4 - pi), [3..5] of phi2 - phi0, phi3 - phi1, phi3 - phi0. */
static inline void relative_angles(const double *th, double c[6], double s[6])
{
    double s2 = sin(th[1]), c2 = cos(th[1]), s3 = sin(th[2]), c3 = cos(th[2]);
    double s4 = sin(th[3]), c4 = cos(th[3]);
    c[0] = -c2, s[0] = -s2;
    c[1] = -c3, s[1] = s3;
    c[2] = -c4, s[2] = -s4;
    c[3] = c[0] * c[1] - s[0] * s[1], s[3] = s[0] * c[1] + c[0] * s[1];
    c[4] = c[1] * c[2] - s[1] * s[2], s[4] = s[1] * c[2] + c[1] * s[2];
    c[5] = c[3] * c[2] - s[3] * s[2], s[5] = s[3] * c[2] + c[3] * s[2];
}

/* The joint-space mass matrix m = A^T Mphi A (full, symmetric) from the relative angles'
   cosines: Mphi_ij = mu_ij cos(phi_i - phi_j). */
static inline void joint_mass(const double c[6], double m[N][N])
{
    double p00 = MU[0][0], p11 = MU[1][1], p22 = MU[2][2], p33 = MU[3][3];
    double p10 = MU[1][0] * c[0], p21 = MU[2][1] * c[1], p32 = MU[3][2] * c[2];
    double p20 = MU[2][0] * c[3], p31 = MU[3][1] * c[4], p30 = MU[3][0] * c[5];
    /* A's columns are (1,1,1,1), (0,1,1,1), (0,0,-1,-1), (0,0,0,1): with the signs sigma =
       (1, 1, -1, 1), m_ab = sigma_a sigma_b sum_{i>=a, j>=b} p_ij. Row i's suffix sums
       r_ib = sum_{j>=b} p_ij, then the sums over i >= a (the lower triangle). */
    double r33 = p33, r32 = p32 + r33, r31 = p31 + r32, r30 = p30 + r31;
    double r22 = p22 + p32, r21 = p21 + r22, r20 = p20 + r21;
    double r11 = p11 + p21 + p31, r10 = p10 + r11;
    double r00 = p00 + p10 + p20 + p30;
    double s20 = r20 + r30, s21 = r21 + r31, s10 = r10 + s20;
    m[0][0] = r00 + s10;
    m[1][0] = m[0][1] = s10, m[1][1] = r11 + s21;
    m[2][0] = m[0][2] = -s20, m[2][1] = m[1][2] = -s21, m[2][2] = r22 + r32;
    m[3][0] = m[0][3] = r30, m[3][1] = m[1][3] = r31, m[3][2] = m[2][3] = -r32;
    m[3][3] = r33;
}

/* x = m^-1 f by LDL^T, m symmetric positive definite 4 x 4 (its lower triangle read). */
static inline void solve(double m[N][N], const double *f, double *x)
{
    double r0 = 1.0 / m[0][0];
    double l10 = m[1][0] * r0, l20 = m[2][0] * r0, l30 = m[3][0] * r0;
    double d1 = m[1][1] - l10 * m[1][0], r1 = 1.0 / d1;
    double t21 = m[2][1] - l20 * m[1][0], t31 = m[3][1] - l30 * m[1][0];
    double l21 = t21 * r1, l31 = t31 * r1;
    double d2 = m[2][2] - l20 * m[2][0] - l21 * t21, r2 = 1.0 / d2;
    double t32 = m[3][2] - l30 * m[2][0] - l31 * t21, l32 = t32 * r2;
    double d3 = m[3][3] - l30 * m[3][0] - l31 * t31 - l32 * t32;
    double z0 = f[0], z1 = f[1] - l10 * z0, z2 = f[2] - l20 * z0 - l21 * z1;
    double z3 = f[3] - l30 * z0 - l31 * z1 - l32 * z2;
    x[3] = z3 / d3;
    x[2] = z2 * r2 - l32 * x[3];
    x[1] = z1 * r1 - l21 * x[2] - l31 * x[3];
    x[0] = z0 * r0 - l10 * x[1] - l20 * x[2] - l30 * x[3];
}

/* A locked coordinate's row and column of m become the identity's, its right side 0. */
static void lock_rows(double m[N][N], double *f)
{
    for (int l = 0; l < N; ++l) {
        if (!locked[l]) continue;
        for (int j = 0; j < N; ++j) m[l][j] = m[j][l] = 0.0;
        m[l][l] = 1.0;
        f[l] = 0.0;
    }
}

/* The hinge friction -F tanh(rate / slip rate). tanh(u) = sign(u) (1 - 2 / (exp(2 |u|) + 1)),
   within 2.2e-16 (a unit of round-off of 1) of libm's tanh, which goes through expm1 for a
   relative accuracy near 0 that the law does not need; from |u| = 20 on tanh(u) rounds to 1. */
static inline double friction(double F, double rate)
{
    double u = fabs(rate) * (1.0 / SLIP_RATE);
    double t = u < 20.0 ? 1.0 - 2.0 / (exp(2.0 * u) + 1.0) : 1.0;
    return rate < 0 ? F * t : -F * t;
}

/* The right side: y = (theta, theta') -> (theta', theta''). */
static void rhs(const double *restrict y, double *restrict dy)
{
    const double *th = y, *w = y + N;
    if (timing_calls) {
        timed_rhs(y, dy);
        return;
    }
    double m[N][N], c[6], s[6], f[N];
    evaluations++;
    /* the library calls first (nothing else live across them) */
    double fr0 = friction(FRICTION[0], w[0]), fr1 = friction(FRICTION[1], w[1]);
    double fr2 = friction(FRICTION[2], w[2]), fr3 = friction(FRICTION[3], w[3]);
    relative_angles(th, c, s);
    joint_mass(c, m);
    /* absolute rates phi' = A theta', squared */
    double v0 = w[0], v1 = v0 + w[1], v2 = v1 - w[2], v3 = v2 + w[3];
    double q0 = v0 * v0, q1 = v1 * v1, q2 = v2 * v2, q3 = v3 * v3;
    /* b_i = sum_j mu_ij sin(phi_i - phi_j) phi'_j^2 */
    double g10 = MU[1][0] * s[0], g21 = MU[2][1] * s[1], g32 = MU[3][2] * s[2];
    double g20 = MU[2][0] * s[3], g31 = MU[3][1] * s[4], g30 = MU[3][0] * s[5];
    double b0 = -g10 * q1 - g20 * q2 - g30 * q3;
    double b1 = g10 * q0 - g21 * q2 - g31 * q3;
    double b2 = g20 * q0 + g21 * q1 - g32 * q3;
    double b3 = g30 * q0 + g31 * q1 + g32 * q2;
    /* A^T b = (b0 + b1 + b2 + b3, b1 + b2 + b3, -(b2 + b3), b3) */
    double b23 = b2 + b3, b123 = b1 + b23;
    /* the cable loops' torques k_c C theta; their generalized forces -C^T of them */
    double e0 = CABLE_K * (2 * th[0] - th[1]), e1 = CABLE_K * (th[1] - th[2]),
           e2 = CABLE_K * (th[2] - th[3]);
    f[0] = PRELOAD[0] - STIFFNESS[0] * th[0] - 2 * e0 + fr0 - (b0 + b123);
    f[1] = PRELOAD[1] - STIFFNESS[1] * th[1] + e0 - e1 + fr1 - b123;
    f[2] = PRELOAD[2] - STIFFNESS[2] * th[2] + e1 - e2 + fr2 + b23;
    f[3] = PRELOAD[3] - STIFFNESS[3] * th[3] + e2 + fr3 - b3;
    if (any_locked) lock_rows(m, f);
    for (int i = 0; i < N; ++i) dy[i] = w[i]; /* a locked rate is 0 */
    solve(m, f, dy + N);
}

/* ---- Dormand-Prince 5(4) ---------------------------------------------------------------- */

static const double A21 = 1.0 / 5, A31 = 3.0 / 40, A32 = 9.0 / 40, A41 = 44.0 / 45,
                    A42 = -56.0 / 15, A43 = 32.0 / 9, A51 = 19372.0 / 6561,
                    A52 = -25360.0 / 2187, A53 = 64448.0 / 6561, A54 = -212.0 / 729,
                    A61 = 9017.0 / 3168, A62 = -355.0 / 33, A63 = 46732.0 / 5247,
                    A64 = 49.0 / 176, A65 = -5103.0 / 18656, A71 = 35.0 / 384,
                    A73 = 500.0 / 1113, A74 = 125.0 / 192, A75 = -2187.0 / 6784,
                    A76 = 11.0 / 84;
static const double E1 = 71.0 / 57600, E3 = -71.0 / 16695, E4 = 71.0 / 1920,
                    E5 = -17253.0 / 339200, E6 = 22.0 / 525, E7 = -1.0 / 40;
static const double D1 = -12715105075.0 / 11282082432, D3 = 87487479700.0 / 32700410799,
                    D4 = -10690763975.0 / 1880347072, D5 = 701980252875.0 / 199316789632,
                    D6 = -1453857185.0 / 822651844, D7 = 69997945.0 / 29380423;

typedef struct step {
    double y0[NY], y1[NY], k[7][NY], h, error;
} step;

/* One step of h from y0 with k[0] = f(y0); y1, k[1..6] (k[6] = f(y1)) and the error in the
   RMS norm (1: at tolerance). */
static void dopri(step *s, double h, double tol)
{
    double y[NY];
    const double *k1 = s->k[0], *y0 = s->y0;
    double *k2 = s->k[1], *k3 = s->k[2], *k4 = s->k[3], *k5 = s->k[4], *k6 = s->k[5],
           *k7 = s->k[6];
    s->h = h;
    for (int i = 0; i < NY; ++i) y[i] = y0[i] + h * A21 * k1[i];
    rhs(y, k2);
    for (int i = 0; i < NY; ++i) y[i] = y0[i] + h * (A31 * k1[i] + A32 * k2[i]);
    rhs(y, k3);
    for (int i = 0; i < NY; ++i) y[i] = y0[i] + h * (A41 * k1[i] + A42 * k2[i] + A43 * k3[i]);
    rhs(y, k4);
    for (int i = 0; i < NY; ++i)
        y[i] = y0[i] + h * (A51 * k1[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i]);
    rhs(y, k5);
    for (int i = 0; i < NY; ++i)
        y[i] = y0[i] + h * (A61 * k1[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i]
                            + A65 * k5[i]);
    rhs(y, k6);
    for (int i = 0; i < NY; ++i)
        s->y1[i] = y0[i] + h * (A71 * k1[i] + A73 * k3[i] + A74 * k4[i] + A75 * k5[i]
                                + A76 * k6[i]);
    rhs(s->y1, k7);
    double sum = 0;
    for (int i = 0; i < NY; ++i) {
        double e = h * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i]
                        + E7 * k7[i]);
        double a = fabs(y0[i]), b = fabs(s->y1[i]);
        double scale = tol + tol * (a > b ? a : b);
        sum += (e / scale) * (e / scale);
    }
    s->error = sqrt(sum / NY);
}

/* The continuous extension at t0 + theta h (Hairer, Norsett & Wanner, II.6), components
   0..n-1. */
static void dense(const step *s, double theta, int n, double *y)
{
    double t1 = 1 - theta;
    for (int i = 0; i < n; ++i) {
        double dy = s->y1[i] - s->y0[i], bspl = s->h * s->k[0][i] - dy;
        double r5 = s->h * (D1 * s->k[0][i] + D3 * s->k[2][i] + D4 * s->k[3][i]
                            + D5 * s->k[4][i] + D6 * s->k[5][i] + D7 * s->k[6][i]);
        y[i] = s->y0[i] + theta * (dy + t1 * (bspl + theta * (dy - s->h * s->k[6][i] - bspl
                                                              + t1 * r5)));
    }
}

/* Hairer's initial step (DOPRI5's HINIT), from y0 and k[0] = f(y0). */
static double initial_step(step *s, double tol, double h_max)
{
    double dnf = 0, dny = 0, y1[NY], f1[NY];
    for (int i = 0; i < NY; ++i) {
        double sk = tol + tol * fabs(s->y0[i]);
        dnf += (s->k[0][i] / sk) * (s->k[0][i] / sk);
        dny += (s->y0[i] / sk) * (s->y0[i] / sk);
    }
    double h = dnf <= 1e-10 || dny <= 1e-10 ? 1e-6 : 0.01 * sqrt(dny / dnf);
    h = fmin(h, h_max);
    for (int i = 0; i < NY; ++i) y1[i] = s->y0[i] + h * s->k[0][i];
    rhs(y1, f1);
    double der2 = 0;
    for (int i = 0; i < NY; ++i) {
        double sk = tol + tol * fabs(s->y0[i]), d = (f1[i] - s->k[0][i]) / sk;
        der2 += d * d;
    }
    der2 = sqrt(der2) / h;
    double der12 = fmax(der2, sqrt(dnf));
    double h1 = der12 <= 1e-15 ? fmax(1e-6, h * 1e-3) : pow(0.01 / der12, 0.2);
    return fmin(fmin(100 * h, h1), h_max);
}

/* ---- latches ----------------------------------------------------------------------------- */

/* The plastic impact of the hinges just locked (their rates in y still those before). */
static void impact(double *y)
{
    double m[N][N], c[6], s[6], r[N], dx[N];
    relative_angles(y, c, s);
    joint_mass(c, m);
    /* right side M_FL theta'_L on the free rows */
    for (int i = 0; i < N; ++i) {
        r[i] = 0.0;
        for (int j = 0; j < N; ++j)
            if (locked[j]) r[i] += m[i][j] * y[N + j];
    }
    lock_rows(m, r);
    solve(m, r, dx);
    for (int i = 0; i < N; ++i) y[N + i] = locked[i] ? 0.0 : y[N + i] + dx[i];
}

/* The first hinge (not locked) whose angle crossed its latch in the step, and when (as a
   fraction of the step: bisection on its component of the continuous extension); -1 if
   none. */
static int crossing(const step *s, double *theta)
{
    int found = -1;
    double best = 2;
    for (int k = 0; k < N; ++k) {
        if (locked[k] || !(s->y1[k] >= LATCH[k])) continue;
        double lo = 0, hi = 1, y[N];
        for (int it = 0; it < 60; ++it) {
            double mid = 0.5 * (lo + hi);
            dense(s, mid, k + 1, y);
            if (y[k] >= LATCH[k]) hi = mid; else lo = mid;
        }
        if (hi < best) {
            best = hi;
            found = k;
        }
    }
    *theta = best;
    return found;
}

/* ---- the run ----------------------------------------------------------------------------- */

static double seconds(void)
{
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return now.tv_sec + 1e-9 * now.tv_nsec;
}

/* --time-rhs: the states the run's accepted steps started from, with their latches. */
typedef struct sample {
    double y[NY];
    int locked[N];
} sample;
static sample *samples;
static long n_samples, samples_size;

static void keep_sample(const double *y)
{
    if (n_samples == samples_size) {
        samples_size = samples_size ? 2 * samples_size : 4096;
        samples = realloc(samples, samples_size * sizeof *samples);
        if (!samples) {
            fprintf(stderr, "out of memory\n");
            exit(1);
        }
    }
    memcpy(samples[n_samples].y, y, sizeof samples->y);
    memcpy(samples[n_samples].locked, locked, sizeof locked);
    n_samples++;
}

/* --time-rhs, inside a run: each evaluation between two clock readings (rhs passes its calls
   here while timing_calls is set). */
static double rhs_seconds;

static void timed_rhs(const double *restrict y, double *restrict dy)
{
    timing_calls = 0;
    double start = seconds();
    rhs(y, dy);
    rhs_seconds += seconds() - start;
    timing_calls = 1;
}

/* One run from the stowed state at rest to t_end: rows every dt_out to csv (NULL: none),
   latch times on stderr when report is set, the states of the steps kept when keep is. */
static void integrate(double t_end, double tol, double dt_out, FILE *csv, int report, int keep,
                      long *steps, long *rejected)
{
    step s;
    memset(&s, 0, sizeof s); /* stowed, at rest */
    memset(locked, 0, sizeof locked);
    any_locked = 0;
    const double h_max = t_end;
    const double beta = 0.04, expo = 0.2 - 0.75 * beta, safe = 0.9;
    double t = 0, y[N], fac_old = 1e-4;
    long next_out = 0;
    int reject = 0;
    *steps = *rejected = 0;
    rhs(s.y0, s.k[0]);
    double h = initial_step(&s, tol, h_max);
    while (t < t_end - 1e-12) {
        if (t + h > t_end) h = t_end - t;
        dopri(&s, h, tol);
        /* Hairer's proportional-integral control: h_new = h / fac */
        double fac11 = pow(s.error, expo);
        double fac = fac11 / pow(fac_old, beta) / safe;
        fac = fac < 0.1 ? 0.1 : fac > 5.0 ? 5.0 : fac;
        if (!(s.error <= 1.0)) {
            ++*rejected;
            h /= fmin(5.0, fac11 / safe);
            reject = 1;
            continue;
        }
        double h_new = fmin(h / fac, h_max);
        if (reject) h_new = fmin(h_new, h);
        reject = 0;
        fac_old = fmax(s.error, 1e-4);
        double theta;
        int k = crossing(&s, &theta);
        if (k >= 0) { /* re-take the step exactly to the crossing, then latch */
            double hk = theta * h;
            for (int it = 0; it < 3; ++it) {
                dopri(&s, hk, tol);
                double g = s.y1[k] - LATCH[k], rate = s.y1[N + k];
                if (rate <= 0 || fabs(g / rate) < 1e-13) break;
                hk -= g / rate;
            }
        }
        for (; csv && next_out * dt_out <= t + s.h + 1e-12 && next_out * dt_out <= t_end + 1e-12;
             ++next_out) {
            dense(&s, (next_out * dt_out - t) / s.h, N, y);
            fprintf(csv, "%.17g,%.17g,%.17g,%.17g,%.17g\n", next_out * dt_out, y[0], y[1], y[2],
                    y[3]);
        }
        if (keep) keep_sample(s.y0);
        ++*steps;
        t += s.h;
        memcpy(s.y0, s.y1, sizeof s.y0);
        memcpy(s.k[0], s.k[6], sizeof s.k[0]);
        if (k >= 0) {
            locked[k] = 1;
            any_locked = 1;
            s.y0[k] = LATCH[k];
            impact(s.y0);
            rhs(s.y0, s.k[0]);
            if (report) fprintf(stderr, "latch h%d t %.12g\n", k + 1, t);
        }
        h = h_new;
    }
}

/* --time-rhs: the right side's own cost, timed in a second run (each call) and in a loop over
   the first run's states (evaluated again and again, in order: independent evaluations, which
   the processor may overlap). */
static void time_rhs(double t_end, double tol)
{
    long steps, rejected, before = evaluations;
    timing_calls = 1;
    integrate(t_end, tol, t_end, NULL, 0, 0, &steps, &rejected);
    timing_calls = 0;
    long calls = evaluations - before;
    double start = seconds(), reading;
    for (int i = 0; i < 100000; ++i) seconds();
    reading = (seconds() - start) / 100000; /* what one clock reading adds to each call */
    fprintf(stderr, "rhs in the run %.1f ns per evaluation (%ld calls, %.1f ns a clock reading "
            "taken off)\n", 1e9 * (rhs_seconds / calls - reading), calls, 1e9 * reading);
    double dy[NY], check = 0;
    long rounds = 0, count = 0;
    double elapsed;
    start = seconds();
    do {
        for (long i = 0; i < n_samples; ++i) {
            memcpy(locked, samples[i].locked, sizeof locked);
            any_locked = locked[0] | locked[1] | locked[2] | locked[3];
            rhs(samples[i].y, dy);
            check += dy[N] + dy[N + 1] + dy[N + 2] + dy[N + 3];
        }
        count += n_samples;
        rounds++;
        elapsed = seconds() - start;
    } while (elapsed < 0.2 || rounds < 3);
    fprintf(stderr, "rhs in a loop %.1f ns per evaluation (%ld evaluations over the %ld states "
            "of the run's steps; check %.6g)\n", 1e9 * elapsed / count, count, n_samples,
            check / count);
}

int main(int argc, char **argv)
{
    double t_end = 70.0, tol = 1e-8, dt_out = 0.05;
    const char *out = NULL;
    int timing = 0;
    for (int i = 1; i < argc; ++i) {
        if (strcmp(argv[i], "--time-rhs") == 0) timing = 1;
        else if (i + 1 < argc && strcmp(argv[i], "--t-end") == 0) t_end = atof(argv[++i]);
        else if (i + 1 < argc && strcmp(argv[i], "--tol") == 0) tol = atof(argv[++i]);
        else if (i + 1 < argc && strcmp(argv[i], "--dt-out") == 0) dt_out = atof(argv[++i]);
        else if (i + 1 < argc && strcmp(argv[i], "-o") == 0) out = argv[++i];
        else {
            fprintf(stderr, "usage: %s [--t-end T] [--tol TOL] [--dt-out DT] [-o out.csv] "
                    "[--time-rhs]\n", argv[0]);
            return 2;
        }
    }
    FILE *csv = out ? fopen(out, "w") : NULL;
    if (out && !csv) {
        perror(out);
        return 1;
    }
    if (csv) fprintf(csv, "t,theta1,theta2,theta3,theta4\n");
    double start = seconds();
    long steps, rejected;
    setup();
    integrate(t_end, tol, dt_out, csv, 1, timing, &steps, &rejected);
    double elapsed = seconds() - start;
    if (csv) fclose(csv);
    fprintf(stderr, "steps %ld rejected %ld evaluations %ld\n", steps, rejected, evaluations);
    fprintf(stderr, "time %.3f ms, %.1f ns per evaluation\n", 1e3 * elapsed,
            1e9 * elapsed / evaluations);
    if (timing) time_rhs(t_end, tol);
    return 0;
}
