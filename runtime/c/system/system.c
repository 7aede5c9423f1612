/* system.c: the model bound to one parameter vector for a run: its mass matrix (mass.c), its
 * hinges (hinges.c), the names of its energies and dissipators, and the forces, powers and
 * energies the method sees: the generated model's plus the hinge torques of laws.c (system.h).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "system.h"

/* The dissipator and energy names: the model's, then "friction.<h>", then "latch.<h>". */
static int name_terms(dep_system *s, dep_arena *arena)
{
    const dep_model *model = s->model;
    int d = 0, e = 0;
    s->nd = model->nd + s->n_friction + s->n_compliant;
    s->ne = model->ne + s->n_compliant;
    s->dissipator_names = dep_bytes(arena, (size_t)(s->nd ? s->nd : 1) * sizeof(char *));
    s->energy_names = dep_bytes(arena, (size_t)(s->ne ? s->ne : 1) * sizeof(char *));
    if (arena->failed) {
        return DEP_MEMORY_ERROR;
    }
    for (; d < model->nd; ++d) {
        s->dissipator_names[d] = model->dissipator_names[d];
    }
    for (; e < model->ne; ++e) {
        s->energy_names[e] = model->energy_names[e];
    }
    for (int pass = 0; pass < 2; ++pass) { /* friction first, then compliant latches */
        for (int i = 0; i < s->nh; ++i) {
            const dep_hinge_mechanics *h = &s->hinges[i];
            if (pass == 0 ? !h->has_friction : !h->compliant) {
                continue;
            }
            char *name = dep_bytes(arena, strlen(h->name) + 10);
            if (name == NULL) {
                return DEP_MEMORY_ERROR;
            }
            sprintf(name, "%s.%s", pass == 0 ? "friction" : "latch", h->name);
            s->dissipator_names[d++] = name;
            if (pass == 1) {
                s->energy_names[e++] = name;
            }
        }
    }
    return DEP_OK;
}

/* Each coordinate's size (the model's coordinate_scales) and the energy of moving every
   coordinate by its size in a second, sum_j M_jj s_j^2, at most 1 J: the sizes the errors of
   a position, a rate, an acceleration and a work are measured against (docs/method.md, 6a).
   The cap keeps a heavy bus's sum (1,700 J for a 500 kg bus of 1.2 m) from loosening the
   dissipated energies' accuracy of a slow deployment whose kinetic energy is 0.03 J; a
   small mechanism's sum stays its own, so millimetres and metres are held alike. */
#define ENERGY_CAP 1.0 /* J */

static int scales(dep_system *system, dep_error *error)
{
    const dep_model *model = system->model;
    model->coordinate_scales(system->p, system->scales);
    system->energy_scale = 0.0;
    for (int j = 0; j < model->nq; ++j) {
        double s = system->scales[j];
        if (!(s > 0.0 && isfinite(s))) {
            char message[DEP_NAME_MAX + 120];
            snprintf(message, sizeof message, "the size of coordinate '%s' is %g: the model's "
                     "members need positive, finite lengths", model->coordinate_names[j], s);
            return dep_plain_error(error, DEP_SETTINGS_ERROR, message);
        }
        system->energy_scale += system->mass.entry_diagonal[j] * s * s;
    }
    system->energy_scale = fmin(system->energy_scale, ENERGY_CAP);
    return DEP_OK;
}

