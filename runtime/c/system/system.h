/* system.h: the model bound to one parameter vector (runtime/c/README.md): its constant mass
 * matrix, factorised once; its hinges' properties and modes; the forces, powers and energies
 * of a run: the generated model's (depsim_model.h) plus the hinge torques the integrator
 * applies itself (Coulomb friction in each hinge's mode, the push of a compliant latch).
 *
 *   mass.c    the mass matrix, inverted if diagonal, else its envelope Cholesky factor
 *   hinges.c  each hinge's properties from hinge_properties, its mode, the joints' kinds
 *   laws.c    the hinge torque laws: friction, compliant contact; their powers and energies
 *   system.c  the system of a run: the model's forces with the hinge torques added
 */
#ifndef DEPSIM_SYSTEM_H
#define DEPSIM_SYSTEM_H

#include "../algebra/algebra.h"

/* ---- mass.c ------------------------------------------------------------------------------- */

typedef struct dep_mass {
    int n, nnz, diagonal;
    const int *rows, *cols;   /* the model's MASS_ROWS/COLS: where M is non-zero */
    double *values;           /* nnz: M there */
    double *entry_diagonal;   /* n: M_jj */
    double *inverse_diagonal; /* n, when diagonal */
    dep_envelope factor;      /* otherwise: M in envelope form and its Cholesky factor */
} dep_mass;

/* M^-1 (diagonal) or M's Cholesky factor (mass->values set); a SolverError naming the
   coordinate of a non-positive entry, or for a matrix that is not positive definite. */
int dep_mass_factor(dep_mass *mass, const char *const *coordinates, dep_arena *arena,
                    dep_error *error);
void dep_mass_solve(const dep_mass *mass, const double *b, double *x); /* x = M^-1 b; x may be b */
double dep_mass_quadratic(const dep_mass *mass, const double *x);     /* x^T M x */
/* M's envelope (first[i]: row i's first non-zero column) and its lower part into A (zero on
   entry) in envelope form e. */
void dep_mass_envelope_start(const dep_mass *mass, int *first);
void dep_mass_to_envelope(const dep_mass *mass, const dep_envelope *e, double *A);

/* ---- hinges.c ----------------------------------------------------------------------------- */

/* A hinge's runtime properties (from hinge_properties) and its mode. */
enum dep_latch_state { DEP_OPEN, DEP_LATCHED, DEP_CONTACT, DEP_APART };
enum dep_stop_state { DEP_STOP_NONE = 0, DEP_STOP_MIN = 1, DEP_STOP_MAX = 2 };

typedef struct dep_hinge_mechanics {
    int index;
    const char *name;
    int has_latch, compliant, has_stop_min, has_stop_max, has_static, has_friction;
    int has_hold, held; /* a hold-down until `release`; held now */
    double latch, latch_stiffness, latch_damping, stop_min, stop_max, release;
    double kinetic, static_friction, slip_rate; /* friction (N m), static (N m), rad/s */
    double latch_side, direction;
    int latch_state, stop, stuck; /* enum dep_latch_state, enum dep_stop_state, 0/1 */
} dep_hinge_mechanics;

int dep_hinge_locked(const dep_hinge_mechanics *h);   /* by a latch, a stop or a hold-down */
int dep_hinge_sliding(const dep_hinge_mechanics *h);  /* stick-slip, slipping */
/* "hinge", "slider" or "joint": the kind of the joint whose model row `row` is (messages). */
const char *dep_joint_kind(const dep_model *model, int row);
/* The slider (index into slider_names) that hinge entry k is, -1 for a hinge. */
int dep_hinge_slider(const dep_model *model, int k);
/* A hinge's reaction force rows: x, y and, in a spatial model, z. */
#define DEP_FORCE_ROWS 3
/* Each hinge's rows x, y, z (DEP_FORCE_ROWS nh) among the model's rows: its reaction force;
   -1: none (z in a planar model). */
void dep_hinge_force_rows(const dep_model *model, int *rows);
/* A hinge's force (DEP_FORCE_ROWS) from its rows (dep_hinge_force_rows) and the multipliers:
   NAN without rows, F_z 0 in a planar model. */
void dep_hinge_force(const int *rows, const double *lam, double *force);

