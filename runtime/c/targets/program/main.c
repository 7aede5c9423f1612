/* main.c: the standalone program of a C target folder (docs/c-target.md).
 *
 *     ./MODEL [--set NAME=VALUE]... [--t-end T] [--dt-out DT] [--tol TOL] [--max-steps N]
 *             [--stepping auto|explicit|implicit]
 *             [-o out.csv]
 *     ./MODEL --list          parameters, their SI units and defaults
 *
 * Values are plain numbers in SI units (m, kg, s, rad, N*m, ...); units are not parsed here
 * (`depsim run` accepts them). Writes the CSV of `depsim run`: `t`, then every output, %.17g.
 * With -o the CSV goes to the file and a summary to stdout; without, the CSV goes to stdout.
 * Exit codes: 0 ok, 1 out of memory or an unwritable file, 2 usage error, 3 solver failure.
 */
#if defined(__unix__) || defined(__APPLE__)
#define _XOPEN_SOURCE 700 /* stat, lstat, realpath: what a path names */
#include <limits.h>
#include <sys/stat.h>
#define HAVE_POSIX 1
#endif
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/include/depsim.h"
#include "model.h"

enum { EXIT_OK = 0, EXIT_FAILED = 1, EXIT_USAGE = 2, EXIT_SOLVER = 3 };

typedef struct options {
    double p[MODEL_NP + 1];
    dep_settings settings;
    const char *out;
    int list;
} options;

static const char *program = "model";

static int usage_error(const char *format, const char *a, const char *b)
{
    fprintf(stderr, "%s: error: ", program);
    fprintf(stderr, format, a, b);
    fprintf(stderr, "\n(%s --help shows the options)\n", program);
    return EXIT_USAGE;
}

static void print_help(void)
{
    char t_end[DEP_FORMAT_SIZE], dt_out[DEP_FORMAT_SIZE], tol[DEP_FORMAT_SIZE];
    dep_repr(depsim_model.t_end, t_end, sizeof t_end); /* 0.05, not 0.050000000000000003 */
    dep_repr(depsim_model.dt_out, dt_out, sizeof dt_out);
    dep_repr(depsim_model.tol, tol, sizeof tol);
    printf("usage: %s [--set NAME=VALUE]... [--t-end T] [--dt-out DT] [--tol TOL]\n"
           "       [--max-steps N] [--stepping auto|explicit|implicit] [-o CSV]\n"
           "       %s --list\n\n"
           "Simulate %s (%s) with the depsim C integrator.\n\n"
           "  --set NAME=VALUE  set a parameter, a plain number in SI units (no unit text);\n"
           "                    repeatable; --list shows the names and units\n"
           "  --t-end T         end time, s (default %s)\n"
           "  --dt-out DT       output interval, s (default %s)\n"
           "  --tol TOL         integration tolerance (default %s)\n"
           "  --max-steps N     the most steps a run may take (default %.0f); a stiff run\n"
           "                    that would need more stops at once\n"
           "  --stepping S      the ODE method: auto (default: explicit, linearly implicit\n"
           "                    once a beam's stiff modes bound the explicit step),\n"
           "                    explicit or implicit (docs/method.md, 10)\n"
           "  -o, --out CSV     write the outputs to CSV (else to stdout)\n"
           "  --list            list the parameters and exit\n\n"
           "Exit codes: 0 ok, 1 failed to write or out of memory, 2 usage error, 3 solver "
           "failure.\n", program, program, depsim_model.name, depsim_model.description,
           t_end, dt_out, tol, DEP_MAX_STEPS);
}

static void print_parameters(void)
{
    char value[DEP_FORMAT_SIZE];
    printf("%-28s %-14s %s\n", "parameter", "SI unit", "default");
    for (int i = 0; i < depsim_model.np; ++i) {
        dep_repr(depsim_model.parameter_defaults[i], value, sizeof value);
        printf("%-28s %-14s %s\n", depsim_model.parameter_names[i],
               depsim_model.parameter_units[i], value);
    }
    for (int i = 0; i < depsim_model.nfix; ++i) {
        printf("%-28s %-14s %d (structural: fixed in the model text)\n",
               depsim_model.fixed_names[i], "-", depsim_model.fixed_values[i]);
    }
}

