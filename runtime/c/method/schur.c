/* schur.c: S = J G J^T for the multiplier iteration (6) (multipliers.c): G is M^-1, or the
 * linearly implicit step's response (a mobility). With a diagonal mass matrix (rigid bodies)
 * S is formed once per Jacobian from the non-zeros of Phi_q alone (S_ab = sum_j J_aj J_bj /
 * M_jj over the coordinates both rows touch) and held in envelope (skyline) form, row a from
 * its first non-zero column, the rows in reverse Cuthill-McKee order when that makes the
 * envelope at least a quarter smaller: a chain's rows give a band, so forming and factorising S costs O(n) per
 * Jacobian instead of O(n^3). With another mass matrix (beams), S is formed densely below
 * EXPLICIT_BELOW rows. Its Cholesky factor is made once per Jacobian and reused by every pass
 * and trial that sees it, and small dense factors of other mobilities are kept aside; above
 * that size, or when S is singular (a dead point, redundant rows), S is solved by
 * Jacobi-preconditioned conjugate gradients (products with Phi_q, G, Phi_q^T only)
 * (method.h).
 */
#include <math.h>
#include <string.h>

#include "method.h"

/* The rows' own order is kept unless reverse Cuthill-McKee's envelope is below this share of
   its envelope: a spatial model's rows (each body's six frame rows, then the joints') hold
   their envelope at 0.6 of the model's order, an order that places the rows body by body
   keeps its own within a few rows. */
#define RCM_KEEP 0.75
#define EXPLICIT_BELOW 96 /* form S (nc x nc) once per Jacobian below this many rows */
#define CG_RTOL 1e-10
/* Under the linearly implicit step the passes see three mobilities (position, velocity: the
   step's responses; acceleration: M^-1), each for its own S; a dense factor of up to
   KEPT_ROWS rows is set aside when another mobility's is formed, and taken back while it
   serves (dep_schur_form). */
#define KEPT_ROWS 16

/* Room for S and L of `size` entries each (schur_room: allocated as first needed, twice that
   when more is needed; an envelope of a few rows needs a few dozen, a dense S of 95 rows
   9,025), and for the dense S's G J^T rows (nc x nq); 0 when out of memory. */
static int schur_room(dep_multipliers *mp, size_t size, int nc)
{
    if (size > mp->room) {
        size_t room = 2 * size;
        double *S = dep_doubles(mp->arena, room), *L = dep_doubles(mp->arena, room);
        if (S == NULL || L == NULL) {
            return 0;
        }
        mp->S = mp->envelope.A = S;
        mp->L = mp->envelope.L = L;
        mp->room = room;
    }
    if ((size_t)nc > mp->GJ_rows) {
        size_t rows = 2 * (size_t)nc < (size_t)mp->capacity ? 2 * (size_t)nc : (size_t)mp->capacity;
        double *GJ = dep_doubles(mp->arena, rows * (size_t)mp->nq);
        if (GJ == NULL) {
            return 0;
        }
        mp->MinvJT = GJ;
        mp->GJ_rows = rows;
    }
    return 1;
}

