/* sensitivity.c: forward sensitivities of a run with respect to chosen parameters
 * (docs/method.md, 12): s_k = (dq/dp_k, dqd/dp_k) carried along the accepted trajectory by the
 * variational equations of the constrained motion (tangents.c), their jumps at events, the
 * event times' sensitivities, and the outputs' at the output times (run.h).
 *
 * Over each accepted step the sensitivity ODE ds_k/dt = (dqd, dqdd) is integrated with the
 * classical fourth-order Runge-Kutta method on the step's interpolant, and its end projected
 * onto the tangents of the position and velocity constraints.
 *
 * At an event at tau(p) with condition g(q, p) = 0 (a latch or a stop reached, a hold-down's
 * release time): dtau/dp = -(g_q dq + g_p) / g' by the implicit function theorem, and with
 * D x- = s- + x'- dtau, the state after the event x+ = Gamma(x-) (a plastic impact onto the
 * new rows: M qd+ + J^T mu = M qd-, J qd+ = -Phi_t) gives s+ = Gamma_x D x- + Gamma_p - x'+ dtau.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "run.h"

/* ---- a run's sensitivities ----------------------------------------------------------------- */

/* x (n) of least norm with A x = b (A: rows x n, row-major) in the least-squares sense, by
   the normal equations on the smaller side with a ridge of 1e-13 of their largest diagonal
   (a dependent row or column then costs nothing); `work`: (max(rows, n))^2 + rows doubles. */
static void least_norm(const double *A, int rows, int n, const double *b, double *x,
                       double *work)
{
    int side = rows < n ? rows : n;
    double *N = work, *y = work + (size_t)side * side, largest = 0.0;
    for (int a = 0; a < side; ++a) {
        for (int e = 0; e < side; ++e) {
            double sum = 0.0;
            for (int c = 0; c < (rows < n ? n : rows); ++c) {
                sum += rows < n ? A[(size_t)a * n + c] * A[(size_t)e * n + c]
                                : A[(size_t)c * n + a] * A[(size_t)c * n + e];
            }
            N[(size_t)a * side + e] = sum;
        }
        largest = fmax(largest, N[(size_t)a * side + a]);
    }
    for (int a = 0; a < side; ++a) {
        N[(size_t)a * side + a] += 1e-13 * fmax(largest, 1e-300);
        double sum = 0.0;
        for (int c = 0; c < rows && rows >= n; ++c) {
            sum += A[(size_t)c * n + a] * b[c];
        }
        y[a] = rows < n ? b[a] : sum;
    }
    dep_solve_small(side, N, y);
    for (int c = 0; c < n; ++c) {
        double sum = 0.0;
        for (int a = 0; a < rows && rows < n; ++a) {
            sum += A[(size_t)a * n + c] * y[a];
        }
        x[c] = rows < n ? sum : y[c];
    }
}

/* The residual of the assembly's conditions along (dq, dqd, dp) (level 0: the model's rows
   Phi and the loop hinges' given angles; level 1: their rates), less `given` (the targets'
   own tangents; NULL: none), into out (rows). */
static void assembly_residual(dep_run *run, int level, const double *q, const double *qd,
                              const double *dq, const double *dqd, const double *dp,
                              const int *targets, int n_targets, const double *given,
                              double *out)
{
    dep_sensitivity *x = &run->sens;
    const dep_model *m = run->model;
    int nc = run->cs.nc_module;
    if (level == 0) {
        m->phi_tangent(q, 0.0, run->p, dq, dp, out);
        m->hinge_angles_tangent(q, run->p, dq, dp, x->dtheta);
    } else {
        m->phi_q_tangent(q, 0.0, run->p, dq, dp, x->dJ);
        m->phi_t_tangent(q, 0.0, run->p, dq, dp, out);
        dep_cs_times(&run->cs, x->J, dqd, x->b);
        dep_cs_times(&run->cs, x->dJ, qd, x->c);
        for (int a = 0; a < nc; ++a) {
            out[a] += x->b[a] + x->c[a];
        }
        m->hinge_rates_tangent(q, qd, run->p, dq, dqd, dp, x->dtheta);
    }
    for (int k = 0; k < n_targets; ++k) {
        out[nc + k] = x->dtheta[targets[k]] - (given != NULL ? given[targets[k]] : 0.0);
    }
}

