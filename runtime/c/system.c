/* system.c: the model bound to one parameter vector: its constant mass matrix, factorised
 * once (inverted if diagonal, else its envelope Cholesky factor; dep_envelope), its hinges'
 * properties (read from hinge_properties by name) and the forces, powers and energies of a run (the model's plus
 * the hinge torques of mechanism.c).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "runtime.h"

/* ---- the mass matrix --------------------------------------------------------------------- */

static int factor_mass(dep_mass *mass, const char *const *coordinates, dep_arena *arena,
                       dep_error *error)
{
    int n = mass->n;
    mass->diagonal = 1;
    for (int k = 0; k < mass->nnz; ++k) {
        if (mass->rows[k] == mass->cols[k]) {
            mass->entry_diagonal[mass->rows[k]] = mass->values[k];
        } else if (mass->values[k] != 0.0) {
            mass->diagonal = 0;
        }
    }
    if (mass->diagonal) {
        const double *M = mass->entry_diagonal;
        int k = 0, nonpositive = 0;
        for (int i = 0; i < n; ++i) {
            nonpositive |= M[i] <= 0;
            k = M[i] < M[k] ? i : k;
        }
        if (nonpositive) {
            char what[DEP_NAME_MAX + 120];
            snprintf(what, sizeof what, "mass matrix entry of coordinate '%s' is %.3g; every "
                     "body needs positive mass and inertia", coordinates[k], M[k]);
            return dep_solver_error(error, 0, 0.0, "setup", NULL, NULL, 0, 0.0, what,
                                    "check the body's mass and inertia");
        }
        mass->inverse_diagonal = dep_doubles(arena, (size_t)n);
        if (mass->inverse_diagonal == NULL) {
            return dep_plain_error(error, DEP_MEMORY_ERROR, "out of memory");
        }
        for (int i = 0; i < n; ++i) {
            mass->inverse_diagonal[i] = 1.0 / M[i];
        }
        return DEP_OK;
    }
    int *first = dep_bytes(arena, (size_t)n * sizeof *first);
    if (first == NULL) {
        return dep_plain_error(error, DEP_MEMORY_ERROR, "out of memory");
    }
    dep_mass_envelope_start(mass, first); /* each row from its first non-zero (beams: a band) */
    dep_envelope *e = &mass->factor;
    if (dep_envelope_init(e, n, first, arena) != DEP_OK) {
        return dep_plain_error(error, DEP_MEMORY_ERROR, "out of memory");
    }
    dep_mass_to_envelope(mass, e, e->A);
    if (!dep_envelope_factor(e)) {
        return dep_solver_error(error, 0, 0.0, "setup", NULL, NULL, 0, 0.0,
                                "mass matrix is not positive definite",
                                "check masses, inertias and beam properties");
    }
    return DEP_OK;
}

void dep_mass_envelope_start(const dep_mass *mass, int *first)
{
    for (int i = 0; i < mass->n; ++i) {
        first[i] = i;
    }
    for (int k = 0; k < mass->nnz; ++k) {
        int i = mass->rows[k], j = mass->cols[k], low = i < j ? i : j, high = i < j ? j : i;
        if (mass->values[k] != 0.0 && low < first[high]) {
            first[high] = low;
        }
    }
}

void dep_mass_to_envelope(const dep_mass *mass, const dep_envelope *e, double *A)
{
    for (int k = 0; k < mass->nnz; ++k) {
        int i = mass->rows[k], j = mass->cols[k];
        if (j <= i && j >= e->first[i]) {
            DEP_ENVELOPE_AT(e, A, i, j) = mass->values[k];
        }
    }
}

double dep_mass_quadratic(const dep_mass *mass, const double *x)
{
    double sum = 0.0;
    for (int k = 0; k < mass->nnz; ++k) {
        sum += x[mass->rows[k]] * mass->values[k] * x[mass->cols[k]];
    }
    return sum;
}

void dep_mass_solve(const dep_mass *mass, const double *b, double *x)
{
    int n = mass->n;
    if (mass->diagonal) {
        for (int i = 0; i < n; ++i) {
            x[i] = mass->inverse_diagonal[i] * b[i];
        }
        return;
    }
    dep_envelope_solve(&mass->factor, b, x);
}

