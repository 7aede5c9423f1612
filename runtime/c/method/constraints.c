/* constraints.c: the active constraint set, the model's NC rows followed by rows added by
 * events (hinge locks, linear rows), and every level of the constraint error:
 *
 *     v_pos = -Phi(q, t),  v_vel = -Phi_q qd - Phi_t,  v_acc = gamma(q, qd, t) - Phi_q qdd.
 *
 * A run's state (after the start and every event) must satisfy the position and velocity
 * levels to CONSISTENCY tolerances; dep_check_consistency names the worst joint otherwise.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "method.h"

#define CONSISTENCY 1e3 /* a (re)start state may violate its constraints by this many tols */

static const char *const LOCK_NAMES[4] = {"latch", "stop", "stick", "lock"}; /* enum dep_lock */

/* row_start, row_cols for the active rows. */
static void refresh_pattern(dep_constraints *cs)
{
    const dep_model *model = cs->system->model;
    cs->pattern++;
    int nq = cs->nq, k = 0, *start = cs->row_start, *cols = cs->row_cols;
    for (int i = 0, n = 0; i < model->nc; ++i) { /* PHI_Q_ROWS is sorted row-major */
        start[i] = k;
        while (n < model->nnz && model->phi_q_rows[n] == i) {
            cols[k++] = model->phi_q_cols[n++];
        }
    }
    for (int i = 0; i < cs->n_added; ++i) {
        const dep_added_row *r = &cs->added[i];
        start[model->nc + i] = k;
        if (r->kind == DEP_ROW_HINGE_LOCK) {
            const int *hinge_start = cs->system->hinge_start;
            for (int m = hinge_start[r->hinge]; m < hinge_start[r->hinge + 1]; ++m) {
                cols[k++] = model->hinge_jacobian_cols[m];
            }
            continue;
        }
        for (int j = 0; j < nq; ++j) {
            if (r->row[j] != 0.0) {
                cols[k++] = j;
            }
        }
    }
    start[model->nc + cs->n_added] = k;
}

void dep_cs_times(const dep_constraints *cs, const double *J, const double *x, double *out)
{
    for (int i = 0; i < cs->nc; ++i) {
        double sum = 0.0;
        for (int k = cs->row_start[i]; k < cs->row_start[i + 1]; ++k) {
            sum += J[k] * x[cs->row_cols[k]];
        }
        out[i] = sum;
    }
}

void dep_cs_transpose_times(const dep_constraints *cs, const double *J, const double *y,
                            double *out)
{
    memset(out, 0, (size_t)cs->nq * sizeof *out);
    for (int i = 0; i < cs->nc; ++i) {
        for (int k = cs->row_start[i]; k < cs->row_start[i + 1]; ++k) {
            out[cs->row_cols[k]] += J[k] * y[i];
        }
    }
}

void dep_cs_sizes(const dep_constraints *cs, const double *J, const double *x, double *size)
{
    const double *s = cs->system->scales;
    for (int i = 0; i < cs->nc; ++i) {
        double sum = 0.0;
        for (int k = cs->row_start[i]; k < cs->row_start[i + 1]; ++k) {
            int j = cs->row_cols[k];
            sum += fabs(J[k]) * (s[j] + fabs(x[j]));
        }
        size[i] = sum;
    }
}

void dep_cs_times_sized(const dep_constraints *cs, const double *J, const double *x,
                        double *out, double *size)
{
    const double *s = cs->system->scales;
    for (int i = 0; i < cs->nc; ++i) {
        double sum = 0.0, sized = 0.0;
        for (int k = cs->row_start[i]; k < cs->row_start[i + 1]; ++k) {
            int j = cs->row_cols[k];
            sum += J[k] * x[j];
            sized += fabs(J[k]) * (s[j] + fabs(x[j]));
        }
        out[i] = sum;
        size[i] = sized;
    }
}

void dep_cs_abs_times(const dep_constraints *cs, const double *J, const double *m, double *out)
{
    for (int i = 0; i < cs->nc; ++i) {
        double sum = 0.0;
        for (int k = cs->row_start[i]; k < cs->row_start[i + 1]; ++k) {
            sum += fabs(J[k]) * m[cs->row_cols[k]];
        }
        out[i] = sum;
    }
}

