/* assembly.c: the initial state of a mechanism with closed loops (docs/language.md, Assembly).
 *
 * The model places its members along the assembly tree: q = tree_pose(v, p), v the values of
 * the tree's joints (hinge angles, slider displacements). The values and rates the user gave
 * are held (TREE_HELD); the others are free and start at 0. Where the tree leaves loops open,
 * the free values are solved by Gauss-Newton, damped in Levenberg-Marquardt's way, on
 *
 *     Phi(q(v)) = 0   and, for each hinge that closes a loop and was given an angle,
 *     theta(q(v)) = that angle,
 *
 * with the Jacobian [Phi_q; J_theta] T, T = d tree_pose / d v, whose columns for the free
 * values the model's tree_tangent gives one at a time (T is never formed). The rates follow
 * linearly: Phi_q T vd = -Phi_t (and J_theta T vd = a given loop rate), solved for the free
 * rates by least squares of minimum norm, the held rates fixed. q = tree_pose(v) and
 * qd = tree_tangent(v, vd) are then consistent to round-off; values that cannot all hold are a
 * SolverError naming them.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "run.h"

#define MAX_ITERATIONS 100
#define FIT 1e-13 /* |residual| counted as closed: FIT max(1, |q|) (round-off of a pose) */
#define ROUNDOFF_TERMS 16 /* a computed sum of n terms is good to ROUNDOFF_TERMS n eps of
                             the sum of their sizes (each term a few roundings) */
#define RESTARTS 4 /* starts tried beside the tree placement's when it does not close */

typedef struct assembly {
    const dep_model *m;
    const double *p;
    dep_constraints *cs;
    int nq, nv, nc, nh, nf, rows;   /* rows: nc + hinges with a loop target */
    int *free, *target, *live;      /* nf free joint indices; the hinges with a target; rows */
    double *dual;                   /* nf + rows: normal_solve's D and y on the rows' side */
    double *v, *start, *best, *trial, *vd, *angles, *rates, *q, *unit, *column, *product, *J,
        *H, *A, *N, *F, *g, *step, *theta;
} assembly;

/* d theta / d q of the k-th targeted hinge times x (nq), from the model's values in H. */
static double hinge_times(const assembly *x, int k, const double *v)
{
    const dep_constraints *cs = x->cs;
    double sum = 0.0;
    const int *hinge_start = cs->system->hinge_start;
    const int *cols = cs->system->model->hinge_jacobian_cols;
    for (int n = hinge_start[x->target[k]]; n < hinge_start[x->target[k] + 1]; ++n) {
        sum += x->H[n] * v[cols[n]];
    }
    return sum;
}

/* The residual F(v) (rows) at the pose q(v), with the Jacobian A = [Phi_q; J_h] T[:, free]
   when `jacobian`, column by column. Returns max |F|. */
static double residual(assembly *x, const double *v, int jacobian)
{
    const dep_model *m = x->m;
    int n_target = x->rows - x->nc;
    m->tree_pose(v, x->p, x->q);
    dep_cs_phi(x->cs, x->q, 0.0, x->F);
    if (n_target > 0) {
        m->hinge_angles(x->q, x->p, x->theta);
        for (int k = 0; k < n_target; ++k) {
            x->F[x->nc + k] = x->theta[x->target[k]] - x->angles[x->target[k]];
        }
    }
    double largest = 0.0;
    for (int i = 0; i < x->rows; ++i) {
        largest = fmax(largest, fabs(x->F[i]));
    }
    if (!jacobian) {
        return largest;
    }
    dep_cs_jacobian(x->cs, x->q, 0.0, x->J);
    if (n_target > 0) {
        m->hinge_jacobian(x->q, x->p, x->H);
    }
    for (int c = 0; c < x->nf; ++c) {
        x->unit[x->free[c]] = 1.0;
        m->tree_tangent(v, x->unit, x->p, x->column);
        x->unit[x->free[c]] = 0.0;
        dep_cs_times(x->cs, x->J, x->column, x->product);
        for (int i = 0; i < x->rows; ++i) {
            x->A[(size_t)i * x->nf + c] = i < x->nc ? x->product[i]
                                                    : hinge_times(x, i - x->nc, x->column);
        }
    }
    return largest;
}

