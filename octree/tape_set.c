/* ivoct octree — a set of tapes, each distinct tape stored once (tape_set.h). */
#include "tape_set.h"

#include <stdlib.h>
#include <string.h>

static int grow(void **p, size_t *cap, size_t need, size_t size)
{
    if (need <= *cap)
        return 0;
    size_t cap2 = *cap ? *cap : 64;
    while (cap2 < need)
        cap2 *= 2;
    void *q = realloc(*p, cap2 * size);
    if (!q)
        return -1;
    *p = q;
    *cap = cap2;
    return 0;
}

/* FNV-1a over the clauses' fields (not their padding) */
static uint64_t hash_clauses(const tape_clause_t *c, uint32_t n)
{
    uint64_t h = 0xcbf29ce484222325ull;
    for (uint32_t i = 0; i < n; i++) {
        uint64_t w[4] = {(uint64_t)c[i].op << 32 | c[i].a, c[i].b, 0, 0};
        memcpy(&w[2], &c[i].c.lo, sizeof(double));
        memcpy(&w[3], &c[i].c.hi, sizeof(double));
        for (int k = 0; k < 4; k++)
            h = (h ^ w[k]) * 0x100000001b3ull;
    }
    return h;
}

static int same_clauses(const tape_clause_t *a, const tape_clause_t *b, uint32_t n)
{
    for (uint32_t i = 0; i < n; i++)
        if (a[i].op != b[i].op || a[i].a != b[i].a || a[i].b != b[i].b ||
            memcmp(&a[i].c.lo, &b[i].c.lo, sizeof(double)) ||
            memcmp(&a[i].c.hi, &b[i].c.hi, sizeof(double)))
            return 0;
    return 1;
}

tape_clause_t *tape_set_reserve(tape_set_t *s, uint32_t n)
{
    if (grow((void **)&s->clauses, &s->cap_clauses, s->n_clauses + n, sizeof *s->clauses) ||
        grow((void **)&s->scratch, &s->cap_scratch, 2 * (size_t)n, sizeof *s->scratch))
        return NULL;
    return s->clauses + s->n_clauses;
}

/* A table for at least twice the tapes, rebuilt from the entries. */
static int rehash(tape_set_t *s)
{
    if (2 * (s->n_tapes + 1) <= s->table_cap)
        return 0;
    size_t cap = s->table_cap ? 2 * s->table_cap : 1024;
    uint32_t *t = calloc(cap, sizeof *t);
    if (!t)
        return -1;
    for (size_t i = 0; i < s->n_tapes; i++) {
        size_t j = s->tapes[i].hash & (cap - 1);
        while (t[j])
            j = (j + 1) & (cap - 1);
        t[j] = (uint32_t)i + 1;
    }
    free(s->table);
    s->table = t;
    s->table_cap = cap;
    return 0;
}

long tape_set_commit(tape_set_t *s, uint32_t n)
{
    if (rehash(s) || grow((void **)&s->tapes, &s->cap_tapes, s->n_tapes + 1, sizeof *s->tapes))
        return -1;
    const tape_clause_t *mine = s->clauses + s->n_clauses;
    uint64_t h = hash_clauses(mine, n);
    size_t j = h & (s->table_cap - 1);
    for (; s->table[j]; j = (j + 1) & (s->table_cap - 1)) {
        const tape_set_entry_t *o = &s->tapes[s->table[j] - 1];
        if (o->hash == h && o->n == n && same_clauses(s->clauses + o->first, mine, n))
            return (long)s->table[j] - 1;
    }
    tape_t t = {s->clauses + s->n_clauses, n};
    s->tapes[s->n_tapes] = (tape_set_entry_t){s->n_clauses, n, tape_is_single_use(&t, s->scratch), h};
    s->n_clauses += n;
    s->table[j] = (uint32_t)s->n_tapes + 1;
    return (long)s->n_tapes++;
}

void tape_set_clear(tape_set_t *s)
{
    s->n_tapes = 0;
    s->n_clauses = 0;
    if (s->table)
        memset(s->table, 0, s->table_cap * sizeof *s->table);
}

void tape_set_free(tape_set_t *s)
{
    free(s->clauses);
    free(s->tapes);
    free(s->table);
    free(s->scratch);
    memset(s, 0, sizeof *s);
}

size_t tape_set_bytes(const tape_set_t *s)
{
    return s->cap_clauses * sizeof *s->clauses + s->cap_tapes * sizeof *s->tapes +
           s->table_cap * sizeof *s->table + s->cap_scratch * sizeof *s->scratch;
}