int dep_multipliers_init(dep_multipliers *mp, const dep_mass *mass,
                         const dep_constraints *cs, int capacity, dep_arena *arena)
{
    size_t nc = (size_t)capacity, nq = (size_t)cs->nq;
    memset(mp, 0, sizeof *mp);
    mp->nq = cs->nq;
    mp->cs = cs;
    mp->capacity = capacity;
    mp->mass = mass;
    mp->schur_id = -1;
    mp->envelope_pattern = -1;
    mp->arena = arena;
    mp->first = dep_bytes(arena, nc * sizeof *mp->first);
    mp->offset = dep_bytes(arena, (nc + 1) * sizeof *mp->offset);
    mp->envelope = (dep_envelope){0, mp->first, mp->offset, mp->S, mp->L,
                                  dep_doubles(arena, nc + 1), 0, 1.0, -1};
    mp->column_start = dep_bytes(arena, (nq + 1) * sizeof *mp->column_start);
    mp->schur_J = dep_doubles(arena, DEP_JACOBIAN_SIZE(cs->system->model));
    for (int k = 0; k < DEP_SCHUR_KEPT; ++k) {
        dep_schur_kept *kept = &mp->kept[k];
        kept->id = -1;
        kept->S = dep_doubles(arena, KEPT_ROWS * KEPT_ROWS);
        kept->L = dep_doubles(arena, KEPT_ROWS * KEPT_ROWS);
        kept->diag = dep_doubles(arena, KEPT_ROWS);
        kept->J = dep_doubles(arena, DEP_JACOBIAN_SIZE(cs->system->model));
    }
    mp->column_rows = dep_bytes(arena, DEP_JACOBIAN_SIZE(cs->system->model) * sizeof(int));
    mp->column_entries = dep_bytes(arena, DEP_JACOBIAN_SIZE(cs->system->model) * sizeof(int));
    mp->column = dep_doubles(arena, nq);
    mp->work = dep_doubles(arena, nq);
    double **vectors[] = {&mp->diag, &mp->x, &mp->r, &mp->z, &mp->d, &mp->Sd, &mp->inv_diag,
                          &mp->step, &mp->trial_lam, &mp->permuted_in, &mp->permuted_out};
    int **orders[] = {&mp->rank, &mp->order, &mp->degree};
    for (size_t i = 0; i < sizeof orders / sizeof *orders; ++i) {
        *orders[i] = dep_bytes(arena, (nc + 1) * sizeof(int));
    }
    for (size_t i = 0; i < sizeof vectors / sizeof *vectors; ++i) {
        *vectors[i] = dep_doubles(arena, nc);
    }
    mp->secant_u = dep_doubles(arena, DEP_SECANTS * nc);
    mp->secant_w = dep_doubles(arena, DEP_SECANTS * nc);
    mp->secant_y = dep_doubles(arena, nc);
    mp->null_max = nc < DEP_NULL_MAX ? (int)nc : DEP_NULL_MAX;
    mp->nulls = dep_doubles(arena, (size_t)mp->null_max * nc + 1);
    mp->range = dep_doubles(arena, nc);
    mp->nulls_id = -1;
    mp->rank_drop = DEP_RANK_DROP;
    mp->forced = dep_bytes(arena, (size_t)nc + 1);
    return arena->failed ? DEP_MEMORY_ERROR : DEP_OK;
}

void dep_multipliers_set_mobility(dep_multipliers *mp, dep_mobility_function mobility,
                                  void *context, long long id)
{
    mp->mobility = mobility;
    mp->mobility_context = context;
    mp->mobility_id = mobility != NULL ? id : 0;
}

void dep_multipliers_apply(const dep_multipliers *mp, const double *x, double *out)
{
    if (mp->mobility != NULL) {
        mp->mobility(mp->mobility_context, x, out);
    } else {
        dep_mass_solve(mp->mass, x, out);
    }
}

static double dot(const double *a, const double *b, int n)
{
    double sum = 0.0;
    for (int i = 0; i < n; ++i) {
        sum += a[i] * b[i];
    }
    return sum;
}

/* out (nc) = J x over the active rows' pattern. */
static void times(const dep_multipliers *mp, const double *J, int nc, const double *x,
                  double *out)
{
    const int *start = mp->cs->row_start, *cols = mp->cs->row_cols;
    for (int a = 0; a < nc; ++a) {
        double sum = 0.0;
        for (int k = start[a]; k < start[a + 1]; ++k) {
            sum += J[k] * x[cols[k]];
        }
        out[a] = sum;
    }
}

/* out (nq, all zero on entry) += J^T y over the pattern. */
void dep_multipliers_transpose_times(const dep_multipliers *mp, const double *J, int nc,
                                     const double *y, double *out)
{
    const int *start = mp->cs->row_start, *cols = mp->cs->row_cols;
    for (int a = 0; a < nc; ++a) {
        for (int k = start[a]; k < start[a + 1]; ++k) {
            out[cols[k]] += J[k] * y[a];
        }
    }
}

