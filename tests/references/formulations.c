/* formulations.c: the spatial formulations depsim's coordinates are measured against
 * (bench/bench_formulation.py; checked by tests/references/test_formulations.py). Nothing is
 * shared with depsim. Built by tests/references/formulations.py with the Euler-parameter
 * kernels it generates with sympy (ep_kernels.c):
 *
 *     cc -O2 -fno-math-errno -std=c99 -I BUILD -o formulations formulations.c -lm
 *     ./formulations METHOD SPEC [--tol TOL] [--t-end T] [--dt-out DT] [-o out.csv]
 *                    [--repeat R] [--time-rhs] [--alpha A] [--derivative]
 *
 * SPEC is the mechanism (written by formulations.py): rigid bodies in a tree of hinges from
 * the ground, or one free body. METHOD:
 *
 * ep          Euler parameters: body i has q_i = (r_i, p_i), its centre of mass and a
 *             quaternion p = (e0, e1, e2, e3). The mass matrix M(p) = diag(m 1, 4 L^T J L)
 *             depends on p (L the 3 x 4 matrix of omega' = 2 L p'); the norm row p.p = 1 and
 *             each hinge's five rows (its points coincide, its axis fixed in both members)
 *             are solved with the accelerations at every evaluation, the index-1 system
 *             [M Phi_q^T; Phi_q 0] [q''; lambda] = [Q; gamma - 2 a Phi' - a^2 Phi]
 *             (Baumgarte, a = --alpha, default 10 1/s): M is singular along p, so each
 *             body's block is M + c p p^T (c = 4 tr(J) / 3) with Q + (c / 2) gamma_p p, the
 *             same solution since p^T p'' = gamma_p / 2 is one of the rows; per body a 4 x 4
 *             Cholesky factor, then S = Phi_q M^-1 Phi_q^T in envelope form (a chain's rows
 *             in body order: a band of 11), its Cholesky factor, the multipliers and q''.
 * ep-project  the same without Baumgarte, the positions and velocities projected onto the
 *             rows (M-orthogonally: Newton on Phi = 0 to 0.01 tol, then Phi_q q' = 0) after
 *             every accepted step, and the step's last stage evaluated again.
 * joint       joint coordinates (the hinge angles) of a tree of hinges, Featherstone's
 *             articulated-body algorithm (O(n), no mass matrix formed).
 * angles      one free body in z-y-x Euler angles (R = Rz(psi) Ry(theta) Rx(phi)) and its
 *             body angular velocity, Euler's equations: singular where cos(theta) = 0.
 * quat        one free body, a quaternion and its body angular velocity (Euler's equations,
 *             q' = q (x) (0, w) / 2, R from q / |q|; no multipliers): 7 states.
 *
 * Every method is integrated by Dormand-Prince 5(4) as Hairer & Wanner's DOPRI5 (atol = rtol
 * = tol in the RMS norm, the proportional-integral step control, beta 0.04) with its
 * continuous extension at the output times: t, then each body's r (3) and R (9, row by
 * row), the energy and the constraint residual (ep: max |Phi|; joint: 0; angles:
 * |cos(theta)|; quat: | |q| - 1 |) every dt_out to out.csv.
 *
 * Stderr gets one line of JSON: steps, rejected steps, evaluations and the largest residual
 * over the accepted steps of the first run; the wall and CPU seconds of each of the --repeat
 * runs after it (no output rows, no checks: the method alone); with --time-rhs the cost of
 * one right-side evaluation, ns, at every 97th call of one more run: 20 evaluations of that
 * call's state timed together, each sample one number (their median is the figure).
 * --derivative prints the right side at the initial state instead of running.
 */
#define _POSIX_C_SOURCE 199309L /* clock_gettime */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ep_kernels.h"

#define MAXB 256

/* ---- the mechanism ---------------------------------------------------------------------- */

typedef struct hinge {
    int parent;                    /* -1: the ground */
    double sA[3], sB[3];           /* points: parent frame from its centre (ground: world), child */
    double a[3], e[3], f[3];       /* unit axis in the parent's frame and two normals to it */
    double aB[3];                  /* the axis in the child's frame */
} hinge;

static int nb;                             /* bodies */
static double g[3];                        /* gravity */
static double mass[MAXB], J[MAXB][9];      /* inertia about the centre, body frame */
static double J6[MAXB][6], cmod[MAXB];     /* (Jxx, Jyy, Jzz, Jxy, Jyz, Jxz); c of M + c p p^T */
static int has_hinge[MAXB];
static hinge H[MAXB];                      /* body i's hinge to its parent */
static double theta0[MAXB], rate0[MAXB];   /* joint: initial angles and rates */
static double *ep_y0;                      /* ep: q0, qd0 (14 nb) */
static double quat0[4], w0[3], euler0[3];  /* one free body: quaternion, body rates, angles */
static double Jinv[9];                     /* free body: J^-1 */

static void fail(const char *what)
{
    fprintf(stderr, "formulations: %s\n", what);
    exit(2);
}

static void read_numbers(FILE *in, int n, double *x)
{
    for (int i = 0; i < n; ++i)
        if (fscanf(in, "%lf", &x[i]) != 1) fail("bad spec: a number expected");
}

static void read_spec(const char *path)
{
    FILE *in = fopen(path, "r");
    char key[64];
    int ib = 0;
    if (!in) fail("cannot open the spec");
    while (fscanf(in, "%63s", key) == 1) {
        if (strcmp(key, "bodies") == 0) {
            if (fscanf(in, "%d", &nb) != 1 || nb < 1 || nb > MAXB) fail("bad body count");
            ep_y0 = calloc(14 * (size_t)nb, sizeof *ep_y0);
        } else if (strcmp(key, "gravity") == 0) {
            read_numbers(in, 3, g);
        } else if (strcmp(key, "body") == 0) {
            if (ib >= nb) fail("too many bodies");
            read_numbers(in, 1, &mass[ib]);
            read_numbers(in, 9, J[ib]);
            double *j = J[ib];
            J6[ib][0] = j[0]; J6[ib][1] = j[4]; J6[ib][2] = j[8];
            J6[ib][3] = j[1]; J6[ib][4] = j[5]; J6[ib][5] = j[2];
            cmod[ib] = 4.0 * (j[0] + j[4] + j[8]) / 3.0;
            ib++;
        } else if (strcmp(key, "hinge") == 0) { /* child parent sA sB a e f aB */
            int child;
            double parent;
            if (fscanf(in, "%d", &child) != 1 || child < 0 || child >= nb) fail("bad hinge");
            read_numbers(in, 1, &parent);
            hinge *h = &H[child];
            h->parent = (int)parent;
            if (h->parent >= child) fail("a hinge's parent must come before its child");
            read_numbers(in, 3, h->sA);
            read_numbers(in, 3, h->sB);
            read_numbers(in, 3, h->a);
            read_numbers(in, 3, h->e);
            read_numbers(in, 3, h->f);
            read_numbers(in, 3, h->aB);
            has_hinge[child] = 1;
        } else if (strcmp(key, "theta0") == 0) {
            read_numbers(in, nb, theta0);
        } else if (strcmp(key, "rate0") == 0) {
            read_numbers(in, nb, rate0);
        } else if (strcmp(key, "ep_y0") == 0) {
            read_numbers(in, 14 * nb, ep_y0);
        } else if (strcmp(key, "quat0") == 0) {
            read_numbers(in, 4, quat0);
        } else if (strcmp(key, "w0") == 0) {
            read_numbers(in, 3, w0);
        } else if (strcmp(key, "euler0") == 0) {
            read_numbers(in, 3, euler0);
        } else {
            fail("unknown key in the spec");
        }
    }
    fclose(in);
    if (ib != nb) fail("fewer bodies than announced");
}

