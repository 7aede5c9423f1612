/* program_tables.c: --input NAME=FILE.csv, an input's time table read with the rules and the
 * messages of depsim.runtime.tables.read_table (program.h):
 *
 * two numbers a line, `t,u` (s and the input's SI unit), times never decreasing (a repeated
 * time is a jump); blank lines and `#` comments skipped; the first line with content may be a
 * header naming the two columns (each field starts with a letter or `_` and is not a
 * number); a UTF-8 byte-order mark dropped; lines end at \n, \r\n or \r; a number is what
 * Python's float() reads (digits with single `_` between them, inf, nan); any other line is an
 * error naming FILE:LINE. A file over 64 MiB is refused unread.
 */
#if defined(__unix__) || defined(__APPLE__)
#define _XOPEN_SOURCE 700 /* stat: what a path names */
#include <sys/stat.h>
#define HAVE_POSIX 1
#endif
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "program.h"

#define MAX_TABLE_BYTES (64L * 1024 * 1024) /* tables.MAX_TABLE_BYTES */
#define BLOCK_LINES 16384                   /* tables.BLOCK_LINES: a decode error's "after" */
#define DECODE_CHUNK 8192                   /* the bytes Python's text reader decodes at once */
#define FIELD_MAX 1024

typedef struct reader {
    const char *name, *path; /* the input, the file as Python's Path prints it */
    double *t, *u;
    int n, capacity;
} reader;

static int fail(const reader *r, const char *message)
{
    fprintf(stderr, "%s: error: --input %s: %s: %s\n", program, r->name, r->path, message);
    return EXIT_USAGE;
}

/* ---- text as Python sees it ---------------------------------------------------------------- */

/* The length of a UTF-8 whitespace character (str.isspace) at s..end, else 0. */
static int space(const unsigned char *s, const unsigned char *end)
{
    if (s >= end) {
        return 0;
    }
    if (*s == ' ' || (*s >= 0x09 && *s <= 0x0D) || (*s >= 0x1C && *s <= 0x1F)) {
        return 1;
    }
    unsigned long c = 0;
    int n = (*s & 0xE0) == 0xC0 ? 2 : (*s & 0xF0) == 0xE0 ? 3 : 0;
    if (n == 0 || end - s < n) {
        return 0;
    }
    c = n == 2 ? (s[0] & 0x1Fu) << 6 | (s[1] & 0x3Fu)
               : (s[0] & 0x0Fu) << 12 | (s[1] & 0x3Fu) << 6 | (s[2] & 0x3Fu);
    int white = c == 0x85 || c == 0xA0 || c == 0x1680 || (c >= 0x2000 && c <= 0x200A)
                || c == 0x2028 || c == 0x2029 || c == 0x202F || c == 0x205F || c == 0x3000;
    return white ? n : 0;
}

/* str.strip(): [*begin, *end) without whitespace at either end. */
static void strip(const char **begin, const char **end)
{
    const unsigned char *b = (const unsigned char *)*begin, *e = (const unsigned char *)*end;
    for (int n; (n = space(b, e)) > 0;) {
        b += n;
    }
    while (e > b) { /* the last character: back to its first byte */
        const unsigned char *c = e - 1;
        while (c > b && (*c & 0xC0) == 0x80 && e - c < 3) {
            --c;
        }
        if (space(c, e) != e - c) {
            break;
        }
        e = c;
    }
    *begin = (const char *)b;
    *end = (const char *)e;
}

/* Digits with single '_' between two of them, from s[i] (copied to out without the '_'): the
   index after them (i when there are none). */
static size_t digit_part(const char *s, size_t i, size_t n, char *out, size_t *used)
{
    while (i < n && isdigit((unsigned char)s[i])) {
        out[(*used)++] = s[i++];
        if (i + 1 < n && s[i] == '_' && isdigit((unsigned char)s[i + 1])) {
            ++i;
        }
    }
    return i;
}

/* float(text) of Python: 1 and the value, or 0 when text is not a number. Text is stripped:
   [sign] (inf | infinity | nan, any case) or [sign] (digits [. [digits]] | . digits)
   [(e | E) [sign] digits]. */
