/* Scene files (scene/scene.c): a full scene, the defaults, and bad input of
 * every kind, each reported as "file:line:col: message" at the right place
 * and never a crash.  Files are written to a fresh directory under /tmp. */
#define _POSIX_C_SOURCE 200809L /* mkdtemp */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "../scene/scene.h"

#define BOX "box = -1 1 -1 1 -1 1\n"

static char dir[64];

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/tmp/ivoct-test-scene-XXXXXX");
    return mkdtemp(dir) ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    return rmdir(dir); /* every test removes its own files */
}

/* Write n bytes of text to dir/name; returns the path (static buffer). */
static const char *write_n(const char *name, const char *text, size_t n)
{
    static char path[128];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(text, 1, n, f), n);
    assert_int_equal(fclose(f), 0);
    return path;
}

static const char *write_file(const char *name, const char *text)
{
    return write_n(name, text, strlen(text));
}

/* Load text as dir/name and expect the formatted error "path:line:col: msg". */
static void expect_error_n(const char *name, const char *text, size_t n, int line, int col, const char *msg)
{
    const char *path = write_n(name, text, n);
    scene_t s;
    ivoct_error_t err;
    memset(&s, 0x5a, sizeof s); /* scene_load must zero it on failure */
    int rc = scene_load(path, &s, &err);
    char want[2048], got[2048];
    snprintf(want, sizeof want, "%s:%d:%d: %s", path, line, col, msg);
    ivoct_error_format(&err, got, sizeof got);
    if (rc == 0) {
        scene_free(&s);
        fail_msg("%s loaded, expected: %s", name, want);
    }
    scene_t zero;
    memset(&zero, 0, sizeof zero);
    assert_memory_equal(&s, &zero, sizeof s);
    scene_free(&s); /* harmless on a zeroed scene */
    remove(path);
    if (strcmp(got, want) != 0)
        fail_msg("%s:\n   got: %s\n  want: %s", name, got, want);
}

static void expect_error(const char *name, const char *text, int line, int col, const char *msg)
{
    expect_error_n(name, text, strlen(text), line, col, msg);
}

static void load_ok(const char *name, const char *text, scene_t *s)
{
    const char *path = write_file(name, text);
    ivoct_error_t err;
    if (scene_load(path, s, &err) != 0) {
        char buf[1024];
        fail_msg("%s: %s", name, ivoct_error_format(&err, buf, sizeof buf));
    }
    remove(path);
}

static void assert_vec(const double *v, double a, double b, double c)
{
    if (!(v[0] == a && v[1] == b && v[2] == c))
        fail_msg("(%g %g %g), want (%g %g %g)", v[0], v[1], v[2], a, b, c);
}

/* ---- valid scenes --------------------------------------------------------------------- */

static void test_full_scene(void **state)
{
    (void)state;
    scene_t s;
    load_ok("full.ini",
            "; a comment\n"
            "# another\n"
            "[surface]\n"
            "name = Gumdrop   torus ; inline comment\n"
            "let.r2 = y^2 + z^2\n"
            "f    = 4*(x^4 + r2^2) + 17*x^2*r2\n"
            "       - 20*(x^2 + y^2 + z^2 + k)  ; continues f\n"
            "\n"
            "       + 17\n"
            "let.k = 0.5 * 0\n"
            "box  = -2 2  -2.5 2.5, -0.3 0.3   ; xmin xmax ymin ymax zmin zmax\n"
            "[octree]\n"
            "depth  = 10\n"
            "tests  = interval, lipschitz,ilie\n"
            "refine = 1e-3\n"
            "[camera]\n"
            "eye = 5 4 3\n"
            "target: 0 0 0.5\n"
            "up = 0 1 0\n"
            "fov = 45\n"
            "size = 640 480\n"
            "[render]\n"
            "method = mrfro-newton\n"
            "light = -3 4.5 1e1\n",
            &s);
    assert_non_null(s.path);
    assert_string_equal(s.source.name, "Gumdrop   torus");
    assert_int_equal(s.source.n_lets, 2);
    assert_string_equal(s.source.let_names[0], "r2");
    assert_string_equal(s.source.let_texts[0], "y^2 + z^2");
    assert_string_equal(s.source.let_names[1], "k");
    assert_string_equal(s.source.let_texts[1], "0.5 * 0");
    assert_string_equal(s.source.f, "4*(x^4 + r2^2) + 17*x^2*r2\n- 20*(x^2 + y^2 + z^2 + k)\n+ 17");
    assert_non_null(s.tape);
    assert_true(s.tape->n > 5);
    /* box bounds are rounded outward when the decimal is not a double */
    assert_true(s.box[0] == -2 && s.box[1] == 2 && s.box[2] == -2.5 && s.box[3] == 2.5);
    /* the double nearest 0.3 is below 0.3: zmax is the next one up */
    assert_true(s.box[4] == nextafter(-0.3, -1));
    assert_true(s.box[5] == nextafter(0.3, 1));
    assert_int_equal(s.octree.depth, 10);
    assert_int_equal(s.octree.tests, OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ | OCT_TEST_ILIE);
    assert_true(s.octree.refine == 1e-3);
    assert_vec(s.camera.eye, 5, 4, 3);
    assert_vec(s.camera.target, 0, 0, 0.5);
    assert_vec(s.camera.up, 0, 1, 0);
    assert_true(s.camera.fov == 45);
    assert_int_equal(s.camera.width, 640);
    assert_int_equal(s.camera.height, 480);
    assert_string_equal(ray_method_name(s.method), "mrfro-newton");
    assert_int_equal(s.has_light, 1);
    assert_vec(s.light, -3, 4.5, 10);
    scene_free(&s);
    assert_null(s.tape);
}