/* The initial state's sensitivities: the assembly's (assembly.c) linearised. The tree places
   q = tree_pose(v), qd = tree_tangent(v, vd); the given values and rates move with p as
   tree_values does, and the free ones so that the model's rows and the loop hinges' given
   angles (rates) keep holding: the least-norm solution of those linear conditions, as the
   assembly's Gauss-Newton steps take them. */
static int initial_sensitivities(dep_run *run, const double *q, const double *qd)
{
    dep_sensitivity *x = &run->sens;
    const dep_model *m = run->model;
    int nv = m->nv, nq = run->nq, nc = run->cs.nc_module, nh = m->nh;
    size_t n2 = 2 * (size_t)nq, k = (size_t)x->k, big = (size_t)(nv > nc + nh ? nv : nc + nh) + 1;
    size_t wide = (size_t)(nq > m->np ? nq : m->np) + (size_t)nv + 1;
    double *mem = calloc(3 * (size_t)nv + 3 + 4 * (size_t)nh + 4 + (size_t)(nc + nh) * nv
                         + big * big + 3 * big + (size_t)nq + 1 + wide + k * (nv + 1), sizeof *mem);
    int *index = calloc((size_t)(nv + nh) + 2, sizeof *index);
    if (mem == NULL || index == NULL) {
        free(mem);
        free(index);
        return dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory");
    }
    double *dv = mem, *dvd = dv + nv + 1, *unit = dvd + nv + 1;
    double *angle = unit + nv + 1, *rate = angle + nh + 1, *dangle = rate + nh + 1;
    double *drate = dangle + nh + 1, *A = drate + nh + 1;
    double *r0 = A + (size_t)(nc + nh) * nv, *solution = r0 + big, *work = solution + big;
    double *column = work + big * big + big, *zero = column + nq + 1, *values = zero + wide;
    int *free_values = index, *targets = index + nv + 1;
    const double *v = run->tree_v, *vd = run->tree_vd;
    m->loop_targets(run->p, angle, rate);
    dep_sens_at_state(run, 0.0, q);
    for (int level = 0; level < 2; ++level) { /* the values, then the rates */
        int nf = 0, n_targets = 0;
        for (int j = 0; j < nv; ++j) {
            if (!(m->tree_held[j] & (level == 0 ? 1 : 2))) {
                free_values[nf++] = j;
            }
        }
        for (int h = 0; h < nh; ++h) {
            if (isfinite(level == 0 ? angle[h] : rate[h])) {
                targets[n_targets++] = h;
            }
        }
        int rows = nc + n_targets;
        for (int c = 0; c < nf && rows > 0; ++c) { /* the free values' (rates') columns */
            unit[free_values[c]] = 1.0;
            m->tree_tangent(v, unit, run->p, column); /* d q / d v_c, d qd / d vd_c */
            unit[free_values[c]] = 0.0;
            assembly_residual(run, level, q, qd, level == 0 ? column : zero,
                              level == 0 ? zero : column, zero, targets, n_targets, NULL, r0);
            for (int a = 0; a < rows; ++a) {
                A[(size_t)a * nf + c] = r0[a];
            }
        }
        for (size_t i = 0; i < k; ++i) {
            double *dq = x->s + i * n2, *dqd = dq + nq, *solved = values + i * (size_t)(nv + 1);
            x->dp[x->params[i]] = 1.0;
            m->tree_values_tangent(run->p, x->dp, dv, dvd);
            m->loop_targets_tangent(run->p, x->dp, dangle, drate);
            if (level == 1) {
                memcpy(dv, solved, (size_t)nv * sizeof *dv); /* the values as solved */
            }
            for (int c = 0; c < nf; ++c) {
                (level == 0 ? dv : dvd)[free_values[c]] = 0.0;
            }
            m->tree_pose_tangent(v, run->p, dv, x->dp, dq);
            m->tree_tangent_tangent(v, vd, run->p, dv, dvd, x->dp, dqd);
            if (rows > 0 && nf > 0) {
                assembly_residual(run, level, q, qd, dq, dqd, x->dp, targets, n_targets,
                                  level == 0 ? dangle : drate, r0);
                for (int a = 0; a < rows; ++a) {
                    r0[a] = -r0[a];
                }
                least_norm(A, rows, nf, r0, solution, work);
                for (int c = 0; c < nf; ++c) {
                    (level == 0 ? dv : dvd)[free_values[c]] = solution[c];
                }
                m->tree_pose_tangent(v, run->p, dv, x->dp, dq);
                m->tree_tangent_tangent(v, vd, run->p, dv, dvd, x->dp, dqd);
            }
            if (level == 0) {
                memcpy(solved, dv, (size_t)nv * sizeof *dv);
            }
            x->dp[x->params[i]] = 0.0;
        }
    }
    free(mem);
    free(index);
    return DEP_OK;
}

