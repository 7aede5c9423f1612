/* firing.c: the events of a run: the initial modes, crossings located on the step's dense
 * output, the step re-taken exactly to the crossing, the mechanism (transitions.c) or the
 * user's callback deciding, the change applied (changes.c).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "run.h"

#define REFINE_EVENT 3             /* Newton corrections of an event time on the re-taken step */
#define EVENT_SLOPE_FRACTION 1e-3  /* g' from g at the step end and this fraction of h before */
#define EVENT_TIME_TOL 1e-12       /* s, as events.c */

/* ---- the initial state and the events ------------------------------------------------------- */

/* _start: the initial state after the mechanism's modes at t = 0. */
int dep_run_start(dep_run *run, const double *q0, const double *qd0)
{
    dep_mechanism *m = run->mechanism;
    int status;
    memset(run->work, 0, (size_t)run->nd * sizeof(double));
    if (m == NULL) {
        status = dep_run_restart(run, 0.0, q0, qd0, run->work, "initial state");
    } else {
        dep_state here = run->state;
        int due[DEP_KINDS * DEP_MAX_ADDED], n_due;
        status = dep_check_consistency(&run->cs, 0.0, q0, qd0, run->settings.tol,
                                       "initial state", run->scratch, run->error);
        if (status != DEP_OK) {
            return status;
        }
        n_due = dep_mechanism_start(m, q0, qd0, due);
        dep_change_clear(&run->change);
        status = dep_settle(m, 0.0, q0, qd0, &run->cs, due, n_due, &run->change, run->error);
        if (status != DEP_OK) {
            return status;
        }
        here.t = 0.0;
        memcpy(here.q, q0, (size_t)run->nq * sizeof(double));
        memcpy(here.qd, qd0, (size_t)run->nq * sizeof(double));
        memset(here.work, 0, (size_t)run->nd * sizeof(double));
        status = dep_run_apply_change(run, &run->change, &here);
        for (int k = 0; status == DEP_OK && k < run->change.n_records; ++k) {
            const dep_event_record *r = &run->change.records[k];
            status = dep_run_add_record(run, r->name, r->kind, r->hinge, 0.0, r->data,
                                        r->n_data);
        }
    }
    if (status == DEP_OK) {
        dep_run_observe_loads(run, &run->state);
    }
    return status;
}

/* The user's callback's response as a change. */
static int user_change(dep_run *run, const dep_event *event, double t, const dep_state *here,
                       dep_change *change)
{
    dep_event_response *r = run->response;
    dep_row *added = run->response_rows;
    for (int i = 0; i < run->cs.n_added; ++i) {
        const dep_added_row *a = &run->cs.added[i];
        memset(&added[i], 0, sizeof added[i]);
        added[i].kind = a->kind;
        dep_copy_text(added[i].name, DEP_NAME_MAX, a->name);
        dep_copy_text(added[i].joint, DEP_NAME_MAX, a->joint);
        added[i].hinge = a->hinge;
        added[i].angle = a->angle;
        added[i].row = a->row;
        added[i].value = a->value;
    }
    dep_event_hit hit = {event->name, t, here->q, here->qd, here->lam, run->cs.nc,
                         run->cs.row_names, run->p, run->cs.n_added, added};
    memset(r, 0, sizeof *r);
    r->stop = -1;
    if (event->callback != NULL && event->callback(event->context, &hit, r) != 0) {
        char message[DEP_NAME_MAX + 40];
        snprintf(message, sizeof message, "event '%.*s': its callback failed", DEP_NAME_MAX,
                 event->name);
        return dep_plain_error(run->error, DEP_CALLBACK_ERROR, message);
    }
    change->stop = r->stop;
    change->has_q = r->q != NULL;
    change->has_qd = r->qd != NULL;
    if (r->q != NULL) {
        memcpy(change->q, r->q, (size_t)run->nq * sizeof(double));
    }
    if (r->qd != NULL) {
        memcpy(change->qd, r->qd, (size_t)run->nq * sizeof(double));
    }
    for (int i = 0; i < r->n_add && i < DEP_MAX_ADDED; ++i) {
        int status = dep_cs_prepare_row(&run->cs, &r->add[i], &change->add[change->n_add++],
                                        run->error);
        if (status != DEP_OK) {
            return status;
        }
    }
    for (int i = 0; i < r->n_remove && i < DEP_MAX_ADDED; ++i) {
        dep_copy_text(change->remove[change->n_remove++], DEP_NAME_MAX, r->remove[i]);
    }
    change->impact = r->impact;
    for (int i = 0; i < r->n_data && i < DEP_MAX_DATA; ++i) {
        dep_datum_number(change->data, &change->n_data, change->data_capacity,
                         r->data_names[i], r->data_values[i]);
    }
    return DEP_OK;
}

