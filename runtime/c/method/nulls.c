/* nulls.c: the null vectors of S = Phi_q G Phi_q^T that the iteration (6) deflates: the rows
 * the factor dropped, and the weak rows whose combination of the rows before them keeps
 * almost nothing of the rows' sizes (docs/method.md, 6a).
 */
#include <math.h>
#include <string.h>

#include "method.h"

/* A row whose pivot is at most RANK_SCREEN times rank_drop of its diagonal is looked at as
   the end of a combination of the rows before it (rayleigh_share). Its pivot is the
   combination's share times the combination's rows' sizes over its own (sum_a n_a^2 S_aa /
   S_jj, n_j = 1): the screen lets a closing row be up to RANK_SCREEN times smaller than the
   rows it closes. */
#define RANK_SCREEN 1e4
/* A combination of rows keeping at most this share of their sizes is null to the round-off
   of S's entries (a redundant row's: 1e-17 to 1e-16 along the Bricard linkage's motion). */
#define RANK_ROUNDOFF 1e-13
/* Inverse iterations that refine a weak row's combination towards S's eigenvector. The passes
   deflate it from their solves and residuals, and an update that solves with the exact factor
   converges at once only where the deflated vectors span S's weak eigenvectors: with one
   iteration, chains of 20 and 40 parallelograms sharing their cranks stopped a few degrees
   before lying flat at tol 1e-10, the acceleration pass contracting by 0.7 to 0.9 an update
   (several weak directions at once, their eigenvalues close together, so that one iteration
   leaves each vector mixed with the others' and the next ones'). */
#define WEAK_REFINE 2

/* The null vector of the factor for its dropped row j (in the factor's order): n_j = 1, the
   later rows 0, and L_<j^T n_<j = -L_j,<j^T by columns of the rows before j, so that
   L^T n = 0 and S n = L L^T n = 0. row(i, k): L_ik for k in first..i. */
static void null_vector(const dep_multipliers *mp, int nc, int j, double *n)
{
    const dep_envelope *e = &mp->envelope;
    int envelope = mp->schur_envelope;
    memset(n, 0, (size_t)nc * sizeof *n);
    int first_j = envelope ? e->first[j] : 0;
    for (int k = first_j; k < j; ++k) {
        n[k] = -(envelope ? DEP_ENVELOPE_AT(e, e->L, j, k) : mp->L[j * nc + k]);
    }
    for (int i = j - 1; i >= 0; --i) {
        double pivot = envelope ? DEP_ENVELOPE_AT(e, e->L, i, i) : mp->L[i * nc + i];
        n[i] = pivot != 0.0 ? n[i] / pivot : 0.0;
        int first_i = envelope ? e->first[i] : 0;
        for (int k = first_i; k < i; ++k) {
            n[k] -= (envelope ? DEP_ENVELOPE_AT(e, e->L, i, k) : mp->L[i * nc + k]) * n[i];
        }
    }
    n[j] = 1.0;
}

/* n^T S n / sum_a n_a^2 S_aa for a vector n in the rows' order: how much of the rows'
   own sizes the combination n of them keeps, sin^2 of the angle between a row and the span of
   the others when n combines two. The pivot of the row that closes a combination in the
   factor's order is that share divided by the row's part in it squared, so a combination
   whose last row takes a small part of it shows a larger pivot than it is independent (the
   IFToMM Bricard linkage's redundant row: pivots of 1e-15 to 2e-9 of their diagonal along
   its motion for the same combination of its rows). */
static double rayleigh_share(const dep_multipliers *mp, int nc, const double *n)
{
    const dep_envelope *e = &mp->envelope;
    double form = 0.0, sizes = 0.0;
    if (!mp->schur_envelope) {
        for (int a = 0; a < nc; ++a) {
            for (int b = 0; b < nc; ++b) {
                form += n[a] * mp->S[a * nc + b] * n[b];
            }
            sizes += n[a] * n[a] * mp->S[a * nc + a];
        }
        return sizes > 0.0 ? fabs(form) / sizes : 0.0;
    }
    double *own = mp->permuted_in; /* n in the factor's order */
    for (int a = 0; a < nc; ++a) {
        own[mp->permuted ? mp->rank[a] : a] = n[a];
    }
    for (int i = 0; i < nc; ++i) { /* the envelope holds S's lower triangle */
        double diagonal = DEP_ENVELOPE_AT(e, e->A, i, i), off = 0.0;
        for (int k = e->first[i]; k < i; ++k) {
            off += DEP_ENVELOPE_AT(e, e->A, i, k) * own[k];
        }
        form += own[i] * (diagonal * own[i] + 2.0 * off);
        sizes += own[i] * own[i] * diagonal;
    }
    return sizes > 0.0 ? fabs(form) / sizes : 0.0;
}

