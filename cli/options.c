/* ivoct command line — the option parser every command shares, and the help
 * it prints from the same table. */
#include <stdio.h>
#include <string.h>

#include "cli.h"

static int takes_values(cli_kind_t k)
{
    return k == CLI_STRING || k == CLI_INT || k == CLI_DOUBLE || k == CLI_CUSTOM;
}

static const cli_option_t *find(const cli_command_t *cmd, const char *a)
{
    for (const cli_option_t *o = cmd->options; o->name; o++)
        if (o->kind != CLI_OPERAND && (!strcmp(a, o->name) || (o->alias && !strcmp(a, o->alias))))
            return o;
    return NULL;
}

/* The n-th operand entry (0-based), NULL when there are fewer. */
static const cli_option_t *operand(const cli_command_t *cmd, int n)
{
    for (const cli_option_t *o = cmd->options; o->name; o++)
        if (o->kind == CLI_OPERAND && n-- == 0)
            return o;
    return NULL;
}

/* One option a (its entry o) with its values v[0..nargs-1]. */
static int take(const cli_command_t *cmd, const cli_option_t *o, const char *a, char **v, int nargs)
{
    switch (o->kind) {
    case CLI_HELP:
        cli_print_help(cmd, stdout);
        return EXIT_OK;
    case CLI_FLAG:
        *(bool *)o->target = true;
        break;
    case CLI_STRING:
        *(const char **)o->target = v[0];
        break;
    case CLI_INT:
        if (!cli_parse_int(cmd->name, a, v[0], o->lo, o->hi, (long *)o->target))
            return EXIT_USAGE;
        break;
    case CLI_DOUBLE:
        for (int k = 0; k < nargs; k++)
            if (!cli_parse_double(cmd->name, a, v[k], (double *)o->target + k))
                return EXIT_USAGE;
        break;
    case CLI_CUSTOM: {
        char msg[1024];
        msg[0] = '\0';
        if (o->parse(a, v[0], o->target, msg, sizeof msg))
            return cli_usage_error(cmd->name, "%s", msg);
        break;
    }
    case CLI_OPERAND:
        break;
    }
    if (o->given)
        *o->given = true;
    return CLI_RUN;
}

int cli_parse(const cli_command_t *cmd, int argc, char **argv)
{
    int operands = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (a[0] != '-' || a[1] == '\0') {
            const cli_option_t *o = operand(cmd, operands++);
            if (!o)
                return cli_usage_error(cmd->name, "unexpected argument '%s'", a);
            *(const char **)o->target = a;
            if (o->given)
                *o->given = true;
            continue;
        }
        const cli_option_t *o = find(cmd, a);
        if (!o)
            return cli_usage_error(cmd->name, "unknown option '%s'", a);
        int nargs = takes_values(o->kind) ? (o->nargs > 0 ? o->nargs : 1) : 0;
        if (nargs >= argc - i) {
            if (o->needs)
                return cli_usage_error(cmd->name, "%s needs %s", a, o->needs);
            if (nargs == 1)
                return cli_usage_error(cmd->name, "%s needs a value", a);
            return cli_usage_error(cmd->name, "%s needs %d values", a, nargs);
        }
        int rc = take(cmd, o, a, argv + i + 1, nargs);
        if (rc != CLI_RUN)
            return rc;
        i += nargs;
    }
    return CLI_RUN;
}

void cli_print_help(const cli_command_t *cmd, FILE *f)
{
    fputs(cmd->synopsis, f);
    for (const cli_option_t *o = cmd->options; o->name; o++) {
        if (!o->help)
            continue;
        char head[128];
        snprintf(head, sizeof head, "%s%s%s", o->name, o->arg ? " " : "", o->arg ? o->arg : "");
        if ((int)strlen(head) >= cmd->column)
            fprintf(f, "  %s\n%*s", head, cmd->column + 2, "");
        else
            fprintf(f, "  %-*s", cmd->column, head);
        /* the help, its continuation lines under its first */
        for (const char *line = o->help;;) {
            const char *end = strchr(line, '\n');
            int len = end ? (int)(end - line) : (int)strlen(line);
            fprintf(f, "%.*s\n", len, line);
            if (!end)
                break;
            line = end + 1;
            fprintf(f, "%*s", cmd->column + 2, "");
        }
    }
}