void dep_cs_abs_transpose_times(const dep_constraints *cs, const double *J, const double *y,
                                double *out)
{
    memset(out, 0, (size_t)cs->nq * sizeof *out);
    for (int i = 0; i < cs->nc; ++i) {
        for (int k = cs->row_start[i]; k < cs->row_start[i + 1]; ++k) {
            out[cs->row_cols[k]] += fabs(J[k] * y[i]);
        }
    }
}

int dep_constraints_init(dep_constraints *cs, const dep_system *system, dep_arena *arena)
{
    const dep_model *model = system->model;
    size_t nq = (size_t)system->nq, nh = (size_t)model->nh;
    memset(cs, 0, sizeof *cs);
    cs->system = system;
    cs->nq = system->nq;
    cs->nc_module = cs->nc = model->nc;
    cs->capacity = model->nc + DEP_MAX_ADDED;
    cs->row_names = dep_bytes(arena, (size_t)cs->capacity * sizeof *cs->row_names);
    cs->row_joints = dep_bytes(arena, (size_t)cs->capacity * sizeof *cs->row_joints);
    cs->theta = dep_doubles(arena, nh);
    cs->hinge_jacobian = dep_doubles(arena, (size_t)model->nhnz + 1);
    cs->row_values = dep_doubles(arena, nq);
    for (int i = 0; i < DEP_MAX_ADDED; ++i) {
        cs->added[i].row = dep_doubles(arena, nq);
    }
    cs->row_locks = dep_bytes(arena, (size_t)cs->capacity * sizeof *cs->row_locks);
    cs->row_hinges = dep_bytes(arena, (size_t)cs->capacity * sizeof *cs->row_hinges);
    cs->row_start = dep_bytes(arena, ((size_t)cs->capacity + 1) * sizeof *cs->row_start);
    cs->row_cols = dep_bytes(arena, DEP_JACOBIAN_SIZE(model) * sizeof *cs->row_cols);
    if (arena->failed) {
        return DEP_MEMORY_ERROR;
    }
    for (int i = 0; i < model->nc; ++i) {
        cs->row_names[i] = model->constraint_names[i];
        cs->row_joints[i] = model->constraint_joints[i];
        cs->row_locks[i] = cs->row_hinges[i] = -1;
    }
    refresh_pattern(cs);
    return DEP_OK;
}

/* ---- the added rows (HingeLock, LinearConstraint) ----------------------------------------- */

/* The added rows' helpers below evaluate the model's hinge function they need once per
   call of the level (*made: 0 before the first lock row at q), not once per lock row. */
static double row_phi(dep_constraints *cs, const dep_added_row *r, const double *q, int *made)
{
    const dep_system *s = cs->system;
    if (r->kind == DEP_ROW_HINGE_LOCK) {
        if (!*made) {
            s->model->hinge_angles(q, s->p, cs->theta);
            *made = 1;
        }
        return cs->theta[r->hinge] - r->angle;
    }
    double sum = 0.0;
    for (int j = 0; j < cs->nq; ++j) {
        sum += r->row[j] * q[j];
    }
    return sum - r->value;
}

/* The added row i's Jacobian at its pattern (row_cols from row_start[nc_module + i]): a
   linear row's own non-zeros, a lock's values of the model's hinge_jacobian. */
static const double *row_jacobian(dep_constraints *cs, int i, const double *q, int *made)
{
    const dep_system *s = cs->system;
    const dep_added_row *r = &cs->added[i];
    if (r->kind == DEP_ROW_LINEAR) {
        int a = cs->nc_module + i, n = 0;
        for (int k = cs->row_start[a]; k < cs->row_start[a + 1]; ++k) {
            cs->row_values[n++] = r->row[cs->row_cols[k]];
        }
        return cs->row_values;
    }
    if (!*made) {
        s->model->hinge_jacobian(q, s->p, cs->hinge_jacobian);
        *made = 1;
    }
    return cs->hinge_jacobian + cs->system->hinge_start[r->hinge];
}

/* HingeLock.gamma: the model's hinge_gamma, -(J_k qd)_q qd (zero for rigid bodies); zero
   for linear rows. */
static double row_gamma(dep_constraints *cs, const dep_added_row *r, const double *q,
                        const double *qd, int *made)
{
    const dep_system *s = cs->system;
    if (r->kind == DEP_ROW_LINEAR) {
        return 0.0;
    }
    if (!*made) {
        s->model->hinge_gamma(q, qd, s->p, cs->theta);
        *made = 1;
    }
    return cs->theta[r->hinge];
}

/* ---- every level, for the active rows ---------------------------------------------------- */

