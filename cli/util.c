/* ivoct command line — helpers shared by the subcommands: usage errors, error
 * printing, number parsing, JSON printing, the progress bar. */
#include <math.h>
#include <omp.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

#include "../scene/scene.h"
#include "cli.h"

int cli_usage_error(const char *cmd, const char *fmt, ...)
{
    va_list ap;
    fprintf(stderr, "ivoct %s: ", cmd);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fprintf(stderr, " (see 'ivoct %s --help')\n", cmd);
    return EXIT_USAGE;
}

void cli_print_error(const ivoct_error_t *err)
{
    char buf[1024];
    fprintf(stderr, "ivoct: %s\n", ivoct_error_format(err, buf, sizeof buf));
}

bool cli_parse_double(const char *cmd, const char *opt, const char *text, double *out)
{
    char *end;
    double v = strtod(text, &end);
    if (end == text || *end != '\0' || !isfinite(v)) {
        cli_usage_error(cmd, "%s expects a finite number, got '%s'", opt, text);
        return false;
    }
    *out = v;
    return true;
}

bool cli_parse_int(const char *cmd, const char *opt, const char *text, long lo, long hi,
                   long *out)
{
    char *end;
    long v = strtol(text, &end, 10);
    if (end == text || *end != '\0' || v < lo || v > hi) {
        cli_usage_error(cmd, "%s expects an integer from %ld to %ld, got '%s'", opt, lo, hi,
                        text);
        return false;
    }
    *out = v;
    return true;
}

void cli_json_double(FILE *f, double x)
{
    if (x != x)
        fputs("null", f);
    else if (isinf(x))
        fputs(x > 0 ? "1e999" : "-1e999", f);
    else
        fprintf(f, "%.17g", x);
}

void cli_show_progress(void *user, double fraction)
{
    cli_progress_t *p = user;
    if (!p->shown && omp_get_wtime() - p->start < 1.0)
        return;
    if (!cli_progress_lock())
        return; /* a signal is ending the process: its message has the line */
    p->shown = 1;
    int frames = p->frames > 0 ? p->frames : 1;
    double total = (p->frame + fraction) / frames;
    int width = 40, full = (int)(total * width + 0.5);
    fprintf(stderr, "\r%s [%.*s%*s] %3d%%", p->label, full,
            "########################################", width - full, "",
            (int)(total * 100 + 0.5));
    if (total >= 1.0)
        fputc('\n', stderr);
    fflush(stderr);
    cli_progress_unlock(total < 1.0);
}

void cli_json_implicitize(FILE *f, const scene_t *s)
{
    const imp_result_t *r = s->implicit;
    if (!r)
        return;
    fputs(",\n  \"implicitize\": {\"method\": ", f);
    cli_json_string(f, imp_method_name(r->method));
    fputs(", \"seconds\": ", f);
    cli_json_double(f, r->seconds);
    fprintf(f, ", \"degree\": %d, \"terms\": %ld}", r->degree, r->terms);
}

void cli_json_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (; s && *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\')
            fprintf(f, "\\%c", c);
        else if (c < 0x20)
            fprintf(f, "\\u%04x", c);
        else
            fputc(c, f);
    }
    fputc('"', f);
}

int cli_parse_memory(const char *opt, const char *value, void *target, char *msg, size_t n)
{
    char *end;
    double v = strtod(value, &end);
    double mult = 1;
    if (end != value && v >= 0) {
        switch (*end) {
        case 'k': case 'K': mult = 1024.0, end++; break;
        case 'm': case 'M': mult = 1024.0 * 1024, end++; break;
        case 'g': case 'G': mult = 1024.0 * 1024 * 1024, end++; break;
        default: break;
        }
        if (*end == 'B' || *end == 'b')
            end++;
        if (*end == '\0' && v * mult <= 1e18) {
            *(size_t *)target = (size_t)(v * mult);
            return 0;
        }
    }
    snprintf(msg, n, "%s expects a size like 512M or 2G, got '%s'", opt, value);
    return -1;
}
