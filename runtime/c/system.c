/* system.c: a run's memory, its errors (Python's SolverError text), the settings checks of
 * resolve_settings, and the model bound to one parameter vector with its constant mass
 * matrix, factorised once (inverted if diagonal, Cholesky otherwise). Port of system.py and
 * errors.py.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "runtime.h"

#define TOL_FLOOR (100 * DEP_EPS) /* below: double precision cannot resolve the errors */

/* ---- memory ------------------------------------------------------------------------------ */

void *dep_bytes(dep_arena *arena, size_t n)
{
    if (arena->count == arena->capacity) {
        int capacity = arena->capacity ? 2 * arena->capacity : 64;
        void **blocks = realloc(arena->blocks, (size_t)capacity * sizeof *blocks);
        if (blocks == NULL) {
            arena->failed = 1;
            return NULL;
        }
        arena->blocks = blocks;
        arena->capacity = capacity;
    }
    void *block = calloc(n ? n : 1, 1);
    if (block == NULL) {
        arena->failed = 1;
        return NULL;
    }
    arena->blocks[arena->count++] = block;
    return block;
}

double *dep_doubles(dep_arena *arena, size_t n)
{
    return dep_bytes(arena, n * sizeof(double));
}

void dep_arena_free(dep_arena *arena)
{
    for (int i = 0; i < arena->count; ++i) {
        free(arena->blocks[i]);
    }
    free(arena->blocks);
    arena->blocks = NULL;
    arena->count = arena->capacity = 0;
}

/* ---- errors ------------------------------------------------------------------------------ */

/* Copy `from` into `to` (size bytes), cut short if needed, always terminated. */
void dep_copy_text(char *to, size_t size, const char *from)
{
    size_t i = 0;
    for (; from != NULL && from[i] != '\0' && i + 1 < size; ++i) {
        to[i] = from[i];
    }
    to[i] = '\0';
}

void dep_error_clear(dep_error *error)
{
    memset(error, 0, sizeof *error);
}

static int is_pass(const char *stage)
{
    return strcmp(stage, "position") == 0 || strcmp(stage, "velocity") == 0
           || strcmp(stage, "acceleration") == 0;
}

int dep_solver_error(dep_error *error, int has_t, double t, const char *stage, const char *row,
                     const char *joint, int has_residual, double residual, const char *what,
                     const char *hint)
{
    char head[600] = "";
    size_t used = 0;
    dep_error_clear(error);
    error->code = DEP_SOLVER_ERROR;
    error->has_t = has_t;
    error->t = t;
    error->has_residual = has_residual;
    error->residual = residual;
    dep_copy_text(error->stage, sizeof error->stage, stage);
    dep_copy_text(error->row, sizeof error->row, row);
    dep_copy_text(error->joint, sizeof error->joint, joint);
    dep_copy_text(error->what, sizeof error->what, what);
    dep_copy_text(error->hint, sizeof error->hint, hint);
    /* SolverError._format: "t = .. s, <stage> pass, <joint> (row <row>): what\n  hint: .." */
    if (has_t) {
        used += (size_t)snprintf(head + used, sizeof head - used, "t = %.9g s", t);
    }
    if (stage != NULL && used < sizeof head) {
        used += (size_t)snprintf(head + used, sizeof head - used, "%s%s%s", used ? ", " : "",
                                 stage, is_pass(stage) ? " pass" : "");
    }
    if (joint != NULL && used < sizeof head) {
        used += (size_t)snprintf(head + used, sizeof head - used, "%s%s", used ? ", " : "", joint);
        if (row != NULL && row[0] != '\0' && used < sizeof head) {
            snprintf(head + used, sizeof head - used, " (row %s)", row);
        }
    }
    if (head[0] != '\0') {
        snprintf(error->message, sizeof error->message, "%s: %s", head, error->what);
    } else {
        dep_copy_text(error->message, sizeof error->message, error->what);
    }
    if (hint != NULL && hint[0] != '\0') {
        used = strlen(error->message);
        snprintf(error->message + used, sizeof error->message - used, "\n  hint: %s", hint);
    }
    return DEP_SOLVER_ERROR;
}