static void test_defaults(void **state)
{
    (void)state;
    scene_t s;
    load_ok("my-sphere.ini", "[surface]\nf = x^2 + y^2 + z^2 - 1\nbox = 0 2 -1 1 -3 3\n", &s);
    assert_string_equal(s.source.name, "my-sphere");
    assert_int_equal(s.source.n_lets, 0);
    assert_null(s.source.let_names);
    assert_int_equal(s.octree.depth, 8);
    assert_int_equal(s.octree.tests, OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ);
    assert_true(s.octree.refine == 0);
    assert_vec(s.camera.target, 1, 0, 0);
    assert_vec(s.camera.up, 0, 0, 1);
    assert_true(s.camera.fov == 30);
    assert_int_equal(s.camera.width, 300);
    assert_int_equal(s.camera.height, 300);
    assert_string_equal(ray_method_name(s.method), "newton-ah");
    assert_int_equal(s.has_light, 0);
    /* the eye looks at the centre from (1, 0.8, 0.6), and the box's
     * circumscribed sphere fits in the field of view */
    double d[3], len = 0;
    for (int i = 0; i < 3; i++) {
        d[i] = s.camera.eye[i] - s.camera.target[i];
        len += d[i] * d[i];
    }
    len = sqrt(len);
    assert_true(fabs(d[0] / len - 1 / sqrt(2)) < 1e-12);
    assert_true(fabs(d[1] / len - 0.8 / sqrt(2)) < 1e-12);
    double radius = 0.5 * sqrt(4 + 4 + 36);
    assert_true(radius / len < sin(15 * 3.14159265358979323846 / 180));
    scene_free(&s);

    /* eye given, target defaulted to the box centre; a name with no .ini */
    load_ok("plain", "[surface]\nf = x\nbox = -1 1 -1 1 -1 1\n[camera]\neye = 3 0 0\n", &s);
    assert_string_equal(s.source.name, "plain");
    assert_vec(s.camera.eye, 3, 0, 0);
    assert_vec(s.camera.target, 0, 0, 0);
    scene_free(&s);

    /* a name on a continuation line */
    load_ok("n.ini", "[surface]\nname =\n   My   surface  \n   again ; comment\nf = x\n" BOX, &s);
    assert_string_equal(s.source.name, "My   surface again");
    scene_free(&s);

    /* the largest depth and size: the octree's and the renderer's limits */
    load_ok("max.ini", "[surface]\nf = x\n" BOX "[octree]\ndepth = 21\n[camera]\nsize = 65536 1\n", &s);
    assert_int_equal(s.octree.depth, OCT_MAX_DEPTH);
    assert_int_equal(s.camera.width, RAY_MAX_SIZE);
    assert_int_equal(s.camera.height, 1);
    scene_free(&s);

    /* CRLF line ends, a byte order mark, ':' as separator, a point box */
    load_ok("crlf.ini", "\xEF\xBB\xBF[surface]\r\nf: x + y\r\nbox = 1 1 2 2 3 3\r\n", &s);
    assert_string_equal(s.source.f, "x + y");
    assert_vec(s.camera.target, 1, 2, 3);
    assert_true(s.camera.eye[0] > 1);
    scene_free(&s);
    scene_free(NULL);
}

/* ---- errors --------------------------------------------------------------------------- */

