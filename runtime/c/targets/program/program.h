/* program.h: what the files of the standalone program share (docs/c-target.md, section 4):
 *
 *   main.c             the options, the run, the exit codes
 *   program_output.c   the output files, all written or none (the CSV, the JSON summary)
 *   program_summary.c  the JSON summary, as `depsim run --summary` writes it
 *   program_tables.c   --input NAME=FILE.csv: a time table, as `depsim run --input` reads it
 *
 * Like the FMU wrapper, the program sees the core's public interface and the model alone.
 */
#ifndef DEPSIM_PROGRAM_H
#define DEPSIM_PROGRAM_H

#include <stdio.h>

#include "core/include/depsim.h"

enum { EXIT_OK = 0, EXIT_FAILED = 1, EXIT_USAGE = 2, EXIT_SOLVER = 3 };

#define PROGRAM_PATH_MAX 4096

extern const char *program; /* the program's name, the start of its messages */

/* ---- program_output.c -------------------------------------------------------------------- */

/* One output file of a run: the option naming it, its path and what writes it. */
typedef struct program_output {
    const char *option;
    const char *path;
    int (*write)(const dep_result *result, FILE *file); /* EXIT_OK or EXIT_FAILED */
    int in_place;                      /* a pipe or a device: written into, never replaced */
    char target[PROGRAM_PATH_MAX];     /* the file replaced (a symbolic link's target) */
    char partial[PROGRAM_PATH_MAX];    /* written first, then renamed over target */
} program_output;

/* Before the run: each output (path NULL: not asked for) can be written, and no two are the
   same file; else a message and EXIT_FAILED (cannot be written) or EXIT_USAGE. */
int program_check_outputs(program_output *outputs, int n);
/* After the run: every output, or none (a file that fails takes back those before it). */
int program_write_outputs(program_output *outputs, int n, const dep_result *result);
/* The CSV of `depsim run`: t, then every output, each number as "%.17g" writes it. */
int program_write_csv(const dep_result *result, FILE *file);

/* ---- program_summary.c ------------------------------------------------------------------- */

/* The JSON summary of `depsim run --summary` (depsim.runtime.Result.summary() through
   json.dumps(indent=2)): model, parameters, tolerances, statistics, events, deployment and
   peak hinge loads, every number as Python's repr writes it. */
int program_write_summary(const dep_result *result, FILE *file);

/* ---- program_tables.c -------------------------------------------------------------------- */

/* The time table of input `name` in the CSV file `path`, with the rules of
   depsim.runtime.tables.read_table (lines `t,u`, a first line naming the columns, blank lines
   and `#` comments skipped, a UTF-8 byte-order mark dropped, times never decreasing): its n
   points in *t and *u (malloc'ed; free both). EXIT_OK, else EXIT_USAGE after the message
   `<program>: error: --input NAME: FILE:LINE: ...`, or EXIT_FAILED when out of memory. */
int program_read_table(const char *name, const char *path, double **t, double **u, int *n);

#endif /* DEPSIM_PROGRAM_H */