static int python_float(const char *text, size_t n, double *value)
{
    char digits[FIELD_MAX];
    size_t i = 0, used = 0, mark;
    if (n == 0 || n >= sizeof digits) {
        return 0;
    }
    if (text[0] == '+' || text[0] == '-') {
        digits[used++] = text[i++];
    }
    static const char *const words[] = {"inf", "infinity", "nan"};
    for (int w = 0; w < 3; ++w) {
        int same = n - i == strlen(words[w]);
        for (size_t k = 0; same && k < n - i; ++k) {
            same = tolower((unsigned char)text[i + k]) == words[w][k];
        }
        if (same) {
            *value = w == 2 ? NAN : text[0] == '-' ? -INFINITY : INFINITY;
            return 1;
        }
    }
    mark = i;
    i = digit_part(text, i, n, digits, &used);
    int mantissa = i > mark;
    if (i < n && text[i] == '.') {
        digits[used++] = text[i++];
        mark = i;
        i = digit_part(text, i, n, digits, &used);
        mantissa = mantissa || i > mark;
    }
    if (!mantissa) {
        return 0;
    }
    if (i < n && (text[i] == 'e' || text[i] == 'E')) {
        digits[used++] = text[i++];
        if (i < n && (text[i] == '+' || text[i] == '-')) {
            digits[used++] = text[i++];
        }
        mark = i;
        i = digit_part(text, i, n, digits, &used);
        if (i == mark) {
            return 0;
        }
    }
    if (i != n) {
        return 0;
    }
    digits[used] = '\0';
    *value = strtod(digits, NULL);
    return 1;
}

/* A column's name: starts with an ASCII letter or `_` and is not a number (tables._is_name). */
static int is_name(const char *text, size_t length)
{
    double ignored;
    return length > 0 && (isalpha((unsigned char)text[0]) || text[0] == '_')
           && !python_float(text, length, &ignored);
}

/* ---- the table ------------------------------------------------------------------------------- */

typedef struct field {
    const char *text;
    size_t length;
} field;

/* The fields of content (split at ',', each stripped); the count (all of them, even beyond
   `most`). */
static int split(const char *content, const char *end, field *fields, int most)
{
    int n = 0;
    for (const char *start = content;; ++n) {
        const char *comma = memchr(start, ',', (size_t)(end - start));
        const char *stop = comma != NULL ? comma : end, *b = start, *e = stop;
        strip(&b, &e);
        if (n < most) {
            fields[n].text = b;
            fields[n].length = (size_t)(e - b);
        }
        if (comma == NULL) {
            return n + 1;
        }
        start = comma + 1;
    }
}

/* "FILE:LINE: <what> got '<content>'" (what ends with its punctuation) */
static int fail_line(const reader *r, long line, const char *what, const char *content,
                     const char *end, const char *why)
{
    fprintf(stderr, "%s: error: --input %s: %s:%ld: %s got '%.*s'%s%s%s\n", program, r->name,
            r->path, line, what, (int)(end - content), content, why ? " (" : "", why ? why : "",
            why ? ")" : "");
    return EXIT_USAGE;
}

/* Why two fields are not two numbers (tables._not_numbers). */
static void not_numbers(const field *fields, char *why, size_t size)
{
    const field *first = NULL;
    double ignored;
    for (int k = 0; k < 2; ++k) {
        const field *f = &fields[k];
        if (python_float(f->text, f->length, &ignored)) {
            continue;
        }
        first = first != NULL ? first : f;
        if (f->length == 0) {
            snprintf(why, size, "an empty field");
            return;
        }
        if (!is_name(f->text, f->length)) {
            snprintf(why, size, "'%.*s' is not a number, nor a column's name: a name starts "
                     "with a letter or '_'", (int)f->length, f->text);
            return;
        }
    }
    snprintf(why, size, "'%.*s' is not a number; a header naming the columns comes only first",
             (int)first->length, first->text);
}

static int add(reader *r, double t, double u)
{
    if (r->n == r->capacity) {
        int capacity = r->capacity ? 2 * r->capacity : 64;
        double *times = realloc(r->t, (size_t)capacity * sizeof *times);
        if (times != NULL) {
            r->t = times;
        }
        double *values = times != NULL ? realloc(r->u, (size_t)capacity * sizeof *values) : NULL;
        if (values == NULL) {
            fprintf(stderr, "%s: error: out of memory\n", program);
            return EXIT_FAILED;
        }
        r->u = values;
        r->capacity = capacity;
    }
    r->t[r->n] = t;
    r->u[r->n++] = u;
    return EXIT_OK;
}

