/* ivoct — scene files: INI read with libinih, checked, f compiled to a tape.
 *
 * How a file is read (docs/scene-format.md has the user's view):
 *  1. The whole file is read into memory and split into lines, so that every
 *     error can name a column, and so that what libinih cannot report well is
 *     caught first: an empty file, NUL bytes, lines longer than TAPE_MAX_TEXT,
 *     unknown [section] headers (libinih does not call the handler for a
 *     section header, so an empty unknown section would pass unseen).
 *  2. libinih parses the lines through ini_parse_stream and our reader, which
 *     counts lines, so the handler knows the physical line of each call.
 *     The handler only stores each key with its value pieces: the text of the
 *     key line and of each continuation line, with the file line and column
 *     where the piece starts.  Key names are taken from our copy of the line,
 *     not from libinih, which truncates names to 49 bytes.
 *  3. The stored values are parsed in file order; then the lets (in file
 *     order) and f are compiled.  A value that spans lines is joined with '\n',
 *     so an error at (line k, column c) of the joined text is at column
 *     piece[k].col + c - 1 of file line piece[k].line.
 * The error reported is the first in the file, except that expressions are
 * compiled only when the file's structure (sections, keys) is sound, and the
 * keys that are missing are reported only when nothing else is wrong. */
#include "scene.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <ini.h>

/* A scene file larger than this is refused before reading it: a real scene
 * is a few kilobytes, and even TAPE_MAX_TEXT-long expressions fit many times. */
#define SCENE_MAX_FILE (64u << 20)

enum { SEC_NONE, SEC_SURFACE, SEC_OCTREE, SEC_CAMERA, SEC_RENDER, SEC_UNKNOWN };
static const char *const SECTION_NAMES[] = {"", "surface", "octree", "camera", "render", ""};

enum { K_NAME, K_F, K_BOX, K_DEPTH, K_TESTS, K_REFINE, K_EYE, K_TARGET, K_UP, K_FOV, K_SIZE, K_METHOD, K_COUNT };
#define K_LET K_COUNT
static const struct {
    int sec;
    const char *key;
} KEYS[K_COUNT] = {
    [K_NAME] = {SEC_SURFACE, "name"},   [K_F] = {SEC_SURFACE, "f"},
    [K_BOX] = {SEC_SURFACE, "box"},     [K_DEPTH] = {SEC_OCTREE, "depth"},
    [K_TESTS] = {SEC_OCTREE, "tests"},  [K_REFINE] = {SEC_OCTREE, "refine"},
    [K_EYE] = {SEC_CAMERA, "eye"},      [K_TARGET] = {SEC_CAMERA, "target"},
    [K_UP] = {SEC_CAMERA, "up"},        [K_FOV] = {SEC_CAMERA, "fov"},
    [K_SIZE] = {SEC_CAMERA, "size"},    [K_METHOD] = {SEC_RENDER, "method"},
};
static const char *const KEYS_EXPECTED[] = {
    "", "name, f, box or let.NAME", "depth, tests or refine", "eye, target, up, fov or size", "method", "",
};

static const char *const METHODS[] = {"mitchell", "newton",       "newton-ah", "mrfro",
                                      "mrfro-newton", "lipschitz", "sampling"};
#define N_METHODS (sizeof METHODS / sizeof METHODS[0])

static const char *const TEST_NAMES[] = {"interval", "lipschitz", "ilie"};
#define N_TESTS (sizeof TEST_NAMES / sizeof TEST_NAMES[0])

#define MAX_SIZE 16384
#define MAX_DEPTH 24