/* Solve the n x n system N s = rhs in place (N: lower Cholesky factor on return, rhs: s). */
static void cholesky_solve(double *N, int n, double *s)
{
    for (int c = 0; c < n; ++c) { /* Cholesky, lower triangle in place */
        double d = N[(size_t)c * n + c];
        for (int k = 0; k < c; ++k) {
            d -= N[(size_t)c * n + k] * N[(size_t)c * n + k];
        }
        d = sqrt(fmax(d, 1e-300));
        N[(size_t)c * n + c] = d;
        for (int r = c + 1; r < n; ++r) {
            double e = N[(size_t)r * n + c];
            for (int k = 0; k < c; ++k) {
                e -= N[(size_t)r * n + k] * N[(size_t)c * n + k];
            }
            N[(size_t)r * n + c] = e / d;
        }
    }
    for (int r = 0; r < n; ++r) {
        for (int k = 0; k < r; ++k) {
            s[r] -= N[(size_t)r * n + k] * s[k];
        }
        s[r] /= N[(size_t)r * n + r];
    }
    for (int r = n - 1; r >= 0; --r) {
        for (int k = r + 1; k < n; ++k) {
            s[r] -= N[(size_t)k * n + r] * s[k];
        }
        s[r] /= N[(size_t)r * n + r];
    }
}

/* Solve (A^T A + D) s = A^T b for s (nf), D = damping diag(A^T A) + floor I: the regularised
   normal equations give the least-squares solution of minimum norm as the damping and floor
   vanish. Only A's non-zero rows enter: a tree joint turns the members beyond it rigidly, so
   its column is zero (to round-off) in every row but the loops' closing ones. With fewer such
   rows than unknowns (a long chain closing one loop), the same s comes from the rows' side,
   s = D^-1 A^T (A D^-1 A^T + I)^-1 b: a system of their size instead of nf. */
static void normal_solve(assembly *x, const double *b, double damping, double *s)
{
    int n = x->nf, live = 0, *rows = x->live;
    double *N = x->N, largest = 0.0, entry = 0.0;
    for (size_t k = 0; k < (size_t)x->rows * (size_t)n; ++k) {
        entry = fmax(entry, fabs(x->A[k]));
    }
    for (int i = 0; i < x->rows; ++i) { /* zero: to round-off of A's largest entry */
        int nonzero = 0;
        for (int c = 0; c < n && !nonzero; ++c) {
            nonzero = fabs(x->A[(size_t)i * n + c]) > 1e-13 * entry;
        }
        if (nonzero) {
            rows[live++] = i;
        }
    }
    if (live < n) {
        double *d = x->dual, *y = x->dual + n;
        for (int c = 0; c < n; ++c) {
            double sum = 0.0;
            for (int k = 0; k < live; ++k) {
                sum += x->A[(size_t)rows[k] * n + c] * x->A[(size_t)rows[k] * n + c];
            }
            d[c] = sum;
            largest = fmax(largest, sum);
        }
        for (int c = 0; c < n; ++c) { /* D alone: A^T A is the rows' side's A D^-1 A^T */
            d[c] = damping * d[c] + 1e-14 * fmax(largest, 1e-300);
        }
        for (int a = 0; a < live; ++a) {
            const double *Aa = x->A + (size_t)rows[a] * n;
            for (int e = 0; e <= a; ++e) {
                const double *Ae = x->A + (size_t)rows[e] * n;
                double sum = a == e ? 1.0 : 0.0;
                for (int c = 0; c < n; ++c) {
                    sum += Aa[c] * Ae[c] / d[c];
                }
                N[(size_t)a * live + e] = sum;
            }
            y[a] = b[rows[a]];
        }
        cholesky_solve(N, live, y);
        for (int c = 0; c < n; ++c) {
            double sum = 0.0;
            for (int a = 0; a < live; ++a) {
                sum += x->A[(size_t)rows[a] * n + c] * y[a];
            }
            s[c] = sum / d[c];
        }
        return;
    }
    for (int r = 0; r < n; ++r) {
        for (int c = 0; c <= r; ++c) {
            double sum = 0.0;
            for (int k = 0; k < live; ++k) {
                sum += x->A[(size_t)rows[k] * n + r] * x->A[(size_t)rows[k] * n + c];
            }
            N[(size_t)r * n + c] = sum;
        }
        largest = fmax(largest, N[(size_t)r * n + r]);
    }
    for (int r = 0; r < n; ++r) {
        double sum = 0.0;
        for (int k = 0; k < live; ++k) {
            sum += x->A[(size_t)rows[k] * n + r] * b[rows[k]];
        }
        s[r] = sum;
        N[(size_t)r * n + r] += damping * N[(size_t)r * n + r] + 1e-14 * fmax(largest, 1e-300);
    }
    cholesky_solve(N, n, s);
}

