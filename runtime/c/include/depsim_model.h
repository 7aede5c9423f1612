/* depsim_model.h: what the integrator needs from a model. GENERATED from
 * depsim/runtime/interface.py, depsim/dsl/attributes.py and depsim/dsl/limits.py
 * (python -m depsim.codegen.interface_header); do not edit.
 *
 * A generated model.c defines one `const dep_model depsim_model` filled with its
 * sizes, name tables and functions; a NumPy module is seen through the same struct.
 * The functions have the names of docs/generated-module.md (prefixed `model_` in
 * model.h) and its argument order; the result arrays come last and are written
 * completely (zeros included). Arrays hold doubles in SI units: q, qd: nq; p: np;
 * t: time (s). Matrices are row-major. Empty tables are NULL.
 */
#ifndef DEPSIM_MODEL_H
#define DEPSIM_MODEL_H

#define DEP_MODEL_ABI 14 /* bumped whenever this struct changes */

/* The columns of hinge_properties (HINGE_PROPERTIES): the hinge attributes the
   integrator applies itself (docs/language.md, hinge), SI; nan where not given. */
enum dep_hinge_property {
    DEP_HINGE_LATCH = 0, /* rad */
    DEP_HINGE_LATCH_STIFFNESS = 1, /* N*m/rad */
    DEP_HINGE_LATCH_DAMPING = 2, /* N*m*s/rad */
    DEP_HINGE_STOP_MIN = 3, /* rad */
    DEP_HINGE_STOP_MAX = 4, /* rad */
    DEP_HINGE_FRICTION = 5, /* N*m */
    DEP_HINGE_STATIC_FRICTION = 6, /* N*m */
    DEP_HINGE_SLIP_RATE = 7, /* rad/s */
    DEP_HINGE_RELEASE = 8, /* s */
    DEP_HINGE_PROPERTIES = 9 /* their count: every model's nhp */
};
/* Their names, in column order (an initializer of const char *[]). */
#define DEP_HINGE_PROPERTY_NAMES \
    {"latch", \
     "latch_stiffness", \
     "latch_damping", \
     "stop_min", \
     "stop_max", \
     "friction", \
     "static_friction", \
     "slip_rate", \
     "release"}

/* What a range check of the parameters asks of its value (limit_kinds; the
   model text's checks, depsim.dsl.limits). */
enum dep_limit_kind {
    DEP_LIMIT_POSITIVE = 0,
    DEP_LIMIT_NONNEGATIVE = 1,
    DEP_LIMIT_NONZERO = 2,
    DEP_LIMIT_BELOW = 3,
    DEP_LIMIT_AT_LEAST = 4
};

