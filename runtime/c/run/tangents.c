/* tangents.c: the tangent of the constrained motion along the forward sensitivities of a run
 * (docs/method.md, 12; sensitivity.c carries them along the run), its memory, and the
 * projection of the sensitivities onto the constraints' tangents.
 *
 * At any state (q, qd, t) of the active constraint set (rows J, right side gamma) the motion
 * is M qdd + J^T lambda = f, J qdd = gamma. Its tangent along s_k (a direction dq, dqd of the
 * state and the unit dp of parameter k) is the same system for (dqdd, dlambda):
 *
 *     M dqdd + J^T dlambda = df - dJ^T lambda - dM qdd,    J dqdd = dgamma - dJ qdd,
 *
 * df, dJ, dgamma, dM the generated tangents (model->*_tangent) plus the hinge torques' own
 * (friction by its law, a compliant latch's push), solved through S = J M^-1 J^T (the same
 * factor for every k). The sensitivity ODE ds_k/dt = (dqd, dqdd) is integrated over each
 * accepted step with the classical fourth-order Runge-Kutta method on the step's interpolant,
 * and its end projected onto the tangents of the position and velocity constraints in M's
 * metric, as the method's passes hold the state itself on them.
 *
 * At an event at tau(p) with condition g(q, p) = 0 (a latch or a stop reached, a hold-down's
 * release time): dtau/dp = -(g_q dq + g_p) / g' by the implicit function theorem, and with
 * D x- = s- + x'- dtau, the state after the event x+ = Gamma(x-) (a plastic impact onto the
 * new rows: the same linear system with M qd+ + J^T mu = M qd-) gives
 * s+ = Gamma_x D x- + Gamma_p - x'+ dtau.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "run.h"

/* ---- memory ------------------------------------------------------------------------------- */

