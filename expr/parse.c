/* ivoct — the expression compiler: lexer, recursive-descent parser building
 * the DAG of dag.c, the named subexpressions, and the tape_compile* entry
 * points of tape.h.
 *
 * Grammar (docs/scene-format.md), loosest first:
 *   expr    := term (('+' | '-') term)*             left-associative
 *   term    := unary (('*' | '/') unary)*           left-associative
 *   unary   := ('-' | '+') unary | power            -x^2 = -(x^2)
 *   power   := primary ('^' unary)?                 right-associative, 2^-x allowed
 *   primary := number | name | function '(' expr (',' expr)? ')' | '(' expr ')'
 *
 * Recursion happens only at '(' , a sign and '^', and each of those counts one
 * level against TAPE_MAX_NESTING, so the C stack stays bounded (about five
 * frames per level) whatever the input; long flat chains such as x+x+...+x
 * are loops.  Everything after parsing (dag.c) is iterative. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dag.h"
#include "tape.h"

/* ---- the compiler: a DAG shared by all texts, and the names defined ---------- */

typedef struct name_def {
    char *name;
    uint32_t node;
} name_def_t;

struct tape_compiler {
    dag_t dag;
    name_def_t *names;
    uint32_t n_names, cap_names;
    uint32_t *index; /* open addressing over names: index + 1, 0 = free */
    uint32_t index_cap;
};

static const struct {
    const char *name;
    tape_op_t op;
    int nargs;
} FUNCS[] = {
    {"sqrt", TAPE_SQRT, 1}, {"exp", TAPE_EXP, 1},   {"log", TAPE_LOG, 1},
    {"sin", TAPE_SIN, 1},   {"cos", TAPE_COS, 1},   {"tan", TAPE_TAN, 1},
    {"atan", TAPE_ATAN, 1}, {"abs", TAPE_ABS, 1},   {"min", TAPE_MIN, 2},
    {"max", TAPE_MAX, 2},
};
#define N_FUNCS (sizeof FUNCS / sizeof FUNCS[0])

/* x y z pi e: the names that are not functions and cannot be redefined */
static const char *const BUILTINS[] = {"x", "y", "z", "pi", "e"};
#define N_BUILTINS (sizeof BUILTINS / sizeof BUILTINS[0])

/* Longest part of a name or token quoted in a message. */
#define QUOTE_MAX 40

