/* arena.c: a run's memory: every allocation in one arena, freed at once (base.h). */
#include <stdlib.h>

#include "base.h"

static void *allocate(dep_arena *arena, size_t n, int zeroed)
{
    if (arena->count == arena->capacity) {
        int capacity = arena->capacity ? 2 * arena->capacity : 64;
        void **blocks = realloc(arena->blocks, (size_t)capacity * sizeof *blocks);
        if (blocks == NULL) {
            arena->failed = 1;
            return NULL;
        }
        arena->blocks = blocks;
        arena->capacity = capacity;
    }
    void *block = zeroed ? calloc(n ? n : 1, 1) : malloc(n ? n : 1);
    if (block == NULL) {
        arena->failed = 1;
        return NULL;
    }
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

void dep_arena_free(dep_arena *arena)
{
    for (int i = 0; i < arena->count; ++i) {
        free(arena->blocks[i]);
    }
    free(arena->blocks);
    arena->blocks = NULL;
    arena->count = arena->capacity = 0;
}
