/* system.h: the integrator's memory, errors and settings checks, the mass matrix, the
 * hinges' properties and the model bound to one parameter vector (system.c, errors.c,
 * mechanism.c)
 */
#ifndef DEPSIM_SYSTEM_H
#define DEPSIM_SYSTEM_H

#include <stddef.h>
#include "depsim.h"

#define DEP_EPS 2.220446049250313e-16 /* double machine epsilon */
#define DEP_PASS_FAILED 100           /* internal: a pass did not converge  */

/* ---- system.c: memory, errors, the mass matrix, the model bound to p ------------------ */

typedef struct dep_arena { /* every allocation of a run, freed at once */
    void **blocks;
    int count, capacity;
    int failed;
} dep_arena;

double *dep_doubles(dep_arena *arena, size_t n); /* zeroed; NULL (and arena->failed) on failure */
void *dep_bytes(dep_arena *arena, size_t n); /* zeroed */
/* not zeroed: for a large block whose parts are set before they are read (calloc clears
   memory that a long-lived process, a study's worker, has used before: megabytes a run) */
void *dep_bytes_unset(dep_arena *arena, size_t n);
void dep_arena_free(dep_arena *arena);

void dep_error_clear(dep_error *error);
void dep_copy_text(char *to, size_t size, const char *from);
/* Python's SolverError(what, t=, stage=, row=, joint=, residual=, hint=): fills every field and
   the formatted message. Pass has_t/has_residual 0 and NULL strings for None. */
int dep_solver_error(dep_error *error, int has_t, double t, const char *stage, const char *row,
                     const char *joint, int has_residual, double residual, const char *what,
                     const char *hint);
int dep_plain_error(dep_error *error, int code, const char *message);
void dep_repr(double value, char *out, size_t size); /* Python's repr(float) */
/* open: dep_open's settings (t_end may be INFINITY; dt_out and tables unused). */
int dep_check_settings(const dep_model *model, const double *p, const dep_settings *settings,
                       int open, dep_error *error);

/* A symmetric positive definite matrix in envelope (skyline) form and its Cholesky factor,
   which fills nothing outside the envelope: row i holds columns first[i]..i, from offset[i].
   A band of width b costs O(n b^2) to factor and O(n b) to solve. */
typedef struct dep_envelope {
    int n;
    int *first, *offset; /* n, n + 1 */
    double *A, *L;       /* offset[n] each */
    double *inverse;     /* n: 1 / L_ii (the solves multiply: a division's latency would
                            set their pace, each row waiting on the one before) */
} dep_envelope;

#define DEP_ENVELOPE_AT(e, M, i, j) ((M)[(e)->offset[i] + (j) - (e)->first[i]])

/* Room for the envelope whose row i starts at column first[i] <= i (copied); A zeroed. */
int dep_envelope_init(dep_envelope *e, int n, const int *first, dep_arena *arena);
int dep_envelope_factor(dep_envelope *e); /* 0 when not positive definite to working precision */
void dep_envelope_solve(const dep_envelope *e, const double *b, double *x); /* x may be b */
/* The same for `count` right sides at once, interleaved: entry i of side v at [i count + v]. */
void dep_envelope_solve_block(const dep_envelope *e, int count, const double *b, double *x);
/* out = A x for the symmetric matrix whose lower envelope is `values` (e's layout). */
void dep_envelope_times(const dep_envelope *e, const double *values, const double *x,
                        double *out);

typedef struct dep_mass {
    int n, nnz, diagonal;
    const int *rows, *cols;   /* the model's MASS_ROWS/COLS: where M is non-zero */
    double *values;           /* nnz: M there */
    double *entry_diagonal;   /* n: M_jj */
    double *inverse_diagonal; /* n, when diagonal */
    dep_envelope factor;      /* otherwise: M in envelope form and its Cholesky factor */
} dep_mass;

void dep_mass_solve(const dep_mass *mass, const double *b, double *x); /* x = M^-1 b; x may be b */
double dep_mass_quadratic(const dep_mass *mass, const double *x);     /* x^T M x */
/* M's envelope (first[i]: row i's first non-zero column) and its lower part into A (zero on
   entry) in envelope form e. */
void dep_mass_envelope_start(const dep_mass *mass, int *first);
void dep_mass_to_envelope(const dep_mass *mass, const dep_envelope *e, double *A);
/* x = (L L^T)^-1 b for a dense lower Cholesky factor L (n x n); x may be b. */
void dep_cholesky_solve(const double *L, int n, const double *b, double *x);

struct dep_mechanism;

/* A hinge's runtime properties (from hinge_properties) and its mode. */
enum dep_latch_state { DEP_OPEN, DEP_LATCHED, DEP_CONTACT, DEP_APART };
enum dep_kind { DEP_KIND_LATCH, DEP_KIND_STOP_MIN, DEP_KIND_STOP_MAX, DEP_KIND_STICK };
enum dep_stop_state { DEP_STOP_NONE = 0, DEP_STOP_MIN = 1, DEP_STOP_MAX = 2 };

typedef struct dep_hinge_mechanics {
    int index;
    const char *name;
    int has_latch, compliant, has_stop_min, has_stop_max, has_static, has_friction;
    double latch, latch_stiffness, latch_damping, stop_min, stop_max;
    double kinetic, static_friction, slip_rate; /* friction (N m), static (N m), rad/s */
    double latch_side, direction;
    int latch_state, stop, stuck; /* enum dep_latch_state, enum dep_stop_state, 0/1 */
} dep_hinge_mechanics;

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
    struct dep_mechanism *mechanism; /* NULL: no latch, stop or stick-slip (or mechanics off) */
    const char **dissipator_names;   /* nd */
    const char **energy_names;       /* ne */
    /* scratch: nh, nh, nh, nhnz (at HINGE_JACOBIAN_ROWS/COLS), nq; friction: nh, each
       friction hinge's torque at `rates` (set with them by dep_hinge_torques) */
    double *angles, *rates, *tau, *hinge_jacobian, *torque_force, *friction;
} dep_system;

/* mechanics 0: every hinge free (friction by the regularised law, no latch or stop modes). */
int dep_system_init(dep_system *system, const dep_model *model, const double *p,
                    int mechanics, dep_arena *arena, dep_error *error);

/* mechanism.c: the hinge torques the integrator applies (friction, compliant contact). */
double dep_friction_torque(const dep_hinge_mechanics *h, double rate);
double dep_friction_slope(const dep_hinge_mechanics *h, double rate);
void dep_friction_law(const dep_system *system, const double *q, const double *qd,
                      double *friction);
int dep_hinge_forcing(const dep_system *system);
/* friction: the friction torques (nh) to apply, or NULL for the law at (q, qd) */
void dep_hinge_torques(const dep_system *system, const double *q, const double *qd,
                       const double *friction, double *tau);
void dep_hinge_transpose_times(const dep_system *system, const double *J_h, const double *tau,
                               double *out);
void dep_hinge_dissipation(const dep_system *system, const double *q, const double *qd,
                           double *power);
/* The same from the rates and friction torques dep_hinge_torques left at (q, qd). */
void dep_hinge_power(const dep_system *system, const double *q, double *power);
void dep_hinge_energy(const dep_system *system, const double *q, double *energy);
const char *dep_joint_kind(const dep_system *system, const char *joint);
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

#endif /* DEPSIM_SYSTEM_H */
