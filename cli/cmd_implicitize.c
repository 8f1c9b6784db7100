/* ivoct implicitize — the implicit equation of a parametric scene. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../scene/scene.h"
#include "cli.h"

static const char SYNOPSIS[] =
    "usage: ivoct implicitize SCENE [--method M] [--time-limit S] [--max-memory SIZE] [--json]\n"
    "\n"
    "Find the implicit equation f(x,y,z) = 0 of a parametric scene ([surface]\n"
    "param.x, param.y, param.z): the irreducible polynomial with integer\n"
    "coefficients that vanishes on the parametrization, checked exactly.  Print f,\n"
    "its degree and number of terms, the method, the time, and the factors of the\n"
    "eliminant removed because they do not vanish on the parametrization (base\n"
    "points, denominators).  build and render do the same when they load the scene.\n"
    "Exit 2 when the parametrization is not a surface, 1 past the budget.\n"
    "\n";

static int parse_method(const char *opt, const char *value, void *target, char *msg, size_t n)
{
    imp_method_t m;
    if (imp_method_parse(value, &m)) {
        snprintf(msg, n, "%s: unknown method '%s'; expected auto, resultant or groebner", opt, value);
        return -1;
    }
    *(int *)target = (int)m;
    return 0;
}

static void print_text(const scene_t *s, const imp_result_t *r)
{
    printf("scene:    %s\n", s->source.name);
    for (int k = 0; k < 3; k++)
        printf("param.%c:  %s\n", "xyz"[k], s->source.param[k]);
    printf("method:   %s\n", imp_method_name(r->method));
    printf("time:     %.3f s\n", r->seconds);
    printf("degree:   %d\n", r->degree);
    printf("terms:    %ld\n", r->terms);
    if (!r->n_removed)
        printf("removed:  none\n");
    for (size_t i = 0; i < r->n_removed; i++)
        printf("removed:  %s\n", r->removed[i]);
    printf("f:        %s\n", r->f);
}

static void print_json(const scene_t *s, const imp_result_t *r)
{
    fputs("{\n  \"scene\": ", stdout);
    cli_json_string(stdout, s->source.name);
    fputs(",\n  \"param\": [", stdout);
    for (int k = 0; k < 3; k++) {
        fputs(k ? ", " : "", stdout);
        cli_json_string(stdout, s->source.param[k]);
    }
    fputs("],\n  \"method\": ", stdout);
    cli_json_string(stdout, imp_method_name(r->method));
    fputs(",\n  \"seconds\": ", stdout);
    cli_json_double(stdout, r->seconds);
    printf(",\n  \"degree\": %d,\n  \"terms\": %ld,\n  \"removed\": [", r->degree, r->terms);
    for (size_t i = 0; i < r->n_removed; i++) {
        fputs(i ? ", " : "", stdout);
        cli_json_string(stdout, r->removed[i]);
    }
    fputs("],\n  \"f\": ", stdout);
    cli_json_string(stdout, r->f);
    fputs(",\n  \"f_tape\": ", stdout);
    cli_json_string(stdout, r->f_tape);
    fputs("\n}\n", stdout);
}

int cmd_implicitize(int argc, char **argv)
{
    const char *scene_path = NULL;
    bool json = false;
    scene_options_t opt = {.implicitize = -1};
    size_t max_memory = 0;
    double seconds = 0;
    bool have_seconds = false;
    const cli_option_t options[] = {
        {.name = "--help", .alias = "-h", .kind = CLI_HELP},
        {.name = "SCENE", .kind = CLI_OPERAND, .target = &scene_path,
         .help = "a scene file (.ini) with param.x, param.y, param.z"},
        {.name = "--method", .kind = CLI_CUSTOM, .target = &opt.implicitize, .parse = parse_method,
         .arg = "M",
         .help = "resultant, groebner, or auto: resultants, then the Groebner basis\n"
                 "if they fail (default: the scene's implicitize, else auto)"},
        {.name = "--time-limit", .kind = CLI_DOUBLE, .target = &seconds, .given = &have_seconds,
         .arg = "S", .help = "seconds the implicitization may take (default 60)"},
        {.name = "--max-memory", .kind = CLI_CUSTOM, .target = &max_memory,
         .parse = cli_parse_memory, .arg = "SIZE",
         .help = "memory of the intermediate polynomials (default 1G)"},
        {.name = "--json", .kind = CLI_FLAG, .target = &json,
         .help = "print {\"scene\", \"param\", \"method\", \"seconds\", \"degree\", \"terms\",\n"
                 "\"removed\", \"f\", \"f_tape\"} (f_tape: f nested for evaluation)"},
        {0},
    };
    const cli_command_t cmd = {"implicitize", SYNOPSIS, 16, options};
    int rc = cli_parse(&cmd, argc, argv);
    if (rc != CLI_RUN)
        return rc;
    if (!scene_path)
        return cli_usage_error("implicitize", "missing the scene file");
    if (have_seconds && !(seconds > 0))
        return cli_usage_error("implicitize", "--time-limit: expected a number of seconds > 0");
    opt.budget.seconds = seconds;
    opt.budget.bytes = max_memory;

    scene_t s;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    int loaded = scene_load_with(scene_path, &opt, &s, &err);
    if (loaded) {
        cli_print_error(&err);
        return loaded == SCENE_ERUNTIME ? EXIT_RUNTIME : EXIT_USAGE;
    }
    if (!s.implicit) {
        fprintf(stderr, "ivoct implicitize: %s: not a parametric surface (its f is implicit "
                        "already; param.x, param.y, param.z give a parametrization)\n",
                scene_path);
        scene_free(&s);
        return EXIT_USAGE;
    }
    if (json)
        print_json(&s, s.implicit);
    else
        print_text(&s, s.implicit);
    scene_free(&s);
    return EXIT_OK;
}