/* A whole-string finite number; 0 when `text` is not one. */
static int parse_number(const char *text, double *value)
{
    char *end = NULL;
    if (text[0] == '\0') {
        return 0;
    }
    *value = strtod(text, &end);
    while (*end == ' ') {
        ++end;
    }
    return *end == '\0' && isfinite(*value);
}

/* ---- --set NAME=VALUE --------------------------------------------------------------------- */

/* The longest common subsequence of a and b (names are short). */
static size_t common_letters(const char *a, const char *b)
{
    size_t n = strlen(b), row[DEP_NAME_MAX + 1] = {0};
    if (n > DEP_NAME_MAX) {
        return 0;
    }
    for (size_t i = 1; a[i - 1] != '\0'; ++i) {
        size_t diagonal = 0;
        for (size_t j = 1; j <= n; ++j) {
            size_t above = row[j];
            row[j] = a[i - 1] == b[j - 1] ? diagonal + 1 : above > row[j - 1] ? above : row[j - 1];
            diagonal = above;
        }
    }
    return row[n];
}

/* The parameter most like `name` with a similarity 2 M / (|name| + |candidate|) >= 0.6 (M:
   common letters, as difflib's ratio, which `depsim run` uses), or NULL. */
static const char *closest_parameter(const char *name)
{
    const char *best = NULL;
    double best_score = 0.6;
    for (int i = 0; i < depsim_model.np; ++i) {
        const char *candidate = depsim_model.parameter_names[i];
        size_t total = strlen(name) + strlen(candidate);
        double score = total ? 2.0 * (double)common_letters(name, candidate) / (double)total : 0;
        if (score >= best_score) {
            best = candidate;
            best_score = score + 1e-12; /* the first of equals wins */
        }
    }
    return best;
}

static int set_parameter(const char *item, double *p)
{
    char name[DEP_NAME_MAX];
    const char *equals = strchr(item, '=');
    double value;
    if (equals == NULL || equals == item || equals[1] == '\0'
        || (size_t)(equals - item) >= sizeof name) {
        return usage_error("--set '%s': expected NAME=VALUE, e.g. --set %s=1.5", item,
                           depsim_model.np ? depsim_model.parameter_names[0] : "NAME");
    }
    memcpy(name, item, (size_t)(equals - item));
    name[equals - item] = '\0';
    int index = dep_parameter_index(&depsim_model, name);
    for (int i = 0; index < 0 && i < depsim_model.nfix; ++i) {
        if (strcmp(name, depsim_model.fixed_names[i]) == 0) {
            int value = depsim_model.fixed_values[i];
            fprintf(stderr, "%s: error: '%s' is a structural parameter (a loop bound or an "
                    "index, %s = %d): it was fixed when the model was compiled, not a run-time "
                    "parameter; to change it, edit `param %s = %d` in %s and compile again\n",
                    program, name, name, value, name, value, depsim_model.source_file);
            return EXIT_USAGE;
        }
    }
    if (index < 0) {
        const char *close = closest_parameter(name);
        if (close != NULL) {
            fprintf(stderr, "%s: error: unknown parameter '%s'; did you mean '%s'? "
                    "(%s --list lists them)\n", program, name, close, program);
            return EXIT_USAGE;
        }
        return usage_error("unknown parameter '%s' (%s --list lists them)", name, program);
    }
    if (!parse_number(equals + 1, &value)) {
        fprintf(stderr, "%s: error: bad value for '%s': '%s' is not a finite number; this "
                "program takes plain SI numbers (%s for this parameter), without units\n",
                program, name, equals + 1, depsim_model.parameter_units[index]);
        return EXIT_USAGE;
    }
    p[index] = value;
    return EXIT_OK;
}

/* ---- the command line -------------------------------------------------------------------- */