/* The Cholesky factor of the explicit S (lower, in mp->L), semi-definite: a row whose pivot is
   at most DEP_RANK_DROP of its diagonal depends on the rows before it and is dropped (its
   column of L nought; mp->schur_dropped counts them); the smallest pivot kept relative to its
   diagonal and its row into mp->schur_min_pivot, schur_min_row. 0 when a pivot is negative
   or NaN (conjugate gradients then handle a consistent singular system). */
static int factor_schur(dep_multipliers *mp, int nc)
{
    const double *S = mp->S;
    double *L = mp->L;
    mp->schur_dropped = 0;
    mp->schur_min_pivot = 1.0;
    mp->schur_min_row = -1;
    for (int j = 0; j < nc; ++j) {
        for (int i = j; i < nc; ++i) {
            double sum = S[i * nc + j];
            for (int k = 0; k < j; ++k) {
                sum -= L[i * nc + k] * L[j * nc + k];
            }
            if (i > j) {
                L[i * nc + j] = L[j * nc + j] != 0.0 ? sum / L[j * nc + j] : 0.0;
            } else if (!isnan(sum) && (sum <= DEP_RANK_DROP * S[j * nc + j] || mp->forced[j])) {
                L[j * nc + j] = 0.0; /* row j depends on the rows before it: dropped */
                mp->schur_dropped++;
            } else if (!(sum > 0.0)) {
                return 0;
            } else {
                L[j * nc + j] = sqrt(sum);
                if (sum < mp->schur_min_pivot * S[j * nc + j]) {
                    mp->schur_min_pivot = sum / S[j * nc + j];
                    mp->schur_min_row = j;
                }
            }
        }
    }
    mp->factorizations++;
    return 1;
}

/* The envelope's factor of S (dropping the rows forced), its statistics into mp. */
static void factor_envelope(dep_multipliers *mp)
{
    mp->schur_factored = dep_envelope_factor(&mp->envelope, DEP_RANK_DROP, mp->forced);
    mp->schur_dropped = mp->envelope.dropped;
    mp->schur_min_pivot = mp->envelope.min_pivot;
    mp->schur_min_row = mp->envelope.min_row >= 0 && mp->permuted
                        ? mp->order[mp->envelope.min_row] : mp->envelope.min_row;
    mp->factorizations += mp->schur_factored;
}

int dep_schur_refactor(dep_multipliers *mp, int nc)
{
    if (mp->schur_envelope) {
        factor_envelope(mp);
    } else {
        mp->schur_factored = factor_schur(mp, nc);
    }
    return mp->schur_factored;
}

/* S_ab of the envelope (b in first[a]..a). */
#define ENVELOPE(mp, M, a, b) DEP_ENVELOPE_AT(&(mp)->envelope, M, a, b)

/* The envelope's layout for the active rows' pattern: the rows touching each coordinate, the
   row order (kept unless reverse Cuthill-McKee's envelope is below RCM_KEEP of its own,
   mp->permuted), each row's envelope from the first row it shares a coordinate with. It
   depends on the pattern only, so it is laid out once per pattern (cs->pattern). */
