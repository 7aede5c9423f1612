/* method.h: the numerical method of Lee & Kim (runtime/c/README.md, docs/method.md): the
 * active constraint rows, the ODE methods and their dense output, the multipliers' profile
 * over a step and its predictor, step size control, events located on the dense output, the
 * iteration (6) with its S = Phi_q G Phi_q^T, and one step of the three passes. It sees a
 * system (system.h) and knows no latch, stop or run.
 *
 *   constraints.c  the active rows (the model's and those added by events), every level
 *   dopri.c        Dormand-Prince 5(4), its dense output, the quintic step interpolant
 *   rosenbrock.c   the linearly implicit step for stiff elastic forces (ROS34PW2)
 *   profile.c      lambda(t) over a step through the accepted multipliers; the predictor
 *   control.c      the step's error norms, the step size, the first step
 *   events.c       zero crossings of event functions located on the dense output
 *   schur.c        S = J G J^T: formed, factorised, kept and solved (or by CG)
 *   multipliers.c  the iteration (6)
 *   passes.c       pass 3 on any constraint set; the velocity projection of an impact
 *   stepper.c      the stepper's state and the motion's right side with lambda(t) given
 *   responses.c    the linearly implicit step's responses and the multipliers' filter
 *   friction.c     hinge friction prescribed over the step, settled to its law
 *   step.c         one step: the position, velocity and acceleration passes
 */
#ifndef DEPSIM_METHOD_H
#define DEPSIM_METHOD_H

#include "../system/system.h"

#define DEP_PASS_FAILED 100 /* internal: a pass did not converge */

/* ---- constraints.c: the active rows (the model's and those added by events) ----------- */

typedef struct dep_added_row {
    long long id; /* identity of a row, kept while it is active */
    int kind, hinge;
    int lock;     /* a lock row's enum dep_lock, else -1 */
    char name[DEP_NAME_MAX], joint[DEP_NAME_MAX];
    double angle, value;
    double *row; /* nq, DEP_ROW_LINEAR */
} dep_added_row;

typedef struct dep_constraints {
    const dep_system *system;
    int nq, nc_module, n_added, nc, capacity;
    long long next_id;
    dep_added_row added[DEP_MAX_ADDED];
    const char **row_names; /* capacity */
    const char **row_joints;
    double *theta, *hinge_jacobian, *row_values; /* scratch */
    /* Where the active rows' Jacobian can be non-zero: row i's columns are
       row_cols[row_start[i] .. row_start[i + 1]). The model's rows from PHI_Q_ROWS/COLS, a
       hinge lock from HINGE_JACOBIAN_ROWS/COLS, a linear row from its own non-zeros. A
       Jacobian J of the active rows holds exactly these entries, in this order: row i's
       values are J[row_start[i] .. row_start[i + 1]) (DEP_JACOBIAN_SIZE of them at most). */
    int *row_start, *row_cols;
    long long pattern;         /* changes whenever row_start and row_cols do */
    int *row_locks, *row_hinges; /* capacity: each active row's lock and hinge, or -1 */
} dep_constraints;

/* Doubles that hold a Jacobian of any active set: Phi_q's non-zeros and every added row's. */
#define DEP_JACOBIAN_SIZE(model) \
    ((size_t)(model)->nnz + (size_t)DEP_MAX_ADDED * (size_t)(model)->nq)

int dep_constraints_init(dep_constraints *cs, const dep_system *system, dep_arena *arena);
void dep_cs_phi(dep_constraints *cs, const double *q, double t, double *out);
void dep_cs_jacobian(dep_constraints *cs, const double *q, double t, double *J);
void dep_cs_jacobian_transpose_times(dep_constraints *cs, const double *q, double t,
                                     const double *lam, double *out);
void dep_cs_phi_t(dep_constraints *cs, const double *q, double t, double *out);
void dep_cs_gamma(dep_constraints *cs, const double *q, const double *qd, double t, double *out);
void dep_cs_v_vel(dep_constraints *cs, const double *q, const double *qd, double t,
                  const double *J, double *out);
void dep_cs_v_acc(dep_constraints *cs, const double *q, const double *qd, const double *qdd,
                  double t, const double *J, double *out);
void dep_cs_describe(const dep_constraints *cs, int row, char *joint_text, size_t size);
/* Products with a Jacobian J of the active rows (dep_cs_jacobian), over its pattern only:
   out = J x (nc), out = J^T y (nq). */
void dep_cs_times(const dep_constraints *cs, const double *J, const double *x, double *out);
void dep_cs_transpose_times(const dep_constraints *cs, const double *J, const double *y,
                            double *out);
/* What each row's residual is measured against: size_i = sum_j |J_ij| (s_j + |x_j|), s the
   coordinates' sizes (system->scales), x the pass's vector (q, qd or qdd): the change of the
   row that moving each coordinate by its weight's unit makes (docs/method.md, 2). */
void dep_cs_sizes(const dep_constraints *cs, const double *J, const double *x, double *size);
/* Both, out = J x and size, in one pass over the pattern. */
void dep_cs_times_sized(const dep_constraints *cs, const double *J, const double *x,
                        double *out, double *size);
/* out_i = sum_j |J_ij| m_j (m >= 0: the sizes of the terms x_j is made of, the round-off
   scale of J x); out_j = sum_i |J_ij| |y_i| (the sizes of the terms of J^T y). */
void dep_cs_abs_times(const dep_constraints *cs, const double *J, const double *m, double *out);
void dep_cs_abs_transpose_times(const dep_constraints *cs, const double *J, const double *y,
                                double *out);
