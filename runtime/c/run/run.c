/* run.c: one run of the iterative Lagrange-multiplier integrator of Lee & Kim
 * (docs/method.md): set up (the system, the mechanism, the events, the stepper), begun at the
 * assembled initial state with lambda_0 from pass 3, advanced step by step with events handled
 * after each (steps.c, firing.c), and finished into a result with its deployment summary
 * (run.h).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "run.h"

/* The system, with the mechanism of the hinges' latches, stops and stick-slip friction
   when the settings ask for it and the model has any. */
static int setup_system(dep_run *run, const double *params)
{
    dep_arena *arena = &run->arena;
    const dep_model *m = run->model;
    dep_mechanism *mechanism = NULL;
    int status;
    run->p = dep_doubles(arena, (size_t)m->np);
    run->p_spare = dep_doubles(arena, (size_t)m->np);
    if (run->p == NULL || run->p_spare == NULL) {
        return dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory");
    }
    memcpy(run->p, params != NULL ? params : m->parameter_defaults, (size_t)m->np * sizeof(double));
    if ((status = dep_check_settings(m, run->p, &run->settings, !run->recording,
                                     run->error)) != DEP_OK
        || (status = dep_system_init(&run->system, m, run->p, run->settings.mechanics != 0,
                                     arena, run->error)) != DEP_OK) {
        return status;
    }
    if (dep_mechanism_create(&mechanism, &run->system,
                             dep_constraint_tolerance(run->settings.tol), arena) != DEP_OK) {
        return dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory");
    }
    run->mechanism = mechanism;
    run->nq = m->nq;
    run->nd = run->system.nd;
    run->ny = 2 * m->nq + run->nd;
    return DEP_OK;
}

static int setup(dep_run *run, const double *params, const dep_event *events, int n_events)
{
    dep_arena *arena = &run->arena;
    const dep_model *m = run->model;
    int status = setup_system(run, params);
    dep_mechanism *mechanism = run->mechanism;
    if (status != DEP_OK
        || (status = dep_watch_init(&run->watch, events, n_events,
                                    mechanism ? mechanism->events : NULL,
                                    mechanism ? mechanism->n_events : 0, arena,
                                    run->error)) != DEP_OK) {
        return status;
    }
    run->n_user_events = n_events;
    if (run->settings.stepping == DEP_STEPPING_IMPLICIT) {
        run->implicit_from = 0.0;
    }
    if (dep_constraints_init(&run->cs, &run->system, arena) != DEP_OK
        || dep_stepper_init(&run->stepper, &run->system, &run->cs, run->settings.tol, arena)
        || dep_history_init(&run->history, run->cs.capacity, arena)
        || dep_history_init(&run->friction, m->nh + 1, arena)
        || dep_history_init(&run->forces, m->nq, arena)
        || (run->prior.qd = dep_doubles(arena, (size_t)m->nq)) == NULL
        || (run->prior.qdd = dep_doubles(arena, (size_t)m->nq)) == NULL
        || dep_state_init(&run->state, m->nq, run->cs.capacity, run->nd, arena)
        || dep_outcome_init(&run->outcome, m->nq, run->cs.capacity, run->nd, m->nh, arena)
        || dep_outcome_init(&run->fired, m->nq, run->cs.capacity, run->nd, m->nh, arena)
        || dep_loads_init(&run->loads, m, arena)
        || dep_change_init(&run->change, m->nq, m->nh, arena)) {
        return dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory");
    }
    run->stepper.implicit = run->settings.stepping == DEP_STEPPING_IMPLICIT;
    if (run->stepper.implicit) {
        run->profile_nodes = DEP_IMPLICIT_PROFILE_NODES;
    }
    status = run->recording ? dep_recorder_init(&run->recorder, &run->system, mechanism,
                                                &run->settings, run->cs.capacity, arena)
                            : DEP_OK;
    run->recorder.records = &run->records; /* the impacts so far, for the run values */
    run->recorder.n_records = &run->n_records;
    if (status == DEP_OK && (status = dep_sensitivity_init(run)) != DEP_OK) {
        return status;
    }
    run->run_values = dep_doubles(arena, DEP_RUN_VALUES(m) + 1);
    run->run_energy = dep_doubles(arena, (size_t)run->system.ne + 1);
    if (status == DEP_SETTINGS_ERROR) {
        char what[200];
        snprintf(what, sizeof what, "t_end / dt_out = %.6g / %.6g asks for %.4g output times; "
                 "this model records at most %.0f (1 GiB of results): use a larger dt_out",
                 run->settings.t_end, run->settings.dt_out,
                 floor(run->settings.t_end / run->settings.dt_out) + 1,
                 dep_max_output_times(&run->system));
        return dep_plain_error(run->error, status, what);
    }
    size_t capacity = (size_t)run->cs.capacity, nq = (size_t)m->nq, ny = (size_t)run->ny;
    run->scratch = dep_doubles(arena, DEP_JACOBIAN_SIZE(m) + (DEP_HISTORY + 2) * capacity
                                      + 3 * ny + 2 * nq);
    run->dense_J = dep_doubles(arena, DEP_JACOBIAN_SIZE(m));
    run->force_now = dep_doubles(arena, nq);
    run->dense_lam = dep_doubles(arena, capacity);
    run->tangent = dep_doubles(arena, ny); /* also the defect's (q, qd) */
    size_t nh = (size_t)m->nh + 1;
    run->friction_predicted = dep_doubles(arena, nh);
    run->friction_d = dep_doubles(arena, nh);
    run->friction_table = dep_doubles(arena, 2 * (size_t)nh);
    run->friction_move = dep_doubles(arena, ny);
    run->turns = dep_doubles(arena, 4 * nh);
    for (int i = 0; i < m->nh; ++i) {
        run->n_wraps += m->hinge_wraps[i] != 0;
    }
    run->normal = dep_doubles(arena, 4 * capacity + 6 * nq);
    double **vectors[] = {&run->y, &run->dy, &run->work};
    for (size_t i = 0; i < 3; ++i) {
        *vectors[i] = dep_doubles(arena, ny);
    }
    double **rows[] = {&run->q, &run->qd, &run->mass_qd, &run->lam, &run->predicted};
    for (size_t i = 0; i < 5; ++i) {
        *rows[i] = dep_doubles(arena, capacity + nq);
    }
    run->response = dep_bytes(arena, sizeof *run->response);
    run->response_rows = dep_bytes(arena, DEP_MAX_ADDED * sizeof *run->response_rows);
    return status != DEP_OK || arena->failed
        ? dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory") : DEP_OK;
}

