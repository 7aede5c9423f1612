/* settings.c: the checks of a run's settings, parameters and input tables, as
 * depsim.runtime's resolve_settings makes them, and the model text's range checks of the
 * parameters, as depsim.dsl.check_parameters makes them (run.h).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "run.h"

#define TOL_FLOOR (100 * DEP_EPS) /* below: double precision cannot resolve the errors */

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

/* ---- the model text's range checks ------------------------------------------------------- */

/* Whether `format` is a range check's message: text with at most two "%g" and any "%%". */
static int message_format(const char *format)
{
    int values = 0;
    for (const char *c = format; c != NULL && *c != '\0'; ++c) {
        if (*c == '%' && c[1] == '%') {
            ++c;
        } else if (*c == '%' && (c[1] != 'g' || ++values > 2)) {
            return 0;
        }
    }
    return format != NULL;
}

static int holds(int kind, double value, double bound)
{
    switch (kind) {
    case DEP_LIMIT_POSITIVE: return value > 0;
    case DEP_LIMIT_NONNEGATIVE: return value >= 0;
    case DEP_LIMIT_NONZERO: return value != 0;
    case DEP_LIMIT_BELOW: return value < bound;
    case DEP_LIMIT_AT_LEAST: return value >= bound;
    default: return 0;
    }
}

/* Append `piece` to text (size bytes, `*used` of them taken), cut short at its end. */
static void append(char *text, size_t size, size_t *used, const char *piece)
{
    for (; *piece != '\0' && *used + 1 < size; ++piece) {
        text[(*used)++] = *piece;
    }
    text[*used] = '\0';
}

/* " (from L = -1 m, ...)": the parameters range check `limit` depends on that differ from
   their defaults, except the one it checks itself (depsim.dsl.limits._origin). */
static void origin(const dep_model *m, int limit, const double *p, char *text, size_t size,
                   size_t *used)
{
    char part[DEP_NAME_MAX + 80];
    int parts = 0;
    for (int k = 0; k < m->nlimp; ++k) {
        int j = m->limit_parameter_cols[k];
        double value = p[j], fallback = m->parameter_defaults[j];
        if (m->limit_parameter_rows[k] != limit || value == fallback
            || (isnan(value) && isnan(fallback))
            || strcmp(m->parameter_names[j], m->limit_names[limit]) == 0) {
            continue;
        }
        const char *unit = m->parameter_units[j];
        int plain = strcmp(unit, "") == 0 || strcmp(unit, "1") == 0;
        append(text, size, used, parts++ ? ", " : " (from ");
        snprintf(part, sizeof part, "%.*s = %g%s%.*s", DEP_NAME_MAX, m->parameter_names[j],
                 value, plain ? "" : " ", DEP_NAME_MAX, plain ? "" : unit);
        append(text, size, used, part);
    }
    if (parts) {
        append(text, size, used, ")");
    }
}

int dep_check_limits(const dep_model *model, const double *p, const unsigned char *only,
                     dep_error *error)
{
    char message[sizeof error->message], broken[600];
    size_t used = 0;
    int n = model->nlim, k = 0;
    double *values = malloc(2 * (size_t)(n > 0 ? n : 1) * sizeof *values);
    if (values == NULL) {
        return dep_plain_error(error, DEP_MEMORY_ERROR, "out of memory");
    }
    if (n > 0) {
        model->parameter_checks(p, values, values + n);
    }
    message[0] = '\0';
    for (int i = 0; i < n; ++i) {
        int kind = model->limit_kinds[i], decided = 1;
        for (; k < model->nlimp && model->limit_parameter_rows[k] == i; ++k) {
            decided = decided && (only == NULL || only[model->limit_parameter_cols[k]]);
        }
        double value = values[i], bound = values[n + i];
        int finite = isfinite(value) && (kind < DEP_LIMIT_BELOW || isfinite(bound));
        if (!decided || (finite && holds(kind, value, bound))) {
            continue;
        }
        if (!finite) {
            snprintf(broken, sizeof broken, "cannot evaluate %.*s: the result is not a finite "
                     "number", DEP_NAME_MAX, model->limit_names[i]);
        } else if (message_format(model->limit_messages[i])) {
            /* the model's one wording (depsim.dsl.limits.message_format): "%g" and "%%" only */
            snprintf(broken, sizeof broken, model->limit_messages[i], value, bound);
        } else {
            snprintf(broken, sizeof broken, "%.*s is out of its range", DEP_NAME_MAX,
                     model->limit_names[i]);
        }
        append(message, sizeof message, &used, used ? "; " : "");
        append(message, sizeof message, &used, broken);
        origin(model, i, p, message, sizeof message, &used);
    }
    free(values);
    return used ? dep_plain_error(error, DEP_SETTINGS_ERROR, message) : DEP_OK;
}

/* ---- a run's settings ------------------------------------------------------------------------ */

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
    int status = dep_check_limits(model, p, NULL, error);
    if (status != DEP_OK) {
        return status;
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
    if (settings->n_sensitivities != 0 && (open || settings->n_sensitivities < 0
                                           || settings->sensitivities == NULL)) {
        return dep_plain_error(error, DEP_SETTINGS_ERROR, open
            ? "sensitivities are computed by a whole run (dep_simulate), not an open one"
            : "n_sensitivities must be 0, or the count of the indices in sensitivities");
    }
    if (settings->n_sensitivities > 0 && settings->stepping == DEP_STEPPING_IMPLICIT) {
        return dep_plain_error(error, DEP_SETTINGS_ERROR, "sensitivities are not followed "
                               "through the linearly implicit step yet: use stepping "
                               "explicit");
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