typedef struct dep_model {
    int abi; /* DEP_MODEL_ABI of the header the model was compiled with */

    /* identity */
    const char *name;
    const char *description;
    const char *source_file;
    const char *source_sha256;
    const char *depsim_version;

    /* sizes */
    int nq; /* coordinates */
    int nc; /* constraint rows */
    int np; /* parameters */
    int nnz; /* structural non-zeros of Phi_q */
    int nh; /* hinges */
    int nhp; /* hinge properties */
    int ns; /* sliders */
    int nout; /* outputs */
    int ne; /* energy terms */
    int nd; /* dissipators */
    int nv; /* joints of the assembly tree */
    int ni; /* inputs (external loads a run or a co-simulation drives) */
    int nhnz; /* structural non-zeros of hinge_jacobian */
    int nkz; /* structural non-zeros of the stiffness (0: no beams) */
    int nmz; /* structural non-zeros of the mass matrix */
    int nfix; /* structural parameters (loop bounds, indices): fixed */
    int nw; /* run values outputs may use: nh + nd + 4 */
    int nsys; /* the system's quantities of system_state */
    int nlim; /* range checks of the parameters (the model text's) */
    int nlimp; /* (range check, parameter) pairs it depends on */
    int tangents; /* 1: the tangent functions below are generated, 0: they are NULL */

    /* tables (NULL when empty) */
    const char *const *coordinate_names; /* nq */
    const char *const *parameter_names; /* np */
    const double *parameter_defaults; /* np, SI */
    const char *const *parameter_units; /* np, SI unit text */
    const char *const *constraint_names; /* nc, "<joint>.<component>" */
    const char *const *constraint_joints; /* nc */
    const int *constraint_hinges; /* nc, the hinge (index into hinge_names) whose row it is, -1 for none; a hinge's rows in component order (x, y): its reaction force */
    const int *constraint_sliders; /* nc, the slider (index into slider_names) whose row it is, -1 for none */
    const int *phi_q_rows; /* nnz, row-major sorted */
    const int *phi_q_cols; /* nnz */
    const char *const *hinge_names; /* nh */
    const char *const *hinge_property_names; /* nhp, columns of hinge_properties() */
    const int *hinge_wraps; /* nh, 1: the angle is measured within half a turn of the middle of its travel (a spatial hinge, atan2) and the motion depends on it, so a run stops where it turns past that; 0: it is continuous (a planar hinge, a slider's entry) or nothing loads by it */
    const char *const *slider_names; /* ns */
    const char *const *output_names; /* nout */
    const char *const *output_units; /* nout */
    const char *const *energy_names; /* ne */
    const char *const *dissipator_names; /* nd */
    const char *const *tree_joints; /* nv, the joints placing the members at t = 0, in placement order */
    const int *tree_held; /* nv, 1: its initial value is given, 2: its rate, 3: both (held by the assembly) */
    const int *hinge_jacobian_rows; /* nhnz, row-major sorted: where d theta / d q can be non-zero (a lock row's pattern) */
    const int *hinge_jacobian_cols; /* nhnz */
    const char *const *input_names; /* ni */
    const char *const *input_units; /* ni, SI unit text */
    const int *input_slots; /* ni, u_k(t) = p[slot] + p[slot + 1] t: the parameters holding input k */
    const int *stiffness_rows; /* nkz, row-major sorted: where the stiff forces' Jacobian can be non-zero */
    const int *stiffness_cols; /* nkz */
    const int *mass_rows; /* nmz, row-major sorted: where the mass matrix is non-zero (its diagonal for rigid bodies) */
    const int *mass_cols; /* nmz */
    const char *const *fixed_names; /* nfix, structural parameters: fixed in the model text, not in p */
    const int *fixed_values; /* nfix, their values */
    const char *const *run_value_names; /* nw, "<h>.torque" per hinge, "work.<dissipator>" per dissipator, then "work.friction", "work.latch", "work.impacts", "energy.latch" */
    const char *const *system_state_names; /* nsys, columns of system_state(): mass, com_x, com_y, momentum_x, momentum_y, angular_momentum (about the centre of mass) */
    const char *const *limit_names; /* nlim, what each range check tests, e.g. "rod.length", in the model text's order */
    const int *limit_kinds; /* nlim, enum dep_limit_kind: value > 0, >= 0, != 0, < bound, >= bound */
    const char *const *limit_messages; /* nlim, the check broken in words, a printf format of the value and the bound (%g each, in that order; %% a percent sign) */
    const int *limit_parameter_rows; /* nlimp, row-major sorted: range check i depends on parameter j */
    const int *limit_parameter_cols; /* nlimp */

    /* the model's simulation settings */
    double t_end, tol, dt_out;

    /* functions (docs/generated-module.md) */
    /* Values of the constant mass matrix M at (MASS_ROWS, MASS_COLS). */
    void (*mass_matrix)(const double *p, double *M);
    /* The tree joints' initial values and rates (given, else 0). */
    void (*tree_values)(const double *p, double *v0, double *vd0);
    /* The pose placed along the assembly tree with joint values v, shape (NQ,). */
    void (*tree_pose)(const double *v, const double *p, double *q);
    /* d tree_pose / d v times the joint rates vd: the tree's velocities, shape (NQ,). */
    void (*tree_tangent)(const double *v, const double *vd, const double *p, double *qd);
    /* Given initial angle and rate of each hinge closing a loop (nan: not given). */
    void (*loop_targets)(const double *p, double *angle, double *rate);
    /* Constraint residuals Phi(q, t), shape (NC,). */
    void (*phi)(const double *q, double t, const double *p, double *phi);
    /* Values of Phi_q at (PHI_Q_ROWS, PHI_Q_COLS). */
    void (*phi_q)(const double *q, double t, const double *p, double *phi_q);
    /* Phi_q^T lam for multipliers lam (NC,): the constraints' generalized force, shape (NQ,). */
    void (*phi_q_transpose_times)(const double *q, double t, const double *p, const double *lam, double *f);
    /* dPhi/dt, shape (NC,). */
    void (*phi_t)(const double *q, double t, const double *p, double *phi_t);
    /* Right side of Phi_q qdd = gamma, shape (NC,). */
    void (*gamma)(const double *q, const double *qd, double t, const double *p, double *gamma);
    /* Generalized applied force f = -dV/dq + damping (no hinge friction), shape (NQ,). */
    void (*force)(const double *q, const double *qd, double t, const double *p, double *f);
    /* Hinge angles theta (rad), shape (NH,). */
    void (*hinge_angles)(const double *q, const double *p, double *theta);
    /* Hinge angle rates (rad/s), shape (NH,). */
    void (*hinge_rates)(const double *q, const double *qd, const double *p, double *theta_rate);
    /* Values of d theta / d q at (HINGE_JACOBIAN_ROWS, HINGE_JACOBIAN_COLS). */
    void (*hinge_jacobian)(const double *q, const double *p, double *J);
    /* -(J qd)_q qd per hinge: a locked hinge adds the row J qdd = hinge_gamma. */
    void (*hinge_gamma)(const double *q, const double *qd, const double *p, double *gamma_h);
    /* HINGE_PROPERTIES of each hinge (SI; nan: not given), shape (NH, NHP). */
    void (*hinge_properties)(const double *p, double *H);
    /* The named outputs, shape (NOUT,), from the state, the model rows' multipliers lam (NC,) and the run values w (NW,). */
    void (*outputs)(const double *q, const double *qd, double t, const double *p, const double *lam, const double *w, double *y);
    /* The whole system's mass (kg), centre of mass (m), momentum (N*s) and angular momentum about its centre of mass (N*m*s), in the order of SYSTEM_STATE. */
    void (*system_state)(const double *q, const double *qd, const double *p, double *s);
    /* Kinetic energy and each potential (J), in the order of ENERGIES. */
    void (*energy)(const double *q, const double *qd, double t, const double *p, double *E);
    /* Power removed by each element of DISSIPATORS (W). */
    void (*dissipation)(const double *q, const double *qd, double t, const double *p, double *P);
    /* The size (SI) each coordinate's errors are measured against: the model's length (its largest member's) for a position, 1 for an angle or a beam's slope. */
    void (*coordinate_scales)(const double *p, double *s);
    /* The stiff forces' Jacobian of a model with beams, K ~ -df/dq and D ~ -df/dqd, at (STIFFNESS_ROWS, STIFFNESS_COLS). */
    void (*stiffness)(const double *q, const double *p, double *K, double *D);
    /* Each range check's value and its bound (kinds below and at_least; else 0). */
    void (*parameter_checks)(const double *p, double *value, double *bound);

    /* tangents (docs/generated-module.md): NULL unless the model was compiled with them */
    /* d/de mass_matrix(p + e dp) at e = 0: values at (MASS_ROWS, MASS_COLS), shape (NMZ,). */
    void (*mass_matrix_tangent)(const double *p, const double *dp, double *dM);
    /* d/de tree_values(p + e dp) at e = 0, shapes dv0 (NV,), dvd0 (NV,). */
    void (*tree_values_tangent)(const double *p, const double *dp, double *dv0, double *dvd0);
    /* d/de tree_pose(v + e dv, p + e dp) at e = 0, shape (NQ,). */
    void (*tree_pose_tangent)(const double *v, const double *p, const double *dv, const double *dp, double *dq);
    /* d/de tree_tangent(v + e dv, vd + e dvd, p + e dp) at e = 0, shape (NQ,). */
    void (*tree_tangent_tangent)(const double *v, const double *vd, const double *p, const double *dv, const double *dvd, const double *dp, double *dqd);
    /* d/de loop_targets(p + e dp) at e = 0, shapes dangle (NH,), drate (NH,); 0 where the base is nan (not given). */
    void (*loop_targets_tangent)(const double *p, const double *dp, double *dangle, double *drate);
    /* d/de phi(q + e dq, t, p + e dp) at e = 0, shape (NC,). */
    void (*phi_tangent)(const double *q, double t, const double *p, const double *dq, const double *dp, double *dphi);
    /* d/de phi_q(q + e dq, t, p + e dp) at e = 0: values at (PHI_Q_ROWS, PHI_Q_COLS), shape (NNZ,). */
    void (*phi_q_tangent)(const double *q, double t, const double *p, const double *dq, const double *dp, double *dphi_q);
    /* d/de phi_t(q + e dq, t, p + e dp) at e = 0, shape (NC,). */
    void (*phi_t_tangent)(const double *q, double t, const double *p, const double *dq, const double *dp, double *dphi_t);
    /* d/de gamma(q + e dq, qd + e dqd, t, p + e dp) at e = 0, shape (NC,). */
    void (*gamma_tangent)(const double *q, const double *qd, double t, const double *p, const double *dq, const double *dqd, const double *dp, double *dgamma);
    /* d/de force(q + e dq, qd + e dqd, t, p + e dp) at e = 0, shape (NQ,). */
    void (*force_tangent)(const double *q, const double *qd, double t, const double *p, const double *dq, const double *dqd, const double *dp, double *df);
    /* d/de hinge_angles(q + e dq, p + e dp) at e = 0, shape (NH,). */
    void (*hinge_angles_tangent)(const double *q, const double *p, const double *dq, const double *dp, double *dtheta);
    /* d/de hinge_rates(q + e dq, qd + e dqd, p + e dp) at e = 0, shape (NH,). */
    void (*hinge_rates_tangent)(const double *q, const double *qd, const double *p, const double *dq, const double *dqd, const double *dp, double *dtheta_rate);
    /* d/de hinge_jacobian(q + e dq, p + e dp) at e = 0: values at (HINGE_JACOBIAN_ROWS, HINGE_JACOBIAN_COLS), shape (NHNZ,). */
    void (*hinge_jacobian_tangent)(const double *q, const double *p, const double *dq, const double *dp, double *dJ);
    /* d/de hinge_gamma(q + e dq, qd + e dqd, p + e dp) at e = 0, shape (NH,). */
    void (*hinge_gamma_tangent)(const double *q, const double *qd, const double *p, const double *dq, const double *dqd, const double *dp, double *dgamma_h);
    /* d/de hinge_properties(p + e dp) at e = 0, shape (NH, NHP); 0 where the base is nan (a property not given). */
    void (*hinge_properties_tangent)(const double *p, const double *dp, double *dH);
    /* d/de outputs(q + e dq, qd + e dqd, t, p + e dp, lam + e dlam, w + e dw) at e = 0, shape (NOUT,); with IEEE arithmetic, as outputs (nan or inf outside a function's domain). */
    void (*outputs_tangent)(const double *q, const double *qd, double t, const double *p, const double *lam, const double *w, const double *dq, const double *dqd, const double *dp, const double *dlam, const double *dw, double *dy);
} dep_model;

#endif /* DEPSIM_MODEL_H */