static int envelope_layout(dep_multipliers *mp, int nc)
{
    int nq = mp->nq, *start = mp->column_start, *rows = mp->column_rows, *first = mp->first;
    const int *row_start = mp->cs->row_start, *cols = mp->cs->row_cols;
    if (mp->envelope_pattern == mp->cs->pattern && mp->envelope.n == nc) {
        return 1;
    }
    memset(start, 0, ((size_t)nq + 1) * sizeof *start);
    for (int k = 0; k < row_start[nc]; ++k) {
        start[cols[k] + 1]++;
    }
    for (int j = 0; j < nq; ++j) {
        start[j + 1] += start[j];
    }
    for (int a = 0; a < nc; ++a) { /* (row, entry) by coordinate, rows ascending */
        for (int k = row_start[a]; k < row_start[a + 1]; ++k) {
            mp->column_entries[start[cols[k]]] = k;
            rows[start[cols[k]]++] = a;
        }
    }
    for (int j = nq; j > 0; --j) { /* start[j] back to the beginning of column j */
        start[j] = start[j - 1];
    }
    start[0] = 0;
    int *rank = mp->rank; /* the row order, and first[] in it (dep_envelope_size) */
    const dep_pattern pattern = {nc, nq, row_start, cols, start, rows};
    dep_reverse_cuthill_mckee(&pattern, mp->order, mp->degree, rank);
    size_t reordered = dep_envelope_size(&pattern, rank, first);
    for (int a = 0; a < nc; ++a) {
        mp->order[a] = a;
    }
    mp->permuted = (double)reordered < RCM_KEEP * (double)dep_envelope_size(&pattern, mp->order,
                                                                            first);
    if (mp->permuted) {
        dep_envelope_size(&pattern, rank, first);
    } else {
        memcpy(rank, mp->order, (size_t)nc * sizeof *rank);
    }
    mp->envelope.n = nc; /* S and its factor in mp->S and mp->L */
    mp->offset[0] = 0;
    for (int a = 0; a < nc; ++a) {
        mp->offset[a + 1] = mp->offset[a] + a - first[a] + 1;
    }
    if (!schur_room(mp, (size_t)mp->offset[nc], 0)) {
        return 0;
    }
    mp->envelope_pattern = mp->cs->pattern;
    return 1;
}

/* Forms S = J M^-1 J^T in the envelope (S_ab += J_aj J_bj / M_jj). */
static int envelope_schur(dep_multipliers *mp, const double *J, int nc)
{
    int nq = mp->nq, *start = mp->column_start, *rows = mp->column_rows, *rank = mp->rank;
    if (!envelope_layout(mp, nc)) {
        return 0;
    }
    memset(mp->S, 0, (size_t)mp->offset[nc] * sizeof *mp->S);
    const double *inverse = mp->mass->inverse_diagonal;
    const int *entries = mp->column_entries;
    for (int j = 0; j < nq; ++j) {
        for (int k = start[j]; k < start[j + 1]; ++k) {
            double weight = J[entries[k]] * inverse[j];
            for (int m = start[j]; m <= k; ++m) {
                int a = rank[rows[k]], b = rank[rows[m]];
                ENVELOPE(mp, mp->S, a > b ? a : b, a > b ? b : a) += weight * J[entries[m]];
            }
        }
    }
    for (int a = 0; a < nc; ++a) {
        mp->diag[a] = ENVELOPE(mp, mp->S, rank[a], rank[a]);
    }
    return 1;
}

/* 1 when the factor of S at hand serves the rows J (id): formed for them, or for the same
   rows and mobility at a Jacobian whose non-zeros all lie within `allowed` times J's largest
   of J's. An update of (6) by that factor then leaves about `allowed` of the error it
   removes; the passes' corrections and the friction's end values move a step's end by a few
   tolerances, so one factorisation serves them all, and the step's error estimates, whose
   projections it changes as little. */
static int schur_serves(dep_multipliers *mp, const double *J, long long id, int nc,
                        double allowed)
{
    if (mp->schur_nc != nc || mp->schur_mobility != mp->mobility_id) {
        return 0;
    }
    if (mp->schur_id == id && (allowed > 0.0 || mp->schur_exact)) {
        return 1;
    }
    if (mp->schur_id < 0 || !mp->schur_factored || mp->schur_pattern != mp->cs->pattern) {
        return 0;
    }
    int nnz = mp->cs->row_start[nc], exact = 1;
    double bound = allowed * mp->schur_J_largest;
    for (int k = 0; k < nnz; ++k) {
        if (!(fabs(J[k] - mp->schur_J[k]) <= bound)) { /* (NaN included) */
            return 0;
        }
        exact = exact && J[k] == mp->schur_J[k];
    }
    mp->schur_id = id;
    mp->schur_exact = exact;
    return 1;
}

