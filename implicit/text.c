/* ivoct — polynomials of Z[x, y, z] as text in the expression grammar of
 * docs/scene-format.md: expanded, and nested (Horner) for tape_compile.
 *
 * Integer coefficients are written in full (exact decimal integers, however
 * many digits): the expression compiler encloses a literal that is not a
 * double, so nothing is rounded silently. */
#include <stdlib.h>
#include <string.h>

#include "internal.h"

/* ---- a growing string; out of memory is sticky and checked once at the end ---- */

typedef struct sb {
    char *s;
    size_t len, cap;
    int oom;
} sb_t;

static void sb_putn(sb_t *b, const char *s, size_t n)
{
    if (b->oom)
        return;
    if (b->len + n + 1 > b->cap) {
        size_t cap = b->cap ? b->cap : 64;
        while (cap < b->len + n + 1)
            cap *= 2;
        char *t = realloc(b->s, cap);
        if (t == NULL) {
            b->oom = 1;
            return;
        }
        b->s = t;
        b->cap = cap;
    }
    memcpy(b->s + b->len, s, n);
    b->len += n;
    b->s[b->len] = '\0';
}

static void sb_puts(sb_t *b, const char *s) { sb_putn(b, s, strlen(s)); }

/* |c| in decimal */
static void sb_abs_fmpz(sb_t *b, const fmpz_t c)
{
    fmpz_t a;
    fmpz_init(a);
    fmpz_abs(a, c);
    size_t n = fmpz_sizeinbase(a, 10) + 2;
    char small[64], *buf = n <= sizeof small ? small : malloc(n);
    if (buf == NULL)
        b->oom = 1;
    else {
        fmpz_get_str(buf, 10, a);
        sb_puts(b, buf);
        if (buf != small)
            free(buf);
    }
    fmpz_clear(a);
}

/* Hand over the string (NULL when out of memory). */
static char *sb_take(sb_t *b)
{
    if (b->oom) {
        free(b->s);
        return NULL;
    }
    if (b->s == NULL)
        sb_puts(b, "");
    return b->oom ? NULL : b->s;
}

static const char NAMES[3] = {'x', 'y', 'z'};

/* "x^2*y*z^3" for the exponents e (not all 0) */
static void sb_monomial(sb_t *b, const ulong e[3])
{
    int first = 1;
    char buf[32];
    for (int k = 0; k < 3; k++) {
        if (e[k] == 0)
            continue;
        if (!first)
            sb_puts(b, "*");
        first = 0;
        sb_putn(b, NAMES + k, 1);
        if (e[k] > 1) {
            snprintf(buf, sizeof buf, "^%lu", (unsigned long)e[k]);
            sb_puts(b, buf);
        }
    }
}

char *imp_text_expanded(const fmpz_mpoly_t f, const fmpz_mpoly_ctx_t ctx3)
{
    sb_t b = {0};
    if (f->length == 0)
        sb_puts(&b, "0");
    for (slong i = 0; i < f->length; i++) {
        ulong e[3];
        fmpz_mpoly_get_term_exp_ui(e, f, i, ctx3);
        const fmpz *c = f->coeffs + i;
        int neg = fmpz_sgn(c) < 0, constant = e[0] == 0 && e[1] == 0 && e[2] == 0;
        if (i == 0)
            sb_puts(&b, neg ? "-" : "");
        else
            sb_puts(&b, neg ? " - " : " + ");
        if (constant || !fmpz_is_pm1(c)) {
            sb_abs_fmpz(&b, c);
            if (!constant)
                sb_puts(&b, "*");
        }
        if (!constant)
            sb_monomial(&b, e);
    }
    return sb_take(&b);
}

/* ---- Horner ------------------------------------------------------------------------ */

/* A piece of Horner text: whether it is a sum at its top level (so it needs
 * parentheses as a factor) and how deep its parentheses nest. */
typedef struct piece {
    sb_t b;
    int sum, depth;
} piece_t;

