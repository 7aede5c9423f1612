/* intelsat_hand.c: a minimal hand-written solver of the INTELSAT V deployment, the baseline
 * depsim is measured against (bench/bench_intelsat.py) and the test suite's reference
 * (tests/examples/test_intelsat5.py). Nothing is shared with depsim.
 *
 * Four joint coordinates, the hinge angles theta1..4 (docs/examples.md): absolute angles
 * phi = A theta + c, each member's centre of mass a sum along the chain, so
 *
 *     M(theta) theta'' = Q(theta, theta') - sum_k m_k Jv_k^T b_k(theta, theta')
 *
 * with M = sum_k m_k Jv_k^T Jv_k + J_k A_k^T A_k, b_k the velocity-product acceleration of
 * centre k, Q the springs (T0 - k theta), the cable loops (-k_c C^T C theta) and the hinge
 * friction -F tanh(theta' / 1e-3). Dormand-Prince 5(4) with the usual step control (atol =
 * rtol = tol, safety 0.9, factor in [0.2, 10]); a hinge reaching its deployed angle latches
 * (located on the continuous extension, the step re-taken to it), with a plastic impact
 * theta'+_F = theta'-_F + M_FF^-1 M_FL theta'-_L; locked coordinates leave the equations.
 *
 *     cc -O2 -std=c99 -o intelsat_hand intelsat_hand.c -lm
 *     ./intelsat_hand [--t-end T] [--tol TOL] [--dt-out DT] [-o out.csv]
 *
 * Prints "steps S rejected R evaluations E" and the latch times on stderr.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define N 4
#define PI 3.141592653589793

static const double L[N] = {1.090, 1.965, 1.965, 1.936};
static const double MASS[N] = {2.222, 12.377, 9.982, 8.920};
static const double INERTIA[N] = {0.2798, 4.2009, 3.8773, 2.9316};
static const double FRICTION[N] = {0.68, 0.64, 0.69, 0.70};
static const double STIFFNESS[N] = {0.1273, 0.1305, 0.1305, 0.1305};
static const double PRELOAD[N] = {1.70, 0.85, 0.85, 0.85};
static const double LATCH[N] = {PI / 2, PI, PI, PI};
static const double A[N][N] = {{1, 0, 0, 0}, {1, 1, 0, 0}, {1, 1, -1, 0}, {1, 1, -1, 1}};
static const double C_OFFSET[N] = {0, -PI, 0, -PI};
static const double CABLE[3][N] = {{2, -1, 0, 0}, {0, 1, -1, 0}, {0, 0, 1, -1}};
#define CABLE_K (4500.0 * 0.01835 * 0.01835)
#define SLIP_RATE 1e-3

static int locked[N];
static long evaluations;

/* theta'' (locked coordinates stay at rest) from y = (theta, theta'). */
static void rhs(const double *y, double *dy)
{
    const double *th = y, *w = y + N;
    double phi[N], dphi[N], M[N][N] = {{0}}, f[N];
    evaluations++;
    for (int k = 0; k < N; ++k) {
        phi[k] = C_OFFSET[k];
        dphi[k] = 0;
        for (int j = 0; j < N; ++j) {
            phi[k] += A[k][j] * th[j];
            dphi[k] += A[k][j] * w[j];
        }
    }
    for (int i = 0; i < N; ++i) { /* generalized forces */
        double cable = 0;
        for (int c = 0; c < 3; ++c) {
            double e = 0;
            for (int j = 0; j < N; ++j) {
                e += CABLE[c][j] * th[j];
            }
            cable += CABLE[c][i] * e;
        }
        f[i] = PRELOAD[i] - STIFFNESS[i] * th[i] - CABLE_K * cable
               - FRICTION[i] * tanh(w[i] / SLIP_RATE);
    }
    double s[N], c[N];
    for (int k = 0; k < N; ++k) {
        s[k] = sin(phi[k]);
        c[k] = cos(phi[k]);
    }
    for (int k = 0; k < N; ++k) { /* member k: centre Jacobian Jv (2 x N) and bias b */
        double jv[2][N] = {{0}}, b[2] = {0, 0};
        for (int j = 0; j <= k; ++j) {
            double arm = j < k ? L[j] : L[j] / 2;
            for (int i = 0; i < N; ++i) {
                jv[0][i] += -arm * s[j] * A[j][i];
                jv[1][i] += arm * c[j] * A[j][i];
            }
            b[0] -= arm * dphi[j] * dphi[j] * c[j];
            b[1] -= arm * dphi[j] * dphi[j] * s[j];
        }
        for (int i = 0; i < N; ++i) {
            for (int j = 0; j < N; ++j) {
                M[i][j] += MASS[k] * (jv[0][i] * jv[0][j] + jv[1][i] * jv[1][j])
                           + INERTIA[k] * A[k][i] * A[k][j];
            }
            f[i] -= MASS[k] * (jv[0][i] * b[0] + jv[1][i] * b[1]);
        }
    }
    int free[N], n = 0;
    for (int i = 0; i < N; ++i) {
        if (!locked[i]) {
            free[n++] = i;
        }
    }
    double K[N][N + 1];
    for (int a = 0; a < n; ++a) { /* M_FF x = f_F by Gaussian elimination */
        for (int b2 = 0; b2 < n; ++b2) {
            K[a][b2] = M[free[a]][free[b2]];
        }
        K[a][n] = f[free[a]];
    }
    for (int p = 0; p < n; ++p) {
        for (int r = p + 1; r < n; ++r) {
            double factor = K[r][p] / K[p][p];
            for (int q = p; q <= n; ++q) {
                K[r][q] -= factor * K[p][q];
            }
        }
    }
    double x[N];
    for (int p = n - 1; p >= 0; --p) {
        double sum = K[p][n];
        for (int q = p + 1; q < n; ++q) {
            sum -= K[p][q] * x[q];
        }
        x[p] = sum / K[p][p];
    }
    for (int i = 0; i < N; ++i) {
        dy[i] = locked[i] ? 0.0 : w[i];
        dy[N + i] = 0.0;
    }
    for (int a = 0; a < n; ++a) {
        dy[N + free[a]] = x[a];
    }
}

