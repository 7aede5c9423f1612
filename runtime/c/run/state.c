/* state.c: a run's state and what it keeps of it: a (re)start checked and its lambda found,
 * a pass failure as the error the user sees, the outputs due on a step's dense output, the
 * active rows a callback sees, the peak hinge loads at accepted states and the event records
 * (run.h).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "run.h"

/* ---- errors ----------------------------------------------------------------------------- */

/* _solver_error: a pass failure as the SolverError the user sees. */
int dep_run_pass_error(dep_run *run, const dep_failure *failure, double t)
{
    char joint[DEP_NAME_MAX + 8], what[400], hint[400];
    if (failure->row < 0) { /* not a constraint row: the step itself */
        return dep_solver_error(run->error, 1, t, dep_stage_names[failure->stage], NULL, NULL,
                                0, 0.0, failure->reason, failure->hint[0] != '\0'
                                ? failure->hint : "the state may no longer be finite; "
                                "check the beams' properties, or try a tighter tol");
    }
    dep_cs_describe(&run->cs, failure->row, joint, sizeof joint);
    if (failure->residual <= 1e3 * DEP_EPS * fmax(1.0, failure->scale)) {
        snprintf(hint, sizeof hint, "the residual is at the level of round-off: tol is tighter "
                 "than double precision reaches here; try tol >= %.0e", 10 * run->settings.tol);
    } else {
        snprintf(hint, sizeof hint, "Phi_q may be singular here (a dead point, a joint at the "
                 "end of its travel) or constraints redundant and inconsistent; check %s and "
                 "the joints in its loop, or try a looser tol", joint);
    }
    snprintf(what, sizeof what, "%s; residual %.3g", failure->reason, failure->residual);
    return dep_solver_error(run->error, 1, t, dep_stage_names[failure->stage],
                            run->cs.row_names[failure->row], joint, 1, failure->residual, what,
                            hint);
}

/* ---- states ------------------------------------------------------------------------------ */

/* _restart: a state to step from, checked for consistency, lambda from pass 3. */
int dep_run_restart(dep_run *run, double t, const double *q, const double *qd,
                    const double *work, const char *stage)
{
    dep_stepper *stepper = &run->stepper;
    dep_state *s = &run->state;
    dep_pass_report report;
    dep_failure failure;
    int status = dep_check_consistency(&run->cs, t, q, qd, run->settings.tol, stage,
                                       run->scratch, run->error);
    if (status != DEP_OK) {
        return status;
    }
    memmove(s->q, q, (size_t)run->nq * sizeof *q);
    memmove(s->qd, qd, (size_t)run->nq * sizeof *qd);
    memmove(s->work, work, (size_t)run->nd * sizeof *work);
    memset(s->lam, 0, (size_t)run->cs.nc * sizeof *s->lam);
    s->t = t;
    dep_implicit_forget(&stepper->im); /* new rows, inputs or parameters: K, D and W anew */
    stepper->end_t = NAN;              /* and the force at the last step's end */
    dep_cs_jacobian(&run->cs, s->q, t, stepper->restart_J);
    status = dep_acceleration(stepper, s->q, s->qd, t, s->lam, stepper->restart_J,
                              ++stepper->jacobian_ids, s->qdd, &report, &failure);
    if (status == DEP_PASS_FAILED) {
        return dep_run_pass_error(run, &failure, t);
    }
    dep_tally_observe(&run->tally, &report);
    dep_history_reset(&run->history, t, s->lam, run->cs.nc);
    dep_friction_law(&run->system, s->q, s->qd, run->friction_predicted);
    dep_history_reset(&run->friction, t, run->friction_predicted, run->system.nh);
    run->friction_steps = 0;
    run->prior.valid = 0;
    return DEP_OK;
}

/* _lam_dict: the active rows' multipliers at `state` when some event watches them. */
const dep_active_rows *dep_run_rows(dep_run *run, const dep_state *state)
{
    if (!run->watch.needs_multipliers) {
        return NULL;
    }
    run->state_rows = dep_cs_view(&run->cs, state->lam);
    return &run->state_rows;
}

/* _observe_loads: peak hinge forces and lock torques at an accepted state (exact lambda). */
void dep_run_observe_loads(dep_run *run, const dep_state *s)
{
    dep_loads *loads = &run->loads;
    dep_hinge_forces(loads, s->lam, loads->forces);
    if (run->mechanism != NULL) {
        dep_mechanism_hinge_torques(run->mechanism, s->q, s->qd, &run->cs, s->lam,
                                    loads->torques);
    } else {
        dep_lock_torques(run->model, &run->cs, s->lam, loads->torques);
    }
    dep_loads_observe(loads, s->t, loads->forces, loads->torques);
}

/* ---- recording ----------------------------------------------------------------------------- */

/* Record the output times up to t_until: on the step's dense output when `end` is given,
   else at the current state. */
int dep_run_record_until(dep_run *run, double t_until, const dep_outcome *end)
{
    if (!run->recording) {
        return DEP_OK;
    }
    int first, count = dep_recorder_pending(&run->recorder, t_until, &first), nq = run->nq;
    const dep_state *start = &run->state;
    for (int k = first; k < first + count; ++k) {
        double t = run->recorder.times[k];
        int status;
        if (end == NULL) {
            status = dep_record(&run->recorder, t, start->q, start->qd, start->lam, start->work,
                                &run->cs);
        } else {
            const dep_state *new = &end->state;
            dep_interpolate(end->data, start->t, new->t - start->t, nq, t, run->q, run->qd);
            dep_dense_components(end->rk, t, 2 * nq, run->nd, run->work);
            dep_profile_value(&end->profile, new->lam, t, run->cs.nc, run->lam);
            status = dep_record(&run->recorder, t, run->q, run->qd, run->lam, run->work, &run->cs);
        }
        if (status != DEP_OK) {
            return dep_plain_error(run->error, status, "out of memory");
        }
    }
    return DEP_OK;
}

int dep_run_add_record(dep_run *run, const char *name, int kind, int hinge, double t,
                       const dep_datum *data, int n)
{
    if (run->n_records == run->records_capacity) {
        int capacity = run->records_capacity ? 2 * run->records_capacity : 16;
        dep_event_record *records = dep_bytes(&run->arena, (size_t)capacity * sizeof *records);
        if (records == NULL) {
            return dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory");
        }
        if (run->n_records) {
            memcpy(records, run->records, (size_t)run->n_records * sizeof *records);
        }
        run->records = records;
        run->records_capacity = capacity;
    }
    dep_event_record *record = &run->records[run->n_records];
    dep_copy_text(record->name, sizeof record->name, name);
    record->t = t;
    record->kind = kind;
    record->hinge = hinge;
    record->n_data = n;
    record->data = dep_bytes(&run->arena, (size_t)(n ? n : 1) * sizeof *record->data);
    if (record->data == NULL) {
        return dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory");
    }
    if (n) {
        memcpy(record->data, data, (size_t)n * sizeof *data);
    }
    run->n_records++;
    return DEP_OK;
}

/* _log: the event's record, or the records its change names instead. */
int dep_run_log_event(dep_run *run, const char *name, double t, const dep_change *change)
{
    if (change->records == NULL) {
        return dep_run_add_record(run, name, DEP_RECORD_EVENT, -1, t, change->data,
                                  change->n_data);
    }
    for (int k = 0; k < change->n_records; ++k) {
        const dep_event_record *r = &change->records[k];
        int status = dep_run_add_record(run, r->name, r->kind, r->hinge, t, r->data,
                                        r->n_data);
        if (status != DEP_OK) {
            return status;
        }
    }
    return DEP_OK;
}