static int positive(const char *option, const char *text, double *value)
{
    if (!parse_number(text, value)) {
        return usage_error("argument %s: '%s' is not a number", option, text);
    }
    if (!(*value > 0)) {
        return usage_error("argument %s: '%s' must be a positive number", option, text);
    }
    return EXIT_OK;
}

static int stepping(const char *text, int *value)
{
    static const char *const names[] = {"auto", "explicit", "implicit"}; /* enum dep_stepping */
    for (int k = 0; k < 3; ++k) {
        if (strcmp(text, names[k]) == 0) {
            *value = k;
            return EXIT_OK;
        }
    }
    return usage_error("argument --stepping: '%s' is not one of auto, explicit, implicit%s",
                       text, "");
}

/* The value of option `name` at argv[*i] ("--name VALUE" or "--name=VALUE"), or NULL. */
static const char *option_value(int argc, char **argv, int *i, const char *name, int *missing)
{
    size_t length = strlen(name);
    if (strncmp(argv[*i], name, length) != 0) {
        return NULL;
    }
    if (argv[*i][length] == '=') {
        return argv[*i] + length + 1;
    }
    if (argv[*i][length] != '\0') {
        return NULL;
    }
    if (*i + 1 >= argc) {
        *missing = 1;
        return NULL;
    }
    return argv[++*i];
}

static int parse_arguments(int argc, char **argv, options *o)
{
    for (int i = 1; i < argc; ++i) {
        int missing = 0, status = EXIT_OK;
        const char *value;
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            print_help();
            return -1;
        } else if (strcmp(argv[i], "--list") == 0) {
            o->list = 1;
        } else if ((value = option_value(argc, argv, &i, "--set", &missing)) != NULL) {
            status = set_parameter(value, o->p);
        } else if ((value = option_value(argc, argv, &i, "--t-end", &missing)) != NULL) {
            status = positive("--t-end", value, &o->settings.t_end);
        } else if ((value = option_value(argc, argv, &i, "--dt-out", &missing)) != NULL) {
            status = positive("--dt-out", value, &o->settings.dt_out);
        } else if ((value = option_value(argc, argv, &i, "--tol", &missing)) != NULL) {
            status = positive("--tol", value, &o->settings.tol);
        } else if ((value = option_value(argc, argv, &i, "--max-steps", &missing)) != NULL) {
            status = positive("--max-steps", value, &o->settings.max_steps);
        } else if ((value = option_value(argc, argv, &i, "--stepping", &missing)) != NULL) {
            status = stepping(value, &o->settings.stepping);
        } else if ((value = option_value(argc, argv, &i, "--out", &missing)) != NULL
                   || (value = option_value(argc, argv, &i, "-o", &missing)) != NULL) {
            o->out = value;
        } else if (!missing) {
            status = usage_error("unrecognized argument '%s'%s", argv[i], "");
        }
        if (missing) {
            return usage_error("argument %s: expected a value%s", argv[i], "");
        }
        if (status != EXIT_OK) {
            return status;
        }
    }
    return EXIT_OK;
}

/* ---- results ------------------------------------------------------------------------------ */

static int write_csv(const dep_result *r, FILE *file)
{
    fprintf(file, "t");
    for (int j = 0; j < r->nout; ++j) {
        fprintf(file, ",%s", depsim_model.output_names[j]);
    }
    fprintf(file, "\n");
    char number[DEP_FORMAT_SIZE];
    for (int i = 0; i < r->n; ++i) { /* as "%.17g" (dep_format_double) */
        fwrite(number, 1, (size_t)dep_format_double(r->times[i], number), file);
        for (int j = 0; j < r->nout; ++j) {
            putc(',', file);
            fwrite(number, 1, (size_t)dep_format_double(r->outputs[(size_t)i * (size_t)r->nout
                                                                    + (size_t)j], number), file);
        }
        putc('\n', file);
    }
    return ferror(file) ? EXIT_FAILED : EXIT_OK;
}

/* What -o names, as `depsim run` treats it: a regular file or nothing yet is written next to
   it and renamed over it (a failure never leaves a half-written file; a symbolic link is
   followed, its target replaced and the link kept); a pipe or a device (/dev/null, a
   terminal, /dev/fd/N) is written in place, never replaced; a folder is refused. */