/* "crank_pin = 1.5708 rad, wrist.rate = 0 rad/s, ..." : what the user gave (rates when
   `rates`), for messages. */
static void given_text(const assembly *x, const dep_run *run, int rates, char *out,
                       size_t size)
{
    const dep_model *m = x->m;
    size_t used = 0;
    out[0] = '\0';
    for (int k = 0; k < x->nv && used < size; ++k) {
        if (m->tree_held[k] & (rates ? 2 : 1)) {
            used += (size_t)snprintf(out + used, size - used, "%s%s%s = %.6g", used ? ", " : "",
                                     m->tree_joints[k], rates ? ".rate" : "",
                                     rates ? x->vd[k] : x->v[k]);
        }
    }
    for (int h = 0; h < x->nh && used < size; ++h) {
        double value = rates ? x->rates[h] : x->angles[h];
        if (isfinite(value)) {
            used += (size_t)snprintf(out + used, size - used, "%s%s%s = %.6g", used ? ", " : "",
                                     m->hinge_names[h], rates ? ".rate" : "", value);
        }
    }
    if (used == 0) {
        snprintf(out, size, "none");
    }
    (void)run;
}

/* The failing row of F: its name and joint for the message. */
static int worst_row(const assembly *x)
{
    int worst = 0;
    for (int i = 1; i < x->rows; ++i) {
        if (fabs(x->F[i]) > fabs(x->F[worst])) {
            worst = i;
        }
    }
    return worst;
}

static int fail(assembly *x, dep_run *run, int rates, double gap)
{
    char given[300], what[768], joint[DEP_NAME_MAX + 16] = "", row[DEP_NAME_MAX + 8] = "";
    int worst = worst_row(x);
    given_text(x, run, rates, given, sizeof given);
    if (worst < x->nc) {
        dep_cs_describe(x->cs, worst, joint, sizeof joint);
        dep_copy_text(row, sizeof row, x->cs->row_names[worst]);
    } else {
        snprintf(joint, sizeof joint, "hinge %s", x->m->hinge_names[x->target[worst - x->nc]]);
    }
    snprintf(what, sizeof what, "the given initial %s cannot all hold: %s; the loops stay open "
             "by %.3g at %s", rates ? "rates" : "values", given, gap, joint);
    return dep_solver_error(run->error, 1, 0.0, "initial state", row[0] ? row : NULL, joint, 1,
                            gap, what, "give fewer initial values (only those that drive the "
                            "mechanism), or values that close its loops");
}