/* g of `event` at a state of the current constraint set with multipliers lam. */
static int event_value(dep_run *run, const dep_event *event, double t, const double *q,
                       const double *qd, const double *lam, double *g)
{
    dep_active_rows rows = dep_cs_view(&run->cs, lam);
    return dep_event_value(event, t, q, qd, &rows, g, run->error);
}

/* A Newton correction of the event time from the re-taken step's end (g' from g at the end
   and EVENT_SLOPE_FRACTION h before it, on the step's interpolant). */
static int event_shift(dep_run *run, const dep_event *event, double h, double *shift)
{
    const dep_state *prior = &run->state, *here = &run->fired.state;
    double g, g_back, back = here->t - EVENT_SLOPE_FRACTION * h;
    int status = event_value(run, event, here->t, here->q, here->qd, here->lam, &g);
    if (status != DEP_OK) {
        return status;
    }
    dep_interpolate(run->fired.data, prior->t, here->t - prior->t, run->nq, back, run->q,
                    run->qd);
    dep_profile_value(&run->fired.profile, here->lam, back, run->cs.nc, run->dense_lam);
    status = event_value(run, event, back, run->q, run->qd, run->dense_lam, &g_back);
    double slope = (g - g_back) / (EVENT_SLOPE_FRACTION * h);
    *shift = slope != 0.0 ? -g / slope : 0.0;
    return status;
}

/* _retake: the step from the state re-taken to the crossing. The crossing was located on the
   dense output, which differs from a step's own end by the local error; so g at the re-taken
   end is driven to zero by up to REFINE_EVENT Newton corrections of the end time, until they
   are below EVENT_TIME_TOL. *here: the state the event happens in. */
static int retake(dep_run *run, const dep_event *event, double *t_event, const dep_state **here)
{
    const dep_state *prior = &run->state;
    for (int attempt = 0; attempt <= REFINE_EVENT; ++attempt) {
        double h = *t_event - prior->t, shift;
        dep_failure failure;
        int status = dep_run_step(run, h, &run->fired, &failure);
        if (status == DEP_PASS_FAILED) {
            return dep_run_pass_error(run, &failure, *t_event);
        }
        dep_run_attach_prior(run, &run->fired);
#ifdef DEP_TRACE
        fprintf(stderr, "event step t=%.17g h=%.17g integrations %d\n", prior->t, h,
                run->fired.integrations);
#endif
        if (attempt == REFINE_EVENT) {
            break;
        }
        if ((status = event_shift(run, event, h, &shift)) != DEP_OK) {
            return status;
        }
        if (!(fabs(shift) > EVENT_TIME_TOL) || !(prior->t + run->h_min < *t_event + shift)) {
            break;
        }
        *t_event += shift;
    }
    dep_tally_accept(&run->tally, run->fired.reports, *t_event - prior->t);
    *here = &run->fired.state;
    return DEP_OK;
}

/* The run ends at the event: its records, then the state's row at t_event. */
static int stop_here(dep_run *run, int k, double t_event, const dep_state *here)
{
    const dep_event *event = &run->watch.events[k];
    int status, first = run->n_records;
    if (here != &run->state) {
        dep_state_copy(&run->state, here, run->nq, run->cs.nc, run->nd);
    }
    if ((status = dep_run_log_event(run, event->name, t_event, &run->change)) != DEP_OK
        || (status = dep_sensitivity_event(run, k, t_event, here, first, 1)) != DEP_OK
        || (status = dep_run_record_until(run, t_event, NULL)) != DEP_OK) {
        return status;
    }
    if (dep_recorder_last_time(&run->recorder) != t_event) {
        const dep_state *s = &run->state;
        status = dep_record(&run->recorder, t_event, s->q, s->qd, s->lam, s->work, &run->cs);
        if (status == DEP_OK) {
            return dep_sensitivity_record(run, run->recorder.rows - 1, t_event, s->q, s->qd,
                                          s->lam, s->work);
        }
    }
    return status == DEP_OK ? DEP_OK : dep_plain_error(run->error, status, "out of memory");
}