enum { PATH_FILE, PATH_IN_PLACE, PATH_FOLDER };

static int path_kind(const char *path)
{
#ifdef HAVE_POSIX
    struct stat st;
    if (stat(path, &st) != 0 || S_ISREG(st.st_mode)) {
        return PATH_FILE;
    }
    return S_ISDIR(st.st_mode) ? PATH_FOLDER : PATH_IN_PLACE;
#else
    (void)path;
    return PATH_FILE;
#endif
}

static int save_csv(const dep_result *r, const char *path)
{
    char partial[4096], target[4096];
    int kind = path_kind(path), status;
    if (kind == PATH_FOLDER) {
        fprintf(stderr, "%s: error: cannot write '%s': it is a folder\n", program, path);
        return EXIT_FAILED;
    }
    if (kind == PATH_IN_PLACE) {
        FILE *file = fopen(path, "w");
        status = file == NULL ? EXIT_FAILED : write_csv(r, file);
        if (file != NULL && fclose(file) != 0) {
            status = EXIT_FAILED;
        }
        if (status != EXIT_OK) {
            fprintf(stderr, "%s: error: cannot write '%s'\n", program, path);
        }
        return status;
    }
    const char *to = path;
#ifdef HAVE_POSIX
    struct stat st;
    char resolved[PATH_MAX];
    if (lstat(path, &st) == 0 && S_ISLNK(st.st_mode) && realpath(path, resolved) != NULL) {
        to = resolved; /* the link's target is replaced, the link kept */
    }
#endif
    if (snprintf(target, sizeof target, "%s", to) >= (int)sizeof target
        || snprintf(partial, sizeof partial, "%s.partial", to) >= (int)sizeof partial) {
        fprintf(stderr, "%s: error: output path too long\n", program);
        return EXIT_FAILED;
    }
    FILE *file = fopen(partial, "w");
    status = file == NULL ? EXIT_FAILED : write_csv(r, file);
    if (file != NULL && fclose(file) != 0) {
        status = EXIT_FAILED;
    }
    if (status == EXIT_OK && rename(partial, target) != 0) {
        status = EXIT_FAILED;
    }
    if (status != EXIT_OK) {
        remove(partial);
        fprintf(stderr, "%s: error: cannot write '%s'\n", program, path);
    }
    return status;
}

int main(int argc, char **argv)
{
    options o;
    dep_result result;
    dep_error error;
    program = depsim_model.name;
    if (argc > 0 && argv[0][0] != '\0') { /* the program's base name */
        program = strrchr(argv[0], '/') != NULL ? strrchr(argv[0], '/') + 1 : argv[0];
    }
    memcpy(o.p, depsim_model.parameter_defaults, (size_t)depsim_model.np * sizeof(double));
    o.settings = dep_default_settings(&depsim_model);
    o.settings.rows = DEP_ROWS_OUTPUTS; /* the CSV's outputs and the summary's loads and work */
    o.out = NULL;
    o.list = 0;
    int status = parse_arguments(argc, argv, &o);
    if (status != EXIT_OK) {
        return status < 0 ? EXIT_OK : status;
    }
    if (o.list) {
        print_parameters();
        return EXIT_OK;
    }
    status = dep_simulate(&depsim_model, o.p, &o.settings, NULL, 0, &result, &error);
    if (status == DEP_SOLVER_ERROR) {
        fprintf(stderr, "%s: solver failure: %s\n", program, error.message);
        return EXIT_SOLVER;
    }
    if (status != DEP_OK) {
        fprintf(stderr, "%s: error: %s\n", program, error.message);
        return status == DEP_SETTINGS_ERROR ? EXIT_USAGE : EXIT_FAILED;
    }
    if (o.out != NULL) {
        status = save_csv(&result, o.out);
        if (status == EXIT_OK) {
            fputs(result.report, stdout);
        }
    } else {
        status = write_csv(&result, stdout);
    }
    dep_result_free(&result);
    return status;
}
