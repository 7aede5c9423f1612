/* mechanism.c: the runtime's forces of the hinges' mechanics. Port of deployment.py's
 * MechanismSystem with friction.py and the formulas of latches.py (docs/deployment.md).
 *
 * While a hinge slides with stick-slip friction, is locked (its tanh friction cancelled) or
 * presses a compliant latch, the runtime adds its torque to the model's force, and its
 * dissipated power and spring energy to the model's.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "runtime.h"

/* ---- friction.py and latches.py: the formulas ------------------------------------------- */

/* +kinetic tanh(rate / slip_rate) cancels the model's regularised law; while sliding
   -direction kinetic is the exact Coulomb torque (N m). */
static double friction_torque(double rate, double kinetic, double slip_rate, double direction,
                              int sliding)
{
    double cancel = kinetic != 0.0 ? kinetic * tanh(rate / slip_rate) : 0.0;
    return sliding ? cancel - direction * kinetic : cancel;
}

static double friction_power(double rate, double kinetic, double direction, int sliding)
{
    return sliding ? direction * kinetic * rate : 0.0;
}

/* A compliant latch's push max(0, k delta + c delta') (N m) for the overshoot delta. */
static double contact_torque(double overshoot, double rate, double stiffness, double damping)
{
    return fmax(0.0, stiffness * overshoot + damping * rate);
}

static double contact_power(double overshoot, double rate, double stiffness, double damping)
{
    return (contact_torque(overshoot, rate, stiffness, damping) - stiffness * overshoot) * rate;
}

static double contact_energy(double overshoot, double stiffness)
{
    double pressed = fmax(overshoot, 0.0);
    return 0.5 * stiffness * (pressed * pressed);
}

/* ---- forces, powers and energies of the runtime terms ------------------------------------ */

int dep_mechanism_forcing(const dep_mechanism *m)
{
    for (int i = 0; i < m->n_hinges; ++i) {
        if (dep_hinge_owns_friction(&m->hinges[i]) || m->hinges[i].latch_state == DEP_CONTACT) {
            return 1;
        }
    }
    return 0;
}

/* The runtime torques on the hinge angles (nh), to add as J^T tau to the force. */
void dep_mechanism_torques(dep_mechanism *m, const double *q, const double *qd, double *tau)
{
    int have_angles = 0;
    memset(tau, 0, (size_t)m->model->nh * sizeof *tau);
    m->model->hinge_rates(q, qd, m->p, m->rates);
    for (int i = 0; i < m->n_hinges; ++i) {
        const dep_hinge_mechanics *h = &m->hinges[i];
        double rate = m->rates[h->index];
        if (dep_hinge_owns_friction(h)) {
            tau[h->index] += friction_torque(rate, h->kinetic, h->slip_rate, h->direction,
                                             dep_hinge_sliding(h));
        }
        if (h->latch_state == DEP_CONTACT) {
            if (!have_angles) {
                m->model->hinge_angles(q, m->p, m->angles);
                have_angles = 1;
            }
            double side = h->latch_side;
            double delta = side * (m->angles[h->index] - h->latch), delta_rate = side * rate;
            tau[h->index] -= side * contact_torque(delta, delta_rate, h->latch_stiffness,
                                                   h->latch_damping);
        }
    }
}

/* After the model's dissipated powers (power[0..nd), filled by the caller): the power of
   the friction the runtime owns in place of its "friction.<h>", then each compliant
   latch's. */
void dep_mechanism_dissipation(dep_mechanism *m, const double *q, const double *qd,
                               double *power)
{
    const dep_model *model = m->model;
    int n = model->nd, owned = 0;
    char name[DEP_NAME_MAX + 16];
    for (int i = 0; i < m->n_hinges; ++i) {
        owned |= dep_hinge_owns_friction(&m->hinges[i]);
    }
    if (owned || m->n_compliant > 0) {
        model->hinge_rates(q, qd, m->p, m->rates);
    }
    for (int i = 0; owned && i < m->n_hinges; ++i) {
        const dep_hinge_mechanics *h = &m->hinges[i];
        if (!dep_hinge_owns_friction(h)) {
            continue;
        }
        snprintf(name, sizeof name, "friction.%s", h->name);
        for (int d = 0; d < n; ++d) {
            if (strcmp(model->dissipator_names[d], name) == 0) {
                power[d] = friction_power(m->rates[h->index], h->kinetic, h->direction,
                                          dep_hinge_sliding(h));
            }
        }
    }
    if (m->n_compliant == 0) {
        return;
    }
    model->hinge_angles(q, m->p, m->angles);
    for (int i = 0; i < m->n_hinges; ++i) {
        const dep_hinge_mechanics *h = &m->hinges[i];
        if (h->compliant) {
            double side = h->latch_side, rate = m->rates[h->index];
            double delta = side * (m->angles[h->index] - h->latch);
            power[n++] = h->latch_state != DEP_CONTACT ? 0.0
                : contact_power(delta, side * rate, h->latch_stiffness, h->latch_damping);
        }
    }
}

/* Compliant latches' spring energies (J), after the model's `ne` terms in `energy`. */
void dep_mechanism_energy(dep_mechanism *m, const double *q, const double *qd, double *energy)
{
    int n = m->model->ne;
    (void)qd;
    if (m->n_compliant == 0) {
        return;
    }
    m->model->hinge_angles(q, m->p, m->angles);
    for (int i = 0; i < m->n_hinges; ++i) {
        const dep_hinge_mechanics *h = &m->hinges[i];
        if (h->compliant) {
            double delta = h->latch_side * (m->angles[h->index] - h->latch);
            energy[n++] = h->latch_state != DEP_CONTACT ? 0.0
                : contact_energy(delta, h->latch_stiffness);
        }
    }
}

/* Each hinge's lock torque (nh), NAN while free: -lambda of its lock rows, or the compliant
   latch's torque -side P while in contact. */
void dep_mechanism_hinge_torques(dep_mechanism *m, const double *q, const double *qd,
                                 const dep_constraints *cs, const double *lam, double *tau)
{
    int have = 0;
    dep_lock_torques(m->model, cs, lam, tau);
    for (int i = 0; i < m->n_hinges; ++i) {
        const dep_hinge_mechanics *h = &m->hinges[i];
        if (h->latch_state != DEP_CONTACT) {
            continue;
        }
        if (!have) {
            m->model->hinge_angles(q, m->p, m->angles);
            m->model->hinge_rates(q, qd, m->p, m->rates);
            have = 1;
        }
        double side = h->latch_side;
        double push = contact_torque(side * (m->angles[h->index] - h->latch),
                                     side * m->rates[h->index], h->latch_stiffness,
                                     h->latch_damping);
        tau[h->index] = -side * push;
    }
}

