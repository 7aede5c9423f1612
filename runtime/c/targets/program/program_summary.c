/* program_summary.c: the JSON summary of a run, as `depsim run --summary` writes it
 * (depsim.runtime.Result.summary() through json.dumps(indent=2), program.h): the same keys in
 * the same order, numbers as Python's repr (NaN, Infinity where Python writes them; null
 * where the summary has None), text escaped to ASCII as json.dumps escapes it.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "program.h"
#include "model.h"

#define DEPTH_MAX 8

/* A JSON writer laying out as json.dumps(indent=2): one member or item a line. */
typedef struct json {
    FILE *file;
    int depth;
    int empty[DEPTH_MAX + 1]; /* no member or item yet at that depth */
} json;

static void next_line(json *j)
{
    putc('\n', j->file);
    for (int k = 0; k < 2 * j->depth; ++k) {
        putc(' ', j->file);
    }
}

/* The UTF-8 sequence at s as a code point (U+FFFD for a byte that starts none, as Python's
   errors="replace" reads it); *length: the bytes it took. */
static unsigned long code_point(const unsigned char *s, int *length)
{
    int n = s[0] < 0x80 ? 1 : (s[0] & 0xE0) == 0xC0 ? 2 : (s[0] & 0xF0) == 0xE0 ? 3
            : (s[0] & 0xF8) == 0xF0 ? 4 : 0;
    unsigned long c = n == 1 ? s[0] : n == 2 ? s[0] & 0x1Fu : n == 3 ? s[0] & 0x0Fu : s[0] & 0x07u;
    for (int k = 1; k < n; ++k) {
        if ((s[k] & 0xC0) != 0x80) {
            n = 0;
            break;
        }
        c = (c << 6) | (s[k] & 0x3Fu);
    }
    static const unsigned long least[5] = {0, 0, 0x80, 0x800, 0x10000};
    if (n == 0 || c < least[n] || c > 0x10FFFF || (c >= 0xD800 && c <= 0xDFFF)) {
        *length = 1;
        return 0xFFFD;
    }
    *length = n;
    return c;
}

/* A text as json.dumps writes it (ensure_ascii): printable ASCII as it is, the rest escaped. */
static void string(json *j, const char *text)
{
    const unsigned char *s = (const unsigned char *)text;
    putc('"', j->file);
    while (*s != '\0') {
        int length;
        unsigned long c = code_point(s, &length);
        const char *short_form = c == '"' ? "\\\"" : c == '\\' ? "\\\\" : c == '\n' ? "\\n"
                                 : c == '\r' ? "\\r" : c == '\t' ? "\\t" : c == '\b' ? "\\b"
                                 : c == '\f' ? "\\f" : NULL;
        if (short_form != NULL) {
            fputs(short_form, j->file);
        } else if (c >= 0x20 && c < 0x7F) {
            putc((int)c, j->file);
        } else if (c < 0x10000) {
            fprintf(j->file, "\\u%04lx", c);
        } else {
            c -= 0x10000;
            fprintf(j->file, "\\u%04lx\\u%04lx", 0xD800 + (c >> 10), 0xDC00 + (c & 0x3FF));
        }
        s += length;
    }
    putc('"', j->file);
}

static void open_(json *j, char bracket)
{
    putc(bracket, j->file);
    j->empty[++j->depth] = 1;
}

static void close_(json *j, char bracket)
{
    int empty = j->empty[j->depth--];
    if (!empty) {
        next_line(j);
    }
    putc(bracket, j->file);
}

/* The start of the next item of an array, or of the member `name` of an object. */
static void item(json *j)
{
    if (!j->empty[j->depth]) {
        putc(',', j->file);
    }
    j->empty[j->depth] = 0;
    next_line(j);
}

static void key(json *j, const char *name)
{
    item(j);
    string(j, name);
    fputs(": ", j->file);
}

/* A float as json.dumps writes it: repr, NaN, Infinity, -Infinity. */
static void number(json *j, double x)
{
    char text[DEP_FORMAT_SIZE];
    if (isnan(x) || isinf(x)) {
        fputs(isnan(x) ? "NaN" : x > 0 ? "Infinity" : "-Infinity", j->file);
        return;
    }
    dep_repr(x, text, sizeof text);
    fputs(text, j->file);
}

