/* exp_info's reading child (export/common.cpp, export/README.md): the VTK and
 * OpenVDB readers run in a forked child, which can inherit a lock that another
 * thread held at the fork and then sleep on it forever.  The parent ends a child
 * that sleeps without using any CPU and reads the file again in a new child.
 *
 * The inherited lock is simulated with a pthread_atfork child handler that puts
 * the chosen children to sleep (pause: asleep, no CPU) before they read:
 *  - no child stuck: the .vtu and the .vdb are summarised;
 *  - the first child stuck: the summary still comes (from the second child),
 *    and no child is left behind;
 *  - every child stuck: exp_info fails with "stopped", after the three tries,
 *    and no child is left behind. */
#define _GNU_SOURCE
#include <dirent.h>
#include <pthread.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmocka.h>

#include "../export/export.h"
#include "../octree/octree.h"
#include "support/testutil.h"

static char g_dir[64];
static char g_vtu[128], g_vdb[128];

/* how many of the next children to put to sleep (decided in the parent, before
 * each fork), and whether this one is */
static int g_stick_next;
static int g_stick_this;

static void before_fork(void)
{
    g_stick_this = g_stick_next > 0;
    if (g_stick_next > 0)
        g_stick_next--;
}

static void in_child(void)
{
    while (g_stick_this)
        pause();
}

static int setup(void **state)
{
    (void)state;
    strcpy(g_dir, "/tmp/ivoct-info-XXXXXX");
    if (!mkdtemp(g_dir))
        return -1;
    if (pthread_atfork(before_fork, NULL, in_child))
        return -1;
    tape_t *t = tu_compile("x^2 + y^2 + z^2 - 1");
    oct_params_t p;
    oct_params_default(&p);
    p.depth = 4;
    const double box[6] = {-2, 2, -2, 2, -2, 2};
    oct_tree_t *tree = NULL;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (oct_build(t, box, &p, &tree, &err))
        return -1;
    snprintf(g_vtu, sizeof g_vtu, "%s/sphere.vtu", g_dir);
    snprintf(g_vdb, sizeof g_vdb, "%s/sphere.vdb", g_dir);
    int rc = exp_vtu(tree, NULL, g_vtu, &err) || exp_vdb(tree, t, NULL, g_vdb, &err);
    oct_free(tree);
    tape_free(t);
    return rc ? -1 : 0;
}

static int teardown(void **state)
{
    (void)state;
    unlink(g_vtu);
    unlink(g_vdb);
    rmdir(g_dir);
    return 0;
}

/* No child of this process is left (running or a zombie). */
static void assert_no_children(void)
{
    assert_int_equal(waitpid(-1, NULL, WNOHANG), -1);
}

/* exp_info on path with the first `stuck` children asleep: its result, the
 * summary in out (NUL-terminated) and the seconds it took */
static int info(const char *path, int stuck, char **text, ivoct_error_t *err, double *seconds)
{
    size_t len = 0;
    FILE *out = open_memstream(text, &len);
    assert_non_null(out);
    ivoct_error_clear(err);
    g_stick_next = stuck;
    double t0 = tu_now();
    int rc = exp_info(path, out, err);
    *seconds = tu_now() - t0;
    g_stick_next = 0;
    fclose(out);
    return rc;
}

static void test_reads(void **state)
{
    (void)state;
    const char *paths[2] = {g_vtu, g_vdb};
    for (int i = 0; i < 2; i++) {
        char *text = NULL;
        ivoct_error_t err;
        double s;
        assert_int_equal(info(paths[i], 0, &text, &err, &s), 0);
        assert_true(strlen(text) > 0);
        free(text);
        assert_no_children();
    }
}

static void test_stuck_child_is_replaced(void **state)
{
    (void)state;
    const char *paths[2] = {g_vtu, g_vdb};
    for (int i = 0; i < 2; i++) {
        char *plain = NULL, *text = NULL;
        ivoct_error_t err;
        double s;
        assert_int_equal(info(paths[i], 0, &plain, &err, &s), 0);
        assert_int_equal(info(paths[i], 1, &text, &err, &s), 0);
        assert_string_equal(text, plain);
        assert_true(s >= 2.0); /* the stuck child was watched for two seconds */
        free(plain);
        free(text);
        assert_no_children();
    }
}

static void test_always_stuck_fails(void **state)
{
    (void)state;
    char *text = NULL;
    ivoct_error_t err;
    double s;
    assert_int_equal(info(g_vtu, 1000, &text, &err, &s), -1);
    assert_non_null(strstr(err.msg, g_vtu));
    assert_non_null(strstr(err.msg, "stopped"));
    assert_true(s >= 6.0); /* three tries of two seconds */
    assert_string_equal(text, "");
    free(text);
    assert_no_children();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reads),
        cmocka_unit_test(test_stuck_child_is_replaced),
        cmocka_unit_test(test_always_stuck_fails),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