/* ---- small algebra ---------------------------------------------------------------------- */

static inline void cross(const double *a, const double *b, double *c)
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

static inline double dot3(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static inline void matvec3(const double *A, const double *x, double *y) /* y = A x */
{
    for (int i = 0; i < 3; ++i) y[i] = A[3 * i] * x[0] + A[3 * i + 1] * x[1] + A[3 * i + 2] * x[2];
}

static inline void mattvec3(const double *A, const double *x, double *y) /* y = A^T x */
{
    for (int i = 0; i < 3; ++i) y[i] = A[i] * x[0] + A[3 + i] * x[1] + A[6 + i] * x[2];
}

static void matmul3(const double *A, const double *B, double *C) /* C = A B */
{
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
}

/* Rodrigues: the rotation by angle about the unit axis a. */
static void rotation(const double *a, double angle, double *R)
{
    double c = cos(angle), s = sin(angle), k = 1 - c, x = a[0], y = a[1], z = a[2];
    R[0] = c + k * x * x;     R[1] = k * x * y - s * z; R[2] = k * x * z + s * y;
    R[3] = k * x * y + s * z; R[4] = c + k * y * y;     R[5] = k * y * z - s * x;
    R[6] = k * x * z - s * y; R[7] = k * y * z + s * x; R[8] = c + k * z * z;
}

/* R(p), homogeneous of degree 2: (e0^2 - e.e) 1 + 2 e e^T + 2 e0 [e]x. */
static void quaternion_matrix(const double *p, double *R)
{
    double w = p[0], x = p[1], y = p[2], z = p[3], d = w * w - x * x - y * y - z * z;
    R[0] = d + 2 * x * x;         R[1] = 2 * (x * y - w * z); R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z);   R[4] = d + 2 * y * y;       R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y);   R[7] = 2 * (y * z + w * x); R[8] = d + 2 * z * z;
}

/* omega' = 2 L(p) p' (body frame). */
static void body_rate(const double *p, const double *pd, double *w)
{
    w[0] = 2 * (-p[1] * pd[0] + p[0] * pd[1] + p[3] * pd[2] - p[2] * pd[3]);
    w[1] = 2 * (-p[2] * pd[0] - p[3] * pd[1] + p[0] * pd[2] + p[1] * pd[3]);
    w[2] = 2 * (-p[3] * pd[0] + p[2] * pd[1] - p[1] * pd[2] + p[0] * pd[3]);
}

/* In-place Cholesky of a 4 x 4 (row-major, lower triangle used) and its solve. */
static inline void chol4(double *A)
{
    for (int j = 0; j < 4; ++j) {
        double s = A[5 * j];
        for (int k = 0; k < j; ++k) s -= A[4 * j + k] * A[4 * j + k];
        double d = sqrt(s);
        A[5 * j] = d;
        for (int i = j + 1; i < 4; ++i) {
            double t = A[4 * i + j];
            for (int k = 0; k < j; ++k) t -= A[4 * i + k] * A[4 * j + k];
            A[4 * i + j] = t / d;
        }
    }
}

static inline void chol4_solve(const double *L, const double *b, double *x)
{
    double y[4];
    for (int i = 0; i < 4; ++i) {
        double s = b[i];
        for (int k = 0; k < i; ++k) s -= L[4 * i + k] * y[k];
        y[i] = s / L[5 * i];
    }
    for (int i = 3; i >= 0; --i) {
        double s = y[i];
        for (int k = i + 1; k < 4; ++k) s -= L[4 * k + i] * x[k];
        x[i] = s / L[5 * i];
    }
}

static double seconds(clockid_t clock)
{
    struct timespec now;
    clock_gettime(clock, &now);
    return now.tv_sec + 1e-9 * now.tv_nsec;
}

/* ---- Euler parameters ------------------------------------------------------------------- */

/* Rows: body b's hinge rows (5, on its parent and b), then its norm row. The envelope of S:
   row r from first[r]. Each row touches one or two bodies (its blocks of Phi_q, 7 wide). */
static int nrows, *row_body[2], *row_nbodies, *first, *env_start, env_size;
static int *body_rows, *body_slots, *body_nrows; /* rows touching body b: body_rows[16 b + k],
                                                     in order; their slot (0, 1) in Jq and Y */
static int *body_offsets; /* S's entry of the pair (k, l <= k) of body b's rows: 136 b + ... */
static double *Jq, *Y;              /* per row and touched body: 7 of Phi_q, 7 of M^-1 Phi_q^T */
static double *phi_v, *gam_v, *lam_v, *rhs_v, *S, *Minv, *zq;
static double alpha = 10.0;

static void ep_setup(void)
{
    nrows = 0;
    for (int b = 0; b < nb; ++b) nrows += (has_hinge[b] ? 5 : 0) + 1;
    row_body[0] = malloc(nrows * sizeof(int));
    row_body[1] = malloc(nrows * sizeof(int));
    row_nbodies = malloc(nrows * sizeof(int));
    first = malloc(nrows * sizeof(int));
    env_start = malloc((nrows + 1) * sizeof(int));
    body_rows = malloc(16 * (size_t)nb * sizeof(int));
    body_slots = malloc(16 * (size_t)nb * sizeof(int));
    body_offsets = malloc(136 * (size_t)nb * sizeof(int));
    body_nrows = calloc(nb, sizeof(int));
    int r = 0;
    for (int b = 0; b < nb; ++b) {
        if (has_hinge[b])
            for (int k = 0; k < 5; ++k, ++r) {
                row_nbodies[r] = H[b].parent >= 0 ? 2 : 1;
                row_body[0][r] = b;
                row_body[1][r] = H[b].parent;
            }
        row_nbodies[r] = 1;
        row_body[0][r] = b;
        row_body[1][r] = -1;
        r++;
    }
    for (r = 0; r < nrows; ++r)
        for (int k = 0; k < row_nbodies[r]; ++k) {
            int b = row_body[k][r];
            if (body_nrows[b] == 16) fail("a body with more than 16 rows");
            body_slots[16 * b + body_nrows[b]] = k;
            body_rows[16 * b + body_nrows[b]++] = r;
        }
    env_size = 0;
    for (r = 0; r < nrows; ++r) {
        int lo = r;
        for (int k = 0; k < row_nbodies[r]; ++k) {
            int b = row_body[k][r];
            if (body_rows[16 * b] < lo) lo = body_rows[16 * b];
        }
        first[r] = lo;
        env_start[r] = env_size;
        env_size += r - lo + 1;
    }
    env_start[nrows] = env_size;
    for (int b = 0; b < nb; ++b) {
        const int *rows = body_rows + 16 * b;
        for (int i = 0, k = 0; i < body_nrows[b]; ++i)
            for (int j = 0; j <= i; ++j, ++k)
                body_offsets[136 * b + k] = env_start[rows[i]] + rows[j] - first[rows[i]];
    }
    Jq = malloc(14 * (size_t)nrows * sizeof *Jq);
    Y = malloc(14 * (size_t)nrows * sizeof *Y);
    phi_v = malloc(nrows * sizeof *phi_v);
    gam_v = malloc(nrows * sizeof *gam_v);
    lam_v = malloc(nrows * sizeof *lam_v);
    rhs_v = malloc(nrows * sizeof *rhs_v);
    S = malloc(env_size * sizeof *S);
    Minv = malloc(16 * (size_t)nb * sizeof *Minv);
    zq = malloc(7 * (size_t)nb * sizeof *zq);
}

