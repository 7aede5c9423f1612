/* envelope.c: symmetric positive definite matrices in envelope (skyline) form, their Cholesky
 * factor and solves (algebra.h). The factor fills nothing outside the envelope: a chain's
 * band of width b costs O(n b^2) to factor and O(n b) to solve.
 */
#include <math.h>
#include <string.h>

#include "algebra.h"

int dep_envelope_init(dep_envelope *e, int n, const int *first, dep_arena *arena)
{
    e->n = n;
    e->first = dep_bytes(arena, ((size_t)n + 1) * sizeof *e->first);
    e->offset = dep_bytes(arena, ((size_t)n + 1) * sizeof *e->offset);
    if (e->first == NULL || e->offset == NULL) {
        return DEP_MEMORY_ERROR;
    }
    e->offset[0] = 0;
    for (int i = 0; i < n; ++i) {
        e->first[i] = first[i];
        e->offset[i + 1] = e->offset[i] + i - first[i] + 1;
    }
    e->A = dep_doubles(arena, (size_t)e->offset[n] + 1);
    e->L = dep_doubles(arena, (size_t)e->offset[n] + 1);
    e->inverse = dep_doubles(arena, (size_t)n + 1);
    return arena->failed ? DEP_MEMORY_ERROR : DEP_OK;
}

int dep_envelope_factor(dep_envelope *e, double drop, const unsigned char *forced)
{
    double largest = 0.0;
    for (int i = 0; i < e->n; ++i) {
        largest = fmax(largest, DEP_ENVELOPE_AT(e, e->A, i, i));
    }
    e->dropped = 0;
    e->min_pivot = 1.0;
    e->min_row = -1;
    for (int i = 0; i < e->n; ++i) {
        for (int j = e->first[i]; j <= i; ++j) {
            int from = e->first[i] > e->first[j] ? e->first[i] : e->first[j];
            double sum = DEP_ENVELOPE_AT(e, e->A, i, j);
            const double *Li = &DEP_ENVELOPE_AT(e, e->L, i, from);
            const double *Lj = &DEP_ENVELOPE_AT(e, e->L, j, from);
            for (int k = 0; k < j - from; ++k) {
                sum -= Li[k] * Lj[k];
            }
            if (j < i) { /* (times the pivot's inverse: no division's latency on the row) */
                DEP_ENVELOPE_AT(e, e->L, i, j) = sum * e->inverse[j];
                continue;
            }
            double diagonal = DEP_ENVELOPE_AT(e, e->A, i, i);
            if (drop > 0.0 && !isnan(sum) && (sum <= drop * diagonal
                                              || (forced != NULL && forced[i]))) {
                DEP_ENVELOPE_AT(e, e->L, i, i) = 0.0; /* row i depends on the rows before it */
                e->inverse[i] = 0.0;
                e->dropped++;
                continue;
            }
            if (!(sum > (drop > 0.0 ? 0.0 : 1e-12 * largest))) {
                return 0;
            }
            DEP_ENVELOPE_AT(e, e->L, i, i) = sqrt(sum);
            e->inverse[i] = 1.0 / DEP_ENVELOPE_AT(e, e->L, i, i);
            if (sum < e->min_pivot * diagonal) {
                e->min_pivot = sum / diagonal;
                e->min_row = i;
            }
        }
    }
    return 1;
}

/* One right side: L y = b by rows (a dot product each), L^T x = y by columns. Each row waits
   on the one before, so that value is carried in a register (`last`, `next`) rather than
   stored and loaded back at once: a forwarded load's latency on every row of the chain. b is
   read as the rows go, not copied into x first: a copy's wide stores, read back at once a
   number at a time, cannot be forwarded to the loads at all (the solve of INTELSAT V's 8
   rows took twice as long). The operations and their order are those of the plain loops. */
