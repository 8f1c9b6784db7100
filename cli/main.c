/* ivoct — the command line: dispatch to subcommands. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../expr/tape.h"
#include "cli.h"

static const char USAGE[] =
    "usage: ivoct COMMAND [options]\n"
    "\n"
    "Certified interval-octree subdivision of implicit surfaces f(x,y,z) = 0.\n"
    "\n"
    "commands:\n"
    "  eval    enclose f (and its gradient) over a box:\n"
    "          ivoct eval (SCENE | -e EXPR) [--box X0 X1 Y0 Y1 Z0 Z1] [--grad] [--json]\n"
    "  build   the octree of surface cells of a scene:\n"
    "          ivoct build SCENE [--depth N] [--tests LIST] [--refine EPS] [--threads N]\n"
    "                      [--max-memory SIZE] [--vtu F] [--htg F] [--vdb F] [--mesh F]\n"
    "                      [--cells F.csv] [--save F.ivo] [--stats F.json] [--quiet]\n"
    "  info    summarise an octree or export file: ivoct info FILE\n"
    "  implicitize  the implicit equation of a parametric scene:\n"
    "          ivoct implicitize SCENE [--method M] [--time-limit S] [--json]\n"
    "  render  ray cast a scene into a PNG and/or the .vti render buffers:\n"
    "          ivoct render SCENE [--octree F.ivo | --no-octree] [--no-leaf-tapes]\n"
    "                       [--method M] [--size WxH] [--threads N] [--max-memory SIZE]\n"
    "                       [--png F] [--vti F] [--frames N] [--stats F.json] [--quiet]\n"
    "\n"
    "Run 'ivoct COMMAND --help' for the options of a command.\n"
    "Exit codes: 0 ok, 1 runtime failure, 2 usage or input error; SIGINT, SIGTERM\n"
    "and SIGHUP end it by the signal (130, 143, 129), leaving no output of the command.\n"
    "Environment: IVOCT_SIMD=portable|avx2|avx512 forces the evaluators' SIMD path\n"
    "(default: the widest this CPU runs; every path gives the same results);\n"
    "IVOCT_OPENVDB_MODULE=FILE, IVOCT_VTK_MODULE=FILE the modules (libivoct_openvdb.so,\n"
    "libivoct_vtk.so) that .vdb, .htg and .vtp files, meshes and 'ivoct info' of them\n"
    "load on first use (default: the build's, or the installed ones).\n";

int main(int argc, char **argv)
{
    if (argc < 2) {
        fputs(USAGE, stderr);
        return EXIT_USAGE;
    }
    const char *cmd = argv[1];
    if (!strcmp(cmd, "--help") || !strcmp(cmd, "-h") || !strcmp(cmd, "help")) {
        fputs(USAGE, stdout);
        return EXIT_OK;
    }
    /* a path forced by the environment must exist and run here: a typo
     * would otherwise measure the wrong path without a word */
    const char *simd = getenv("IVOCT_SIMD");
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (simd && tape_simd_select(simd, &err)) {
        fprintf(stderr, "ivoct: IVOCT_SIMD: %s\n", err.msg);
        return EXIT_USAGE;
    }
    if (!strcmp(cmd, "--version")) {
        printf("ivoct %s\nSIMD path: %s (this build has: %s)\nmalloc: %s\n", IVOCT_VERSION,
               tape_simd_name(), tape_simd_paths(), cli_allocator());
        return EXIT_OK;
    }
    static const struct {
        const char *name;
        int (*run)(int, char **);
    } commands[] = {
        {"eval", cmd_eval},     {"build", cmd_build},
        {"info", cmd_info},     {"render", cmd_render},
        {"implicitize", cmd_implicitize}};
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (!strcmp(cmd, commands[i].name)) {
            /* before any thread is started */
            cli_signals_start(commands[i].name);
#ifdef IVOCT_MPI
            /* under mpirun, `build` and `render` run over the ranks (cli/mpi.c) */
            if (commands[i].run == cmd_build || commands[i].run == cmd_render) {
                int rc = cli_mpi_start(&argc, &argv);
                if (rc)
                    return cli_signals_finish(rc);
                return cli_signals_finish(cli_mpi_finish(commands[i].run(argc - 1, argv + 1)));
            }
#endif
            return cli_signals_finish(commands[i].run(argc - 1, argv + 1));
        }
    fprintf(stderr, "ivoct: unknown command '%s'\n%s", cmd, USAGE);
    return EXIT_USAGE;
}