/* inih's isspace() in the C locale, and its inline comment rule. */
static int is_space(int c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f'; }

typedef struct piece {
    char *text;
    int line, col; /* where the piece starts in the file */
} piece_t;

typedef struct entry {
    int kind;  /* K_* */
    char *key; /* as written */
    int line, col;
    piece_t *pieces;
    size_t n_pieces, cap_pieces;
} entry_t;

typedef struct loader {
    const char *path;
    char *buf; /* the file, without a UTF-8 byte order mark, NUL-terminated */
    size_t size;
    size_t *line_off, *line_len; /* line_len without the '\n' */
    int n_lines;
    unsigned char *cont; /* per line: a continuation line by inih's rule */
    unsigned char *sec;  /* per line: the SEC_* in force */
    bool has_surface;
    /* reader */
    size_t rpos, rlimit;
    int rline;
    /* stored keys, in file order */
    entry_t *entries;
    size_t n_entries, cap_entries;
    int seen[K_COUNT]; /* entry index + 1 */
    /* the entry whose value is being parsed, for the hint of fail_at */
    const struct entry *cur;
    /* the first error (smallest line) found so far */
    bool failed;
    ivoct_error_t first;
    bool oom;
} loader_t;

/* ---- errors ------------------------------------------------------------------------ */

/* Keep the error if it comes before the one already found. */
static void fail_at(loader_t *L, int line, int col, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;

static void cont_hint(const loader_t *L, int line, char *buf, size_t n);

static void fail_at(loader_t *L, int line, int col, const char *fmt, ...)
{
    if (L->failed && (L->first.line <= line || line == 0))
        return;
    L->failed = true;
    L->first.line = line;
    L->first.col = col;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(L->first.msg, sizeof L->first.msg, fmt, ap);
    va_end(ap);
    size_t len = strlen(L->first.msg);
    cont_hint(L, line, L->first.msg + len, sizeof L->first.msg - len);
}

static void fail_oom(loader_t *L)
{
    L->oom = true;
}

/* ---- small helpers -------------------------------------------------------------- */

static char *dup_n(const char *s, size_t n)
{
    char *d = malloc(n + 1);
    if (d) {
        memcpy(d, s, n);
        d[n] = '\0';
    }
    return d;
}

static char *dup_s(const char *s) { return dup_n(s, strlen(s)); }

static const char *line_text(const loader_t *L, int line) { return L->buf + L->line_off[line - 1]; }

/* First non-space byte of line at or after index i (0-based), or the length. */
static size_t skip_space(const loader_t *L, int line, size_t i)
{
    const char *t = line_text(L, line);
    size_t n = L->line_len[line - 1];
    while (i < n && is_space((unsigned char)t[i]))
        i++;
    return i;
}

/* inih's find_chars_or_comment: the first of chars, or an inline ';' that
 * follows whitespace, or the end (n). */
static size_t find_chars_or_comment(const char *t, size_t i, size_t n, const char *chars)
{
    int was_space = 0;
    for (; i < n; i++) {
        if (chars && strchr(chars, t[i]))
            break;
        if (was_space && t[i] == ';')
            break;
        was_space = is_space((unsigned char)t[i]);
    }
    return i;
}

/* A key written indented under another key is read as more of that key's
 * value (the INI rule for continuation lines), which makes for puzzling
 * errors: when an error is on such a line and the line looks like a key
 * (it holds '=' or ':', which no value has), say so. */
static void cont_hint(const loader_t *L, int line, char *buf, size_t n)
{
    const entry_t *e = L->cur;
    if (!e || n == 0)
        return;
    for (size_t i = 1; i < e->n_pieces; i++) {
        if (e->pieces[i].line == line && strpbrk(e->pieces[i].text, "=:")) {
            snprintf(buf, n, " (this indented line continues '%s' from line %d; a key must start its line)",
                     e->key, e->line);
            return;
        }
    }
}

/* ---- reading and the first checks ----------------------------------------------- */

static int read_file(loader_t *L, ivoct_error_t *err)
{
    FILE *f = fopen(L->path, "rb");
    if (!f) {
        ivoct_error_at(err, 0, 0, "cannot open file: %s", strerror(errno));
        return -1;
    }
    size_t cap = 1 << 16, n = 0;
    int read_errno = 0;
    char *buf = malloc(cap);
    if (!buf) {
        fclose(f);
        ivoct_error_at(err, 0, 0, "out of memory while reading the scene file");
        return -1;
    }
    for (;;) {
        if (n > SCENE_MAX_FILE) {
            free(buf);
            fclose(f);
            ivoct_error_at(err, 0, 0, "scene file larger than the limit of %u bytes", SCENE_MAX_FILE);
            return -1;
        }
        if (n + 1 >= cap) {
            char *nb = realloc(buf, cap * 2);
            if (!nb) {
                free(buf);
                fclose(f);
                ivoct_error_at(err, 0, 0, "out of memory while reading the scene file");
                return -1;
            }
            buf = nb;
            cap *= 2;
        }
        errno = 0;
        size_t got = fread(buf + n, 1, cap - 1 - n, f);
        read_errno = errno;
        n += got;
        if (got == 0)
            break;
    }
    int bad = ferror(f);
    fclose(f);
    if (bad) {
        free(buf);
        ivoct_error_at(err, 0, 0, "cannot read file: %s", read_errno ? strerror(read_errno) : "I/O error");
        return -1;
    }
    buf[n] = '\0';
    /* libinih would skip a byte order mark too; removing it here keeps the
     * columns of line 1 what an editor shows */
    size_t skip = (n >= 3 && memcmp(buf, "\xEF\xBB\xBF", 3) == 0) ? 3 : 0;
    if (skip)
        memmove(buf, buf + 3, n - 3 + 1);
    L->buf = buf;
    L->size = n - skip;
    return 0;
}

static int split_lines(loader_t *L)
{
    size_t n = 1;
    for (size_t i = 0; i < L->size; i++)
        n += L->buf[i] == '\n';
    if (n > (size_t)1 << 30)
        return -1;
    L->line_off = malloc(n * sizeof *L->line_off);
    L->line_len = malloc(n * sizeof *L->line_len);
    L->cont = calloc(n, 1);
    L->sec = calloc(n, 1);
    if (!L->line_off || !L->line_len || !L->cont || !L->sec)
        return -1;
    size_t start = 0;
    int k = 0;
    for (size_t i = 0; i <= L->size; i++) {
        if (i == L->size || L->buf[i] == '\n') {
            L->line_off[k] = start;
            L->line_len[k] = i - start;
            k++;
            start = i + 1;
        }
    }
    /* a final '\n' ends the last line rather than starting an empty one */
    if (k > 1 && L->line_len[k - 1] == 0 && L->line_off[k - 1] == L->size)
        k--;
    L->n_lines = k;
    return 0;
}

static int section_id(const char *s, size_t n)
{
    for (int i = SEC_SURFACE; i <= SEC_RENDER; i++)
        if (strlen(SECTION_NAMES[i]) == n && memcmp(s, SECTION_NAMES[i], n) == 0)
            return i;
    return SEC_UNKNOWN;
}

/* Classify the lines as libinih will (ini.c: comment, continuation, section,
 * key), note the section of each line, and find the first line that libinih
 * must not see.  Returns that line (n_lines + 1 when all are fine). */
static int prescan(loader_t *L)
{
    int prev_key = 0, sec = SEC_NONE, content = 0;
    for (int ln = 1; ln <= L->n_lines; ln++) {
        const char *t = line_text(L, ln);
        size_t n = L->line_len[ln - 1];
        const char *nul = memchr(t, '\0', n);
        if (nul) {
            fail_at(L, ln, (int)(nul - t) + 1, "NUL byte in the scene file (is it a text file?)");
            return ln;
        }
        /* libinih's buffer holds TAPE_MAX_TEXT bytes plus "\r\n\0" */
        size_t raw = n > 0 && t[n - 1] == '\r' ? n - 1 : n;
        if (raw > TAPE_MAX_TEXT) {
            fail_at(L, ln, 1, "line is %zu bytes long; the limit is %u bytes", raw, TAPE_MAX_TEXT);
            return ln;
        }
        size_t body = n;
        while (body > 0 && is_space((unsigned char)t[body - 1]))
            body--;
        size_t i = skip_space(L, ln, 0);
        L->sec[ln - 1] = (unsigned char)sec;
        if (i >= body || t[i] == ';' || t[i] == '#')
            continue; /* blank or comment */
        content = 1;
        if (prev_key && i > 0) {
            L->cont[ln - 1] = 1;
            continue;
        }
        if (t[i] != '[') {
            prev_key = 1;
            continue;
        }
        prev_key = 0;
        size_t close = find_chars_or_comment(t, i + 1, body, "]");
        if (close >= body || t[close] != ']')
            continue; /* libinih reports the missing ']' at this line */
        size_t a = i + 1, b = close;
        while (a < b && is_space((unsigned char)t[a]))
            a++;
        while (b > a && is_space((unsigned char)t[b - 1]))
            b--;
        sec = section_id(t + a, b - a);
        L->sec[ln - 1] = (unsigned char)sec;
        if (sec == SEC_SURFACE)
            L->has_surface = true;
        if (sec == SEC_UNKNOWN) {
            fail_at(L, ln, (int)i + 1,
                    "unknown section [%.*s]; expected [surface], [octree], [camera] or [render]",
                    (int)(b - a < 64 ? b - a : 64), t + a);
            return ln;
        }
        size_t after = skip_space(L, ln, close + 1);
        if (after < body && t[after] != ';' && t[after] != '#') {
            fail_at(L, ln, (int)after + 1, "unexpected text after the section header [%s]",
                    SECTION_NAMES[sec]);
            return ln;
        }
    }
    if (!content) {
        fail_at(L, 1, 1, "empty scene file, expected a [surface] section");
        return 1;
    }
    return L->n_lines + 1;
}

/* ---- libinih --------------------------------------------------------------------- */

/* fgets for libinih over our buffer, stopping before line rlimit; counts the
 * lines it starts so that the handler knows the current line. */
static char *reader(char *str, int num, void *stream)
{
    loader_t *L = stream;
    if (num < 1 || L->rpos >= L->rlimit)
        return NULL;
    if (L->rpos == 0 || L->buf[L->rpos - 1] == '\n')
        L->rline++;
    size_t k = 0, max = (size_t)num - 1;
    while (k < max && L->rpos < L->rlimit) {
        char c = L->buf[L->rpos++];
        str[k++] = c;
        if (c == '\n')
            break;
    }
    str[k] = '\0';
    return str;
}

static int add_piece(entry_t *e, const char *text, int line, int col)
{
    if (e->n_pieces == e->cap_pieces) {
        size_t cap = e->cap_pieces ? e->cap_pieces * 2 : 2;
        piece_t *p = realloc(e->pieces, cap * sizeof *p);
        if (!p)
            return -1;
        e->pieces = p;
        e->cap_pieces = cap;
    }
    char *copy = dup_s(text);
    if (!copy)
        return -1;
    /* Debian's libinih 55 leaves inline comments on continuation lines
     * (later versions remove them as on key lines): cut them here, by the
     * same rule, so that both kinds of line read alike. */
    size_t n = strlen(copy), cut = find_chars_or_comment(copy, 0, n, NULL);
    while (cut > 0 && is_space((unsigned char)copy[cut - 1]))
        cut--;
    copy[cut] = '\0';
    e->pieces[e->n_pieces].text = copy;
    e->pieces[e->n_pieces].line = line;
    e->pieces[e->n_pieces].col = col;
    e->n_pieces++;
    return 0;
}

static int key_kind(int sec, const char *key, size_t n)
{
    if (sec == SEC_SURFACE && n >= 4 && memcmp(key, "let.", 4) == 0)
        return K_LET;
    for (int k = 0; k < K_COUNT; k++)
        if (KEYS[k].sec == sec && strlen(KEYS[k].key) == n && memcmp(KEYS[k].key, key, n) == 0)
            return k;
    return -1;
}

/* Called by libinih for each key line and each continuation line; section
 * and name are taken from our own copy of the line (see the top). */
static int handler(void *user, const char *section, const char *name, const char *value)
{
    loader_t *L = user;
    (void)section;
    (void)name;
    int ln = L->rline;
    if (ln < 1 || ln > L->n_lines) {
        fail_at(L, ln, 1, "internal error: line count out of step with libinih");
        return 0;
    }
    const char *t = line_text(L, ln);
    size_t n = L->line_len[ln - 1];
    size_t i = skip_space(L, ln, 0);
    if (L->cont[ln - 1]) {
        if (L->n_entries == 0)
            return 1; /* only after a key in an unknown section: already an error */
        if (add_piece(&L->entries[L->n_entries - 1], value, ln, (int)i + 1)) {
            fail_oom(L);
            return 0;
        }
        return 1;
    }
    int sec = L->sec[ln - 1];
    size_t sep = find_chars_or_comment(t, i, n, "=:");
    size_t kend = sep;
    while (kend > i && is_space((unsigned char)t[kend - 1]))
        kend--;
    int qlen = (int)(kend - i < 64 ? kend - i : 64);
    if (sec == SEC_NONE) {
        fail_at(L, ln, (int)i + 1, "key '%.*s' before any section; expected a [surface] section first",
                qlen, t + i);
        return 0;
    }
    int kind = key_kind(sec, t + i, kend - i);
    if (kind < 0) {
        fail_at(L, ln, (int)i + 1, "unknown key '%.*s' in [%s]; expected %s", qlen, t + i,
                SECTION_NAMES[sec], KEYS_EXPECTED[sec]);
        return 0;
    }
    if (kind != K_LET && L->seen[kind]) {
        fail_at(L, ln, (int)i + 1, "duplicate key '%s' (first given at line %d)", KEYS[kind].key,
                L->entries[L->seen[kind] - 1].line);
        return 0;
    }
    if (L->n_entries == L->cap_entries) {
        size_t cap = L->cap_entries ? L->cap_entries * 2 : 16;
        entry_t *e = realloc(L->entries, cap * sizeof *e);
        if (!e) {
            fail_oom(L);
            return 0;
        }
        L->entries = e;
        L->cap_entries = cap;
    }
    entry_t *e = &L->entries[L->n_entries];
    memset(e, 0, sizeof *e);
    e->kind = kind;
    e->line = ln;
    e->col = (int)i + 1;
    e->key = dup_n(t + i, kend - i);
    L->n_entries++;
    size_t vcol = skip_space(L, ln, sep + 1);
    if (!e->key || add_piece(e, value, ln, (int)vcol + 1)) {
        fail_oom(L);
        return 0;
    }
    if (kind != K_LET)
        L->seen[kind] = (int)L->n_entries;
    return 1;
}

/* The runtime settings of Debian's libinih are process globals:
 *  - ini_use_stack = false: the stack buffer has the compiled-in size of 200
 *    bytes, and a longer line would be split into pieces parsed as lines;
 *  - ini_allow_realloc with ini_max_line = TAPE_MAX_TEXT + 3 (the '\r', '\n'
 *    and '\0' inih counts): a heap buffer that grows to the longest line we
 *    accept (longer ones are refused before libinih sees them);
 *  - ini_stop_on_first_error: report the first error, and never call the
 *    handler on lines after it;
 *  - ini_allow_multiline: indented lines continue the previous value (f and
 *    let.* that span lines); inline ';' comments and ';' / '#' line comments.
 * Set on every load, since another part of the process could change them;
 * so scene_load must not run in two threads at once. */
static int run_inih(loader_t *L, int stop_line)
{
    static char start_prefixes[] = ";#";
    static char inline_prefixes[] = ";";
    ini_use_stack = false;
    ini_allow_realloc = true;
    ini_max_line = (int)TAPE_MAX_TEXT + 3;
    ini_stop_on_first_error = true;
    ini_allow_multiline = true;
    ini_allow_inline_comments = true;
    ini_allow_bom = true;
    ini_allow_no_value = false;
    ini_start_comment_prefixes = start_prefixes;
    ini_inline_comment_prefixes = inline_prefixes;
    L->rpos = 0;
    L->rline = 0;
    L->rlimit = stop_line <= L->n_lines ? L->line_off[stop_line - 1] : L->size;
    return ini_parse_stream(reader, L, handler, L);
}

/* ---- values -------------------------------------------------------------------------- */

/* The pieces of a value joined with sep ('\n' keeps the line structure that
 * errors are mapped back through). */
static char *join(const entry_t *e, char sep)
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

/* (line, col) inside the joined value -> file position. */
static void map_pos(const entry_t *e, int line, int col, int *fl, int *fc)
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
        while (s[v->pos] && (is_space((unsigned char)s[v->pos]) || s[v->pos] == ','))
            v->pos++;
        if (!s[v->pos]) {
            v->piece++;
            v->pos = 0;
            continue;
        }
        size_t a = v->pos;
        while (s[v->pos] && !is_space((unsigned char)s[v->pos]) && s[v->pos] != ',')
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
        fail_at(L, line, col, "%s: NaN is not allowed", what);
        return -1;
    }
    if (word_nocase(u, m, "inf") || word_nocase(u, m, "infinity")) {
        fail_at(L, line, col, "%s: infinite values are not allowed, found '%.*s'", what, q, t);
        return -1;
    }
    if (!decimal_syntax(t, n)) {
        fail_at(L, line, col, "%s: expected a number, found '%.*s'", what, q, t);
        return -1;
    }
    char small[64], *buf = n < sizeof small ? small : malloc(n + 1);
    if (!buf) {
        fail_oom(L);
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
        fail_at(L, line, col, "%s: number out of range", what);
        return -1;
    }
    *out = round < 0 ? v.lo : round > 0 ? v.hi : d;
    return 0;
}