void dep_cs_phi(dep_constraints *cs, const double *q, double t, double *out)
{
    int made = 0;
    cs->system->model->phi(q, t, cs->system->p, out);
    for (int i = 0; i < cs->n_added; ++i) {
        out[cs->nc_module + i] = row_phi(cs, &cs->added[i], q, &made);
    }
}

void dep_cs_jacobian(dep_constraints *cs, const double *q, double t, double *J)
{
    const dep_model *model = cs->system->model;
    int made = 0;
    model->phi_q(q, t, cs->system->p, J); /* the model's rows come first, in its order */
    for (int i = 0; i < cs->n_added; ++i) {
        int a = cs->nc_module + i;
        memcpy(J + cs->row_start[a], row_jacobian(cs, i, q, &made),
               (size_t)(cs->row_start[a + 1] - cs->row_start[a]) * sizeof *J);
    }
}

void dep_cs_jacobian_transpose_times(dep_constraints *cs, const double *q, double t,
                                     const double *lam, double *out)
{
    int made = 0;
    cs->system->model->phi_q_transpose_times(q, t, cs->system->p, lam, out);
    for (int i = 0; i < cs->n_added; ++i) {
        int a = cs->nc_module + i;
        const double *row = row_jacobian(cs, i, q, &made);
        for (int k = cs->row_start[a]; k < cs->row_start[a + 1]; ++k) {
            out[cs->row_cols[k]] += row[k - cs->row_start[a]] * lam[a];
        }
    }
}

void dep_cs_phi_t(dep_constraints *cs, const double *q, double t, double *out)
{
    cs->system->model->phi_t(q, t, cs->system->p, out);
    for (int i = 0; i < cs->n_added; ++i) {
        out[cs->nc_module + i] = 0.0;
    }
}

void dep_cs_gamma(dep_constraints *cs, const double *q, const double *qd, double t, double *out)
{
    int made = 0;
    cs->system->model->gamma(q, qd, t, cs->system->p, out);
    for (int i = 0; i < cs->n_added; ++i) {
        out[cs->nc_module + i] = row_gamma(cs, &cs->added[i], q, qd, &made);
    }
}

void dep_cs_v_vel(dep_constraints *cs, const double *q, const double *qd, double t,
                  const double *J, double *out)
{
    dep_cs_phi_t(cs, q, t, out);
    for (int i = 0; i < cs->nc; ++i) {
        double sum = 0.0;
        for (int k = cs->row_start[i]; k < cs->row_start[i + 1]; ++k) {
            sum += J[k] * qd[cs->row_cols[k]];
        }
        out[i] = -sum - out[i];
    }
}

void dep_cs_v_acc(dep_constraints *cs, const double *q, const double *qd, const double *qdd,
                  double t, const double *J, double *out)
{
    dep_cs_gamma(cs, q, qd, t, out);
    for (int i = 0; i < cs->nc; ++i) {
        double sum = 0.0;
        for (int k = cs->row_start[i]; k < cs->row_start[i + 1]; ++k) {
            sum += J[k] * qdd[cs->row_cols[k]];
        }
        out[i] -= sum;
    }
}

/* "hinge h3", "slider s1", "lock h1": the joint of a row for messages. */
void dep_cs_describe(const dep_constraints *cs, int row, char *joint_text, size_t size)
{
    const char *joint = cs->row_joints[row];
    const char *kind = row >= cs->nc_module ? "lock" : dep_joint_kind(cs->system->model, row);
    snprintf(joint_text, size, "%s %s", kind, joint);
}

/* ---- changing the set after an event (ConstraintSet.without / with_rows) --------------- */

static void refresh_names(dep_constraints *cs)
{
    cs->nc = cs->nc_module + cs->n_added;
    for (int i = 0; i < cs->n_added; ++i) {
        cs->row_names[cs->nc_module + i] = cs->added[i].name;
        cs->row_joints[cs->nc_module + i] = cs->added[i].joint;
        cs->row_locks[cs->nc_module + i] = cs->added[i].lock;
        cs->row_hinges[cs->nc_module + i] = cs->added[i].lock >= 0 ? cs->added[i].hinge : -1;
    }
    refresh_pattern(cs);
}

