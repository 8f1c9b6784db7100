#define _XOPEN_SOURCE 700 /* POSIX 2008 with XSI: realpath */
#include "io.h"

#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* ---- the registry of temporary names ------------------------------------------------
 * Every temporary file of the process, from its creation (under the lock, so a
 * name is registered before the file exists) until it is renamed or removed
 * (under the lock, so the name is dropped only once the file is gone). */

typedef struct reg_entry {
    const char *name; /* the io_file_t's tmp */
    struct reg_entry *prev, *next;
} reg_entry_t;

static pthread_mutex_t reg_lock = PTHREAD_MUTEX_INITIALIZER;
static reg_entry_t *reg_head;
static int reg_cancelled; /* io_remove_temporaries was called */

/* Both with reg_lock held. */
static void reg_insert(reg_entry_t *e, const char *name)
{
    e->name = name;
    e->prev = NULL;
    e->next = reg_head;
    if (reg_head)
        reg_head->prev = e;
    reg_head = e;
}

static void reg_remove(reg_entry_t *e)
{
    if (!e)
        return;
    if (e->prev)
        e->prev->next = e->next;
    else
        reg_head = e->next;
    if (e->next)
        e->next->prev = e->prev;
    free(e);
}

size_t io_remove_temporaries(void)
{
    size_t n = 0;
    pthread_mutex_lock(&reg_lock);
    reg_cancelled = 1;
    for (reg_entry_t *e = reg_head; e; e = e->next)
        if (unlink(e->name) == 0)
            n++;
    pthread_mutex_unlock(&reg_lock);
    return n;
}

/* ---- single files ------------------------------------------------------------------- */

static void free_file(io_file_t *f)
{
    free(f->tmp);
    free(f->path);
    free(f->buf);
    memset(f, 0, sizeof *f);
}

/* A stream's buffer.  The writers hand stdio pieces of a few hundred bytes to
 * tens of kilobytes (the .vdb's leaf nodes, the .vtu's compressed blocks);
 * through stdio's default buffer (st_blksize, 4 KiB here) each 4 KiB is a
 * write(2): 7 000 of them for a 30 MB file.  glibc sizes the buffer itself
 * unless given one, so it is given one; without the memory, stdio's stays.
 * Not larger: a piece that fits the buffer's room is copied into it, and the
 * CSV's pieces (~700 KB) would all be; past the room, whole buffers' worth go
 * straight to write(2). */
#define IO_BUFFER ((size_t)128 * 1024)

static void give_buffer(io_file_t *f)
{
    f->buf = malloc(IO_BUFFER);
    if (f->buf && setvbuf(f->f, f->buf, _IOFBF, IO_BUFFER) != 0) {
        free(f->buf);
        f->buf = NULL;
    }
}

/* The extension of path ("" when none): from its last '.' after the last '/',
 * not a leading one. */
static const char *extension_of(const char *path)
{
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    const char *dot = strrchr(base, '.');
    return dot && dot > base ? dot : "";
}

