/* ivoct eval — enclose f, and optionally its gradient, over a box. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../scene/scene.h"
#include "cli.h"

static const char SYNOPSIS[] =
    "usage: ivoct eval (SCENE | -e EXPR) [--box X0 X1 Y0 Y1 Z0 Z1] [--grad] [--json]\n"
    "\n"
    "Print a rigorous enclosure [lo, hi] of f over the box: every value of f at a\n"
    "point of the box where f is defined lies in it.  A point box (X0 = X1, ...)\n"
    "gives the enclosure of f at that point.  An empty result means f is defined\n"
    "nowhere in the box.\n"
    "\n";

static void print_iv_text(const char *label, iv_t v)
{
    if (iv_is_empty(v))
        printf("%-6s empty (undefined on the whole box)\n", label);
    else
        printf("%-6s in [%.17g, %.17g]\n", label, v.lo, v.hi);
}

static void print_iv_json(iv_t v)
{
    fputc('[', stdout);
    cli_json_double(stdout, v.lo);
    fputs(", ", stdout);
    cli_json_double(stdout, v.hi);
    fputc(']', stdout);
}

int cmd_eval(int argc, char **argv)
{
    const char *scene_path = NULL, *expr = NULL;
    double box[6];
    bool have_box = false, grad = false, json = false;

    const cli_option_t options[] = {
        {.name = "--help", .alias = "-h", .kind = CLI_HELP},
        {.name = "SCENE", .kind = CLI_OPERAND, .target = &scene_path,
         .help = "a scene file (.ini); its f and box are used"},
        {.name = "-e", .kind = CLI_STRING, .target = &expr, .needs = "an expression", .arg = "EXPR",
         .help = "an expression in x, y, z instead of a scene"},
        {.name = "--box", .kind = CLI_DOUBLE, .target = box, .nargs = 6, .given = &have_box,
         .needs = "6 numbers", .arg = "...",
         .help = "the box (default: the scene's box; required with -e)"},
        {.name = "--grad", .kind = CLI_FLAG, .target = &grad,
         .help = "also enclose the gradient (df/dx, df/dy, df/dz)"},
        {.name = "--json", .kind = CLI_FLAG, .target = &json,
         .help = "print {\"lo\": .., \"hi\": .. [, \"grad\": [[lo,hi],[lo,hi],[lo,hi]]]}\n"
                 "with 17 significant digits; infinities as 1e999, empty as null"},
        {0},
    };
    const cli_command_t cmd = {"eval", SYNOPSIS, 13, options};
    int rc = cli_parse(&cmd, argc, argv);
    if (rc != CLI_RUN)
        return rc;
    if (!scene_path == !expr)
        return cli_usage_error("eval", "give either a scene file or -e EXPR");
    if (expr && !have_box)
        return cli_usage_error("eval", "-e needs --box X0 X1 Y0 Y1 Z0 Z1");
    if (have_box)
        for (int k = 0; k < 3; k++)
            if (box[2 * k] > box[2 * k + 1])
                return cli_usage_error("eval", "--box: %c0 = %.17g > %c1 = %.17g", "xyz"[k],
                                       box[2 * k], "xyz"[k], box[2 * k + 1]);

    scene_t s;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    rc = expr ? scene_from_expr(expr, box, &s, &err) : scene_load(scene_path, &s, &err);
    if (rc) {
        cli_print_error(&err);
        return rc == SCENE_ERUNTIME ? EXIT_RUNTIME : EXIT_USAGE;
    }
    if (have_box)
        memcpy(s.box, box, sizeof box);

    iv_box_t b = {{s.box[0], s.box[1]}, {s.box[2], s.box[3]}, {s.box[4], s.box[5]}};
    tape_ws_t *ws = tape_ws_new(s.tape->n);
    if (!ws) {
        scene_free(&s);
        fprintf(stderr, "ivoct eval: out of memory\n");
        return EXIT_RUNTIME;
    }
    iv_grad_t g;
    if (grad) {
        tape_eval_grad(s.tape, ws, 1, &b, &g);
    } else {
        tape_eval_interval(s.tape, ws, 1, &b, &g.v);
    }

    if (json) {
        fputs("{\"lo\": ", stdout);
        cli_json_double(stdout, g.v.lo);
        fputs(", \"hi\": ", stdout);
        cli_json_double(stdout, g.v.hi);
        if (iv_is_empty(g.v))
            fputs(", \"empty\": true", stdout);
        if (grad) {
            fputs(", \"grad\": [", stdout);
            print_iv_json(g.dx);
            fputs(", ", stdout);
            print_iv_json(g.dy);
            fputs(", ", stdout);
            print_iv_json(g.dz);
            fputc(']', stdout);
        }
        fputs("}\n", stdout);
    } else {
        print_iv_text("f", g.v);
        if (grad) {
            print_iv_text("df/dx", g.dx);
            print_iv_text("df/dy", g.dy);
            print_iv_text("df/dz", g.dz);
        }
    }
    tape_ws_free(ws);
    scene_free(&s);
    if (fflush(stdout) != 0 || ferror(stdout)) {
        fprintf(stderr, "ivoct eval: cannot write the output\n");
        return EXIT_RUNTIME;
    }
    return EXIT_OK;
}
