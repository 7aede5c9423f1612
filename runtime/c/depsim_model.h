/* depsim_model.h: what the C integrator needs from a generated model.
 *
 * A generated model.c defines one `const dep_model depsim_model` filled with its sizes, name
 * tables and functions. The functions are those of docs/generated-module.md, with the same
 * names (prefixed `model_` in model.h) and argument order; the result arrays come last and
 * are written completely (zeros included). Every array holds doubles in SI units:
 * q, qd: nq; p: np; t: time (s). Empty tables are NULL.
 */
#ifndef DEPSIM_MODEL_H
#define DEPSIM_MODEL_H

#define DEP_MODEL_ABI 1 /* bumped whenever this struct changes */

typedef struct dep_model {
    int abi; /* DEP_MODEL_ABI of the header the model was compiled with */

    /* identity */
    const char *name;
    const char *description;
    const char *source_file;
    const char *source_sha256;
    const char *depsim_version;

    /* sizes: coordinates, constraint rows, parameters, non-zeros of Phi_q, hinges,
       hinge properties, sliders, outputs, energy terms, dissipators */
    int nq, nc, np, nnz, nh, nhp, ns, nout, ne, nd;

    /* name tables (NULL when empty) */
    const char *const *coordinate_names;     /* nq */
    const char *const *parameter_names;      /* np */
    const double *parameter_defaults;        /* np, SI */
    const char *const *parameter_units;      /* np */
    const char *const *constraint_names;     /* nc, "<joint>.<component>" */
    const char *const *constraint_joints;    /* nc */
    const int *phi_q_rows;                   /* nnz, row-major sorted */
    const int *phi_q_cols;                   /* nnz */
    const char *const *hinge_names;          /* nh */
    const char *const *hinge_property_names; /* nhp: columns of hinge_properties() */
    const char *const *slider_names;         /* ns */
    const char *const *output_names;         /* nout */
    const char *const *output_units;         /* nout */
    const char *const *energy_names;         /* ne */
    const char *const *dissipator_names;     /* nd */

    /* the model's simulation settings */
    double t_end, tol, dt_out;

    /* functions (docs/generated-module.md) */
    void (*mass_matrix)(const double *p, double *M);                 /* nq x nq, row-major */
    void (*initial_state)(const double *p, double *q0, double *qd0); /* nq, nq */
    void (*phi)(const double *q, double t, const double *p, double *phi);          /* nc */
    void (*phi_q)(const double *q, double t, const double *p, double *phi_q);      /* nnz */
    void (*phi_t)(const double *q, double t, const double *p, double *phi_t);      /* nc */
    void (*gamma)(const double *q, const double *qd, double t, const double *p,
                  double *gamma);                                                   /* nc */
    void (*force)(const double *q, const double *qd, double t, const double *p,
                  double *f);                                                       /* nq */
    void (*hinge_angles)(const double *q, const double *p, double *theta);          /* nh */
    void (*hinge_rates)(const double *q, const double *qd, const double *p,
                        double *theta_rate);                                        /* nh */
    void (*hinge_jacobian)(const double *q, const double *p, double *J);  /* nh x nq */
    void (*hinge_gamma)(const double *q, const double *qd, const double *p,
                        double *gamma_h);                                           /* nh */
    void (*hinge_properties)(const double *p, double *H);                /* nh x nhp */
    void (*outputs)(const double *q, const double *qd, double t, const double *p,
                    double *y);                                                     /* nout */
    void (*energy)(const double *q, const double *qd, double t, const double *p,
                   double *E);                                                      /* ne */
    void (*dissipation)(const double *q, const double *qd, double t, const double *p,
                        double *P);                                                 /* nd */
} dep_model;

#endif /* DEPSIM_MODEL_H */