/* Records "assembly": the free joints' solved values and rates. */
static int record(assembly *x, dep_run *run)
{
    dep_datum data[2 * DEP_MAX_ADDED];
    int n = 0, capacity = (int)(sizeof data / sizeof data[0]);
    for (int c = 0; c < x->nf; ++c) {
        const char *name = x->m->tree_joints[x->free[c]];
        if (!(x->m->tree_held[x->free[c]] & 1)) {
            dep_datum *d = dep_datum_add(data, &n, capacity, "values", name);
            if (d != NULL) {
                d->kind = DEP_NUMBER;
                d->number = x->v[x->free[c]];
            }
        }
        if (!(x->m->tree_held[x->free[c]] & 2)) {
            dep_datum *d = dep_datum_add(data, &n, capacity, "rates", name);
            if (d != NULL) {
                d->kind = DEP_NUMBER;
                d->number = x->vd[x->free[c]];
            }
        }
    }
    return dep_run_add_record(run, "assembly", DEP_RECORD_ASSEMBLY, -1, 0.0, data, n);
}

/* r = A step - b over the rows (the rates' residual with x->step as the free rates). */
static void rate_residual(const assembly *x, const double *b, double *r)
{
    for (int i = 0; i < x->rows; ++i) {
        double sum = -b[i];
        for (int c = 0; c < x->nf; ++c) {
            sum += x->A[(size_t)i * x->nf + c] * x->step[c];
        }
        r[i] = sum;
    }
}

/* The velocities: least squares of minimum norm for the free rates (every tree joint whose
   rate was not given), the held rates fixed. */
static int assemble_rates(assembly *x, dep_run *run)
{
    const dep_model *m = x->m;
    int n_target = 0;
    for (int h = 0; h < x->nh; ++h) {
        if (isfinite(x->rates[h])) {
            x->target[n_target++] = h;
        }
    }
    x->rows = x->nc + n_target;
    x->nf = 0;
    for (int k = 0; k < x->nv; ++k) {
        if (!(m->tree_held[k] & 2)) {
            x->free[x->nf++] = k;
            x->vd[k] = 0.0;
        }
    }
    residual(x, x->v, 1); /* J, H and A at the assembled pose (F unused) */
    double *b = x->F, *qd = x->trial;
    m->tree_tangent(x->v, x->vd, x->p, qd); /* the held rates' velocities */
    dep_cs_phi_t(x->cs, x->q, 0.0, b);
    dep_cs_times(x->cs, x->J, qd, x->product);
    for (int i = 0; i < x->rows; ++i) {
        b[i] = i < x->nc ? -b[i] - x->product[i]
                         : x->rates[x->target[i - x->nc]] - hinge_times(x, i - x->nc, qd);
    }
    if (x->nf > 0) { /* the least squares, then one correction from its own residual */
        normal_solve(x, b, 0.0, x->step);
        rate_residual(x, b, x->g);
        normal_solve(x, x->g, 0.0, x->unit);
        for (int c = 0; c < x->nf; ++c) {
            x->step[c] -= x->unit[c];
            x->unit[c] = 0.0;
        }
        for (int c = 0; c < x->nf; ++c) {
            x->vd[x->free[c]] = x->step[c];
        }
    }
    /* A row is closed to within 1e-3 tol of the rates' size, or to the round-off of computing
       it: its nf + 1 terms, each good to a few eps of its own size. */
    double gap = 0.0, scale = 1.0, worst = 0.0;
    rate_residual(x, b, x->g);
    for (int i = 0; i < x->rows; ++i) {
        scale = fmax(scale, fabs(b[i]));
    }
    for (int i = 0; i < x->rows; ++i) {
        double size = fabs(b[i]);
        for (int c = 0; c < x->nf; ++c) {
            size += fabs(x->A[(size_t)i * x->nf + c] * x->step[c]);
        }
        double limit = fmax(1e-3 * run->settings.tol * scale,
                            ROUNDOFF_TERMS * (x->nf + 1) * DEP_EPS * size);
        gap = fmax(gap, fabs(x->g[i]));
        worst = fmax(worst, fabs(x->g[i]) / limit);
    }
    memcpy(x->F, x->g, (size_t)x->rows * sizeof *x->F); /* for the message's worst row */
    if (worst > 1.0) {
        return fail(x, run, 1, gap);
    }
    return DEP_OK;
}

