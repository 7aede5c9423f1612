/* mass.c: the model's constant mass matrix, factorised once per run: inverted if diagonal
 * (rigid bodies), else its envelope Cholesky factor (beams: a band) (system.h).
 */
#include <stdio.h>

#include "system.h"

int dep_mass_factor(dep_mass *mass, const char *const *coordinates, dep_arena *arena,
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
    if (!dep_envelope_factor(e, 0.0, NULL)) {
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