/* p = (p)*v^k, or v^k for p = 1, -v^k for p = -1 */
static void piece_mul_power(piece_t *p, int var, ulong k)
{
    char pw[32];
    if (k > 1)
        snprintf(pw, sizeof pw, "%c^%lu", NAMES[var], (unsigned long)k);
    else
        snprintf(pw, sizeof pw, "%c", NAMES[var]);
    sb_t r = {0};
    if (!p->b.oom && strcmp(p->b.s, "1") == 0)
        sb_puts(&r, pw);
    else if (!p->b.oom && strcmp(p->b.s, "-1") == 0) {
        sb_puts(&r, "-");
        sb_puts(&r, pw);
    } else if (p->sum) {
        sb_puts(&r, "(");
        sb_puts(&r, p->b.oom ? "" : p->b.s);
        sb_puts(&r, ")*");
        sb_puts(&r, pw);
        p->depth++;
    } else {
        sb_puts(&r, p->b.oom ? "" : p->b.s);
        sb_puts(&r, "*");
        sb_puts(&r, pw);
    }
    r.oom |= p->b.oom;
    free(p->b.s);
    p->b = r;
    p->sum = 0;
}

/* p = p + q (q's leading '-' becomes the operator) */
static void piece_add(piece_t *p, const piece_t *q)
{
    if (q->b.oom || p->b.oom) {
        p->b.oom = 1;
        return;
    }
    if (q->b.s[0] == '-') {
        sb_puts(&p->b, " - ");
        sb_puts(&p->b, q->b.s + 1);
    } else {
        sb_puts(&p->b, " + ");
        sb_puts(&p->b, q->b.s);
    }
    p->sum = 1;
    if (q->depth > p->depth)
        p->depth = q->depth;
}

/* Horner text of a in the variables var, var - 1, ..., 0 (a free of the
 * variables above var). */
static void horner(piece_t *out, const fmpz_mpoly_t a, int var, const fmpz_mpoly_ctx_t ctx)
{
    memset(out, 0, sizeof *out);
    slong deg = var >= 0 ? fmpz_mpoly_degree_si(a, var, ctx) : 0;
    if (var < 0 || a->length == 0 || deg <= 0) {
        if (var > 0 && a->length > 0) {
            horner(out, a, var - 1, ctx);
            return;
        }
        /* a constant (var < 0, or the zero polynomial) */
        char *s = imp_text_expanded(a, ctx);
        if (s == NULL)
            out->b.oom = 1;
        else {
            sb_puts(&out->b, s);
            free(s);
        }
        out->sum = 0;
        return;
    }
    /* the coefficients of var^e, e = deg ... 0 */
    fmpz_mpoly_struct *c = malloc(sizeof *c * (size_t)(deg + 1));
    if (c == NULL) {
        out->b.oom = 1;
        return;
    }
    for (slong e = 0; e <= deg; e++)
        fmpz_mpoly_init(c + e, ctx);
    for (slong i = 0; i < a->length; i++) {
        ulong ex[3];
        fmpz_mpoly_get_term_exp_ui(ex, a, i, ctx);
        ulong e = ex[var];
        ex[var] = 0;
        fmpz_mpoly_push_term_fmpz_ui(c + e, a->coeffs + i, ex, ctx);
    }
    int started = 0;
    slong last = 0;
    for (slong e = deg; e >= 0; e--) {
        if (c[e].length == 0)
            continue;
        fmpz_mpoly_sort_terms(c + e, ctx);
        fmpz_mpoly_combine_like_terms(c + e, ctx);
        piece_t q;
        horner(&q, c + e, var - 1, ctx);
        if (!started) {
            *out = q;
            started = 1;
        } else {
            piece_mul_power(out, var, (ulong)(last - e));
            piece_add(out, &q);
            free(q.b.s);
        }
        last = e;
    }
    if (last > 0)
        piece_mul_power(out, var, (ulong)last);
    for (slong e = 0; e <= deg; e++)
        fmpz_mpoly_clear(c + e, ctx);
    free(c);
}

char *imp_text_horner(const fmpz_mpoly_t f, const fmpz_mpoly_ctx_t ctx3)
{
    piece_t p;
    horner(&p, f, 2, ctx3);
    if (!p.b.oom && p.depth > IMP_TAPE_NESTING) {
        free(p.b.s);
        return imp_text_expanded(f, ctx3);
    }
    return sb_take(&p.b);
}
