/* ivoct — the coordinate texts of a parametrization, parsed into exact
 * rational functions of u and v (imp_param_parse).
 *
 * Grammar: the expression grammar of docs/scene-format.md restricted to what
 * stays a quotient of polynomials with rational coefficients:
 *   expr    := term (('+' | '-') term)*        left-associative
 *   term    := unary (('*' | '/') unary)*      left-associative
 *   unary   := ('-' | '+') unary | power
 *   power   := primary ('^' unary)?            the exponent an integer constant
 *   primary := number | 'u' | 'v' | '(' expr ')'
 * Every value is computed as it is parsed: a fraction num/den of integer
 * polynomials (FLINT's fmpz_mpoly over Z[u, v]), reduced by their gcd after
 * each operation so the coefficients stay as small as the value allows.
 *
 * Like expr/parse.c, recursion happens only at '(', a sign and '^', each
 * counting one level against IMP_MAX_NESTING, so the C stack is bounded
 * whatever the input.  Sizes are predicted before each product or power and
 * refused past IMP_MAX_DEGREE and IMP_MAX_BITS, so no text can make FLINT
 * allocate without bound ((1+u)^100000 is an error, not a crash). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <flint/fmpq.h>

#include "internal.h"

/* Longest part of a name or token quoted in a message. */
#define QUOTE_MAX 40

typedef enum {
    T_END, T_NUM, T_NAME, T_PLUS, T_MINUS, T_STAR, T_SLASH, T_CARET, T_LPAREN, T_RPAREN
} tok_kind_t;

typedef struct token {
    tok_kind_t kind;
    size_t start, len;
    int line, col;
} token_t;

/* A value: num / den in Z[u, v]. */
typedef struct rat {
    fmpz_mpoly_t num, den;
} rat_t;

typedef struct parser {
    const char *s;
    size_t n, pos, line_start;
    int line;
    token_t tok;
    int depth;
    const fmpz_mpoly_ctx_struct *ctx;
    ivoct_error_t *err;
} parser_t;