/* Damped Gauss-Newton on the free values from x->v; returns the residual it ends at. */
static double gauss_newton(assembly *x, double size)
{
    double damping = 1e-3, error = residual(x, x->v, 1);
    for (int iteration = 0; iteration < MAX_ITERATIONS && error > FIT * size; ++iteration) {
        for (int i = 0; i < x->rows; ++i) {
            x->g[i] = -x->F[i];
        }
        int improved = 0;
        for (int attempt = 0; attempt < 12 && !improved; ++attempt) {
            normal_solve(x, x->g, damping, x->step);
            memcpy(x->trial, x->v, (size_t)x->nv * sizeof *x->trial);
            for (int c = 0; c < x->nf; ++c) {
                x->trial[x->free[c]] += x->step[c];
            }
            double trial_error = residual(x, x->trial, 0);
            if (trial_error < error) {
                memcpy(x->v, x->trial, (size_t)x->nv * sizeof *x->v);
                damping = fmax(damping / 10, 1e-12);
                improved = 1;
            } else {
                damping *= 10;
            }
        }
        if (!improved) {
            break;
        }
        error = residual(x, x->v, 1);
    }
    return residual(x, x->v, 0);
}

/* The free values: Gauss-Newton from the tree placement, closed to 1e-3 tol of the pose's
   size or to its round-off (FIT). A placement at a stationary point of the residual (a
   four-bar given exactly straight: no first-order move closes it) stops where it starts;
   the search then starts again from the free values turned by 0.01, 0.04, 0.09, 0.16 (rad,
   or m for a slider) in alternating senses, and keeps the best closure. */
static int assemble_values(assembly *x, dep_run *run)
{
    double size = 1.0, *start = x->start, *best = x->best;
    residual(x, x->v, 0);
    for (int j = 0; j < x->nq; ++j) {
        size = fmax(size, fabs(x->q[j]));
    }
    double limit = fmax(1e-3 * run->settings.tol, FIT) * size;
    memcpy(start, x->v, (size_t)x->nv * sizeof *start);
    double error = x->nf > 0 ? gauss_newton(x, size) : residual(x, x->v, 0);
    for (int restart = 1; restart <= RESTARTS && x->nf > 0 && !(error <= limit); ++restart) {
        double best_error = error;
        memcpy(best, x->v, (size_t)x->nv * sizeof *best);
        memcpy(x->v, start, (size_t)x->nv * sizeof *x->v);
        for (int c = 0; c < x->nf; ++c) {
            x->v[x->free[c]] += 0.01 * restart * restart * ((c + restart) % 2 ? 1.0 : -1.0);
        }
        error = gauss_newton(x, size);
        if (!(error < best_error)) {
            memcpy(x->v, best, (size_t)x->nv * sizeof *x->v);
            error = residual(x, x->v, 0);
        }
    }
    if (!(error <= limit)) {
        return fail(x, run, 0, error);
    }
    return DEP_OK;
}

/* Whether the tree placement (q, qd) already satisfies every constraint level and loop
   target to round-off. */
static int closed(assembly *x, const double *q, const double *qd)
{
    double size = 1.0, speed = 1.0;
    for (int j = 0; j < x->nq; ++j) {
        size = fmax(size, fabs(q[j]));
        speed = fmax(speed, fabs(qd[j]));
    }
    if (residual(x, x->v, 0) > FIT * size) {
        return 0;
    }
    double *rate = x->theta, *J = x->J, *v = x->F;
    dep_cs_jacobian(x->cs, q, 0.0, J);
    dep_cs_v_vel(x->cs, q, qd, 0.0, J, v); /* -(Phi_q qd + Phi_t) */
    for (int i = 0; i < x->nc; ++i) {
        if (fabs(v[i]) > FIT * speed) {
            return 0;
        }
    }
    x->m->hinge_rates(q, qd, x->p, rate);
    for (int h = 0; h < x->nh; ++h) {
        if (isfinite(x->rates[h]) && fabs(rate[h] - x->rates[h]) > FIT * speed) {
            return 0;
        }
    }
    return 1;
}

