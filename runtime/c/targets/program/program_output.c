/* program_output.c: the standalone program's output files, treated as `depsim run` treats
 * them (program.h): checked before the run; after it, every file written or none. A regular
 * file (or nothing yet) is written beside itself (`FILE.partial`) and renamed over it, a
 * symbolic link keeping its place (its target is replaced); a pipe or a device (/dev/null, a
 * terminal, /dev/fd/N) is written in place, never replaced; a folder is refused.
 */
#if defined(__unix__) || defined(__APPLE__)
#define _XOPEN_SOURCE 700 /* stat, lstat, realpath, access: what a path names */
#include <limits.h>
#include <sys/stat.h>
#include <unistd.h>
#define HAVE_POSIX 1
#endif
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "program.h"
#include "model.h"

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

/* The file a regular output replaces (a symbolic link's target) and its partial file. */
static int place(program_output *out)
{
    const char *to = out->path;
#ifdef HAVE_POSIX
    struct stat st;
    char resolved[PATH_MAX];
    if (lstat(out->path, &st) == 0 && S_ISLNK(st.st_mode) && realpath(out->path, resolved)) {
        to = resolved; /* the link's target is replaced, the link kept */
    }
#endif
    if (snprintf(out->target, sizeof out->target, "%s", to) >= (int)sizeof out->target
        || snprintf(out->partial, sizeof out->partial, "%s.partial", to)
               >= (int)sizeof out->partial) {
        fprintf(stderr, "%s: error: %s %s: the path is too long\n", program, out->option,
                out->path);
        return EXIT_FAILED;
    }
    return EXIT_OK;
}

/* The same file seen from two outputs: their targets resolve to one path. */
static int same_file(const program_output *a, const program_output *b)
{
#ifdef HAVE_POSIX
    char first[PATH_MAX], second[PATH_MAX];
    const program_output *both[2] = {a, b};
    char *keys[2] = {first, second};
    for (int k = 0; k < 2; ++k) {
        const char *target = both[k]->target, *slash = strrchr(target, '/');
        char folder[PROGRAM_PATH_MAX];
        snprintf(folder, sizeof folder, "%.*s", slash ? (int)(slash - target) : 1,
                 slash ? (slash == target ? "/" : target) : ".");
        if (realpath(folder, keys[k]) == NULL) {
            return 0;
        }
        size_t used = strlen(keys[k]);
        snprintf(keys[k] + used, PATH_MAX - used, "/%s", slash ? slash + 1 : target);
    }
    return strcmp(first, second) == 0;
#else
    return strcmp(a->target, b->target) == 0;
#endif
}

int program_check_outputs(program_output *outputs, int n)
{
    for (int k = 0; k < n; ++k) {
        program_output *out = &outputs[k];
        if (out->path == NULL) {
            continue;
        }
        int kind = path_kind(out->path);
        if (kind == PATH_FOLDER) {
            fprintf(stderr, "%s: error: cannot write '%s': it is a folder\n", program, out->path);
            return EXIT_FAILED;
        }
        out->in_place = kind == PATH_IN_PLACE;
        if (out->in_place) {
            continue;
        }
        if (place(out) != EXIT_OK) {
            return EXIT_FAILED;
        }
        FILE *probe = fopen(out->partial, "w"); /* the folder exists and takes a new file */
        if (probe == NULL) {
            fprintf(stderr, "%s: error: cannot write '%s': %s\n", program, out->path,
                    strerror(errno));
            return EXIT_FAILED;
        }
        fclose(probe);
        remove(out->partial);
        for (int j = 0; j < k; ++j) {
            if (outputs[j].path != NULL && !outputs[j].in_place && same_file(&outputs[j], out)) {
                fprintf(stderr, "%s: error: %s %s: that is the file of %s; give another file\n",
                        program, out->option, out->path, outputs[j].option);
                return EXIT_USAGE;
            }
        }
    }
    return EXIT_OK;
}

/* Write one output into `path` (a partial file, or a pipe or device in place). */
static int write_file(const program_output *out, const char *path, const dep_result *result)
{
    FILE *file = fopen(path, "w");
    int status = file == NULL ? EXIT_FAILED : out->write(result, file);
    if (file != NULL && fclose(file) != 0) {
        status = EXIT_FAILED;
    }
    return status;
}

static void take_back(program_output *outputs, int n)
{
    for (int k = 0; k < n; ++k) {
        if (outputs[k].path != NULL && !outputs[k].in_place) {
            remove(outputs[k].partial);
        }
    }
}

int program_write_outputs(program_output *outputs, int n, const dep_result *result)
{
    /* the files first (taken back together if one fails), then pipes and devices, then the
       files put in place */
    for (int pass = 0; pass < 3; ++pass) {
        for (int k = 0; k < n; ++k) {
            program_output *out = &outputs[k];
            if (out->path == NULL || out->in_place != (pass == 1)) {
                continue;
            }
            int status = pass == 0 ? write_file(out, out->partial, result)
                         : pass == 1 ? write_file(out, out->path, result)
                         : rename(out->partial, out->target) == 0 ? EXIT_OK : EXIT_FAILED;
            if (status != EXIT_OK) {
                take_back(outputs, n);
                fprintf(stderr, "%s: error: cannot write '%s'\n", program, out->path);
                return status;
            }
        }
    }
    return EXIT_OK;
}

int program_write_csv(const dep_result *r, FILE *file)
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
