/* rosenbrock.c: the linearly implicit step for stiff elastic forces (docs/method.md, 10).
 *
 * A beam's axial and high bending modes are far faster than its motion; an explicit method
 * must resolve them for stability. ROS34PW2 (Rang & Angermann, BIT 45 (2005) 761-787) is a
 * W-method: of order 3 whatever Jacobian T it is given, L-stable in the modes T describes.
 * With lambda(t) prescribed over the step (the paper's frame), the motion is the ODE
 * y' = F(t, y), y = (q, qd, work), and each stage i solves
 *
 *     (I - gamma h T) k_i = h F(t0 + c_i h, y0 + sum_j a_ij k_j) + h T sum_j g_ij k_j
 *
 * with T = [[0, I, 0], [-M^-1 K, -M^-1 D, 0], [0, 0, 0]], K and D the stiff forces' stiffness
 * and damping (the model's `stiffness`: the beams' elasticity and damping, hinge springs and
 * dampers, cables; evaluated at each step's start). Its velocity
 * block is W kv = M r_v - gamma h K r_q with W = M + gamma h D + gamma^2 h^2 K, symmetric
 * positive definite and banded: an envelope factorisation, no M^-1 anywhere. K and D are sums
 * of symmetric terms (codegen/loads.py); the stages take them from their lower triangles in
 * W's envelope, as W does, so T is the same matrix in both. Since any T
 * keeps the order, W (with the K and D it was made from) serves every step of its size while
 * K and D stay within DEP_JACOBIAN_DRIFT of it (dep_implicit_prepare).
 * The step's error is sum (b_i - bhat_i) k_i (the embedded order-2 solution), filtered by
 * (I - gamma h T)^-1 as in Hairer & Wanner's RADAU5 (Solving ODEs II, IV.8): modes T makes
 * stiff (omega h >> 1) are damped by the L-stable method and leave the estimate, so an
 * excited axial or high bending mode of a beam does not hold the step at its period, while
 * the motion T does not stiffen keeps its estimate.
 */
#include <math.h>
#include <string.h>

#include "method.h"

#define GAMMA 0.435866521508459
static const double ALPHA[4][3] = {
    {0},
    {0.87173304301691801},
    {0.84457060015369423, -0.11299064236484185},
    {0.0, 0.0, 1.0},
};
static const double COUPLING[4][3] = { /* gamma_ij */
    {0},
    {-0.87173304301691801},
    {-0.90338057013044082, 0.054180672388095326},
    {0.24212380706095346, -1.2232505839045147, 0.54526025533510214},
};
static const double B[4] = {0.24212380706095346, -1.2232505839045147, 1.5452602553351020,
                            0.435866521508459};
static const double BHAT[4] = {0.37810903145819369, -0.096042292212423178, 0.5,
                               0.2179332607542295};
static const double C[4] = {0.0, 0.87173304301691801, 0.73157995778885238, 1.0}; /* sum_j a_ij */