/* A new run of `model`: its settings checked, its system, events and (when `recording`)
   its recorder set up. NULL with `error` filled on failure. */
dep_run *dep_run_new(const dep_model *model, const double *params, const dep_settings *settings,
                     const dep_event *events, int n_events, int recording, dep_error *error)
{
    dep_run *run = calloc(1, sizeof *run);
    dep_error_clear(error);
    if (run == NULL) {
        dep_plain_error(error, DEP_MEMORY_ERROR, "out of memory");
        return NULL;
    }
    if (model->abi != DEP_MODEL_ABI) {
        free(run);
        dep_plain_error(error, DEP_SETTINGS_ERROR, "the model was generated for another "
                        "version of depsim_model.h; regenerate it");
        return NULL;
    }
    run->model = model;
    run->settings = *settings;
    run->error = error;
    run->recording = recording;
    run->t_stop = run->settings.t_end;
    run->h_min = 64 * DEP_EPS * fmax(1.0, isfinite(run->settings.t_end) ? run->settings.t_end
                                                                          : 1.0);
    run->h_cap = INFINITY;
    run->err_previous = 1.0;
    run->implicit_from = run->stiff_rate = NAN;
    run->omega_max = 0.0;
    run->profile_nodes = DEP_PROFILE_NODES;
    dep_tally_init(&run->tally);
    run->force_steps = 0;
    if (setup(run, params, events, n_events) != DEP_OK) {
        dep_run_free(run);
        return NULL;
    }
    return run;
}

/* The progress callback, if any: DEP_INTERRUPTED when it asks to stop. */
static int report_progress(dep_run *run)
{
    const dep_settings *s = &run->settings;
    if (s->progress == NULL || s->progress(s->progress_context, run->state.t) == 0) {
        return DEP_OK;
    }
    char message[80];
    snprintf(message, sizeof message, "stopped at t = %.9g s", run->state.t);
    return dep_plain_error(run->error, DEP_INTERRUPTED, message);
}

/* The assembled initial state at t = 0, its modes and lambda_0, recorded. */
int dep_run_begin(dep_run *run)
{
    int status;
    if ((status = dep_run_assemble(run, run->q, run->qd)) != DEP_OK
        || (status = dep_run_start(run, run->q, run->qd)) != DEP_OK
        || (status = dep_sensitivity_begin(run)) != DEP_OK
        || (status = dep_run_record_until(run, 0.0, NULL)) != DEP_OK) {
        return status;
    }
    return dep_watch_reset(&run->watch, 0.0, run->state.q, run->state.qd, -1, 0.0,
                           dep_run_rows(run, &run->state), run->error);
}