int dep_plain_error(dep_error *error, int code, const char *message)
{
    dep_error_clear(error);
    error->code = code;
    dep_copy_text(error->what, sizeof error->what, message);
    dep_copy_text(error->message, sizeof error->message, message);
    return code;
}

void dep_repr(double value, char *out, size_t size)
{
    char digits[40];
    int precision = 1;
    if (isnan(value) || isinf(value)) {
        snprintf(out, size, "%s", isnan(value) ? "nan" : value > 0 ? "inf" : "-inf");
        return;
    }
    /* the shortest digits that read back exactly, placed as Python's repr places them */
    for (; precision < 17; ++precision) {
        snprintf(digits, sizeof digits, "%.*e", precision - 1, value);
        if (strtod(digits, NULL) == value) {
            break;
        }
    }
    snprintf(digits, sizeof digits, "%.*e", precision - 1, value);
    int exponent = atoi(strchr(digits, 'e') + 1);
    if (exponent < -4 || exponent >= 16) {
        char mantissa[40];
        snprintf(mantissa, sizeof mantissa, "%.*s", (int)(strchr(digits, 'e') - digits), digits);
        snprintf(out, size, "%se%c%02d", mantissa, exponent < 0 ? '-' : '+', abs(exponent));
    } else {
        int decimals = precision - 1 - exponent;
        snprintf(out, size, "%.*f", decimals > 0 ? decimals : 1, value);
    }
}

/* resolve_settings: ValueError for a bad value, SolverError for tol below round-off. */
int dep_check_settings(const dep_model *model, const double *p, const dep_settings *settings,
                       dep_error *error)
{
    char message[1200], number[40];
    const char *checks[3] = {"t_end must be a positive number of seconds, got %s",
                             "dt_out must be a positive number of seconds, got %s",
                             "tol must lie between 0 and 1, got %s"};
    double values[3] = {settings->t_end, settings->dt_out, settings->tol};
    size_t used = (size_t)snprintf(message, sizeof message, "parameters are not finite: ");
    int bad = 0;
    for (int i = 0; i < model->np; ++i) {
        if (!isfinite(p[i]) && used < sizeof message) {
            used += (size_t)snprintf(message + used, sizeof message - used, "%s%s",
                                     bad++ ? ", " : "", model->parameter_names[i]);
        }
    }
    if (bad) {
        return dep_plain_error(error, DEP_SETTINGS_ERROR, message);
    }
    for (int i = 0; i < 3; ++i) {
        int ok = isfinite(values[i]) && values[i] > 0 && (i < 2 || values[i] < 1);
        if (!ok) {
            dep_repr(values[i], number, sizeof number);
            snprintf(message, sizeof message, checks[i], number);
            return dep_plain_error(error, DEP_SETTINGS_ERROR, message);
        }
    }
    if (settings->tol < TOL_FLOOR) {
        char what[120], hint[60];
        snprintf(what, sizeof what, "tol = %.3g is tighter than double-precision round-off",
                 settings->tol);
        snprintf(hint, sizeof hint, "use tol >= %.1e", TOL_FLOOR);
        return dep_solver_error(error, 0, 0.0, "settings", NULL, NULL, 0, 0.0, what, hint);
    }
    return DEP_OK;
}

/* ---- the mass matrix --------------------------------------------------------------------- */