int dep_system_init(dep_system *system, const dep_model *model, const double *p,
                    int mechanics, dep_arena *arena, dep_error *error)
{
    int nh = model->nh, status;
    memset(system, 0, sizeof *system);
    system->model = model;
    system->p = p;
    system->nq = model->nq;
    system->nh = nh;
    system->mass.n = model->nq;
    system->mass.nnz = model->nmz;
    system->mass.rows = model->mass_rows;
    system->mass.cols = model->mass_cols;
    system->mass.values = dep_doubles(arena, (size_t)model->nmz + 1);
    system->mass.entry_diagonal = dep_doubles(arena, (size_t)model->nq + 1);
    system->angles = dep_doubles(arena, (size_t)nh);
    system->rates = dep_doubles(arena, (size_t)nh);
    system->tau = dep_doubles(arena, (size_t)nh);
    system->friction = dep_doubles(arena, (size_t)nh);
    system->hinge_jacobian = dep_doubles(arena, (size_t)model->nhnz + 1);
    system->torque_force = dep_doubles(arena, (size_t)model->nq + 1);
    system->scales = dep_doubles(arena, (size_t)model->nq + 1);
    system->hinge_start = dep_bytes(arena, ((size_t)nh + 1) * sizeof *system->hinge_start);
    if (arena->failed) {
        return dep_plain_error(error, DEP_MEMORY_ERROR, "out of memory");
    }
    for (int h = 0, n = 0; h <= nh; ++h) { /* HINGE_JACOBIAN_ROWS is sorted row-major */
        system->hinge_start[h] = n;
        while (h < nh && n < model->nhnz && model->hinge_jacobian_rows[n] == h) {
            ++n;
        }
    }
    if ((status = dep_hinges_read(system, mechanics, arena, error)) != DEP_OK) {
        return status;
    }
    if (name_terms(system, arena) != DEP_OK) {
        return dep_plain_error(error, DEP_MEMORY_ERROR, "out of memory");
    }
    model->mass_matrix(p, system->mass.values);
    if ((status = dep_mass_factor(&system->mass, model->coordinate_names, arena, error))
        != DEP_OK) {
        return status;
    }
    return scales(system, error);
}

/* ---- the forces, powers and energies of a run -------------------------------------------- */

/* out (nq) = J_h^T tau, J_h the hinge Jacobian's non-zeros (model->hinge_jacobian). */
void dep_hinge_transpose_times(const dep_system *system, const double *J_h, const double *tau,
                               double *out)
{
    const dep_model *model = system->model;
    memset(out, 0, (size_t)system->nq * sizeof *out);
    for (int k = 0; k < model->nhnz; ++k) {
        out[model->hinge_jacobian_cols[k]] += J_h[k] * tau[model->hinge_jacobian_rows[k]];
    }
}

/* out (nh) = J_h x: the hinge rates for x = qd. */
void dep_hinge_times(const dep_system *system, const double *J_h, const double *x, double *out)
{
    const int *cols = system->model->hinge_jacobian_cols;
    for (int h = 0; h < system->nh; ++h) {
        double sum = 0.0;
        for (int k = system->hinge_start[h]; k < system->hinge_start[h + 1]; ++k) {
            sum += J_h[k] * x[cols[k]];
        }
        out[h] = sum;
    }
}

/* f (nq): the model's force plus J_h^T tau of the hinge torques (laws.c), the friction
   torques given (nh) or, with NULL, by the law; the rates by J_h, which the torques need
   anyway (a spatial hinge's rate function costs about as much as its Jacobian). */
static void force(const dep_system *system, const double *q, const double *qd, double t,
                  const double *friction, double *f)
{
    const dep_model *model = system->model;
    model->force(q, qd, t, system->p, f);
    if (!dep_hinge_forcing(system)) {
        return;
    }
    model->hinge_jacobian(q, system->p, system->hinge_jacobian);
    dep_hinge_times(system, system->hinge_jacobian, qd, system->rates);
    dep_hinge_torques(system, q, system->rates, friction, system->tau);
    dep_hinge_transpose_times(system, system->hinge_jacobian, system->tau,
                              system->torque_force);
    for (int j = 0; j < system->nq; ++j) {
        f[j] += system->torque_force[j];
    }
}

void dep_system_force(const dep_system *system, const double *q, const double *qd, double t,
                      double *f)
{
    force(system, q, qd, t, NULL, f);
}

/* The power removed by each dissipator (nd), W. */
void dep_system_dissipation(const dep_system *system, const double *q, const double *qd,
                            double t, double *power)
{
    if (system->model->nd > 0) {
        system->model->dissipation(q, qd, t, system->p, power);
    }
    dep_hinge_dissipation(system, q, qd, power);
}

void dep_system_force_power(const dep_system *system, const double *q, const double *qd,
                            double t, const double *friction, double *f, double *power)
{
    force(system, q, qd, t, friction, f);
    if (system->model->nd > 0) {
        system->model->dissipation(q, qd, t, system->p, power);
    }
    if (dep_hinge_forcing(system)) { /* dep_system_force left the rates and torques */
        dep_hinge_power(system, q, power);
    } else {
        dep_hinge_dissipation(system, q, qd, power);
    }
}

/* Kinetic energy and each potential (ne), J. */
void dep_system_energy(const dep_system *system, const double *q, const double *qd, double t,
                       double *energy)
{
    system->model->energy(q, qd, t, system->p, energy);
    dep_hinge_energy(system, q, energy);
}