/* Steps to t (or a stopping event). */
int dep_run_until(dep_run *run, double t)
{
    long long steps = 0;
    int status;
    run->t_stop = t;
    if (!isfinite(run->settings.t_end)) {
        run->h_min = 64 * DEP_EPS * fmax(1.0, t);
    }
    while (t - run->state.t > run->h_min && !run->stopped) {
        if (run->h_next == 0.0) {
            run->h_next = dep_run_first_step(run);
        }
        if ((status = dep_run_advance(run, &run->h_next)) != DEP_OK
            || (status = dep_run_after_step(run, &run->stopped)) != DEP_OK
            || (++steps % DEP_PROGRESS_STEPS == 0 && (status = report_progress(run)) != DEP_OK)) {
            return status;
        }
    }
    return DEP_OK;
}

/* From the assembled initial state to t_end or a stopping event, piece by piece of the
   input tables. */
int dep_run_integrate(dep_run *run)
{
    int status;
    dep_run_start_tables(run);
    if ((status = dep_run_begin(run)) != DEP_OK) {
        return status;
    }
    while (run->settings.t_end - run->state.t > run->h_min && !run->stopped) {
        if ((status = dep_run_until(run, dep_run_next_break(run, run->state.t))) != DEP_OK
            || (run->settings.n_tables > 0 && !run->stopped
                && (status = dep_run_apply_tables(run)) != DEP_OK)) {
            return status;
        }
    }
    return report_progress(run);
}

/* The event records into the result (malloc'ed). */
static int finish_events(dep_run *run, dep_result *result)
{
    result->n_events = run->n_records;
    result->events = calloc((size_t)(run->n_records ? run->n_records : 1), sizeof *result->events);
    if (result->events == NULL) {
        return DEP_MEMORY_ERROR;
    }
    for (int k = 0; k < run->n_records; ++k) {
        const dep_event_record *r = &run->records[k];
        result->events[k] = *r;
        result->events[k].data = malloc((size_t)(r->n_data ? r->n_data : 1) * sizeof(dep_datum));
        if (result->events[k].data == NULL) {
            result->events[k].n_data = 0;
            return DEP_MEMORY_ERROR;
        }
        if (r->n_data) {
            memcpy(result->events[k].data, r->data, (size_t)r->n_data * sizeof(dep_datum));
        }
    }
    return DEP_OK;
}

int dep_run_finish(dep_run *run, dep_result *result)
{
    if (dep_recorder_result(&run->recorder, result) != DEP_OK
        || finish_events(run, result) != DEP_OK) {
        dep_result_free(result);
        return dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory");
    }
    result->tol = run->settings.tol;
    result->constraint_tol = run->stepper.constraint_tol;
    result->t_end = run->settings.t_end;
    result->dt_out = run->settings.dt_out;
    result->stats = dep_tally_stats(&run->tally, run->stepper.integrations,
                                    run->stepper.rhs_evaluations);
    result->stats.implicit_from = run->implicit_from;
    result->stats.stiff_rate = run->stiff_rate;
    result->stats.force_steps = run->force_steps;
    if (dep_summarize(run->model, &run->system, &run->loads, result) != DEP_OK
        || dep_sensitivity_result(run, result) != DEP_OK) {
        dep_result_free(result);
        return dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory");
    }
    return DEP_OK;
}

void dep_run_outputs(dep_run *run, double *outputs)
{
    const dep_model *m = run->model;
    const dep_state *s = &run->state;
    if (m->nout == 0) {
        return;
    }
    double *torques = run->loads.torques;
    if (run->mechanism != NULL) {
        dep_mechanism_hinge_torques(run->mechanism, s->q, s->qd, &run->cs, s->lam, torques);
    } else {
        dep_lock_torques(m, &run->cs, s->lam, torques);
    }
    dep_run_values(&run->system, s->q, torques, s->work,
                   dep_impact_loss(run->records, run->n_records), run->run_energy,
                   run->run_values);
    m->outputs(s->q, s->qd, s->t, run->p, s->lam, run->run_values, outputs);
}

void dep_run_free(dep_run *run)
{
    if (run != NULL) {
        dep_arena_free(&run->arena);
        free(run);
    }
}