/* q, qd (nq each) from the model's initial values: the tree placement when it closes every
   loop (or there is none), else the assembly above; an "assembly" record tells what it did. */
int dep_run_assemble(dep_run *run, double *q, double *qd)
{
    const dep_model *m = run->model;
    assembly x = {.m = m, .p = run->p, .cs = &run->cs, .nq = m->nq, .nv = m->nv,
                  .nc = run->cs.nc, .nh = m->nh};
    dep_arena *arena = &run->arena;
    size_t nv = (size_t)m->nv, nq = (size_t)m->nq, rows = (size_t)(x.nc + m->nh), nfree = 0;
    for (int k = 0; k < m->nv; ++k) {
        nfree += m->tree_held[k] != 3; /* at most this many free values or rates */
    }
    x.free = dep_bytes(arena, (nv + 1) * sizeof *x.free);
    x.target = dep_bytes(arena, ((size_t)m->nh + 1) * sizeof *x.target);
    x.live = dep_bytes(arena, (rows + 1) * sizeof *x.live);
    x.dual = dep_doubles(arena, nv + rows + 1);
    x.v = dep_doubles(arena, nv + 1);
    x.start = dep_doubles(arena, nv + 1);
    x.best = dep_doubles(arena, nv + 1);
    x.trial = dep_doubles(arena, nv + nq + 1);
    x.vd = dep_doubles(arena, nv + 1);
    x.angles = dep_doubles(arena, (size_t)m->nh + 1);
    x.rates = dep_doubles(arena, (size_t)m->nh + 1);
    x.theta = dep_doubles(arena, (size_t)m->nh + 1);
    x.q = dep_doubles(arena, nq);
    x.unit = dep_doubles(arena, nv + 1);
    x.column = dep_doubles(arena, nq + 1);
    x.product = dep_doubles(arena, (size_t)x.nc + 1);
    x.J = dep_doubles(arena, DEP_JACOBIAN_SIZE(m));
    x.H = dep_doubles(arena, (size_t)m->nhnz + 1);
    x.A = dep_doubles(arena, rows * nfree + 1);
    size_t side = nfree < rows ? nfree : rows; /* normal_solve: n x n with n <= live rows, or
                                                   live x live with live < n */
    x.N = dep_doubles(arena, side * side + 1);
    x.F = dep_doubles(arena, rows + 1);
    x.g = dep_doubles(arena, rows + 1);
    x.step = dep_doubles(arena, nv + 1);
    if (arena->failed) {
        return dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory");
    }
    m->tree_values(run->p, x.v, x.vd);
    m->tree_pose(x.v, run->p, q);
    m->tree_tangent(x.v, x.vd, run->p, qd);
    run->tree_v = x.v; /* the joint values and rates placing the initial state */
    run->tree_vd = x.vd;
    if (m->nv == 0) {
        return DEP_OK;
    }
    m->loop_targets(run->p, x.angles, x.rates);
    for (int h = 0; h < m->nh; ++h) {
        if (isfinite(x.angles[h])) {
            x.target[x.rows++] = h;
        }
    }
    x.rows += x.nc;
    for (int k = 0; k < m->nv; ++k) {
        if (!(m->tree_held[k] & 1)) {
            x.free[x.nf++] = k;
        }
    }
    if (closed(&x, q, qd)) {
        return DEP_OK; /* a tree, or loops the given values close: the placement as it is */
    }
    int status = assemble_values(&x, run);
    if (status == DEP_OK) {
        status = assemble_rates(&x, run);
    }
    if (status != DEP_OK) {
        return status;
    }
    m->tree_pose(x.v, run->p, q);
    m->tree_tangent(x.v, x.vd, run->p, qd);
    return record(&x, run);
}
