/* snapshot.c: a run's state saved and put back (run.h; dep_save, dep_restore in depsim.h), so
 * that a co-simulation master can roll a step back (docs/fmu.md, FMU state).
 *
 * A run's state is its struct and the blocks of its arena: the stepper's histories and
 * caches, the mechanism's modes and rows, the inputs, everything. A snapshot copies them all;
 * put back into the same run, whose blocks are still where they were, the copy restores it
 * exactly, pointers and all, and the run goes on bit for bit as it went on from the save.
 * A run's memory means nothing to another run (its pointers), so a snapshot also keeps the
 * calls that brought the run there (dep_replay: parameters and settings, then each
 * dep_advance and dep_set_inputs); put into another run, or read back from bytes in another
 * process, the run is opened again and the calls repeated: the same steps, the same state
 * bit for bit, at the cost of integrating again from t = 0.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "run.h"

#define SNAPSHOT_MAGIC "DEPSNAP1"
#define SNAPSHOT_VERSION 1u
#define SHA_CHARS 72 /* a model's source_sha256, kept in the bytes */

static const char core_data = 0; /* its address: where this core's data lies */

/* ---- the calls of a dep_open run -------------------------------------------------------- */

int dep_run_replay_open(dep_run *run)
{
    dep_replay *r = &run->replay;
    size_t np = (size_t)run->model->np;
    r->open = 1;
    r->settings = run->settings;
    r->p = dep_doubles(&run->arena, np + 1);
    if (r->p == NULL) {
        return dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory");
    }
    memcpy(r->p, run->p, np * sizeof(double));
    return DEP_OK;
}

int dep_run_replay_add(dep_run *run, int kind, const double *a, const double *b, int n)
{
    dep_replay *r = &run->replay;
    long size = kind == DEP_REPLAY_INPUTS ? 2L * n : n;
    if (!r->open) {
        return DEP_OK;
    }
    if (r->n + 1 + size > r->capacity) { /* a new block, twice the size (the arena keeps all) */
        long capacity = 2 * (r->n + 1 + size) + 64;
        double *entries = dep_doubles(&run->arena, (size_t)capacity);
        if (entries == NULL) {
            return dep_plain_error(run->error, DEP_MEMORY_ERROR, "out of memory");
        }
        if (r->n > 0) {
            memcpy(entries, r->entries, (size_t)r->n * sizeof *entries);
        }
        r->entries = entries;
        r->capacity = capacity;
    }
    double *to = r->entries + r->n;
    to[0] = kind;
    for (int k = 0; k < n; ++k) {
        to[1 + k] = a[k];
        if (kind == DEP_REPLAY_INPUTS) {
            to[1 + n + k] = b != NULL ? b[k] : 0.0;
        }
    }
    r->n += 1 + size;
    return DEP_OK;
}

/* ---- saving ----------------------------------------------------------------------------- */

void dep_snapshot_destroy(dep_snapshot *s)
{
    if (s != NULL) {
        free(s->addresses);
        free(s->sizes);
        free(s->bytes);
        free(s->replay.p);
        free(s->replay.entries);
        free(s);
    }
}

/* The calls of `from` into `to`, in memory of their own. */
static int copy_replay(dep_replay *to, const dep_replay *from, int np)
{
    *to = *from;
    to->p = malloc(((size_t)np + 1) * sizeof(double));
    to->entries = malloc(((size_t)from->n + 1) * sizeof(double));
    to->capacity = from->n;
    if (to->p == NULL || to->entries == NULL) {
        return DEP_MEMORY_ERROR;
    }
    if (from->p != NULL) {
        memcpy(to->p, from->p, (size_t)np * sizeof(double));
    }
    if (from->n > 0) {
        memcpy(to->entries, from->entries, (size_t)from->n * sizeof(double));
    }
    return DEP_OK;
}