int dep_cs_remove(dep_constraints *cs, const char *name);
int dep_cs_add(dep_constraints *cs, const dep_row *row, dep_error *error);
/* A row of an event callback (dep_row) as an added row: checked, named "<hinge>.lock" by
   default (HingeLock), its joint the hinge. */
int dep_cs_prepare_row(const dep_constraints *cs, const dep_row *row, dep_added_row *out,
                       dep_error *error);
int dep_cs_add_row(dep_constraints *cs, const dep_added_row *row, dep_error *error);
int dep_cs_index(const dep_constraints *cs, const char *name); /* -1 when not active */
/* The active row that locks `hinge` by `lock` (enum dep_lock), or -1; and its removal. */
int dep_cs_lock_index(const dep_constraints *cs, int lock, int hinge);
void dep_cs_remove_lock(dep_constraints *cs, int lock, int hinge);
/* "latch", "stop", "stick", "lock": a lock row's name is "<hinge>.<this>". */
const char *dep_lock_name(int lock);
/* The active rows as an event function sees them, with multipliers lam. */
dep_active_rows dep_cs_view(const dep_constraints *cs, const double *lam);
void dep_cs_assign(dep_constraints *cs, const dep_added_row *rows, int n);
int dep_check_consistency(dep_constraints *cs, double t, const double *q, const double *qd,
                          double tol, const char *stage, double *scratch, dep_error *error);
/* T_h = -lambda of each hinge's active lock rows (nh; the rows added at run time), NAN where
   none is active. */
void dep_lock_torques(const dep_model *model, const dep_constraints *cs, const double *lam,
                      double *torques);

/* ---- dopri.c: Dormand-Prince 5(4), its dense output, the quintic step interpolant ------- */

typedef void (*dep_rhs_function)(void *context, double t, const double *y, double *dy);

enum dep_ode_method { DEP_DOPRI, DEP_ROSENBROCK };

typedef struct dep_rk_step {
    int n;
    int method;        /* enum dep_ode_method: which method took the step */
    int order;         /* the power of h of its error estimate */
    double t0, h;
    const double *y0;
    /* n, n, 7 x n: DOPRI's stages; a Rosenbrock step keeps y' at its start and end in rows 0
       and 6 (its dense output is the cubic Hermite interpolant) */
    double *y1, *error, *K;
    /* Hairer's stiffness indicator h |lambda| ~ h |K7 - K6| / |y1 - y6| (it nears 3.3, the
       stability bound, where a stiff mode holds the step down) and y1 - y6, that mode's
       direction (n). */
    double stiffness, *mode;
} dep_rk_step;

int dep_rk_init(dep_rk_step *rk, int n, dep_arena *arena);
/* Dormand & Prince's tableau: the stages' times c, their coefficients a and the weights b of
   the fifth-order solution (the seventh stage is the step's end). */
extern const double dep_dopri_c[6], dep_dopri_a[6][5], dep_dopri_b[6];
void dep_dopri_step(dep_rk_step *rk, dep_rhs_function rhs, void *context, double t0,
                    const double *y0, const double *k1, double h, double *scratch);
void dep_dense_components(const dep_rk_step *rk, double t, int first, int count, double *out);
/* The interpolant's data: DEP_INTERPOLANT_ROWS x nq + DEP_INTERPOLANT_TAIL doubles. An
   acceleration marked weak (dep_acceleration_weak) is left out of the velocity interpolant. */
#define DEP_INTERPOLANT_ROWS 12
#define DEP_INTERPOLANT_TAIL 4
void dep_interpolant_data(double h, const double *q0, const double *qd0, const double *qdd0,
                          int qdd0_weak, const double *q1, const double *qd1,
                          const double *qdd1, int qdd1_weak, int nq, double *data);
void dep_interpolant_prior(double *data, int nq, double h, double h_prior, const double *qd,
                           const double *qdd, int qdd_weak);
void dep_interpolate(const double *data, double t0, double h, int nq, double t, double *q,
                     double *qd);

/* ---- rosenbrock.c: the linearly implicit step for stiff elastic forces ---------------- */

/* g = (qd, f - Phi_q^T lambda(t), work rates) at y = (q, qd, work): the motion's right side
   before the mass matrix. */
typedef void (*dep_force_function)(void *context, double t, const double *y, double *g);

/* ROS34PW2 (Rang & Angermann 2005), a W-method of order 3 for any Jacobian, applied to
   y = (q, qd, work) with the Jacobian [[0, I, 0], [-M^-1 K, -M^-1 D, 0], 0] of the stiff
   forces' K and D (the model's `stiffness`: beams, hinge springs and dampers, cables): each
   stage solves with
   W = M + gamma h D + gamma^2 h^2 K, factorised in envelope form. Because any T keeps the
   order, K, D and W are kept while the step size stays the same and K and D at the step's
   start are within DEP_JACOBIAN_DRIFT of them (dep_implicit_prepare). */
