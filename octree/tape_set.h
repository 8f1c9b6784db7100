/* ivoct octree — a set of tapes, each distinct tape stored once (internal to
 * octree/).
 *
 * Pruning gives the same tape in many places (the cells of a CSG scene near
 * the same few primitives, a shell's inside and outside), so the builder's
 * levels and the leaf tapes keep their pruned tapes here: equal tapes get
 * the same id, which also lets the builder evaluate every cell of a tape in
 * one batch.  Tapes are stored as a first clause and a length in one clause
 * array, so the array can grow; tape_set_get makes the pointer. */
#ifndef IVOCT_OCTREE_TAPE_SET_H
#define IVOCT_OCTREE_TAPE_SET_H

#include <stddef.h>
#include <stdint.h>

#include "../expr/tape.h"

typedef struct tape_set_entry {
    size_t first;
    uint32_t n;
    int single_use; /* tape_is_single_use */
    uint64_t hash;
} tape_set_entry_t;

typedef struct tape_set {
    tape_clause_t *clauses;
    size_t n_clauses, cap_clauses;
    tape_set_entry_t *tapes;
    size_t n_tapes, cap_tapes;
    uint32_t *table;  /* open addressing: tape id + 1, 0 empty */
    size_t table_cap; /* a power of two, at least twice n_tapes */
    uint32_t *scratch;/* 2 * the longest tape's clauses, for tape_is_single_use */
    size_t cap_scratch;
} tape_set_t;

/* Room for a tape of n clauses at the end of the clause array, to write a
 * candidate into (tape_prune) before tape_set_commit; NULL when out of
 * memory.  Valid until the next call. */
tape_clause_t *tape_set_reserve(tape_set_t *s, uint32_t n);

/* The id of the stored tape equal to the n clauses just written at
 * tape_set_reserve's place, which are then dropped; or a new id for them.
 * -1 when out of memory. */
long tape_set_commit(tape_set_t *s, uint32_t n);

/* The tape with id id (its pointer valid until the clause array grows). */
static inline tape_t tape_set_get(const tape_set_t *s, size_t id)
{
    tape_t t = {s->clauses + s->tapes[id].first, s->tapes[id].n};
    return t;
}

/* Forget every tape, keep the storage. */
void tape_set_clear(tape_set_t *s);
void tape_set_free(tape_set_t *s);
/* Bytes allocated. */
size_t tape_set_bytes(const tape_set_t *s);

#endif