int dep_implicit_init(dep_implicit *im, const dep_system *system, int ny, dep_arena *arena)
{
    const dep_model *model = system->model;
    int nq = system->nq, nkz = model->nkz;
    memset(im, 0, sizeof *im);
    im->system = system;
    im->nq = nq;
    im->ny = ny;
    im->nkz = nkz;
    im->K = dep_doubles(arena, (size_t)nkz);
    im->D = dep_doubles(arena, (size_t)nkz);
    im->K_now = dep_doubles(arena, (size_t)nkz);
    im->D_now = dep_doubles(arena, (size_t)nkz);
    im->K_drift = dep_doubles(arena, (size_t)nkz);
    im->D_drift = dep_doubles(arena, (size_t)nkz);
    im->diagonal = dep_bytes(arena, (size_t)nq * sizeof *im->diagonal + 1);
    im->lower = dep_bytes(arena, (size_t)nkz * sizeof *im->lower + 1);
    int *first = dep_bytes(arena, (size_t)nq * sizeof *first + 1);
    if (arena->failed) {
        return DEP_MEMORY_ERROR;
    }
    /* W's envelope: M's and K's non-zeros on or below the diagonal */
    dep_mass_envelope_start(&system->mass, first);
    for (int k = 0; k < nkz; ++k) {
        int i = model->stiffness_rows[k], j = model->stiffness_cols[k];
        if (j < first[i]) {
            first[i] = j;
        }
    }
    if (dep_envelope_init(&im->W, nq, first, arena) != DEP_OK) {
        return DEP_MEMORY_ERROR;
    }
    im->mass_envelope = dep_doubles(arena, (size_t)im->W.offset[nq] + 1);
    im->K_envelope = dep_doubles(arena, (size_t)im->W.offset[nq] + 1);
    im->D_envelope = dep_doubles(arena, (size_t)im->W.offset[nq] + 1);
    im->now_envelope = dep_doubles(arena, (size_t)im->W.offset[nq] + 1);
    im->g0 = dep_doubles(arena, (size_t)ny);
    im->k = dep_doubles(arena, 4 * (size_t)ny);
    im->arg = dep_doubles(arena, (size_t)ny);
    im->g = dep_doubles(arena, (size_t)ny);
    size_t block = (size_t)DEP_RESPONSE_BLOCK * (size_t)nq;
    im->sum = dep_doubles(arena, 2 * block + (size_t)ny);
    im->rhs = dep_doubles(arena, (size_t)nq);
    im->block_rhs = dep_doubles(arena, block);
    im->product = dep_doubles(arena, block);
    im->dk = dep_doubles(arena, 8 * block);
    im->block_x = dep_doubles(arena, block);
    im->block_dq = dep_doubles(arena, block);
    im->block_dqd = dep_doubles(arena, block);
    if (arena->failed) {
        return DEP_MEMORY_ERROR;
    }
    dep_mass_to_envelope(&system->mass, &im->W, im->mass_envelope);
    for (int j = 0; j < nq; ++j) {
        im->diagonal[j] = -1;
    }
    for (int k = 0; k < nkz; ++k) {
        int i = model->stiffness_rows[k], j = model->stiffness_cols[k];
        im->lower[k] = j <= i ? im->W.offset[i] + j - im->W.first[i] : -1;
        if (i == j) {
            im->diagonal[i] = k;
        }
    }
    return DEP_OK;
}

/* drift[k] = (DEP_JACOBIAN_DRIFT sqrt(|A_ii A_jj|))^2 for entry k = (i, j) of A on the
   stiffness pattern (0 where a diagonal entry is absent: A_ij is then 0 for a semi-definite
   A); squared, so that neither this nor near takes a square root. */
static void drift_bounds(const dep_implicit *im, const double *A, double *drift)
{
    const int *rows = im->system->model->stiffness_rows, *cols = im->system->model->stiffness_cols;
    const double squared = DEP_JACOBIAN_DRIFT * DEP_JACOBIAN_DRIFT;
    for (int k = 0; k < im->nkz; ++k) {
        int di = im->diagonal[rows[k]], dj = im->diagonal[cols[k]];
        drift[k] = di >= 0 && dj >= 0 ? squared * fabs(A[di] * A[dj]) : 0.0;
    }
}

/* Whether every entry of `now` is within drift (squared) of `held`. */
static int near(const dep_implicit *im, const double *held, const double *now,
                const double *drift)
{
    for (int k = 0; k < im->nkz; ++k) {
        double change = now[k] - held[k];
        if (!(change * change <= drift[k])) { /* (NaN included) */
            return 0;
        }
    }
    return 1;
}

/* A matrix on the stiffness pattern (K or D) into W's envelope: its lower triangle. */
static void to_envelope(const dep_implicit *im, const double *A, double *envelope)
{
    memset(envelope, 0, (size_t)im->W.offset[im->nq] * sizeof *envelope);
    for (int k = 0; k < im->nkz; ++k) {
        if (im->lower[k] >= 0) {
            envelope[im->lower[k]] = A[k];
        }
    }
}

int dep_implicit_prepare(dep_implicit *im, const double *q, double h)
{
    const dep_system *s = im->system;
    s->model->stiffness(q, s->p, im->K_now, im->D_now);
    if (h == im->h && near(im, im->K, im->K_now, im->K_drift)
        && near(im, im->D, im->D_now, im->D_drift)) {
        return 1;
    }
    memcpy(im->K, im->K_now, (size_t)im->nkz * sizeof *im->K);
    memcpy(im->D, im->D_now, (size_t)im->nkz * sizeof *im->D);
    drift_bounds(im, im->K, im->K_drift);
    drift_bounds(im, im->D, im->D_drift);
    im->damped = 0;
    for (int k = 0; k < im->nkz; ++k) {
        im->damped |= im->D[k] != 0.0;
    }
    size_t size = (size_t)im->W.offset[im->nq];
    to_envelope(im, im->K, im->K_envelope);
    to_envelope(im, im->D, im->D_envelope);
    double a = GAMMA * h, b = a * a;
    for (size_t e = 0; e < size; ++e) {
        im->W.A[e] = im->mass_envelope[e] + a * im->D_envelope[e] + b * im->K_envelope[e];
    }
    im->h = h;
    im->id++;
    if (!dep_envelope_factor(&im->W, 0.0, NULL)) {
        im->h = 0.0;
        return 0;
    }
    return 1;
}