typedef struct dep_implicit {
    const dep_system *system;
    int nq, ny, nkz, damped;
    double *K, *D;          /* nkz, W's: at the start of the step that factorised it */
    double *K_now, *D_now;  /* nkz: at the step's start */
    double *K_drift, *D_drift; /* nkz: how far (squared) K_now, D_now may be from K, D */
    int *diagonal;          /* nq: where (j, j) sits in the stiffness pattern, -1 if absent */
    int *lower;             /* nkz: where entry k sits in W's envelope, -1 above the diagonal */
    double *mass_envelope;  /* M in W's envelope */
    double *K_envelope, *D_envelope; /* W's K and D in it (their lower triangles) */
    double *now_envelope;   /* K_now in it (dep_implicit_fastest) */
    dep_envelope W;
    double h;               /* W's step size; 0: none yet, or forgotten */
    long long id;           /* changes with every factorisation */
    double *g0;             /* ny: g at the step's start (stage 1 of every integration) */
    double *k, *arg, *g, *rhs; /* 4 ny, ny, ny, nq */
    /* scratch for up to DEP_RESPONSE_BLOCK vectors at once: sum 2 nq (at least ny), rhs and
       product nq, dk 4 x 2 nq (the stages of dep_implicit_response) */
    double *sum, *block_rhs, *product, *dk;
    double *block_x, *block_dq, *block_dqd; /* a caller's block: nq x DEP_RESPONSE_BLOCK each */
} dep_implicit;

#define DEP_RESPONSE_BLOCK 8
/* W is kept for a step of its size while every entry of K and D now is within this fraction
   of sqrt(K_ii K_jj) (sqrt(D_ii D_jj)) of W's, the scale a positive semi-definite matrix's
   entries have whatever the coordinates' units (2e-3 against 1e-3: 10 % less time on
   two_link_flex at 16 elements, chord2 5.4e-6 instead of 4.3e-6 rad; docs/method.md, 10) */
#define DEP_JACOBIAN_DRIFT 2e-3

int dep_implicit_init(dep_implicit *im, const dep_system *system, int ny, dep_arena *arena);
/* W for a step of size h from q: the last one while h is the same and K and D at q are
   within DEP_JACOBIAN_DRIFT of its own, else W anew from them (im->id changes); 0 when W is
   not positive definite. */
int dep_implicit_prepare(dep_implicit *im, const double *q, double h);
/* The next dep_implicit_prepare makes W anew (after an event or new inputs). */
void dep_implicit_forget(dep_implicit *im);
/* One step from (t0, y0), g0 = g(t0, y0) already in im->g0; four evaluations of g less one. */
void dep_rosenbrock_step(dep_implicit *im, dep_rk_step *rk, dep_force_function g,
                         void *context, double t0, const double *y0, double h);
/* The step end's linear response (dq, dqd) to adding x weight(t) to Phi_q^T lambda, weight
   given at the four stage times (dep_rosenbrock_times), for count <= DEP_RESPONSE_BLOCK
   vectors x at once (nq x count, entry j of vector v at [j count + v]; dq, dqd alike). */
void dep_implicit_response(dep_implicit *im, int count, const double *x,
                           const double weight[4], double *dq, double *dqd);
void dep_rosenbrock_times(double t0, double h, double times[4]);
/* sqrt of the largest eigenvalue of M^-1 K at q (rad/s), from below (power iteration). */
double dep_implicit_fastest(dep_implicit *im, const double *q);

/* ---- schur.c, multipliers.c: the iteration (6) with S = J G J^T ------------------------- */

enum dep_stage { DEP_POSITION = 0, DEP_VELOCITY = 1, DEP_ACCELERATION = 2 };
extern const char *const dep_stage_names[3];

#define DEP_MAX_ITERATIONS 25
#define DEP_SECANTS 8 /* secant corrections a pass keeps (multipliers.c) */
#define DEP_MAX_HALVINGS 4

typedef struct dep_pass_report {
    int stage, iterations, n_errors;
    int roundoff;    /* 1: it ended at the round-off of its residuals, above tol's limit */
    long long cg_iterations;
    double residual; /* max |v| at its end, in the rows' units */
    double errors[DEP_MAX_ITERATIONS + 1]; /* max_i |v_i| / size_i at each iterate */
} dep_pass_report;

/* Why a pass failed: what run/state.c tells the user, and what helps. */
enum dep_failure_kind {
    DEP_FAILED_STEP = 0,    /* not a constraint row: the step itself (row -1) */
    DEP_FAILED_NONFINITE,   /* the state or the forces became NaN or infinite */
    DEP_FAILED_INCONSISTENT, /* rows S's factor found dependent keep a residual: the
                                constraints cannot all hold here */
    DEP_FAILED_CONDITION,   /* S ill-conditioned beyond what the pass can resolve */
    DEP_FAILED_NONLINEAR    /* the update did not reduce the error at a well-conditioned S */
};

typedef struct dep_failure {
    int stage, row, kind; /* row -1: not a constraint row; kind: enum dep_failure_kind */
    double residual;      /* |v| of the row (its units) */
    double limit;         /* what it had to fall below there: tol times the row's size */
    double roundoff;      /* the round-off level of the row's residual */
    double condition;     /* about S's condition (1 / its smallest relative pivot; 0: S
                             was not factored) */
    int rank, rows;       /* the rank S's factor found, of `rows` */
    int weak_row;         /* the row of the smallest pivot (-1: none) */
    char reason[256];
    char hint[256]; /* with row -1: what to try ("": the state may not be finite) */
} dep_failure;

typedef struct dep_measurement {
    double *v;                 /* nc: the residual */
    double *size;              /* nc: what each row's residual is measured against
                                  (dep_cs_sizes) */
    double *magnitude;         /* nc: the size of the terms v_i is computed from (its
                                  round-off, over DEP_EPS), when measured `sized` */
    double *J_own;             /* nc x nq storage when the pass measures its own Jacobian */
    const double *J;           /* the Jacobian of v */
    long long jacobian_id;     /* identity of J's contents (the Schur cache key) */
    double *x;                 /* nq: the pass's vector (qd1, qdd, qd+) */
    dep_rk_step rk;            /* the position pass's trajectory */
} dep_measurement;