/* At t = 0 (after dep_run_start): the initial state's sensitivities (the assembly's), projected
   onto the constraints of the rows the start engaged, and their rates. */
int dep_sensitivity_begin(dep_run *run)
{
    dep_sensitivity *x = &run->sens;
    if (x->k == 0) {
        return DEP_OK;
    }
    size_t n2 = 2 * (size_t)run->nq;
    const dep_state *s = &run->state;
    int status = initial_sensitivities(run, s->q, s->qd);
    if (status != DEP_OK) {
        return status;
    }
    for (int r = 0; r < DEP_MAX_ADDED * x->k; ++r) {
        x->row_angles[r] = NAN;
    }
    x->n_rows = 0;
    dep_sens_rows_changed(run, s->q);
    dep_sens_at_state(run, s->t, s->q);
    dep_sens_project(run, s->t, s->q, s->qd, x->s);
    dep_sens_motion_tangent(run, s->t, s->q, s->qd, x->s, x->ds);
    x->t0 = x->t1 = s->t;
    status = dep_sens_event_times(run, 0, NULL); /* the records at t = 0: a fixed time */
    if (status != DEP_OK) {
        return status;
    }
    memcpy(x->s0, x->s, (size_t)x->k * n2 * sizeof(double));
    memcpy(x->ds0, x->ds, (size_t)x->k * n2 * sizeof(double));
    return DEP_OK;
}


/* s over the accepted step from run->state to t1 (<= its end: an event's time), the states
   on the step's interpolant `end->data`. */
/* s over a whole DOPRI step on its own stages (the stage states y0 + h sum a K of the step's
   last integration): the sensitivities then share the step's stability, which a step held at
   DOPRI's stability bound by a stiff mode needs (the classical method's bound is smaller). */
static void dopri_stages(dep_run *run, const dep_rk_step *rk)
{
    dep_sensitivity *x = &run->sens;
    int nq = run->nq, ny = rk->n;
    size_t n = (size_t)x->k * 2 * (size_t)nq;
    double h = rk->h, *Q = x->Q, *QD = x->QD;
    memcpy(x->stages, x->ds0, n * sizeof(double));
    for (int stage = 1; stage < 6; ++stage) {
        const double *a = dep_dopri_a[stage];
        for (int j = 0; j < nq; ++j) {
            double dq = 0.0, dqd = 0.0;
            for (int m = 0; m < stage; ++m) {
                dq += a[m] * rk->K[(size_t)m * (size_t)ny + (size_t)j];
                dqd += a[m] * rk->K[(size_t)m * (size_t)ny + (size_t)(nq + j)];
            }
            Q[j] = rk->y0[j] + h * dq;
            QD[j] = rk->y0[nq + j] + h * dqd;
        }
        for (size_t j = 0; j < n; ++j) {
            double sum = 0.0;
            for (int m = 0; m < stage; ++m) {
                sum += a[m] * x->stages[(size_t)m * n + j];
            }
            x->stage[j] = x->s0[j] + h * sum;
        }
        double t = rk->t0 + dep_dopri_c[stage] * h;
        dep_sens_at_state(run, t, Q);
        dep_sens_motion_tangent(run, t, Q, QD, x->stage, x->stages + (size_t)stage * n);
    }
    for (size_t j = 0; j < n; ++j) {
        double sum = 0.0;
        for (int m = 0; m < 6; ++m) {
            sum += dep_dopri_b[m] * x->stages[(size_t)m * n + j];
        }
        x->s[j] = x->s0[j] + h * sum;
    }
}

/* s over the accepted step from run->state to t1 (<= its end: an event's time), the states
   on the step's interpolant `end->data`: the classical fourth-order method (two new states);
   a whole DOPRI step held by a stiff mode (Hairer's indicator h |lambda| above
   DEP_SENSITIVITY_STIFF) on its own stages instead. */