/* Copies a factor's S, L, diagonal and Jacobian (nc rows, nnz non-zeros) between the cache and
   a kept slot. */
static void copy_factor(int nc, int nnz, const double *S, const double *L, const double *diag,
                        const double *J, double *S_to, double *L_to, double *diag_to,
                        double *J_to)
{
    size_t square = (size_t)nc * (size_t)nc * sizeof *S;
    memcpy(S_to, S, square);
    memcpy(L_to, L, square);
    memcpy(diag_to, diag, (size_t)nc * sizeof *diag);
    memcpy(J_to, J, (size_t)nnz * sizeof *J);
}

/* Before S is formed for another mobility: the factor at hand set aside, when it is a small
   dense one (in its mobility's slot, else the next). */
static void keep_factor(dep_multipliers *mp)
{
    if (mp->schur_id < 0 || !mp->schur_factored || !mp->schur_explicit || mp->schur_envelope
        || mp->schur_nc > KEPT_ROWS || mp->schur_mobility == mp->mobility_id) {
        return;
    }
    int slot = -1;
    for (int k = 0; k < DEP_SCHUR_KEPT; ++k) {
        slot = mp->kept[k].mobility == mp->schur_mobility && mp->kept[k].id >= 0 ? k : slot;
    }
    if (slot < 0) {
        slot = mp->next_kept;
        mp->next_kept = (mp->next_kept + 1) % DEP_SCHUR_KEPT;
    }
    dep_schur_kept *kept = &mp->kept[slot];
    int nc = mp->schur_nc;
    copy_factor(nc, mp->cs->row_start[nc], mp->S, mp->L, mp->diag, mp->schur_J, kept->S,
                kept->L, kept->diag, kept->J);
    kept->id = mp->schur_id;
    kept->mobility = mp->schur_mobility;
    kept->pattern = mp->schur_pattern;
    kept->nc = nc;
    kept->exact = mp->schur_exact;
    kept->J_largest = mp->schur_J_largest;
    kept->dropped = mp->schur_dropped;
    kept->min_row = mp->schur_min_row;
    kept->min_pivot = mp->schur_min_pivot;
}

/* A kept factor of this mobility that serves J (as schur_serves) back in the cache; 1 if so. */
static int take_factor(dep_multipliers *mp, const double *J, long long id, int nc,
                       double allowed)
{
    for (int k = 0; k < DEP_SCHUR_KEPT; ++k) {
        dep_schur_kept *kept = &mp->kept[k];
        if (kept->id < 0 || kept->mobility != mp->mobility_id || kept->nc != nc
            || kept->pattern != mp->cs->pattern) {
            continue;
        }
        int nnz = mp->cs->row_start[nc], exact = kept->id == id && kept->exact;
        int serves = kept->id == id && (allowed > 0.0 || exact);
        double bound = allowed * kept->J_largest;
        for (int e = 0; !serves && e < nnz; ++e) {
            if (!(fabs(J[e] - kept->J[e]) <= bound)) {
                break;
            }
            exact = e == 0 ? J[e] == kept->J[e] : exact && J[e] == kept->J[e];
            serves = e == nnz - 1;
        }
        if (!serves || !schur_room(mp, (size_t)nc * (size_t)nc, 0)) {
            continue;
        }
        copy_factor(nc, nnz, kept->S, kept->L, kept->diag, kept->J, mp->S, mp->L, mp->diag,
                    mp->schur_J);
        mp->schur_id = id;
        mp->schur_mobility = kept->mobility;
        mp->schur_pattern = kept->pattern;
        mp->schur_nc = nc;
        mp->schur_J_largest = kept->J_largest;
        mp->schur_exact = exact;
        mp->schur_dropped = kept->dropped;
        mp->schur_min_row = kept->min_row;
        mp->schur_min_pivot = kept->min_pivot;
        mp->schur_explicit = mp->schur_factored = 1;
        mp->schur_envelope = 0;
        memset(mp->forced, 0, (size_t)nc); /* (its dropped rows are in its factor) */
        return 1;
    }
    return 0;
}