/* The pass's residual v at lam, and each row's size; with `sized`, magnitude too. */
typedef void (*dep_measure_function)(void *context, const double *lam, int sized,
                                     dep_measurement *out);

typedef void (*dep_mobility_function)(void *context, const double *x, double *out);

/* A small dense factor of S set aside while the passes see another mobility (schur.c). */
typedef struct dep_schur_kept {
    long long id, mobility, pattern; /* (id -1: none) */
    int nc, exact, dropped, min_row;
    double J_largest, min_pivot;
    double *S, *L, *diag, *J;
} dep_schur_kept;

#define DEP_SCHUR_KEPT 3 /* the linearly implicit step's position, velocity and acceleration S */

typedef struct dep_multipliers { /* scratch of the iteration and its Schur-complement cache */
    int nq, capacity;
    const dep_constraints *cs; /* the rows whose Jacobians (their pattern) the passes see */
    const dep_mass *mass;
    /* What a level sees of a generalized force x: M^-1 x, or mobility(context, x, out) when
       set (the linearly implicit step's response), identified by mobility_id (> 0) in the
       Schur cache key. */
    dep_mobility_function mobility;
    void *mobility_context;
    long long mobility_id, schur_mobility;
    long long schur_id, factorizations;
    int schur_nc, schur_explicit, schur_factored;
    int schur_exact;           /* 1: S was formed from the Jacobian schur_id names (not a nearby
                                  one that serves it) */
    int schur_dropped;         /* rows its factor dropped: S is singular (redundant rows, a
                                  singular position) */
    int schur_min_row;         /* the row of the smallest pivot its factor kept, relative to */
    double schur_min_pivot;    /* its diagonal (1 / it: about S's condition; -1, 1: none) */
    long long schur_pattern;   /* the rows' pattern (cs->pattern) S was formed for */
    double *schur_J;           /* the Jacobian's non-zeros S was formed from */
    double schur_J_largest;    /* and the largest of them in size */
    int schur_envelope;        /* 1: S and L held in envelope form (a diagonal mass matrix) */
    dep_schur_kept kept[DEP_SCHUR_KEPT]; /* other mobilities' factors; next: the one to reuse */
    int next_kept;
    dep_arena *arena;          /* grows S and L (room doubles each) and MinvJT (GJ_rows x nq)
                                  as they are first needed (schur_room) */
    size_t room, GJ_rows;
    int *first, *offset;       /* capacity: row a of S spans columns first[a]..a, from offset[a] */
    dep_envelope envelope;     /* that form: first, offset, S and L */
    long long envelope_pattern; /* the rows' pattern (cs->pattern) the form was laid out for */
    /* nq + 1, then per coordinate the rows touching it and their entries in J */
    int *column_start, *column_rows, *column_entries;
    double *S, *L, *diag, *MinvJT, *column; /* MinvJT: G J^T by rows, for an explicit S */
    double *x, *r, *z, *d, *Sd, *inv_diag, *step, *trial_lam, *work;
    /* The envelope's row order: row a at position rank[a] (order: the inverse), reverse
       Cuthill-McKee when it at least halves the envelope (permuted), else the rows' own. */
    int *rank, *order, *degree, permuted;
    double *permuted_in, *permuted_out;
    /* The iteration's secant corrections (multipliers.c): the step for a residual v is
       K v = S^-1 v / C + sum_k u_k (w_k . v), DEP_SECANTS pairs of capacity each; y: scratch */
    double *secant_u, *secant_w, *secant_y;
    int secants;
    double rank_drop;   /* the pivot, relative to its diagonal, below which a row is dropped */
    unsigned char *forced; /* capacity, factor order: rows the factor drops as combinations of
                              the rows before them (dep_schur_nulls) */
    int weak_nulls;        /* of the n_nulls: weak rows' combinations (not null to round-off:
                              a singular position's) */
    double *range;      /* capacity: a residual less its part along the null vectors */
    int null_max;       /* min(capacity, DEP_NULL_MAX) */
    double *nulls;      /* null_max x capacity: S's null vectors (orthonormal) for the */
    long long nulls_id; /* factor of the Jacobian with this id (-1: none) */
    int n_nulls;
} dep_multipliers;

int dep_multipliers_init(dep_multipliers *mp, const dep_mass *mass,
                         const dep_constraints *cs, int capacity, dep_arena *arena);
int dep_measurement_init(dep_measurement *m, const dep_model *model, int capacity, int ny,
                         int own_jacobian, dep_arena *arena);
/* S = J G J^T with G = mobility (NULL: M^-1) for the iterations that follow. */
void dep_multipliers_set_mobility(dep_multipliers *mp, dep_mobility_function mobility,
                                  void *context, long long id);
void dep_multipliers_apply(const dep_multipliers *mp, const double *x, double *out); /* G x */
int dep_iterate_multipliers(dep_multipliers *mp, int stage, double *lam, int nc,
                            dep_measure_function measure, void *context, double C, double tol,
                            dep_measurement *slots[2], dep_measurement **final,
                            dep_pass_report *report, dep_failure *failure);
/* The size of the terms a pass's residual v = b - J x is computed from, x = x0 - c M^-1 J^T
   lam (c: the pass's C): magnitude_i = |b_i| + sum_j |J_ij| (|x_j| + c (M^-1 |J^T| |lam|)_j)
   (b may be NULL). Its round-off is about DEP_EPS times that. */
void dep_pass_magnitude(dep_multipliers *mp, const double *J, int nc, const double *lam,
                        double c, const double *x, const double *b, double *magnitude);