/* io_open, with the temporary name PATH.tmp.PID.N followed by ext. */
static int open_tmp(io_file_t *out, const char *path, const char *ext, ivoct_error_t *err)
{
    memset(out, 0, sizeof *out);
    /* a symbolic link is followed: the file it names is replaced, the link
     * stays (renamed over, the link would become the file; /dev/stdout,
     * when stdout is a file, would be replaced); a dangling one is replaced */
    struct stat st;
    char *target = lstat(path, &st) == 0 && S_ISLNK(st.st_mode) ? realpath(path, NULL) : NULL;
    size_t n = strlen(target ? target : path), extra = 48 + strlen(ext);
    out->path = target ? target : malloc(n + 1);
    out->tmp = malloc(n + extra);
    reg_entry_t *e = malloc(sizeof *e);
    if (!out->path || !out->tmp || !e) {
        free(e);
        ivoct_error_set(err, "cannot write %s: out of memory", path);
        free_file(out);
        return -1;
    }
    if (!target)
        memcpy(out->path, path, n + 1);
    path = out->path;
    /* a device or a pipe (/dev/stdout, /dev/full) is written in place: it
     * cannot be renamed over, and it holds no file to leave half-written */
    if (stat(path, &st) == 0 && !S_ISREG(st.st_mode)) {
        free(e);
        free(out->tmp);
        out->tmp = NULL;
        out->f = S_ISDIR(st.st_mode) ? (errno = EISDIR, NULL) : fopen(path, "wb");
        if (!out->f) {
            ivoct_error_set(err, "cannot write %s: %s", path, strerror(errno));
            free_file(out);
            return -1;
        }
        give_buffer(out);
        return 0;
    }
    /* same folder as the destination, so that rename() is atomic; created
     * like any output (0666 less the umask), which mkstemp's 0600 would not be */
    static atomic_uint counter;
    int fd = -1, cancelled;
    pthread_mutex_lock(&reg_lock);
    cancelled = reg_cancelled;
    for (int attempt = 0; attempt < 100 && fd < 0 && !cancelled; attempt++) {
        snprintf(out->tmp, n + extra, "%s.tmp.%ld.%u%s", path, (long)getpid(),
                 atomic_fetch_add(&counter, 1u), ext);
        fd = open(out->tmp, O_WRONLY | O_CREAT | O_EXCL, 0666);
        if (fd < 0 && errno != EEXIST)
            break;
    }
    int e_open = errno;
    if (fd >= 0) {
        reg_insert(e, out->tmp);
        out->reg = e;
    }
    pthread_mutex_unlock(&reg_lock);
    if (fd < 0) {
        free(e);
        ivoct_error_set(err, "cannot write %s: %s", path,
                        cancelled ? "interrupted" : strerror(e_open));
        free_file(out);
        return -1;
    }
    out->f = fdopen(fd, "wb");
    if (!out->f) {
        int e2 = errno;
        close(fd);
        io_abort(out);
        ivoct_error_set(err, "cannot write %s: %s", path, strerror(e2));
        return -1;
    }
    give_buffer(out);
    return 0;
}

int io_open(io_file_t *out, const char *path, ivoct_error_t *err)
{
    return open_tmp(out, path, "", err);
}

/* Flush, check and close f->f; 0, or the errno of the first failure. */
static int close_checked(io_file_t *f)
{
    /* after a failed fwrite, ferror is set and errno still tells why */
    int bad = fflush(f->f) != 0 || ferror(f->f);
    int e = bad ? (errno ? errno : EIO) : 0;
    if (fclose(f->f) != 0 && !bad)
        e = errno ? errno : EIO;
    f->f = NULL;
    free(f->buf); /* a file kept in a group waits closed: not its buffer */
    f->buf = NULL;
    return e;
}

int io_commit(io_file_t *f, ivoct_error_t *err)
{
    int e = close_checked(f);
    const char *why = NULL;
    if (!e && f->tmp) {
        pthread_mutex_lock(&reg_lock);
        if (reg_cancelled)
            why = "interrupted";
        else if (rename(f->tmp, f->path) != 0)
            e = errno;
        if (!why && !e) {
            reg_remove(f->reg);
            f->reg = NULL;
        }
        pthread_mutex_unlock(&reg_lock);
    }
    if (e || why) {
        ivoct_error_set(err, "cannot write %s: %s", f->path, why ? why : strerror(e));
        io_abort(f);
        return -1;
    }
    free_file(f);
    return 0;
}

void io_abort(io_file_t *f)
{
    if (f->f)
        fclose(f->f);
    if (f->tmp) {
        pthread_mutex_lock(&reg_lock);
        unlink(f->tmp);
        reg_remove(f->reg);
        pthread_mutex_unlock(&reg_lock);
    }
    free_file(f);
}

/* ---- commit groups ----------------------------------------------------------------- */

