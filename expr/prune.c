/* ivoct — pruning a tape to the branches that can matter over a region.
 *
 * This is what keeps CSG scenes cheap: a union of 64 spheres is a chain of 63
 * min clauses, but in a small cell only one or two spheres can be the minimum.
 * The interval evaluation decides the choices (tape_eval_interval_choices);
 * one forward pass aliases each decided clause to its chosen operand, one
 * backward pass marks what the result still needs, one forward pass emits it. */
#include "tape.h"

enum { KEEP = 0, TO_NEG = 1 };

int tape_op_arity(tape_op_t op)
{
    switch (op) {
    case TAPE_CONST:
    case TAPE_X:
    case TAPE_Y:
    case TAPE_Z:
    case TAPE_OP_COUNT:
        return 0;
    case TAPE_ADD:
    case TAPE_SUB:
    case TAPE_MUL:
    case TAPE_DIV:
    case TAPE_MIN:
    case TAPE_MAX:
        return 2;
    default:
        return 1;
    }
}

int tape_has_choices(const tape_t *t)
{
    for (uint32_t i = 0; i < t->n; i++) {
        uint32_t op = t->clauses[i].op;
        if (op == TAPE_MIN || op == TAPE_MAX || op == TAPE_ABS)
            return 1;
    }
    return 0;
}

int tape_is_single_use(const tape_t *t, uint32_t *scratch)
{
    uint32_t *depends = scratch, *uses = scratch + t->n;
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        int arity = tape_op_arity((tape_op_t)c->op);
        uses[i] = 0;
        depends[i] = c->op == TAPE_X || c->op == TAPE_Y || c->op == TAPE_Z;
        if (arity >= 1) {
            depends[i] |= depends[c->a];
            if (depends[c->a] && ++uses[c->a] > 1)
                return 0;
        }
        if (arity == 2) {
            depends[i] |= depends[c->b];
            if (depends[c->b] && ++uses[c->b] > 1)
                return 0;
        }
    }
    return 1;
}

void tape_prune(const tape_t *t, const uint8_t *choices, uint32_t *scratch, tape_t *out)
{
    const uint32_t n = t->n, DEAD = UINT32_MAX;
    uint32_t *alias = scratch, *index = scratch + n, *rewrite = scratch + 2 * n;

    /* decide: alias[i] is the clause that computes clause i's value */
    for (uint32_t i = 0; i < n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        alias[i] = i;
        rewrite[i] = KEEP;
        switch ((tape_choice_t)choices[i]) {
        case TAPE_CHOICE_A:
            alias[i] = alias[c->a];
            break;
        case TAPE_CHOICE_B:
            alias[i] = alias[c->b];
            break;
        case TAPE_CHOICE_NEG_A:
            rewrite[i] = TO_NEG;
            break;
        case TAPE_CHOICE_BOTH:
            break;
        }
    }

    /* mark what the result needs, walking back from it */
    for (uint32_t i = 0; i < n; i++)
        index[i] = DEAD;
    index[alias[n - 1]] = 0;
    for (uint32_t i = n; i-- > 0;) {
        if (index[i] == DEAD || alias[i] != i)
            continue;
        const tape_clause_t *c = &t->clauses[i];
        int arity = tape_op_arity((tape_op_t)c->op);
        if (arity >= 1)
            index[alias[c->a]] = 0;
        if (arity == 2)
            index[alias[c->b]] = 0;
    }

    /* emit the live clauses in order; the result (alias[n-1]) is the last,
     * since every live clause is one of its operands' ancestors */
    uint32_t m = 0;
    for (uint32_t i = 0; i < n; i++) {
        if (index[i] == DEAD || alias[i] != i)
            continue;
        tape_clause_t c = t->clauses[i];
        int arity = tape_op_arity((tape_op_t)c.op);
        if (arity >= 1)
            c.a = index[alias[c.a]];
        if (arity == 2)
            c.b = index[alias[c.b]];
        if (rewrite[i] == TO_NEG)
            c.op = TAPE_NEG;
        index[i] = m;
        out->clauses[m++] = c;
    }
    out->n = m;
}