void dep_cholesky_solve(const double *L, int n, const double *b, double *x)
{
    for (int i = 0; i < n; ++i) { /* L y = b */
        double sum = b[i];
        for (int k = 0; k < i; ++k) {
            sum -= L[i * n + k] * x[k];
        }
        x[i] = sum / L[i * n + i];
    }
    for (int i = n - 1; i >= 0; --i) { /* L^T x = y */
        double sum = x[i];
        for (int k = i + 1; k < n; ++k) {
            sum -= L[k * n + i] * x[k];
        }
        x[i] = sum / L[i * n + i];
    }
}

/* ---- envelope matrices -------------------------------------------------------------------- */

int dep_envelope_init(dep_envelope *e, int n, const int *first, dep_arena *arena)
{
    e->n = n;
    e->first = dep_bytes(arena, ((size_t)n + 1) * sizeof *e->first);
    e->offset = dep_bytes(arena, ((size_t)n + 1) * sizeof *e->offset);
    if (e->first == NULL || e->offset == NULL) {
        return DEP_MEMORY_ERROR;
    }
    e->offset[0] = 0;
    for (int i = 0; i < n; ++i) {
        e->first[i] = first[i];
        e->offset[i + 1] = e->offset[i] + i - first[i] + 1;
    }
    e->A = dep_doubles(arena, (size_t)e->offset[n] + 1);
    e->L = dep_doubles(arena, (size_t)e->offset[n] + 1);
    e->inverse = dep_doubles(arena, (size_t)n + 1);
    return arena->failed ? DEP_MEMORY_ERROR : DEP_OK;
}

int dep_envelope_factor(dep_envelope *e)
{
    double largest = 0.0;
    for (int i = 0; i < e->n; ++i) {
        largest = fmax(largest, DEP_ENVELOPE_AT(e, e->A, i, i));
    }
    for (int i = 0; i < e->n; ++i) {
        for (int j = e->first[i]; j <= i; ++j) {
            int from = e->first[i] > e->first[j] ? e->first[i] : e->first[j];
            double sum = DEP_ENVELOPE_AT(e, e->A, i, j);
            const double *Li = &DEP_ENVELOPE_AT(e, e->L, i, from);
            const double *Lj = &DEP_ENVELOPE_AT(e, e->L, j, from);
            for (int k = 0; k < j - from; ++k) {
                sum -= Li[k] * Lj[k];
            }
            if (j < i) { /* (times the pivot's inverse: no division's latency on the row) */
                DEP_ENVELOPE_AT(e, e->L, i, j) = sum * e->inverse[j];
            } else if (!(sum > 1e-12 * largest)) {
                return 0;
            } else {
                DEP_ENVELOPE_AT(e, e->L, i, i) = sqrt(sum);
                e->inverse[i] = 1.0 / DEP_ENVELOPE_AT(e, e->L, i, i);
            }
        }
    }
    return 1;
}

/* One right side: L y = b by rows (a dot product each), L^T x = y by columns. Each row waits
   on the one before, so that value is carried in a register (`last`, `next`) rather than
   stored and loaded back at once: a forwarded load's latency on every row of the chain. b is
   read as the rows go, not copied into x first: a copy's wide stores, read back at once a
   number at a time, cannot be forwarded to the loads at all (the solve of INTELSAT V's 8
   rows took twice as long). The operations and their order are those of the plain loops. */
void dep_envelope_solve(const dep_envelope *e, const double *b, double *x)
{
    int n = e->n;
    double last = 0.0; /* x[i - 1] */
    for (int i = 0; i < n; ++i) {
        const double *row = &DEP_ENVELOPE_AT(e, e->L, i, 0);
        double sum = b[i];
        int k = e->first[i];
        for (; k < i - 1; ++k) {
            sum -= row[k] * x[k];
        }
        if (k == i - 1) {
            sum -= row[k] * last;
        }
        x[i] = last = sum * e->inverse[i];
    }
    double next = n > 0 ? x[n - 1] : 0.0; /* x[i] with the updates of the rows below it */
    for (int i = n - 1; i >= 0; --i) {
        const double *row = &DEP_ENVELOPE_AT(e, e->L, i, 0);
        double xi = next * e->inverse[i];
        x[i] = xi;
        int k = e->first[i];
        for (; k < i - 1; ++k) {
            x[k] -= row[k] * xi;
        }
        if (i > 0) {
            next = k == i - 1 ? x[i - 1] - row[i - 1] * xi : x[i - 1];
        }
    }
}