/* Phi, Phi_q (Jq, by row and touched body) and gamma at (q, qd); with qd NULL no gamma. */
static void ep_rows(const double *q, const double *qd)
{
    double jac[70], ph[5], ga[5], zero[7] = {0};
    int r = 0;
    for (int b = 0; b < nb; ++b) {
        const double *qb = q + 7 * b, *qdb = qd ? qd + 7 * b : zero;
        if (has_hinge[b]) {
            const hinge *h = &H[b];
            double par[15];
            memcpy(par, h->sA, 3 * sizeof(double));
            memcpy(par + 3, h->sB, 3 * sizeof(double));
            memcpy(par + 6, h->e, 3 * sizeof(double));
            memcpy(par + 9, h->f, 3 * sizeof(double));
            memcpy(par + 12, h->aB, 3 * sizeof(double));
            if (h->parent < 0) {
                ep_ground_hinge((double *)qb, (double *)qdb, par, ph, jac, ga);
                for (int k = 0; k < 5; ++k)
                    memcpy(Jq + 14 * (r + k), jac + 7 * k, 7 * sizeof(double));
            } else {
                const double *qa = q + 7 * h->parent, *qda = qd ? qd + 7 * h->parent : zero;
                ep_hinge((double *)qa, (double *)qda, (double *)qb, (double *)qdb, par, ph, jac,
                         ga);
                for (int k = 0; k < 5; ++k) { /* slot 0: the child b, slot 1: the parent */
                    memcpy(Jq + 14 * (r + k), jac + 14 * k + 7, 7 * sizeof(double));
                    memcpy(Jq + 14 * (r + k) + 7, jac + 14 * k, 7 * sizeof(double));
                }
            }
            for (int k = 0; k < 5; ++k, ++r) {
                phi_v[r] = ph[k];
                gam_v[r] = ga[k];
            }
        }
        const double *p = qb + 3, *pd = qdb + 3;
        double *jr = Jq + 14 * r;
        jr[0] = jr[1] = jr[2] = 0;
        for (int k = 0; k < 4; ++k) jr[3 + k] = 2 * p[k];
        phi_v[r] = p[0] * p[0] + p[1] * p[1] + p[2] * p[2] + p[3] * p[3] - 1;
        gam_v[r] = -2 * (pd[0] * pd[0] + pd[1] * pd[1] + pd[2] * pd[2] + pd[3] * pd[3]);
        r++;
    }
}

/* The bodies' mass blocks (M_p + c p p^T, inverted into Minv by its Cholesky factor) and
   forces Q into zq. */
static void ep_masses(const double *q, const double *qd)
{
    for (int b = 0; b < nb; ++b) {
        const double *p = q + 7 * b + 3, *pd = qd + 7 * b + 3;
        double L[16], Qp[4], *A = Minv + 16 * b;
        ep_body((double *)p, (double *)pd, J6[b], &cmod[b], L, Qp);
        chol4(L);
        for (int k = 0; k < 4; ++k) {
            double unit[4] = {0, 0, 0, 0}, x[4];
            unit[k] = 1;
            chol4_solve(L, unit, x);
            for (int i = 0; i < 4; ++i) A[4 * i + k] = x[i];
        }
        for (int k = 0; k < 3; ++k) zq[7 * b + k] = mass[b] * g[k];
        memcpy(zq + 7 * b + 3, Qp, 4 * sizeof(double));
    }
}

/* x = M^-1 v for body b's 7-block (Minv: the 4 x 4 block's inverse, from ep_masses). */
static inline void mass_solve(int b, const double *v, double *x)
{
    const double im = 1.0 / mass[b], *A = Minv + 16 * b;
    x[0] = v[0] * im;
    x[1] = v[1] * im;
    x[2] = v[2] * im;
    for (int i = 0; i < 4; ++i)
        x[3 + i] = A[4 * i] * v[3] + A[4 * i + 1] * v[4] + A[4 * i + 2] * v[5]
                   + A[4 * i + 3] * v[6];
}

static inline double dot7(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4] + a[5] * b[5]
           + a[6] * b[6];
}

/* Y = M^-1 Phi_q^T by row and body; S = Phi_q Y in the envelope (body by body: the rows
   touching a body, in order, a small dense product), factorised. */
static void ep_schur(void)
{
    memset(S, 0, env_size * sizeof *S);
    for (int b = 0; b < nb; ++b) {
        const int n = body_nrows[b], *rows = body_rows + 16 * b, *slots = body_slots + 16 * b;
        const int *offsets = body_offsets + 136 * b;
        const double *jb[16];
        double *yb[16];
        for (int i = 0; i < n; ++i) {
            jb[i] = Jq + 14 * rows[i] + 7 * slots[i];
            yb[i] = Y + 14 * rows[i] + 7 * slots[i];
            mass_solve(b, jb[i], yb[i]);
        }
        for (int i = 0, k = 0; i < n; ++i)
            for (int j = 0; j <= i; ++j, ++k) S[offsets[k]] += dot7(jb[i], yb[j]);
    }
    /* envelope Cholesky, row by row */
    for (int i = 0; i < nrows; ++i) {
        double *Li = S + env_start[i] - first[i];
        for (int j = first[i]; j <= i; ++j) {
            double *Lj = S + env_start[j] - first[j];
            int k0 = first[i] > first[j] ? first[i] : first[j];
            double s = Li[j];
            for (int k = k0; k < j; ++k) s -= Li[k] * Lj[k];
            Li[j] = j < i ? s / Lj[j] : sqrt(s);
        }
    }
}

static void ep_schur_solve(const double *b, double *x)
{
    for (int i = 0; i < nrows; ++i) {
        const double *Li = S + env_start[i] - first[i];
        double s = b[i];
        for (int k = first[i]; k < i; ++k) s -= Li[k] * x[k];
        x[i] = s / Li[i];
    }
    for (int i = nrows - 1; i >= 0; --i) {
        const double *Li = S + env_start[i] - first[i];
        x[i] /= Li[i];
        for (int k = first[i]; k < i; ++k) x[k] -= Li[k] * x[i];
    }
}