/* The null vectors of the factor dep_schur_form left, one per dropped row and weak
   combination (up to mp->null_max), orthonormal, into mp->nulls; their count (nulls.c). */
int dep_schur_nulls(dep_multipliers *mp, int nc);
/* x (nc) less its parts along the null vectors mp->nulls (orthonormal). */
void dep_schur_deflate(const dep_multipliers *mp, int nc, double *x);
/* The factor of the S at hand again, dropping the rows mp->forced; 1 when factored. */
int dep_schur_refactor(dep_multipliers *mp, int nc);
/* x = S^-1 b for the rows J (nc x nq) with identity jacobian_id; 1 when solved. */
int dep_schur_solve(dep_multipliers *mp, const double *J, long long jacobian_id, int nc,
                    const double *b, double *x);
/* A row of S whose pivot is at most DEP_RANK_DROP of its diagonal depends on the rows before
   it to round-off: S's factor drops it (dep_envelope_factor). A combination of rows that
   keeps at most mp->rank_drop of their sizes (DEP_RANK_WEAK for the step's passes: a row
   within 3e-5 rad of the span of the others) is a direction of S's null space for the
   iteration, which takes the minimum-norm multipliers there (dep_schur_nulls, nulls.c;
   docs/method.md, 6a). */
#define DEP_RANK_DROP 1e-15
#define DEP_RANK_WEAK 1e-9
/* Null vectors of S the iteration handles (more: only the first). A chain of N parallelograms
   sharing their cranks gains N at its singular position. */
#define DEP_NULL_MAX 128
/* A Jacobian this close (relative) keeps the factor of S. */
#define DEP_SCHUR_REUSE 1e-6
/* S for the rows J (identity id): the factor at hand when it serves them (formed for them, or
   for the same rows and mobility at a Jacobian whose non-zeros all lie within `allowed` times
   J's largest of J's), a kept one that serves, else formed anew (allowed 0: the factor of J
   itself, formed anew unless the one at hand is of exactly these values). */
void dep_schur_form(dep_multipliers *mp, const double *J, long long id, int nc, double allowed);
/* x = S^-1 b (x may be b) with the S dep_schur_form left: by its factor, else by conjugate
   gradients (their iterations added to *iterations); 1 when solved. */
int dep_schur_solve_formed(dep_multipliers *mp, const double *J, int n, const double *b,
                           double *x, long long *iterations);
/* out (nq, all zero on entry) += J^T y over the first nc rows of the active pattern. */
void dep_multipliers_transpose_times(const dep_multipliers *mp, const double *J, int nc,
                                     const double *y, double *out);
/* passes.c: qd+ = qd - M^-1 J^T mu with J qd+ + phi_t = 0 by the iteration (6), C = 1. */
int dep_project_velocity(dep_multipliers *mp, const double *J, long long jacobian_id, int nc,
                         const double *qd, const double *phi_t, double tol, double *qd_new,
                         double *mu, dep_measurement *slots[2], dep_pass_report *report,
                         dep_failure *failure);

/* ---- profile.c, control.c: the multipliers' profile and predictor, step size control -- */

#define DEP_HISTORY 4         /* accepted multipliers kept: a cubic profile and its error */
#define DEP_PROFILE_NODES 3   /* at most this many of them shape a step's profile */

typedef struct dep_history {
    int count, nc;
    double t[DEP_HISTORY];
    double *lam[DEP_HISTORY]; /* oldest first; capacity each */
    double *miss;             /* capacity: the predictor's miss at the last accepted step */
    double miss_h, applied;   /* that step's h (0: none since the reset), the share of the
                                 miss in the last guess */
    int miss_count;           /* the accepted points the guess was made from at that step */
} dep_history;

/* lambda(t) over a step t0 -> t0 + h: the polynomial through the last `nodes` accepted
   multipliers (at u_j <= 0 in step units u = (t - t0) / h) and the step's unknown end value
   at u = 1 (docs/method.md, section 2). `position` and `velocity` are the integrals of the end
   value's basis polynomial l(u): integral_0^1 (1 - u) l(u) du and integral_0^1 l(u) du, so
   that d q_{i+1} = -h^2 position M^-1 Phi_q^T d lambda_{i+1} for frozen Phi_q (the C of the
   iteration (6)) and d qd_{i+1} = -h velocity M^-1 Phi_q^T d lambda_{i+1}. With Phi_q
   linear in time between its values at the step's start and end, the start's share:
   `position_start` and `velocity_start`, the same integrals weighted by 1 - u. `lagged`:
   integral_0^1 (1 - u)^2 / 2 l(u) du, what a force growing over the step like the velocity's
   response, integral_0^u l, moves q_{i+1} by per h^2 (times velocity; step.c). */
typedef struct dep_profile {
    double t0, h;
    int nodes;
    double u[DEP_PROFILE_NODES];
    const double *lam[DEP_PROFILE_NODES];
    double inverse[DEP_PROFILE_NODES + 1]; /* 1 / prod_{m != j} (u_j - u_m), u_nodes = 1 */
    double position, velocity, position_start, velocity_start, lagged;
    double excursion; /* integral_0^1 (1 - u) |prod_j (u - u_j) (u - 1)| du */
    double drift;     /* integral_0^1 |prod_j (u - u_j) (u - 1)| du: the velocities' share */
} dep_profile;

int dep_history_init(dep_history *history, int capacity, dep_arena *arena);
void dep_history_reset(dep_history *history, double t, const double *lam, int nc);
void dep_history_add(dep_history *history, double t, const double *lam);
void dep_profile_set(dep_profile *profile, const dep_history *history, double h, int most);
void dep_profile_hold(dep_profile *profile, double t0, const double *lam);
void dep_profile_value(const dep_profile *profile, const double *lam_end, double t, int nc,
                       double *out);