int dep_run_save(const dep_run *run, dep_snapshot **out, dep_error *error)
{
    const dep_arena *arena = &run->arena;
    dep_snapshot *s = calloc(1, sizeof *s);
    size_t n = (size_t)arena->count, at = 0;
    *out = NULL;
    if (s != NULL) {
        s->model = run->model;
        s->run = run;
        s->core = &core_data;
        s->image = *run;
        s->n_blocks = arena->count;
        s->addresses = malloc((n + 1) * sizeof *s->addresses);
        s->sizes = malloc((n + 1) * sizeof *s->sizes);
        for (size_t k = 0; k < n; ++k) {
            s->n_bytes += arena->sizes[k];
        }
        s->bytes = malloc(s->n_bytes + 1);
    }
    if (s == NULL || s->addresses == NULL || s->sizes == NULL || s->bytes == NULL
        || copy_replay(&s->replay, &run->replay, run->model->np) != DEP_OK) {
        dep_snapshot_destroy(s);
        return dep_plain_error(error, DEP_MEMORY_ERROR, "out of memory");
    }
    for (size_t k = 0; k < n; ++k) {
        s->addresses[k] = arena->blocks[k];
        s->sizes[k] = arena->sizes[k];
        memcpy(s->bytes + at, arena->blocks[k], arena->sizes[k]);
        at += arena->sizes[k];
    }
    *out = s;
    return DEP_OK;
}

/* ---- putting back ------------------------------------------------------------------------- */

/* Whether `run` is the run the snapshot's memory was taken of, its blocks where they were. */
static int same_memory(const dep_run *run, const dep_snapshot *s)
{
    if (run != s->run || s->n_blocks < 0 || s->core != &core_data
        || run->model != s->image.model || run->arena.count < s->n_blocks) {
        return 0;
    }
    for (int k = 0; k < s->n_blocks; ++k) {
        if (run->arena.blocks[k] != s->addresses[k] || run->arena.sizes[k] != s->sizes[k]) {
            return 0;
        }
    }
    return 1;
}

/* The run's memory as it was: the blocks allocated since freed, the others' contents and the
   struct copied back (its arena's own bookkeeping and the caller's error kept). */
static void put_back(dep_run *run, const dep_snapshot *s, dep_error *error)
{
    size_t at = 0;
    dep_arena_truncate(&run->arena, s->n_blocks);
    for (int k = 0; k < s->n_blocks; ++k) {
        memcpy(run->arena.blocks[k], s->bytes + at, s->sizes[k]);
        at += s->sizes[k];
    }
    dep_arena arena = run->arena;
    arena.failed = s->image.arena.failed;
    *run = s->image;
    run->arena = arena;
    run->error = error;
}

/* A run opened again with the snapshot's parameters and settings, its calls repeated as
   dep_open, dep_advance and dep_set_inputs made them (targets/library.c). */
static int replay(const dep_snapshot *s, dep_run **out, dep_error *error)
{
    const dep_replay *r = &s->replay;
    int ni = s->model->ni, status;
    *out = NULL;
    if (!r->open) {
        return dep_plain_error(error, DEP_SETTINGS_ERROR, "this saved state can be put back "
                               "only into the run it was taken of (a run of dep_simulate)");
    }
    dep_run *run = dep_run_new(s->model, r->p, &r->settings, NULL, 0, 0, error);
    if (run == NULL) {
        return error->code;
    }
    if ((status = dep_run_replay_open(run)) == DEP_OK) {
        status = dep_run_begin(run);
    }
    for (long k = 0; k < r->n && status == DEP_OK;) {
        int kind = (int)r->entries[k];
        const double *values = r->entries + k + 1;
        int n = kind == DEP_REPLAY_ADVANCE ? 1 : 2 * ni;
        if ((kind != DEP_REPLAY_ADVANCE && kind != DEP_REPLAY_INPUTS) || k + 1 + n > r->n) {
            status = dep_plain_error(error, DEP_SETTINGS_ERROR, "the saved state is damaged");
            break;
        }
        run->error = error;
        status = kind == DEP_REPLAY_ADVANCE ? dep_run_until(run, values[0])
                 : dep_run_set_inputs(run, values, values + ni, error);
        if (status == DEP_OK) {
            status = dep_run_replay_add(run, kind, values, values + ni,
                                        kind == DEP_REPLAY_ADVANCE ? 1 : ni);
        }
        k += 1 + n;
    }
    if (status != DEP_OK) {
        dep_run_free(run);
        return status;
    }
    *out = run;
    return DEP_OK;
}

int dep_run_restore(dep_run **run, const dep_snapshot *s, dep_error *error)
{
    dep_run *again;
    dep_error_clear(error);
    if (*run != NULL && same_memory(*run, s)) {
        put_back(*run, s, error);
        return DEP_OK;
    }
    int status = replay(s, &again, error);
    if (status == DEP_OK) {
        dep_run_free(*run);
        *run = again;
    }
    return status;
}