/* _fire: event k at t_event; *stop: 1 when the run ends here. */
static int fire(dep_run *run, int k, double t_event, double side, int *stop)
{
    const dep_event *event = &run->watch.events[k];
    const dep_state *here = &run->state;
    int status = DEP_OK;
    if (t_event - run->state.t > run->h_min) {
        status = retake(run, event, &t_event, &here);
        if (status == DEP_OK) {
            status = dep_sensitivity_retake(run, &run->fired);
        }
    }
    if (status != DEP_OK) {
        return status;
    }
    if ((status = dep_sensitivity_prepare_event(run, k, here)) != DEP_OK) {
        return status; /* (before the modes change: the state the event happens in) */
    }
    run->watch.hits[k]++;
    run->tally.events++;
    dep_change_clear(&run->change);
    if (k >= run->n_user_events) {
        int due = k - run->n_user_events;
        status = dep_settle(run->mechanism, t_event, here->q, here->qd, &run->cs, &due, 1,
                            &run->change, run->error);
    } else {
        status = user_change(run, event, t_event, here, &run->change);
    }
    if (status != DEP_OK) {
        return status;
    }
    dep_run_observe_loads(run, here);
    *stop = run->change.stop < 0 ? event->terminal != 0 : run->change.stop != 0;
    if (*stop) {
        return stop_here(run, k, t_event, here);
    }
    int first = run->n_records;
    if ((status = dep_run_apply_change(run, &run->change, here)) != DEP_OK
        || (status = dep_run_log_event(run, event->name, t_event, &run->change)) != DEP_OK
        || (status = dep_sensitivity_event(run, k, t_event, here, first, 0)) != DEP_OK) {
        return status;
    }
    dep_run_observe_loads(run, &run->state);
    return dep_watch_reset(&run->watch, t_event, run->state.q, run->state.qd, k, side,
                           dep_run_rows(run, &run->state), run->error);
}

/* q, qd (and the multipliers) inside the step just taken (_multipliers_at). */
static int dense_output(void *context, double t, double *q, double *qd, dep_active_rows *rows)
{
    dep_run *run = context;
    const dep_state *start = &run->state, *new = &run->outcome.state;
    dep_interpolate(run->outcome.data, start->t, new->t - start->t, run->nq, t, q, qd);
    if (rows == NULL) {
        return DEP_OK;
    }
    dep_pass_report report;
    dep_failure failure;
    dep_profile_value(&run->outcome.profile, new->lam, t, run->cs.nc, run->dense_lam);
    dep_cs_jacobian(&run->cs, q, t, run->dense_J);
    int status = dep_acceleration(&run->stepper, q, qd, t, run->dense_lam, run->dense_J,
                                  ++run->stepper.jacobian_ids, run->mass_qd, &report, &failure);
    if (status == DEP_PASS_FAILED) {
        return dep_run_pass_error(run, &failure, t);
    }
    *rows = dep_cs_view(&run->cs, run->dense_lam);
    return DEP_OK;
}

/* _after_step: record outputs, then look for events; *stop: 1 when the run ends. */
int dep_run_after_step(dep_run *run, int *stop)
{
    dep_state *new = &run->outcome.state;
    int k = -1, status;
    double t_event = new->t, side = 0.0;
    *stop = 0;
    if (run->watch.count > 0) {
        status = dep_first_crossing(&run->watch, run->state.t, new->t, new->q, new->qd,
                                    dep_run_rows(run, new), dense_output, run, run->q, run->qd,
                                    &run->dense_rows, &k, &t_event, &side, run->error);
        if (status != DEP_OK) {
            return status;
        }
    }
    status = dep_sensitivity_step(run, &run->outcome, k < 0 ? new->t : t_event);
    if (status != DEP_OK) {
        return status;
    }
    status = dep_run_record_until(run, k < 0 ? new->t : t_event, &run->outcome);
    if (status != DEP_OK) {
        return status;
    }
    if (k < 0) {
        run->prior.valid = 1;
        run->prior.t = run->state.t;
        memcpy(run->prior.qd, run->state.qd, (size_t)run->nq * sizeof(double));
        memcpy(run->prior.qdd, run->state.qdd, (size_t)run->nq * sizeof(double));
        run->prior.qdd_weak = run->state.qdd_weak;
        dep_state_copy(&run->state, new, run->nq, run->cs.nc, run->nd);
        dep_history_add(&run->history, new->t, new->lam);
        dep_cs_transpose_times(&run->cs, run->outcome.J1, new->lam, run->force_now);
        dep_history_add(&run->forces, new->t, run->force_now);
        dep_history_add(&run->friction, new->t, run->outcome.friction);
        dep_run_observe_loads(run, &run->state);
        return DEP_OK;
    }
    return fire(run, k, t_event, side, stop);
}
