/* hinges.c: each hinge's properties as the model gives them (hinge_properties, one row per
 * hinge), its mode, and what kind of joint a name is (system.h).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "system.h"

/* The hinge properties the integrator applies, by name (columns of hinge_properties). */
static const char *const PROPERTIES[8] = {"latch", "latch_stiffness", "latch_damping",
                                          "stop_min", "stop_max", "friction",
                                          "static_friction", "slip_rate"};

/* A hinge's properties from its row of hinge_properties (NAN: not given), free. */
static void read_hinge(dep_hinge_mechanics *h, const double *v, int mechanics)
{
    h->has_latch = mechanics && !isnan(v[0]);
    h->latch = v[0];
    h->compliant = h->has_latch && !isnan(v[1]);
    h->latch_stiffness = v[1];
    h->latch_damping = isnan(v[2]) ? 0.0 : v[2];
    h->has_stop_min = mechanics && !isnan(v[3]);
    h->stop_min = v[3];
    h->has_stop_max = mechanics && !isnan(v[4]);
    h->stop_max = v[4];
    h->has_friction = !isnan(v[5]);
    h->kinetic = isnan(v[5]) ? 0.0 : v[5];
    h->has_static = mechanics && !isnan(v[6]);
    h->static_friction = v[6];
    h->slip_rate = v[7];
    h->latch_side = 1.0;
    h->direction = 1.0;
    h->latch_state = DEP_OPEN;
    h->stop = DEP_STOP_NONE;
    h->stuck = 0;
}

/* Every hinge's properties; a SETTINGS error for a friction law without a positive
   slip rate. */
int dep_hinges_read(dep_system *system, int mechanics, dep_arena *arena, dep_error *error)
{
    const dep_model *model = system->model;
    int nh = model->nh, nhp = model->nhp, column[8];
    double *table = dep_doubles(arena, (size_t)nh * (size_t)nhp), v[8];
    system->hinges = dep_bytes(arena, (size_t)(nh ? nh : 1) * sizeof *system->hinges);
    if (arena->failed) {
        return dep_plain_error(error, DEP_MEMORY_ERROR, "out of memory");
    }
    for (int k = 0; k < 8; ++k) {
        column[k] = -1;
        for (int c = 0; c < nhp; ++c) {
            column[k] = strcmp(model->hinge_property_names[c], PROPERTIES[k]) == 0 ? c : column[k];
        }
    }
    if (nh > 0 && nhp > 0) {
        model->hinge_properties(system->p, table);
    }
    for (int i = 0; i < nh; ++i) {
        dep_hinge_mechanics *h = &system->hinges[i];
        for (int k = 0; k < 8; ++k) {
            v[k] = column[k] >= 0 ? table[(size_t)i * (size_t)nhp + (size_t)column[k]] : NAN;
        }
        read_hinge(h, v, mechanics);
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
    return h->latch_state == DEP_LATCHED || h->stop != DEP_STOP_NONE;
}

int dep_hinge_sliding(const dep_hinge_mechanics *h)
{
    return h->has_static && !dep_hinge_locked(h) && !h->stuck;
}

const char *dep_joint_kind(const dep_model *model, const char *joint)
{
    for (int i = 0; i < model->nh; ++i) {
        if (strcmp(model->hinge_names[i], joint) == 0) {
            return "hinge";
        }
    }
    for (int i = 0; i < model->ns; ++i) {
        if (strcmp(model->slider_names[i], joint) == 0) {
            return "slider";
        }
    }
    return "joint";
}