/* Phi_q x for one row (x: all of q's size). */
static inline double row_times(int r, const double *x)
{
    double s = dot7(Jq + 14 * r, x + 7 * row_body[0][r]);
    if (row_nbodies[r] == 2) s += dot7(Jq + 14 * r + 7, x + 7 * row_body[1][r]);
    return s;
}

/* x -= Y lambda (M^-1 Phi_q^T lambda), body by body */
static void subtract_y(const double *lam, double *x)
{
    for (int b = 0; b < nb; ++b) {
        const int *rows = body_rows + 16 * b, *slots = body_slots + 16 * b;
        double *xb = x + 7 * b;
        for (int i = 0; i < body_nrows[b]; ++i) {
            const double *yr = Y + 14 * rows[i] + 7 * slots[i], l = lam[rows[i]];
            for (int j = 0; j < 7; ++j) xb[j] -= yr[j] * l;
        }
    }
}

static void ep_rhs(const double *y, double *dy)
{
    int nq = 7 * nb;
    const double *q = y, *qd = y + nq;
    double *qdd = dy + nq;
    memcpy(dy, qd, nq * sizeof(double));
    ep_masses(q, qd);
    ep_rows(q, qd);
    for (int r = 0; r < nrows; ++r)
        gam_v[r] -= 2 * alpha * row_times(r, qd) + alpha * alpha * phi_v[r];
    /* the norm rows' share of M + c p p^T: Q_p + (c / 2) gamma_p p */
    for (int b = 0, r = 0; b < nb; ++b) {
        r += has_hinge[b] ? 5 : 0;
        const double *p = q + 7 * b + 3;
        for (int k = 0; k < 4; ++k) zq[7 * b + 3 + k] += 0.5 * cmod[b] * gam_v[r] * p[k];
        r++;
    }
    for (int b = 0; b < nb; ++b) {
        double v[7];
        memcpy(v, zq + 7 * b, sizeof v);
        mass_solve(b, v, qdd + 7 * b);
    }
    ep_schur();
    for (int r = 0; r < nrows; ++r) rhs_v[r] = row_times(r, qdd) - gam_v[r];
    ep_schur_solve(rhs_v, lam_v);
    subtract_y(lam_v, qdd);
}

static double ep_residual(const double *q)
{
    ep_rows(q, NULL);
    double worst = 0;
    for (int r = 0; r < nrows; ++r)
        if (fabs(phi_v[r]) > worst) worst = fabs(phi_v[r]);
    return worst;
}

/* Project y onto Phi = 0 (Newton, M-orthogonal steps) and Phi_q qd = 0. Returns the
   number of position iterations. */
static int ep_project(double *y, double tol)
{
    int nq = 7 * nb, it;
    double *q = y, *qd = y + nq;
    for (it = 0; it < 4; ++it) {
        ep_rows(q, NULL);
        double worst = 0;
        for (int r = 0; r < nrows; ++r)
            if (fabs(phi_v[r]) > worst) worst = fabs(phi_v[r]);
        ep_masses(q, qd);
        ep_schur();
        if (worst <= 0.01 * tol) break;
        ep_schur_solve(phi_v, lam_v);
        subtract_y(lam_v, q);
    }
    for (int r = 0; r < nrows; ++r) rhs_v[r] = row_times(r, qd);
    ep_schur_solve(rhs_v, lam_v);
    subtract_y(lam_v, qd);
    return it;
}

static double ep_energy(const double *y)
{
    int nq = 7 * nb;
    double E = 0;
    for (int b = 0; b < nb; ++b) {
        const double *r = y + 7 * b, *p = r + 3, *rd = y + nq + 7 * b, *pd = rd + 3;
        double w[3], Jw[3];
        body_rate(p, pd, w);
        matvec3(J[b], w, Jw);
        E += 0.5 * mass[b] * dot3(rd, rd) + 0.5 * dot3(w, Jw) - mass[b] * dot3(g, r);
    }
    return E;
}

/* ---- joint coordinates: the articulated-body algorithm ---------------------------------- */

/* Body i's frame: origin at its hinge point, axes the body's. Spatial vectors (angular,
   linear) in it. X_i from the parent's frame: E = rot(a, theta)^T, r = the origin's offset
   in the parent's frame. I_i: the spatial inertia about the origin (c = -sB). */
static double (*Ispat)[36];

static void joint_setup(void)
{
    Ispat = malloc((size_t)nb * sizeof *Ispat);
    for (int i = 0; i < nb; ++i) {
        if (!has_hinge[i]) fail("joint coordinates need a hinge for every body");
        double *I = Ispat[i], c[3], m = mass[i];
        for (int k = 0; k < 3; ++k) c[k] = -H[i].sB[k];
        double cx[9] = {0, -c[2], c[1], c[2], 0, -c[0], -c[1], c[0], 0};
        memset(I, 0, 36 * sizeof(double));
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b) {
                double ccT = 0; /* (cx cx^T)_ab */
                for (int k = 0; k < 3; ++k) ccT += cx[3 * a + k] * cx[3 * b + k];
                I[6 * a + b] = J[i][3 * a + b] + m * ccT;
                I[6 * a + 3 + b] = m * cx[3 * a + b];
                I[6 * (3 + a) + b] = m * cx[3 * b + a];
                I[6 * (3 + a) + 3 + b] = a == b ? m : 0;
            }
    }
}

static inline void joint_offset(int i, double *r)
{
    const hinge *h = &H[i];
    for (int k = 0; k < 3; ++k) r[k] = h->sA[k] - (h->parent >= 0 ? H[h->parent].sB[k] : 0);
}

/* X m: (E w, E (v - r x w)) */
static inline void xform(const double *E, const double *r, const double *m, double *out)
{
    double t[3], rw[3];
    cross(r, m, rw);
    for (int k = 0; k < 3; ++k) t[k] = m[3 + k] - rw[k];
    matvec3(E, m, out);
    matvec3(E, t, out + 3);
}

/* X^T f: (E^T n + r x E^T F, E^T F) */
static inline void xform_t(const double *E, const double *r, const double *f, double *out)
{
    double n[3], F[3], rF[3];
    mattvec3(E, f, n);
    mattvec3(E, f + 3, F);
    cross(r, F, rF);
    for (int k = 0; k < 3; ++k) {
        out[k] = n[k] + rF[k];
        out[3 + k] = F[k];
    }
}

static inline void crm(const double *v, const double *m, double *out) /* v x m */
{
    double a[3], b[3];
    cross(v, m, out);
    cross(v, m + 3, a);
    cross(v + 3, m, b);
    for (int k = 0; k < 3; ++k) out[3 + k] = a[k] + b[k];
}

static inline void crf(const double *v, const double *f, double *out) /* v x* f */
{
    double a[3], b[3];
    cross(v, f, a);
    cross(v + 3, f + 3, b);
    for (int k = 0; k < 3; ++k) out[k] = a[k] + b[k];
    cross(v, f + 3, out + 3);
}

/* out += X^T I X for X = rot(E) xlt(r) = [[E, 0], [-E [r]x, E]], I = [[A, B], [B^T, C]]
   symmetric: with A', B', C' = E^T (A, B, C) E and T = B' + [r]x C', the blocks are
   A' + [r]x B'^T - T [r]x, T, T^T, C'. */
