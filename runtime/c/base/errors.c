/* errors.c: a run's errors, the text of depsim.runtime.SolverError field by field, and
 * Python's repr of a float for the messages (base.h).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base.h"

/* Copy `from` into `to` (size bytes), cut short if needed, always terminated. */
void dep_copy_text(char *to, size_t size, const char *from)
{
    size_t i = 0;
    for (; from != NULL && from[i] != '\0' && i + 1 < size; ++i) {
        to[i] = from[i];
    }
    to[i] = '\0';
}

void dep_error_clear(dep_error *error)
{
    memset(error, 0, sizeof *error);
}

static int is_pass(const char *stage)
{
    return strcmp(stage, "position") == 0 || strcmp(stage, "velocity") == 0
           || strcmp(stage, "acceleration") == 0;
}

int dep_solver_error(dep_error *error, int has_t, double t, const char *stage, const char *row,
                     const char *joint, int has_residual, double residual, const char *what,
                     const char *hint)
{
    char head[600] = "";
    size_t used = 0;
    dep_error_clear(error);
    error->code = DEP_SOLVER_ERROR;
    error->has_t = has_t;
    error->t = t;
    error->has_residual = has_residual;
    error->residual = residual;
    dep_copy_text(error->stage, sizeof error->stage, stage);
    dep_copy_text(error->row, sizeof error->row, row);
    dep_copy_text(error->joint, sizeof error->joint, joint);
    dep_copy_text(error->what, sizeof error->what, what);
    dep_copy_text(error->hint, sizeof error->hint, hint);
    /* SolverError._format: "t = .. s, <stage> pass, <joint> (row <row>): what\n  hint: .." */
    if (has_t) {
        used += (size_t)snprintf(head + used, sizeof head - used, "t = %.9g s", t);
    }
    if (stage != NULL && used < sizeof head) {
        used += (size_t)snprintf(head + used, sizeof head - used, "%s%s%s", used ? ", " : "",
                                 stage, is_pass(stage) ? " pass" : "");
    }
    if (joint != NULL && used < sizeof head) {
        used += (size_t)snprintf(head + used, sizeof head - used, "%s%s", used ? ", " : "", joint);
        if (row != NULL && row[0] != '\0' && used < sizeof head) {
            snprintf(head + used, sizeof head - used, " (row %s)", row);
        }
    }
    if (head[0] != '\0') {
        snprintf(error->message, sizeof error->message, "%s: %s", head, error->what);
    } else {
        dep_copy_text(error->message, sizeof error->message, error->what);
    }
    if (hint != NULL && hint[0] != '\0') {
        used = strlen(error->message);
        snprintf(error->message + used, sizeof error->message - used, "\n  hint: %s", hint);
    }
    return DEP_SOLVER_ERROR;
}

int dep_plain_error(dep_error *error, int code, const char *message)
{
    dep_error_clear(error);
    error->code = code;
    dep_copy_text(error->what, sizeof error->what, message);
    dep_copy_text(error->message, sizeof error->message, message);
    return code;
}

void dep_repr(double value, char *out, size_t size)
{
    char digits[40];
    int precision = 1;
    if (isnan(value) || isinf(value)) {
        snprintf(out, size, "%s", isnan(value) ? "nan" : value > 0 ? "inf" : "-inf");
        return;
    }
    /* the shortest digits that read back exactly, placed as Python's repr places them */
    for (; precision < 17; ++precision) {
        snprintf(digits, sizeof digits, "%.*e", precision - 1, value);
        if (strtod(digits, NULL) == value) {
            break;
        }
    }
    snprintf(digits, sizeof digits, "%.*e", precision - 1, value);
    int exponent = atoi(strchr(digits, 'e') + 1);
    if (exponent < -4 || exponent >= 16) {
        char mantissa[40];
        snprintf(mantissa, sizeof mantissa, "%.*s", (int)(strchr(digits, 'e') - digits), digits);
        snprintf(out, size, "%se%c%02d", mantissa, exponent < 0 ? '-' : '+', abs(exponent));
    } else {
        int decimals = precision - 1 - exponent;
        snprintf(out, size, "%.*f", decimals > 0 ? decimals : 1, value);
    }
}