int dep_sensitivity_init(dep_run *run)
{
    dep_sensitivity *x = &run->sens;
    const dep_model *m = run->model;
    const dep_settings *settings = &run->settings;
    memset(x, 0, sizeof *x);
    x->k = settings->n_sensitivities;
    if (x->k == 0) {
        return DEP_OK;
    }
    if (!m->tangents) {
        return dep_plain_error(run->error, DEP_SETTINGS_ERROR, "sensitivities need the model's "
                               "tangent functions: generate it with tangents");
    }
    for (int i = 0; i < x->k; ++i) {
        int j = settings->sensitivities[i];
        if (j < 0 || j >= m->np) {
            char message[120];
            snprintf(message, sizeof message, "sensitivity %d: parameter index %d is not one of "
                     "the model's %d", i, j, m->np);
            return dep_plain_error(run->error, DEP_SETTINGS_ERROR, message);
        }
    }
    dep_arena *arena = &run->arena;
    size_t k = (size_t)x->k, nq = (size_t)m->nq, n2 = 2 * nq, nc = (size_t)run->cs.capacity;
    size_t nh = (size_t)m->nh + 1, nmz = (size_t)m->nmz + 1, np = (size_t)m->np + 1;
    x->params = dep_bytes(arena, k * sizeof *x->params);
    if (x->params != NULL) {
        memcpy(x->params, settings->sensitivities, k * sizeof *x->params);
    }
    double **state[] = {&x->s, &x->ds, &x->s0, &x->ds0, &x->stage, &x->k2, &x->k3, &x->k4};
    for (size_t i = 0; i < sizeof state / sizeof *state; ++i) {
        *state[i] = dep_doubles(arena, k * n2);
    }
    x->stages = dep_doubles(arena, 6 * k * n2);
    x->event_dlam = dep_doubles(arena, k);
    x->dlam = dep_doubles(arena, k * nc);
    x->dM = dep_doubles(arena, k * nmz);
    x->dH = dep_doubles(arena, k * nh * DEP_HINGE_PROPERTIES);
    x->dp = dep_doubles(arena, np);
    x->J = dep_doubles(arena, DEP_JACOBIAN_SIZE(m));
    x->dJ = dep_doubles(arena, DEP_JACOBIAN_SIZE(m));
    double **rows[] = {&x->gamma, &x->lam, &x->r2, &x->y, &x->b, &x->c};
    for (size_t i = 0; i < sizeof rows / sizeof *rows; ++i) {
        *rows[i] = dep_doubles(arena, nc + 1);
    }
    double **coordinates[] = {&x->f, &x->qdd, &x->r1, &x->u, &x->v, &x->Dq, &x->Dqd, &x->Q,
                              &x->QD};
    for (size_t i = 0; i < sizeof coordinates / sizeof *coordinates; ++i) {
        *coordinates[i] = dep_doubles(arena, nq + 1);
    }
    double **hinges[] = {&x->tau, &x->theta, &x->rate, &x->dtheta, &x->drate, &x->dtau,
                         &x->gamma_h};
    for (size_t i = 0; i < sizeof hinges / sizeof *hinges; ++i) {
        *hinges[i] = dep_doubles(arena, nh);
    }
    x->Jh = dep_doubles(arena, (size_t)m->nhnz + 1);
    x->dJh = dep_doubles(arena, (size_t)m->nhnz + 1);
    x->row_angles = dep_doubles(arena, DEP_MAX_ADDED * k);
    x->saved_angles = dep_doubles(arena, DEP_MAX_ADDED * k);
    x->w = dep_doubles(arena, DEP_RUN_VALUES(m) + 1);
    x->dw = dep_doubles(arena, DEP_RUN_VALUES(m) + 1);
    x->energy = dep_doubles(arena, (size_t)run->system.ne + 1);
    x->torques = dep_doubles(arena, nh);
    if (run->recording) {
        size_t rows_out = (size_t)run->recorder.capacity;
        x->out_q = dep_doubles(arena, rows_out * k * n2);
        x->out_y = dep_doubles(arena, rows_out * k * ((size_t)m->nout + 1));
        x->out_lam = dep_doubles(arena, rows_out * k * ((size_t)m->nc + 1));
    }
    if (arena->failed || dep_multipliers_init(&x->mp, &run->system.mass, &run->cs,
                                              run->cs.capacity, arena) != DEP_OK) {
        return dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory");
    }
    /* the parameters' tangents of M and of the hinge properties: constants of the run */
    for (int i = 0; i < x->k; ++i) {
        x->dp[x->params[i]] = 1.0;
        m->mass_matrix_tangent(run->p, x->dp, x->dM + (size_t)i * nmz);
        if (m->nh > 0) {
            m->hinge_properties_tangent(run->p, x->dp, x->dH + (size_t)i * nh
                                        * DEP_HINGE_PROPERTIES);
        }
        x->dp[x->params[i]] = 0.0;
    }
    return DEP_OK;
}

/* ---- the tangent of the motion at one state ------------------------------------------------ */

/* J of the active rows at (q, t), under a new identity for the Schur factor. */
void dep_sens_at_state(dep_run *run, double t, const double *q)
{
    dep_sensitivity *x = &run->sens;
    dep_cs_jacobian(&run->cs, q, t, x->J);
    x->J_id = ++x->ids;
}

/* out = S^-1 b for the J at_state left (0 where S's factor dropped a row). */
void dep_sens_schur(dep_run *run, const double *b, double *out)
{
    dep_sensitivity *x = &run->sens;
    if (!dep_schur_solve(&x->mp, x->J, x->J_id, run->cs.nc, b, out)) {
        memset(out, 0, (size_t)run->cs.nc * sizeof *out);
        x->unsolved = 1;
    }
}