static int is_digit(int c) { return c >= '0' && c <= '9'; }
static int is_alpha(int c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; }
static int is_alnum(int c) { return is_alpha(c) || is_digit(c); }
static int is_space(int c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f'; }
static int lower(int c) { return c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c; }

static int name_is(const char *s, size_t len, const char *name)
{
    return strlen(name) == len && memcmp(s, name, len) == 0;
}

static int name_is_nocase(const char *s, size_t len, const char *name)
{
    if (strlen(name) != len)
        return 0;
    for (size_t i = 0; i < len; i++)
        if (lower((unsigned char)s[i]) != lower((unsigned char)name[i]))
            return 0;
    return 1;
}

static int find_func(const char *s, size_t len)
{
    for (size_t i = 0; i < N_FUNCS; i++)
        if (name_is(s, len, FUNCS[i].name))
            return (int)i;
    return -1;
}

static uint64_t name_hash(const char *s, size_t len)
{
    uint64_t h = 0xcbf29ce484222325ull; /* FNV-1a */
    for (size_t i = 0; i < len; i++)
        h = (h ^ (unsigned char)s[i]) * 0x100000001b3ull;
    return h;
}

/* Index of the defined name, or -1. */
static long find_name(const tape_compiler_t *tc, const char *s, size_t len)
{
    if (!tc->index_cap)
        return -1;
    uint32_t mask = tc->index_cap - 1;
    for (uint32_t i = (uint32_t)name_hash(s, len) & mask; tc->index[i]; i = (i + 1) & mask) {
        const name_def_t *d = &tc->names[tc->index[i] - 1];
        if (name_is(s, len, d->name))
            return (long)tc->index[i] - 1;
    }
    return -1;
}

static int index_insert(tape_compiler_t *tc, uint32_t k)
{
    if ((uint64_t)(tc->n_names + 1) * 2 > tc->index_cap) {
        uint32_t cap = tc->index_cap ? tc->index_cap * 2 : 64;
        if (cap < tc->index_cap)
            return -1;
        uint32_t *ix = calloc(cap, sizeof *ix);
        if (!ix)
            return -1;
        for (uint32_t j = 0; j < tc->n_names; j++) {
            const char *nm = tc->names[j].name;
            uint32_t i = (uint32_t)name_hash(nm, strlen(nm)) & (cap - 1);
            while (ix[i])
                i = (i + 1) & (cap - 1);
            ix[i] = j + 1;
        }
        free(tc->index);
        tc->index = ix;
        tc->index_cap = cap;
    }
    const char *nm = tc->names[k].name;
    uint32_t mask = tc->index_cap - 1;
    uint32_t i = (uint32_t)name_hash(nm, strlen(nm)) & mask;
    while (tc->index[i])
        i = (i + 1) & mask;
    tc->index[i] = k + 1;
    return 0;
}

tape_compiler_t *tape_compiler_new(void)
{
    tape_compiler_t *tc = calloc(1, sizeof *tc);
    if (tc)
        dag_init(&tc->dag);
    return tc;
}

void tape_compiler_free(tape_compiler_t *tc)
{
    if (!tc)
        return;
    for (uint32_t i = 0; i < tc->n_names; i++)
        free(tc->names[i].name);
    free(tc->names);
    free(tc->index);
    dag_free(&tc->dag);
    free(tc);
}

/* ---- lexer ---------------------------------------------------------------------- */

typedef enum {
    T_END,
    T_NUM,
    T_NAME,
    T_PLUS,
    T_MINUS,
    T_STAR,
    T_SLASH,
    T_CARET,
    T_LPAREN,
    T_RPAREN,
    T_COMMA
} tok_kind_t;

typedef struct token {
    tok_kind_t kind;
    size_t start, len; /* bytes of text */
    int line, col;     /* 1-based */
} token_t;

typedef struct parser {
    tape_compiler_t *tc;
    const char *s;
    size_t n;
    size_t pos, line_start;
    int line;
    token_t tok;
    int depth;
    ivoct_error_t *err;
} parser_t;

static int col_at(const parser_t *p, size_t pos) { return (int)(pos - p->line_start) + 1; }

/* Length of the character at s[i] for messages: a whole UTF-8 sequence. */
static size_t char_len(const parser_t *p, size_t i)
{
    size_t k = 1;
    if ((unsigned char)p->s[i] >= 0xc0)
        while (i + k < p->n && k < 4 && ((unsigned char)p->s[i + k] & 0xc0) == 0x80)
            k++;
    return k;
}

static int lex_number(parser_t *p)
{
    const char *s = p->s;
    size_t i = p->pos;
    while (is_digit(s[i]))
        i++;
    if (s[i] == '.') {
        i++;
        while (is_digit(s[i]))
            i++;
    }
    if (s[i] == 'e' || s[i] == 'E') {
        size_t j = i + 1;
        if (s[j] == '+' || s[j] == '-')
            j++;
        if (!is_digit(s[j])) {
            ivoct_error_at(p->err, p->line, col_at(p, i),
                           "malformed number: expected the digits of an exponent after '%c'", s[i]);
            return -1;
        }
        while (is_digit(s[j]))
            j++;
        i = j;
    }
    if (s[i] == '.' || is_digit(s[i])) {
        ivoct_error_at(p->err, p->line, col_at(p, i), "malformed number: unexpected '.'");
        return -1;
    }
    if (is_alpha(s[i])) {
        size_t k = i;
        while (is_alnum(s[k]))
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

/* Read the next token into p->tok. */
static int lex(parser_t *p)
{
    const char *s = p->s;
    while (p->pos < p->n && is_space(s[p->pos])) {
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
    if (is_digit(c) || (c == '.' && is_digit(s[p->pos + 1])))
        return lex_number(p);
    if (is_alpha(c)) {
        size_t i = p->pos;
        while (is_alnum(s[i]))
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
    case ',': p->tok.kind = T_COMMA; break;
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

/* ---- parser ---------------------------------------------------------------------- */

/* "end of input" or the token quoted, for "expected ..., found ..." */
static void describe(const parser_t *p, const token_t *t, char *buf, size_t n)
{
    if (t->kind == T_END)
        snprintf(buf, n, "end of input");
    else
        snprintf(buf, n, "'%.*s'", (int)(t->len < QUOTE_MAX ? t->len : QUOTE_MAX), p->s + t->start);
}

/* Report a failed dag_* call: out of memory has no position; an exponent
 * too large is reported at the '^'. */
static int dag_status(parser_t *p, int rc, const token_t *at)
{
    if (rc == DAG_OK)
        return 0;
    if (rc == DAG_EEXPONENT)
        ivoct_error_at(p->err, at->line, at->col,
                       "integer exponent too large: at most %d in absolute value for a variable base",
                       DAG_MAX_POWI);
    else
        ivoct_error_at(p->err, 0, 0, "out of memory while compiling the expression");
    return -1;
}

static int enter(parser_t *p)
{
    if (++p->depth > TAPE_MAX_NESTING) {
        ivoct_error_at(p->err, p->tok.line, p->tok.col, "expression nested deeper than %d levels",
                       TAPE_MAX_NESTING);
        return -1;
    }
    return 0;
}

static int parse_expr(parser_t *p, uint32_t *out);
static int parse_unary(parser_t *p, uint32_t *out);

static int parse_number(parser_t *p, uint32_t *out)
{
    char small[64], *buf = small;
    size_t len = p->tok.len;
    if (len >= sizeof small && !(buf = malloc(len + 1)))
        return dag_status(p, DAG_ENOMEM, &p->tok);
    memcpy(buf, p->s + p->tok.start, len);
    buf[len] = '\0';
    iv_t v;
    int ok = iv_from_decimal(buf, &v);
    if (buf != small)
        free(buf);
    if (!ok) {
        ivoct_error_at(p->err, p->tok.line, p->tok.col, "number out of range");
        return -1;
    }
    if (dag_status(p, dag_const(&p->tc->dag, v, out), &p->tok))
        return -1;
    return lex(p);
}

/* Closing parenthesis of the '(' at open. */
static int expect_close(parser_t *p, const token_t *open)
{
    if (p->tok.kind != T_RPAREN) {
        ivoct_error_at(p->err, p->tok.line, p->tok.col, "expected ')' to close '(' opened at %d:%d",
                       open->line, open->col);
        return -1;
    }
    p->depth--;
    return lex(p);
}

static int parse_call(parser_t *p, int f, uint32_t *out)
{
    const char *fname = FUNCS[f].name;
    int nargs = FUNCS[f].nargs;
    token_t open = p->tok;
    if (enter(p) || lex(p))
        return -1;
    if (p->tok.kind == T_RPAREN) {
        ivoct_error_at(p->err, p->tok.line, p->tok.col, "%s takes %d argument%s", fname, nargs,
                       nargs == 1 ? "" : "s");
        return -1;
    }
    uint32_t a, b = 0;
    if (parse_expr(p, &a))
        return -1;
    if (nargs == 2) {
        if (p->tok.kind == T_RPAREN) {
            ivoct_error_at(p->err, p->tok.line, p->tok.col, "%s takes 2 arguments", fname);
            return -1;
        }
        if (p->tok.kind != T_COMMA) {
            char found[QUOTE_MAX + 8];
            describe(p, &p->tok, found, sizeof found);
            ivoct_error_at(p->err, p->tok.line, p->tok.col,
                           "expected ',' between the arguments of %s, found %s", fname, found);
            return -1;
        }
        if (lex(p) || parse_expr(p, &b))
            return -1;
    }
    if (p->tok.kind == T_COMMA) {
        ivoct_error_at(p->err, p->tok.line, p->tok.col, "%s takes %d argument%s", fname, nargs,
                       nargs == 1 ? "" : "s");
        return -1;
    }
    if (expect_close(p, &open))
        return -1;
    dag_t *d = &p->tc->dag;
    int rc = nargs == 2 ? dag_binary(d, FUNCS[f].op, a, b, out) : dag_unary(d, FUNCS[f].op, a, out);
    return dag_status(p, rc, &open);
}

/* A hint for a name that differs only in case from a known one. */
static void case_hint(const parser_t *p, const char *s, size_t len, int function, char *buf, size_t n)
{
    buf[0] = '\0';
    const char *match = NULL;
    if (function) {
        for (size_t i = 0; i < N_FUNCS && !match; i++)
            if (name_is_nocase(s, len, FUNCS[i].name))
                match = FUNCS[i].name;
    } else {
        for (size_t i = 0; i < N_BUILTINS && !match; i++)
            if (name_is_nocase(s, len, BUILTINS[i]))
                match = BUILTINS[i];
        for (uint32_t i = 0; i < p->tc->n_names && !match; i++)
            if (name_is_nocase(s, len, p->tc->names[i].name))
                match = p->tc->names[i].name;
    }
    if (match)
        snprintf(buf, n, " (names are case-sensitive: did you mean '%.*s'?)", QUOTE_MAX, match);
}

static int parse_name(parser_t *p, uint32_t *out)
{
    token_t nt = p->tok;
    const char *s = p->s + nt.start;
    size_t len = nt.len;
    int qlen = (int)(len < QUOTE_MAX ? len : QUOTE_MAX);
    if (lex(p))
        return -1;
    int call = p->tok.kind == T_LPAREN;
    int f = find_func(s, len);
    if (f >= 0) {
        if (!call) {
            ivoct_error_at(p->err, p->tok.line, p->tok.col, "expected '(' after function '%s'",
                           FUNCS[f].name);
            return -1;
        }
        return parse_call(p, f, out);
    }
    dag_t *d = &p->tc->dag;
    int rc = -1;
    long k;
    if (name_is(s, len, "x"))
        rc = dag_leaf(d, TAPE_X, out);
    else if (name_is(s, len, "y"))
        rc = dag_leaf(d, TAPE_Y, out);
    else if (name_is(s, len, "z"))
        rc = dag_leaf(d, TAPE_Z, out);
    else if (name_is(s, len, "pi"))
        rc = dag_const(d, dag_pi, out);
    else if (name_is(s, len, "e"))
        rc = dag_const(d, dag_e, out);
    else if ((k = find_name(p->tc, s, len)) >= 0) {
        *out = p->tc->names[k].node;
        rc = DAG_OK;
    }
    if (rc < 0) {
        char hint[QUOTE_MAX + 64];
        case_hint(p, s, len, call, hint, sizeof hint);
        ivoct_error_at(p->err, nt.line, nt.col, "unknown %s '%.*s'%s", call ? "function" : "name",
                       qlen, s, hint);
        return -1;
    }
    if (call) {
        ivoct_error_at(p->err, nt.line, nt.col, "'%.*s' is not a function", qlen, s);
        return -1;
    }
    return dag_status(p, rc, &nt);
}

static int parse_primary(parser_t *p, uint32_t *out)
{
    switch (p->tok.kind) {
    case T_NUM: return parse_number(p, out);
    case T_NAME: return parse_name(p, out);
    case T_LPAREN: {
        token_t open = p->tok;
        if (enter(p) || lex(p) || parse_expr(p, out))
            return -1;
        return expect_close(p, &open);
    }
    default: {
        char found[QUOTE_MAX + 8];
        describe(p, &p->tok, found, sizeof found);
        ivoct_error_at(p->err, p->tok.line, p->tok.col, "expected an expression, found %s", found);
        return -1;
    }
    }
}

static int parse_power(parser_t *p, uint32_t *out)
{
    uint32_t base, ex;
    if (parse_primary(p, &base))
        return -1;
    if (p->tok.kind != T_CARET) {
        *out = base;
        return 0;
    }
    token_t op = p->tok;
    if (enter(p) || lex(p) || parse_unary(p, &ex))
        return -1;
    p->depth--;
    return dag_status(p, dag_pow(&p->tc->dag, base, ex, out), &op);
}

static int parse_unary(parser_t *p, uint32_t *out)
{
    if (p->tok.kind != T_MINUS && p->tok.kind != T_PLUS)
        return parse_power(p, out);
    token_t op = p->tok;
    uint32_t a;
    if (enter(p) || lex(p) || parse_unary(p, &a))
        return -1;
    p->depth--;
    if (op.kind == T_PLUS) {
        *out = a;
        return 0;
    }
    return dag_status(p, dag_unary(&p->tc->dag, TAPE_NEG, a, out), &op);
}

static int parse_term(parser_t *p, uint32_t *out)
{
    uint32_t lhs, rhs;
    if (parse_unary(p, &lhs))
        return -1;
    while (p->tok.kind == T_STAR || p->tok.kind == T_SLASH) {
        token_t op = p->tok;
        if (lex(p) || parse_unary(p, &rhs))
            return -1;
        tape_op_t o = op.kind == T_STAR ? TAPE_MUL : TAPE_DIV;
        if (dag_status(p, dag_binary(&p->tc->dag, o, lhs, rhs, &lhs), &op))
            return -1;
    }
    *out = lhs;
    return 0;
}

static int parse_expr(parser_t *p, uint32_t *out)
{
    uint32_t lhs, rhs;
    if (parse_term(p, &lhs))
        return -1;
    while (p->tok.kind == T_PLUS || p->tok.kind == T_MINUS) {
        token_t op = p->tok;
        if (lex(p) || parse_term(p, &rhs))
            return -1;
        tape_op_t o = op.kind == T_PLUS ? TAPE_ADD : TAPE_SUB;
        if (dag_status(p, dag_binary(&p->tc->dag, o, lhs, rhs, &lhs), &op))
            return -1;
    }
    *out = lhs;
    return 0;
}

/* Parse a whole text into a DAG node. */
static int parse_text(tape_compiler_t *tc, const char *text, uint32_t *root, ivoct_error_t *err)
{
    /* measured without reading past the limit + 1 */
    size_t n = 0;
    while (text[n] && n <= TAPE_MAX_TEXT)
        n++;
    if (n > TAPE_MAX_TEXT) {
        ivoct_error_at(err, 1, 1, "expression longer than the limit of %u bytes", TAPE_MAX_TEXT);
        return -1;
    }
    parser_t p;
    memset(&p, 0, sizeof p);
    p.tc = tc;
    p.s = text;
    p.n = n;
    p.line = 1;
    p.err = err;
    if (lex(&p) || parse_expr(&p, root))
        return -1;
    if (p.tok.kind == T_RPAREN) {
        ivoct_error_at(err, p.tok.line, p.tok.col, "unexpected ')'");
        return -1;
    }
    if (p.tok.kind != T_END) {
        ivoct_error_at(err, p.tok.line, p.tok.col, "trailing input after expression");
        return -1;
    }
    return 0;
}

/* ---- the entry points of tape.h ------------------------------------------------- */

int tape_compiler_define(tape_compiler_t *tc, const char *name, const char *text,
                         ivoct_error_t *err)
{
    size_t len = strlen(name);
    int ok = len > 0 && is_alpha((unsigned char)name[0]);
    for (size_t i = 1; ok && i < len; i++)
        ok = is_alnum((unsigned char)name[i]);
    int qlen = (int)(len < QUOTE_MAX ? len : QUOTE_MAX);
    if (!ok) {
        ivoct_error_at(err, 0, 0, "invalid name '%.*s': a name is a letter or '_' followed by letters, digits or '_'",
                       qlen, name);
        return -1;
    }
    for (size_t i = 0; i < N_BUILTINS; i++) {
        if (strcmp(name, BUILTINS[i]) == 0) {
            ivoct_error_at(err, 0, 0, "'%s' is reserved: it is a %s", name,
                           i < 3 ? "variable" : "constant");
            return -1;
        }
    }
    if (find_func(name, len) >= 0) {
        ivoct_error_at(err, 0, 0, "'%s' is reserved: it is a function", name);
        return -1;
    }
    if (find_name(tc, name, len) >= 0) {
        ivoct_error_at(err, 0, 0, "name '%.*s' is already defined", qlen, name);
        return -1;
    }
    uint32_t node;
    if (parse_text(tc, text, &node, err))
        return -1;
    if (tc->n_names == tc->cap_names) {
        uint32_t cap = tc->cap_names ? tc->cap_names * 2 : 16;
        name_def_t *nn = cap > tc->cap_names ? realloc(tc->names, (size_t)cap * sizeof *nn) : NULL;
        if (!nn)
            goto oom;
        tc->names = nn;
        tc->cap_names = cap;
    }
    char *copy = malloc(len + 1);
    if (!copy)
        goto oom;
    memcpy(copy, name, len + 1);
    tc->names[tc->n_names].name = copy;
    tc->names[tc->n_names].node = node;
    if (index_insert(tc, tc->n_names)) {
        free(copy);
        goto oom;
    }
    tc->n_names++;
    return 0;
oom:
    ivoct_error_at(err, 0, 0, "out of memory while defining '%.*s'", qlen, name);
    return -1;
}

int tape_compiler_compile(tape_compiler_t *tc, const char *text, tape_t **out, ivoct_error_t *err)
{
    *out = NULL;
    uint32_t root;
    if (parse_text(tc, text, &root, err))
        return -1;
    if (dag_to_tape(&tc->dag, root, out)) {
        ivoct_error_at(err, 0, 0, "out of memory while compiling the expression");
        return -1;
    }
    return 0;
}

int tape_compile(const char *text, tape_t **out, ivoct_error_t *err)
{
    *out = NULL;
    tape_compiler_t *tc = tape_compiler_new();
    if (!tc) {
        ivoct_error_at(err, 0, 0, "out of memory while compiling the expression");
        return -1;
    }
    int rc = tape_compiler_compile(tc, text, out, err);
    tape_compiler_free(tc);
    return rc;
}