/* ---- system.c ----------------------------------------------------------------------------- */

/* The model bound to p, with the forces the integrator applies itself: each hinge's Coulomb
   friction in its mode and the compliant latches' contact torques. Its dissipators are the
   model's, then "friction.<h>" for each hinge with friction, then "latch.<h>" for each
   compliant latch; its energies the model's, then "latch.<h>". */
typedef struct dep_system {
    const dep_model *model;
    const double *p;
    int nq, nd, nh, ne;
    dep_mass mass;
    dep_hinge_mechanics *hinges;     /* nh, every hinge */
    int n_friction, n_compliant;     /* hinges with friction, compliant latches */
    const char **dissipator_names;   /* nd */
    const char **energy_names;       /* ne */
    /* scratch: nh, nh, nh, nhnz (at HINGE_JACOBIAN_ROWS/COLS), nq; friction: nh, each
       friction hinge's torque at `rates` (set with them by dep_hinge_torques) */
    double *angles, *rates, *tau, *hinge_jacobian, *torque_force, *friction;
    /* nq: the size each coordinate's errors are measured against (the model's
       coordinate_scales: its length for a position, 1 for an angle), for its rate per second
       and its acceleration per second squared alike; and sum_j M_jj s_j^2 (J), a work's */
    double *scales, energy_scale;
    int *hinge_start; /* nh + 1: hinge h's entries of J_h are [hinge_start[h], hinge_start[h + 1]) */
} dep_system;

/* mechanics 0: every hinge free (friction by the regularised law, no latch or stop modes). */
int dep_system_init(dep_system *system, const dep_model *model, const double *p,
                    int mechanics, dep_arena *arena, dep_error *error);
/* hinges.c: system->hinges with their properties at system->p (mechanics as for
   dep_system_init), n_friction and n_compliant; a SETTINGS error for a friction law without a
   positive slip rate. */
int dep_hinges_read(dep_system *system, int mechanics, dep_arena *arena, dep_error *error);
/* out (nq) = J_h^T tau, J_h the hinge Jacobian's non-zeros (model->hinge_jacobian). */
void dep_hinge_transpose_times(const dep_system *system, const double *J_h, const double *tau,
                               double *out);
/* out (nh) = J_h x (the hinge rates for x = qd, as model->hinge_rates gives them). */
void dep_hinge_times(const dep_system *system, const double *J_h, const double *x, double *out);
void dep_system_force(const dep_system *system, const double *q, const double *qd, double t,
                      double *f);
void dep_system_dissipation(const dep_system *system, const double *q, const double *qd,
                            double t, double *power);
/* Both at one state, the hinge rates and friction torques evaluated once; the friction
   torques given (nh), or NULL for the law. */
void dep_system_force_power(const dep_system *system, const double *q, const double *qd,
                            double t, const double *friction, double *f, double *power);
void dep_system_energy(const dep_system *system, const double *q, const double *qd, double t,
                       double *energy);

/* ---- laws.c: the hinge torques the integrator applies (friction, compliant contact) ----- */

double dep_friction_torque(const dep_hinge_mechanics *h, double rate);
double dep_friction_slope(const dep_hinge_mechanics *h, double rate);
void dep_friction_law(const dep_system *system, const double *q, const double *qd,
                      double *friction);
int dep_hinge_forcing(const dep_system *system);
/* rates: the hinge rates at the state (nh), kept in system->rates for dep_hinge_power;
   friction: the friction torques (nh) to apply, or NULL for the law at those rates */
void dep_hinge_torques(const dep_system *system, const double *q, const double *rates,
                       const double *friction, double *tau);
void dep_hinge_dissipation(const dep_system *system, const double *q, const double *qd,
                           double *power);
/* The same from the rates and friction torques dep_hinge_torques left at (q, qd). */
void dep_hinge_power(const dep_system *system, const double *q, double *power);
void dep_hinge_energy(const dep_system *system, const double *q, double *energy);
/* A compliant latch's push max(0, k delta + c delta') (N m) on hinge h at `angle` and `rate`
   (its lock torque is -latch_side times it). */
double dep_contact_push(const dep_hinge_mechanics *h, double angle, double rate);

#endif /* DEPSIM_SYSTEM_H */
