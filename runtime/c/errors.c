/* errors.c: a run's memory (one arena, freed at once), its errors (the text of
 * depsim.runtime.SolverError, field by field) and the checks of its settings.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "runtime.h"

#define TOL_FLOOR (100 * DEP_EPS) /* below: double precision cannot resolve the errors */

/* ---- memory ------------------------------------------------------------------------------ */

static void *allocate(dep_arena *arena, size_t n, int zeroed)
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
    void *block = zeroed ? calloc(n ? n : 1, 1) : malloc(n ? n : 1);
    if (block == NULL) {
        arena->failed = 1;
        return NULL;
    }
    arena->blocks[arena->count++] = block;
    return block;
}

void *dep_bytes(dep_arena *arena, size_t n)
{
    return allocate(arena, n, 1);
}

void *dep_bytes_unset(dep_arena *arena, size_t n)
{
    return allocate(arena, n, 0);
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
/* A time table: its input exists, it has points, its times are finite and non-decreasing
   and its values finite. */
static int check_table(const dep_model *model, const dep_input_table *table, dep_error *error)
{
    char message[300];
    const char *name = table->input >= 0 && table->input < model->ni
                       ? model->input_names[table->input] : NULL;
    if (name == NULL) {
        snprintf(message, sizeof message, "input table for input %d: the model has %d inputs",
                 table->input, model->ni);
        return dep_plain_error(error, DEP_SETTINGS_ERROR, message);
    }
    if (table->n < 1 || table->t == NULL || table->u == NULL) {
        snprintf(message, sizeof message, "the time table of input %s has no points", name);
        return dep_plain_error(error, DEP_SETTINGS_ERROR, message);
    }
    for (int i = 0; i < table->n; ++i) {
        const char *fault = !isfinite(table->t[i]) ? "a time that is not finite"
                            : !isfinite(table->u[i]) ? "a value that is not finite"
                            : i > 0 && table->t[i] < table->t[i - 1] ? "a time before the one "
                              "above it (times must not decrease)" : NULL;
        if (fault != NULL) {
            snprintf(message, sizeof message, "the time table of input %s has %s at point %d "
                     "(t = %.9g s)", name, fault, i + 1, table->t[i]);
            return dep_plain_error(error, DEP_SETTINGS_ERROR, message);
        }
    }
    return DEP_OK;
}

int dep_check_settings(const dep_model *model, const double *p, const dep_settings *settings,
                       int open, dep_error *error)
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
        ok = ok || (open && i == 0 && values[i] == INFINITY) || (open && i == 1);
        if (!ok) {
            dep_repr(values[i], number, sizeof number);
            snprintf(message, sizeof message, checks[i], number);
            return dep_plain_error(error, DEP_SETTINGS_ERROR, message);
        }
    }
    if (!(settings->max_steps >= 0 && settings->max_steps < 1e15)) {
        dep_repr(settings->max_steps, number, sizeof number);
        snprintf(message, sizeof message, "max_steps must be a positive number of steps (0: "
                 "the default, %.0f), got %s", DEP_MAX_STEPS, number);
        return dep_plain_error(error, DEP_SETTINGS_ERROR, message);
    }
    if (settings->stepping < DEP_STEPPING_AUTO || settings->stepping > DEP_STEPPING_IMPLICIT) {
        snprintf(message, sizeof message, "stepping must be auto (0), explicit (1) or implicit "
                 "(2), got %d", settings->stepping);
        return dep_plain_error(error, DEP_SETTINGS_ERROR, message);
    }
    if (settings->rows != DEP_ROWS_ALL && settings->rows != DEP_ROWS_OUTPUTS) {
        snprintf(message, sizeof message, "rows must be all (0) or outputs (1), got %d",
                 settings->rows);
        return dep_plain_error(error, DEP_SETTINGS_ERROR, message);
    }
    if (settings->stepping == DEP_STEPPING_IMPLICIT && model->nkz == 0) {
        return dep_plain_error(error, DEP_SETTINGS_ERROR, "stepping implicit needs stiff "
                               "forces with a Jacobian (a model with beams); this model has "
                               "none");
    }
    for (int k = 0; k < settings->n_tables && !open; ++k) {
        int status = check_table(model, &settings->tables[k], error);
        if (status != DEP_OK) {
            return status;
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