static int is_digit(int c) { return c >= '0' && c <= '9'; }
static int is_alpha(int c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; }
static int is_alnum(int c) { return is_alpha(c) || is_digit(c); }
static int is_space(int c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f'; }

static int col_at(const parser_t *p, size_t pos) { return (int)(pos - p->line_start) + 1; }

/* ---- values ------------------------------------------------------------------------ */

static void rat_init(rat_t *a, const parser_t *p)
{
    fmpz_mpoly_init(a->num, p->ctx);
    fmpz_mpoly_init(a->den, p->ctx);
    fmpz_mpoly_one(a->den, p->ctx);
}

static void rat_clear(rat_t *a, const parser_t *p)
{
    fmpz_mpoly_clear(a->num, p->ctx);
    fmpz_mpoly_clear(a->den, p->ctx);
}

static slong poly_deg(const fmpz_mpoly_t a, const fmpz_mpoly_ctx_t ctx)
{
    slong d = fmpz_mpoly_total_degree_si(a, ctx);
    return d < 0 ? 0 : d;
}

static slong poly_bits(const fmpz_mpoly_t a)
{
    slong b = fmpz_mpoly_max_bits(a);
    return b < 0 ? -b : b;
}

/* Bits of a product of a and b, bounded from above: the largest coefficient
 * of a product is at most the shorter factor's length times the product of
 * the largest coefficients. */
static slong mul_bits(const fmpz_mpoly_t a, const fmpz_mpoly_t b)
{
    slong la = a->length, lb = b->length, l = la < lb ? la : lb;
    return poly_bits(a) + poly_bits(b) + (slong)FLINT_BIT_COUNT((ulong)l) + 1;
}

/* Refuse a product a*b whose degree or coefficients would pass the limits. */
static int check_mul(parser_t *p, const fmpz_mpoly_t a, const fmpz_mpoly_t b, const token_t *at)
{
    if (poly_deg(a, p->ctx) + poly_deg(b, p->ctx) > IMP_MAX_DEGREE) {
        ivoct_error_at(p->err, at->line, at->col,
                       "polynomial of degree above the limit of %d in a parametrization",
                       IMP_MAX_DEGREE);
        return -1;
    }
    if (mul_bits(a, b) > IMP_MAX_BITS) {
        ivoct_error_at(p->err, at->line, at->col,
                       "coefficients above the limit of %d bits in a parametrization",
                       IMP_MAX_BITS);
        return -1;
    }
    return 0;
}

/* Reduce a fraction: divide by the gcd (which carries the integer content),
 * then make the denominator's leading coefficient positive. */
static void rat_reduce(rat_t *a, const parser_t *p)
{
    if (fmpz_mpoly_is_zero(a->num, p->ctx)) {
        fmpz_mpoly_one(a->den, p->ctx);
        return;
    }
    fmpz_mpoly_t g;
    fmpz_mpoly_init(g, p->ctx);
    /* Within the limits of degree and size the gcd does not fail; if it did,
     * the fraction would merely stay unreduced, which is still exact. */
    if (fmpz_mpoly_gcd(g, a->num, a->den, p->ctx) && !fmpz_mpoly_is_one(g, p->ctx)) {
        fmpz_mpoly_divexact(a->num, a->num, g, p->ctx);
        fmpz_mpoly_divexact(a->den, a->den, g, p->ctx);
    }
    fmpz_mpoly_clear(g, p->ctx);
    if (fmpz_sgn(a->den->coeffs + 0) < 0) {
        fmpz_mpoly_neg(a->num, a->num, p->ctx);
        fmpz_mpoly_neg(a->den, a->den, p->ctx);
    }
}

/* a = a + sign * b */
static int rat_add(parser_t *p, rat_t *a, const rat_t *b, int sign, const token_t *at)
{
    if (check_mul(p, a->num, b->den, at) || check_mul(p, b->num, a->den, at) ||
        check_mul(p, a->den, b->den, at))
        return -1;
    fmpz_mpoly_t t;
    fmpz_mpoly_init(t, p->ctx);
    if (fmpz_mpoly_equal(a->den, b->den, p->ctx)) {
        if (sign > 0)
            fmpz_mpoly_add(a->num, a->num, b->num, p->ctx);
        else
            fmpz_mpoly_sub(a->num, a->num, b->num, p->ctx);
    } else {
        fmpz_mpoly_mul(t, b->num, a->den, p->ctx);
        fmpz_mpoly_mul(a->num, a->num, b->den, p->ctx);
        if (sign > 0)
            fmpz_mpoly_add(a->num, a->num, t, p->ctx);
        else
            fmpz_mpoly_sub(a->num, a->num, t, p->ctx);
        fmpz_mpoly_mul(a->den, a->den, b->den, p->ctx);
    }
    fmpz_mpoly_clear(t, p->ctx);
    rat_reduce(a, p);
    return 0;
}

static int rat_mul(parser_t *p, rat_t *a, const rat_t *b, const token_t *at)
{
    if (check_mul(p, a->num, b->num, at) || check_mul(p, a->den, b->den, at))
        return -1;
    fmpz_mpoly_mul(a->num, a->num, b->num, p->ctx);
    fmpz_mpoly_mul(a->den, a->den, b->den, p->ctx);
    rat_reduce(a, p);
    return 0;
}

static int rat_div(parser_t *p, rat_t *a, const rat_t *b, const token_t *at)
{
    if (fmpz_mpoly_is_zero(b->num, p->ctx)) {
        ivoct_error_at(p->err, at->line, at->col, "division by a polynomial that is identically 0");
        return -1;
    }
    if (check_mul(p, a->num, b->den, at) || check_mul(p, a->den, b->num, at))
        return -1;
    fmpz_mpoly_t t;
    fmpz_mpoly_init(t, p->ctx);
    fmpz_mpoly_mul(t, a->den, b->num, p->ctx);
    fmpz_mpoly_mul(a->num, a->num, b->den, p->ctx);
    fmpz_mpoly_swap(a->den, t, p->ctx);
    fmpz_mpoly_clear(t, p->ctx);
    rat_reduce(a, p);
    return 0;
}

/* a = a^n for an integer n (0^0 = 1, as in the expression grammar). */
static int rat_pow(parser_t *p, rat_t *a, slong n, const token_t *at)
{
    if (n < 0 && fmpz_mpoly_is_zero(a->num, p->ctx)) {
        ivoct_error_at(p->err, at->line, at->col,
                       "negative power of a polynomial that is identically 0");
        return -1;
    }
    ulong m = n < 0 ? (ulong)(-(n + 1)) + 1 : (ulong)n;
    slong deg = poly_deg(a->num, p->ctx) > poly_deg(a->den, p->ctx) ? poly_deg(a->num, p->ctx)
                                                                     : poly_deg(a->den, p->ctx);
    slong bits = poly_bits(a->num) > poly_bits(a->den) ? poly_bits(a->num) : poly_bits(a->den);
    slong len = a->num->length > a->den->length ? a->num->length : a->den->length;
    /* (bits + log2 len) per factor bounds the coefficients of the power; a
     * monomial with coefficients +-1 (u, 1/v, -1) does not grow at all */
    slong per = bits + (slong)FLINT_BIT_COUNT((ulong)len);
    int grows = !(len <= 1 && bits <= 1);
    if (m > 0 && ((deg > 0 && m > (ulong)(IMP_MAX_DEGREE / deg)) ||
                  (grows && m > (ulong)(IMP_MAX_BITS / per)))) {
        ivoct_error_at(p->err, at->line, at->col,
                       "power too large: the result would pass the limit of degree %d or of "
                       "%d-bit coefficients in a parametrization",
                       IMP_MAX_DEGREE, IMP_MAX_BITS);
        return -1;
    }
    if (n < 0)
        fmpz_mpoly_swap(a->num, a->den, p->ctx);
    /* within the limits above the exponents cannot overflow: pow_ui succeeds */
    if (!fmpz_mpoly_pow_ui(a->num, a->num, m, p->ctx) || !fmpz_mpoly_pow_ui(a->den, a->den, m, p->ctx)) {
        ivoct_error_at(p->err, at->line, at->col, "power too large in a parametrization");
        return -1;
    }
    rat_reduce(a, p);
    return 0;
}

/* ---- lexer ------------------------------------------------------------------------- */

static int lex_number(parser_t *p)
{
    const char *s = p->s;
    size_t i = p->pos;
    while (i < p->n && is_digit(s[i]))
        i++;
    if (i < p->n && s[i] == '.') {
        i++;
        while (i < p->n && is_digit(s[i]))
            i++;
    }
    if (i < p->n && (s[i] == 'e' || s[i] == 'E')) {
        size_t j = i + 1;
        if (j < p->n && (s[j] == '+' || s[j] == '-'))
            j++;
        if (j >= p->n || !is_digit(s[j])) {
            ivoct_error_at(p->err, p->line, col_at(p, i),
                           "malformed number: expected the digits of an exponent after '%c'", s[i]);
            return -1;
        }
        while (j < p->n && is_digit(s[j]))
            j++;
        i = j;
    }
    if (i < p->n && (s[i] == '.' || is_digit(s[i]))) {
        ivoct_error_at(p->err, p->line, col_at(p, i), "malformed number: unexpected '.'");
        return -1;
    }
    if (i < p->n && is_alpha(s[i])) {
        size_t k = i;
        while (k < p->n && is_alnum(s[k]))
            k++;
        int len = (int)(k - i < QUOTE_MAX ? k - i : QUOTE_MAX);
        ivoct_error_at(p->err, p->line, col_at(p, i),
                       "expected an operator before '%.*s' (implicit multiplication is not supported)",
                       len, s + i);
        return -1;
    }
    p->tok.kind = T_NUM;
    p->tok.len = i - p->pos;
    p->pos = i;
    return 0;
}

/* Length of the character at s[i] for messages: a whole UTF-8 sequence. */
static size_t char_len(const parser_t *p, size_t i)
{
    size_t k = 1;
    if ((unsigned char)p->s[i] >= 0xc0)
        while (i + k < p->n && k < 4 && ((unsigned char)p->s[i + k] & 0xc0) == 0x80)
            k++;
    return k;
}

static int lex(parser_t *p)
{
    const char *s = p->s;
    while (p->pos < p->n && is_space((unsigned char)s[p->pos])) {
        if (s[p->pos] == '\n') {
            p->line++;
            p->line_start = p->pos + 1;
        }
        p->pos++;
    }
    p->tok.start = p->pos;
    p->tok.line = p->line;
    p->tok.col = col_at(p, p->pos);
    p->tok.len = 1;
    if (p->pos >= p->n) {
        p->tok.kind = T_END;
        p->tok.len = 0;
        return 0;
    }
    unsigned char c = (unsigned char)s[p->pos];
    if (is_digit(c) || (c == '.' && p->pos + 1 < p->n && is_digit(s[p->pos + 1])))
        return lex_number(p);
    if (is_alpha(c)) {
        size_t i = p->pos;
        while (i < p->n && is_alnum(s[i]))
            i++;
        p->tok.kind = T_NAME;
        p->tok.len = i - p->pos;
        p->pos = i;
        return 0;
    }
    switch (c) {
    case '+': p->tok.kind = T_PLUS; break;
    case '-': p->tok.kind = T_MINUS; break;
    case '*': p->tok.kind = T_STAR; break;
    case '/': p->tok.kind = T_SLASH; break;
    case '^': p->tok.kind = T_CARET; break;
    case '(': p->tok.kind = T_LPAREN; break;
    case ')': p->tok.kind = T_RPAREN; break;
    case ',':
        ivoct_error_at(p->err, p->line, p->tok.col,
                       "unexpected ',': a parametrization has no functions of two arguments");
        return -1;
    case '.':
        ivoct_error_at(p->err, p->line, p->tok.col, "malformed number: expected a digit after '.'");
        return -1;
    default:
        if (c < 0x20 || c == 0x7f)
            ivoct_error_at(p->err, p->line, p->tok.col, "unexpected control character 0x%02x", c);
        else
            ivoct_error_at(p->err, p->line, p->tok.col, "unexpected character '%.*s'",
                           (int)char_len(p, p->pos), s + p->pos);
        return -1;
    }
    p->pos++;
    return 0;
}

static void describe(const parser_t *p, const token_t *t, char *buf, size_t n)
{
    if (t->kind == T_END)
        snprintf(buf, n, "end of input");
    else
        snprintf(buf, n, "'%.*s'", (int)(t->len < QUOTE_MAX ? t->len : QUOTE_MAX), p->s + t->start);
}

/* ---- parser ------------------------------------------------------------------------ */

static int enter(parser_t *p)
{
    if (++p->depth > IMP_MAX_NESTING) {
        ivoct_error_at(p->err, p->tok.line, p->tok.col, "expression nested deeper than %d levels",
                       IMP_MAX_NESTING);
        return -1;
    }
    return 0;
}

static int parse_expr(parser_t *p, rat_t *out);
static int parse_unary(parser_t *p, rat_t *out);

/* A decimal literal, exactly: digits d (integer and fraction parts) and
 * exponent e give d * 10^(e - number of fraction digits). */
static int parse_number(parser_t *p, rat_t *out)
{
    const char *s = p->s + p->tok.start;
    size_t len = p->tok.len, i = 0, nd = 0, frac = 0;
    char *digits = malloc(len + 1);
    if (digits == NULL) {
        ivoct_error_at(p->err, 0, 0, "out of memory while parsing a parametrization");
        return -2;
    }
    int seen_point = 0;
    for (; i < len && s[i] != 'e' && s[i] != 'E'; i++) {
        if (s[i] == '.') {
            seen_point = 1;
            continue;
        }
        if (nd == 0 && s[i] == '0' && !seen_point)
            continue; /* leading zeros of the integer part */
        digits[nd++] = s[i];
        frac += (size_t)seen_point;
    }
    digits[nd] = '\0';
    long e = 0;
    if (i < len) { /* exponent, saturated: anything past the limits is refused below */
        int neg = s[i + 1] == '-';
        for (i += 1 + (s[i + 1] == '+' || s[i + 1] == '-'); i < len; i++)
            if (e < 100000000L)
                e = 10 * e + (s[i] - '0');
        if (neg)
            e = -e;
    }
    long scale = e - (long)frac;
    /* log2(10) < 3.33: the numerator or denominator has at most this many bits */
    double bits = 3.33 * ((double)nd + (double)(scale < 0 ? -scale : scale));
    if (bits > IMP_MAX_BITS) {
        free(digits);
        ivoct_error_at(p->err, p->tok.line, p->tok.col,
                       "number too large or too precise for exact arithmetic: above the limit of "
                       "%d bits",
                       IMP_MAX_BITS);
        return -1;
    }
    fmpz_t m, t;
    fmpz_init(m);
    fmpz_init(t);
    if (nd > 0)
        fmpz_set_str(m, digits, 10);
    free(digits);
    fmpz_set_ui(t, 10);
    fmpz_pow_ui(t, t, (ulong)(scale < 0 ? -scale : scale));
    fmpq_t q;
    fmpq_init(q);
    if (scale >= 0) {
        fmpz_mul(m, m, t);
        fmpz_one(t);
    }
    fmpq_set_fmpz_frac(q, m, t); /* canonical: 0.50 = 1/2 */
    fmpz_mpoly_set_fmpz(out->num, fmpq_numref(q), p->ctx);
    fmpz_mpoly_set_fmpz(out->den, fmpq_denref(q), p->ctx);
    fmpq_clear(q);
    fmpz_clear(m);
    fmpz_clear(t);
    return lex(p);
}

static int name_is(const parser_t *p, const token_t *t, const char *name)
{
    return t->len == strlen(name) && memcmp(p->s + t->start, name, t->len) == 0;
}

/* A name: u, v, or an error that says why the name has no place here. */
static int parse_name(parser_t *p, rat_t *out)
{
    static const char *const transcendental[] = {"sin", "cos", "tan", "atan", "exp", "log"};
    static const char *const other_funcs[] = {"sqrt", "abs", "min", "max"};
    token_t t = p->tok;
    const char *s = p->s + t.start;
    int qlen = (int)(t.len < QUOTE_MAX ? t.len : QUOTE_MAX);
    if (name_is(p, &t, "u") || name_is(p, &t, "v")) {
        fmpz_mpoly_gen(out->num, s[0] == 'u' ? 0 : 1, p->ctx);
        fmpz_mpoly_one(out->den, p->ctx);
        return lex(p);
    }
    for (size_t k = 0; k < sizeof transcendental / sizeof *transcendental; k++)
        if (name_is(p, &t, transcendental[k])) {
            ivoct_error_at(p->err, t.line, t.col,
                           "transcendental function '%s' in a parametrization: only polynomials "
                           "and quotients of polynomials in u and v",
                           transcendental[k]);
            return -1;
        }
    for (size_t k = 0; k < sizeof other_funcs / sizeof *other_funcs; k++)
        if (name_is(p, &t, other_funcs[k])) {
            ivoct_error_at(p->err, t.line, t.col,
                           "function '%s' in a parametrization: only polynomials and quotients of "
                           "polynomials in u and v",
                           other_funcs[k]);
            return -1;
        }
    if (name_is(p, &t, "x") || name_is(p, &t, "y") || name_is(p, &t, "z")) {
        ivoct_error_at(p->err, t.line, t.col, "'%c' in a parametrization: the parameters are u and v",
                       s[0]);
        return -1;
    }
    if (name_is(p, &t, "pi") || name_is(p, &t, "e")) {
        ivoct_error_at(p->err, t.line, t.col,
                       "'%.*s' in a parametrization: coefficients are exact rationals (%.*s is "
                       "transcendental)",
                       qlen, s, qlen, s);
        return -1;
    }
    const char *hint = name_is(p, &t, "U")   ? " (names are case-sensitive: did you mean 'u'?)"
                       : name_is(p, &t, "V") ? " (names are case-sensitive: did you mean 'v'?)"
                                             : "";
    size_t k = p->pos;
    while (k < p->n && is_space((unsigned char)p->s[k]))
        k++;
    int call = k < p->n && p->s[k] == '(';
    ivoct_error_at(p->err, t.line, t.col, "unknown %s '%.*s' in a parametrization: the parameters are u and v%s",
                   call ? "function" : "name", qlen, s, hint);
    return -1;
}

static int parse_primary(parser_t *p, rat_t *out)
{
    switch (p->tok.kind) {
    case T_NUM:
        return parse_number(p, out);
    case T_NAME:
        return parse_name(p, out);
    case T_LPAREN: {
        token_t open = p->tok;
        int rc = 0;
        if (enter(p) || lex(p) || (rc = parse_expr(p, out)) == -1)
            return -1;
        if (rc)
            return rc;
        if (p->tok.kind != T_RPAREN) {
            ivoct_error_at(p->err, p->tok.line, p->tok.col, "expected ')' to close '(' opened at %d:%d",
                           open.line, open.col);
            return -1;
        }
        p->depth--;
        return lex(p);
    }
    default: {
        char found[QUOTE_MAX + 8];
        describe(p, &p->tok, found, sizeof found);
        ivoct_error_at(p->err, p->tok.line, p->tok.col, "expected an expression, found %s", found);
        return -1;
    }
    }
}

/* The exponent of '^': an integer constant (2, -1, (3), 2^3 ...). */
static int parse_exponent(parser_t *p, slong *n)
{
    token_t at = p->tok;
    rat_t e;
    rat_init(&e, p);
    int rc = parse_unary(p, &e);
    if (rc == 0) {
        if (!fmpz_mpoly_is_fmpz(e.num, p->ctx) || !fmpz_mpoly_is_fmpz(e.den, p->ctx)) {
            ivoct_error_at(p->err, at.line, at.col,
                           "the exponent depends on u or v: exponents must be integer constants");
            rc = -1;
        } else if (!fmpz_mpoly_is_one(e.den, p->ctx)) {
            ivoct_error_at(p->err, at.line, at.col,
                           "the exponent is not an integer: a parametrization is rational");
            rc = -1;
        } else {
            fmpz_t c;
            fmpz_init(c);
            fmpz_mpoly_get_fmpz(c, e.num, p->ctx);
            if (fmpz_bits(c) > 20) { /* past 10^6: beyond any limit below */
                ivoct_error_at(p->err, at.line, at.col, "exponent too large in a parametrization");
                rc = -1;
            } else {
                *n = fmpz_get_si(c);
            }
            fmpz_clear(c);
        }
    }
    rat_clear(&e, p);
    return rc;
}

static int parse_power(parser_t *p, rat_t *out)
{
    int rc = parse_primary(p, out);
    if (rc || p->tok.kind != T_CARET)
        return rc;
    token_t caret = p->tok;
    slong n = 0;
    rc = 0;
    if (enter(p) || lex(p) || (rc = parse_exponent(p, &n)) == -1)
        return -1;
    if (rc)
        return rc;
    p->depth--;
    return rat_pow(p, out, n, &caret);
}

static int parse_unary(parser_t *p, rat_t *out)
{
    if (p->tok.kind != T_MINUS && p->tok.kind != T_PLUS)
        return parse_power(p, out);
    int neg = p->tok.kind == T_MINUS, rc = 0;
    if (enter(p) || lex(p) || (rc = parse_unary(p, out)) == -1)
        return -1;
    if (rc)
        return rc;
    p->depth--;
    if (neg)
        fmpz_mpoly_neg(out->num, out->num, p->ctx);
    return 0;
}

static int parse_term(parser_t *p, rat_t *out)
{
    int rc = parse_unary(p, out);
    if (rc)
        return rc;
    rat_t b;
    rat_init(&b, p);
    while (rc == 0 && (p->tok.kind == T_STAR || p->tok.kind == T_SLASH)) {
        token_t op = p->tok;
        if ((rc = lex(p)) || (rc = parse_unary(p, &b)))
            break;
        rc = op.kind == T_STAR ? rat_mul(p, out, &b, &op) : rat_div(p, out, &b, &op);
    }
    rat_clear(&b, p);
    return rc;
}

static int parse_expr(parser_t *p, rat_t *out)
{
    int rc = parse_term(p, out);
    if (rc)
        return rc;
    rat_t b;
    rat_init(&b, p);
    while (rc == 0 && (p->tok.kind == T_PLUS || p->tok.kind == T_MINUS)) {
        token_t op = p->tok;
        if ((rc = lex(p)) || (rc = parse_term(p, &b)))
            break;
        rc = rat_add(p, out, &b, op.kind == T_PLUS ? 1 : -1, &op);
    }
    rat_clear(&b, p);
    return rc;
}

/* One coordinate text into num/den.  Returns 0, -1 (input error) or -2 (no memory). */
static int parse_coordinate(const char *text, const fmpz_mpoly_ctx_t ctx, fmpz_mpoly_t num,
                            fmpz_mpoly_t den, ivoct_error_t *err)
{
    if (text == NULL) {
        ivoct_error_at(err, 0, 0, "missing coordinate text");
        return -1;
    }
    size_t n = 0; /* measured without reading past the limit + 1 */
    while (text[n] && n <= IMP_MAX_TEXT)
        n++;
    if (n > IMP_MAX_TEXT) {
        ivoct_error_at(err, 1, 1, "parametrization longer than the limit of %u bytes", IMP_MAX_TEXT);
        return -1;
    }
    parser_t p = {.s = text, .n = n, .line = 1, .ctx = ctx, .err = err};
    rat_t v;
    rat_init(&v, &p);
    int rc = lex(&p);
    if (rc == 0 && p.tok.kind == T_END) {
        ivoct_error_at(err, p.tok.line, p.tok.col, "empty coordinate: expected an expression");
        rc = -1;
    }
    if (rc == 0)
        rc = parse_expr(&p, &v);
    if (rc == 0 && p.tok.kind != T_END) {
        if (p.tok.kind == T_RPAREN)
            ivoct_error_at(err, p.tok.line, p.tok.col, "unexpected ')'");
        else
            ivoct_error_at(err, p.tok.line, p.tok.col, "trailing input after expression");
        rc = -1;
    }
    if (rc == 0) {
        fmpz_mpoly_swap(num, v.num, ctx);
        fmpz_mpoly_swap(den, v.den, ctx);
    }
    rat_clear(&v, &p);
    return rc;
}

/* ---- the map as a whole: is its image a surface? -------------------------------------- */

/* Numerators of dX/du and dX/dv: (n' d - n d') / d^2, the positive d^2 left out. */
void imp_partials(const fmpz_mpoly_t n, const fmpz_mpoly_t d, const fmpz_mpoly_ctx_t ctx,
                  fmpz_mpoly_t du, fmpz_mpoly_t dv)
{
    fmpz_mpoly_t a, b;
    fmpz_mpoly_init(a, ctx);
    fmpz_mpoly_init(b, ctx);
    fmpz_mpoly_struct *out[2] = {du, dv};
    for (slong var = 0; var < 2; var++) {
        fmpz_mpoly_derivative(a, n, var, ctx);
        fmpz_mpoly_mul(a, a, d, ctx);
        fmpz_mpoly_derivative(b, d, var, ctx);
        fmpz_mpoly_mul(b, b, n, ctx);
        fmpz_mpoly_sub(out[var], a, b, ctx);
    }
    fmpz_mpoly_clear(a, ctx);
    fmpz_mpoly_clear(b, ctx);
}

/* Rank of the Jacobian matrix of the map as rational functions: 0 (constant),
 * 1 (the image is a curve: every 2x2 minor vanishes identically) or 2 (a
 * surface).  Exact: the minors' numerators are polynomials compared with 0. */
static int jacobian_rank(const imp_param_t *p)
{
    const fmpz_mpoly_ctx_struct *ctx = p->ctx;
    fmpz_mpoly_t du[3], dv[3], m, t;
    int rank = 0;
    for (int i = 0; i < 3; i++) {
        fmpz_mpoly_init(du[i], ctx);
        fmpz_mpoly_init(dv[i], ctx);
        imp_partials(p->num + i, p->den + i, ctx, du[i], dv[i]);
        if (!fmpz_mpoly_is_zero(du[i], ctx) || !fmpz_mpoly_is_zero(dv[i], ctx))
            rank = 1;
    }
    fmpz_mpoly_init(m, ctx);
    fmpz_mpoly_init(t, ctx);
    for (int i = 0; i < 3 && rank == 1; i++) {
        int j = (i + 1) % 3;
        fmpz_mpoly_mul(m, du[i], dv[j], ctx);
        fmpz_mpoly_mul(t, dv[i], du[j], ctx);
        if (!fmpz_mpoly_equal(m, t, ctx))
            rank = 2;
    }
    fmpz_mpoly_clear(m, ctx);
    fmpz_mpoly_clear(t, ctx);
    for (int i = 0; i < 3; i++) {
        fmpz_mpoly_clear(du[i], ctx);
        fmpz_mpoly_clear(dv[i], ctx);
    }
    return rank;
}

/* ---- interface -------------------------------------------------------------------------- */

int imp_param_parse(const char *const text[3], imp_param_t **out, int *which, ivoct_error_t *err)
{
    ivoct_error_clear(err);
    if (out)
        *out = NULL;
    if (which)
        *which = 0;
    if (text == NULL || out == NULL) {
        ivoct_error_set(err, "imp_param_parse: no texts or no result");
        return IMP_EINPUT;
    }
    imp_param_t *p = malloc(sizeof *p);
    if (p == NULL) {
        ivoct_error_set(err, "out of memory while parsing a parametrization");
        return IMP_ENOMEM;
    }
    fmpz_mpoly_ctx_init(p->ctx, 2, ORD_LEX);
    for (int i = 0; i < 3; i++) {
        fmpz_mpoly_init(p->num + i, p->ctx);
        fmpz_mpoly_init(p->den + i, p->ctx);
    }
    for (int i = 0; i < 3; i++) {
        int rc = parse_coordinate(text[i], p->ctx, p->num + i, p->den + i, err);
        if (rc) {
            if (which)
                *which = i;
            imp_param_free(p);
            return rc == -2 ? IMP_ENOMEM : IMP_EINPUT;
        }
    }
    int rank = jacobian_rank(p);
    if (rank < 2) {
        if (rank == 0)
            ivoct_error_at(err, 0, 0,
                           "the parametrization is constant: its image is a point, not a surface");
        else
            ivoct_error_at(err, 0, 0,
                           "the image of the parametrization is a curve, not a surface: its "
                           "Jacobian matrix has rank 1 (the coordinates depend on only one of u, v, "
                           "or on one combination of them)");
        imp_param_free(p);
        return IMP_EINPUT;
    }
    *out = p;
    return IMP_OK;
}

void imp_param_free(imp_param_t *p)
{
    if (p == NULL)
        return;
    for (int i = 0; i < 3; i++) {
        fmpz_mpoly_clear(p->num + i, p->ctx);
        fmpz_mpoly_clear(p->den + i, p->ctx);
    }
    fmpz_mpoly_ctx_clear(p->ctx);
    free(p);
}
