/* Implicitization (implicit/implicit.h): the parser of parametrizations and
 * its errors, exact points, rigorous patch bounds, and the implicit equations
 * of six surfaces by both methods.
 *
 * Oracles independent of the module's own checks: the returned text of f is
 * parsed again here by FLINT's own parser (fmpz_mpoly_set_str_pretty) and
 * evaluated in exact rationals at >= 50 random rational points of the
 * parametrization (the points from imp_param_eval, whose values are checked
 * on known points first); f is factored again here (irreducible over Q);
 * f_tape must expand to the same polynomial; both texts must compile with
 * ivoct's expression compiler, and its rigorous enclosure at a point must
 * hold the exact value.  Bounds: random points of the patch must lie in the
 * box. */
#define _POSIX_C_SOURCE 200809L /* clock_gettime */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <cmocka.h>
#include <flint/flint.h>
#include <flint/fmpz_mpoly.h>
#include <flint/fmpz_mpoly_factor.h>
#include <gmp.h>

#include "../expr/tape.h"
#include "../implicit/implicit.h"

/* splitmix64, fixed seed: reproducible inputs */
static uint64_t rng_state = 0x1234abcdu;
static uint64_t rnd(void)
{
    uint64_t z = (rng_state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}
static double uniform(void) { return (double)(rnd() >> 11) * 0x1p-53; }

/* a random rational a/b, |a| <= 40, 1 <= b <= 25 */
static void random_rational(mpq_t q)
{
    long a = (long)(rnd() % 81) - 40, b = (long)(rnd() % 25) + 1;
    mpq_set_si(q, a, (unsigned long)b);
    mpq_canonicalize(q);
}

static imp_param_t *parse3(const char *x, const char *y, const char *z)
{
    const char *t[3] = {x, y, z};
    imp_param_t *p = NULL;
    int which = -1;
    ivoct_error_t err;
    int rc = imp_param_parse(t, &p, &which, &err);
    if (rc != IMP_OK)
        fail_msg("parse (%s, %s, %s): rc %d, coordinate %d, %d:%d: %s", x, y, z, rc, which,
                 err.line, err.col, err.msg);
    return p;
}

/* ---- the six surfaces ------------------------------------------------------------------ */

typedef struct surface {
    const char *name, *x, *y, *z;
    int degree;
    const char *f; /* the expected text, or NULL (Enneper: checked by its properties) */
    long terms;
} surface_t;

static const surface_t SURFACES[] = {
    {"sphere (stereographic)", "2*u/(1+u^2+v^2)", "2*v/(1+u^2+v^2)", "(u^2+v^2-1)/(1+u^2+v^2)", 2,
     "x^2 + y^2 + z^2 - 1", 4},
    {"Whitney umbrella", "u*v", "u", "v^2", 3, "x^2 - y^2*z", 2},
    {"Roman surface", "2*v*(u^2+v^2-1)/(1+u^2+v^2)^2", "2*u*(u^2+v^2-1)/(1+u^2+v^2)^2",
     "4*u*v/(1+u^2+v^2)^2", 4, "x^2*y^2 + x^2*z^2 - x*y*z + y^2*z^2", 4},
    {"Plücker's conoid", "u", "u*v", "2*v/(1+v^2)", 3, "x^2*z - 2*x*y + y^2*z", 3},
    {"Enneper's surface", "u-u^3/3+u*v^2", "v-v^3/3+v*u^2", "u^2-v^2", 9, NULL, 23},
    /* a cubic with a double point at the origin, parametrized by the lines
     * through it (implicit/README.md): x^2 - y^2 + x z + z (x^2 + y^2 + z^2) */
    {"nodal cubic", "-u*(u^2-v^2+u)/(1+u^2+v^2)", "-v*(u^2-v^2+u)/(1+u^2+v^2)",
     "-(u^2-v^2+u)/(1+u^2+v^2)", 3, "x^2*z + x^2 + x*z + y^2*z - y^2 + z^3", 6},
};
#define N_SURFACES (sizeof SURFACES / sizeof SURFACES[0])

static const char *XYZ[3] = {"x", "y", "z"};

/* r = f(p) exactly, f in Z[x, y, z] */
static void eval_mpq(mpq_t r, const fmpz_mpoly_t f, const fmpz_mpoly_ctx_t ctx, mpq_t p[3])
{
    mpq_t t, w;
    mpz_t c;
    mpq_init(t);
    mpq_init(w);
    mpz_init(c);
    mpq_set_ui(r, 0, 1);
    for (slong i = 0; i < fmpz_mpoly_length(f, ctx); i++) {
        ulong e[3];
        fmpz_mpoly_get_term_exp_ui(e, f, i, ctx);
        fmpz_t cf;
        fmpz_init(cf);
        fmpz_mpoly_get_term_coeff_fmpz(cf, f, i, ctx);
        fmpz_get_mpz(c, cf);
        fmpz_clear(cf);
        mpq_set_z(t, c);
        for (int k = 0; k < 3; k++) {
            mpz_pow_ui(mpq_numref(w), mpq_numref(p[k]), e[k]);
            mpz_pow_ui(mpq_denref(w), mpq_denref(p[k]), e[k]);
            mpq_mul(t, t, w);
        }
        mpq_add(r, r, t);
    }
    mpq_clear(t);
    mpq_clear(w);
    mpz_clear(c);
}

/* The text parsed by FLINT (fails the test when it does not parse). */
static void parse_flint(fmpz_mpoly_t f, const char *text, const fmpz_mpoly_ctx_t ctx)
{
    if (fmpz_mpoly_set_str_pretty(f, text, XYZ, ctx) != 0)
        fail_msg("FLINT cannot parse '%s'", text);
}

/* Compile text with ivoct's expression compiler and check that its rigorous
 * enclosure at the double point p holds the exact value of f there. */
static void check_tape(const char *text, const fmpz_mpoly_t f, const fmpz_mpoly_ctx_t ctx)
{
    tape_t *t = NULL;
    ivoct_error_t err;
    if (tape_compile(text, &t, &err) != 0)
        fail_msg("tape_compile('%.200s'): %d:%d: %s", text, err.line, err.col, err.msg);
    tape_ws_t *ws = tape_ws_new(t->n);
    assert_non_null(ws);
    mpq_t p[3], r, b;
    for (int k = 0; k < 3; k++)
        mpq_init(p[k]);
    mpq_init(r);
    mpq_init(b);
    for (int j = 0; j < 8; j++) {
        double d[3];
        for (int k = 0; k < 3; k++) {
            d[k] = ldexp(floor(uniform() * 4096) - 2048, -10); /* k/1024 in [-2, 2) */
            mpq_set_d(p[k], d[k]);
        }
        iv_box_t box = {{d[0], d[0]}, {d[1], d[1]}, {d[2], d[2]}};
        iv_t out;
        tape_eval_interval(t, ws, 1, &box, &out);
        eval_mpq(r, f, ctx, p);
        mpq_set_d(b, out.lo);
        assert_true(mpq_cmp(b, r) <= 0);
        mpq_set_d(b, out.hi);
        assert_true(mpq_cmp(b, r) >= 0);
    }
    for (int k = 0; k < 3; k++)
        mpq_clear(p[k]);
    mpq_clear(r);
    mpq_clear(b);
    tape_ws_free(ws);
    tape_free(t);
}

/* Everything promised about one result. */
static void check_result(const surface_t *s, const imp_param_t *p, const imp_result_t *r,
                         fmpz_mpoly_t f, const fmpz_mpoly_ctx_t ctx)
{
    assert_non_null(r->f);
    assert_non_null(r->f_tape);
    if (s->f && strcmp(r->f, s->f) != 0)
        fail_msg("%s by %s: f = %s, want %s", s->name, imp_method_name(r->method), r->f, s->f);
    assert_int_equal(r->degree, s->degree);
    assert_int_equal(r->terms, s->terms);
    assert_true(r->seconds >= 0);

    parse_flint(f, r->f, ctx);
    assert_int_equal(fmpz_mpoly_total_degree_si(f, ctx), s->degree);
    assert_int_equal(fmpz_mpoly_length(f, ctx), s->terms);
    /* primitive, positive leading coefficient in lex x > y > z */
    fmpz_t c, g;
    fmpz_init(c);
    fmpz_init(g);
    for (slong i = 0; i < fmpz_mpoly_length(f, ctx); i++) {
        fmpz_mpoly_get_term_coeff_fmpz(c, f, i, ctx);
        fmpz_gcd(g, g, c);
    }
    assert_true(fmpz_is_one(g));
    fmpz_mpoly_get_term_coeff_fmpz(c, f, 0, ctx);
    assert_true(fmpz_sgn(c) > 0);
    fmpz_clear(c);
    fmpz_clear(g);

    /* irreducible over Q: one factor, multiplicity 1 */
    fmpz_mpoly_factor_t fac;
    fmpz_mpoly_factor_init(fac, ctx);
    assert_true(fmpz_mpoly_factor(fac, f, ctx));
    assert_int_equal(fac->num, 1);
    assert_true(fmpz_is_one(fac->exp + 0));
    fmpz_mpoly_factor_clear(fac, ctx);

    /* f_tape is the same polynomial */
    fmpz_mpoly_t h;
    fmpz_mpoly_init(h, ctx);
    parse_flint(h, r->f_tape, ctx);
    assert_true(fmpz_mpoly_equal(f, h, ctx));
    fmpz_mpoly_clear(h, ctx);

    /* f vanishes exactly at 50 random rational points of the map */
    mpq_t u, v, xyz[3], val;
    mpq_init(u);
    mpq_init(v);
    mpq_init(val);
    for (int k = 0; k < 3; k++)
        mpq_init(xyz[k]);
    int points = 0;
    for (int tries = 0; points < 50 && tries < 500; tries++) {
        random_rational(u);
        random_rational(v);
        if (imp_param_eval(p, u, v, xyz) != 0)
            continue; /* a pole */
        eval_mpq(val, f, ctx, xyz);
        if (mpq_sgn(val) != 0)
            fail_msg("%s by %s: f != 0 at u = %s, v = %s", s->name, imp_method_name(r->method),
                     mpq_get_str(NULL, 10, u), mpq_get_str(NULL, 10, v));
        points++;
    }
    assert_int_equal(points, 50);
    mpq_clear(u);
    mpq_clear(v);
    mpq_clear(val);
    for (int k = 0; k < 3; k++)
        mpq_clear(xyz[k]);

    /* both texts are expressions of ivoct's grammar, and mean f */
    check_tape(r->f, f, ctx);
    check_tape(r->f_tape, f, ctx);
}

static void test_surfaces(void **state)
{
    (void)state;
    fmpz_mpoly_ctx_t ctx;
    fmpz_mpoly_ctx_init(ctx, 3, ORD_LEX);
    for (size_t i = 0; i < N_SURFACES; i++) {
        const surface_t *s = SURFACES + i;
        imp_param_t *p = parse3(s->x, s->y, s->z);
        fmpz_mpoly_t f[2];
        for (int m = 0; m < 2; m++) {
            imp_method_t method = m ? IMP_GROEBNER : IMP_RESULTANT;
            imp_result_t r;
            ivoct_error_t err;
            int rc = imp_implicitize(p, method, NULL, &r, &err);
            if (rc != IMP_OK)
                fail_msg("%s by %s: rc %d: %s", s->name, imp_method_name(method), rc, err.msg);
            assert_int_equal(r.method, method);
            fmpz_mpoly_init(f[m], ctx);
            check_result(s, p, &r, f[m], ctx);
            /* a prime ideal: the Gröbner basis gives f itself */
            if (method == IMP_GROEBNER)
                assert_int_equal(r.n_removed, 0);
            for (size_t k = 0; k < r.n_removed; k++)
                assert_non_null(r.removed[k]);
            if (i == N_SURFACES - 1 && method == IMP_RESULTANT) {
                /* the nodal cubic's resultant: y^6 f^2 (README) */
                assert_int_equal(r.n_removed, 1);
                assert_string_equal(r.removed[0], "y^6");
            }
            if (i == 0 && method == IMP_RESULTANT)
                assert_true(r.n_removed >= 1);
            imp_result_free(&r);
            assert_null(r.f);
        }
        /* both methods: the same f (both primitive, positive leading coefficient) */
        assert_true(fmpz_mpoly_equal(f[0], f[1], ctx));
        fmpz_mpoly_clear(f[0], ctx);
        fmpz_mpoly_clear(f[1], ctx);
        imp_param_free(p);
    }
    fmpz_mpoly_ctx_clear(ctx);
    flint_cleanup();
}

static void test_auto(void **state)
{
    (void)state;
    imp_param_t *p = parse3(SURFACES[0].x, SURFACES[0].y, SURFACES[0].z);
    imp_result_t r;
    ivoct_error_t err;
    assert_int_equal(imp_implicitize(p, IMP_AUTO, NULL, &r, &err), IMP_OK);
    assert_int_equal(r.method, IMP_RESULTANT);
    assert_string_equal(r.f, "x^2 + y^2 + z^2 - 1");
    imp_result_free(&r);
    imp_result_free(NULL);
    imp_param_free(p);
    imp_param_free(NULL);
    flint_cleanup();
}

/* ---- budgets ----------------------------------------------------------------------------- */

static void expect_budget(const imp_param_t *p, imp_method_t m, double seconds, size_t bytes,
                          const char *want1, const char *want2)
{
    imp_budget_t b = {seconds, bytes};
    imp_result_t r;
    ivoct_error_t err;
    memset(&r, 0x5a, sizeof r);
    int rc = imp_implicitize(p, m, &b, &r, &err);
    if (rc != IMP_EBUDGET)
        fail_msg("%s with %g s, %zu bytes: rc %d (%s)", imp_method_name(m), seconds, bytes, rc,
                 rc ? err.msg : r.f);
    if (!strstr(err.msg, want1) || (want2 && !strstr(err.msg, want2)))
        fail_msg("message '%s', want '%s' and '%s'", err.msg, want1, want2 ? want2 : "");
    imp_result_t zero;
    memset(&zero, 0, sizeof zero);
    assert_memory_equal(&r, &zero, sizeof r);
}

/* Resultants with a budget of 0.3 s end with IMP_EBUDGET in at most 3 s (ten
 * times the budget: the sanitizer build and a shared machine are slow; every
 * map here takes seconds or minutes unbounded). */
static void expect_budget_kept(const char *x, const char *y, const char *z)
{
    imp_param_t *p = parse3(x, y, z);
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    expect_budget(p, IMP_RESULTANT, 0.3, 0, "implicitization by resultants: past the time budget of 0.3 s", NULL);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double took = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    if (took > 3.0)
        fail_msg("a budget of 0.3 s took %.2f s: %s, %s, %s", took, x, y, z);
    imp_param_free(p);
}

static void test_budget(void **state)
{
    (void)state;
    const surface_t *e = SURFACES + 4; /* Enneper */
    imp_param_t *p = parse3(e->x, e->y, e->z);
    expect_budget(p, IMP_RESULTANT, 1e-9, 0,
                  "implicitization by resultants: past the time budget of 1e-09 s", NULL);
    expect_budget(p, IMP_GROEBNER, 1e-9, 0,
                  "implicitization by Gröbner basis: past the time budget of 1e-09 s", NULL);
    expect_budget(p, IMP_AUTO, 1e-9, 0, "by resultants: past the time budget",
                  "then implicitization by Gröbner basis: past the time budget");
    expect_budget(p, IMP_RESULTANT, 0, 1, "implicitization by resultants", "past the memory budget of 1 bytes");
    expect_budget(p, IMP_GROEBNER, 0, 1, "implicitization by Gröbner basis", "past the memory budget of 1 bytes");
    expect_budget(p, IMP_AUTO, 0, 1, "resultants", "Gröbner basis");

    /* the time budget holds inside a resultant: this map's resultant in v
     * would take minutes (denominators of degree 8) */
    expect_budget_kept("2*u/(1+u^2+v^2)", "2*v/(u^8+v^6)", "(u^8+v^2)/(1+u^2+v^2)");
    /* within one elimination step of a pseudo-remainder: its coefficients
     * grow so large that, checked only between steps, the budget took 6.6 s */
    expect_budget_kept("5*u^7 - 2*u^3*v", "2*u^4*v^2",
                       "(3*u^5*v + 3*u^4*v^2 + u*v/3 + u^2*v^2 + u*v^4)/(1 + u^2 + v^4)^2");
    /* within the exact check: the resultants and the factorization end within
     * 0.3 s, the check that the factor vanishes on the map takes 3 s */
    expect_budget_kept("u^4*v + u^6 + u^3*v^10 + u^2*v^4/3 + v^6 - u^7*v^8",
                       "(u^3 + 2*u^2 + u*v^9/3 + u^4/3 + 5*u*v - v^3)/(1 + u^2 + v^2)^3", "v/3");

    /* a budget that is not one */
    imp_budget_t bad = {-1, 0};
    imp_result_t r;
    ivoct_error_t err;
    assert_int_equal(imp_implicitize(p, IMP_RESULTANT, &bad, &r, &err), IMP_EINPUT);
    assert_null(r.f);
    /* the defaults are plenty */
    imp_budget_t dflt = {0, 0};
    assert_int_equal(imp_implicitize(p, IMP_AUTO, &dflt, &r, &err), IMP_OK);
    assert_int_equal(r.degree, 9);
    imp_result_free(&r);
    imp_param_free(p);
    flint_cleanup();
}

/* ---- parsing ----------------------------------------------------------------------------- */

/* coordinate i of p at (u, v) = (a/b, c/d) equals n/m exactly */
static void expect_coord(const imp_param_t *p, int i, long a, long b, long c, long d, long n, long m)
{
    mpq_t u, v, xyz[3], want;
    mpq_init(u);
    mpq_init(v);
    mpq_init(want);
    for (int k = 0; k < 3; k++)
        mpq_init(xyz[k]);
    mpq_set_si(u, a, (unsigned long)b);
    mpq_set_si(v, c, (unsigned long)d);
    mpq_canonicalize(u);
    mpq_canonicalize(v);
    mpq_set_si(want, n, (unsigned long)m);
    mpq_canonicalize(want);
    assert_int_equal(imp_param_eval(p, u, v, xyz), 0);
    if (!mpq_equal(xyz[i], want))
        fail_msg("coordinate %d at (%ld/%ld, %ld/%ld) = %s, want %ld/%ld", i, a, b, c, d,
                 mpq_get_str(NULL, 10, xyz[i]), n, m);
    mpq_clear(u);
    mpq_clear(v);
    mpq_clear(want);
    for (int k = 0; k < 3; k++)
        mpq_clear(xyz[k]);
}

static void test_parse_values(void **state)
{
    (void)state;
    /* decimals are exact: 0.1 = 1/10, 2.5e-3 = 1/400, 1.5E+2 = 150 */
    imp_param_t *p = parse3("0.1*u + 2.5e-3", "1.5E+2*v - .5", "u*v");
    expect_coord(p, 0, 1, 1, 0, 1, 41, 400);
    expect_coord(p, 1, 0, 1, 1, 3, 99, 2);
    imp_param_free(p);
    /* precedence and signs: -u^2 = -(u^2), 2^3^2 = 2^9, u/v/2 = (u/v)/2, u^-2 */
    p = parse3("-u^2 + 2^3^2", "u/v/2", "u^-2 + (u+v)^0 + u^(-1) * v^+1");
    expect_coord(p, 0, 3, 1, 1, 1, 503, 1);
    expect_coord(p, 1, 3, 1, 5, 1, 3, 10);
    expect_coord(p, 2, 2, 1, 3, 1, 11, 4); /* 1/4 + 1 + 3/2 */
    imp_param_free(p);
    /* multi-line texts, blanks and a quotient that simplifies */
    p = parse3("(u^2 - v^2)\n  / (u - v)", "\tu *\n v\r\n", "(u^2+v^2+1)^2 / (1 + u^2 + v^2)");
    expect_coord(p, 0, 2, 1, 7, 1, 9, 1);
    expect_coord(p, 2, 1, 2, 1, 3, 49, 36);
    imp_param_free(p);
    /* the sphere at known points: (1, 2) -> (1/3, 2/3, 2/3) */
    p = parse3(SURFACES[0].x, SURFACES[0].y, SURFACES[0].z);
    expect_coord(p, 0, 1, 1, 2, 1, 1, 3);
    expect_coord(p, 1, 1, 1, 2, 1, 2, 3);
    expect_coord(p, 2, 1, 1, 2, 1, 2, 3);
    expect_coord(p, 2, -1, 2, 1, 3, -23, 49);
    imp_param_free(p);
    /* a pole: -1 and the point unchanged */
    p = parse3("1/u", "v", "u*v");
    mpq_t u, v, xyz[3];
    mpq_init(u);
    mpq_init(v);
    for (int k = 0; k < 3; k++) {
        mpq_init(xyz[k]);
        mpq_set_ui(xyz[k], 7, 1);
    }
    mpq_set_ui(v, 1, 2);
    assert_int_equal(imp_param_eval(p, u, v, xyz), -1);
    for (int k = 0; k < 3; k++) {
        assert_int_equal(mpq_cmp_ui(xyz[k], 7, 1), 0);
        mpq_clear(xyz[k]);
    }
    mpq_clear(u);
    mpq_clear(v);
    imp_param_free(p);
    flint_cleanup();
}

static void expect_parse_error(const char *x, const char *y, const char *z, int which, int line,
                               int col, const char *msg)
{
    const char *t[3] = {x, y, z};
    imp_param_t *p = (imp_param_t *)&p; /* must be set to NULL */
    int w = -1;
    ivoct_error_t err;
    int rc = imp_param_parse(t, &p, &w, &err);
    if (rc != IMP_EINPUT) {
        imp_param_free(rc == IMP_OK ? p : NULL);
        fail_msg("(%.60s, %.60s, %.60s): rc %d, want an input error '%s'", x, y, z, rc, msg);
    }
    assert_null(p);
    if (w != which || err.line != line || err.col != col || !strstr(err.msg, msg))
        fail_msg("(%.60s, %.60s, %.60s):\n   got coordinate %d, %d:%d: %s\n  want coordinate %d, "
                 "%d:%d: ...%s...",
                 x, y, z, w, err.line, err.col, err.msg, which, line, col, msg);
}

static void test_parse_errors(void **state)
{
    (void)state;
    expect_parse_error("u", "sin(u)", "v", 1, 1, 1,
                       "transcendental function 'sin' in a parametrization: only polynomials and "
                       "quotients of polynomials in u and v");
    expect_parse_error("u", "v", "2*exp(v)", 2, 1, 3, "transcendental function 'exp'");
    expect_parse_error("u + x", "v", "u", 0, 1, 5, "'x' in a parametrization: the parameters are u and v");
    expect_parse_error("u", "z*v", "u", 1, 1, 1, "'z' in a parametrization");
    expect_parse_error("pi*u", "v", "u", 0, 1, 1, "'pi' in a parametrization: coefficients are exact rationals");
    expect_parse_error("u", "v", "e^u", 2, 1, 1, "'e' in a parametrization");
    expect_parse_error("sqrt(u)", "v", "u", 0, 1, 1, "function 'sqrt' in a parametrization");
    expect_parse_error("u", "abs(v)", "u", 1, 1, 1, "function 'abs'");
    expect_parse_error("u", "v", "foo(u)", 2, 1, 1, "unknown function 'foo'");
    expect_parse_error("u", "w", "u", 1, 1, 1, "unknown name 'w'");
    expect_parse_error("U", "v", "u", 0, 1, 1, "did you mean 'u'?");
    expect_parse_error("u +\n  * v", "v", "u", 0, 2, 3, "expected an expression, found '*'");
    expect_parse_error("u", "u +\n  (v *\n   sin(u))", "v", 1, 3, 4, "transcendental function 'sin'");
    expect_parse_error("u", "v", "1/(u-u)", 2, 1, 2, "division by a polynomial that is identically 0");
    expect_parse_error("u", "v/0", "u", 1, 1, 2, "identically 0");
    expect_parse_error("u", "v", "(v-v)^-2", 2, 1, 6, "negative power of a polynomial that is identically 0");
    expect_parse_error("u^v", "v", "u", 0, 1, 3, "the exponent depends on u or v");
    expect_parse_error("u^(1/2)", "v", "u", 0, 1, 3, "the exponent is not an integer");
    expect_parse_error("u^0.5", "v", "u", 0, 1, 3, "not an integer");
    expect_parse_error("(u + v", "v", "u", 0, 1, 7, "expected ')' to close '(' opened at 1:1");
    expect_parse_error("u", "v)", "u", 1, 1, 2, "unexpected ')'");
    expect_parse_error("u", "v", "u v", 2, 1, 3, "trailing input");
    expect_parse_error("2u", "v", "u", 0, 1, 2, "implicit multiplication is not supported");
    expect_parse_error("u", "", "v", 1, 1, 1, "empty coordinate");
    expect_parse_error("u", "v", "  \n  ", 2, 2, 3, "empty coordinate");
    expect_parse_error("u # v", "v", "u", 0, 1, 3, "unexpected character '#'");
    expect_parse_error("u", "min(u, v)", "v", 1, 1, 1, "function 'min'");
    expect_parse_error("u", "v", "1.2.3", 2, 1, 4, "malformed number");
    expect_parse_error("u", "v", "1e+", 2, 1, 2, "malformed number: expected the digits of an exponent");
    expect_parse_error("(1+u)^100000", "v", "u", 0, 1, 6, "power too large");
    expect_parse_error("u", "u^65", "v", 1, 1, 2, "power too large");
    expect_parse_error("u", "v", "(u+1)^40*(v+1)^40", 2, 1, 9, "degree above the limit of 64");
    expect_parse_error("u", "1e100000*v", "u", 1, 1, 1, "number too large or too precise");
    expect_parse_error("u", "v", "u^1e30", 2, 1, 3, "exponent too large");
    /* the map as a whole: line 0 */
    expect_parse_error("1", "2.5", "-3", 0, 0, 0, "the parametrization is constant");
    expect_parse_error("u+v", "(u+v)^2", "(u+v)^3", 0, 0, 0, "is a curve, not a surface");
    expect_parse_error("u", "u^2", "1/(1+u)", 0, 0, 0, "is a curve");
    expect_parse_error("v", "3", "v^2 + v", 0, 0, 0, "is a curve");
    /* a missing text */
    expect_parse_error("u", NULL, "v", 1, 0, 0, "missing coordinate text");

    /* 100000 '(': an error, not a stack overflow */
    size_t n = 100000;
    char *deep = malloc(2 * n + 2);
    assert_non_null(deep);
    memset(deep, '(', n);
    deep[n] = 'u';
    memset(deep + n + 1, ')', n);
    deep[2 * n + 1] = '\0';
    expect_parse_error("u", "v", deep, 2, 1, IMP_MAX_NESTING + 1, "nested deeper than 1000 levels");
    memset(deep, '-', 2 * n + 1); /* a chain of signs nests too */
    deep[2 * n] = 'u';
    expect_parse_error(deep, "v", "u", 0, 1, IMP_MAX_NESTING + 1, "nested deeper");
    free(deep);
    /* longer than the limit */
    size_t len = IMP_MAX_TEXT + 2;
    char *lng = malloc(len + 1);
    assert_non_null(lng);
    for (size_t i = 0; i < len; i++)
        lng[i] = i % 2 ? '+' : 'u';
    lng[len] = '\0';
    lng[len - 1] = 'u';
    expect_parse_error("u", lng, "v", 1, 1, 1, "longer than the limit");
    free(lng);
    flint_cleanup();
}

static void test_method_names(void **state)
{
    (void)state;
    imp_method_t m;
    for (int i = 0; i < 3; i++) {
        assert_int_equal(imp_method_parse(imp_method_name((imp_method_t)i), &m), 0);
        assert_int_equal(m, i);
    }
    assert_string_equal(imp_method_name(IMP_GROEBNER), "groebner");
    assert_int_equal(imp_method_parse("wu-ritt", &m), -1);
    assert_int_equal(imp_method_parse(NULL, &m), -1);
}

/* ---- bounds ----------------------------------------------------------------------------- */

static void check_bounds(const imp_param_t *p, const char *name, double u0, double u1, double v0,
                         double v1)
{
    double u[2] = {u0, u1}, v[2] = {v0, v1}, box[6];
    ivoct_error_t err;
    if (imp_param_bounds(p, u, v, box, &err) != IMP_OK)
        fail_msg("%s: bounds: %s", name, err.msg);
    mpq_t qu, qv, xyz[3], b;
    mpq_init(qu);
    mpq_init(qv);
    mpq_init(b);
    for (int k = 0; k < 3; k++)
        mpq_init(xyz[k]);
    for (int j = 0; j < 200; j++) {
        /* the corners, then random points */
        double a = j < 4 ? (j & 1 ? u1 : u0) : u0 + (u1 - u0) * uniform();
        double c = j < 4 ? (j & 2 ? v1 : v0) : v0 + (v1 - v0) * uniform();
        mpq_set_d(qu, a);
        mpq_set_d(qv, c);
        assert_int_equal(imp_param_eval(p, qu, qv, xyz), 0);
        for (int k = 0; k < 3; k++) {
            mpq_set_d(b, box[2 * k]);
            if (mpq_cmp(b, xyz[k]) > 0)
                fail_msg("%s: coordinate %d at (%.17g, %.17g) below the box's %.17g", name, k, a, c, box[2 * k]);
            mpq_set_d(b, box[2 * k + 1]);
            if (mpq_cmp(b, xyz[k]) < 0)
                fail_msg("%s: coordinate %d at (%.17g, %.17g) above the box's %.17g", name, k, a, c, box[2 * k + 1]);
        }
    }
    mpq_clear(qu);
    mpq_clear(qv);
    mpq_clear(b);
    for (int k = 0; k < 3; k++)
        mpq_clear(xyz[k]);
}

static void test_bounds(void **state)
{
    (void)state;
    for (size_t i = 0; i < N_SURFACES; i++) {
        const surface_t *s = SURFACES + i;
        imp_param_t *p = parse3(s->x, s->y, s->z);
        check_bounds(p, s->name, -1, 1, -1, 1);
        check_bounds(p, s->name, 0.5, 2, -3, -1);
        check_bounds(p, s->name, 0.25, 0.25, -1, 1); /* a segment */
        imp_param_free(p);
    }
    /* tight: the sphere's patch [-1, 1]^2 has x in [-1, 1] and z in [-1, 1/3] */
    imp_param_t *p = parse3(SURFACES[0].x, SURFACES[0].y, SURFACES[0].z);
    double u[2] = {-1, 1}, v[2] = {-1, 1}, box[6];
    ivoct_error_t err;
    assert_int_equal(imp_param_bounds(p, u, v, box, &err), IMP_OK);
    assert_true(box[0] <= -1 && box[0] > -1.01 && box[1] >= 1 && box[1] < 1.01);
    assert_true(box[4] <= -1 && box[4] > -1.01 && box[5] >= 1.0 / 3 && box[5] < 0.34);
    /* invalid patches */
    double bad[2] = {1, -1}, nan2[2] = {0, NAN};
    assert_int_equal(imp_param_bounds(p, bad, v, box, &err), IMP_EINPUT);
    assert_int_equal(imp_param_bounds(p, u, nan2, box, &err), IMP_EINPUT);
    imp_param_free(p);
    /* a pole: x = 1/u on u in [-1, 1] */
    p = parse3("1/u", "v", "u*v");
    assert_int_equal(imp_param_bounds(p, u, v, box, &err), IMP_EINPUT);
    assert_non_null(strstr(err.msg, "the denominator of x may vanish on the patch"));
    check_bounds(p, "1/u", 0.5, 1, -1, 1);
    imp_param_free(p);
    flint_cleanup();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_parse_values), cmocka_unit_test(test_parse_errors),
        cmocka_unit_test(test_method_names), cmocka_unit_test(test_bounds),
        cmocka_unit_test(test_surfaces),     cmocka_unit_test(test_auto),
        cmocka_unit_test(test_budget),
    };
    int rc = cmocka_run_group_tests(tests, NULL, NULL);
    flint_cleanup_master();
    return rc;
}