void dep_implicit_forget(dep_implicit *im)
{
    im->h = 0.0;
}

/* out -= A x for a symmetric A in W's envelope (K or D), on `count` interleaved vectors
   (entry j of vector v at [j count + v]). */
static void envelope_subtract(const dep_implicit *im, const double *A, int count,
                              const double *x, double *out)
{
    const dep_envelope *e = &im->W;
    for (int i = 0; i < e->n; ++i) {
        const double *row = &DEP_ENVELOPE_AT(e, A, i, 0);
        double *oi = out + (size_t)i * count;
        const double *xi = x + (size_t)i * count;
        if (count == 1) { /* row i's sum in a local, then its mirror column */
            double sum = oi[0] - row[i] * xi[0], value = xi[0];
            for (int j = e->first[i]; j < i; ++j) {
                sum -= row[j] * x[j];
                out[j] -= row[j] * value;
            }
            oi[0] = sum;
            continue;
        }
        for (int j = e->first[i]; j <= i; ++j) {
            double a = row[j];
            double *oj = out + (size_t)j * count;
            const double *xj = x + (size_t)j * count;
            for (int v = 0; v < count; ++v) {
                oi[v] -= a * xj[v];
            }
            if (j < i) {
                for (int v = 0; v < count; ++v) {
                    oj[v] -= a * xi[v];
                }
            }
        }
    }
}

/* `count` stages at once (interleaved) from r_q (in kq), their velocity right sides less the
   elastic terms (in rhs, overwritten), the stiffness's argument s_q and the damping's s_v:
   W kv = rhs - K (h s_q + gamma h r_q) - h D s_v, kq = r_q + gamma h kv. Without s (NULL),
   the error filter: W kv = rhs - gamma h K r_q. */
static void solve_stage(dep_implicit *im, int count, const double *sq, const double *sv,
                        double *kq, double *kv, double *rhs)
{
    size_t n = (size_t)im->nq * (size_t)count;
    double h = im->h, a = GAMMA * h, *argument = im->product;
    for (size_t j = 0; j < n; ++j) {
        argument[j] = (sq != NULL ? h * sq[j] : 0.0) + a * kq[j];
    }
    envelope_subtract(im, im->K_envelope, count, argument, rhs);
    if (sv != NULL && im->damped) {
        for (size_t j = 0; j < n; ++j) {
            argument[j] = h * sv[j];
        }
        envelope_subtract(im, im->D_envelope, count, argument, rhs);
    }
    dep_envelope_solve_block(&im->W, count, rhs, kv);
    for (size_t j = 0; j < n; ++j) {
        kq[j] += a * kv[j];
    }
}

void dep_rosenbrock_times(double t0, double h, double times[4])
{
    for (int i = 0; i < 4; ++i) {
        times[i] = t0 + C[i] * h;
    }
}

