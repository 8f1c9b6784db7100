/* ivoct — scene files: the INI adaptor (libinih).
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
 * The values are parsed afterwards (values.c, scene.c).  Which sections and
 * keys there are is scene.c's (scene_section_id, scene_key_kind). */
#include <errno.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <ini.h>

#include "scene_internal.h"

/* A scene file larger than this is refused before reading it: a real scene
 * is a few kilobytes, and even TAPE_MAX_TEXT-long expressions fit many times. */
#define SCENE_MAX_FILE (64u << 20)

/* ---- errors ------------------------------------------------------------------------ */

static void cont_hint(const loader_t *L, int line, char *buf, size_t n);

void scene_fail_at(loader_t *L, int line, int col, const char *fmt, ...)
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

void scene_fail_oom(loader_t *L)
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
    while (i < n && scene_is_space((unsigned char)t[i]))
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
        was_space = scene_is_space((unsigned char)t[i]);
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
            scene_fail_at(L, ln, (int)(nul - t) + 1, "NUL byte in the scene file (is it a text file?)");
            return ln;
        }
        /* libinih's buffer holds TAPE_MAX_TEXT bytes plus "\r\n\0" */
        size_t raw = n > 0 && t[n - 1] == '\r' ? n - 1 : n;
        if (raw > TAPE_MAX_TEXT) {
            scene_fail_at(L, ln, 1, "line is %zu bytes long; the limit is %u bytes", raw, TAPE_MAX_TEXT);
            return ln;
        }
        size_t body = n;
        while (body > 0 && scene_is_space((unsigned char)t[body - 1]))
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
        while (a < b && scene_is_space((unsigned char)t[a]))
            a++;
        while (b > a && scene_is_space((unsigned char)t[b - 1]))
            b--;
        sec = scene_section_id(t + a, b - a);
        L->sec[ln - 1] = (unsigned char)sec;
        if (sec == SEC_SURFACE)
            L->has_surface = true;
        if (sec == SEC_UNKNOWN) {
            scene_fail_at(L, ln, (int)i + 1,
                    "unknown section [%.*s]; expected %s", (int)(b - a < 64 ? b - a : 64), t + a,
                    scene_sections_expected);
            return ln;
        }
        size_t after = skip_space(L, ln, close + 1);
        if (after < body && t[after] != ';' && t[after] != '#') {
            scene_fail_at(L, ln, (int)after + 1, "unexpected text after the section header [%s]",
                    scene_section_name(sec));
            return ln;
        }
    }
    if (!content) {
        scene_fail_at(L, 1, 1, "empty scene file, expected a [surface] section");
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
    while (cut > 0 && scene_is_space((unsigned char)copy[cut - 1]))
        cut--;
    copy[cut] = '\0';
    e->pieces[e->n_pieces].text = copy;
    e->pieces[e->n_pieces].line = line;
    e->pieces[e->n_pieces].col = col;
    e->n_pieces++;
    return 0;
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
        scene_fail_at(L, ln, 1, "internal error: line count out of step with libinih");
        return 0;
    }
    const char *t = line_text(L, ln);
    size_t n = L->line_len[ln - 1];
    size_t i = skip_space(L, ln, 0);
    if (L->cont[ln - 1]) {
        if (L->n_entries == 0)
            return 1; /* only after a key in an unknown section: already an error */
        if (add_piece(&L->entries[L->n_entries - 1], value, ln, (int)i + 1)) {
            scene_fail_oom(L);
            return 0;
        }
        return 1;
    }
    int sec = L->sec[ln - 1];
    size_t sep = find_chars_or_comment(t, i, n, "=:");
    size_t kend = sep;
    while (kend > i && scene_is_space((unsigned char)t[kend - 1]))
        kend--;
    int qlen = (int)(kend - i < 64 ? kend - i : 64);
    if (sec == SEC_NONE) {
        scene_fail_at(L, ln, (int)i + 1, "key '%.*s' before any section; expected a [surface] section first",
                qlen, t + i);
        return 0;
    }
    int kind = scene_key_kind(sec, t + i, kend - i);
    if (kind < 0) {
        scene_fail_at(L, ln, (int)i + 1, "unknown key '%.*s' in [%s]; expected %s", qlen, t + i,
                scene_section_name(sec), scene_keys_expected(sec));
        return 0;
    }
    if (kind != K_LET && L->seen[kind]) {
        scene_fail_at(L, ln, (int)i + 1, "duplicate key '%s' (first given at line %d)", scene_key_name(kind),
                L->entries[L->seen[kind] - 1].line);
        return 0;
    }
    if (L->n_entries == L->cap_entries) {
        size_t cap = L->cap_entries ? L->cap_entries * 2 : 16;
        entry_t *e = realloc(L->entries, cap * sizeof *e);
        if (!e) {
            scene_fail_oom(L);
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
        scene_fail_oom(L);
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

/* ---- the loader ------------------------------------------------------------------- */

void scene_ini_free(loader_t *L)
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

const entry_t *scene_entry(const loader_t *L, int kind)
{
    return L->seen[kind] ? &L->entries[L->seen[kind] - 1] : NULL;
}


int scene_ini_read(loader_t *L, ivoct_error_t *err)
{
    if (read_file(L, err))
        return -1;
    if (split_lines(L)) {
        ivoct_error_at(err, 0, 0, "out of memory while reading the scene file");
        return -1;
    }
    int stop = prescan(L);
    int rc = run_inih(L, stop);
    if (rc == -2 || L->oom) {
        L->oom = true;
    } else if (rc > 0) {
        /* a handler error is already recorded at line rc; otherwise libinih
         * found a line it cannot read */
        const char *t = line_text(L, rc);
        size_t i = skip_space(L, rc, 0);
        if (t[i] == '[')
            scene_fail_at(L, rc, 1, "expected ']' to close the section name");
        else
            scene_fail_at(L, rc, 1, "expected 'key = value' (no '=' or ':' found)");
    }
    return 0;
}