/* One line's content (before any '#', stripped; not empty): a header, or a row. */
static int line_content(reader *r, long line, const char *content, const char *end,
                        int *header_possible)
{
    field fields[2];
    double values[2];
    char why[FIELD_MAX + 120];
    int n = split(content, end, fields, 2);
    if (*header_possible) {
        *header_possible = 0;
        int names = 1;
        for (const char *start = content; names;) { /* every field a name */
            const char *comma = memchr(start, ',', (size_t)(end - start));
            const char *b = start, *e = comma != NULL ? comma : end;
            strip(&b, &e);
            names = is_name(b, (size_t)(e - b));
            if (comma == NULL) {
                break;
            }
            start = comma + 1;
        }
        if (names && n != 2) {
            return fail_line(r, line, "a header names the two columns 't,u';", content, end,
                             NULL);
        }
        if (names) {
            return EXIT_OK;
        }
    }
    if (n != 2) {
        snprintf(why, sizeof why, "%d field%s", n, n != 1 ? "s" : "");
        return fail_line(r, line, "expected two numbers 't,u',", content, end, why);
    }
    if (!python_float(fields[0].text, fields[0].length, &values[0])
        || !python_float(fields[1].text, fields[1].length, &values[1])) {
        not_numbers(fields, why, sizeof why);
        return fail_line(r, line, "expected two numbers 't,u',", content, end, why);
    }
    if (!isfinite(values[0]) || !isfinite(values[1])) {
        return fail_line(r, line, "expected two finite numbers 't,u',", content, end, NULL);
    }
    if (r->n > 0 && values[0] < r->t[r->n - 1]) {
        fprintf(stderr, "%s: error: --input %s: %s:%ld: time %g s is before the line above "
                "(%g s): times must not decrease\n", program, r->name, r->path, line, values[0],
                r->t[r->n - 1]);
        return EXIT_USAGE;
    }
    return add(r, values[0], values[1]);
}

/* The first byte that is not UTF-8 (as Python's decoder finds it), or -1. */
static long not_utf8(const unsigned char *s, long size)
{
    for (long k = 0; k < size;) {
        int n = s[k] < 0x80 ? 1 : (s[k] & 0xE0) == 0xC0 ? 2 : (s[k] & 0xF0) == 0xE0 ? 3
                : (s[k] & 0xF8) == 0xF0 ? 4 : 0;
        if (n == 0 || k + n > size) {
            return k;
        }
        unsigned long c = n == 1 ? s[k] : n == 2 ? s[k] & 0x1Fu : n == 3 ? s[k] & 0x0Fu
                          : s[k] & 0x07u;
        for (int i = 1; i < n; ++i) {
            if ((s[k + i] & 0xC0) != 0x80) {
                return k;
            }
            c = c << 6 | (s[k + i] & 0x3Fu);
        }
        static const unsigned long least[5] = {0, 0, 0x80, 0x800, 0x10000};
        if (c < least[n] || c > 0x10FFFF || (c >= 0xD800 && c <= 0xDFFF)) {
            return k;
        }
        k += n;
    }
    return -1;
}

/* Lines ending at \n, \r\n or \r (Python's universal newlines) before byte `stop`. */
static long lines_before(const char *text, long stop)
{
    long lines = 0;
    for (long k = 0; k < stop; ++k) {
        if (text[k] == '\n' || (text[k] == '\r' && (k + 1 >= stop || text[k + 1] != '\n'))) {
            ++lines;
        }
    }
    return lines;
}

static int parse(reader *r, const char *text, long size)
{
    /* Python decodes DECODE_CHUNK bytes at a time and reads BLOCK_LINES lines a step: a byte
       that is not UTF-8 stops the step whose lines need its chunk, after the steps before */
    long bad = not_utf8((const unsigned char *)text, size), last_line = -1;
    if (bad >= 0) {
        last_line = lines_before(text, bad / DECODE_CHUNK * DECODE_CHUNK)
                    / BLOCK_LINES * BLOCK_LINES;
    }
    long start = size >= 3 && memcmp(text, "\xEF\xBB\xBF", 3) == 0 ? 3 : 0, line = 0;
    int header_possible = 1;
    while (start < size && line != last_line) {
        long stop = start;
        while (stop < size && text[stop] != '\n' && text[stop] != '\r') {
            ++stop;
        }
        ++line;
        const char *content = text + start, *hash = memchr(content, '#', (size_t)(stop - start));
        const char *end = hash != NULL ? hash : text + stop;
        strip(&content, &end);
        if (end > content) {
            int status = line_content(r, line, content, end, &header_possible);
            if (status != EXIT_OK) {
                return status;
            }
        }
        start = stop + (stop < size && text[stop] == '\r' && stop + 1 < size
                        && text[stop + 1] == '\n' ? 2 : 1);
    }
    if (bad >= 0) {
        char message[120];
        snprintf(message, sizeof message, "cannot read: not UTF-8 text (after line %ld)",
                 last_line);
        return fail(r, message);
    }
    return r->n > 0 ? EXIT_OK : fail(r, "the table has no rows 't,u'");
}