static void congruence(const double *E, const double *r, const double *I, double *out)
{
    double A[9], B[9], C[9], Ap[9], Bp[9], Cp[9], t1[9], T[9], TL[9];
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
            A[3 * a + b] = I[6 * a + b];
            B[3 * a + b] = I[6 * a + 3 + b];
            C[3 * a + b] = I[6 * (3 + a) + 3 + b];
        }
    /* M' = E^T M E */
    const double *Ms[3] = {A, B, C};
    double *Mp[3] = {Ap, Bp, Cp};
    for (int m = 0; m < 3; ++m) {
        for (int a = 0; a < 3; ++a) /* t1 = M E */
            for (int b = 0; b < 3; ++b)
                t1[3 * a + b] = Ms[m][3 * a] * E[b] + Ms[m][3 * a + 1] * E[3 + b]
                                + Ms[m][3 * a + 2] * E[6 + b];
        for (int a = 0; a < 3; ++a) /* E^T t1 */
            for (int b = 0; b < 3; ++b)
                Mp[m][3 * a + b] = E[a] * t1[b] + E[3 + a] * t1[3 + b] + E[6 + a] * t1[6 + b];
    }
    for (int b = 0; b < 3; ++b) { /* T = B' + [r]x C', column by column */
        double col[3] = {Cp[b], Cp[3 + b], Cp[6 + b]}, x[3];
        cross(r, col, x);
        for (int a = 0; a < 3; ++a) T[3 * a + b] = Bp[3 * a + b] + x[a];
    }
    for (int b = 0; b < 3; ++b) { /* [r]x B'^T: columns r x (row b of B') */
        double x[3];
        cross(r, Bp + 3 * b, x);
        for (int a = 0; a < 3; ++a) TL[3 * a + b] = Ap[3 * a + b] + x[a];
    }
    for (int a = 0; a < 3; ++a) { /* - T [r]x: row a of T [r]x is (row a of T) x r */
        double x[3];
        cross(T + 3 * a, r, x);
        for (int b = 0; b < 3; ++b) TL[3 * a + b] -= x[b];
    }
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
            out[6 * a + b] += TL[3 * a + b];
            out[6 * a + 3 + b] += T[3 * a + b];
            out[6 * (3 + a) + b] += T[3 * b + a];
            out[6 * (3 + a) + 3 + b] += Cp[3 * a + b];
        }
}

static double (*jE)[9], (*jr)[3], (*jv)[6], (*jc)[6], (*jIA)[36], (*jpA)[6], (*jU)[6], *jd, *ju,
    (*ja)[6];

static void joint_alloc(void)
{
    jE = malloc(nb * sizeof *jE); jr = malloc(nb * sizeof *jr); jv = malloc(nb * sizeof *jv);
    jc = malloc(nb * sizeof *jc); jIA = malloc(nb * sizeof *jIA); jpA = malloc(nb * sizeof *jpA);
    jU = malloc(nb * sizeof *jU); jd = malloc(nb * sizeof *jd); ju = malloc(nb * sizeof *ju);
    ja = malloc(nb * sizeof *ja);
}

static void joint_rhs(const double *y, double *dy)
{
    const double *th = y, *thd = y + nb;
    double *thdd = dy + nb;
    memcpy(dy, thd, nb * sizeof(double));
    for (int i = 0; i < nb; ++i) {
        const hinge *h = &H[i];
        double R[9], Iv[6], vJ[6] = {0};
        rotation(h->a, th[i], R);
        for (int a = 0; a < 3; ++a) /* E = R^T */
            for (int b = 0; b < 3; ++b) jE[i][3 * a + b] = R[3 * b + a];
        joint_offset(i, jr[i]);
        if (h->parent >= 0) xform(jE[i], jr[i], jv[h->parent], jv[i]);
        else memset(jv[i], 0, sizeof jv[i]);
        for (int k = 0; k < 3; ++k) {
            vJ[k] = h->a[k] * thd[i];
            jv[i][k] += vJ[k];
        }
        crm(jv[i], vJ, jc[i]);
        memcpy(jIA[i], Ispat[i], sizeof jIA[i]);
        for (int a = 0; a < 6; ++a) {
            double s = 0;
            for (int b = 0; b < 6; ++b) s += Ispat[i][6 * a + b] * jv[i][b];
            Iv[a] = s;
        }
        crf(jv[i], Iv, jpA[i]);
    }
    for (int i = nb - 1; i >= 0; --i) {
        const hinge *h = &H[i];
        const double *a = h->a, *IA = jIA[i];
        for (int k = 0; k < 6; ++k)
            jU[i][k] = IA[6 * k] * a[0] + IA[6 * k + 1] * a[1] + IA[6 * k + 2] * a[2];
        jd[i] = dot3(a, jU[i]);
        ju[i] = -dot3(a, jpA[i]);
        if (h->parent < 0) continue;
        double Ia[36], pa[6], Ic[6], w[6], inv_d = 1.0 / jd[i];
        for (int k = 0; k < 6; ++k) w[k] = jU[i][k] * inv_d;
        for (int k = 0; k < 6; ++k)
            for (int l = 0; l < 6; ++l) Ia[6 * k + l] = IA[6 * k + l] - jU[i][k] * w[l];
        for (int k = 0; k < 6; ++k) {
            double s = 0;
            for (int l = 0; l < 6; ++l) s += Ia[6 * k + l] * jc[i][l];
            Ic[k] = s;
        }
        for (int k = 0; k < 6; ++k) pa[k] = jpA[i][k] + Ic[k] + w[k] * ju[i];
        const double *E = jE[i], *r = jr[i];
        congruence(E, r, Ia, jIA[h->parent]);
        double pp[6];
        xform_t(E, r, pa, pp);
        for (int k = 0; k < 6; ++k) jpA[h->parent][k] += pp[k];
    }
    for (int i = 0; i < nb; ++i) {
        const hinge *h = &H[i];
        double ap[6];
        if (h->parent >= 0) {
            xform(jE[i], jr[i], ja[h->parent], ap);
        } else { /* the ground's acceleration -g, seen in body i's frame */
            double a0[6] = {0, 0, 0, -g[0], -g[1], -g[2]};
            xform(jE[i], jr[i], a0, ap);
        }
        for (int k = 0; k < 6; ++k) ap[k] += jc[i][k];
        double uU = 0;
        for (int k = 0; k < 6; ++k) uU += jU[i][k] * ap[k];
        thdd[i] = (ju[i] - uU) / jd[i];
        for (int k = 0; k < 6; ++k) ja[i][k] = ap[k];
        for (int k = 0; k < 3; ++k) ja[i][k] += h->a[k] * thdd[i];
    }
}

