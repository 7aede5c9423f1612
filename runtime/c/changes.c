/* changes.c: what an event changes in a run: the active rows a callback sees, the records of
 * the events, a change applied (rows added and removed, a new state, a plastic impact, then
 * lambda again from pass 3), and the peak hinge loads at accepted states.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "runtime.h"

int dep_change_init(dep_change *change, int nq, int nh, dep_arena *arena)
{
    (void)nh;
    memset(change, 0, sizeof *change);
    change->q = dep_doubles(arena, (size_t)nq);
    change->qd = dep_doubles(arena, (size_t)nq);
    change->add = dep_bytes(arena, DEP_MAX_ADDED * sizeof *change->add);
    change->remove = dep_bytes(arena, DEP_MAX_ADDED * sizeof *change->remove);
    change->data_capacity = DEP_USER_DATA;
    change->data = dep_bytes(arena, DEP_USER_DATA * sizeof *change->data);
    return arena->failed ? DEP_MEMORY_ERROR : DEP_OK;
}

void dep_change_clear(dep_change *change)
{
    change->stop = -1;
    change->has_q = change->has_qd = change->impact = 0;
    change->n_add = change->n_remove = change->n_records = change->n_data = 0;
    change->records = NULL;
}

/* _lam_dict: the active rows' multipliers at `state` when some event watches them. */
const dep_active_rows *dep_run_rows(dep_run *run, const dep_state *state)
{
    if (!run->watch.needs_multipliers) {
        return NULL;
    }
    run->state_rows.nc = run->cs.nc;
    run->state_rows.names = run->cs.row_names;
    run->state_rows.lam = state->lam;
    return &run->state_rows;
}

/* _observe_loads: peak hinge forces and lock torques at an accepted state (exact lambda). */
void dep_run_observe_loads(dep_run *run, const dep_state *s)
{
    dep_loads *loads = &run->loads;
    dep_hinge_forces(loads, s->lam, loads->forces);
    if (run->system.mechanism != NULL) {
        dep_mechanism_hinge_torques(run->system.mechanism, s->q, s->qd, &run->cs, s->lam,
                                    loads->torques);
    } else {
        dep_lock_torques(run->model, &run->cs, s->lam, loads->torques);
    }
    dep_loads_observe(loads, s->t, loads->forces, loads->torques);
}

/* ---- records ------------------------------------------------------------------------------- */

int dep_run_add_record(dep_run *run, const char *name, double t, const dep_datum *data, int n)
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
        return dep_run_add_record(run, name, t, change->data, change->n_data);
    }
    for (int k = 0; k < change->n_records; ++k) {
        const dep_event_record *r = &change->records[k];
        int status = dep_run_add_record(run, r->name, t, r->data, r->n_data);
        if (status != DEP_OK) {
            return status;
        }
    }
    return DEP_OK;
}

/* ---- applying a change --------------------------------------------------------------------- */

static int impact(dep_run *run, const dep_state *here, dep_change *change)
{
    dep_stepper *st = &run->stepper;
    dep_pass_report report;
    dep_failure failure;
    dep_measurement *slots[2] = {&st->slots[2], &st->slots[3]};
    double *J = st->restart_J, *phi_t = st->phi_t1, *qd_new = run->mass_qd;
    dep_cs_jacobian(&run->cs, run->q, here->t, J);
    dep_cs_phi_t(&run->cs, run->q, here->t, phi_t);
    int status = dep_project_velocity(&st->mp, J, ++st->jacobian_ids, run->cs.nc, run->qd,
                                      phi_t, st->constraint_tol, qd_new, run->lam, slots,
                                      &report, &failure);
    if (status == DEP_PASS_FAILED) {
        return dep_run_pass_error(run, &failure, here->t);
    }
    dep_tally_observe(&run->tally, &report);
    dep_datum_number(change->data, &change->n_data, change->data_capacity,
                     "impact_energy_loss", dep_energy_loss(&run->system.mass, run->qd, qd_new));
    memcpy(run->qd, qd_new, (size_t)run->nq * sizeof(double));
    return DEP_OK;
}

/* _apply: the new constraint set and state; lambda restarts from pass 3. */
int dep_run_apply_change(dep_run *run, dep_change *change, const dep_state *here)
{
    int nq = run->nq, status = DEP_OK;
    for (int i = 0; i < change->n_remove; ++i) {
        dep_cs_remove(&run->cs, change->remove[i]);
    }
    for (int i = 0; i < change->n_add && status == DEP_OK; ++i) {
        status = dep_cs_add_row(&run->cs, &change->add[i], run->error);
    }
    if (status != DEP_OK) {
        return status;
    }
    memcpy(run->q, change->has_q ? change->q : here->q, (size_t)nq * sizeof(double));
    memcpy(run->qd, change->has_qd ? change->qd : here->qd, (size_t)nq * sizeof(double));
    memcpy(run->work, here->work, (size_t)run->nd * sizeof(double));
    if (change->impact && (status = impact(run, here, change)) != DEP_OK) {
        return status;
    }
    return dep_run_restart(run, here->t, run->q, run->qd, run->work, "state after the event");
}
