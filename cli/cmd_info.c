/* ivoct info — summarise a file ivoct wrote. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "../export/export.h"
#include "../octree/octree.h"
#include "cli.h"

static const char SYNOPSIS[] =
    "usage: ivoct info FILE\n"
    "\n"
    "Summarise a file of ivoct build: an octree (.ivo, or the index .pivo of its\n"
    "pieces: its scene, box, depth, tests, node and leaf counts and leaves per\n"
    "depth), or an export (.vtu, .htg, .vdb, a .vtp mesh, the indexes .pvtu and\n"
    ".phtg of pieces: its scene, cells, leaves per depth, arrays or grids).  Files\n"
    "are recognised by content.  A truncated or corrupt file is reported (exit 2).\n";

static int info_ivo(const char *path)
{
    oct_tree_t *t;
    oct_source_t src;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (oct_load(path, &t, &src, &err)) {
        fprintf(stderr, "ivoct info: %s\n", err.msg);
        return EXIT_USAGE;
    }
    int pieces = oct_index_pieces(path);
    if (pieces)
        printf("file:     %s (ivoct octree in %d piece%s)\n", path, pieces, pieces > 1 ? "s" : "");
    else
        printf("file:     %s (ivoct octree)\n", path);
    printf("scene:    %s\n", src.name);
    for (size_t i = 0; i < src.n_lets; i++)
        printf("let:      %s = %s\n", src.let_names[i], src.let_texts[i]);
    printf("f:        %s\n", src.f);
    for (int k = 0; k < 3 && src.param[0]; k++)
        printf("param.%c:  %s\n", "xyz"[k], src.param[k]);
    for (int k = 0; k < 2 && src.param[0]; k++)
        if (!isnan(src.patch[2 * k]))
            printf("%c:        [%.17g, %.17g]\n", "uv"[k], src.patch[2 * k], src.patch[2 * k + 1]);
    printf("box:      [%.17g, %.17g] x [%.17g, %.17g] x [%.17g, %.17g]\n", t->box[0], t->box[1],
           t->box[2], t->box[3], t->box[4], t->box[5]);
    printf("depth:    %d\n", t->depth);
    char tests[64];
    printf("tests:    %s\n", oct_tests_format(t->tests, tests, sizeof tests));
    printf("nodes:    %u\n", t->n_nodes);
    printf("leaves:   %u\n", t->n_leaves);
    uint64_t by_depth[OCT_MAX_DEPTH + 1] = {0};
    for (uint32_t i = 0; i < t->n_leaves; i++)
        by_depth[oct_leaf_depth(&t->leaves[i])]++;
    printf("leaves by depth:");
    for (int d = 0; d <= t->depth; d++)
        if (by_depth[d])
            printf(" %d:%llu", d, (unsigned long long)by_depth[d]);
    printf("\n");
    if (t->certain)
        printf("certain:  %llu of %u leaves (%.1f%%; built with --certain)\n",
               (unsigned long long)t->stats.leaves_certain, t->n_leaves,
               t->n_leaves ? 100.0 * (double)t->stats.leaves_certain / t->n_leaves : 0.0);
    oct_free(t);
    oct_source_free(&src);
    return EXIT_OK;
}

int cmd_info(int argc, char **argv)
{
    const char *path = NULL;
    const cli_option_t options[] = {
        {.name = "--help", .alias = "-h", .kind = CLI_HELP},
        {.name = "FILE", .kind = CLI_OPERAND, .target = &path},
        {0},
    };
    const cli_command_t cmd = {"info", SYNOPSIS, 0, options};
    int rc = cli_parse(&cmd, argc, argv);
    if (rc != CLI_RUN)
        return rc;
    if (!path)
        return cli_usage_error("info", "expects exactly one file");
    /* every format is recognised by its content, whatever the file's name: the
     * exports first; anything else is read as .ivo, whose loader says what is wrong */
    ivoct_error_t err;
    ivoct_error_clear(&err);
    int r = exp_info(path, stdout, &err);
    if (r < 0) {
        fprintf(stderr, "ivoct info: %s\n", err.msg);
        return EXIT_USAGE;
    }
    return r == 0 ? EXIT_OK : info_ivo(path);
}
