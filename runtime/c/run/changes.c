/* changes.c: what an event changes in a run: rows added and removed, a new state, a plastic
 * impact, then lambda again from pass 3 (run.h).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "run.h"

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
