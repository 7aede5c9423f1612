/* algebra.h: the linear algebra of the integrator core (runtime/c/README.md): symmetric
 * positive definite matrices in envelope (skyline) form and their Cholesky factor, the row
 * order that keeps an envelope narrow (reverse Cuthill-McKee), small dense solves and norms.
 * Nothing here knows a model or the method.
 *
 *   envelope.c  the envelope form, its factor and solves
 *   ordering.c  reverse Cuthill-McKee over a sparse row pattern; an envelope's size in an order
 *   dense.c     small dense solves, max |v|
 */
#ifndef DEPSIM_ALGEBRA_H
#define DEPSIM_ALGEBRA_H

#include "../base/base.h"

/* ---- envelope.c ---------------------------------------------------------------------------- */

/* A symmetric positive definite matrix in envelope (skyline) form and its Cholesky factor,
   which fills nothing outside the envelope: row i holds columns first[i]..i, from offset[i].
   A band of width b costs O(n b^2) to factor and O(n b) to solve. */
typedef struct dep_envelope {
    int n;
    int *first, *offset; /* n, n + 1 */
    double *A, *L;       /* offset[n] each */
    double *inverse;     /* n: 1 / L_ii (the solves multiply: a division's latency would
                            set their pace, each row waiting on the one before); 0 for a row
                            the factor dropped */
    int dropped;         /* rows the last semi-definite factor dropped */
    double min_pivot;    /* and the smallest pivot it kept relative to its row's diagonal, */
    int min_row;         /* at this row (1 / min_pivot: about the condition of A scaled to a
                            unit diagonal) */
} dep_envelope;

#define DEP_ENVELOPE_AT(e, M, i, j) ((M)[(e)->offset[i] + (j) - (e)->first[i]])

/* Room for the envelope whose row i starts at column first[i] <= i (copied); A zeroed. */
int dep_envelope_init(dep_envelope *e, int n, const int *first, dep_arena *arena);
/* The Cholesky factor of A; 0 when A is not positive definite to working precision. With
   drop > 0, A positive semi-definite: a row whose pivot is at most drop times its diagonal
   depends on the rows before it and is dropped (its column of L and its inverse pivot are 0,
   so a solve gives the solution with that component nought: the basic solution of a
   consistent system); e->dropped counts them. */
int dep_envelope_factor(dep_envelope *e, double drop, const unsigned char *forced);
void dep_envelope_solve(const dep_envelope *e, const double *b, double *x); /* x may be b */
/* The same for `count` right sides at once, interleaved: entry i of side v at [i count + v]. */
void dep_envelope_solve_block(const dep_envelope *e, int count, const double *b, double *x);
/* out = A x for the symmetric matrix whose lower envelope is `values` (e's layout). */
void dep_envelope_times(const dep_envelope *e, const double *values, const double *x,
                        double *out);

/* ---- ordering.c ------------------------------------------------------------------------------ */

/* A sparse pattern of n rows over m columns seen both ways: row a's columns are
   row_cols[row_start[a] .. row_start[a + 1]), column j's rows column_rows[column_start[j] ..
   column_start[j + 1]) in ascending order. Two rows are adjacent when they share a column. */
typedef struct dep_pattern {
    int n, m;
    const int *row_start, *row_cols;
    const int *column_start, *column_rows;
} dep_pattern;

/* Reverse Cuthill-McKee over the rows: rank[a], row a's position, keeping each row near the
   rows it couples to. order, degree: n ints of scratch. */
void dep_reverse_cuthill_mckee(const dep_pattern *pattern, int *order, int *degree, int *rank);
/* The entries of the envelope of the pattern's row-by-row product (row a against row b where
   they share a column) with row a at position rank[a]: each position's first column into
   first (n). */
size_t dep_envelope_size(const dep_pattern *pattern, const int *rank, int *first);

/* ---- dense.c ------------------------------------------------------------------------------- */

/* x = (L L^T)^-1 b for a dense lower Cholesky factor L (n x n), the components of rows whose
   pivot L_ii is 0 (dropped) nought; x may be b. */
void dep_cholesky_solve(const double *L, int n, const double *b, double *x);
/* x = A^-1 b for the n x n matrix A (row-major, overwritten), by elimination with partial
   pivoting; b is overwritten by x. */
void dep_solve_small(int n, double *A, double *b);
/* max_i |v_i|; NaN (the first) when v holds one. */
double dep_max_abs(const double *v, int n);

#endif /* DEPSIM_ALGEBRA_H */
