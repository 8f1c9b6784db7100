/* ivoct — error reports (see error.h). */
#include "error.h"

#include <stdarg.h>
#include <stdio.h>

void ivoct_error_clear(ivoct_error_t *err)
{
    if (err == NULL)
        return;
    err->file[0] = '\0';
    err->line = 0;
    err->col = 0;
    err->msg[0] = '\0';
}

void ivoct_error_set(ivoct_error_t *err, const char *fmt, ...)
{
    if (err == NULL)
        return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err->msg, sizeof err->msg, fmt, ap);
    va_end(ap);
}

void ivoct_error_at(ivoct_error_t *err, int line, int col, const char *fmt, ...)
{
    if (err == NULL)
        return;
    err->line = line;
    err->col = col;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err->msg, sizeof err->msg, fmt, ap);
    va_end(ap);
}

/* "file:line:col: msg"; a column is shown only with a line, and the ": "
 * separator only when some position part is present. */
char *ivoct_error_format(const ivoct_error_t *err, char *buf, unsigned long n)
{
    if (buf == NULL || n == 0)
        return buf;
    buf[0] = '\0';
    if (err == NULL)
        return buf;
    size_t len = 0;
    int w;
#define APPEND(...)                                                     \
    do {                                                                \
        w = snprintf(buf + len, n - len, __VA_ARGS__);                  \
        if (w < 0)                                                      \
            return buf;                                                 \
        len += (size_t)w;                                               \
        if (len >= n)                                                   \
            return buf; /* truncated, still NUL-terminated */          \
    } while (0)
    int prefix = 0;
    if (err->file[0] != '\0') {
        APPEND("%.*s:", (int)sizeof err->file, err->file);
        prefix = 1;
    }
    if (err->line > 0) {
        APPEND("%d:", err->line);
        prefix = 1;
        if (err->col > 0)
            APPEND("%d:", err->col);
    }
    APPEND("%s%.*s", prefix ? " " : "", (int)sizeof err->msg, err->msg);
#undef APPEND
    return buf;
}