static int group_push(io_group_t *g, io_file_t *f, ivoct_error_t *err)
{
    if (g->n == g->cap) {
        size_t cap = g->cap ? 2 * g->cap : 8;
        io_file_t *p = realloc(g->files, cap * sizeof *p);
        if (!p) {
            ivoct_error_set(err, "cannot write %s: out of memory", f->path);
            io_abort(f);
            return -1;
        }
        g->files = p;
        g->cap = cap;
    }
    g->files[g->n++] = *f;
    memset(f, 0, sizeof *f);
    return 0;
}

int io_group_add(io_group_t *g, io_file_t *f, ivoct_error_t *err)
{
    int e = close_checked(f);
    if (e) {
        ivoct_error_set(err, "cannot write %s: %s", f->path, strerror(e));
        io_abort(f);
        return -1;
    }
    return group_push(g, f, err);
}

int io_group_reserve(io_group_t *g, const char *path, const char **tmp, ivoct_error_t *err)
{
    struct stat st;
    if (stat(path, &st) == 0 && !S_ISREG(st.st_mode)) {
        *tmp = path; /* a device or a pipe: the writer writes it in place */
        return 0;
    }
    io_file_t f;
    if (open_tmp(&f, path, extension_of(path), err))
        return -1;
    if (io_group_add(g, &f, err))
        return -1;
    *tmp = g->files[g->n - 1].tmp;
    return 0;
}

void io_group_rename_error(const io_group_t *g, ivoct_error_t *err)
{
    for (size_t i = 0; i < g->n; i++) {
        const char *tmp = g->files[i].tmp, *path = g->files[i].path;
        if (!tmp)
            continue;
        size_t lt = strlen(tmp), lp = strlen(path);
        char out[sizeof err->msg];
        size_t o = 0;
        for (const char *s = err->msg; *s && o + 1 < sizeof out;) {
            if (!strncmp(s, tmp, lt)) {
                size_t k = lp < sizeof out - 1 - o ? lp : sizeof out - 1 - o;
                memcpy(out + o, path, k);
                o += k;
                s += lt;
            } else {
                out[o++] = *s++;
            }
        }
        out[o] = '\0';
        memcpy(err->msg, out, o + 1);
    }
}

static void group_free(io_group_t *g)
{
    for (size_t i = 0; i < g->n; i++)
        free_file(&g->files[i]);
    free(g->files);
    memset(g, 0, sizeof *g);
}

int io_group_commit(io_group_t *g, ivoct_error_t *err)
{
    int rc = 0;
    pthread_mutex_lock(&reg_lock);
    size_t i = 0;
    if (reg_cancelled) {
        ivoct_error_set(err, "cannot write %s: interrupted", g->n ? g->files[0].path : "outputs");
        rc = -1;
    }
    for (; rc == 0 && i < g->n; i++) {
        io_file_t *f = &g->files[i];
        if (!f->tmp)
            continue;
        if (rename(f->tmp, f->path) != 0) {
            ivoct_error_set(err, "cannot write %s: %s", f->path, strerror(errno));
            rc = -1;
            break;
        }
        reg_remove(f->reg);
        f->reg = NULL;
    }
    for (; i < g->n; i++) /* after a failure: the rest are removed */
        if (g->files[i].tmp) {
            unlink(g->files[i].tmp);
            reg_remove(g->files[i].reg);
            g->files[i].reg = NULL;
        }
    pthread_mutex_unlock(&reg_lock);
    group_free(g);
    return rc;
}

void io_group_abort(io_group_t *g)
{
    pthread_mutex_lock(&reg_lock);
    for (size_t i = 0; i < g->n; i++)
        if (g->files[i].tmp) {
            unlink(g->files[i].tmp);
            reg_remove(g->files[i].reg);
            g->files[i].reg = NULL;
        }
    pthread_mutex_unlock(&reg_lock);
    group_free(g);
}