/* Exactly count numbers.  round[i] as in parse_number (NULL: all 0); pos (may
 * be NULL) receives the file position of each. */
static int parse_numbers(loader_t *L, const entry_t *e, const char *what, const char *expected,
                         int count, const int *round, double *out, int (*pos)[2])
{
    vscan_t v = {e, 0, 0};
    const char *t;
    size_t n;
    int line, col, k = 0;
    while (next_token(&v, &t, &n, &line, &col)) {
        if (k == count) {
            fail_at(L, line, col, "%s takes %d number%s (%s), found more", what, count,
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
        fail_at(L, line, col, "%s takes %d number%s (%s), found %d", what, count, count == 1 ? "" : "s",
                expected, k);
        return -1;
    }
    return 0;
}

/* Exactly count integers in [lo, hi]. */
static int parse_ints(loader_t *L, const entry_t *e, const char *what, const char *expected, int count,
                      long lo, long hi, int *out)
{
    vscan_t v = {e, 0, 0};
    const char *t;
    size_t n;
    int line, col, k = 0;
    while (next_token(&v, &t, &n, &line, &col)) {
        int q = (int)(n < 40 ? n : 40);
        if (k == count) {
            fail_at(L, line, col, "%s takes %d integer%s (%s), found more", what, count,
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
            fail_at(L, line, col, "%s: expected an integer from %ld to %ld, found '%.*s'", what, lo, hi, q, t);
            return -1;
        }
        out[k++] = (int)val;
    }
    if (k < count) {
        end_pos(e, &line, &col);
        fail_at(L, line, col, "%s takes %d integer%s (%s), found %d", what, count, count == 1 ? "" : "s",
                expected, k);
        return -1;
    }
    return 0;
}

/* ---- scene_parse_tests ----------------------------------------------------------- */

int scene_parse_tests(const char *text, unsigned *tests, ivoct_error_t *err)
{
    unsigned mask = 0;
    int line = 1;
    size_t ls = 0, i = 0;
    for (;;) {
        while (is_space((unsigned char)text[i])) {
            if (text[i] == '\n') {
                line++;
                ls = i + 1;
            }
            i++;
        }
        size_t a = i;
        while (text[i] && text[i] != ',' && !is_space((unsigned char)text[i]))
            i++;
        if (i == a) {
            ivoct_error_at(err, line, (int)(a - ls) + 1,
                           "expected a test name: interval, lipschitz or ilie");
            return -1;
        }
        size_t k = 0;
        while (k < N_TESTS && !(strlen(TEST_NAMES[k]) == i - a && memcmp(TEST_NAMES[k], text + a, i - a) == 0))
            k++;
        if (k == N_TESTS) {
            ivoct_error_at(err, line, (int)(a - ls) + 1,
                           "unknown test '%.*s'; expected interval, lipschitz or ilie",
                           (int)(i - a < 40 ? i - a : 40), text + a);
            return -1;
        }
        mask |= 1u << k;
        while (is_space((unsigned char)text[i])) {
            if (text[i] == '\n') {
                line++;
                ls = i + 1;
            }
            i++;
        }
        if (!text[i])
            break;
        if (text[i] != ',') {
            ivoct_error_at(err, line, (int)(i - ls) + 1, "expected ',' between test names");
            return -1;
        }
        i++;
    }
    *tests = mask;
    return 0;
}

char *scene_tests_string(unsigned tests, char *buf, unsigned long n)
{
    if (!buf || n == 0)
        return buf;
    buf[0] = '\0';
    size_t len = 0;
    for (size_t k = 0; k < N_TESTS; k++) {
        if (!(tests & (1u << k)))
            continue;
        int w = snprintf(buf + len, n - len, "%s%s", len ? ", " : "", TEST_NAMES[k]);
        if (w < 0 || (size_t)w >= n - len)
            break;
        len += (size_t)w;
    }
    return buf;
}

/* ---- defaults and checks shared with scene_from_expr ------------------------------ */

static void set_defaults(scene_t *s)
{
    s->depth = 8;
    s->tests = SCENE_TEST_INTERVAL | SCENE_TEST_LIPSCHITZ;
    s->refine = 0;
    s->up[0] = 0;
    s->up[1] = 0;
    s->up[2] = 1;
    s->fov = 30;
    s->width = 300;
    s->height = 300;
    snprintf(s->method, sizeof s->method, "newton-ah");
}

/* "box: xmin 2 > xmax 1"; 0 when fine, else the index of the bad minimum. */
static int check_box(const double b[6], char *msg, size_t n)
{
    static const char axis[] = "xyz";
    for (int i = 0; i < 6; i++) {
        if (!isfinite(b[i])) {
            snprintf(msg, n, "box: the bounds must be finite numbers");
            return i + 1;
        }
    }
    for (int i = 0; i < 3; i++) {
        if (b[2 * i] > b[2 * i + 1]) {
            snprintf(msg, n, "box: %cmin %.17g > %cmax %.17g", axis[i], b[2 * i], axis[i], b[2 * i + 1]);
            return 2 * i + 1;
        }
    }
    return 0;
}

/* Camera defaults that frame the box: looking at its centre from the
 * direction (1, 0.8, 0.6), far enough that the circumscribed sphere fits the
 * vertical field of view with a 10% margin. */
static void frame_box(scene_t *s, bool have_eye, bool have_target)
{
    const double *b = s->box;
    if (!have_target)
        for (int i = 0; i < 3; i++)
            s->target[i] = 0.5 * b[2 * i] + 0.5 * b[2 * i + 1];
    if (have_eye)
        return;
    double dx = b[1] - b[0], dy = b[3] - b[2], dz = b[5] - b[4];
    double diag = sqrt(dx * dx + dy * dy + dz * dz);
    if (!(diag > 0) || !isfinite(diag))
        diag = isfinite(diag) ? 1 : DBL_MAX / 4;
    double dist = 1.1 * 0.5 * diag / sin(s->fov * (3.14159265358979323846 / 360));
    double dir[3] = {1, 0.8, 0.6}, len = sqrt(1 + 0.64 + 0.36);
    for (int i = 0; i < 3; i++)
        s->eye[i] = s->target[i] + dist * dir[i] / len;
}

/* NULL when the camera is usable, else what is wrong. */
static const char *check_camera(const scene_t *s, bool *blame_up)
{
    double d[3], c[3];
    for (int i = 0; i < 3; i++)
        d[i] = s->target[i] - s->eye[i];
    *blame_up = false;
    double dl = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (!(dl > 0) || !isfinite(dl))
        return "camera: eye and target must be distinct finite points";
    const double *u = s->up;
    double ul = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    *blame_up = true;
    if (!(ul > 0) || !isfinite(ul))
        return "camera: up must be a non-zero vector";
    c[0] = d[1] * u[2] - d[2] * u[1];
    c[1] = d[2] * u[0] - d[0] * u[2];
    c[2] = d[0] * u[1] - d[1] * u[0];
    if (sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]) <= 1e-9 * dl * ul)
        return "camera: up is parallel to the view direction (target - eye)";
    return NULL;
}

/* ---- scene_load ------------------------------------------------------------------- */

static void loader_free(loader_t *L)
{
    for (size_t i = 0; i < L->n_entries; i++) {
        for (size_t k = 0; k < L->entries[i].n_pieces; k++)
            free(L->entries[i].pieces[k].text);
        free(L->entries[i].pieces);
        free(L->entries[i].key);
    }
    free(L->entries);
    free(L->buf);
    free(L->line_off);
    free(L->line_len);
    free(L->cont);
    free(L->sec);
}

static const entry_t *entry_of(const loader_t *L, int kind)
{
    return L->seen[kind] ? &L->entries[L->seen[kind] - 1] : NULL;
}

/* Parse the stored values into s (not f and the lets). */
static void parse_values(loader_t *L, scene_t *s)
{
    const entry_t *e;
    static const int box_round[6] = {-1, 1, -1, 1, -1, 1};
    if ((e = L->cur = entry_of(L, K_NAME))) {
        free(s->name);
        s->name = join(e, ' ');
        if (s->name) { /* an empty first piece ("name =" then an indented line) */
            size_t k = 0;
            while (s->name[k] == ' ')
                k++;
            memmove(s->name, s->name + k, strlen(s->name + k) + 1);
        }
        if (!s->name)
            fail_oom(L);
        else if (!s->name[0])
            fail_at(L, e->pieces[0].line, e->pieces[0].col, "name: expected a name");
    }
    if ((e = L->cur = entry_of(L, K_BOX))) {
        int pos[6][2];
        if (!parse_numbers(L, e, "box", "xmin xmax ymin ymax zmin zmax", 6, box_round, s->box, pos)) {
            char msg[256];
            int bad = check_box(s->box, msg, sizeof msg);
            if (bad)
                fail_at(L, pos[bad - 1][0], pos[bad - 1][1], "%s", msg);
        }
    }
    if ((e = L->cur = entry_of(L, K_DEPTH)))
        parse_ints(L, e, "depth", "the maximum octree depth", 1, 0, MAX_DEPTH, &s->depth);
    if ((e = L->cur = entry_of(L, K_TESTS))) {
        char *text = join(e, '\n');
        ivoct_error_t te;
        ivoct_error_clear(&te);
        if (!text)
            fail_oom(L);
        else if (scene_parse_tests(text, &s->tests, &te)) {
            int fl, fc;
            map_pos(e, te.line, te.col, &fl, &fc);
            fail_at(L, fl, fc, "tests: %s", te.msg);
        }
        free(text);
    }
    if ((e = L->cur = entry_of(L, K_REFINE))) {
        int pos[1][2];
        if (!parse_numbers(L, e, "refine", "a length, 0 = off", 1, NULL, &s->refine, pos) && s->refine < 0)
            fail_at(L, pos[0][0], pos[0][1], "refine: expected a length >= 0 (0 = off)");
    }
    if ((e = L->cur = entry_of(L, K_EYE)))
        parse_numbers(L, e, "eye", "x y z", 3, NULL, s->eye, NULL);
    if ((e = L->cur = entry_of(L, K_TARGET)))
        parse_numbers(L, e, "target", "x y z", 3, NULL, s->target, NULL);
    if ((e = L->cur = entry_of(L, K_UP)))
        parse_numbers(L, e, "up", "x y z", 3, NULL, s->up, NULL);
    if ((e = L->cur = entry_of(L, K_FOV))) {
        int pos[1][2];
        if (!parse_numbers(L, e, "fov", "degrees", 1, NULL, &s->fov, pos) && !(s->fov > 0 && s->fov < 180))
            fail_at(L, pos[0][0], pos[0][1], "fov: expected an angle in degrees between 0 and 180 (exclusive)");
    }
    if ((e = L->cur = entry_of(L, K_SIZE))) {
        int wh[2];
        if (!parse_ints(L, e, "size", "width height in pixels", 2, 1, MAX_SIZE, wh)) {
            s->width = wh[0];
            s->height = wh[1];
        }
    }
    if ((e = L->cur = entry_of(L, K_METHOD))) {
        vscan_t v = {e, 0, 0};
        const char *t;
        size_t n;
        int line, col;
        if (!next_token(&v, &t, &n, &line, &col)) {
            end_pos(e, &line, &col);
            fail_at(L, line, col, "method: expected a method name");
        } else {
            size_t k = 0;
            while (k < N_METHODS && !(strlen(METHODS[k]) == n && memcmp(METHODS[k], t, n) == 0))
                k++;
            if (k == N_METHODS)
                fail_at(L, line, col,
                        "unknown method '%.*s'; expected mitchell, newton, newton-ah, mrfro, "
                        "mrfro-newton, lipschitz or sampling",
                        (int)(n < 40 ? n : 40), t);
            else
                snprintf(s->method, sizeof s->method, "%s", METHODS[k]);
            if (next_token(&v, &t, &n, &line, &col))
                fail_at(L, line, col, "method: expected one method name, found more");
        }
    }
    L->cur = NULL;
}

/* An expression error of entry e, moved from text to file positions: the
 * error's own position, and the one a message may quote ("... opened at
 * L:C", written by expr/parse.c in text positions too). */
static void fail_expr(loader_t *L, const entry_t *e, const ivoct_error_t *ce)
{
    int fl, fc;
    map_pos(e, ce->line, ce->col, &fl, &fc);
    char msg[sizeof ce->msg + 32];
    snprintf(msg, sizeof msg, "%s", ce->msg);
    const char *at = strstr(ce->msg, " opened at ");
    int ql, qc, used = 0;
    if (at && sscanf(at, " opened at %d:%d%n", &ql, &qc, &used) == 2 && used > 0) {
        int ml, mc;
        map_pos(e, ql, qc, &ml, &mc);
        snprintf(msg, sizeof msg, "%.*s opened at %d:%d%s", (int)(at - ce->msg), ce->msg, ml, mc,
                 at + used);
    }
    L->cur = e;
    fail_at(L, fl, fc, "%s", msg);
    L->cur = NULL;
}

/* Compile the lets (file order) and f. */
static int compile(loader_t *L, scene_t *s)
{
    tape_compiler_t *tc = tape_compiler_new();
    if (!tc) {
        fail_oom(L);
        return -1;
    }
    size_t n_lets = 0;
    for (size_t i = 0; i < L->n_entries; i++)
        n_lets += L->entries[i].kind == K_LET;
    if (n_lets) {
        s->let_names = calloc(n_lets, sizeof *s->let_names);
        s->let_texts = calloc(n_lets, sizeof *s->let_texts);
        if (!s->let_names || !s->let_texts) {
            fail_oom(L);
            tape_compiler_free(tc);
            return -1;
        }
    }
    ivoct_error_t ce;
    ivoct_error_clear(&ce);
    int rc = 0;
    for (size_t i = 0; i < L->n_entries && !rc; i++) {
        const entry_t *e = &L->entries[i];
        if (e->kind != K_LET)
            continue;
        char *name = dup_s(e->key + 4), *text = join(e, '\n');
        s->let_names[s->n_lets] = name;
        s->let_texts[s->n_lets] = text;
        s->n_lets++;
        if (!name || !text) {
            fail_oom(L);
            rc = -1;
        } else if (tape_compiler_define(tc, name, text, &ce)) {
            if (ce.line > 0)
                fail_expr(L, e, &ce);
            else /* name errors have no position in the text: point at the name */
                fail_at(L, e->line, e->col + 4, "%s", ce.msg);
            rc = -1;
        }
    }
    const entry_t *f = entry_of(L, K_F);
    if (!rc) {
        s->f_text = join(f, '\n');
        if (!s->f_text) {
            fail_oom(L);
            rc = -1;
        } else if (tape_compiler_compile(tc, s->f_text, &s->tape, &ce)) {
            fail_expr(L, f, &ce);
            rc = -1;
        }
    }
    tape_compiler_free(tc);
    return rc;
}

static char *base_name(const char *path)
{
    const char *b = strrchr(path, '/');
    b = b ? b + 1 : path;
    size_t n = strlen(b);
    if (n > 4 && strcmp(b + n - 4, ".ini") == 0)
        n -= 4;
    return dup_n(b, n);
}

static void set_file(ivoct_error_t *err, const char *path)
{
    if (err)
        snprintf(err->file, sizeof err->file, "%s", path);
}

int scene_load(const char *path, scene_t *s, ivoct_error_t *err)
{
    memset(s, 0, sizeof *s);
    ivoct_error_clear(err);
    set_file(err, path);
    loader_t L;
    memset(&L, 0, sizeof L);
    L.path = path;
    if (read_file(&L, err))
        return -1;
    if (split_lines(&L)) {
        loader_free(&L);
        ivoct_error_at(err, 0, 0, "out of memory while reading the scene file");
        return -1;
    }
    set_defaults(s);
    int stop = prescan(&L);
    int rc = run_inih(&L, stop);
    if (rc == -2 || L.oom) {
        L.oom = true;
    } else if (rc > 0) {
        /* a handler error is already recorded at line rc; otherwise libinih
         * found a line it cannot read */
        const char *t = line_text(&L, rc);
        size_t i = skip_space(&L, rc, 0);
        if (t[i] == '[')
            fail_at(&L, rc, 1, "expected ']' to close the section name");
        else
            fail_at(&L, rc, 1, "expected 'key = value' (no '=' or ':' found)");
    }
    bool have_eye = L.seen[K_EYE], have_target = L.seen[K_TARGET];
    /* The keys stored all come before any error of the file's structure, so
     * their values are complete and checked in any case; fail_at keeps the
     * error that comes first in the file. */
    bool structure_ok = !L.failed;
    if (!L.oom)
        parse_values(&L, s);
    if (!L.oom && !L.failed) {
        if (!L.has_surface)
            fail_at(&L, 1, 1, "missing [surface] section");
        else if (!L.seen[K_F])
            fail_at(&L, 1, 1, "missing [surface] f");
    }
    /* Expressions only in a sound file: after a structural error a name
     * may be defined in the part that was not read.  Compiled before the box
     * is required, as an indented "box = ..." line is read as more of f,
     * and the compiler's error then explains that. */
    if (!L.oom && structure_ok && L.seen[K_F])
        compile(&L, s);
    if (!L.oom && !L.failed && !L.seen[K_BOX])
        fail_at(&L, 1, 1, "missing [surface] box");
    if (!L.oom && !L.failed) {
        frame_box(s, have_eye, have_target);
        bool blame_up;
        const char *msg = check_camera(s, &blame_up);
        if (msg) {
            /* the key the user wrote that takes part in the problem */
            const entry_t *e = blame_up ? entry_of(&L, K_UP) : NULL;
            if (!e)
                e = have_eye ? entry_of(&L, K_EYE) : entry_of(&L, K_TARGET);
            if (e)
                fail_at(&L, e->pieces[0].line, e->pieces[0].col, "%s", msg);
            else
                fail_at(&L, 1, 1, "%s", msg);
        }
    }
    if (!L.oom && !L.failed && !s->name)
        s->name = base_name(path);
    if (!L.oom && !L.failed && !(s->path = dup_s(path)))
        L.oom = true;
    if (!L.oom && !L.failed && !s->name)
        L.oom = true;
    if (L.oom || L.failed) {
        if (L.oom)
            ivoct_error_at(err, 0, 0, "out of memory while loading the scene");
        else
            ivoct_error_at(err, L.first.line, L.first.col, "%s", L.first.msg);
        loader_free(&L);
        scene_free(s);
        return -1;
    }
    loader_free(&L);
    return 0;
}

int scene_from_expr(const char *expr, const double box[6], scene_t *s, ivoct_error_t *err)
{
    memset(s, 0, sizeof *s);
    ivoct_error_clear(err);
    set_defaults(s);
    memcpy(s->box, box, sizeof s->box);
    char msg[256];
    if (check_box(s->box, msg, sizeof msg)) {
        ivoct_error_at(err, 0, 0, "%s", msg);
        memset(s, 0, sizeof *s);
        return -1;
    }
    if (tape_compile(expr, &s->tape, err)) {
        memset(s, 0, sizeof *s);
        return -1;
    }
    s->f_text = dup_s(expr);
    s->name = dup_s(expr);
    if (!s->f_text || !s->name) {
        scene_free(s);
        ivoct_error_at(err, 0, 0, "out of memory");
        return -1;
    }
    frame_box(s, false, false);
    return 0;
}

void scene_free(scene_t *s)
{
    if (!s)
        return;
    free(s->path);
    free(s->name);
    for (size_t i = 0; i < s->n_lets; i++) {
        free(s->let_names ? s->let_names[i] : NULL);
        free(s->let_texts ? s->let_texts[i] : NULL);
    }
    free(s->let_names);
    free(s->let_texts);
    free(s->f_text);
    tape_free(s->tape);
    memset(s, 0, sizeof *s);
}
