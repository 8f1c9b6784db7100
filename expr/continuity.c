/* ivoct — is f defined and continuous on a whole box?  An ordinary interval
 * evaluation, clause by clause, that checks each operand against the domain
 * where its operation is continuous (modal/ for the semantic extensions,
 * octree/ for the leaves that surely hold surface). */
#include "tape.h"

#include <math.h>

tape_domain_t tape_check_continuous(const tape_t *t, const iv_box_t *box, iv_t *slots,
                                    int *smooth)
{
    int sm = 1;
    if (smooth)
        *smooth = 1;
    if (!t || !box || !slots || t->n == 0)
        return TAPE_DOMAIN_NOT_PROVED;
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        int arity = tape_op_arity((tape_op_t)c->op);
        iv_t a = arity >= 1 ? slots[c->a] : iv_empty();
        iv_t b = arity == 2 ? slots[c->b] : iv_empty();
        iv_t v;
        int ok = 1;
        switch ((tape_op_t)c->op) {
        case TAPE_CONST: v = c->c; break;
        case TAPE_X: v = box->x; break;
        case TAPE_Y: v = box->y; break;
        case TAPE_Z: v = box->z; break;
        case TAPE_NEG: v = iv_neg(a); break;
        case TAPE_SQR: v = iv_sqr(a); break;
        case TAPE_POWI: {
            int n = (int)c->c.lo;
            ok = n >= 0 || a.lo > 0 || a.hi < 0;
            v = iv_powi(a, n);
            break;
        }
        case TAPE_POWR:
            ok = c->c.lo > 0 ? a.lo >= 0 : a.lo > 0;
            sm = sm && a.lo > 0;
            v = iv_powr(a, c->c.lo);
            break;
        case TAPE_SQRT:
            ok = a.lo >= 0;
            sm = sm && a.lo > 0;
            v = iv_sqrt(a);
            break;
        case TAPE_EXP: v = iv_exp(a); break;
        case TAPE_LOG:
            ok = a.lo > 0;
            v = iv_log(a);
            break;
        case TAPE_SIN: v = iv_sin(a); break;
        case TAPE_COS: v = iv_cos(a); break;
        case TAPE_TAN:
            v = iv_tan(a);
            ok = isfinite(v.lo) && isfinite(v.hi); /* no pole in a */
            break;
        case TAPE_ATAN: v = iv_atan(a); break;
        case TAPE_ABS:
            /* continuous everywhere; differentiable unless a reaches 0 */
            sm = sm && (a.lo > 0 || a.hi < 0);
            v = iv_abs(a);
            break;
        case TAPE_ADD: v = iv_add(a, b); break;
        case TAPE_SUB: v = iv_sub(a, b); break;
        case TAPE_MUL: v = iv_mul(a, b); break;
        case TAPE_DIV:
            ok = b.lo > 0 || b.hi < 0;
            v = iv_div(a, b);
            break;
        case TAPE_MIN:
        case TAPE_MAX:
            /* continuous everywhere; differentiable where one operand is
             * the value over the whole box */
            sm = sm && (a.hi < b.lo || b.hi < a.lo);
            v = c->op == TAPE_MIN ? iv_min(a, b) : iv_max(a, b);
            break;
        default: return TAPE_DOMAIN_NOT_PROVED;
        }
        if (!ok || iv_is_empty(v))
            return TAPE_DOMAIN_NOT_PROVED;
        if (!isfinite(v.lo) || !isfinite(v.hi))
            return TAPE_DOMAIN_OVERFLOW;
        slots[i] = v;
    }
    if (smooth)
        *smooth = sm;
    return TAPE_DOMAIN_CONTINUOUS;
}

int tape_is_total(const tape_t *t)
{
    if (!t)
        return 0;
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        switch ((tape_op_t)c->op) {
        case TAPE_POWI:
            if ((int)c->c.lo < 0)
                return 0;
            break;
        case TAPE_POWR:
        case TAPE_SQRT:
        case TAPE_LOG:
        case TAPE_TAN:
        case TAPE_DIV:
            return 0;
        case TAPE_CONST:
            if (!isfinite(c->c.lo) || !isfinite(c->c.hi))
                return 0;
            break;
        default:
            if ((unsigned)c->op >= (unsigned)TAPE_OP_COUNT)
                return 0;
            break;
        }
    }
    return 1;
}