/* World poses (r, R) of the bodies at the angles th; with thd, the energy into *energy. */
static void joint_pose(const double *th, const double *thd, double *r, double *R,
                       double *energy)
{
    double *w = malloc(3 * (size_t)nb * sizeof *w), *v = malloc(3 * (size_t)nb * sizeof *v);
    double E = 0;
    for (int i = 0; i < nb; ++i) {
        const hinge *h = &H[i];
        double Rr[9], P[3], e[3], ri[3], vP[3];
        rotation(h->a, th[i], Rr);
        if (h->parent >= 0) {
            int p = h->parent;
            matmul3(R + 9 * p, Rr, R + 9 * i);
            matvec3(R + 9 * p, h->sA, P);
            matvec3(R + 9 * p, h->a, e);
            double arm[3], wx[3];
            for (int k = 0; k < 3; ++k) {
                arm[k] = P[k];
                P[k] += r[3 * p + k];
            }
            cross(w + 3 * p, arm, wx);
            for (int k = 0; k < 3; ++k) {
                vP[k] = v[3 * p + k] + wx[k];
                w[3 * i + k] = w[3 * p + k];
            }
        } else {
            memcpy(R + 9 * i, Rr, sizeof Rr);
            memcpy(P, h->sA, sizeof P);
            memcpy(e, h->a, sizeof e);
            memset(vP, 0, sizeof vP);
            memset(w + 3 * i, 0, 3 * sizeof(double));
        }
        matvec3(R + 9 * i, h->sB, ri);
        for (int k = 0; k < 3; ++k) {
            r[3 * i + k] = P[k] - ri[k];
            if (thd) w[3 * i + k] += thd[i] * e[k];
        }
        double arm[3], wx[3];
        for (int k = 0; k < 3; ++k) arm[k] = -ri[k];
        cross(w + 3 * i, arm, wx);
        for (int k = 0; k < 3; ++k) v[3 * i + k] = vP[k] + wx[k];
        if (thd) {
            double wb[3], Jw[3];
            mattvec3(R + 9 * i, w + 3 * i, wb);
            matvec3(J[i], wb, Jw);
            E += 0.5 * mass[i] * dot3(v + 3 * i, v + 3 * i) + 0.5 * dot3(wb, Jw)
                 - mass[i] * dot3(g, r + 3 * i);
        }
    }
    if (energy) *energy = E;
    free(w);
    free(v);
}

/* ---- one free body: Euler angles, or a quaternion --------------------------------------- */

static void free_setup(void)
{
    const double *A = J[0];
    double det = A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6])
                 + A[2] * (A[3] * A[7] - A[4] * A[6]);
    Jinv[0] = (A[4] * A[8] - A[5] * A[7]) / det;
    Jinv[1] = (A[2] * A[7] - A[1] * A[8]) / det;
    Jinv[2] = (A[1] * A[5] - A[2] * A[4]) / det;
    Jinv[3] = (A[5] * A[6] - A[3] * A[8]) / det;
    Jinv[4] = (A[0] * A[8] - A[2] * A[6]) / det;
    Jinv[5] = (A[2] * A[3] - A[0] * A[5]) / det;
    Jinv[6] = (A[3] * A[7] - A[4] * A[6]) / det;
    Jinv[7] = (A[1] * A[6] - A[0] * A[7]) / det;
    Jinv[8] = (A[0] * A[4] - A[1] * A[3]) / det;
}

static inline void euler_rates(const double *w, double *wd) /* J w' = (J w) x w */
{
    double Jw[3], c[3];
    matvec3(J[0], w, Jw);
    cross(Jw, w, c);
    matvec3(Jinv, c, wd);
}

static void angles_rhs(const double *y, double *dy) /* y = (psi, theta, phi, w) */
{
    double th = y[1], ph = y[2], ct = cos(th), st = sin(th), cp = cos(ph), sp = sin(ph);
    const double *w = y + 3;
    double s = w[1] * sp + w[2] * cp;
    dy[0] = s / ct;
    dy[1] = w[1] * cp - w[2] * sp;
    dy[2] = w[0] + s * st / ct;
    euler_rates(w, dy + 3);
}

static void angles_matrix(const double *a, double *R) /* Rz(psi) Ry(theta) Rx(phi) */
{
    double z[3] = {0, 0, 1}, yv[3] = {0, 1, 0}, x[3] = {1, 0, 0}, Rz[9], Ry[9], Rx[9], T[9];
    rotation(z, a[0], Rz);
    rotation(yv, a[1], Ry);
    rotation(x, a[2], Rx);
    matmul3(Rz, Ry, T);
    matmul3(T, Rx, R);
}

static void quat_rhs(const double *y, double *dy) /* y = (q, w) */
{
    const double *q = y, *w = y + 4;
    dy[0] = 0.5 * (-q[1] * w[0] - q[2] * w[1] - q[3] * w[2]);
    dy[1] = 0.5 * (q[0] * w[0] + q[2] * w[2] - q[3] * w[1]);
    dy[2] = 0.5 * (q[0] * w[1] + q[3] * w[0] - q[1] * w[2]);
    dy[3] = 0.5 * (q[0] * w[2] + q[1] * w[1] - q[2] * w[0]);
    euler_rates(w, dy + 4);
}

/* ---- the method chosen ------------------------------------------------------------------ */

enum method { EP, EP_PROJECT, JOINT, ANGLES, QUAT };
static enum method method;
static int ny;

static long evaluations;
static int sampling; /* --time-rhs: every 97th call timed */
static double *rhs_samples;
static long n_rhs_samples;
#define SAMPLE_EVERY 97
#define SAMPLE_REPEAT 20
#define MAX_SAMPLES 20000

#ifdef __GNUC__
__attribute__((noinline)) /* one function to count (callgrind) */
#endif
static void raw_rhs(const double *y, double *dy)
{
    switch (method) {
    case EP:
    case EP_PROJECT: ep_rhs(y, dy); break;
    case JOINT: joint_rhs(y, dy); break;
    case ANGLES: angles_rhs(y, dy); break;
    case QUAT: quat_rhs(y, dy); break;
    }
}

static void rhs(const double *y, double *dy)
{
    evaluations++;
    if (sampling && evaluations % SAMPLE_EVERY == 0 && n_rhs_samples < MAX_SAMPLES) {
        double start = seconds(CLOCK_MONOTONIC);
        for (int k = 0; k < SAMPLE_REPEAT; ++k) raw_rhs(y, dy);
        rhs_samples[n_rhs_samples++] = (seconds(CLOCK_MONOTONIC) - start) / SAMPLE_REPEAT;
        return;
    }
    raw_rhs(y, dy);
}

static void initial_state(double *y)
{
    switch (method) {
    case EP:
    case EP_PROJECT: memcpy(y, ep_y0, 14 * (size_t)nb * sizeof *y); break;
    case JOINT:
        memcpy(y, theta0, nb * sizeof *y);
        memcpy(y + nb, rate0, nb * sizeof *y);
        break;
    case ANGLES:
        memcpy(y, euler0, 3 * sizeof *y);
        memcpy(y + 3, w0, 3 * sizeof *y);
        break;
    case QUAT:
        memcpy(y, quat0, 4 * sizeof *y);
        memcpy(y + 4, w0, 3 * sizeof *y);
        break;
    }
}

