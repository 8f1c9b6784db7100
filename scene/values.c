/* ivoct — scene files: the values of the stored keys.
 *
 * A value is the pieces of its entry (the key line and its continuation
 * lines), each with its file position, so every error names the file line and
 * column of what is wrong.  Lists are tokens separated by blanks (including
 * the line breaks between pieces) and commas.  Numbers are read with
 * iv_from_decimal (exact, independent of the locale).  Test lists are the
 * octree's (oct_tests_parse), method names the renderer's (ray_method_parse). */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scene_internal.h"

char *scene_val_join(const entry_t *e, char sep)
{
    size_t n = 0;
    for (size_t i = 0; i < e->n_pieces; i++)
        n += strlen(e->pieces[i].text) + 1;
    char *s = malloc(n + 1);
    if (!s)
        return NULL;
    size_t k = 0;
    for (size_t i = 0; i < e->n_pieces; i++) {
        if (i)
            s[k++] = sep;
        size_t m = strlen(e->pieces[i].text);
        memcpy(s + k, e->pieces[i].text, m);
        k += m;
    }
    s[k] = '\0';
    return s;
}

void scene_val_map_pos(const entry_t *e, int line, int col, int *fl, int *fc)
{
    if (line < 1 || (size_t)line > e->n_pieces || col < 1) {
        *fl = e->line;
        *fc = e->col;
        return;
    }
    *fl = e->pieces[line - 1].line;
    *fc = e->pieces[line - 1].col + col - 1;
}

/* Tokens of a list value: separated by whitespace (including the '\n' between
 * pieces) and commas. */
typedef struct vscan {
    const entry_t *e;
    size_t piece, pos;
} vscan_t;

static int next_token(vscan_t *v, const char **tok, size_t *len, int *line, int *col)
{
    while (v->piece < v->e->n_pieces) {
        const char *s = v->e->pieces[v->piece].text;
        while (s[v->pos] && (scene_is_space((unsigned char)s[v->pos]) || s[v->pos] == ','))
            v->pos++;
        if (!s[v->pos]) {
            v->piece++;
            v->pos = 0;
            continue;
        }
        size_t a = v->pos;
        while (s[v->pos] && !scene_is_space((unsigned char)s[v->pos]) && s[v->pos] != ',')
            v->pos++;
        *tok = s + a;
        *len = v->pos - a;
        *line = v->e->pieces[v->piece].line;
        *col = v->e->pieces[v->piece].col + (int)a;
        return 1;
    }
    return 0;
}

/* Position just after the value, for "found only N" errors. */
static void end_pos(const entry_t *e, int *line, int *col)
{
    const piece_t *p = &e->pieces[e->n_pieces - 1];
    *line = p->line;
    *col = p->col + (int)strlen(p->text);
}

static int lower(int c) { return c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c; }

static int word_nocase(const char *t, size_t n, const char *w)
{
    if (strlen(w) != n)
        return 0;
    for (size_t i = 0; i < n; i++)
        if (lower((unsigned char)t[i]) != w[i])
            return 0;
    return 1;
}

static int decimal_syntax(const char *t, size_t n)
{
    size_t i = 0, digits = 0;
    if (i < n && (t[i] == '+' || t[i] == '-'))
        i++;
    for (; i < n && t[i] >= '0' && t[i] <= '9'; i++)
        digits++;
    if (i < n && t[i] == '.')
        for (i++; i < n && t[i] >= '0' && t[i] <= '9'; i++)
            digits++;
    if (!digits)
        return 0;
    if (i < n && (t[i] == 'e' || t[i] == 'E')) {
        i++;
        if (i < n && (t[i] == '+' || t[i] == '-'))
            i++;
        size_t e = 0;
        for (; i < n && t[i] >= '0' && t[i] <= '9'; i++)
            e++;
        if (!e)
            return 0;
    }
    return i == n;
}

/* One number token.  round: -1 for a lower bound (the enclosure's lo), +1 for
 * an upper bound (hi), 0 otherwise (the double nearest the decimal). */
static int parse_number(loader_t *L, const char *what, const char *t, size_t n, int line, int col,
                        int round, double *out)
{
    const char *u = t;
    size_t m = n;
    if (m && (*u == '+' || *u == '-')) {
        u++;
        m--;
    }
    int q = (int)(n < 40 ? n : 40);
    if (word_nocase(u, m, "nan")) {
        scene_fail_at(L, line, col, "%s: NaN is not allowed", what);
        return -1;
    }
    if (word_nocase(u, m, "inf") || word_nocase(u, m, "infinity")) {
        scene_fail_at(L, line, col, "%s: infinite values are not allowed, found '%.*s'", what, q, t);
        return -1;
    }
    if (!decimal_syntax(t, n)) {
        scene_fail_at(L, line, col, "%s: expected a number, found '%.*s'", what, q, t);
        return -1;
    }
    char small[64], *buf = n < sizeof small ? small : malloc(n + 1);
    if (!buf) {
        scene_fail_oom(L);
        return -1;
    }
    memcpy(buf, t, n);
    buf[n] = '\0';
    iv_t v;
    bool ok = iv_from_decimal(buf, &v);
    /* iv_from_decimal parses without the locale; strtod only picks the
     * nearer of the two doubles around a decimal that is not one */
    char *end;
    double d = ok ? strtod(buf, &end) : 0;
    if (!ok || end != buf + n || !(d == v.lo || d == v.hi))
        d = v.lo;
    if (buf != small)
        free(buf);
    if (!ok || !isfinite(v.lo) || !isfinite(v.hi)) {
        scene_fail_at(L, line, col, "%s: number out of range", what);
        return -1;
    }
    *out = round < 0 ? v.lo : round > 0 ? v.hi : d;
    return 0;
}