/* ---- the file ------------------------------------------------------------------------------- */

/* The path as Python's pathlib prints it: no empty or "." parts, no trailing '/'. */
static void python_path(const char *path, char *out, size_t size)
{
    size_t used = 0;
    const char *p = path;
    if (p[0] == '/') {
        int two = p[1] == '/' && p[2] != '/';
        used = (size_t)snprintf(out, size, "%s", two ? "//" : "/");
        while (*p == '/') {
            ++p;
        }
    }
    size_t root = used;
    while (*p != '\0' && used + 1 < size) {
        const char *slash = strchr(p, '/');
        size_t n = slash != NULL ? (size_t)(slash - p) : strlen(p);
        if (n > 0 && !(n == 1 && p[0] == '.')) {
            used += (size_t)snprintf(out + used, size - used, "%s%.*s",
                                     used > root ? "/" : "", (int)n, p);
        }
        p += n + (slash != NULL);
    }
    if (used == 0) {
        snprintf(out, size, ".");
    } else if (used >= size) {
        out[size - 1] = '\0';
    }
}

/* The file opened to read, or NULL after the message (tables._check_file). */
static FILE *open_table(const reader *r, const char *path)
{
    char message[PROGRAM_PATH_MAX + 120];
    int code = 0;
#ifdef HAVE_POSIX
    struct stat st;
    if (stat(path, &st) != 0) {
        code = errno;
    } else if (!S_ISREG(st.st_mode)) {
        fail(r, "not a regular file");
        return NULL;
    }
#endif
    FILE *file = code == 0 ? fopen(path, "rb") : NULL;
    if (file == NULL) {
        code = code != 0 ? code : errno;
        if (code == ENOENT || code == ENOTDIR || code == ELOOP || code == EBADF) {
            fail(r, "no such file");
        } else {
            snprintf(message, sizeof message, "cannot read: [Errno %d] %s: '%s'", code,
                     strerror(code), r->path);
            fail(r, message);
        }
    }
    return file;
}

/* The file's bytes (malloc'ed, NUL-terminated), or NULL after the message; a file over
   MAX_TABLE_BYTES is not read beyond them. */
static char *read_file(const reader *r, const char *path, long *size, int *status)
{
    FILE *file = open_table(r, path);
    char *text = NULL;
    size_t n = 0, capacity = 0;
    int failed = file == NULL ? 3 : 0; /* 1: out of memory, 2: a read error */
    while (!failed && n <= (size_t)MAX_TABLE_BYTES) {
        if (n + 1 >= capacity) {
            capacity = capacity ? 2 * capacity : 65536;
            char *grown = realloc(text, capacity);
            if (grown == NULL) {
                failed = 1;
                break;
            }
            text = grown;
        }
        size_t got = fread(text + n, 1, capacity - n - 1, file);
        n += got;
        failed = got == 0 && ferror(file) ? 2 : 0;
        if (got == 0) {
            break;
        }
    }
    if (file != NULL) {
        fclose(file);
    }
    if (failed || n > (size_t)MAX_TABLE_BYTES) {
        free(text);
        *status = failed == 1 ? EXIT_FAILED : EXIT_USAGE;
        if (failed == 1) {
            fprintf(stderr, "%s: error: out of memory\n", program);
        } else if (failed != 3) {
            fail(r, failed ? "cannot read: an error while reading"
                           : "larger than the limit of 67,108,864 bytes for a time table; "
                             "thin it out");
        }
        return NULL;
    }
    text[n] = '\0';
    *size = (long)n;
    return text;
}

int program_read_table(const char *name, const char *path, double **t, double **u, int *n)
{
    char shown[PROGRAM_PATH_MAX];
    python_path(path, shown, sizeof shown);
    reader r = {name, shown, NULL, NULL, 0, 0};
    long size = 0;
    int status = EXIT_OK;
    char *text = read_file(&r, path, &size, &status);
    if (text == NULL) {
        return status;
    }
    status = parse(&r, text, size);
    free(text);
    if (status != EXIT_OK) {
        free(r.t);
        free(r.u);
        return status;
    }
    *t = r.t;
    *u = r.u;
    *n = r.n;
    return EXIT_OK;
}