static int factor_mass(dep_mass *mass, const char *const *coordinates, dep_arena *arena,
                       dep_error *error)
{
    int n = mass->n;
    const double *M = mass->matrix;
    mass->diagonal = 1;
    for (int i = 0; i < n * n; ++i) {
        if (i / n != i % n && M[i] != 0.0) {
            mass->diagonal = 0;
        }
    }
    if (mass->diagonal) {
        int k = 0, nonpositive = 0;
        for (int i = 0; i < n; ++i) {
            nonpositive |= M[i * n + i] <= 0;
            k = M[i * n + i] < M[k * n + k] ? i : k;
        }
        if (nonpositive) {
            char what[DEP_NAME_MAX + 120];
            snprintf(what, sizeof what, "mass matrix entry of coordinate '%s' is %.3g; every "
                     "body needs positive mass and inertia", coordinates[k], M[k * n + k]);
            return dep_solver_error(error, 0, 0.0, "setup", NULL, NULL, 0, 0.0, what,
                                    "check the body's mass and inertia");
        }
        mass->inverse_diagonal = dep_doubles(arena, (size_t)n);
        if (mass->inverse_diagonal == NULL) {
            return dep_plain_error(error, DEP_MEMORY_ERROR, "out of memory");
        }
        for (int i = 0; i < n; ++i) {
            mass->inverse_diagonal[i] = 1.0 / M[i * n + i];
        }
        return DEP_OK;
    }
    double *L = mass->cholesky = dep_doubles(arena, (size_t)n * (size_t)n);
    if (L == NULL) {
        return dep_plain_error(error, DEP_MEMORY_ERROR, "out of memory");
    }
    for (int j = 0; j < n; ++j) { /* M = L L^T */
        for (int i = j; i < n; ++i) {
            double sum = M[i * n + j];
            for (int k = 0; k < j; ++k) {
                sum -= L[i * n + k] * L[j * n + k];
            }
            if (i == j && !(sum > 0)) {
                return dep_solver_error(error, 0, 0.0, "setup", NULL, NULL, 0, 0.0,
                                        "mass matrix is not positive definite",
                                        "check masses, inertias and beam properties");
            }
            L[i * n + j] = i == j ? sqrt(sum) : sum / L[j * n + j];
        }
    }
    return DEP_OK;
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
    const double *L = mass->cholesky;
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

int dep_system_init(dep_system *system, const dep_model *model, const double *p,
                    dep_arena *arena, dep_error *error)
{
    memset(system, 0, sizeof *system);
    system->model = model;
    system->p = p;
    system->nq = model->nq;
    system->nd = model->nd;
    system->nh = model->nh;
    system->ne = model->ne;
    system->dissipator_names = (const char **)model->dissipator_names;
    system->energy_names = (const char **)model->energy_names;
    system->mass.n = model->nq;
    system->mass.matrix = dep_doubles(arena, (size_t)model->nq * (size_t)model->nq);
    if (arena->failed) {
        return dep_plain_error(error, DEP_MEMORY_ERROR, "out of memory");
    }
    model->mass_matrix(p, system->mass.matrix);
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

/* ---- the forces, powers and energies of a run (MechanismSystem) --------------------------- */

/* f (nq): the model's force plus, while the mechanism has runtime torques, J_h^T tau. */
void dep_system_force(const dep_system *system, const double *q, const double *qd, double t,
                      double *f)
{
    const dep_model *model = system->model;
    dep_mechanism *m = system->mechanism;
    model->force(q, qd, t, system->p, f);
    if (m == NULL || !dep_mechanism_forcing(m)) {
        return;
    }
    dep_mechanism_torques(m, q, qd, m->tau);
    model->hinge_jacobian(q, system->p, m->hinge_jacobian);
    for (int j = 0; j < system->nq; ++j) {
        double sum = 0.0;
        for (int k = 0; k < model->nh; ++k) {
            sum += m->hinge_jacobian[k * system->nq + j] * m->tau[k];
        }
        f[j] += sum;
    }
}

/* The power removed by each dissipator (nd), W. */
void dep_system_dissipation(const dep_system *system, const double *q, const double *qd,
                            double t, double *power)
{
    if (system->model->nd > 0) {
        system->model->dissipation(q, qd, t, system->p, power);
    }
    if (system->mechanism != NULL) {
        dep_mechanism_dissipation(system->mechanism, q, qd, power);
    }
}

/* Kinetic energy and each potential (ne), J. */
void dep_system_energy(const dep_system *system, const double *q, const double *qd, double t,
                       double *energy)
{
    system->model->energy(q, qd, t, system->p, energy);
    if (system->mechanism != NULL) {
        dep_mechanism_energy(system->mechanism, q, qd, energy);
    }
}