void dep_rosenbrock_step(dep_implicit *im, dep_rk_step *rk, dep_force_function g,
                         void *context, double t0, const double *y0, double h)
{
    int nq = im->nq, ny = im->ny;
    rk->method = DEP_ROSENBROCK;
    rk->order = 3;
    rk->t0 = t0;
    rk->h = h;
    rk->y0 = y0;
    rk->stiffness = 0.0; /* no stability bound on the step */
    for (int i = 0; i < 4; ++i) {
        double *k = im->k + (size_t)i * ny;
        const double *gi = im->g0;
        for (int j = 0; j < ny; ++j) {
            double arg = y0[j], sum = 0.0;
            for (int m = 0; m < i; ++m) {
                arg += ALPHA[i][m] * im->k[(size_t)m * ny + j];
                sum += COUPLING[i][m] * im->k[(size_t)m * ny + j];
            }
            im->arg[j] = arg;
            im->sum[j] = sum;
        }
        if (i > 0) {
            g(context, t0 + C[i] * h, im->arg, im->g);
            gi = im->g;
        }
        for (int j = 0; j < nq; ++j) {
            k[j] = h * (gi[j] + im->sum[nq + j]);
            im->rhs[j] = h * gi[nq + j];
        }
        solve_stage(im, 1, im->sum, im->sum + nq, k, k + nq, im->rhs);
        for (int j = 2 * nq; j < ny; ++j) {
            k[j] = h * gi[j];
        }
    }
    for (int j = 0; j < ny; ++j) {
        double y = y0[j], e = 0.0;
        for (int i = 0; i < 4; ++i) {
            y += B[i] * im->k[(size_t)i * ny + j];
            e += (B[i] - BHAT[i]) * im->k[(size_t)i * ny + j];
        }
        rk->y1[j] = y;
        rk->error[j] = e;
        rk->K[j] = im->g0[j]; /* y' at the start; the work rows need no M^-1 */
    }
    /* the filter: W e_v' = M e_v - gamma h K e_q, e_q' = e_q + gamma h e_v' */
    dep_envelope_times(&im->W, im->mass_envelope, rk->error + nq, im->rhs);
    solve_stage(im, 1, NULL, NULL, rk->error, rk->error + nq, im->rhs);
}

void dep_implicit_response(dep_implicit *im, int count, const double *x,
                           const double weight[4], double *dq, double *dqd)
{
    size_t n = (size_t)im->nq * (size_t)count;
    double h = im->h;
    double *zq = im->sum, *zv = im->sum + n;
    int first = 0; /* the stages before the first weighted one (the start's: l(0) = 0) */
    while (first < 4 && weight[first] == 0.0) {
        ++first;
    }
    memset(im->dk, 0, 2 * n * (size_t)first * sizeof *im->dk);
    for (int i = first; i < 4; ++i) { /* stage i: kq, kv at dk + 2 n i */
        double *kq = im->dk + 2 * n * (size_t)i, *kv = kq + n;
        for (size_t j = 0; j < 2 * n; ++j) {
            double z = 0.0;
            for (int m = 0; m < i; ++m) {
                z += (ALPHA[i][m] + COUPLING[i][m]) * im->dk[2 * n * (size_t)m + j];
            }
            im->sum[j] = z;
        }
        for (size_t j = 0; j < n; ++j) {
            kq[j] = h * zv[j];
            im->block_rhs[j] = -h * weight[i] * x[j];
        }
        solve_stage(im, count, zq, zv, kq, kv, im->block_rhs);
    }
    for (size_t j = 0; j < n; ++j) {
        double sq = 0.0, sv = 0.0;
        for (int i = 0; i < 4; ++i) {
            sq += B[i] * im->dk[2 * n * (size_t)i + j];
            sv += B[i] * im->dk[2 * n * (size_t)i + n + j];
        }
        dq[j] = sq;
        dqd[j] = sv;
    }
}

#define POWER_ITERATIONS 100

double dep_implicit_fastest(dep_implicit *im, const double *q)
{
    const dep_system *s = im->system;
    int nq = im->nq;
    double *x = im->arg, *y = im->g, rate = 0.0;
    s->model->stiffness(q, s->p, im->K_now, im->D_now); /* W's own K and D stay as they are */
    double *K = im->now_envelope;
    to_envelope(im, im->K_now, K);
    for (int j = 0; j < nq; ++j) {
        x[j] = (j % 2 ? 1.0 : -1.0) * (1.0 + 0.1 * (j % 7)); /* rich in the fast modes */
    }
    for (int k = 0; k < POWER_ITERATIONS; ++k) { /* y = M^-1 K x, rate = x.K x / x.M x */
        dep_envelope_times(&im->W, K, x, im->rhs);
        double kx = 0.0, norm = 0.0;
        for (int j = 0; j < nq; ++j) {
            kx += x[j] * im->rhs[j];
        }
        dep_mass_solve(&s->mass, im->rhs, y);
        dep_envelope_times(&im->W, im->mass_envelope, x, im->product);
        double mx = 0.0;
        for (int j = 0; j < nq; ++j) {
            mx += x[j] * im->product[j];
            norm = fmax(norm, fabs(y[j]));
        }
        rate = mx > 0.0 ? fmax(rate, kx / mx) : rate;
        if (!(norm > 0.0)) {
            break;
        }
        for (int j = 0; j < nq; ++j) {
            x[j] = y[j] / norm;
        }
    }
    return sqrt(rate);
}
