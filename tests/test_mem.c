/* mem/ (mem.h): large arrays on transparent huge pages.
 *
 * mem_huge_alloc: small blocks are plain memory; large ones are 2 MiB-aligned,
 * writable to the end, and (on Linux with transparent huge pages) their mapping
 * carries the kernel's huge-page advice ("hg" in /proc/self/smaps's VmFlags).
 * mem_huge_realloc keeps the contents while a block grows through the
 * threshold and shrinks.  mem_release gives back exactly the 2 MiB stretches
 * wholly inside its range (they read as zeros again on Linux) and leaves every
 * other byte as it was, the range still usable memory. */
#define _POSIX_C_SOURCE 200809L /* access */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "../mem/mem.h"

#define MIB ((size_t)1 << 20)

static unsigned char pattern(size_t i) { return (unsigned char)(i * 7 + 3); }

static void fill(unsigned char *p, size_t from, size_t to)
{
    for (size_t i = from; i < to; i++)
        p[i] = pattern(i);
}

static int holds_pattern(const unsigned char *p, size_t from, size_t to)
{
    for (size_t i = from; i < to; i++)
        if (p[i] != pattern(i))
            return 0;
    return 1;
}

/* Does the kernel offer transparent huge pages at all? */
static int thp_available(void)
{
#if defined(__linux__)
    return access("/sys/kernel/mm/transparent_hugepage/enabled", R_OK) == 0;
#else
    return 0;
#endif
}

/* The VmFlags of the mapping holding p ("" when not found). */
static void vm_flags(const void *p, char *flags, size_t size)
{
    flags[0] = 0;
    FILE *f = fopen("/proc/self/smaps", "r");
    if (!f)
        return;
    char line[512];
    int inside = 0;
    while (fgets(line, sizeof line, f)) {
        unsigned long lo, hi;
        if (sscanf(line, "%lx-%lx ", &lo, &hi) == 2) /* a mapping's first line */
            inside = (uintptr_t)p >= lo && (uintptr_t)p < hi;
        else if (inside && strncmp(line, "VmFlags:", 8) == 0) {
            snprintf(flags, size, "%s", line + 8);
            break;
        }
    }
    fclose(f);
}

static void test_alloc_small(void **state)
{
    (void)state;
    unsigned char *p = mem_huge_alloc(1000);
    assert_non_null(p);
    fill(p, 0, 1000);
    assert_true(holds_pattern(p, 0, 1000));
    free(p);
}

static void test_alloc_large(void **state)
{
    (void)state;
    /* not a multiple of the page: the block is rounded up, the bytes asked for usable */
    const size_t n = MEM_HUGE_BYTES + 3 * MIB + 12345;
    unsigned char *p = mem_huge_alloc(n);
    assert_non_null(p);
    assert_int_equal((uintptr_t)p % (2 * MIB), 0);
    fill(p, 0, n);
    assert_true(holds_pattern(p, 0, n));
    if (thp_available()) {
        char flags[512];
        vm_flags(p, flags, sizeof flags);
        assert_non_null(strstr(flags, " hg"));
        vm_flags(p + n - 1, flags, sizeof flags); /* the advice covers the end too */
        assert_non_null(strstr(flags, " hg"));
    }
    free(p);
    /* a size no block can have */
    assert_null(mem_huge_alloc(SIZE_MAX - MIB));
}

static void test_grow_shrink(void **state)
{
    (void)state;
    unsigned char *p = mem_huge_realloc(NULL, MIB); /* NULL: an allocation */
    assert_non_null(p);
    fill(p, 0, MIB);
    const size_t sizes[] = {10 * MIB, 33 * MIB + 5, 2 * MIB, 9 * MIB};
    size_t kept = MIB;
    for (size_t k = 0; k < sizeof sizes / sizeof *sizes; k++) {
        unsigned char *q = mem_huge_realloc(p, sizes[k]);
        assert_non_null(q);
        p = q;
        if (sizes[k] < kept)
            kept = sizes[k];
        assert_true(holds_pattern(p, 0, kept));
        fill(p, kept, sizes[k]);
        kept = sizes[k];
        if (thp_available() && sizes[k] >= MEM_HUGE_BYTES) {
            char flags[512];
            vm_flags(p + sizes[k] / 2, flags, sizeof flags);
            assert_non_null(strstr(flags, " hg"));
        }
    }
    free(p);
}

static void test_release(void **state)
{
    (void)state;
    const size_t n = 8 * MIB;
    unsigned char *p = mem_huge_alloc(n); /* 2 MiB-aligned */
    assert_non_null(p);
    fill(p, 0, n);
    /* [1, 7) MiB: only [2, 6) lies in whole 2 MiB pages */
    mem_release(p + MIB, 6 * MIB);
    assert_true(holds_pattern(p, 0, 2 * MIB));
    assert_true(holds_pattern(p, 6 * MIB, n));
#if defined(__linux__)
    for (size_t i = 2 * MIB; i < 6 * MIB; i += 4093) /* given back: zeros again */
        assert_int_equal(p[i], 0);
#endif
    fill(p, 2 * MIB, 6 * MIB); /* still ours */
    assert_true(holds_pattern(p, 0, n));
    /* a range holding no whole 2 MiB page changes nothing */
    mem_release(p + MIB, 2 * MIB);
    mem_release(p + 3 * MIB, 0);
    assert_true(holds_pattern(p, 0, n));
    free(p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_alloc_small),
        cmocka_unit_test(test_alloc_large),
        cmocka_unit_test(test_grow_shrink),
        cmocka_unit_test(test_release),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
