#define _POSIX_C_SOURCE 200809L
#include "io.h"

#include <errno.h>
#include <fcntl.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

int io_open(io_file_t *out, const char *path, ivoct_error_t *err)
{
    memset(out, 0, sizeof *out);
    size_t n = strlen(path);
    out->path = malloc(n + 1);
    out->tmp = malloc(n + 48);
    if (!out->path || !out->tmp) {
        io_abort(out);
        ivoct_error_set(err, "cannot write %s: out of memory", path);
        return -1;
    }
    memcpy(out->path, path, n + 1);
    /* a device or a pipe (/dev/stdout, /dev/full) is written in place: it
     * cannot be renamed over, and it holds no file to leave half-written */
    struct stat st;
    if (stat(path, &st) == 0 && !S_ISREG(st.st_mode)) {
        free(out->tmp);
        out->tmp = NULL;
        out->f = fopen(path, "wb");
        if (!out->f) {
            ivoct_error_set(err, "cannot write %s: %s", path, strerror(errno));
            io_abort(out);
            return -1;
        }
        return 0;
    }
    /* same folder as the destination, so that rename() is atomic; created
     * like any output (0666 less the umask), which mkstemp's 0600 would not be */
    static atomic_uint counter;
    int fd = -1;
    for (int attempt = 0; attempt < 100 && fd < 0; attempt++) {
        snprintf(out->tmp, n + 48, "%s.tmp.%ld.%u", path, (long)getpid(),
                 atomic_fetch_add(&counter, 1u));
        fd = open(out->tmp, O_WRONLY | O_CREAT | O_EXCL, 0666);
        if (fd < 0 && errno != EEXIST)
            break;
    }
    if (fd < 0) {
        ivoct_error_set(err, "cannot write %s: %s", path, strerror(errno));
        free(out->tmp);
        out->tmp = NULL;
        io_abort(out);
        return -1;
    }
    out->f = fdopen(fd, "wb");
    if (!out->f) {
        close(fd);
        ivoct_error_set(err, "cannot write %s: %s", path, strerror(errno));
        io_abort(out);
        return -1;
    }
    return 0;
}

int io_commit(io_file_t *f, ivoct_error_t *err)
{
    int bad = fflush(f->f) != 0 || ferror(f->f);
    int e = errno;
    if (fclose(f->f) != 0 && !bad)
        bad = 1, e = errno;
    f->f = NULL;
    if (!bad && f->tmp && rename(f->tmp, f->path) != 0)
        bad = 1, e = errno;
    if (bad) {
        ivoct_error_set(err, "cannot write %s: %s", f->path, strerror(e ? e : EIO));
        io_abort(f);
        return -1;
    }
    free(f->tmp);
    free(f->path);
    memset(f, 0, sizeof *f);
    return 0;
}

void io_abort(io_file_t *f)
{
    if (f->f)
        fclose(f->f);
    if (f->tmp)
        remove(f->tmp);
    free(f->tmp);
    free(f->path);
    memset(f, 0, sizeof *f);
}
