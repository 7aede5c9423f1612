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

/* _solver_error: a pass failure as the SolverError the user sees, with its cause
   (method.h, dep_failure_kind) and what helps. */
int dep_run_pass_error(dep_run *run, const dep_failure *failure, double t)
{
    char joint[DEP_NAME_MAX + 8], weak[DEP_NAME_MAX + 8], what[800], hint[700];
    const char *stage = dep_stage_names[failure->stage];
    if (failure->row < 0) { /* not a constraint row: the step itself */
        return dep_solver_error(run->error, 1, t, stage, NULL, NULL, 0, 0.0, failure->reason,
                                failure->hint[0] != '\0' ? failure->hint
                                : "the state may no longer be finite; check the beams' "
                                "properties, or try a tighter tol");
    }
    dep_cs_describe(&run->cs, failure->row, joint, sizeof joint);
    snprintf(weak, sizeof weak, "%s", joint);
    if (failure->weak_row >= 0 && failure->weak_row < run->cs.nc) {
        dep_cs_describe(&run->cs, failure->weak_row, weak, sizeof weak);
    }
    int n = snprintf(what, sizeof what, "%s; residual %.3g, limit %.3g", failure->reason,
                     failure->residual, failure->limit);
    if (failure->roundoff > 0.0 && n > 0 && (size_t)n < sizeof what) {
        n += snprintf(what + n, sizeof what - (size_t)n, ", round-off %.2g", failure->roundoff);
    }
    size_t used = n > 0 && (size_t)n < sizeof what ? (size_t)n : sizeof what - 1;
    switch (failure->kind) {
    case DEP_FAILED_NONFINITE:
        snprintf(hint, sizeof hint, "check the model's masses, stiffnesses and initial rates at "
                 "this time (a force that grows without bound), or try a tighter tol");
        break;
    case DEP_FAILED_INCONSISTENT:
        snprintf(what + used, sizeof what - used, ": the constraints are inconsistent here, "
                 "%d of the %d rows depend on the others (rank %d) and they cannot all hold",
                 failure->rows - failure->rank, failure->rows, failure->rank);
        snprintf(hint, sizeof hint, "check the lengths and points of the loop through %s and "
                 "%s: a redundant joint must agree with the others exactly", joint, weak);
        break;
    case DEP_FAILED_CONDITION:
        snprintf(what + used, sizeof what - used, ": the rows are ill-conditioned here, the "
                 "condition of Phi_q M^-1 Phi_q^T is about %.1e (its weakest row at %s)",
                 failure->condition, weak);
        snprintf(hint, sizeof hint, "the mechanism is at or near a singular position (links "
                 "in line, a dead point) where its motion is not determined to tol; a change "
                 "of tol does not help. Check the geometry near %s and %s, or give a hinge "
                 "there a little damping", joint, weak);
        break;
    default:
        snprintf(what + used, sizeof what - used, ": the correction does not converge at "
                 "steps down to %.2g s (condition of Phi_q M^-1 Phi_q^T about %.1e)",
                 run->h_min, failure->condition);
        snprintf(hint, sizeof hint, "the constraint forces change faster than any step "
                 "resolves (an impact or a very stiff element acting on %s at this time); "
                 "check the model there", joint);
        break;
    }
    return dep_solver_error(run->error, 1, t, stage, run->cs.row_names[failure->row], joint,
                            1, failure->residual, what, hint);
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
    s->qdd_weak = dep_acceleration_weak(stepper);
    dep_tally_observe(&run->tally, &report);
    dep_history_reset(&run->history, t, s->lam, run->cs.nc);
    dep_cs_transpose_times(&run->cs, stepper->restart_J, s->lam, run->force_now);
    dep_history_reset(&run->forces, t, run->force_now, run->nq);
    run->by_force = run->by_force_next = 0;
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
    dep_loads_mark_redundant(loads, &run->cs, &run->stepper.mp);
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
        if (end == NULL) {
            status = dep_sensitivity_record(run, run->recorder.rows - 1, t, start->q, start->qd,
                                            start->lam, start->work);
        } else {
            status = dep_sensitivity_record(run, run->recorder.rows - 1, t, run->q, run->qd,
                                            run->lam, run->work);
        }
        if (status != DEP_OK) {
            return status;
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