/* ---- as bytes ----------------------------------------------------------------------------- */

/* The bytes: "DEPSNAP1", the layout's marks (byte order, sizes), the model's identity, the
   memory (its addresses, the struct, the blocks), the calls, and a checksum of all before it.
   They describe this machine's run: read back on a machine of the same kind. */
typedef struct layout {
    uint32_t order, pointer, image, version;
    char sha[SHA_CHARS];
    int32_t nq, np, nc, ni;
    uint64_t run, model, core;
    int32_t n_blocks, open;
    double t_end, dt_out, tol, max_steps;
    int32_t mechanics, stepping, rows, unused;
    int64_t n;
} layout;

static layout header(const dep_snapshot *s)
{
    layout h;
    memset(&h, 0, sizeof h);
    h.order = 0x01020304u;
    h.pointer = (uint32_t)sizeof(void *);
    h.image = (uint32_t)sizeof(struct dep_run);
    h.version = SNAPSHOT_VERSION;
    dep_copy_text(h.sha, sizeof h.sha, s->model->source_sha256);
    h.nq = s->model->nq;
    h.np = s->model->np;
    h.nc = s->model->nc;
    h.ni = s->model->ni;
    h.run = (uint64_t)(uintptr_t)s->run;
    h.model = (uint64_t)(uintptr_t)s->image.model;
    h.core = (uint64_t)(uintptr_t)s->core;
    h.n_blocks = s->n_blocks;
    h.open = s->replay.open;
    h.t_end = s->replay.settings.t_end;
    h.dt_out = s->replay.settings.dt_out;
    h.tol = s->replay.settings.tol;
    h.max_steps = s->replay.settings.max_steps;
    h.mechanics = s->replay.settings.mechanics;
    h.stepping = s->replay.settings.stepping;
    h.rows = s->replay.settings.rows;
    h.n = s->replay.n;
    return h;
}

static uint64_t checksum(const unsigned char *bytes, size_t n) /* FNV-1a, 64 bits */
{
    uint64_t hash = 14695981039346656037u;
    for (size_t k = 0; k < n; ++k) {
        hash = (hash ^ bytes[k]) * 1099511628211u;
    }
    return hash;
}

size_t dep_snapshot_bytes(const dep_snapshot *s)
{
    size_t blocks = s->n_blocks > 0 ? (size_t)s->n_blocks : 0;
    size_t memory = s->n_blocks >= 0 ? sizeof(struct dep_run) + blocks * 2 * sizeof(uint64_t)
                                       + s->n_bytes : 0;
    return 8 + sizeof(layout) + memory
           + ((size_t)s->model->np + (size_t)s->replay.n) * sizeof(double) + sizeof(uint64_t);
}

static unsigned char *put(unsigned char *at, const void *data, size_t n)
{
    if (n > 0) {
        memcpy(at, data, n);
    }
    return at + n;
}

void dep_snapshot_serialize(const dep_snapshot *s, unsigned char *bytes)
{
    layout h = header(s);
    unsigned char *at = put(bytes, SNAPSHOT_MAGIC, 8);
    at = put(at, &h, sizeof h);
    if (s->n_blocks >= 0) {
        at = put(at, &s->image, sizeof s->image);
        for (int k = 0; k < s->n_blocks; ++k) {
            uint64_t pair[2] = {(uint64_t)(uintptr_t)s->addresses[k], (uint64_t)s->sizes[k]};
            at = put(at, pair, sizeof pair);
        }
        at = put(at, s->bytes, s->n_bytes);
    }
    at = put(at, s->replay.p, (size_t)s->model->np * sizeof(double));
    at = put(at, s->replay.entries, (size_t)s->replay.n * sizeof(double));
    uint64_t sum = checksum(bytes, (size_t)(at - bytes));
    put(at, &sum, sizeof sum);
}

/* Bytes read in order, never past their end. */
typedef struct source {
    const unsigned char *at, *end;
} source;

static int take(source *from, void *to, size_t n)
{
    if ((size_t)(from->end - from->at) < n) {
        return 0;
    }
    if (n > 0) {
        memcpy(to, from->at, n);
    }
    from->at += n;
    return 1;
}

/* The snapshot's memory from the bytes (after the header): its struct (of `image` bytes;
   not kept unless this core's size), the blocks' addresses and sizes, their contents. */