/* ---- Dormand-Prince 5(4) ---------------------------------------------------------------- */

#define NY (2 * N)
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

/* One step from y0 with k[0] = f(y0); the error in the RMS norm (1: at tolerance). */
static void dopri(step *s, double h, double tol)
{
    double y[NY];
    const double *k1 = s->k[0];
    double *k2 = s->k[1], *k3 = s->k[2], *k4 = s->k[3], *k5 = s->k[4], *k6 = s->k[5],
           *k7 = s->k[6];
    s->h = h;
    for (int i = 0; i < NY; ++i) y[i] = s->y0[i] + h * A21 * k1[i];
    rhs(y, k2);
    for (int i = 0; i < NY; ++i) y[i] = s->y0[i] + h * (A31 * k1[i] + A32 * k2[i]);
    rhs(y, k3);
    for (int i = 0; i < NY; ++i) y[i] = s->y0[i] + h * (A41 * k1[i] + A42 * k2[i] + A43 * k3[i]);
    rhs(y, k4);
    for (int i = 0; i < NY; ++i)
        y[i] = s->y0[i] + h * (A51 * k1[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i]);
    rhs(y, k5);
    for (int i = 0; i < NY; ++i)
        y[i] = s->y0[i] + h * (A61 * k1[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i]
                               + A65 * k5[i]);
    rhs(y, k6);
    for (int i = 0; i < NY; ++i)
        s->y1[i] = s->y0[i] + h * (A71 * k1[i] + A73 * k3[i] + A74 * k4[i] + A75 * k5[i]
                                   + A76 * k6[i]);
    rhs(s->y1, k7);
    double sum = 0;
    for (int i = 0; i < NY; ++i) {
        double e = h * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i]
                        + E7 * k7[i]);
        double scale = tol + tol * fmax(fabs(s->y0[i]), fabs(s->y1[i]));
        sum += (e / scale) * (e / scale);
    }
    s->error = sqrt(sum / NY);
}

/* The continuous extension at t0 + theta h (Hairer, Norsett & Wanner, II.6). */
static void dense(const step *s, double theta, double *y)
{
    double t1 = 1 - theta;
    for (int i = 0; i < NY; ++i) {
        double dy = s->y1[i] - s->y0[i], bspl = s->h * s->k[0][i] - dy;
        double r5 = s->h * (D1 * s->k[0][i] + D3 * s->k[2][i] + D4 * s->k[3][i]
                            + D5 * s->k[4][i] + D6 * s->k[5][i] + D7 * s->k[6][i]);
        y[i] = s->y0[i] + theta * (dy + t1 * (bspl + theta * (dy - s->h * s->k[6][i] - bspl
                                                              + t1 * r5)));
    }
}

/* ---- latches ----------------------------------------------------------------------------- */