/* (x, y) with M x + J^T y = r1, J x = r2 (r1 kept; y: nc). */
void dep_sens_solve_motion(dep_run *run, const double *r1, const double *r2, double *xq,
                         double *y)
{
    dep_sensitivity *x = &run->sens;
    int nc = run->cs.nc, nq = run->nq;
    dep_mass_solve(&run->system.mass, r1, x->u);
    dep_cs_times(&run->cs, x->J, x->u, x->b);
    for (int a = 0; a < nc; ++a) {
        x->b[a] -= r2[a];
    }
    dep_sens_schur(run, x->b, y);
    dep_cs_transpose_times(&run->cs, x->J, y, x->v);
    for (int j = 0; j < nq; ++j) {
        x->v[j] = r1[j] - x->v[j];
    }
    dep_mass_solve(&run->system.mass, x->v, xq);
}

/* The tangent dJ (the layout of J) along (dq, dp): the model's rows by phi_q_tangent, a lock
   row by hinge_jacobian_tangent, a linear row's none. */
void dep_sens_jacobian_tangent(dep_run *run, double t, const double *q, const double *dq)
{
    dep_sensitivity *x = &run->sens;
    const dep_model *m = run->model;
    const dep_constraints *cs = &run->cs;
    m->phi_q_tangent(q, t, run->p, dq, x->dp, x->dJ);
    if (cs->n_added == 0) {
        return;
    }
    m->hinge_jacobian_tangent(q, run->p, dq, x->dp, x->dJh);
    for (int r = 0; r < cs->n_added; ++r) {
        const dep_added_row *row = &cs->added[r];
        int a = cs->nc_module + r, start = cs->row_start[a], n = cs->row_start[a + 1] - start;
        if (row->kind == DEP_ROW_LINEAR) {
            memset(x->dJ + start, 0, (size_t)n * sizeof(double));
        } else {
            memcpy(x->dJ + start, x->dJh + cs->system->hinge_start[row->hinge],
                   (size_t)n * sizeof(double));
        }
    }
}

/* The hinge torques' tangent along (dq, dqd, dp) for parameter i: dtau (nh) from the torques
   x->tau, rates and angles at the state (laws.c: friction by its law in the hinge's mode, a
   compliant latch's push while in contact). */
static void torque_tangent(dep_run *run, const double *dH, const double *q, const double *qd,
                           const double *dq, const double *dqd)
{
    dep_sensitivity *x = &run->sens;
    const dep_model *m = run->model;
    const dep_system *system = &run->system;
    static const double none[DEP_HINGE_PROPERTIES];
    m->hinge_rates_tangent(q, qd, run->p, dq, dqd, x->dp, x->drate);
    if (system->n_compliant > 0) {
        m->hinge_angles_tangent(q, run->p, dq, x->dp, x->dtheta);
    }
    for (int h = 0; h < m->nh; ++h) {
        const dep_hinge_mechanics *hm = &system->hinges[h];
        const double *dh = dH != NULL ? dH + (size_t)h * DEP_HINGE_PROPERTIES : none;
        double r = x->rate[h], d = 0.0;
        if (hm->has_friction && !dep_hinge_locked(hm) && !hm->stuck) {
            double dF = dh[DEP_HINGE_FRICTION];
            if (hm->has_static) {
                d = -hm->direction * dF;
            } else {
                double v = hm->slip_rate, slope = -hm->kinetic / v / (cosh(r / v) * cosh(r / v));
                d = -dF * tanh(r / v) + slope * (x->drate[h] - r * dh[DEP_HINGE_SLIP_RATE] / v);
            }
        }
        if (hm->latch_state == DEP_CONTACT) {
            double side = hm->latch_side, delta = side * (x->theta[h] - hm->latch);
            double delta_rate = side * r;
            if (hm->latch_stiffness * delta + hm->latch_damping * delta_rate > 0.0) {
                d -= side * (dh[DEP_HINGE_LATCH_STIFFNESS] * delta
                             + hm->latch_stiffness * side * (x->dtheta[h] - dh[DEP_HINGE_LATCH])
                             + dh[DEP_HINGE_LATCH_DAMPING] * delta_rate
                             + hm->latch_damping * side * x->drate[h]);
            }
        }
        x->dtau[h] = d;
    }
}

