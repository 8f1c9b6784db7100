/* What the fuzz targets share: the input as a NUL-terminated string, or as a
 * temporary file for the readers that take a path.  Header-only, so each
 * target stays one file. */
#ifndef IVOCT_FUZZ_INPUT_H
#define IVOCT_FUZZ_INPUT_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* A copy of data with a NUL after it; NULL when out of memory. */
static inline char *fuzz_string(const uint8_t *data, size_t size)
{
    char *s = malloc(size + 1);
    if (s) {
        if (size)
            memcpy(s, data, size);
        s[size] = '\0';
    }
    return s;
}

/* Write data to a new temporary file (in $TMPDIR, else /tmp) whose name ends in
 * suffix; its path goes to path (PATH_MAX-sized).  The caller unlinks it.
 * Aborts on failure: a fuzzer that cannot write its input tests nothing. */
static inline void fuzz_file(const uint8_t *data, size_t size, const char *suffix, char *path,
                             size_t path_size)
{
    const char *dir = getenv("TMPDIR");
    if (!dir || !*dir)
        dir = "/tmp";
    int n = snprintf(path, path_size, "%s/ivoct-fuzz-XXXXXX%s", dir, suffix);
    if (n < 0 || (size_t)n >= path_size)
        abort();
    int fd = mkstemps(path, (int)strlen(suffix));
    if (fd < 0)
        abort();
    size_t done = 0;
    while (done < size) {
        ssize_t w = write(fd, data + done, size - done);
        if (w <= 0)
            abort();
        done += (size_t)w;
    }
    if (close(fd))
        abort();
}

#endif
