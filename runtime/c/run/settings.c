/* settings.c: the checks of a run's settings, parameters and input tables, as
 * depsim.runtime's resolve_settings makes them (run.h).
 */
#include <math.h>
#include <stdio.h>

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