void dep_schur_deflate(const dep_multipliers *mp, int nc, double *x)
{
    for (int k = 0; k < mp->n_nulls; ++k) {
        const double *n = mp->nulls + (size_t)k * (size_t)nc;
        double dot = 0.0;
        for (int i = 0; i < nc; ++i) {
            dot += n[i] * x[i];
        }
        for (int i = 0; i < nc; ++i) {
            x[i] -= dot * n[i];
        }
    }
}

/* n less its parts along the null vectors found (Gram-Schmidt, twice), of unit length; 0
   when nothing is left. */
static int orthonormal(const dep_multipliers *mp, int nc, double *n)
{
    for (int pass = 0; pass < 2; ++pass) {
        dep_schur_deflate(mp, nc, n);
        double norm = 0.0;
        for (int a = 0; a < nc; ++a) {
            norm += n[a] * n[a];
        }
        norm = sqrt(norm);
        if (!(norm > 0.0) || !isfinite(norm)) {
            return 0;
        }
        for (int a = 0; a < nc; ++a) {
            n[a] /= norm;
        }
    }
    return 1;
}

/* The null vectors of the factor at hand into mp->nulls (dep_schur_nulls): a dropped row's,
   and a weak row's whose combination keeps at most rank_drop of its rows' sizes
   (rayleigh_share). A weak row that closes a combination of the rows before it null to
   round-off (RANK_ROUNDOFF: a redundant row, which stays one along the motion) is dropped
   (mp->forced) and S factored again without it, so that the solves do not divide by its
   pivot, whose round-off would spread to the other rows' multipliers; one near a singular
   position keeps its pivot (the failure's condition tells it). 1 when a row was forced (S
   is to be factored again and the nulls found again). */
static int find_nulls(dep_multipliers *mp, int nc)
{
    const dep_envelope *e = &mp->envelope;
    long long iterations = 0;
    mp->n_nulls = mp->weak_nulls = 0;
    for (int k = 0; k < 2 * nc && mp->n_nulls < mp->null_max; ++k) {
        int j = k % nc; /* the dropped rows first, then the weak ones (apart from those) */
        double pivot = mp->schur_envelope ? DEP_ENVELOPE_AT(e, e->L, j, j) : mp->L[j * nc + j];
        double diagonal = mp->schur_envelope ? DEP_ENVELOPE_AT(e, e->A, j, j) : mp->S[j * nc + j];
        if ((k < nc) != (pivot == 0.0)
            || (pivot != 0.0 && !(pivot * pivot <= RANK_SCREEN * mp->rank_drop * diagonal))) {
            continue;
        }
        double *n = mp->nulls + (size_t)mp->n_nulls * (size_t)nc, *own = mp->permuted_out;
        null_vector(mp, nc, j, mp->schur_envelope && mp->permuted ? own : n);
        if (mp->schur_envelope && mp->permuted) { /* to the rows' own order */
            for (int a = 0; a < nc; ++a) {
                n[a] = own[mp->rank[a]];
            }
        }
        double closing = pivot != 0.0 ? rayleigh_share(mp, nc, n) : 0.0;
        if (pivot != 0.0 && closing <= RANK_ROUNDOFF) {
            mp->forced[j] = 1; /* the row is a combination of the rows before it */
            return 1;
        }
        if (!(closing <= RANK_SCREEN * mp->rank_drop)) {
            continue; /* far from a weak combination: the inverse iterations do not reach */
        }
        if (pivot != 0.0) { /* a weak row: S n ~ pivot n; WEAK_REFINE inverse iterations make
                               n the eigenvector of S's smallest eigenvalue (apart from the
                               null vectors found) */
            for (int round = 0; round < WEAK_REFINE; ++round) {
                orthonormal(mp, nc, n);
                dep_schur_solve_formed(mp, NULL, nc, n, n, &iterations);
            }
            if (!orthonormal(mp, nc, n) || !(rayleigh_share(mp, nc, n) <= mp->rank_drop)) {
                continue; /* the rows it combines are independent enough */
            }
        }
        int found = orthonormal(mp, nc, n);
        mp->n_nulls += found;
        mp->weak_nulls += found && pivot != 0.0;
    }
    return 0;
}

int dep_schur_nulls(dep_multipliers *mp, int nc)
{
    if (mp->nulls_id == mp->schur_id && mp->schur_id >= 0) {
        return mp->n_nulls;
    }
    mp->nulls_id = mp->schur_id;
    mp->n_nulls = mp->weak_nulls = 0;
    if (!mp->schur_factored || !mp->schur_explicit) {
        return 0;
    }
    for (int round = 0; round < mp->null_max && find_nulls(mp, nc); ++round) {
        if (!dep_schur_refactor(mp, nc)) { /* S again without the rows forced */
            mp->n_nulls = 0;
            return 0;
        }
    }
    return mp->n_nulls;
}
