/* dense.c: small dense solves and the largest magnitude of a vector (algebra.h). */
#include <math.h>

#include "algebra.h"

void dep_cholesky_solve(const double *L, int n, const double *b, double *x)
{
    for (int i = 0; i < n; ++i) { /* L y = b */
        double sum = b[i];
        for (int k = 0; k < i; ++k) {
            sum -= L[i * n + k] * x[k];
        }
        x[i] = L[i * n + i] != 0.0 ? sum / L[i * n + i] : 0.0; /* (0: a dropped row) */
    }
    for (int i = n - 1; i >= 0; --i) { /* L^T x = y */
        double sum = x[i];
        for (int k = i + 1; k < n; ++k) {
            sum -= L[k * n + i] * x[k];
        }
        x[i] = L[i * n + i] != 0.0 ? sum / L[i * n + i] : 0.0;
    }
}

/* x = A^-1 b, A overwritten, b overwritten by x (algebra.h). */
void dep_solve_small(int n, double *A, double *b)
{
    for (int c = 0; c < n; ++c) {
        int pivot = c;
        for (int r = c + 1; r < n; ++r) {
            pivot = fabs(A[r * n + c]) > fabs(A[pivot * n + c]) ? r : pivot;
        }
        if (pivot != c) {
            for (int m = 0; m < n; ++m) {
                double swap = A[c * n + m];
                A[c * n + m] = A[pivot * n + m];
                A[pivot * n + m] = swap;
            }
            double swap = b[c];
            b[c] = b[pivot];
            b[pivot] = swap;
        }
        for (int r = c + 1; r < n; ++r) {
            double factor = A[r * n + c] / A[c * n + c];
            for (int m = c; m < n; ++m) {
                A[r * n + m] -= factor * A[c * n + m];
            }
            b[r] -= factor * b[c];
        }
    }
    for (int c = n - 1; c >= 0; --c) {
        double sum = b[c];
        for (int m = c + 1; m < n; ++m) {
            sum -= A[c * n + m] * b[m];
        }
        b[c] = sum / A[c * n + c];
    }
}

double dep_max_abs(const double *v, int n)
{
    double largest = 0.0;
    for (int i = 0; i < n; ++i) { /* (a comparison, not fmax: a libm call on x86-64) */
        double size = fabs(v[i]);
        if (isnan(size)) {
            return v[i];
        }
        largest = size > largest ? size : largest;
    }
    return largest;
}