/* The rows of the same in the same order of operations, SOLVE_CHUNK sides at a time in a local
   accumulator (a store through x could alias any row of x, which keeps the compiler from
   holding the sums in registers). */
#define SOLVE_CHUNK 8

void dep_envelope_solve_block(const dep_envelope *e, int count, const double *b, double *x)
{
    if (count == 1) {
        dep_envelope_solve(e, b, x);
        return;
    }
    if (x != b) {
        memcpy(x, b, (size_t)e->n * (size_t)count * sizeof *x);
    }
    for (int i = 0; i < e->n; ++i) { /* L y = b */
        const double *row = &DEP_ENVELOPE_AT(e, e->L, i, 0);
        double *xi = x + (size_t)i * count;
        for (int v0 = 0; v0 < count; v0 += SOLVE_CHUNK) {
            int width = count - v0 < SOLVE_CHUNK ? count - v0 : SOLVE_CHUNK;
            double sum[SOLVE_CHUNK];
            for (int v = 0; v < width; ++v) {
                sum[v] = xi[v0 + v];
            }
            for (int k = e->first[i]; k < i; ++k) {
                const double l = row[k], *xk = x + (size_t)k * count + v0;
                for (int v = 0; v < width; ++v) {
                    sum[v] -= l * xk[v];
                }
            }
            for (int v = 0; v < width; ++v) {
                xi[v0 + v] = sum[v] * e->inverse[i];
            }
        }
    }
    for (int i = e->n - 1; i >= 0; --i) { /* L^T x = y, column by column */
        const double *row = &DEP_ENVELOPE_AT(e, e->L, i, 0);
        double *xi = x + (size_t)i * count;
        for (int v0 = 0; v0 < count; v0 += SOLVE_CHUNK) {
            int width = count - v0 < SOLVE_CHUNK ? count - v0 : SOLVE_CHUNK;
            double value[SOLVE_CHUNK];
            for (int v = 0; v < width; ++v) {
                value[v] = xi[v0 + v] * e->inverse[i];
                xi[v0 + v] = value[v];
            }
            for (int k = e->first[i]; k < i; ++k) {
                const double l = row[k];
                double *xk = x + (size_t)k * count + v0;
                for (int v = 0; v < width; ++v) {
                    xk[v] -= l * value[v];
                }
            }
        }
    }
}

void dep_envelope_times(const dep_envelope *e, const double *values, const double *x,
                        double *out)
{
    memset(out, 0, (size_t)e->n * sizeof *out);
    for (int i = 0; i < e->n; ++i) {
        for (int j = e->first[i]; j < i; ++j) {
            double a = DEP_ENVELOPE_AT(e, values, i, j);
            out[i] += a * x[j];
            out[j] += a * x[i];
        }
        out[i] += DEP_ENVELOPE_AT(e, values, i, i) * x[i];
    }
}

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
static int read_hinges(dep_system *system, int mechanics, dep_arena *arena, dep_error *error)
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
    if (arena->failed) {
        return dep_plain_error(error, DEP_MEMORY_ERROR, "out of memory");
    }
    if ((status = read_hinges(system, mechanics, arena, error)) != DEP_OK) {
        return status;
    }
    if (name_terms(system, arena) != DEP_OK) {
        return dep_plain_error(error, DEP_MEMORY_ERROR, "out of memory");
    }
    model->mass_matrix(p, system->mass.values);
    return factor_mass(&system->mass, model->coordinate_names, arena, error);
}

const char *dep_joint_kind(const dep_system *system, const char *joint)
{
    const dep_model *model = system->model;
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

/* f (nq): the model's force plus J_h^T tau of the hinge torques (mechanism.c), the friction
   torques given (nh) or, with NULL, by the law. */
static void force(const dep_system *system, const double *q, const double *qd, double t,
                  const double *friction, double *f)
{
    const dep_model *model = system->model;
    model->force(q, qd, t, system->p, f);
    if (!dep_hinge_forcing(system)) {
        return;
    }
    dep_hinge_torques(system, q, qd, friction, system->tau);
    model->hinge_jacobian(q, system->p, system->hinge_jacobian);
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
