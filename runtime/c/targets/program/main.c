/* main.c: the standalone program of a C target folder (docs/c-target.md, section 4): its
 * options, the run, the exit codes (program.h).
 *
 *     ./MODEL [--set NAME=VALUE]... [--input NAME=FILE.csv]... [--t-end T] [--dt-out DT]
 *             [--tol TOL] [--max-steps N] [--stepping auto|explicit|implicit]
 *             [-o out.csv] [--summary summary.json]
 *     ./MODEL --list          parameters, their SI units and defaults
 *
 * Values are plain numbers in SI units (m, kg, s, rad, N*m, ...); units are not parsed here
 * (`depsim run` accepts them). Writes the CSV and the JSON summary of `depsim run`. With -o
 * the CSV goes to the file and the run's report to stdout; without, the CSV goes to stdout.
 * Exit codes: 0 ok, 1 out of memory or an unwritable file, 2 usage error, 3 solver failure.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "program.h"
#include "model.h"

typedef struct options {
    double p[MODEL_NP + 1];
    unsigned char set[MODEL_NP + 1]; /* given by --set */
    const char *set_values[MODEL_NP + 1]; /* the text --set gave each */
    dep_settings settings;
    const char *out, *summary;
    int list;
    int n_inputs;
    const char **inputs; /* the --input items, NAME=FILE (room for every argument) */
} options;