int scene_val_numbers(loader_t *L, const entry_t *e, const char *what, const char *expected,
                      int count, const int *round, double *out, int (*pos)[2])
{
    vscan_t v = {e, 0, 0};
    const char *t;
    size_t n;
    int line, col, k = 0;
    while (next_token(&v, &t, &n, &line, &col)) {
        if (k == count) {
            scene_fail_at(L, line, col, "%s takes %d number%s (%s), found more", what, count,
                    count == 1 ? "" : "s", expected);
            return -1;
        }
        if (parse_number(L, what, t, n, line, col, round ? round[k] : 0, &out[k]))
            return -1;
        if (pos) {
            pos[k][0] = line;
            pos[k][1] = col;
        }
        k++;
    }
    if (k < count) {
        end_pos(e, &line, &col);
        scene_fail_at(L, line, col, "%s takes %d number%s (%s), found %d", what, count, count == 1 ? "" : "s",
                expected, k);
        return -1;
    }
    return 0;
}

int scene_val_ints(loader_t *L, const entry_t *e, const char *what, const char *expected,
                   int count, long lo, long hi, int *out)
{
    vscan_t v = {e, 0, 0};
    const char *t;
    size_t n;
    int line, col, k = 0;
    while (next_token(&v, &t, &n, &line, &col)) {
        int q = (int)(n < 40 ? n : 40);
        if (k == count) {
            scene_fail_at(L, line, col, "%s takes %d integer%s (%s), found more", what, count,
                    count == 1 ? "" : "s", expected);
            return -1;
        }
        size_t i = (n && (t[0] == '+' || t[0] == '-')) ? 1 : 0;
        long val = 0;
        int ok = i < n;
        for (; ok && i < n; i++) {
            ok = t[i] >= '0' && t[i] <= '9';
            if (ok && val <= hi)
                val = val * 10 + (t[i] - '0');
        }
        if (ok && t[0] == '-')
            val = -val;
        if (!ok || val < lo || val > hi) {
            scene_fail_at(L, line, col, "%s: expected an integer from %ld to %ld, found '%.*s'", what, lo, hi, q, t);
            return -1;
        }
        out[k++] = (int)val;
    }
    if (k < count) {
        end_pos(e, &line, &col);
        scene_fail_at(L, line, col, "%s takes %d integer%s (%s), found %d", what, count, count == 1 ? "" : "s",
                expected, k);
        return -1;
    }
    return 0;
}


int scene_val_text(loader_t *L, const entry_t *e, const char *what, char **out)
{
    char *s = scene_val_join(e, ' ');
    *out = NULL;
    if (!s) {
        scene_fail_oom(L);
        return -1;
    }
    /* an empty first piece ("name =" then an indented line) */
    size_t k = 0;
    while (s[k] == ' ')
        k++;
    memmove(s, s + k, strlen(s + k) + 1);
    if (!s[0]) {
        free(s);
        scene_fail_at(L, e->pieces[0].line, e->pieces[0].col, "%s: expected a name", what);
        return -1;
    }
    *out = s;
    return 0;
}

int scene_val_tests(loader_t *L, const entry_t *e, unsigned *tests)
{
    char *text = scene_val_join(e, '\n');
    if (!text) {
        scene_fail_oom(L);
        return -1;
    }
    ivoct_error_t te;
    ivoct_error_clear(&te);
    int rc = oct_tests_parse(text, tests, &te);
    if (rc) {
        int fl, fc;
        scene_val_map_pos(e, te.line, te.col, &fl, &fc);
        scene_fail_at(L, fl, fc, "tests: %s", te.msg);
    }
    free(text);
    return rc;
}

int scene_val_method(loader_t *L, const entry_t *e, ray_method_t *m)
{
    vscan_t v = {e, 0, 0};
    const char *t;
    size_t n;
    int line, col;
    if (!next_token(&v, &t, &n, &line, &col)) {
        end_pos(e, &line, &col);
        scene_fail_at(L, line, col, "method: expected a method name");
        return -1;
    }
    char name[64], list[256];
    int rc = -1;
    if (n < sizeof name) {
        memcpy(name, t, n);
        name[n] = '\0';
        rc = ray_method_parse(name, m) ? -1 : 0;
    }
    if (rc)
        scene_fail_at(L, line, col, "unknown method '%.*s'; expected %s", (int)(n < 40 ? n : 40), t,
                      ray_method_list(list, sizeof list));
    if (next_token(&v, &t, &n, &line, &col)) {
        scene_fail_at(L, line, col, "method: expected one method name, found more");
        rc = -1;
    }
    return rc;
}
