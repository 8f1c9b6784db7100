/* ivoct — internal: the hash-consed expression DAG shared by the parser
 * (parse.c) and the flattening to tapes (dag.c).  Not installed.
 *
 * Nodes are created children-first and never removed, so a node's operands
 * always have smaller indices: the index order is a topological order, and
 * every pass over the DAG is a plain loop (no recursion, whatever the size of
 * the expression). */
#ifndef IVOCT_EXPR_DAG_H
#define IVOCT_EXPR_DAG_H

#include <stdint.h>

#include "interval.h"
#include "tape.h"

typedef struct dag_node {
    uint8_t op;    /* tape_op_t */
    uint8_t total; /* defined at every real (x, y, z): see dag.c */
    uint32_t a, b; /* operands (0 when unused) */
    iv_t c;        /* CONST: value; POWI / POWR: exponent in c.lo (c.hi = c.lo) */
} dag_node_t;

typedef struct dag {
    dag_node_t *nodes;
    uint32_t n, cap;
    uint32_t *table; /* hash-consing: node index + 1, 0 = free slot */
    uint32_t table_cap; /* power of two */
} dag_t;

/* Status codes of the dag_* builders. */
enum {
    DAG_OK = 0,
    DAG_ENOMEM = 1,   /* out of memory (or more than 2^31 nodes) */
    DAG_EEXPONENT = 2 /* an integer exponent too large for POWI, see dag_pow */
};

/* Largest |n| turned into TAPE_POWI for a non-constant base. */
#define DAG_MAX_POWI 1024

/* Enclosures of the real constants pi and e. */
extern const iv_t dag_pi, dag_e;

void dag_init(dag_t *d);
void dag_free(dag_t *d);

/* Builders: each returns DAG_OK and the node in *out, or a DAG_E* status.
 * They fold constants, share identical nodes and apply the exact rewrites
 * listed in dag.c. */
int dag_leaf(dag_t *d, tape_op_t op, uint32_t *out); /* TAPE_X / TAPE_Y / TAPE_Z */
int dag_const(dag_t *d, iv_t c, uint32_t *out);
int dag_unary(dag_t *d, tape_op_t op, uint32_t a, uint32_t *out); /* NEG SQR SQRT .. ABS */
int dag_binary(dag_t *d, tape_op_t op, uint32_t a, uint32_t b, uint32_t *out); /* ADD .. MAX */
int dag_pow(dag_t *d, uint32_t a, uint32_t b, uint32_t *out); /* a ^ b */

/* Flatten the nodes that root depends on into a new tape (root last). */
int dag_to_tape(const dag_t *d, uint32_t root, tape_t **out);

#endif