int dep_sensitivity_step(dep_run *run, const dep_outcome *end, double t1)
{
    dep_sensitivity *x = &run->sens;
    if (x->k == 0) {
        return DEP_OK;
    }
    const dep_state *start = &run->state;
    int nq = run->nq;
    size_t n = (size_t)x->k * 2 * (size_t)nq;
    double t0 = start->t, h = t1 - t0, step = end->state.t - t0, tm = t0 + 0.5 * h;
    if (end->rk->method == DEP_ROSENBROCK) {
        return dep_sens_unsupported(run, t0, "the run takes the linearly implicit step here (stiff "
                           "elastic forces), which they do not follow yet; run with "
                           "stepping='explicit'");
    }
    memcpy(x->s0, x->s, n * sizeof(double));
    memcpy(x->ds0, x->ds, n * sizeof(double));
    x->t0 = t0;
    x->t1 = t1;
    double *Q = x->Q, *QD = x->QD;
    if (t1 == end->state.t && end->rk->stiffness > DEP_SENSITIVITY_STIFF) {
        dopri_stages(run, end->rk);
    } else {
        dep_interpolate(end->data, t0, step, nq, tm, Q, QD);
        dep_sens_at_state(run, tm, Q);
        for (size_t j = 0; j < n; ++j) {
            x->stage[j] = x->s0[j] + 0.5 * h * x->ds0[j];
        }
        dep_sens_motion_tangent(run, tm, Q, QD, x->stage, x->k2);
        for (size_t j = 0; j < n; ++j) {
            x->stage[j] = x->s0[j] + 0.5 * h * x->k2[j];
        }
        dep_sens_motion_tangent(run, tm, Q, QD, x->stage, x->k3);
    }
    if (t1 == end->state.t) {
        memcpy(Q, end->state.q, (size_t)nq * sizeof *Q);
        memcpy(QD, end->state.qd, (size_t)nq * sizeof *QD);
    } else {
        dep_interpolate(end->data, t0, step, nq, t1, Q, QD);
    }
    dep_sens_at_state(run, t1, Q);
    if (!(t1 == end->state.t && end->rk->stiffness > DEP_SENSITIVITY_STIFF)) {
        for (size_t j = 0; j < n; ++j) {
            x->stage[j] = x->s0[j] + h * x->k3[j];
        }
        dep_sens_motion_tangent(run, t1, Q, QD, x->stage, x->k4);
        for (size_t j = 0; j < n; ++j) {
            x->s[j] = x->s0[j] + h / 6.0 * (x->ds0[j] + 2.0 * (x->k2[j] + x->k3[j])
                                            + x->k4[j]);
        }
    }
    dep_sens_project(run, t1, Q, QD, x->s);
    dep_sens_motion_tangent(run, t1, Q, QD, x->s, x->ds);
    return DEP_OK;
}

/* The step to an event taken again (firing.c, retake): s from the step's start over the step
   re-taken to the event. The first pass at it followed the step that crossed the event, whose
   interpolant spans the change of the force law the event marks (a compliant latch's push
   reaching 0 where its contact ends): the outputs before the event were recorded from it, as
   the run's own are. */
int dep_sensitivity_retake(dep_run *run, const dep_outcome *fired)
{
    dep_sensitivity *x = &run->sens;
    if (x->k == 0) {
        return DEP_OK;
    }
    size_t n = (size_t)x->k * 2 * (size_t)run->nq;
    memcpy(x->s, x->s0, n * sizeof(double));
    memcpy(x->ds, x->ds0, n * sizeof(double));
    return dep_sensitivity_step(run, fired, fired->state.t);
}

/* s at t in the step followed last: the cubic Hermite interpolant of its ends. */
static void dense(const dep_sensitivity *x, int n2, double t, double *out)
{
    size_t n = (size_t)x->k * (size_t)n2;
    double h = x->t1 - x->t0;
    if (!(h > 0.0)) {
        memcpy(out, x->s, n * sizeof *out);
        return;
    }
    double u = (t - x->t0) / h;
    double h00 = (1 + 2 * u) * (1 - u) * (1 - u), h10 = u * (1 - u) * (1 - u);
    double h01 = u * u * (3 - 2 * u), h11 = u * u * (u - 1);
    for (size_t j = 0; j < n; ++j) {
        out[j] = h00 * x->s0[j] + h01 * x->s[j] + h * (h10 * x->ds0[j] + h11 * x->ds[j]);
    }
}

/* The sensitivities at an output time t (the recorder's row just written, `row`): q, qd and
   the outputs', the multipliers' tangent solved at the state. */