double dep_profile_end_weight(const dep_profile *profile, double t); /* l(u) of the end value */
void dep_profile_share(dep_profile *to, const dep_profile *from, const dep_history *history);
void dep_history_weights(const dep_history *history, const dep_profile *profile,
                         double *weights);
void dep_history_predict(dep_history *history, const dep_profile *profile,
                         const double *weights, double *out);
void dep_history_learn(dep_history *history, double h, const double *guess, const double *found);
/* scale = tol (floors + max(|y0|, |y1|)) componentwise: what an error of each is measured
   against (floors: the stepper's, the sizes of the coordinates, rates and works). */
void dep_weights(const double *y0, const double *y1, int n, double tol, const double *floors,
                 double *scale);
double dep_rms(const double *x, const double *scale, int n);
int dep_divided_difference(const dep_profile *profile, const dep_history *history,
                           const double *end, double *d, double *scratch);
/* A step's errors in tolerance units (1: at tolerance), control.c. */
typedef struct dep_step_errors {
    double ode;       /* the ODE method's (DOPRI 5(4) or ROS34PW2), tangential part */
    int ode_order;    /* its power of h */
    double lam;       /* the interpolation of the multipliers and of prescribed friction */
    int lam_order;    /* its power of h */
    double friction;  /* the velocity error of prescribed friction's interpolation */
    int friction_order; /* its power of h; 0: none */
} dep_step_errors;

double dep_step_error(const dep_step_errors *errors);
double dep_step_factor(const dep_step_errors *errors, double err_previous, int accepted);
double dep_convergence_factor(const dep_pass_report *report);
double dep_initial_step(dep_rhs_function rhs, void *context, double t0, const double *y0,
                        const double *f0, int n, int order, double tol,
                        const double *floors, double span, double *scratch);

/* ---- events.c: zero crossings located on the dense output ------------------------------ */

/* The dense output inside a step: q, qd at t and, when `rows` is not NULL, the multipliers
   there (acceleration pass). */
typedef int (*dep_dense_function)(void *context, double t, double *q, double *qd,
                                  dep_active_rows *rows);

typedef struct dep_watch {
    dep_event *events; /* the user's, then the mechanism's */
    int count, needs_multipliers;
    int *hits;
    double *values;
} dep_watch;

int dep_watch_init(dep_watch *watch, const dep_event *events, int count,
                   const dep_event *more, int n_more, dep_arena *arena, dep_error *error);
int dep_event_value(const dep_event *event, double t, const double *q, const double *qd,
                    const dep_active_rows *rows, double *g, dep_error *error);
int dep_watch_reset(dep_watch *watch, double t, const double *q, const double *qd, int fired,
                    double side, const dep_active_rows *rows, dep_error *error);
int dep_first_crossing(dep_watch *watch, double t0, double t1, const double *q1,
                       const double *qd1, const dep_active_rows *rows1,
                       dep_dense_function dense, void *context, double *q, double *qd,
                       dep_active_rows *rows, int *index, double *t_root, double *side,
                       dep_error *error);

/* ---- passes.c, stepper.c, responses.c, friction.c, step.c: one step of the method ------- */

/* Pass 3 on any constraint set: lambda (in: the guess) and qdd at (q, qd, t) from (1) and
   (2c). Buffers: f, jt, solved (nq), gamma (nc). */
typedef struct dep_acceleration_work {
    const dep_system *system;
    dep_constraints *cs;
    dep_multipliers *mp;
    dep_measurement *slots[2];
    double *f, *jt, *solved, *gamma;
    /* NULL: accelerations M^-1 (f - J^T lambda); else filter(context, f - J^T lambda, out)
       (dep_filtered_pass) */
    dep_mobility_function filter;
    void *filter_context;
} dep_acceleration_work;

/* passes.c */
int dep_acceleration_pass(dep_acceleration_work *w, const double *q, const double *qd,
                          double t, const double *J, long long jacobian_id, double *lam,
                          double *qdd, double tol, dep_pass_report *report,
                          dep_failure *failure);
/* After dep_acceleration_pass at the same state (its f and gamma): lambda (in: that pass's)
   for which J G (f - J^T lambda) = gamma, G = filter (mp's mobility must be the same G). */
int dep_filtered_pass(dep_acceleration_work *w, dep_mobility_function filter, void *context,
                      const double *J, long long jacobian_id, double *lam, double tol,
                      dep_pass_report *report, dep_failure *failure);

typedef struct dep_state {
    double t;
    double *q, *qd, *qdd, *lam, *work;
    int qdd_weak; /* qdd from a nearly singular S (dep_acceleration_weak) */
} dep_state;

typedef struct dep_outcome {
    dep_state state;
    const dep_rk_step *rk;   /* the trajectory (valid until the next step) */
    const double *J1;        /* Phi_q at the new state */
    long long J1_id;         /* its identity (the Schur cache key) */
    const double *lam_position; /* lambda_{i+1} as the position pass left it */
    double *data;            /* 12 x nq + 1: the step interpolant (dep_interpolant_data) */
    dep_pass_report reports[3];
    int integrations;
    dep_profile profile;     /* the step's lambda(t) (its history part; the end is the state's) */
    /* With friction prescribed over the step (friction.c): its profile, and the friction law
       at the new state (nh), the end value the profile was iterated to. */
    int prescribed;
    dep_profile friction_profile;
    double *friction;
    double friction_rate;    /* max_k C_k (J_h Mc^-1 J_h^T)_kk (1/s): its fastest damping */
    int friction_hinge;      /* the hinge k of that damping */
    int friction_coupled;    /* hinges whose damping mattered to the end value's Newton step */
} dep_outcome;