/* A float that the summary gives as None when it is not finite (its `_finite`) or, with
   nan_only, when it is nan (a field the core leaves nan when it does not apply). */
static void optional(json *j, double x, int nan_only)
{
    if (isnan(x) || (!nan_only && isinf(x))) {
        fputs("null", j->file);
    } else {
        number(j, x);
    }
}

static void integer(json *j, long long value)
{
    fprintf(j->file, "%lld", value);
}

static void named_number(json *j, const char *name, double x)
{
    key(j, name);
    number(j, x);
}

static void named_integer(json *j, const char *name, long long value)
{
    key(j, name);
    integer(j, value);
}

static void passes(json *j, const char *name, const dep_pass_stats *p)
{
    key(j, name);
    open_(j, '{');
    named_number(j, "mean", p->mean);
    named_integer(j, "max", p->max);
    named_integer(j, "total", p->total);
    close_(j, '}');
}

/* Result.stats as dataclasses.asdict gives it. */
static void statistics(json *j, const dep_stats *s)
{
    key(j, "statistics");
    open_(j, '{');
    named_integer(j, "accepted_steps", s->accepted_steps);
    named_integer(j, "rejected_steps", s->rejected_steps);
    named_integer(j, "failed_steps", s->failed_steps);
    named_integer(j, "integrations", s->integrations);
    named_integer(j, "rhs_evaluations", s->rhs_evaluations);
    passes(j, "position", &s->position);
    passes(j, "velocity", &s->velocity);
    passes(j, "acceleration", &s->acceleration);
    named_integer(j, "cg_iterations", s->cg_iterations);
    named_integer(j, "factorizations", s->factorizations);
    named_number(j, "max_v_pos", s->max_v_pos);
    named_number(j, "max_v_vel", s->max_v_vel);
    named_number(j, "max_v_acc", s->max_v_acc);
    named_number(j, "min_step", s->min_step);
    named_number(j, "max_step", s->max_step);
    named_integer(j, "events", s->events);
    key(j, "implicit_from");
    optional(j, s->implicit_from, 1);
    key(j, "stiff_rate");
    optional(j, s->stiff_rate, 1);
    named_integer(j, "force_steps", s->force_steps);
    close_(j, '}');
}

static void datum(json *j, const dep_datum *d)
{
    switch (d->kind) {
    case DEP_TEXT: string(j, d->text); break;
    case DEP_BOOL: fputs(d->number != 0 ? "true" : "false", j->file); break;
    case DEP_NONE: fputs("null", j->file); break;
    default: number(j, d->number);
    }
}

/* The first entry of record e with key `name`, or NULL. */
static const dep_datum *first_entry(const dep_event_record *e, const char *name)
{
    for (int k = 0; k < e->n_data; ++k) {
        if (strcmp(e->data[k].key, name) == 0) {
            return &e->data[k];
        }
    }
    return NULL;
}

/* The value under key `name` of the record's data: the entry itself, or the dict of the
   entries with members (EventRecord.data, runtime.runner._data). */
static void data_value(json *j, const dep_event_record *e, const dep_datum *first)
{
    if (first->member[0] == '\0') {
        datum(j, first);
        return;
    }
    open_(j, '{');
    for (int k = 0; k < e->n_data; ++k) {
        if (strcmp(e->data[k].key, first->key) == 0 && e->data[k].member[0] != '\0') {
            key(j, e->data[k].member);
            datum(j, &e->data[k]);
        }
    }
    close_(j, '}');
}

/* {"name": ..., "t": ..., **data}: the data's keys in order, "name" and "t" replaced in
   place if the data has them. */
static void event(json *j, const dep_event_record *e)
{
    const dep_datum *name = first_entry(e, "name"), *t = first_entry(e, "t");
    item(j);
    open_(j, '{');
    key(j, "name");
    name != NULL ? data_value(j, e, name) : string(j, e->name);
    key(j, "t");
    t != NULL ? data_value(j, e, t) : number(j, e->t);
    for (int k = 0; k < e->n_data; ++k) {
        const dep_datum *d = &e->data[k];
        if (first_entry(e, d->key) == d && strcmp(d->key, "name") != 0
            && strcmp(d->key, "t") != 0) {
            key(j, d->key);
            data_value(j, e, d);
        }
    }
    close_(j, '}');
}