const char *program = "model";

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
    printf("usage: %s [--set NAME=VALUE]... [--input NAME=CSV]... [--t-end T] [--dt-out DT]\n"
           "       [--tol TOL] [--max-steps N] [--stepping auto|explicit|implicit] [-o CSV]\n"
           "       [--summary JSON]\n"
           "       %s --list\n\n"
           "Simulate %s (%s) with the depsim C integrator.\n\n"
           "  --set NAME=VALUE  set a parameter, a plain number in SI units (no unit text);\n"
           "                    repeatable; --list shows the names and units\n"
           "  --input NAME=CSV  drive input NAME by the time table in CSV (lines 't,u' in SI,\n"
           "                    linear in between); a constant input is a --set; repeatable\n"
           "  --t-end T         end time, s (default %s)\n"
           "  --dt-out DT       output interval, s (default %s)\n"
           "  --tol TOL         integration tolerance (default %s)\n"
           "  --max-steps N     the most steps a run may take (default %.0f); a stiff run\n"
           "                    that would need more stops at once\n"
           "  --stepping S      the ODE method: auto (default: explicit, linearly implicit\n"
           "                    once a beam's stiff modes bound the explicit step),\n"
           "                    explicit or implicit (docs/method.md, 10)\n"
           "  -o, --out CSV     write the outputs to CSV (else to stdout) and print the report\n"
           "  --summary JSON    write the run's JSON summary (as depsim run --summary)\n"
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

/* `text` without the white space at either end, into out (size bytes). */
static void stripped(const char *text, size_t length, char *out, size_t size)
{
    while (length > 0 && strchr(" \t\n\r\f\v", text[0]) != NULL) {
        ++text;
        --length;
    }
    while (length > 0 && strchr(" \t\n\r\f\v", text[length - 1]) != NULL) {
        --length;
    }
    snprintf(out, size, "%.*s", (int)(length < size ? length : size - 1), text);
}

static int set_parameter(const char *item, options *o)
{
    double *p = o->p;
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
    if (o->set[index]) {
        char before[64], now[64];
        stripped(o->set_values[index], strlen(o->set_values[index]), before, sizeof before);
        stripped(equals + 1, strlen(equals + 1), now, sizeof now);
        fprintf(stderr, "%s: error: --set %s is given twice (%s and %s): give each parameter "
                "once\n", program, name, before, now);
        return EXIT_USAGE;
    }
    p[index] = value;
    o->set[index] = 1;
    o->set_values[index] = equals + 1;
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
            status = set_parameter(value, o);
        } else if ((value = option_value(argc, argv, &i, "--input", &missing)) != NULL) {
            o->inputs[o->n_inputs++] = value;
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
        } else if ((value = option_value(argc, argv, &i, "--summary", &missing)) != NULL) {
            o->summary = value;
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

/* ---- --input NAME=FILE ----------------------------------------------------------------- */

typedef struct inputs {
    int n;                   /* tables read */
    dep_input_table *tables; /* one per --input item */
    double **values;         /* 2 a table: its times and values (malloc'ed) */
    char (*names)[DEP_NAME_MAX]; /* each item's input name */
} inputs;

static void free_inputs(inputs *in)
{
    for (int k = 0; in->values != NULL && k < 2 * in->n; ++k) {
        free(in->values[k]);
    }
    free(in->values);
    free(in->tables);
    free(in->names);
}

/* NAME and FILE of an --input item, as `depsim run` splits it; EXIT_USAGE if it is not one. */
static int input_item(const char *item, char *name, char *path)
{
    const char *equals = strchr(item, '=');
    if (equals != NULL) {
        stripped(item, (size_t)(equals - item), name, DEP_NAME_MAX);
        stripped(equals + 1, strlen(equals + 1), path, PROGRAM_PATH_MAX);
    }
    if (equals == NULL || name[0] == '\0' || path[0] == '\0') {
        fprintf(stderr, "%s: error: --input '%s': expected NAME=FILE, e.g. --input "
                "T_motor=torque.csv\n", program, item);
        return EXIT_USAGE;
    }
    return EXIT_OK;
}

/* An input given a table and a value: refused before anything is read. */
static int table_and_value(const options *o, const char *name)
{
    char given[DEP_NAME_MAX + 8];
    for (int rate = 0; rate < 2; ++rate) {
        snprintf(given, sizeof given, "%s%s", name, rate ? ".rate" : "");
        int index = dep_parameter_index(&depsim_model, given);
        if (index >= 0 && o->set[index]) {
            fprintf(stderr, "%s: error: input %s is given both a table (--input %s=...) and a "
                    "value (--set %s=...): give one\n", program, name, name, given);
            return EXIT_USAGE;
        }
    }
    return EXIT_OK;
}

static int input_index(const char *name)
{
    for (int k = 0; k < depsim_model.ni; ++k) {
        if (strcmp(depsim_model.input_names[k], name) == 0) {
            return k;
        }
    }
    return -1;
}

static int unknown_input(const char *name)
{
    fprintf(stderr, "%s: error: unknown input '%s'; the model's inputs: ", program, name);
    for (int k = 0; k < depsim_model.ni; ++k) {
        fprintf(stderr, "%s%s", k ? ", " : "", depsim_model.input_names[k]);
    }
    fprintf(stderr, "%s\n", depsim_model.ni ? "" : "none: the model has no `input` statement");
    return EXIT_USAGE;
}

/* One --input item's table (k: its place), unless its input was given one before. */
static int read_input(inputs *in, int k, const char *path)
{
    for (int j = 0; j < k; ++j) {
        if (strcmp(in->names[j], in->names[k]) == 0) {
            fprintf(stderr, "%s: error: --input %s is given twice: give each input one table\n",
                    program, in->names[k]);
            return EXIT_USAGE;
        }
    }
    dep_input_table *table = &in->tables[k];
    ++in->n;
    int status = program_read_table(in->names[k], path, &in->values[2 * k],
                                     &in->values[2 * k + 1], &table->n);
    table->t = in->values[2 * k];
    table->u = in->values[2 * k + 1];
    return status;
}

/* The --input tables, read as `depsim run --input` reads them (program_tables.c), in `in`:
   the items' form and their clashes with --set first, then each file, then the names. */
static int read_inputs(const options *o, inputs *in)
{
    char path[PROGRAM_PATH_MAX];
    int status = EXIT_OK, n = o->n_inputs;
    in->tables = calloc((size_t)n + 1, sizeof *in->tables);
    in->values = calloc(2 * (size_t)n + 1, sizeof *in->values);
    in->names = calloc((size_t)n + 1, sizeof *in->names);
    if (in->tables == NULL || in->values == NULL || in->names == NULL) {
        fprintf(stderr, "%s: error: out of memory\n", program);
        return EXIT_FAILED;
    }
    for (int k = 0; k < n && status == EXIT_OK; ++k) {
        if ((status = input_item(o->inputs[k], in->names[k], path)) == EXIT_OK) {
            status = table_and_value(o, in->names[k]);
        }
    }
    for (int k = 0; k < n && status == EXIT_OK; ++k) {
        input_item(o->inputs[k], in->names[k], path);
        status = read_input(in, k, path);
    }
    for (int k = 0; k < n && status == EXIT_OK; ++k) {
        in->tables[k].input = input_index(in->names[k]);
        status = in->tables[k].input < 0 ? unknown_input(in->names[k]) : EXIT_OK;
    }
    return status;
}

/* ---- the run -------------------------------------------------------------------------------- */

/* The run and its outputs, once the options are read. */
static int run(options *o)
{
    program_output outputs[2] = {{"-o", o->out, program_write_csv, 0, "", ""},
                                 {"--summary", o->summary, program_write_summary, 0, "", ""}};
    inputs in = {0, NULL, NULL, NULL};
    dep_result result;
    dep_error error;
    int status = program_check_outputs(outputs, 2);
    if (status == EXIT_OK && (status = read_inputs(o, &in)) == EXIT_OK) {
        o->settings.tables = in.tables;
        o->settings.n_tables = in.n;
        status = dep_simulate(&depsim_model, o->p, &o->settings, NULL, 0, &result, &error);
        if (status == DEP_SOLVER_ERROR) {
            fprintf(stderr, "%s: solver failure: %s\n", program, error.message);
            status = EXIT_SOLVER;
        } else if (status != DEP_OK) {
            fprintf(stderr, "%s: error: %s\n", program, error.message);
            status = status == DEP_SETTINGS_ERROR ? EXIT_USAGE : EXIT_FAILED;
        } else {
            status = program_write_outputs(outputs, 2, &result);
            if (status == EXIT_OK && o->out != NULL) {
                fputs(result.report, stdout);
            } else if (status == EXIT_OK) {
                status = program_write_csv(&result, stdout);
            }
            dep_result_free(&result);
        }
    }
    free_inputs(&in);
    return status;
}

int main(int argc, char **argv)
{
    options o;
    program = depsim_model.name;
    if (argc > 0 && argv[0][0] != '\0') { /* the program's base name */
        program = strrchr(argv[0], '/') != NULL ? strrchr(argv[0], '/') + 1 : argv[0];
    }
    memset(&o, 0, sizeof o);
    memcpy(o.p, depsim_model.parameter_defaults, (size_t)depsim_model.np * sizeof(double));
    o.settings = dep_default_settings(&depsim_model);
    o.settings.rows = DEP_ROWS_OUTPUTS; /* the CSV's outputs and the summary's loads and work */
    o.inputs = malloc((size_t)(argc > 0 ? argc : 1) * sizeof *o.inputs);
    if (o.inputs == NULL) {
        fprintf(stderr, "%s: error: out of memory\n", program);
        return EXIT_FAILED;
    }
    int status = parse_arguments(argc, argv, &o);
    if (status == EXIT_OK && o.list) {
        print_parameters();
    } else if (status == EXIT_OK) {
        status = run(&o);
    }
    free(o.inputs);
    return status < 0 ? EXIT_OK : status;
}