/* The output row's columns after t: r and R of each body, the energy, the residual. */
static void output_row(FILE *csv, double t, const double *y)
{
    double *r = malloc(3 * (size_t)nb * sizeof *r), *R = malloc(9 * (size_t)nb * sizeof *R);
    double energy = 0, residual = 0;
    switch (method) {
    case EP:
    case EP_PROJECT:
        for (int b = 0; b < nb; ++b) {
            memcpy(r + 3 * b, y + 7 * b, 3 * sizeof *r);
            quaternion_matrix(y + 7 * b + 3, R + 9 * b);
        }
        energy = ep_energy(y);
        residual = ep_residual(y);
        break;
    case JOINT: joint_pose(y, y + nb, r, R, &energy); break;
    case ANGLES: {
        double Jw[3];
        memset(r, 0, 3 * sizeof *r);
        angles_matrix(y, R);
        matvec3(J[0], y + 3, Jw);
        energy = 0.5 * dot3(y + 3, Jw);
        residual = fabs(cos(y[1]));
        break;
    }
    case QUAT: {
        double n = sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2] + y[3] * y[3]), u[4], Jw[3];
        for (int k = 0; k < 4; ++k) u[k] = y[k] / n;
        memset(r, 0, 3 * sizeof *r);
        quaternion_matrix(u, R);
        matvec3(J[0], y + 4, Jw);
        energy = 0.5 * dot3(y + 4, Jw);
        residual = fabs(n - 1);
        break;
    }
    }
    fprintf(csv, "%.17g", t);
    for (int b = 0; b < nb; ++b) {
        for (int k = 0; k < 3; ++k) fprintf(csv, ",%.17g", r[3 * b + k]);
        for (int k = 0; k < 9; ++k) fprintf(csv, ",%.17g", R[9 * b + k]);
    }
    fprintf(csv, ",%.17g,%.17g\n", energy, residual);
    free(r);
    free(R);
}

/* A residual checked at every accepted step (the first run only). */
static double step_residual(const double *y)
{
    switch (method) {
    case EP:
    case EP_PROJECT: return ep_residual(y);
    case ANGLES: return fabs(cos(y[1])); /* the smallest is the closest to gimbal lock */
    case QUAT: return fabs(sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2] + y[3] * y[3]) - 1);
    default: return 0;
    }
}

/* ---- Dormand-Prince 5(4), as in intelsat_hand.c, for ny states -------------------------- */

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

static double *y0v, *y1v, *kv[7], *ytmp, h_step, err_step;

static void dopri(double h, double tol)
{
    double *y = ytmp, *k1 = kv[0], *k2 = kv[1], *k3 = kv[2], *k4 = kv[3], *k5 = kv[4],
           *k6 = kv[5], *k7 = kv[6];
    h_step = h;
    for (int i = 0; i < ny; ++i) y[i] = y0v[i] + h * A21 * k1[i];
    rhs(y, k2);
    for (int i = 0; i < ny; ++i) y[i] = y0v[i] + h * (A31 * k1[i] + A32 * k2[i]);
    rhs(y, k3);
    for (int i = 0; i < ny; ++i) y[i] = y0v[i] + h * (A41 * k1[i] + A42 * k2[i] + A43 * k3[i]);
    rhs(y, k4);
    for (int i = 0; i < ny; ++i)
        y[i] = y0v[i] + h * (A51 * k1[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i]);
    rhs(y, k5);
    for (int i = 0; i < ny; ++i)
        y[i] = y0v[i] + h * (A61 * k1[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i] + A65 * k5[i]);
    rhs(y, k6);
    for (int i = 0; i < ny; ++i)
        y1v[i] = y0v[i] + h * (A71 * k1[i] + A73 * k3[i] + A74 * k4[i] + A75 * k5[i] + A76 * k6[i]);
    rhs(y1v, k7);
    double sum = 0;
    for (int i = 0; i < ny; ++i) {
        double e = h * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i]
                        + E7 * k7[i]);
        double a = fabs(y0v[i]), b = fabs(y1v[i]);
        double scale = tol + tol * (a > b ? a : b);
        sum += (e / scale) * (e / scale);
    }
    err_step = sqrt(sum / ny);
}

static void dense(double theta, double *y)
{
    double t1 = 1 - theta, h = h_step;
    for (int i = 0; i < ny; ++i) {
        double dy = y1v[i] - y0v[i], bspl = h * kv[0][i] - dy;
        double r5 = h * (D1 * kv[0][i] + D3 * kv[2][i] + D4 * kv[3][i] + D5 * kv[4][i]
                         + D6 * kv[5][i] + D7 * kv[6][i]);
        y[i] = y0v[i] + theta * (dy + t1 * (bspl + theta * (dy - h * kv[6][i] - bspl + t1 * r5)));
    }
}

static double initial_step(double tol, double h_max)
{
    double dnf = 0, dny = 0, *yy = ytmp, *f1 = kv[1];
    for (int i = 0; i < ny; ++i) {
        double sk = tol + tol * fabs(y0v[i]);
        dnf += (kv[0][i] / sk) * (kv[0][i] / sk);
        dny += (y0v[i] / sk) * (y0v[i] / sk);
    }
    double h = dnf <= 1e-10 || dny <= 1e-10 ? 1e-6 : 0.01 * sqrt(dny / dnf);
    h = fmin(h, h_max);
    for (int i = 0; i < ny; ++i) yy[i] = y0v[i] + h * kv[0][i];
    rhs(yy, f1);
    double der2 = 0;
    for (int i = 0; i < ny; ++i) {
        double sk = tol + tol * fabs(y0v[i]), d = (f1[i] - kv[0][i]) / sk;
        der2 += d * d;
    }
    der2 = sqrt(der2) / h;
    double der12 = fmax(der2, sqrt(dnf));
    double h1 = der12 <= 1e-15 ? fmax(1e-6, h * 1e-3) : pow(0.01 / der12, 0.2);
    return fmin(fmin(100 * h, h1), h_max);
}

typedef struct run_stats {
    long steps, rejected, evaluations, projections;
    double worst_residual, best_residual;
    int e0_sign_changes, failed;
} run_stats;