static void deployment(json *j, const dep_deployment *d)
{
    key(j, "deployment");
    open_(j, '{');
    key(j, "deployed");
    fputs(d->deployed < 0 ? "null" : d->deployed ? "true" : "false", j->file);
    key(j, "time_to_deploy");
    optional(j, d->time, 1);
    key(j, "latch_hinges");
    open_(j, '[');
    for (int k = 0; k < d->n_latch_hinges; ++k) {
        item(j);
        string(j, depsim_model.hinge_names[d->latch_hinges[k]]);
    }
    close_(j, ']');
    key(j, "latches");
    open_(j, '[');
    for (int k = 0; k < d->n_latches; ++k) {
        const dep_latch_summary *s = &d->latches[k];
        const char *names[4] = {"t", "rate", "impulse", "energy_loss"};
        double values[4] = {s->t, s->rate, s->impulse, s->energy_loss};
        item(j);
        open_(j, '{');
        key(j, "hinge");
        string(j, depsim_model.hinge_names[s->hinge]);
        for (int v = 0; v < 4; ++v) {
            key(j, names[v]);
            optional(j, values[v], 0);
        }
        key(j, "rigid");
        fputs(s->rigid ? "true" : "false", j->file);
        close_(j, '}');
    }
    close_(j, ']');
    named_number(j, "friction_energy", d->friction_energy);
    named_number(j, "impact_energy", d->impact_energy);
    close_(j, '}');
}

/* Whether hinge entry k is a slider's (its name is one: names are unique in a model). */
static int slider_entry(int k)
{
    for (int s = 0; s < depsim_model.ns; ++s) {
        if (strcmp(depsim_model.slider_names[s], depsim_model.hinge_names[k]) == 0) {
            return 1;
        }
    }
    return 0;
}

static void peak_loads(json *j, const dep_result *r)
{
    key(j, "peak_hinge_loads");
    open_(j, '{');
    for (int k = 0; k < r->nh; ++k) {
        const dep_peak *p = &r->peak_loads[k];
        const char *names[4] = {"force", "t_force", "torque", "t_torque"};
        double values[4] = {p->force, p->t_force, p->torque, p->t_torque};
        if (slider_entry(k)) { /* a slider's: its lock force, along its axis (as
                                  runtime/reading.py) */
            double slider[4] = {p->torque, p->t_torque, 0.0, NAN};
            memcpy(values, slider, sizeof values);
        }
        key(j, depsim_model.hinge_names[k]);
        open_(j, '{');
        for (int v = 0; v < 4; ++v) {
            key(j, names[v]);
            optional(j, values[v], 0);
        }
        key(j, "unique");
        fputs(p->unique ? "true" : "false", j->file);
        close_(j, '}');
    }
    close_(j, '}');
}

int program_write_summary(const dep_result *r, FILE *file)
{
    json j = {file, 0, {1}};
    open_(&j, '{');
    key(&j, "model");
    string(&j, depsim_model.name);
    key(&j, "method");
    string(&j, "iterative");
    key(&j, "parameters");
    open_(&j, '{');
    for (int k = 0; k < depsim_model.np; ++k) {
        named_number(&j, depsim_model.parameter_names[k], r->params[k]);
    }
    close_(&j, '}');
    key(&j, "tolerances");
    open_(&j, '{');
    named_number(&j, "tol", r->tol);
    named_number(&j, "constraint_tol", r->constraint_tol);
    named_number(&j, "t_end", r->t_end);
    named_number(&j, "dt_out", r->dt_out);
    close_(&j, '}');
    statistics(&j, &r->stats);
    key(&j, "events");
    open_(&j, '[');
    for (int k = 0; k < r->n_events; ++k) {
        event(&j, &r->events[k]);
    }
    close_(&j, ']');
    deployment(&j, &r->deployment);
    peak_loads(&j, r);
    close_(&j, '}');
    putc('\n', file);
    return ferror(file) ? EXIT_FAILED : EXIT_OK;
}
