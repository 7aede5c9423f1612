/* ordering.c: a row order that keeps the envelope of a sparse pattern's row-by-row product
 * narrow (reverse Cuthill-McKee), and that envelope's size in a given order (algebra.h). The
 * multipliers' S = J M^-1 J^T has this pattern: S_ab is non-zero where rows a and b of J share
 * a coordinate.
 */
#include "algebra.h"

size_t dep_envelope_size(const dep_pattern *pattern, const int *rank, int *first)
{
    const int *start = pattern->column_start, *rows = pattern->column_rows;
    int nc = pattern->n;
    size_t size = 0;
    for (int a = 0; a < nc; ++a) {
        first[a] = a;
    }
    for (int j = 0; j < pattern->m; ++j) {
        int lowest = nc;
        for (int k = start[j]; k < start[j + 1]; ++k) {
            lowest = rank[rows[k]] < lowest ? rank[rows[k]] : lowest;
        }
        for (int k = start[j]; k < start[j + 1]; ++k) {
            int r = rank[rows[k]];
            first[r] = lowest < first[r] ? lowest : first[r];
        }
    }
    for (int r = 0; r < nc; ++r) {
        size += (size_t)(r - first[r] + 1);
    }
    return size;
}

/* Whatever order the model declares its joints in (a comb declared spine first, then its
   teeth), each component is laid out breadth first from its first row, each row's new
   neighbours by ascending degree, and the order reversed. */
void dep_reverse_cuthill_mckee(const dep_pattern *pattern, int *order, int *degree, int *rank)
{
    const int *start = pattern->column_start, *rows = pattern->column_rows;
    const int *row_start = pattern->row_start, *cols = pattern->row_cols;
    int nc = pattern->n, placed = 0, next = 0;
    for (int a = 0; a < nc; ++a) {
        degree[a] = 0;
        for (int k = row_start[a]; k < row_start[a + 1]; ++k) {
            degree[a] += start[cols[k] + 1] - start[cols[k]];
        }
        rank[a] = -1;
    }
    while (placed < nc) {
        while (rank[next] >= 0) { /* each component from its first row (a joint to the ground
                                     comes first in a model, a root of the tree) */
            ++next;
        }
        int seed = next;
        rank[seed] = placed;
        order[placed++] = seed;
        for (int head = placed - 1; head < placed; ++head) { /* breadth first */
            int a = order[head], from = placed;
            for (int k = row_start[a]; k < row_start[a + 1]; ++k) {
                for (int m = start[cols[k]]; m < start[cols[k] + 1]; ++m) {
                    int b = rows[m];
                    if (rank[b] >= 0) {
                        continue;
                    }
                    int at = placed++; /* insert by degree among this row's new neighbours */
                    while (at > from && degree[order[at - 1]] > degree[b]) {
                        order[at] = order[at - 1];
                        --at;
                    }
                    order[at] = b;
                    rank[b] = 0;
                }
            }
            for (int i = from; i < placed; ++i) {
                rank[order[i]] = i;
            }
        }
    }
    for (int i = 0; i < nc; ++i) { /* reversed */
        rank[order[i]] = nc - 1 - i;
    }
}