/* Without the added rows for which `removed` is 1 (the others keep their order). */
static void remove_rows(dep_constraints *cs, const int *removed)
{
    int kept = 0;
    for (int i = 0; i < cs->n_added; ++i) {
        if (removed[i]) {
            continue;
        }
        if (kept != i) { /* keep each row's storage: swap the structs */
            dep_added_row moved = cs->added[kept];
            cs->added[kept] = cs->added[i];
            cs->added[i] = moved;
        }
        ++kept;
    }
    cs->n_added = kept;
    refresh_names(cs);
}

int dep_cs_remove(dep_constraints *cs, const char *name)
{
    int removed[DEP_MAX_ADDED];
    for (int i = 0; i < cs->n_added; ++i) {
        removed[i] = strcmp(cs->added[i].name, name) == 0;
    }
    remove_rows(cs, removed);
    return DEP_OK;
}

void dep_cs_remove_lock(dep_constraints *cs, int lock, int hinge)
{
    int removed[DEP_MAX_ADDED];
    for (int i = 0; i < cs->n_added; ++i) {
        removed[i] = cs->added[i].lock == lock && cs->added[i].hinge == hinge;
    }
    remove_rows(cs, removed);
}

const char *dep_lock_name(int lock)
{
    return LOCK_NAMES[lock];
}

/* Append a copy of `row` (its id kept, or a new one when it has none). */
int dep_cs_add_row(dep_constraints *cs, const dep_added_row *row, dep_error *error)
{
    char message[DEP_NAME_MAX + 80];
    if (cs->n_added == DEP_MAX_ADDED) {
        snprintf(message, sizeof message, "more than %d added constraint rows", DEP_MAX_ADDED);
        return dep_plain_error(error, DEP_CALLBACK_ERROR, message);
    }
    if (dep_cs_index(cs, row->name) >= 0) {
        snprintf(message, sizeof message, "constraint rows named twice: %s", row->name);
        return dep_plain_error(error, DEP_SETTINGS_ERROR, message);
    }
    dep_added_row *r = &cs->added[cs->n_added];
    double *storage = r->row;
    *r = *row;
    r->row = storage;
    if (row->kind == DEP_ROW_LINEAR) {
        memcpy(r->row, row->row, (size_t)cs->nq * sizeof *r->row);
    }
    r->id = row->id != 0 ? row->id : ++cs->next_id;
    cs->n_added++;
    refresh_names(cs);
    return DEP_OK;
}

/* A row of an event callback (dep_row) as an added row: checked, named "<hinge>.lock" by
   default (HingeLock), its joint the hinge. */
int dep_cs_prepare_row(const dep_constraints *cs, const dep_row *row, dep_added_row *out,
                       dep_error *error)
{
    const dep_model *model = cs->system->model;
    char message[DEP_NAME_MAX + 80];
    if (row->kind == DEP_ROW_HINGE_LOCK && (row->hinge < 0 || row->hinge >= model->nh)) {
        snprintf(message, sizeof message, "unknown hinge index %d", row->hinge);
        return dep_plain_error(error, DEP_CALLBACK_ERROR, message);
    }
    if (row->kind != DEP_ROW_HINGE_LOCK && (row->kind != DEP_ROW_LINEAR || row->row == NULL)) {
        return dep_plain_error(error, DEP_CALLBACK_ERROR, "an added row needs a kind and data");
    }
    const char *hinge = row->kind == DEP_ROW_HINGE_LOCK ? model->hinge_names[row->hinge] : "";
    memset(out, 0, sizeof *out);
    out->kind = row->kind;
    out->hinge = row->hinge;
    out->lock = row->kind == DEP_ROW_HINGE_LOCK ? DEP_LOCK_EVENT : -1;
    out->angle = row->angle;
    out->value = row->value;
    out->row = (double *)row->row;
    if (row->name[0] != '\0') {
        dep_copy_text(out->name, sizeof out->name, row->name);
    } else {
        snprintf(out->name, sizeof out->name, "%.*s.%s", DEP_NAME_MAX - 6, hinge,
                 LOCK_NAMES[DEP_LOCK_EVENT]);
    }
    dep_copy_text(out->joint, sizeof out->joint, row->joint[0] != '\0' ? row->joint : hinge);
    return DEP_OK;
}

int dep_cs_add(dep_constraints *cs, const dep_row *row, dep_error *error)
{
    dep_added_row r;
    int status = dep_cs_prepare_row(cs, row, &r, error);
    return status == DEP_OK ? dep_cs_add_row(cs, &r, error) : status;
}