/* At (t, q, qd) of the active rows, J from at_state: lambda and qdd of the motion (x->lam,
   x->qdd), and for each parameter the tangent ds (k x 2 nq) of the sensitivities s and the
   multipliers' dlambda (x->dlam). */
void dep_sens_motion_base(dep_run *run, double t, const double *q, const double *qd)
{
    dep_sensitivity *x = &run->sens;
    const dep_model *m = run->model;
    const dep_system *system = &run->system;
    dep_constraints *cs = &run->cs;
    int forcing = dep_hinge_forcing(system);
    if (x->base_id == x->J_id) { /* every caller passes the same qd with the same J */
        return;
    }
    dep_system_force(system, q, qd, t, x->f);
    dep_cs_gamma(cs, q, qd, t, x->gamma);
    dep_sens_solve_motion(run, x->f, x->gamma, x->qdd, x->lam);
    if (forcing || cs->n_added > 0) {
        m->hinge_jacobian(q, run->p, x->Jh);
    }
    if (forcing) {
        m->hinge_rates(q, qd, run->p, x->rate);
        dep_hinge_torques(system, q, x->rate, NULL, x->tau);
        m->hinge_angles(q, run->p, x->theta);
    }
    x->base_id = x->J_id;
}

void dep_sens_direction(dep_run *run, double t, const double *q, const double *qd,
                        const double *dq, const double *dqd, const double *dH,
                        const double *dM, double *out, double *dlam)
{
    dep_sensitivity *x = &run->sens;
    const dep_model *m = run->model;
    const dep_system *system = &run->system;
    dep_constraints *cs = &run->cs;
    int nq = run->nq, nc = cs->nc;
    m->force_tangent(q, qd, t, run->p, dq, dqd, x->dp, x->r1);
    dep_sens_jacobian_tangent(run, t, q, dq);
    if (dep_hinge_forcing(system)) {
        torque_tangent(run, dH, q, qd, dq, dqd);
        dep_hinge_transpose_times(system, x->Jh, x->dtau, x->u);
        if (cs->n_added == 0) {
            m->hinge_jacobian_tangent(q, run->p, dq, x->dp, x->dJh);
        }
        dep_hinge_transpose_times(system, x->dJh, x->tau, x->v);
        for (int j = 0; j < nq; ++j) {
            x->r1[j] += x->u[j] + x->v[j];
        }
    }
    dep_cs_transpose_times(cs, x->dJ, x->lam, x->u);
    for (int j = 0; j < nq; ++j) {
        x->r1[j] -= x->u[j];
    }
    for (int e = 0; dM != NULL && e < m->nmz; ++e) {
        x->r1[m->mass_rows[e]] -= dM[e] * x->qdd[m->mass_cols[e]];
    }
    m->gamma_tangent(q, qd, t, run->p, dq, dqd, x->dp, x->r2);
    if (cs->n_added > 0) {
        m->hinge_gamma_tangent(q, qd, run->p, dq, dqd, x->dp, x->gamma_h);
        for (int r = 0; r < cs->n_added; ++r) {
            const dep_added_row *row = &cs->added[r];
            x->r2[cs->nc_module + r] = row->kind == DEP_ROW_LINEAR ? 0.0
                                                                   : x->gamma_h[row->hinge];
        }
    }
    dep_cs_times(cs, x->dJ, x->qdd, x->b);
    for (int a = 0; a < nc; ++a) {
        x->r2[a] -= x->b[a];
    }
    memcpy(out, dqd, (size_t)nq * sizeof *out);
    dep_sens_solve_motion(run, x->r1, x->r2, out + nq, dlam);
}

