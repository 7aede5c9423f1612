/* loads.c: hinge reaction loads from the multipliers, and their running peaks at the
 * accepted steps (summary.c merges them with the output times').
 *
 * A hinge's rows "<h>.x", "<h>.y" = r_a - r_b give the force on member b from member a,
 * F_h = (lambda_x, lambda_y) (N, world frame); a lock row "<h>.latch", "<h>.stop",
 * "<h>.stick" or "<h>.lock" gives the torque T_h = -lambda (N m, on member b).
 */
#include <math.h>
#include <string.h>

#include "run.h"


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
    loads->forces = dep_doubles(arena, DEP_FORCE_ROWS * nh);
    loads->torques = dep_doubles(arena, nh);
    loads->rows = dep_bytes(arena, (DEP_FORCE_ROWS * nh + 1) * sizeof *loads->rows);
    loads->redundant = dep_bytes(arena, (nh + 1) * sizeof *loads->redundant);
    if (arena->failed) {
        return DEP_MEMORY_ERROR;
    }
    for (size_t k = 0; k < nh; ++k) {
        loads->t_force[k] = loads->t_torque[k] = NAN;
        loads->redundant[k] = 0;
    }
    dep_hinge_force_rows(model, loads->rows);
    return DEP_OK;
}

/* (F_x, F_y, F_z) of each hinge (DEP_FORCE_ROWS nh) from its rows x, y, z (the model's),
   NAN where it has none, F_z 0 in a planar model. */
void dep_hinge_forces(const dep_loads *loads, const double *lam, double *forces)
{
    for (int k = 0; k < loads->nh; ++k) {
        dep_hinge_force(loads->rows + DEP_FORCE_ROWS * k, lam, forces + DEP_FORCE_ROWS * k);
    }
}

/* PeakTracker.observe: |F_h| and |T_h| at time t; NAN entries are skipped. */
void dep_loads_observe(dep_loads *loads, double t, const double *forces, const double *torques)
{
    for (int k = 0; k < loads->nh; ++k) {
        const double *f = forces + DEP_FORCE_ROWS * k;
        double magnitude = hypot(hypot(f[0], f[1]), f[2]), size = fabs(torques[k]);
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

/* The hinges whose rows take part in a null direction of S at this state (the factor's,
   docs/method.md, 6a): their multipliers are the minimum-norm ones, not the only ones. A row
   takes part when its component is more than NULL_SHARE of the direction's largest. */
#define NULL_SHARE 1e-3

void dep_loads_mark_redundant(dep_loads *loads, const dep_constraints *cs,
                              dep_multipliers *mp)
{
    if (mp->schur_factored && mp->schur_dropped > 0) { /* rows dropped: their directions */
        dep_schur_nulls(mp, cs->nc);
    }
    if (mp->n_nulls == 0 || mp->nulls_id != mp->schur_id) {
        return;
    }
    for (int k = 0; k < mp->n_nulls; ++k) {
        const double *n = mp->nulls + (size_t)k * (size_t)cs->nc;
        double largest = dep_max_abs(n, cs->nc);
        for (int i = 0; i < cs->nc; ++i) {
            int hinge = i < cs->nc_module ? loads->model->constraint_hinges[i]
                                          : cs->row_hinges[i];
            if (hinge >= 0 && fabs(n[i]) > NULL_SHARE * largest) {
                loads->redundant[hinge] = 1;
            }
        }
    }
}