int dep_sensitivity_record(dep_run *run, int row, double t, const double *q, const double *qd,
                           const double *lam, const double *work)
{
    dep_sensitivity *x = &run->sens;
    const dep_model *m = run->model;
    if (x->k == 0 || !run->recording) {
        return DEP_OK;
    }
    size_t k = (size_t)x->k, n2 = 2 * (size_t)run->nq, nout = (size_t)m->nout + 1;
    size_t nc = (size_t)m->nc + 1;
    double *s = x->out_q + (size_t)row * k * n2;
    dense(x, (int)n2, t, s);
    dep_sens_at_state(run, t, q);
    dep_sens_motion_tangent(run, t, q, qd, s, x->stage);
    for (size_t i = 0; i < k; ++i) { /* the model's rows come first among the active */
        memcpy(x->out_lam + ((size_t)row * k + i) * nc, x->dlam + i * (size_t)run->cs.capacity,
               (size_t)m->nc * sizeof(double));
    }
    if (m->nout == 0) {
        return DEP_OK;
    }
    double *torques = x->torques;
    if (run->mechanism != NULL) {
        dep_mechanism_hinge_torques(run->mechanism, q, qd, &run->cs, lam, torques);
    } else {
        dep_lock_torques(m, &run->cs, lam, torques);
    }
    dep_run_values(&run->system, q, torques, work, dep_impact_loss(run->records, run->n_records),
                   x->energy, x->w);
    int nw = (int)DEP_RUN_VALUES(m);
    for (size_t i = 0; i < k; ++i) {
        const double *dlam = x->dlam + i * (size_t)run->cs.capacity;
        for (int j = 0; j < nw; ++j) {
            x->dw[j] = j < m->nh ? 0.0 : NAN; /* a work's sensitivity is not followed */
        }
        for (int a = run->cs.nc_module; a < run->cs.nc; ++a) {
            int h = run->cs.row_hinges[a];
            if (h >= 0) {
                x->dw[h] -= dlam[a];
            }
        }
        x->dp[x->params[i]] = 1.0;
        m->outputs_tangent(q, qd, t, run->p, lam, x->w, s + i * n2, s + i * n2 + run->nq, x->dp,
                           dlam, x->dw, x->out_y + ((size_t)row * k + i) * nout);
        x->dp[x->params[i]] = 0.0;
    }
    return DEP_OK;
}

/* ---- the result ---------------------------------------------------------------------------- */

int dep_sensitivity_result(dep_run *run, dep_result *result)
{
    dep_sensitivity *x = &run->sens;
    const dep_model *m = run->model;
    result->n_sensitivities = x->k;
    if (x->k == 0) {
        return DEP_OK;
    }
    size_t k = (size_t)x->k, n2 = 2 * (size_t)run->nq, rows = (size_t)result->n;
    size_t nout = (size_t)m->nout;
    int failed = 0;
    result->sensitivity_params = malloc(k * sizeof *result->sensitivity_params);
    if (result->sensitivity_params == NULL) {
        return DEP_MEMORY_ERROR;
    }
    memcpy(result->sensitivity_params, x->params, k * sizeof *x->params);
    result->sensitivity_state = dep_copy_doubles(x->out_q, rows * k * n2, &failed);
    size_t nc = (size_t)m->nc, n_lam = rows * k * nc;
    result->sensitivity_lam = malloc((n_lam > 0 ? n_lam : 1) * sizeof(double));
    if (result->sensitivity_lam == NULL) {
        return DEP_MEMORY_ERROR;
    }
    for (size_t r = 0; r < rows * k; ++r) {
        memcpy(result->sensitivity_lam + r * nc, x->out_lam + r * (nc + 1), nc * sizeof(double));
    }
    size_t n_outputs = rows * k * nout, n_events = (size_t)run->n_records * k;
    result->sensitivity_outputs = malloc((n_outputs > 0 ? n_outputs : 1) * sizeof(double));
    if (result->sensitivity_outputs == NULL) {
        return DEP_MEMORY_ERROR;
    }
    for (size_t r = 0; r < rows * k; ++r) {
        for (size_t o = 0; o < nout; ++o) {
            result->sensitivity_outputs[r * nout + o] = x->out_y[r * (nout + 1) + o];
        }
    }
    size_t events = (size_t)run->n_records;
    result->sensitivity_events = malloc((n_events > 0 ? n_events : 1) * sizeof(double));
    if (result->sensitivity_events == NULL || failed) {
        return DEP_MEMORY_ERROR;
    }
    for (size_t r = 0; r < events; ++r) {
        for (size_t i = 0; i < k; ++i) {
            result->sensitivity_events[r * k + i] = (int)r < x->event_capacity
                ? x->event_times[r * k + i] : (run->records[r].t == 0.0 ? 0.0 : NAN);
        }
    }
    return DEP_OK;
}
