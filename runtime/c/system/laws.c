/* laws.c: the hinge torques the integrator applies itself, in each hinge's mode
 * (docs/deployment.md): Coulomb friction, the one definition of it, and the push of a
 * compliant latch in contact; their dissipated powers and the latches' spring energies
 * (system.h). The generated model's force holds no hinge friction: it depends on the mode.
 */
#include <math.h>
#include <string.h>

#include "system.h"

/* ---- the laws ------------------------------------------------------------------------------ */

/* tanh(u) as 1 - 2 / (exp(2 |u|) + 1) with u's sign: within a few units of round-off of 1 in
   absolute terms (all the friction law needs), in a little over half of libm's tanh's time
   (5.4 against 9.5 ns for |u| < 2), which goes through expm1 for a relative accuracy near 0
   that nothing here uses. */
static double smooth_sign(double u)
{
    return copysign(1.0 - 2.0 / (exp(2.0 * fabs(u)) + 1.0), u);
}

/* A hinge's Coulomb friction torque on its angle (N m) at `rate` (rad/s): none while a latch,
   a stop or its stick row holds it (the row carries the torque); the exact -s friction while
   it slides in direction s with static friction; else -friction tanh(rate / slip_rate). */
double dep_friction_torque(const dep_hinge_mechanics *h, double rate)
{
    if (h->kinetic == 0.0 || dep_hinge_locked(h) || h->stuck) {
        return 0.0;
    }
    if (h->has_static) {
        return -h->direction * h->kinetic;
    }
    return -h->kinetic * smooth_sign(rate / h->slip_rate);
}

/* d(dep_friction_torque) / d rate (<= 0): the regularised law's damping, else none. */
double dep_friction_slope(const dep_hinge_mechanics *h, double rate)
{
    if (h->kinetic == 0.0 || dep_hinge_locked(h) || h->stuck || h->has_static) {
        return 0.0;
    }
    double c = 1.0 / cosh(rate / h->slip_rate);
    return -h->kinetic / h->slip_rate * (c * c);
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

static double overshoot(const dep_hinge_mechanics *h, double angle)
{
    return h->latch_side * (angle - h->latch);
}

double dep_contact_push(const dep_hinge_mechanics *h, double angle, double rate)
{
    return contact_torque(overshoot(h, angle), h->latch_side * rate, h->latch_stiffness,
                          h->latch_damping);
}

/* ---- torques, powers and energies of a system ------------------------------------------------ */

/* Whether any hinge torque acts now (friction anywhere, or a latch pressed). */
int dep_hinge_forcing(const dep_system *system)
{
    if (system->n_friction > 0) {
        return 1;
    }
    for (int i = 0; system->n_compliant > 0 && i < system->nh; ++i) {
        if (system->hinges[i].latch_state == DEP_CONTACT) {
            return 1;
        }
    }
    return 0;
}

/* Each hinge's friction torque at (q, qd) by its law (nh; 0 for a hinge without friction). */
void dep_friction_law(const dep_system *system, const double *q, const double *qd,
                      double *friction)
{
    system->model->hinge_rates(q, qd, system->p, system->rates);
    for (int i = 0; i < system->nh; ++i) {
        const dep_hinge_mechanics *h = &system->hinges[i];
        friction[i] = h->has_friction ? dep_friction_torque(h, system->rates[i]) : 0.0;
    }
}

/* The torques on the hinge angles (nh), to add as J^T tau to the model's force; the friction
   torques given (nh) or, with NULL, by the law. */
void dep_hinge_torques(const dep_system *system, const double *q, const double *rates,
                       const double *friction, double *tau)
{
    const dep_model *model = system->model;
    int have_angles = 0;
    memset(tau, 0, (size_t)system->nh * sizeof *tau);
    if (rates != system->rates) {
        memcpy(system->rates, rates, (size_t)system->nh * sizeof *rates);
    }
    for (int i = 0; i < system->nh; ++i) {
        const dep_hinge_mechanics *h = &system->hinges[i];
        double rate = rates[i];
        if (h->has_friction) {
            system->friction[i] = friction != NULL ? friction[i] : dep_friction_torque(h, rate);
            tau[i] += system->friction[i];
        }
        if (h->latch_state == DEP_CONTACT) {
            if (!have_angles) {
                model->hinge_angles(q, system->p, system->angles);
                have_angles = 1;
            }
            tau[i] -= h->latch_side * contact_torque(overshoot(h, system->angles[i]),
                                                     h->latch_side * rate,
                                                     h->latch_stiffness, h->latch_damping);
        }
    }
}

/* After the model's dissipated powers (power[0..model nd), filled by the caller): each
   friction hinge's -tau rate (>= 0), then each compliant latch's. */
void dep_hinge_dissipation(const dep_system *system, const double *q, const double *qd,
                           double *power)
{
    if (system->n_friction == 0 && system->n_compliant == 0) {
        return;
    }
    system->model->hinge_rates(q, qd, system->p, system->rates);
    for (int i = 0; i < system->nh; ++i) {
        const dep_hinge_mechanics *h = &system->hinges[i];
        if (h->has_friction) {
            system->friction[i] = dep_friction_torque(h, system->rates[i]);
        }
    }
    dep_hinge_power(system, q, power);
}

void dep_hinge_power(const dep_system *system, const double *q, double *power)
{
    int n = system->model->nd;
    for (int i = 0; i < system->nh; ++i) {
        if (system->hinges[i].has_friction) {
            power[n++] = -system->friction[i] * system->rates[i];
        }
    }
    if (system->n_compliant == 0) {
        return;
    }
    system->model->hinge_angles(q, system->p, system->angles);
    for (int i = 0; i < system->nh; ++i) {
        const dep_hinge_mechanics *h = &system->hinges[i];
        if (h->compliant) {
            double side = h->latch_side;
            power[n++] = h->latch_state != DEP_CONTACT ? 0.0
                : contact_power(overshoot(h, system->angles[i]), side * system->rates[i],
                                h->latch_stiffness, h->latch_damping);
        }
    }
}

/* After the model's energies (energy[0..model ne)): each compliant latch's spring energy. */
void dep_hinge_energy(const dep_system *system, const double *q, double *energy)
{
    int n = system->model->ne;
    if (system->n_compliant == 0) {
        return;
    }
    system->model->hinge_angles(q, system->p, system->angles);
    for (int i = 0; i < system->nh; ++i) {
        const dep_hinge_mechanics *h = &system->hinges[i];
        if (h->compliant) {
            energy[n++] = h->latch_state != DEP_CONTACT ? 0.0
                : contact_energy(overshoot(h, system->angles[i]), h->latch_stiffness);
        }
    }
}
