/* arena.c: a run's memory: every allocation in one arena, freed at once (base.h). */
#include <stdlib.h>

#include "base.h"

static void *allocate(dep_arena *arena, size_t n, int zeroed)
{
    if (arena->count == arena->capacity) {
        int capacity = arena->capacity ? 2 * arena->capacity : 64;
        void **blocks = realloc(arena->blocks, (size_t)capacity * sizeof *blocks);
        if (blocks != NULL) {
            arena->blocks = blocks;
        }
        size_t *sizes = blocks != NULL ? realloc(arena->sizes, (size_t)capacity * sizeof *sizes)
                                       : NULL;
        if (sizes == NULL) {
            arena->failed = 1;
            return NULL;
        }
        arena->sizes = sizes;
        arena->capacity = capacity;
    }
    void *block = zeroed ? calloc(n ? n : 1, 1) : malloc(n ? n : 1);
    if (block == NULL) {
        arena->failed = 1;
        return NULL;
    }
    arena->sizes[arena->count] = n ? n : 1;
    arena->blocks[arena->count++] = block;
    return block;
}

void *dep_bytes(dep_arena *arena, size_t n)
{
    return allocate(arena, n, 1);
}

void *dep_bytes_unset(dep_arena *arena, size_t n)
{
    return allocate(arena, n, 0);
}

double *dep_doubles(dep_arena *arena, size_t n)
{
    return dep_bytes(arena, n * sizeof(double));
}

/* Free the blocks from `count` on: the arena as it was when it had `count` blocks. */
void dep_arena_truncate(dep_arena *arena, int count)
{
    while (arena->count > count) {
        free(arena->blocks[--arena->count]);
    }
}

void dep_arena_free(dep_arena *arena)
{
    dep_arena_truncate(arena, 0);
    free(arena->blocks);
    free(arena->sizes);
    arena->blocks = NULL;
    arena->sizes = NULL;
    arena->count = arena->capacity = 0;
}