void dep_schur_form(dep_multipliers *mp, const double *J, long long id, int nc, double allowed)
{
    int nq = mp->nq;
    if (schur_serves(mp, J, id, nc, allowed)) {
        return;
    }
    keep_factor(mp);
    if (take_factor(mp, J, id, nc, allowed)) {
        return;
    }
    mp->schur_id = id;
    mp->schur_exact = 1;
    mp->schur_pattern = mp->cs->pattern;
    memcpy(mp->schur_J, J, (size_t)mp->cs->row_start[nc] * sizeof *J);
    mp->schur_J_largest = dep_max_abs(J, mp->cs->row_start[nc]);
    mp->schur_nc = nc;
    mp->schur_mobility = mp->mobility_id;
    mp->schur_envelope = mp->mass->inverse_diagonal != NULL && mp->mobility == NULL;
    memset(mp->forced, 0, (size_t)nc);
    if (mp->schur_envelope && envelope_schur(mp, J, nc)) {
        mp->schur_explicit = 1;
        factor_envelope(mp);
        return;
    }
    mp->schur_envelope = 0; /* (out of memory for the envelope: conjugate gradients) */
    mp->schur_dropped = 0;
    mp->schur_min_pivot = 1.0;
    mp->schur_min_row = -1;
    mp->schur_explicit = nc < EXPLICIT_BELOW && schur_room(mp, (size_t)nc * (size_t)nc, nc);
    const int *row_start = mp->cs->row_start, *cols = mp->cs->row_cols;
    for (int b = 0; b < nc; ++b) { /* row b of (G J^T)^T; kept only to form S */
        double *GJb = mp->schur_explicit ? mp->MinvJT + (size_t)b * (size_t)nq : mp->work;
        for (int k = row_start[b]; k < row_start[b + 1]; ++k) {
            mp->column[cols[k]] = J[k];
        }
        dep_multipliers_apply(mp, mp->column, GJb);
        for (int k = row_start[b]; k < row_start[b + 1]; ++k) {
            mp->column[cols[k]] = 0.0;
        }
        for (int a = mp->schur_explicit ? 0 : b; a <= b; ++a) { /* S_ab and S_ba */
            const double *GJa = mp->schur_explicit ? mp->MinvJT + (size_t)a * (size_t)nq : GJb;
            double ab = 0.0, ba = 0.0;
            for (int k = row_start[a]; k < row_start[a + 1]; ++k) {
                ab += J[k] * GJb[cols[k]];
            }
            for (int k = row_start[b]; k < row_start[b + 1]; ++k) {
                ba += J[k] * GJa[cols[k]];
            }
            if (mp->schur_explicit) {
                mp->S[a * nc + b] = ab;
                mp->S[b * nc + a] = ba;
            }
            if (a == b) {
                mp->diag[a] = ab;
            }
        }
    }
    mp->schur_factored = mp->schur_explicit && factor_schur(mp, nc);
}

static int pcg(dep_multipliers *mp, const double *J, int n, const double *b,
               long long *iterations);

/* x = S^-1 b (x may be b): by the factor when there is one, into x as it goes (a copy read
   back at once stalls: dep_envelope_solve), else conjugate gradients; 1 when solved. */
int dep_schur_solve_formed(dep_multipliers *mp, const double *J, int n, const double *b,
                           double *x, long long *iterations)
{
    if (mp->schur_factored) {
        if (mp->schur_envelope && mp->permuted) {
            for (int a = 0; a < n; ++a) {
                mp->permuted_in[mp->rank[a]] = b[a];
            }
            dep_envelope_solve(&mp->envelope, mp->permuted_in, mp->permuted_in);
            for (int a = 0; a < n; ++a) {
                x[a] = mp->permuted_in[mp->rank[a]];
            }
        } else if (mp->schur_envelope) {
            dep_envelope_solve(&mp->envelope, b, x);
        } else {
            dep_cholesky_solve(mp->L, n, b, x);
        }
        return 1;
    }
    int solved = pcg(mp, J, n, b, iterations);
    if (x != mp->x) {
        memcpy(x, mp->x, (size_t)n * sizeof *x);
    }
    return solved;
}

