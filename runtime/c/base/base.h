/* base.h: the lowest layer of the integrator core (runtime/c/README.md): a run's memory (one
 * arena, freed at once), its errors (the text of depsim.runtime.SolverError, field by field),
 * numbers as text, and the data entries of event records. It sees the public types
 * (depsim.h) and nothing of the method.
 *
 *   arena.c    memory
 *   errors.c   error records and their text, repr(float) (dep_repr, public)
 *   decimal.c  dep_format_double (public): "%.17g" without the C library's big numbers
 *   records.c  the (key, member) -> value entries of an event record
 */
#ifndef DEPSIM_BASE_H
#define DEPSIM_BASE_H

#include <stddef.h>

#include "../include/depsim.h"

#define DEP_EPS 2.220446049250313e-16 /* double machine epsilon */
#define DEP_PI 3.14159265358979323846 /* pi */

/* ---- arena.c: every allocation of a run, freed at once ----------------------------------- */

typedef struct dep_arena {
    void **blocks;
    size_t *sizes; /* each block's bytes (a run's state saved: run/snapshot.c) */
    int count, capacity;
    int failed;
} dep_arena;

double *dep_doubles(dep_arena *arena, size_t n); /* zeroed; NULL (and arena->failed) on failure */
void *dep_bytes(dep_arena *arena, size_t n); /* zeroed */
/* not zeroed: for a large block whose parts are set before they are read (calloc clears
   memory that a long-lived process, a study's worker, has used before: megabytes a run) */
void *dep_bytes_unset(dep_arena *arena, size_t n);
void dep_arena_truncate(dep_arena *arena, int count); /* the blocks from `count` on freed */
void dep_arena_free(dep_arena *arena);

/* ---- errors.c ---------------------------------------------------------------------------- */

void dep_error_clear(dep_error *error);
void dep_copy_text(char *to, size_t size, const char *from);
/* Python's SolverError(what, t=, stage=, row=, joint=, residual=, hint=): fills every field and
   the formatted message. Pass has_t/has_residual 0 and NULL strings for None. */
int dep_solver_error(dep_error *error, int has_t, double t, const char *stage, const char *row,
                     const char *joint, int has_residual, double residual, const char *what,
                     const char *hint);
int dep_plain_error(dep_error *error, int code, const char *message);

/* ---- records.c: event record data --------------------------------------------------------- */

/* The entry (key, member) of data (n entries, room for capacity): the existing one, or a new
   one at the end (a dict's assignment); NULL when full. */
dep_datum *dep_datum_add(dep_datum *data, int *n, int capacity, const char *key,
                         const char *member);
void dep_datum_number(dep_datum *data, int *n, int capacity, const char *key, double value);
void dep_datum_text(dep_datum *data, int *n, int capacity, const char *key, const char *text);

#endif /* DEPSIM_BASE_H */