void dep_sens_motion_tangent(dep_run *run, double t, const double *q, const double *qd,
                             const double *s, double *ds)
{
    dep_sensitivity *x = &run->sens;
    const dep_model *m = run->model;
    size_t n2 = 2 * (size_t)run->nq, nmz = (size_t)m->nmz + 1;
    size_t nhp = ((size_t)m->nh + 1) * DEP_HINGE_PROPERTIES;
    dep_sens_motion_base(run, t, q, qd);
    for (size_t i = 0; i < (size_t)x->k; ++i) {
        const double *dq = s + i * n2;
        x->dp[x->params[i]] = 1.0;
        dep_sens_direction(run, t, q, qd, dq, dq + run->nq, x->dH + i * nhp, x->dM + i * nmz,
                           ds + i * n2, x->dlam + i * (size_t)run->cs.capacity);
        x->dp[x->params[i]] = 0.0;
    }
}

/* s onto the tangents of the position and velocity constraints at (t, q, qd) (J from
   at_state), in M's metric: J dq + Phi_p = 0, then J dqd + dJ qd + dPhi_t = 0. */
void dep_sens_project(dep_run *run, double t, const double *q, const double *qd, double *s)
{
    dep_sensitivity *x = &run->sens;
    const dep_model *m = run->model;
    dep_constraints *cs = &run->cs;
    int nq = run->nq, n2 = 2 * nq;
    if (cs->nc == 0) {
        return;
    }
    for (int i = 0; i < x->k; ++i) {
        double *dq = s + (size_t)i * n2, *dqd = dq + nq;
        const double *angles = x->row_angles;
        x->dp[x->params[i]] = 1.0;
        for (int level = 0; level < 2; ++level) {
            if (level == 0) {
                m->phi_tangent(q, t, run->p, dq, x->dp, x->r2);
                if (cs->n_added > 0) {
                    m->hinge_angles_tangent(q, run->p, dq, x->dp, x->dtheta);
                }
            } else {
                dep_sens_jacobian_tangent(run, t, q, dq);
                m->phi_t_tangent(q, t, run->p, dq, x->dp, x->r2);
                dep_cs_times(cs, x->J, dqd, x->b);
                dep_cs_times(cs, x->dJ, qd, x->c);
                for (int a = 0; a < cs->nc_module; ++a) {
                    x->r2[a] += x->b[a] + x->c[a];
                }
                if (cs->n_added > 0) {
                    m->hinge_rates_tangent(q, qd, run->p, dq, dqd, x->dp, x->drate);
                }
            }
            for (int r = 0; r < cs->n_added; ++r) {
                const dep_added_row *row = &cs->added[r];
                int a = cs->nc_module + r;
                if (row->kind == DEP_ROW_LINEAR) {
                    dep_cs_times(cs, x->J, level == 0 ? dq : dqd, x->b);
                    x->r2[a] = x->b[a];
                } else if (level == 0) {
                    x->r2[a] = x->dtheta[row->hinge] - angles[(size_t)r * x->k + i];
                } else {
                    x->r2[a] = x->drate[row->hinge];
                }
            }
            dep_sens_schur(run, x->r2, x->y);
            dep_cs_transpose_times(cs, x->J, x->y, x->u);
            dep_mass_solve(&run->system.mass, x->u, x->v);
            double *target = level == 0 ? dq : dqd;
            for (int j = 0; j < nq; ++j) {
                target[j] -= x->v[j];
            }
        }
        x->dp[x->params[i]] = 0.0;
    }
}

/* ---- the added rows' angles -------------------------------------------------------------- */

/* The sensitivity of each added row's angle follows the row: cs->added is kept in the same
   order as x->row_angles, by the rows' ids. */
static void follow_rows(dep_run *run, const long long *ids, const double *angles, int n)
{
    dep_sensitivity *x = &run->sens;
    const dep_constraints *cs = &run->cs;
    size_t k = (size_t)x->k;
    for (int r = 0; r < cs->n_added; ++r) {
        int found = -1;
        for (int o = 0; o < n; ++o) {
            if (ids[o] == cs->added[r].id) {
                found = o;
            }
        }
        for (size_t i = 0; i < k; ++i) {
            x->stage[(size_t)r * k + i] = found >= 0 ? angles[(size_t)found * k + i] : NAN;
        }
        x->row_ids[r] = cs->added[r].id;
    }
    memcpy(x->row_angles, x->stage, (size_t)cs->n_added * k * sizeof(double));
    x->n_rows = cs->n_added;
}