static void impact(double *y)
{
    double M[N][N] = {{0}}, phi[N], s[N], c[N];
    for (int k = 0; k < N; ++k) {
        phi[k] = C_OFFSET[k];
        for (int j = 0; j < N; ++j) phi[k] += A[k][j] * y[j];
        s[k] = sin(phi[k]);
        c[k] = cos(phi[k]);
    }
    for (int k = 0; k < N; ++k) {
        double jv[2][N] = {{0}};
        for (int j = 0; j <= k; ++j) {
            double arm = j < k ? L[j] : L[j] / 2;
            for (int i = 0; i < N; ++i) {
                jv[0][i] += -arm * s[j] * A[j][i];
                jv[1][i] += arm * c[j] * A[j][i];
            }
        }
        for (int i = 0; i < N; ++i)
            for (int j = 0; j < N; ++j)
                M[i][j] += MASS[k] * (jv[0][i] * jv[0][j] + jv[1][i] * jv[1][j])
                           + INERTIA[k] * A[k][i] * A[k][j];
    }
    /* theta'+_F = theta'-_F + M_FF^-1 M_FL theta'-_L, theta'+_L = 0 */
    int free[N], n = 0;
    for (int i = 0; i < N; ++i) if (!locked[i]) free[n++] = i;
    double K[N][N + 1];
    for (int a = 0; a < n; ++a) {
        double rhs_a = 0;
        for (int j = 0; j < N; ++j) if (locked[j]) rhs_a += M[free[a]][j] * y[N + j];
        for (int b = 0; b < n; ++b) K[a][b] = M[free[a]][free[b]];
        K[a][n] = rhs_a;
    }
    for (int p = 0; p < n; ++p)
        for (int r = p + 1; r < n; ++r) {
            double factor = K[r][p] / K[p][p];
            for (int q = p; q <= n; ++q) K[r][q] -= factor * K[p][q];
        }
    double x[N];
    for (int p = n - 1; p >= 0; --p) {
        double sum = K[p][n];
        for (int q = p + 1; q < n; ++q) sum -= K[p][q] * x[q];
        x[p] = sum / K[p][p];
    }
    for (int a = 0; a < n; ++a) y[N + free[a]] += x[a];
    for (int j = 0; j < N; ++j) if (locked[j]) y[N + j] = 0.0;
}

/* The first hinge (not locked) whose angle crossed its latch in the step, and when (as a
   fraction of the step, by bisection on the continuous extension); -1 if none. */
static int crossing(const step *s, double *theta)
{
    int found = -1;
    double best = 2;
    for (int k = 0; k < N; ++k) {
        if (locked[k] || !(s->y1[k] >= LATCH[k])) continue;
        double lo = 0, hi = 1, y[NY];
        for (int it = 0; it < 60; ++it) {
            double mid = 0.5 * (lo + hi);
            dense(s, mid, y);
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

int main(int argc, char **argv)
{
    double t_end = 70.0, tol = 1e-8, dt_out = 0.05;
    const char *out = NULL;
    for (int i = 1; i + 1 < argc; i += 2) {
        if (strcmp(argv[i], "--t-end") == 0) t_end = atof(argv[i + 1]);
        else if (strcmp(argv[i], "--tol") == 0) tol = atof(argv[i + 1]);
        else if (strcmp(argv[i], "--dt-out") == 0) dt_out = atof(argv[i + 1]);
        else if (strcmp(argv[i], "-o") == 0) out = argv[i + 1];
    }
    FILE *csv = out ? fopen(out, "w") : NULL;
    if (csv) fprintf(csv, "t,theta1,theta2,theta3,theta4\n");
    step s;
    memset(&s, 0, sizeof s);
    double t = 0, h = 1e-4, y[NY];
    long steps = 0, rejected = 0, next_out = 0;
    rhs(s.y0, s.k[0]);
    while (t < t_end - 1e-12) {
        h = fmin(h, t_end - t);
        dopri(&s, h, tol);
        if (s.error > 1.0) {
            rejected++;
            h *= fmax(0.2, 0.9 * pow(s.error, -0.2));
            continue;
        }
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
            dense(&s, (next_out * dt_out - t) / s.h, y);
            fprintf(csv, "%.17g,%.17g,%.17g,%.17g,%.17g\n", next_out * dt_out, y[0], y[1], y[2],
                    y[3]);
        }
        steps++;
        t += s.h;
        memcpy(s.y0, s.y1, sizeof s.y0);
        memcpy(s.k[0], s.k[6], sizeof s.k[0]);
        if (k >= 0) {
            locked[k] = 1;
            s.y0[k] = LATCH[k];
            impact(s.y0);
            rhs(s.y0, s.k[0]);
            fprintf(stderr, "latch h%d t %.12g\n", k + 1, t);
        }
        h = s.h * fmin(10.0, fmax(0.2, 0.9 * pow(fmax(s.error, 1e-10), -0.2)));
    }
    fprintf(stderr, "steps %ld rejected %ld evaluations %ld\n", steps, rejected, evaluations);
    if (csv) fclose(csv);
    return 0;
}
