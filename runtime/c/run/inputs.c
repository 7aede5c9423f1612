/* inputs.c: a run's inputs (docs/language.md, Inputs): each held in two parameter slots,
 * u(t) = p[slot] + p[slot + 1] t, filled piece by piece from its time table, or set from outside
 * (dep_set_inputs, the FMU); a change restarts the step sequence (run.h).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "run.h"

/* Input k's parameter slots from now on: u(s) = value + rate (s - now), into `p`. */
static void put_input(const dep_run *run, double *p, int k, double value, double rate)
{
    int slot = run->model->input_slots[k];
    p[slot] = value - rate * run->state.t;
    p[slot + 1] = rate;
}

/* Makes `p` (filled from run->p, then changed) the run's parameters if it differs from
   them. A change takes the other buffer, so a binding that converts p once per pointer
   sees it. 1 if it changed. */
static int take_parameters(dep_run *run, double *p)
{
    if (memcmp(p, run->p, (size_t)run->model->np * sizeof *p) == 0) {
        return 0;
    }
    run->p_spare = run->p;
    run->p = p;
    run->system.p = p;
    return 1;
}

/* The spare parameter buffer, filled with the run's parameters. */
static double *spare_parameters(dep_run *run)
{
    memcpy(run->p_spare, run->p, (size_t)run->model->np * sizeof *run->p);
    return run->p_spare;
}

/* After the inputs changed at the current state: lambda and the step sequence anew. The
   events' last values stay those before the change, so a mode the new load ends (a stuck
   hinge it frees, a stop it pulls away from) is found crossing in the next step. */
static int inputs_changed(dep_run *run)
{
    dep_state *s = &run->state;
    memcpy(run->q, s->q, (size_t)run->nq * sizeof(double));
    memcpy(run->qd, s->qd, (size_t)run->nq * sizeof(double));
    memcpy(run->work, s->work, (size_t)run->nd * sizeof(double));
    run->h_next = 0.0;
    return dep_run_restart(run, s->t, run->q, run->qd, run->work, "inputs");
}

/* A table's value and slope on the piece starting at t (right-continuous at a jump). */
static void table_piece(const dep_input_table *table, double t, double *value, double *rate)
{
    int n = table->n, i = 0;
    while (i + 1 < n && table->t[i + 1] <= t) {
        ++i;
    }
    *rate = 0.0;
    if (t < table->t[0] || i == n - 1) {
        *value = t < table->t[0] ? table->u[0] : table->u[n - 1];
        return;
    }
    *rate = (table->u[i + 1] - table->u[i]) / (table->t[i + 1] - table->t[i]);
    *value = table->u[i] + *rate * (t - table->t[i]);
}

/* The next time after t where a table's piece ends (t_end if none). */
double dep_run_next_break(const dep_run *run, double t)
{
    double next = run->settings.t_end;
    for (int k = 0; k < run->settings.n_tables; ++k) {
        const dep_input_table *table = &run->settings.tables[k];
        for (int i = 0; i < table->n; ++i) {
            if (table->t[i] > t + run->h_min) {
                next = fmin(next, table->t[i]);
                break;
            }
        }
    }
    return next;
}

/* The tables' pieces at the current time into the inputs' slots. */
int dep_run_apply_tables(dep_run *run)
{
    double *p = spare_parameters(run);
    for (int k = 0; k < run->settings.n_tables; ++k) {
        const dep_input_table *table = &run->settings.tables[k];
        double value, rate;
        table_piece(table, run->state.t, &value, &rate);
        put_input(run, p, table->input, value, rate);
    }
    return take_parameters(run, p) ? inputs_changed(run) : DEP_OK;
}

/* The tables' values at t = 0 into the inputs' slots (before the run begins). */
void dep_run_start_tables(dep_run *run)
{
    double *p = spare_parameters(run);
    for (int k = 0; k < run->settings.n_tables; ++k) {
        const dep_input_table *table = &run->settings.tables[k];
        double value, rate;
        table_piece(table, 0.0, &value, &rate);
        put_input(run, p, table->input, value, rate);
    }
    take_parameters(run, p);
}

int dep_run_set_inputs(dep_run *run, const double *values, const double *rates,
                       dep_error *error)
{
    double *p = spare_parameters(run);
    dep_error_clear(error);
    run->error = error;
    for (int k = 0; k < run->model->ni; ++k) {
        double rate = rates != NULL ? rates[k] : 0.0;
        if (!isfinite(values[k]) || !isfinite(rate)) {
            char message[200];
            snprintf(message, sizeof message, "input %s: its value and rate must be finite "
                     "numbers", run->model->input_names[k]);
            return dep_plain_error(error, DEP_SETTINGS_ERROR, message);
        }
        put_input(run, p, k, values[k], rate);
    }
    return take_parameters(run, p) ? inputs_changed(run) : DEP_OK;
}