/* forces.c: the constraint forces F = Phi_q^T lambda prescribed over a step near a singular
   position, instead of the multipliers: their profile through the accepted forces and the end
   value Phi_q(q_e)^T lambda_{i+1} (q_e: the step's predicted end), projected onto the rows'
   normal space at every evaluation by the stage's own S. */
typedef struct dep_forces {
    dep_profile profile;  /* over the accepted forces (nq each), the multipliers' times */
    double *end;          /* nq: the end value Phi_q(q_e)^T lambda_{i+1} */
    double *end_J;        /* Phi_q(q_e), fixed for the step */
    double *predicted;    /* nq: q_e */
    dep_multipliers stage; /* the stages' S and factors */
    double *stage_J, *moved, *rows; /* scratch: Phi_q at a stage, nq, capacity */
} dep_forces;

int dep_forces_init(dep_forces *forces, const dep_system *system, dep_constraints *cs,
                    dep_arena *arena);
void dep_forces_begin(dep_forces *forces, dep_constraints *cs, const dep_state *start,
                      double h, const double *prior_qdd, double prior_h);
void dep_forces_multipliers(dep_forces *forces, dep_constraints *cs, const dep_mass *mass,
                            const double *force, long long jacobian_id, double *lam);
void dep_forces_end(dep_forces *forces, const dep_constraints *cs, const double *lam_end);
void dep_forces_value(dep_forces *forces, dep_constraints *cs, const dep_mass *mass,
                      const double *q, double t, long long jacobian_id, double *out);

typedef struct dep_stepper {
    const dep_system *system;
    dep_constraints *constraints;
    dep_multipliers mp;
    int nq, ny, capacity;
    double tol, constraint_tol;
    /* ny: the absolute part of each component's weight, tol (floor + |y|): the size of each
       coordinate (system->scales) for it and its rate, energy_scale for the works */
    double *floors;
    long long rhs_evaluations, integrations, jacobian_ids;
    dep_measurement slots[6], *final_position;
    /* the step being taken */
    const dep_state *start;
    double h, t1;
    dep_profile profile;  /* lambda(t) over the step */
    const double *rhs_end;  /* its end value for the next rhs calls */
    double *y0, *k1, *rhs_lam, *force, *jt_lam, *scratch;
    const double *known_force; /* f for the next right side instead of an evaluation, or NULL */
    /* The linearly implicit step's last acceleration pass: f at (q, qd) = end_state and end_t
       (NaN: none, after a restart; start_force) */
    double *end_force, *end_state, end_t;
    dep_rk_step base;       /* the step's last integration, for lambda_{i+1} = base_lam */
    double *base_lam, *base_J; /* nc; nc x nq: Phi_q at its end */
    long long base_J_id;
    double *miss;           /* 4 nq + 2 capacity: linear_miss's vectors and scratch */
    double *start_J, *start_Jh, *start_force; /* Phi_q, J_h at the step's start (start_made);
                                               M^-1 of the start's, end's column (2 nq) */
    int start_made;
    double *q1, *phi_t1, *lam_pos, *lam_solved;
    double *lam_first; /* lambda_{i+1} as the first round's position pass found it */
    int base_valid, integrations_this_step;
    double *restart_J;
    dep_acceleration_work accel;
    /* The linearly implicit step (models with beams), and its response's scratch */
    int implicit;
    dep_implicit im;
    long long mobility_ids;
    double *filter_block, *filter_S, *filter_rhs; /* history_multipliers' block (responses.c) */
    /* G J^T and J G J^T kept for the W (filter_id) and J they were made at */
    double *filter_GJ, *filter_JGJ, *filter_J;
    long long filter_id, filter_pattern;
    double *dq, *dqd, *column;
    /* The step's response to a unit force on each coordinate the active rows touch:
       slot[j] (-1: untouched), columns + 2 nq slot[j] = (dq, dqd); weight: l(u) at the
       stage times. At most max_slots: the coordinates any constraint or lock row can touch.
       They depend on W, the weights and the active rows, and are kept while those are:
       responses_id is the im->id they were computed with (-1: none) */
    int *slot, n_slots, max_slots;
    double *columns, weight[4];
    long long responses_id;
    /* Hinge friction prescribed over the step like the multipliers (DOPRI steps of a model
       with friction): its profile through the accepted friction torques and an end value,
       iterated until the friction law at the step's end gives it back. */
    int prescribed;
    dep_profile friction_profile;
    double *friction_end, *friction_base, *friction_now; /* nh: end value, base's, at t */
    double *base_Jh, *Jh;   /* nhnz: J_h at the base's end, at the new state */
    double *law, *residual, *residual_end, *slope, *law_scratch, *dtau; /* nh */
    double *lam_shift;      /* capacity */
    int *free_hinges, n_free; /* the coupled hinges: damping that matters at this step */
    double *mobile;         /* n_free x nq: Mc^-1 J_h^T e_k, constrained M^-1 at the end */
    double *mobile_lam;     /* n_free x capacity: S^-1 J M^-1 J_h^T e_k, lambda's part */
    double *newton;         /* n_free x n_free: I + h V C J_h Mc^-1 J_h^T */
    double friction_rate;   /* max_k C_k (J_h Mc^-1 J_h^T)_kk at the last round 0 (1/s) */
    int friction_hinge;     /* its hinge */
    /* by_force 1: the step prescribes the constraint forces (forces.c) instead of the
       multipliers */
    int by_force;
    dep_forces forces;
} dep_stepper;