static void integrate(double t_end, double tol, double dt_out, FILE *csv, int checks,
                      run_stats *st)
{
    const double h_max = t_end, beta = 0.04, expo = 0.2 - 0.75 * beta, safe = 0.9;
    double t = 0, fac_old = 1e-4, *yo = malloc(ny * sizeof *yo);
    long next_out = 0, before = evaluations;
    int reject = 0;
    memset(st, 0, sizeof *st);
    st->best_residual = INFINITY;
    initial_state(y0v);
    int ep = method == EP || method == EP_PROJECT;
    int *e0_sign = checks && ep ? calloc(nb, sizeof(int)) : NULL;
    if (e0_sign)
        for (int b = 0; b < nb; ++b) e0_sign[b] = y0v[7 * b + 3] >= 0 ? 1 : -1;
    if (checks) {
        double res = step_residual(y0v);
        st->worst_residual = st->best_residual = res;
    }
    rhs(y0v, kv[0]);
    double h = initial_step(tol, h_max);
    while (t < t_end - 1e-12 * t_end) {
        if (t + h > t_end) h = t_end - t;
        if (h < 1e-14 * t_end || st->steps + st->rejected > 50000000) {
            st->failed = 1;
            break;
        }
        dopri(h, tol);
        double fac11 = pow(err_step, expo);
        double fac = fac11 / pow(fac_old, beta) / safe;
        fac = fac < 0.1 ? 0.1 : fac > 5.0 ? 5.0 : fac;
        if (!(err_step <= 1.0)) {
            st->rejected++;
            h /= fmin(5.0, fac11 / safe);
            reject = 1;
            continue;
        }
        double h_new = fmin(h / fac, h_max);
        if (reject) h_new = fmin(h_new, h);
        reject = 0;
        fac_old = fmax(err_step, 1e-4);
        for (; csv && next_out * dt_out <= t + h_step + 1e-12 * t_end
               && next_out * dt_out <= t_end * (1 + 1e-12);
             ++next_out) {
            double tout = fmin(next_out * dt_out, t_end);
            dense((tout - t) / h_step, yo);
            output_row(csv, tout, yo);
        }
        st->steps++;
        t += h_step;
        memcpy(y0v, y1v, ny * sizeof *y0v);
        if (method == EP_PROJECT) {
            st->projections += ep_project(y0v, tol);
            rhs(y0v, kv[0]);
        } else {
            memcpy(kv[0], kv[6], ny * sizeof *kv[0]);
        }
        if (checks) {
            double res = step_residual(y0v);
            if (res > st->worst_residual) st->worst_residual = res;
            if (res < st->best_residual) st->best_residual = res;
            if (e0_sign)
                for (int b = 0; b < nb; ++b) {
                    int s = y0v[7 * b + 3] >= 0 ? 1 : -1;
                    if (s != e0_sign[b]) st->e0_sign_changes++;
                    e0_sign[b] = s;
                }
        }
        h = h_new;
    }
    st->evaluations = evaluations - before;
    free(yo);
    free(e0_sign);
}

static int compare(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

int main(int argc, char **argv)
{
    double t_end = 1.0, tol = 1e-8, dt_out = 0.01;
    const char *out = NULL;
    int repeat = 0, timing = 0, derivative = 0;
    if (argc < 3) {
        fprintf(stderr, "usage: %s ep|ep-project|joint|angles|quat SPEC [--tol TOL] [--t-end T] "
                "[--dt-out DT] [-o out.csv] [--repeat R] [--time-rhs] [--alpha A] "
                "[--derivative]\n", argv[0]);
        return 2;
    }
    if (strcmp(argv[1], "ep") == 0) method = EP;
    else if (strcmp(argv[1], "ep-project") == 0) method = EP_PROJECT;
    else if (strcmp(argv[1], "joint") == 0) method = JOINT;
    else if (strcmp(argv[1], "angles") == 0) method = ANGLES;
    else if (strcmp(argv[1], "quat") == 0) method = QUAT;
    else fail("unknown method");
    read_spec(argv[2]);
    for (int i = 3; i < argc; ++i) {
        if (strcmp(argv[i], "--time-rhs") == 0) timing = 1;
        else if (strcmp(argv[i], "--derivative") == 0) derivative = 1;
        else if (i + 1 < argc && strcmp(argv[i], "--t-end") == 0) t_end = atof(argv[++i]);
        else if (i + 1 < argc && strcmp(argv[i], "--tol") == 0) tol = atof(argv[++i]);
        else if (i + 1 < argc && strcmp(argv[i], "--dt-out") == 0) dt_out = atof(argv[++i]);
        else if (i + 1 < argc && strcmp(argv[i], "--repeat") == 0) repeat = atoi(argv[++i]);
        else if (i + 1 < argc && strcmp(argv[i], "--alpha") == 0) alpha = atof(argv[++i]);
        else if (i + 1 < argc && strcmp(argv[i], "-o") == 0) out = argv[++i];
        else fail("bad option");
    }
    switch (method) {
    case EP: ny = 14 * nb; ep_setup(); break;
    case EP_PROJECT: ny = 14 * nb; alpha = 0; ep_setup(); break;
    case JOINT: ny = 2 * nb; joint_setup(); joint_alloc(); break;
    case ANGLES: ny = 6; if (nb != 1) fail("one free body"); free_setup(); break;
    case QUAT: ny = 7; if (nb != 1) fail("one free body"); free_setup(); break;
    }
    y0v = malloc(ny * sizeof(double));
    y1v = malloc(ny * sizeof(double));
    ytmp = malloc(ny * sizeof(double));
    for (int k = 0; k < 7; ++k) kv[k] = malloc(ny * sizeof(double));
    if (derivative) { /* the right side at the initial state, and nothing else */
        initial_state(y0v);
        raw_rhs(y0v, kv[0]);
        fprintf(stderr, "{\"derivative\": [");
        for (int i = 0; i < ny; ++i) fprintf(stderr, "%s%.17g", i ? ", " : "", kv[0][i]);
        fprintf(stderr, "]}\n");
        return 0;
    }
    FILE *csv = out ? fopen(out, "w") : NULL;
    if (out && !csv) fail("cannot write the output");
    run_stats first_run, st;
    integrate(t_end, tol, dt_out, csv, 1, &first_run);
    if (csv) fclose(csv);
    double *walls = malloc((repeat + 1) * sizeof(double));
    double *cpus = malloc((repeat + 1) * sizeof(double));
    for (int k = 0; k < repeat; ++k) {
        double w = seconds(CLOCK_MONOTONIC), c = seconds(CLOCK_PROCESS_CPUTIME_ID);
        integrate(t_end, tol, dt_out, NULL, 0, &st);
        cpus[k] = seconds(CLOCK_PROCESS_CPUTIME_ID) - c;
        walls[k] = seconds(CLOCK_MONOTONIC) - w;
    }
    if (timing) {
        rhs_samples = malloc(MAX_SAMPLES * sizeof *rhs_samples);
        sampling = 1;
        integrate(t_end, tol, dt_out, NULL, 0, &st);
        sampling = 0;
        qsort(rhs_samples, n_rhs_samples, sizeof *rhs_samples, compare);
    }
    fprintf(stderr, "{\"steps\": %ld, \"rejected\": %ld, \"evaluations\": %ld, "
            "\"projection_iterations\": %ld, \"stopped\": %d, \"worst_residual\": %.6g, "
            "\"best_residual\": %.6g, \"e0_sign_changes\": %d, \"rows\": %d, \"walls\": [",
            first_run.steps, first_run.rejected, first_run.evaluations, first_run.projections,
            first_run.failed, first_run.worst_residual, first_run.best_residual,
            first_run.e0_sign_changes, method == EP || method == EP_PROJECT ? nrows : 0);
    for (int k = 0; k < repeat; ++k) fprintf(stderr, "%s%.6g", k ? ", " : "", walls[k]);
    fprintf(stderr, "], \"cpus\": [");
    for (int k = 0; k < repeat; ++k) fprintf(stderr, "%s%.6g", k ? ", " : "", cpus[k]);
    fprintf(stderr, "], \"rhs_ns\": %.6g, \"rhs_samples\": %ld}\n",
            n_rhs_samples ? 1e9 * rhs_samples[n_rhs_samples / 2] : -1.0, n_rhs_samples);
    return 0;
}