static int take_memory(source *from, dep_snapshot *s, size_t image)
{
    size_t n = (size_t)s->n_blocks;
    if ((size_t)(from->end - from->at) < image
        || (size_t)(from->end - from->at - image) / (2 * sizeof(uint64_t)) < n) {
        return 0;
    }
    if (image == sizeof s->image) {
        memcpy(&s->image, from->at, image);
    }
    from->at += image;
    s->addresses = malloc((n + 1) * sizeof *s->addresses);
    s->sizes = malloc((n + 1) * sizeof *s->sizes);
    if (s->addresses == NULL || s->sizes == NULL) {
        return 0;
    }
    for (size_t k = 0; k < n; ++k) {
        uint64_t pair[2];
        if (!take(from, pair, sizeof pair) || pair[1] > (uint64_t)(from->end - from->at)) {
            return 0;
        }
        s->addresses[k] = (void *)(uintptr_t)pair[0];
        s->sizes[k] = (size_t)pair[1];
        s->n_bytes += s->sizes[k];
    }
    s->bytes = malloc(s->n_bytes + 1);
    return s->bytes != NULL && take(from, s->bytes, s->n_bytes);
}

static int take_replay(source *from, dep_snapshot *s, const layout *h)
{
    dep_replay *r = &s->replay;
    size_t np = (size_t)s->model->np;
    if (h->n < 0 || (uint64_t)h->n > (uint64_t)(from->end - from->at) / sizeof(double)) {
        return 0;
    }
    r->open = h->open;
    memset(&r->settings, 0, sizeof r->settings); /* no callback, no tables */
    r->settings.t_end = h->t_end;
    r->settings.dt_out = h->dt_out;
    r->settings.tol = h->tol;
    r->settings.max_steps = h->max_steps;
    r->settings.mechanics = h->mechanics;
    r->settings.stepping = h->stepping;
    r->settings.rows = h->rows;
    r->n = r->capacity = (long)h->n;
    r->p = malloc((np + 1) * sizeof(double));
    r->entries = malloc(((size_t)h->n + 1) * sizeof(double));
    return r->p != NULL && r->entries != NULL && take(from, r->p, np * sizeof(double))
           && take(from, r->entries, (size_t)h->n * sizeof(double));
}

/* Whether the bytes end with the checksum of those before it. */
static int intact(const unsigned char *bytes, size_t size)
{
    uint64_t sum;
    if (bytes == NULL || size < 8 + sizeof(layout) + sizeof sum) {
        return 0;
    }
    memcpy(&sum, bytes + size - sizeof sum, sizeof sum);
    return checksum(bytes, size - sizeof sum) == sum;
}

int dep_snapshot_deserialize(const dep_model *model, const unsigned char *bytes, size_t size,
                             dep_snapshot **out, dep_error *error)
{
    int ok = intact(bytes, size);
    source from = {bytes, ok ? bytes + size - sizeof(uint64_t) : bytes};
    char magic[8];
    layout h, expected;
    dep_snapshot *s = calloc(1, sizeof *s);
    *out = NULL;
    if (s == NULL) {
        return dep_plain_error(error, DEP_MEMORY_ERROR, "out of memory");
    }
    s->model = model;
    s->n_blocks = -1;
    expected = header(s);
    ok = ok && take(&from, magic, 8)
             && memcmp(magic, SNAPSHOT_MAGIC, 8) == 0 && take(&from, &h, sizeof h)
             && h.order == expected.order && h.pointer == expected.pointer
             && h.version == expected.version && memcmp(h.sha, expected.sha, sizeof h.sha) == 0
             && h.nq == expected.nq && h.np == expected.np && h.nc == expected.nc
             && h.ni == expected.ni;
    if (ok) {
        s->n_blocks = h.n_blocks;
        s->run = (const dep_run *)(uintptr_t)h.run;
        s->core = (const void *)(uintptr_t)h.core;
        ok = (h.n_blocks < 0 || take_memory(&from, s, h.image)) && take_replay(&from, s, &h)
             && from.at == from.end;
        if (h.image != expected.image) {
            s->n_blocks = -1; /* another core's run: its calls only */
        }
    }
    if (!ok) {
        dep_snapshot_destroy(s);
        return dep_plain_error(error, DEP_SETTINGS_ERROR, "these bytes are not a saved state "
                               "of this model's run (another model, another depsim, another "
                               "kind of machine, or damaged)");
    }
    *out = s;
    return DEP_OK;
}