void dep_envelope_solve(const dep_envelope *e, const double *b, double *x)
{
    int n = e->n;
    double last = 0.0; /* x[i - 1] */
    for (int i = 0; i < n; ++i) {
        const double *row = &DEP_ENVELOPE_AT(e, e->L, i, 0);
        double sum = b[i];
        int k = e->first[i];
        for (; k < i - 1; ++k) {
            sum -= row[k] * x[k];
        }
        if (k == i - 1) {
            sum -= row[k] * last;
        }
        x[i] = last = sum * e->inverse[i];
    }
    double next = n > 0 ? x[n - 1] : 0.0; /* x[i] with the updates of the rows below it */
    for (int i = n - 1; i >= 0; --i) {
        const double *row = &DEP_ENVELOPE_AT(e, e->L, i, 0);
        double xi = next * e->inverse[i];
        x[i] = xi;
        int k = e->first[i];
        for (; k < i - 1; ++k) {
            x[k] -= row[k] * xi;
        }
        if (i > 0) {
            next = k == i - 1 ? x[i - 1] - row[i - 1] * xi : x[i - 1];
        }
    }
}

/* The rows of the same in the same order of operations, SOLVE_CHUNK sides at a time in a local
   accumulator (a store through x could alias any row of x, which keeps the compiler from
   holding the sums in registers). */
#define SOLVE_CHUNK 8

void dep_envelope_solve_block(const dep_envelope *e, int count, const double *b, double *x)
{
    if (count == 1) {
        dep_envelope_solve(e, b, x);
        return;
    }
    if (x != b) {
        memcpy(x, b, (size_t)e->n * (size_t)count * sizeof *x);
    }
    for (int i = 0; i < e->n; ++i) { /* L y = b */
        const double *row = &DEP_ENVELOPE_AT(e, e->L, i, 0);
        double *xi = x + (size_t)i * count;
        for (int v0 = 0; v0 < count; v0 += SOLVE_CHUNK) {
            int width = count - v0 < SOLVE_CHUNK ? count - v0 : SOLVE_CHUNK;
            double sum[SOLVE_CHUNK];
            for (int v = 0; v < width; ++v) {
                sum[v] = xi[v0 + v];
            }
            for (int k = e->first[i]; k < i; ++k) {
                const double l = row[k], *xk = x + (size_t)k * count + v0;
                for (int v = 0; v < width; ++v) {
                    sum[v] -= l * xk[v];
                }
            }
            for (int v = 0; v < width; ++v) {
                xi[v0 + v] = sum[v] * e->inverse[i];
            }
        }
    }
    for (int i = e->n - 1; i >= 0; --i) { /* L^T x = y, column by column */
        const double *row = &DEP_ENVELOPE_AT(e, e->L, i, 0);
        double *xi = x + (size_t)i * count;
        for (int v0 = 0; v0 < count; v0 += SOLVE_CHUNK) {
            int width = count - v0 < SOLVE_CHUNK ? count - v0 : SOLVE_CHUNK;
            double value[SOLVE_CHUNK];
            for (int v = 0; v < width; ++v) {
                value[v] = xi[v0 + v] * e->inverse[i];
                xi[v0 + v] = value[v];
            }
            for (int k = e->first[i]; k < i; ++k) {
                const double l = row[k];
                double *xk = x + (size_t)k * count + v0;
                for (int v = 0; v < width; ++v) {
                    xk[v] -= l * value[v];
                }
            }
        }
    }
}

void dep_envelope_times(const dep_envelope *e, const double *values, const double *x,
                        double *out)
{
    memset(out, 0, (size_t)e->n * sizeof *out);
    for (int i = 0; i < e->n; ++i) {
        for (int j = e->first[i]; j < i; ++j) {
            double a = DEP_ENVELOPE_AT(e, values, i, j);
            out[i] += a * x[j];
            out[j] += a * x[i];
        }
        out[i] += DEP_ENVELOPE_AT(e, values, i, i) * x[i];
    }
}
