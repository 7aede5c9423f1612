/* library.c: the integrator core's public interface (depsim.h) over one run (run.h): a whole
 * run into a result (dep_simulate), or a run advanced piece by piece (dep_open, dep_advance,
 * dep_set_inputs: a co-simulation step, docs/fmu.md), and what the caller reads of it.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "../run/run.h"

dep_settings dep_default_settings(const dep_model *model)
{
    dep_settings settings = {model->t_end, model->dt_out, model->tol, 1, NULL, NULL, 0.0,
                             NULL, 0, DEP_STEPPING_AUTO, DEP_ROWS_ALL, NULL, 0};
    return settings;
}

int dep_parameter_index(const dep_model *model, const char *name)
{
    for (int i = 0; i < model->np; ++i) {
        if (strcmp(model->parameter_names[i], name) == 0) {
            return i;
        }
    }
    return -1;
}

int dep_check_parameters(const dep_model *model, const double *p, const unsigned char *only,
                         dep_error *error)
{
    dep_error_clear(error);
    return dep_check_limits(model, p, only, error);
}

int dep_simulate(const dep_model *model, const double *params, const dep_settings *settings,
                 const dep_event *events, int n_events, dep_result *result, dep_error *error)
{
    memset(result, 0, sizeof *result);
    dep_settings chosen = settings != NULL ? *settings : dep_default_settings(model);
    dep_run *run = dep_run_new(model, params, &chosen, events, n_events, 1, error);
    if (run == NULL) {
        return error->code;
    }
    int status = dep_run_integrate(run);
    if (status == DEP_OK) {
        status = dep_run_finish(run, result);
    }
    dep_run_free(run);
    return status;
}

/* ---- one run advanced piece by piece ------------------------------------------------------- */

int dep_open(const dep_model *model, const double *params, const dep_settings *settings,
             dep_run **out, dep_error *error)
{
    dep_settings chosen = settings != NULL ? *settings : dep_default_settings(model);
    dep_run *run = dep_run_new(model, params, &chosen, NULL, 0, 0, error);
    *out = NULL;
    if (run == NULL) {
        return error->code;
    }
    int status = dep_run_replay_open(run); /* its calls kept: a state put back elsewhere */
    if (status == DEP_OK) {
        status = dep_run_begin(run);
    }
    if (status != DEP_OK) {
        dep_run_free(run);
        return status;
    }
    *out = run;
    return DEP_OK;
}

int dep_advance(dep_run *run, double t, dep_error *error)
{
    char message[160];
    dep_error_clear(error);
    run->error = error;
    if (!(t >= run->state.t - run->h_min && t <= run->settings.t_end)) {
        snprintf(message, sizeof message, "cannot advance to t = %.17g s: the run is at "
                 "t = %.17g s and ends at %.17g s", t, run->state.t, run->settings.t_end);
        return dep_plain_error(error, DEP_SETTINGS_ERROR, message);
    }
    int status = dep_run_until(run, t);
    return status == DEP_OK ? dep_run_replay_add(run, DEP_REPLAY_ADVANCE, &t, NULL, 1) : status;
}

int dep_set_inputs(dep_run *run, const double *values, const double *rates, dep_error *error)
{
    int status = dep_run_set_inputs(run, values, rates, error);
    return status == DEP_OK ? dep_run_replay_add(run, DEP_REPLAY_INPUTS, values, rates,
                                                 run->model->ni) : status;
}

double dep_time(const dep_run *run)
{
    return run->state.t;
}

void dep_outputs(dep_run *run, double *outputs)
{
    dep_run_outputs(run, outputs);
}

void dep_hinge_states(dep_run *run, dep_hinge_state *out)
{
    const dep_model *m = run->model;
    const dep_state *s = &run->state;
    int nh = m->nh;
    if (nh == 0) {
        return;
    }
    double *angles = run->loads.forces, *rates = run->loads.torques;
    m->hinge_angles(s->q, run->p, angles);
    m->hinge_rates(s->q, s->qd, run->p, rates);
    for (int k = 0; k < nh; ++k) {
        const dep_hinge_mechanics *h = &run->system.hinges[k];
        out[k].angle = angles[k];
        out[k].rate = rates[k];
        out[k].has_latch = h->has_latch;
        out[k].latched = h->has_latch && h->latch_state == DEP_LATCHED;
    }
    dep_hinge_forces(&run->loads, s->lam, run->loads.forces);
    for (int k = 0; k < nh; ++k) {
        out[k].force_x = run->loads.forces[DEP_FORCE_ROWS * k];
        out[k].force_y = run->loads.forces[DEP_FORCE_ROWS * k + 1];
        out[k].force_z = run->loads.forces[DEP_FORCE_ROWS * k + 2];
    }
    dep_lock_torques(m, &run->cs, s->lam, run->loads.torques);
    for (int k = 0; k < nh; ++k) {
        out[k].torque = isnan(run->loads.torques[k]) ? 0.0 : run->loads.torques[k];
    }
}

void dep_close(dep_run *run)
{
    dep_run_free(run);
}

/* ---- a run's state saved and put back ------------------------------------------------------ */

int dep_save(const dep_run *run, dep_snapshot **out, dep_error *error)
{
    dep_error_clear(error);
    return dep_run_save(run, out, error);
}

int dep_restore(dep_run **run, const dep_snapshot *snapshot, dep_error *error)
{
    return dep_run_restore(run, snapshot, error);
}

void dep_snapshot_free(dep_snapshot *snapshot)
{
    dep_snapshot_destroy(snapshot);
}

size_t dep_snapshot_size(const dep_snapshot *snapshot)
{
    return dep_snapshot_bytes(snapshot);
}

void dep_snapshot_write(const dep_snapshot *snapshot, unsigned char *bytes)
{
    dep_snapshot_serialize(snapshot, bytes);
}

int dep_snapshot_read(const dep_model *model, const unsigned char *bytes, size_t size,
                      dep_snapshot **out, dep_error *error)
{
    dep_error_clear(error);
    return dep_snapshot_deserialize(model, bytes, size, out, error);
}