/* A new row's angle sensitivities (the rows without one after follow_rows): a latch's or a
   stop's the parameter's, a hold-down's or a stick row's the angle's own where it engaged. */
static void new_row_angles(dep_run *run, const double *q)
{
    dep_sensitivity *x = &run->sens;
    const dep_model *m = run->model;
    const dep_constraints *cs = &run->cs;
    size_t k = (size_t)x->k, nhp = DEP_HINGE_PROPERTIES, nh1 = (size_t)m->nh + 1;
    int n2 = 2 * run->nq;
    for (int r = 0; r < cs->n_added; ++r) {
        const dep_added_row *row = &cs->added[r];
        for (size_t i = 0; i < k; ++i) {
            double *angle = &x->row_angles[(size_t)r * k + i];
            if (!isnan(*angle) || row->kind == DEP_ROW_LINEAR) {
                *angle = isnan(*angle) ? 0.0 : *angle;
                continue;
            }
            const double *dh = x->dH + (i * nh1 + (size_t)row->hinge) * nhp;
            const dep_hinge_mechanics *h = &run->system.hinges[row->hinge];
            if (row->lock == DEP_LOCK_LATCH) {
                *angle = dh[DEP_HINGE_LATCH];
            } else if (row->lock == DEP_LOCK_STOP) {
                *angle = row->angle == h->stop_max ? dh[DEP_HINGE_STOP_MAX]
                                                   : dh[DEP_HINGE_STOP_MIN];
            } else {
                x->dp[x->params[i]] = 1.0;
                m->hinge_angles_tangent(q, run->p, x->s + i * (size_t)n2, x->dp, x->dtheta);
                x->dp[x->params[i]] = 0.0;
                *angle = x->dtheta[row->hinge];
            }
        }
    }
}

void dep_sens_rows_changed(dep_run *run, const double *q)
{
    dep_sensitivity *x = &run->sens;
    long long ids[DEP_MAX_ADDED];
    size_t n = (size_t)x->n_rows * (size_t)x->k;
    memcpy(ids, x->row_ids, (size_t)x->n_rows * sizeof *ids);
    memcpy(x->saved_angles, x->row_angles, n * sizeof(double));
    follow_rows(run, ids, x->saved_angles, x->n_rows);
    new_row_angles(run, q);
}

/* ---- records and refusals ---------------------------------------------------------------- */

/* The event records from `first` on get the sensitivities dtau (k) of their time (NULL: 0,
   a fixed time). */
int dep_sens_event_times(dep_run *run, int first, const double *dtau)
{
    dep_sensitivity *x = &run->sens;
    size_t k = (size_t)x->k;
    if (run->n_records > x->event_capacity) {
        int capacity = 2 * run->n_records + 8;
        double *times = dep_doubles(&run->arena, (size_t)capacity * k);
        if (times == NULL) {
            return dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory");
        }
        if (x->event_capacity > 0) {
            memcpy(times, x->event_times, (size_t)x->event_capacity * k * sizeof *times);
        }
        for (size_t j = (size_t)x->event_capacity * k; j < (size_t)capacity * k; ++j) {
            times[j] = NAN;
        }
        x->event_times = times;
        x->event_capacity = capacity;
    }
    for (int r = first; r < run->n_records; ++r) {
        for (size_t i = 0; i < k; ++i) {
            x->event_times[(size_t)r * k + i] = dtau != NULL ? dtau[i] : 0.0;
        }
    }
    return DEP_OK;
}

/* A failure of the sensitivities' own: the step method they cannot follow. */
int dep_sens_unsupported(dep_run *run, double t, const char *what)
{
    char message[400];
    snprintf(message, sizeof message, "sensitivities at t = %.9g s: %s", t, what);
    return dep_plain_error(run->error, DEP_SETTINGS_ERROR, message);
}