/* The position of row `name` among the active rows, or -1. */
int dep_cs_index(const dep_constraints *cs, const char *name)
{
    for (int i = 0; i < cs->nc; ++i) {
        if (strcmp(cs->row_names[i], name) == 0) {
            return i;
        }
    }
    return -1;
}

int dep_cs_lock_index(const dep_constraints *cs, int lock, int hinge)
{
    for (int i = cs->nc_module; i < cs->nc; ++i) {
        if (cs->row_locks[i] == lock && cs->row_hinges[i] == hinge) {
            return i;
        }
    }
    return -1;
}

dep_active_rows dep_cs_view(const dep_constraints *cs, const double *lam)
{
    dep_active_rows view = {cs->nc, cs->row_names, lam, cs->row_locks, cs->row_hinges};
    return view;
}

/* The module's rows followed by copies of rows[0..n) (a new ConstraintSet). */
void dep_cs_assign(dep_constraints *cs, const dep_added_row *rows, int n)
{
    cs->n_added = 0;
    for (int i = 0; i < n && i < DEP_MAX_ADDED; ++i) {
        dep_added_row *r = &cs->added[i];
        double *storage = r->row;
        *r = rows[i];
        r->row = storage;
        if (rows[i].kind == DEP_ROW_LINEAR) {
            memcpy(r->row, rows[i].row, (size_t)cs->nq * sizeof *r->row);
        }
        cs->n_added++;
    }
    refresh_names(cs);
}

/* ---- check_consistency ------------------------------------------------------------------- */

static int violation(dep_constraints *cs, double t, const double *v, const double *values,
                     double tol, const char *stage, const char *level, const char *quantity,
                     dep_error *error)
{
    double limit = CONSISTENCY * tol * fmax(1.0, dep_max_abs(values, cs->nq));
    int row = -1;
    for (int i = 0; i < cs->nc; ++i) { /* np.nanargmax of |v| */
        if (!isnan(v[i]) && (row < 0 || fabs(v[i]) > fabs(v[row]))) {
            row = i;
        }
    }
    if (cs->nc == 0 || (row >= 0 && fabs(v[row]) <= limit && dep_max_abs(v, cs->nc) <= limit)) {
        return DEP_OK;
    }
    row = row < 0 ? 0 : row;
    char what[300], joint[DEP_NAME_MAX + 8];
    dep_cs_describe(cs, row, joint, sizeof joint);
    snprintf(what, sizeof what, "the %s violates the %s constraint: |%s| = %.3g > %.1g", stage,
             level, quantity, fabs(v[row]), limit);
    const char *hint = strcmp(stage, "initial state") == 0
        ? "check the initial angles and rates of the joints in this joint's closed loop"
        : "an event callback must leave a state on the new constraints (impact=True makes "
          "the velocity jump)";
    return dep_solver_error(error, 1, t, stage, cs->row_names[row], joint, 1, fabs(v[row]),
                            what, hint);
}

int dep_check_consistency(dep_constraints *cs, double t, const double *q, const double *qd,
                          double tol, const char *stage, double *scratch, dep_error *error)
{
    double *J = scratch, *v = scratch + DEP_JACOBIAN_SIZE(cs->system->model);
    dep_cs_jacobian(cs, q, t, J);
    dep_cs_phi(cs, q, t, v);
    for (int i = 0; i < cs->nc; ++i) {
        v[i] = -v[i];
    }
    int status = violation(cs, t, v, q, tol, stage, "position", "Phi", error);
    if (status != DEP_OK) {
        return status;
    }
    dep_cs_v_vel(cs, q, qd, t, J, v);
    return violation(cs, t, v, qd, tol, stage, "velocity", "Phi_q qd + Phi_t", error);
}

/* ---- the lock rows' torques --------------------------------------------------------------- */

/* T_h = -lambda of each hinge's active lock rows (nh; the rows added at run time), NAN where
   none is active: summed by lock kind (enum dep_lock), then in row order. */
void dep_lock_torques(const dep_model *model, const dep_constraints *cs, const double *lam,
                      double *torques)
{
    for (int k = 0; k < model->nh; ++k) {
        torques[k] = NAN;
    }
    for (int kind = 0; kind < 4; ++kind) {
        for (int a = 0; a < cs->n_added; ++a) {
            int i = cs->nc_module + a, k = cs->row_hinges[i];
            if (cs->row_locks[i] == kind && isfinite(lam[i])) {
                torques[k] = isnan(torques[k]) ? -lam[i] : torques[k] - lam[i];
            }
        }
    }
}