/* x = S^-1 b for the rows J (nc x nq) with identity jacobian_id; 1 when solved. */
int dep_schur_solve(dep_multipliers *mp, const double *J, long long jacobian_id, int nc,
                    const double *b, double *x)
{
    long long iterations = 0;
    dep_schur_form(mp, J, jacobian_id, nc, DEP_SCHUR_REUSE);
    return dep_schur_solve_formed(mp, J, nc, b, x, &iterations);
}

static void schur_apply(dep_multipliers *mp, const double *J, int nc, const double *x,
                        double *out)
{
    int nq = mp->nq;
    if (mp->schur_envelope && mp->permuted) {
        for (int a = 0; a < nc; ++a) {
            mp->permuted_in[mp->rank[a]] = x[a];
        }
        dep_envelope_times(&mp->envelope, mp->S, mp->permuted_in, mp->permuted_out);
        for (int a = 0; a < nc; ++a) {
            out[a] = mp->permuted_out[mp->rank[a]];
        }
        return;
    }
    if (mp->schur_envelope) {
        dep_envelope_times(&mp->envelope, mp->S, x, out);
        return;
    }
    if (mp->schur_explicit) {
        for (int a = 0; a < nc; ++a) {
            out[a] = dot(mp->S + (size_t)a * (size_t)nc, x, nc);
        }
        return;
    }
    dep_multipliers_transpose_times(mp, J, nc, x, mp->column);
    dep_multipliers_apply(mp, mp->column, mp->work);
    times(mp, J, nc, mp->work, out);
    memset(mp->column, 0, (size_t)nq * sizeof *mp->column);
}

/* Solve S x = b by Jacobi-preconditioned conjugate gradients into mp->x; returns 1 when
   converged. A row whose diagonal of S vanishes stays out of the preconditioner. */
static int pcg(dep_multipliers *mp, const double *J, int n, const double *b, long long *iterations)
{
    int maxiter = 2 * n + 10;
    double scale = 0.0, *x = mp->x, *r = mp->r, *z = mp->z, *d = mp->d, *Sd = mp->Sd;
    for (int i = 0; i < n; ++i) {
        scale = i == 0 ? mp->diag[0] : fmax(scale, mp->diag[i]);
    }
    for (int i = 0; i < n; ++i) {
        int live = mp->diag[i] > 1e-14 * scale;
        mp->inv_diag[i] = live ? 1.0 / mp->diag[i] : 0.0;
        x[i] = 0.0;
        r[i] = b[i];
        z[i] = d[i] = mp->inv_diag[i] * r[i];
    }
    double target2 = CG_RTOL * CG_RTOL * dot(b, b, n), rz = dot(r, z, n);
    for (int k = 0; k < maxiter; ++k) {
        if (dot(r, r, n) <= target2) {
            *iterations += k;
            return 1;
        }
        schur_apply(mp, J, n, d, Sd);
        double curvature = dot(d, Sd, n);
        if (!(curvature > 0.0)) {
            break;
        }
        double step = rz / curvature;
        for (int i = 0; i < n; ++i) {
            x[i] += step * d[i];
            r[i] -= step * Sd[i];
            z[i] = mp->inv_diag[i] * r[i];
        }
        double rz_new = dot(r, z, n), ratio = rz > 0 ? rz_new / rz : 0.0;
        for (int i = 0; i < n; ++i) {
            d[i] = rz > 0 ? z[i] + ratio * d[i] : z[i];
        }
        rz = rz_new;
    }
    *iterations += maxiter;
    return dot(r, r, n) <= target2;
}
