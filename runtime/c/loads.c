/* loads.c: hinge reaction loads from the multipliers, and their running peaks at the
 * accepted steps (summary.c merges them with the output times').
 *
 * A hinge's rows "<h>.x", "<h>.y" = r_a - r_b give the force on member b from member a,
 * F_h = (lambda_x, lambda_y) (N, world frame); a lock row "<h>.latch", "<h>.stop",
 * "<h>.stick" or "<h>.lock" gives the torque T_h = -lambda (N m, on member b).
 */
#include <math.h>
#include <string.h>

#include "runtime.h"

static const char *const LOCK_ROWS[4] = {"latch", "stop", "stick", "lock"};

/* The position of "<hinge>.<suffix>" among the model's constraint rows, or -1. */
static int model_row(const dep_model *model, const char *hinge, const char *suffix)
{
    size_t length = strlen(hinge);
    for (int i = 0; i < model->nc; ++i) {
        const char *name = model->constraint_names[i];
        if (strncmp(name, hinge, length) == 0 && name[length] == '.'
            && strcmp(name + length + 1, suffix) == 0) {
            return i;
        }
    }
    return -1;
}

int dep_loads_init(dep_loads *loads, const dep_model *model, dep_arena *arena)
{
    size_t nh = (size_t)model->nh;
    memset(loads, 0, sizeof *loads);
    loads->model = model;
    loads->nh = model->nh;
    loads->force = dep_doubles(arena, nh);
    loads->t_force = dep_doubles(arena, nh);
    loads->torque = dep_doubles(arena, nh);
    loads->t_torque = dep_doubles(arena, nh);
    loads->forces = dep_doubles(arena, 2 * nh);
    loads->torques = dep_doubles(arena, nh);
    loads->rows = dep_bytes(arena, (2 * nh + 1) * sizeof *loads->rows);
    if (arena->failed) {
        return DEP_MEMORY_ERROR;
    }
    for (size_t k = 0; k < nh; ++k) {
        loads->t_force[k] = loads->t_torque[k] = NAN;
        loads->rows[2 * k] = model_row(model, model->hinge_names[k], "x");
        loads->rows[2 * k + 1] = model_row(model, model->hinge_names[k], "y");
    }
    return DEP_OK;
}

/* (F_x, F_y) of each hinge (2 nh) from its rows "<h>.x", "<h>.y" (the model's), NAN where
   it has none. */
void dep_hinge_forces(const dep_loads *loads, const double *lam, double *forces)
{
    for (int k = 0; k < loads->nh; ++k) {
        int ix = loads->rows[2 * k], iy = loads->rows[2 * k + 1];
        forces[2 * k] = ix >= 0 && iy >= 0 ? lam[ix] : NAN;
        forces[2 * k + 1] = ix >= 0 && iy >= 0 ? lam[iy] : NAN;
    }
}

int dep_lock_row(const dep_model *model, const char *name, int *hinge)
{
    for (int k = 0; k < model->nh; ++k) {
        size_t length = strlen(model->hinge_names[k]);
        if (strncmp(name, model->hinge_names[k], length) != 0 || name[length] != '.') {
            continue;
        }
        for (int kind = 0; kind < 4; ++kind) {
            if (strcmp(name + length + 1, LOCK_ROWS[kind]) == 0) {
                *hinge = k;
                return kind;
            }
        }
    }
    *hinge = -1;
    return -1;
}

/* T_h = -lambda of each hinge's active lock rows (nh; the rows added at run time), NAN where
   none is active: summed by kind in LOCK_ROWS order, then in row order. */
void dep_lock_torques(const dep_model *model, const dep_constraints *cs, const double *lam,
                      double *torques)
{
    for (int k = 0; k < model->nh; ++k) {
        torques[k] = NAN;
    }
    for (int kind = 0; kind < 4; ++kind) {
        for (int a = 0; a < cs->n_added; ++a) {
            int i = cs->nc_module + a, k = cs->lock_hinge[a];
            if (cs->lock_kind[a] == kind && isfinite(lam[i])) {
                torques[k] = isnan(torques[k]) ? -lam[i] : torques[k] - lam[i];
            }
        }
    }
}

/* PeakTracker.observe: |F_h| and |T_h| at time t; NAN entries are skipped. */
void dep_loads_observe(dep_loads *loads, double t, const double *forces, const double *torques)
{
    for (int k = 0; k < loads->nh; ++k) {
        double magnitude = hypot(forces[2 * k], forces[2 * k + 1]), size = fabs(torques[k]);
        if (isfinite(magnitude) && magnitude > loads->force[k]) {
            loads->force[k] = magnitude;
            loads->t_force[k] = t;
        }
        if (isfinite(size) && size > loads->torque[k]) {
            loads->torque[k] = size;
            loads->t_torque[k] = t;
        }
    }
}