double dep_constraint_tolerance(double tol);
int dep_stepper_init(dep_stepper *stepper, const dep_system *system, dep_constraints *cs,
                     double tol, dep_arena *arena);
int dep_state_init(dep_state *state, int nq, int capacity, int nd, dep_arena *arena);
void dep_state_copy(dep_state *to, const dep_state *from, int nq, int nc, int nd);
int dep_outcome_init(dep_outcome *outcome, int nq, int capacity, int nd, int nh,
                     dep_arena *arena);
void dep_stepper_derivative(dep_stepper *stepper, const dep_state *state, double *dy);
void dep_stepper_rhs(void *context, double t, const double *y, double *dy);
int dep_stepper_tangential(dep_stepper *stepper, const double *J, long long J_id, double *v,
                           double *scratch);
/* The works of the frictions prescribed over the last step (work: nfriction, after the
   model's own dissipators) moved with the end positions q moved by dq: -tau d(theta), tau the
   friction's end value. What a position correction does to them; it is the part of their
   error that a correction carries away (run/steps.c, tangential_error). */
void dep_stepper_work_move(dep_stepper *stepper, const double *q, const double *dq,
                           double *work);
void dep_stepper_set_rhs(dep_stepper *stepper, const dep_profile *profile,
                         const double *lam_end);
/* 1 when the acceleration pass just made (its factor of S at hand) solved an S whose
   smallest pivot is below DEP_WEAK_ACCELERATION of its diagonal: a singular position's
   neighbourhood, where the pass deflates its weak directions and qdd along them carries the
   velocity level's residual over their strength; the dense output then interpolates the
   velocities without that acceleration (method/dopri.c). */
#define DEP_WEAK_ACCELERATION 1e-5
int dep_acceleration_weak(const dep_stepper *stepper);
int dep_acceleration(dep_stepper *stepper, const double *q, const double *qd, double t,
                     double *lam, const double *J, long long jacobian_id, double *qdd,
                     dep_pass_report *report, dep_failure *failure);


/* Room for the linearly implicit step (done by dep_stepper_init for a model with stiff
   forces; with none, its T is the kinematic part alone: still a W-method of order 3). */
int dep_stepper_prepare_implicit(dep_stepper *stepper, dep_arena *arena);
/* The multipliers' G of the last step's pass (DEP_POSITION, DEP_VELOCITY), M^-1 otherwise. */
void dep_stepper_use_mobility(dep_stepper *stepper, int stage);
/* friction_profile, friction_predicted: NULL, or the friction torques' profile and predicted
   end value (a model with hinge friction; DOPRI steps). */
int dep_step(dep_stepper *stepper, const dep_state *state, const dep_profile *profile,
             const double *lam_predicted, const dep_profile *friction_profile,
             const double *friction_predicted, dep_outcome *outcome, dep_failure *failure);


/* ---- between the step's files (stepper.c, responses.c, friction.c, step.c) --------------- */

/* The passes' iteration tolerance as a fraction of tol (dep_constraint_tolerance), and the
   limit of the friction's end value (friction.c) in the same units. */
#define DEP_CONSTRAINT_FRACTION 0.01
/* Up to this many rows history_multipliers (responses.c) applies the filter to every row's J^T
   in one block of solves (filter_rows, kept while W and J are) and solves for the
   multipliers' change with the n x n matrix J G J^T (one update of (6) with A = (J G J^T)^-1:
   the condition is linear in lambda); with more, by the iteration (6) with the Schur cache's
   A. */
#define DEP_FILTER_DIRECT_ROWS 16
#define DEP_FRICTION_ROUNDS 8 /* end values of the friction torques tried before a step fails */

/* stepper.c: g = (qd, f - Phi_q^T lambda(t), work rates), the Rosenbrock step's right side. */
void dep_stepper_stage_force(void *context, double t, const double *y, double *g);
/* responses.c: the Rosenbrock step's responses to a unit force on each coordinate the active
   rows touch, kept while W, the profile's end weights and the rows are the same. */
void dep_stepper_unit_responses(dep_stepper *stepper);
/* The step end's response (stepper->dq, dqd) to adding x l(u) to the constraint forces
   Phi_q^T lambda over the step (x: nq, a generalized force). */
void dep_stepper_respond(dep_stepper *stepper, const double *x);
/* The constraint force of lambda_{i+1} changed by lam - from, Phi_q frozen at J, into
   stepper->column. */
void dep_stepper_lam_column(dep_stepper *stepper, const double *J, const double *lam,
                            const double *from);
/* The response to lambda_{i+1} changed by lam - from (nought without a change). */
void dep_stepper_respond_to(dep_stepper *stepper, const double *J, const double *lam,
                            const double *from);
/* Under the linearly implicit step: the multipliers the new state keeps, and qdd at them. */
int dep_stepper_history_multipliers(dep_stepper *stepper, dep_state *new, dep_failure *failure);
/* friction.c: 1 when the friction law at the new state gives back the prescribed end value,
   else 0 with the end value (and lambda_{i+1}) moved by Newton's step. */
int dep_stepper_friction_settled(dep_stepper *stepper, const double *q1, const double *qd1,
                                 int round, const dep_measurement *pos);
/* The failure of a step whose friction did not settle. */
int dep_stepper_friction_failure(const dep_stepper *stepper, dep_failure *failure);

#endif /* DEPSIM_METHOD_H */
