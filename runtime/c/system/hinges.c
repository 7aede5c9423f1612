/* hinges.c: each hinge's properties as the model gives them (hinge_properties, one row per
 * hinge), its mode, and what kind of joint a name is (system.h).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "system.h"

/* A hinge's properties from its row of hinge_properties (NAN: not given), free. */
static void read_hinge(dep_hinge_mechanics *h, const double *v, int mechanics)
{
    h->has_latch = mechanics && !isnan(v[DEP_HINGE_LATCH]);
    h->latch = v[DEP_HINGE_LATCH];
    h->compliant = h->has_latch && !isnan(v[DEP_HINGE_LATCH_STIFFNESS]);
    h->latch_stiffness = v[DEP_HINGE_LATCH_STIFFNESS];
    h->latch_damping = isnan(v[DEP_HINGE_LATCH_DAMPING]) ? 0.0 : v[DEP_HINGE_LATCH_DAMPING];
    h->has_stop_min = mechanics && !isnan(v[DEP_HINGE_STOP_MIN]);
    h->stop_min = v[DEP_HINGE_STOP_MIN];
    h->has_stop_max = mechanics && !isnan(v[DEP_HINGE_STOP_MAX]);
    h->stop_max = v[DEP_HINGE_STOP_MAX];
    h->has_friction = !isnan(v[DEP_HINGE_FRICTION]);
    h->kinetic = isnan(v[DEP_HINGE_FRICTION]) ? 0.0 : v[DEP_HINGE_FRICTION];
    h->has_static = mechanics && !isnan(v[DEP_HINGE_STATIC_FRICTION]);
    h->static_friction = v[DEP_HINGE_STATIC_FRICTION];
    h->slip_rate = v[DEP_HINGE_SLIP_RATE];
    h->has_hold = mechanics && v[DEP_HINGE_RELEASE] > 0; /* (released at t = 0: never held) */
    h->release = v[DEP_HINGE_RELEASE];
    h->held = 0; /* engaged when the run starts */
    h->latch_side = 1.0;
    h->direction = 1.0;
    h->latch_state = DEP_OPEN;
    h->stop = DEP_STOP_NONE;
    h->stuck = 0;
}

/* The model's hinge properties are the columns the core reads (depsim_model.h), in order: a
   model made for another table is refused, never read as "not given" (a model without hinges
   has none to read). */
static int check_columns(const dep_model *model, dep_error *error)
{
    static const char *const names[DEP_HINGE_PROPERTIES] = DEP_HINGE_PROPERTY_NAMES;
    char message[DEP_NAME_MAX + 200];
    int k = 0;
    if (model->nh == 0) {
        return DEP_OK;
    }
    while (k < DEP_HINGE_PROPERTIES && k < model->nhp
           && strcmp(model->hinge_property_names[k], names[k]) == 0) {
        ++k;
    }
    if (k == DEP_HINGE_PROPERTIES && model->nhp == DEP_HINGE_PROPERTIES) {
        return DEP_OK;
    }
    if (k < model->nhp && k < DEP_HINGE_PROPERTIES) {
        snprintf(message, sizeof message, "the model's hinge property %d is '%.*s' where the "
                 "integrator reads '%s'; generate the model again with this depsim", k,
                 DEP_NAME_MAX, model->hinge_property_names[k], names[k]);
    } else {
        snprintf(message, sizeof message, "the model has %d hinge properties, the integrator "
                 "reads %d; generate the model again with this depsim", model->nhp,
                 DEP_HINGE_PROPERTIES);
    }
    return dep_plain_error(error, DEP_SETTINGS_ERROR, message);
}

/* Every hinge's properties; a SETTINGS error for a friction law without a positive
   slip rate. */
int dep_hinges_read(dep_system *system, int mechanics, dep_arena *arena, dep_error *error)
{
    const dep_model *model = system->model;
    int nh = model->nh, status = check_columns(model, error);
    double *table = dep_doubles(arena, (size_t)nh * DEP_HINGE_PROPERTIES);
    system->hinges = dep_bytes(arena, (size_t)(nh ? nh : 1) * sizeof *system->hinges);
    if (status != DEP_OK) {
        return status;
    }
    if (arena->failed) {
        return dep_plain_error(error, DEP_MEMORY_ERROR, "out of memory");
    }
    if (nh > 0) {
        model->hinge_properties(system->p, table);
    }
    for (int i = 0; i < nh; ++i) {
        dep_hinge_mechanics *h = &system->hinges[i];
        read_hinge(h, table + (size_t)i * DEP_HINGE_PROPERTIES, mechanics);
        h->index = i;
        h->name = model->hinge_names[i];
        if (h->has_friction && !(h->slip_rate > 0)) {
            char message[DEP_NAME_MAX + 120];
            snprintf(message, sizeof message, "hinge %s: friction needs a positive slip_rate, "
                     "got %g rad/s", h->name, h->slip_rate);
            return dep_plain_error(error, DEP_SETTINGS_ERROR, message);
        }
        system->n_friction += h->has_friction;
        system->n_compliant += h->compliant;
    }
    return DEP_OK;
}

int dep_hinge_locked(const dep_hinge_mechanics *h)
{
    return h->latch_state == DEP_LATCHED || h->stop != DEP_STOP_NONE || h->held;
}

int dep_hinge_sliding(const dep_hinge_mechanics *h)
{
    return h->has_static && !dep_hinge_locked(h) && !h->stuck;
}

/* Each hinge's rows x, y (and z) among the model's constraint rows (constraint_hinges: a
   hinge's force rows in component order), -1 where a hinge has none. */
void dep_hinge_force_rows(const dep_model *model, int *rows)
{
    for (int k = 0; k < DEP_FORCE_ROWS * model->nh; ++k) {
        rows[k] = -1;
    }
    for (int i = 0; i < model->nc; ++i) {
        int k = model->constraint_hinges[i];
        int n = 0;
        while (k >= 0 && n < DEP_FORCE_ROWS && rows[DEP_FORCE_ROWS * k + n] >= 0) {
            ++n;
        }
        if (k >= 0 && n < DEP_FORCE_ROWS) {
            rows[DEP_FORCE_ROWS * k + n] = i;
        }
    }
}

void dep_hinge_force(const int *rows, const double *lam, double *force)
{
    int present = rows[0] >= 0 && rows[1] >= 0;
    force[0] = present ? lam[rows[0]] : NAN;
    force[1] = present ? lam[rows[1]] : NAN;
    force[2] = !present ? NAN : rows[2] >= 0 ? lam[rows[2]] : 0.0;
}

const char *dep_joint_kind(const dep_model *model, int row)
{
    return model->constraint_hinges[row] >= 0 ? "hinge"
           : model->constraint_sliders[row] >= 0 ? "slider" : "joint";
}

/* A slider with friction, a latch, a stop or a hold-down is an entry of the hinge tables,
   after the hinges and under its own name, which is in slider_names too (names are unique in
   a model): its angle is its displacement (m), its torque a force along its axis (N). */
int dep_hinge_slider(const dep_model *model, int k)
{
    for (int j = 0; j < model->ns; ++j) {
        if (strcmp(model->slider_names[j], model->hinge_names[k]) == 0) {
            return j;
        }
    }
    return -1;
}