static void test_errors(void **state)
{
    (void)state;
    static const struct {
        const char *text;
        int line, col;
        const char *msg;
    } cases[] = {
        {"", 1, 1, "empty scene file, expected a [surface] section"},
        {"; just a comment\n\n   \n# and another\n", 1, 1, "empty scene file, expected a [surface] section"},
        {"[octree]\ndepth = 3\n", 1, 1, "missing [surface] section"},
        {"[surface]\n" BOX, 1, 1,
         "missing [surface] f (or param.x, param.y and param.z for a parametric surface)"},
        {"[surface]\nf = x\n", 1, 1, "missing [surface] box"},
        {"f = x\n", 1, 1, "key 'f' before any section; expected a [surface] section first"},
        {"[surface]\nf = x\n" BOX "colour = red\n", 4, 1,
         "unknown key 'colour' in [surface]; expected name, f, box, let.NAME, param.x, param.y, param.z, u, v or implicitize"},
        {"[surface]\nf = x\n" BOX "[octree]\ndeep = 3\n", 5, 1,
         "unknown key 'deep' in [octree]; expected depth, tests or refine"},
        /* an indented key continues the key above it */
        {"[surface]\nf = x\n" BOX "[octree]\n  tests = ilie\n  depth = 3\n", 6, 3,
         "tests: expected ',' between test names (this indented line continues 'tests' from line 5; a "
         "key must start its line)"},
        {"[surface]\nf = x\n" BOX "[camera]\nmethod = newton\n", 5, 1,
         "unknown key 'method' in [camera]; expected eye, target, up, fov or size"},
        {"[surface]\nf = x\n" BOX "[colors]\nred = 1\n", 4, 1,
         "unknown section [colors]; expected [surface], [octree], [camera] or [render]"},
        {"[surface]\nf = x\n" BOX "[Surface]\n", 4, 1,
         "unknown section [Surface]; expected [surface], [octree], [camera] or [render]"},
        {"[surface] extra\nf = x\n", 1, 11, "unexpected text after the section header [surface]"},
        {"[surface]\nf = x\nf = y\n" BOX, 3, 1, "duplicate key 'f' (first given at line 2)"},
        {"[surface\nf = x\n", 1, 1, "expected ']' to close the section name"},
        {"[surface]\nf x + y\n", 2, 1, "expected 'key = value' (no '=' or ':' found)"},
        /* expressions */
        {"[surface]\nf = sine(x)\n" BOX, 2, 5, "unknown function 'sine'"},
        {"[surface]\nf   =   (x + (y*2)\n" BOX, 2, 19, "expected ')' to close '(' opened at 2:9"},
        {"[surface]\nf = x + y)\n" BOX, 2, 10, "unexpected ')'"},
        {"[surface]\nf = x + y z\n" BOX, 2, 11, "trailing input after expression"},
        {"[surface]\nf =\n" BOX, 2, 4, "expected an expression, found end of input"},
        {"[surface]\nf = x +   ; comment\n" BOX, 2, 8, "expected an expression, found end of input"},
        /* a multi-line f: the error is on the file line of its piece */
        {"[surface]\nf = x*x +\n    y*y + ) \n" BOX, 3, 11, "expected an expression, found ')'"},
        {"[surface]\nf = (x +\n\n  ; comment\n\t(y\n  ) + sin(z)\n" BOX, 6, 13,
         "expected ')' to close '(' opened at 2:5"},
        {"[surface]\nf = (x +\n\t(y\n  ) + sin(z  ; comment\n" BOX, 4, 12,
         "expected ')' to close '(' opened at 4:10"},
        {"[surface]\nf = (x +\n  y\n" BOX, 3, 4, "expected ')' to close '(' opened at 2:5"},
        {"[surface]\nf = x +\n  box = -1 1 -1 1 -1 1\n", 3, 7,
         "unexpected character '=' (this indented line continues 'f' from line 2; a key must start its line)"},
        /* lets */
        {"[surface]\nlet.r2 = x^2 + y^2\nlet.r2 = 1\nf = r2 - 1\n" BOX, 3, 5, "name 'r2' is already defined"},
        {"[surface]\nlet.sin = x\nf = 1\n" BOX, 2, 5, "'sin' is reserved: it is a function"},
        {"[surface]\nlet.x = 1\nf = 1\n" BOX, 2, 5, "'x' is reserved: it is a variable"},
        {"[surface]\nlet.2r = 1\nf = 1\n" BOX, 2, 5,
         "invalid name '2r': a name is a letter or '_' followed by letters, digits or '_'"},
        {"[surface]\nf = r2 - 1\nlet.r2 = x^2 +\n   w\n" BOX, 4, 4, "unknown name 'w'"},
        {"[surface]\nf = r3 - 1\nlet.r2 = 1\n" BOX, 2, 5, "unknown name 'r3'"},
        {"[surface]\nlet.a = b\nlet.b = 1\nf = a\n" BOX, 2, 9, "unknown name 'b'"},
        /* box */
        {"[surface]\nf = x\nbox = 2 1 -1 1 -1 1\n", 3, 7, "box: xmin 2 > xmax 1"},
        {"[surface]\nf = x\nbox = -1 1 -1 1 0.5 0.25\n", 3, 17, "box: zmin 0.5 > zmax 0.25"},
        {"[surface]\nf = x\nbox = -1 1 nan 1 -1 1\n", 3, 12, "box: NaN is not allowed"},
        {"[surface]\nf = x\nbox = -1 1 -NaN 1 -1 1\n", 3, 12, "box: NaN is not allowed"},
        {"[surface]\nf = x\nbox = -1 1 -1 inf -1 1\n", 3, 15, "box: infinite values are not allowed, found 'inf'"},
        {"[surface]\nf = x\nbox = -Infinity 1 -1 1 -1 1\n", 3, 7,
         "box: infinite values are not allowed, found '-Infinity'"},
        {"[surface]\nf = x\nbox = -1 1 -1 1 -1 1e999\n", 3, 20, "box: number out of range"},
        {"[surface]\nf = x\nbox = -1 1 -1 1 -1\n", 3, 19,
         "box takes 6 numbers (xmin xmax ymin ymax zmin zmax), found 5"},
        {"[surface]\nf = x\nbox =\n", 3, 6, "box takes 6 numbers (xmin xmax ymin ymax zmin zmax), found 0"},
        {"[surface]\nf = x\nbox = -1 1 -1 1 -1 1 7\n", 3, 22,
         "box takes 6 numbers (xmin xmax ymin ymax zmin zmax), found more"},
        {"[surface]\nf = x\nbox = 0x10 1 -1 1 -1 1\n", 3, 7, "box: expected a number, found '0x10'"},
        {"[surface]\nf = x\nbox = -1 1 -1 1 -1 1\n  depth = 3\n", 4, 3,
         "box takes 6 numbers (xmin xmax ymin ymax zmin zmax), found more (this indented line continues "
         "'box' from line 3; a key must start its line)"},
        /* other values */
        {"[surface]\nname =\nf = x\n" BOX, 2, 7, "name: expected a name"},
        /* the octree's limit, OCT_MAX_DEPTH = 21 */
        {"[surface]\nf = x\n" BOX "[octree]\ndepth = 22\n", 5, 9, "depth: expected an integer from 0 to 21, found '22'"},
        {"[surface]\nf = x\n" BOX "[octree]\ndepth = 25\n", 5, 9, "depth: expected an integer from 0 to 21, found '25'"},
        {"[surface]\nf = x\n" BOX "[octree]\ndepth = 8.5\n", 5, 9, "depth: expected an integer from 0 to 21, found '8.5'"},
        {"[surface]\nf = x\n" BOX "[octree]\ndepth = -1\n", 5, 9, "depth: expected an integer from 0 to 21, found '-1'"},
        {"[surface]\nf = x\n" BOX "[octree]\ndepth = 99999999999999999999\n", 5, 9,
         "depth: expected an integer from 0 to 21, found '99999999999999999999'"},
        {"[surface]\nf = x\n" BOX "[octree]\ntests = interval, foo\n", 5, 19,
         "tests: unknown test 'foo'; expected interval, lipschitz or ilie"},
        {"[surface]\nf = x\n" BOX "[octree]\ntests =\n", 5, 8, "tests: expected a test name: interval, lipschitz or ilie"},
        {"[surface]\nf = x\n" BOX "[octree]\ntests = interval,\n  lipschitz ilie\n", 6, 13,
         "tests: expected ',' between test names"},
        {"[surface]\nf = x\n" BOX "[octree]\nrefine = -0.1\n", 5, 10, "refine: expected a length >= 0 (0 = off)"},
        {"[surface]\nf = x\n" BOX "[render]\nmethod = raytrace\n", 5, 10,
         "unknown method 'raytrace'; expected mitchell, newton, newton-ah, mrfro, mrfro-newton, lipschitz "
         "or sampling"},
        {"[surface]\nf = x\n" BOX "[render]\nmethod = newton mitchell\n", 5, 17,
         "method: expected one method name, found more"},
        {"[surface]\nf = x\n" BOX "[render]\nlight = 1 2\n", 5, 12,
         "light takes 3 numbers (x y z of a point light), found 2"},
        {"[surface]\nf = x\n" BOX "[render]\nlight = 1 2 inf\n", 5, 13,
         "light: infinite values are not allowed, found 'inf'"},
        {"[surface]\nf = x\n" BOX "[render]\nlight = 1 2 3 4\n", 5, 15,
         "light takes 3 numbers (x y z of a point light), found more"},
        {"[surface]\nf = x\n" BOX "[render]\nlamp = 1 2 3\n", 5, 1,
         "unknown key 'lamp' in [render]; expected method or light"},
        /* the renderer's limit, RAY_MAX_SIZE = 65536 */
        {"[surface]\nf = x\n" BOX "[camera]\nsize = 300 65537\n", 5, 12,
         "size: expected an integer from 1 to 65536, found '65537'"},
        {"[surface]\nf = x\n" BOX "[camera]\nsize = 0 300\n", 5, 8, "size: expected an integer from 1 to 65536, found '0'"},
        {"[surface]\nf = x\n" BOX "[camera]\nsize = 300\n", 5, 11,
         "size takes 2 integers (width height in pixels), found 1"},
        {"[surface]\nf = x\n" BOX "[camera]\nfov = 180\n", 5, 7,
         "camera: fov must be between 0 and 180 degrees (exclusive), got 180"},
        {"[surface]\nf = x\n" BOX "[camera]\nfov = 0\n", 5, 7,
         "camera: fov must be between 0 and 180 degrees (exclusive), got 0"},
        {"[surface]\nf = x\n" BOX "[camera]\neye = 1 2\n", 5, 10, "eye takes 3 numbers (x y z), found 2"},
        {"[surface]\nf = x\n" BOX "[camera]\neye = 0 0 5\n", 5, 7,
         "camera: up is parallel to the view direction (target - eye)"},
        {"[surface]\nf = x\n" BOX "[camera]\nup = 0 0 0\n", 5, 6, "camera: up must be a non-zero vector"},
        {"[surface]\nf = x\n" BOX "[camera]\neye = 1 1 1\ntarget = 1 1 1\n", 5, 7,
         "camera: eye and target must be distinct finite points"},
        /* the first error in the file wins over later ones */
        {"[surface]\nf = sine(x)\nbox = 2 1 -1 1 -1 1\n", 2, 5, "unknown function 'sine'"},
        {"[surface]\nf = x\nbox = -1 1 -1 1 -1 1 2\nlet.a = w\n", 3, 22,
         "box takes 6 numbers (xmin xmax ymin ymax zmin zmax), found more"},
        /* after a structural error, expressions are not compiled: r2 is unknown only
         * because line 4 was not read */
        {"[surface]\nf = r2 - 1\nbogus = 1\nlet.r2 = 1\n" BOX, 3, 1,
         "unknown key 'bogus' in [surface]; expected name, f, box, let.NAME, param.x, param.y, param.z, u, v or implicitize"},
        {"[surface]\nbox = -1 1 -1 1 -1 1 2\n[octree]\nbogus = 1\n", 2, 22,
         "box takes 6 numbers (xmin xmax ymin ymax zmin zmax), found more"},
        {"[surface]\nf = x\nbox = 2 1 -1 1 -1 1\n[octree]\nbogus = 1\n", 3, 7, "box: xmin 2 > xmax 1"},
        {"[surface]\nf = x\nbogus = 1\n[colors]\n", 3, 1,
         "unknown key 'bogus' in [surface]; expected name, f, box, let.NAME, param.x, param.y, param.z, u, v or implicitize"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char name[32];
        snprintf(name, sizeof name, "bad%zu.ini", i);
        expect_error(name, cases[i].text, cases[i].line, cases[i].col, cases[i].msg);
    }
    static const char nul[] = "[surface]\nf = x\0y\n" BOX;
    expect_error_n("nul.ini", nul, sizeof nul - 1, 2, 6, "NUL byte in the scene file (is it a text file?)");
}

static void test_cannot_open(void **state)
{
    (void)state;
    char path[128];
    snprintf(path, sizeof path, "%s/does-not-exist.ini", dir);
    scene_t s;
    ivoct_error_t err;
    assert_int_not_equal(scene_load(path, &s, &err), 0);
    char want[256], got[512];
    snprintf(want, sizeof want, "%s: cannot open file: No such file or directory", path);
    assert_string_equal(ivoct_error_format(&err, got, sizeof got), want);
    assert_int_equal(err.line, 0);
    /* a directory opens but cannot be read */
    assert_int_not_equal(scene_load(dir, &s, &err), 0);
    assert_int_equal(err.line, 0);
    assert_null(s.tape);
}

static char *build(const char *pre, const char *mid, size_t nmid, const char *post)
{
    size_t lp = strlen(pre), lm = strlen(mid), lq = strlen(post);
    char *s = malloc(lp + lm * nmid + lq + 1), *p = s;
    assert_non_null(s);
    memcpy(p, pre, lp);
    p += lp;
    for (size_t i = 0; i < nmid; i++, p += lm)
        memcpy(p, mid, lm);
    memcpy(p, post, lq + 1);
    return s;
}

static void test_limits(void **state)
{
    (void)state;
    /* 100 000 nested parentheses: refused at the 1001st */
    char *open = build("", "(", 100000, ""), *close = build("", ")", 100000, "");
    char *text = build("[surface]\nf = ", open, 1, "");
    char *t2 = build(text, "x", 1, close);
    char *t3 = build(t2, "\n" BOX, 1, "");
    expect_error("deep.ini", t3, 2, 4 + TAPE_MAX_NESTING + 1, "expression nested deeper than 1000 levels");
    free(open);
    free(close);
    free(text);
    free(t2);
    free(t3);
    /* a 10 MB line */
    text = build("[surface]\nf = ", "x+", 5000000, "x\n" BOX);
    expect_error("huge.ini", text, 2, 1, "line is 10000005 bytes long; the limit is 1048576 bytes");
    free(text);
    /* a 10 MB comment line is refused too: libinih must never split a line */
    text = build("[surface]\nf = x\n" BOX ";", " ", 10000000, "\n");
    expect_error("comment.ini", text, 4, 1, "line is 10000001 bytes long; the limit is 1048576 bytes");
    free(text);
    /* a long but acceptable line: about 1 MB of x+x+...+x */
    text = build("[surface]\nf = ", "x+", 500000, "x\n" BOX);
    scene_t s;
    load_ok("long.ini", text, &s);
    assert_int_equal(s.tape->n, 500001);
    scene_free(&s);
    free(text);
    /* an f spread over many lines, over TAPE_MAX_TEXT in all */
    text = build("[surface]\nf = x\n", "  + x + x + x + x + x + x + x + x + x + x + x + x + x\n", 30000, BOX);
    expect_error("many.ini", text, 2, 5, "expression longer than the limit of 1048576 bytes");
    free(text);
}

/* ---- scene_from_expr and the test lists ------------------------------------------- */

static void test_from_expr(void **state)
{
    (void)state;
    static const double box[6] = {-1, 1, -2, 2, 0, 4};
    scene_t s;
    ivoct_error_t err;
    assert_int_equal(scene_from_expr("x^2 + y^2 - z", box, &s, &err), 0);
    assert_null(s.path);
    assert_string_equal(s.source.f, "x^2 + y^2 - z");
    assert_non_null(s.source.name);
    assert_non_null(s.tape);
    assert_int_equal(s.octree.depth, 8);
    assert_string_equal(ray_method_name(s.method), "newton-ah");
    assert_vec(s.camera.target, 0, 0, 2);
    assert_true(memcmp(s.box, box, sizeof box) == 0);
    scene_free(&s);

    char buf[600];
    assert_int_not_equal(scene_from_expr("x +\n  sin(", box, &s, &err), 0);
    assert_string_equal(ivoct_error_format(&err, buf, sizeof buf), "2:7: expected an expression, found end of input");
    assert_string_equal(err.file, "");
    assert_null(s.tape);
    static const double bad[6] = {-1, 1, 3, 2, 0, 4};
    assert_int_not_equal(scene_from_expr("x", bad, &s, &err), 0);
    assert_string_equal(ivoct_error_format(&err, buf, sizeof buf), "box: ymin 3 > ymax 2");
    static const double nanbox[6] = {-1, 1, NAN, 2, 0, 4};
    assert_int_not_equal(scene_from_expr("x", nanbox, &s, &err), 0);
    assert_string_equal(err.msg, "box: the bounds must be finite numbers");
}

static void test_tests_list(void **state)
{
    (void)state;
    unsigned m = 0;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    assert_int_equal(oct_tests_parse("interval, lipschitz", &m, &err), 0);
    assert_int_equal(m, OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ);
    assert_int_equal(oct_tests_parse(" ilie ", &m, &err), 0);
    assert_int_equal(m, OCT_TEST_ILIE);
    assert_int_equal(oct_tests_parse("ilie,interval,ilie", &m, &err), 0);
    assert_int_equal(m, OCT_TEST_ILIE | OCT_TEST_INTERVAL);
    static const struct {
        const char *text;
        int col;
        const char *msg;
    } bad[] = {
        {"", 1, "expected a test name: interval, lipschitz or ilie"},
        {"interval,,ilie", 10, "expected a test name: interval, lipschitz or ilie"},
        {"interval,", 10, "expected a test name: interval, lipschitz or ilie"},
        {"interval lipschitz", 10, "expected ',' between test names"},
        {"Interval", 1, "unknown test 'Interval'; expected interval, lipschitz or ilie"},
        {"interval, newton", 11, "unknown test 'newton'; expected interval, lipschitz or ilie"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        m = 12345;
        assert_int_not_equal(oct_tests_parse(bad[i].text, &m, &err), 0);
        assert_int_equal(m, 12345);
        assert_int_equal(err.line, 1);
        assert_int_equal(err.col, bad[i].col);
        assert_string_equal(err.msg, bad[i].msg);
    }
    char buf[64];
    assert_string_equal(oct_tests_format(7, buf, sizeof buf), "interval, lipschitz, ilie");
    assert_string_equal(oct_tests_format(OCT_TEST_LIPSCHITZ | OCT_TEST_ILIE, buf, sizeof buf),
                        "lipschitz, ilie");
    assert_string_equal(oct_tests_format(0, buf, sizeof buf), "");
    /* round trip */
    assert_int_equal(oct_tests_parse(oct_tests_format(5, buf, sizeof buf), &m, &err), 0);
    assert_int_equal(m, 5);
    /* a short buffer is never overrun */
    char small[12];
    memset(small, 'z', sizeof small);
    oct_tests_format(7, small, 10);
    assert_true(strlen(small) < 10);
    assert_int_equal(small[10], 'z');
}

/* Every scene shipped in scenes/ loads. */
/* ---- parametric surfaces -------------------------------------------------------------- */

#define STEREO                                                                               \
    "param.x = 2*u/(1 + u^2 + v^2)\n"                                                         \
    "param.y = 2*v/(1 + u^2 + v^2)\n"                                                         \
    "param.z = (u^2 + v^2 - 1)/(1 + u^2 + v^2)\n"

/* f of the scene at a point (plain double evaluation of its tape) */
static double f_at(const scene_t *s, double x, double y, double z)
{
    tape_ws_t *ws = tape_ws_new(s->tape->n);
    assert_non_null(ws);
    double out;
    tape_eval_point(s->tape, ws, 1, &x, &y, &z, &out);
    tape_ws_free(ws);
    return out;
}

static void test_parametric(void **state)
{
    (void)state;
    scene_t s;
    /* the sphere by stereographic projection: f found, compiled, stored with the parametrization */
    load_ok("stereo.ini", "[surface]\n" STEREO "u = -3 3\nv = -2 2\n" BOX, &s);
    assert_non_null(s.implicit);
    assert_int_equal(s.implicit->degree, 2);
    assert_int_equal(s.implicit->terms, 4);
    assert_string_equal(s.source.f, s.implicit->f_tape);
    assert_string_equal(s.source.param[0], "2*u/(1 + u^2 + v^2)");
    assert_string_equal(s.source.param[2], "(u^2 + v^2 - 1)/(1 + u^2 + v^2)");
    assert_true(s.source.patch[0] == -3 && s.source.patch[1] == 3);
    assert_true(s.source.patch[2] == -2 && s.source.patch[3] == 2);
    assert_true(f_at(&s, 1, 0, 0) == 0 && f_at(&s, 0, 0.6, 0.8) == 0);
    assert_true(f_at(&s, 0, 0, 0) != 0);
    assert_memory_equal(s.box, ((double[6]){-1, 1, -1, 1, -1, 1}), sizeof s.box);
    scene_free(&s);

    /* no box: the patch bounds one, which holds the patch's points with a margin */
    load_ok("umbrella.ini", "[surface]\nparam.x = u*v\nparam.y = u\nparam.z = v^2\n"
            "u = -1 1\nv = -0.5 2\nimplicitize = groebner\n", &s);
    assert_int_equal(s.implicit->method, IMP_GROEBNER);
    assert_int_equal(s.implicit->degree, 3);
    double want[6] = {-2, 2, -1, 1, 0, 4};
    for (int k = 0; k < 6; k++) {
        assert_true(k % 2 ? s.box[k] >= want[k] : s.box[k] <= want[k]);
        assert_true(fabs(s.box[k] - want[k]) < 0.2 + 1e-9);
    }
    assert_true(s.source.patch[2] == -0.5 && s.source.patch[3] == 2);
    for (int k = 0; k < 5; k++) { /* points of the patch are on f = 0 */
        double u = -1 + 0.5 * k, v = -0.5 + 0.625 * k;
        assert_true(fabs(f_at(&s, u * v, u, v * v)) < 1e-12);
    }
    scene_free(&s);

    /* options: the method forced, a budget too small is a runtime failure */
    const char *path = write_file("opt.ini", "[surface]\n" STEREO "implicitize = groebner\n" BOX);
    ivoct_error_t err;
    scene_options_t opt = {.implicitize = IMP_RESULTANT};
    assert_int_equal(scene_load_with(path, &opt, &s, &err), 0);
    assert_int_equal(s.implicit->method, IMP_RESULTANT);
    scene_free(&s);
    opt.implicitize = -1;
    assert_int_equal(scene_load_with(path, &opt, &s, &err), 0);
    assert_int_equal(s.implicit->method, IMP_GROEBNER);
    scene_free(&s);
    opt.budget.seconds = 1e-9;
    assert_int_equal(scene_load_with(path, &opt, &s, &err), SCENE_ERUNTIME);
    assert_int_equal(err.line, 2); /* at param.x's value */
    assert_int_equal(err.col, 11);
    assert_non_null(strstr(err.msg, "budget"));
    remove(path);

    /* the file's shape */
    expect_error("both.ini", "[surface]\nf = x\n" STEREO BOX, 2, 1,
                 "f and param.x, param.y, param.z: a surface is either implicit (f) or parametric "
                 "(param.x, param.y, param.z), not both");
    expect_error("part.ini", "[surface]\nparam.x = u\nparam.z = v\n" BOX, 2, 1,
                 "missing [surface] param.y: a parametric surface needs param.x, param.y and "
                 "param.z");
    expect_error("let.ini", "[surface]\nlet.r = u\n" STEREO BOX, 2, 1,
                 "let.r: named subexpressions are for f; a parametrization is written out");
    expect_error("u-only.ini", "[surface]\nf = x\n" BOX "u = 0 1\n", 4, 1,
                 "u: only for a parametric surface (param.x, param.y, param.z)");
    expect_error("method-only.ini", "[surface]\nf = x\n" BOX "implicitize = auto\n", 4, 1,
                 "implicitize: only for a parametric surface (param.x, param.y, param.z)");
    expect_error("u-order.ini", "[surface]\n" STEREO "u = 1 0\n" BOX, 5, 5,
                 "u: u0 1 must be below u1 0");
    expect_error("v-count.ini", "[surface]\n" STEREO "v = 1\n" BOX, 5, 6,
                 "v takes 2 numbers (v0 v1), found 1");
    expect_error("method.ini", "[surface]\n" STEREO "implicitize = wu-ritt\n" BOX, 5, 15,
                 "implicitize: unknown method 'wu-ritt'; expected auto, resultant or groebner");
    expect_error("nobox.ini", "[surface]\n" STEREO "u = 0 1\n", 1, 1,
                 "missing [surface] box (or u and v: the patch of the parametrization, which "
                 "bounds one)");

    /* errors of implicit/, at their file positions (continuation lines too) */
    static const struct {
        const char *text;
        int line, col;
        const char *words;
    } cases[] = {
        {"[surface]\nparam.x = u\nparam.y = 2*v/(1 + sin(u))\nparam.z = v\n" BOX, 3, 20, "sin"},
        {"[surface]\nparam.x = u\nparam.y = v\nparam.z = u +\n   x*v\n" BOX, 5, 4, "'x'"},
        {"[surface]\nparam.x = u\nparam.y = v\nparam.z = (u\n" BOX, 4, 13, "opened at 4:11"},
        /* the image is not a surface: reported at param.x's value */
        {"[surface]\nparam.x = 1\nparam.y = 2\nparam.z = 3\n" BOX, 2, 11, "constant"},
        {"[surface]\nparam.x = u+v\nparam.y = (u+v)^2\nparam.z = (u+v)^3\n" BOX, 2, 11, "curve"},
        /* a pole in the patch that bounds the box */
        {"[surface]\nparam.x = 1/u\nparam.y = v\nparam.z = u\nu = -1 1\nv = 0 1\n", 2, 11,
         "pole"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        path = write_file("bad-param.ini", cases[i].text);
        memset(&s, 0x5a, sizeof s);
        int rc = scene_load(path, &s, &err);
        char got[1024];
        ivoct_error_format(&err, got, sizeof got);
        if (rc != SCENE_EINPUT || err.line != cases[i].line || err.col != cases[i].col ||
            !strstr(err.msg, cases[i].words))
            fail_msg("case %zu: rc %d, got %s; want %d:%d with '%s'", i, rc, got, cases[i].line,
                     cases[i].col, cases[i].words);
        printf("  %s\n", got);
        remove(path);
    }
}

static void test_shipped_scenes(void **state)
{
    (void)state;
    static const char *const names[] = {"sphere", "gumdrop", "blobs", "barth-sextic", "csg-64-spheres"};
    const char *src = getenv("IVOCT_SOURCE_DIR");
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        char path[512];
        snprintf(path, sizeof path, "%s/scenes/%s.ini", src ? src : ".", names[i]);
        if (access(path, R_OK) != 0)
            continue; /* run from elsewhere than the source tree */
        scene_t s;
        ivoct_error_t err;
        char buf[1024];
        if (scene_load(path, &s, &err) != 0)
            fail_msg("%s", ivoct_error_format(&err, buf, sizeof buf));
        assert_non_null(s.tape);
        scene_free(&s);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_full_scene), cmocka_unit_test(test_defaults),
        cmocka_unit_test(test_errors),     cmocka_unit_test(test_cannot_open),
        cmocka_unit_test(test_limits),     cmocka_unit_test(test_from_expr),
        cmocka_unit_test(test_tests_list), cmocka_unit_test(test_shipped_scenes),
        cmocka_unit_test(test_parametric),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
