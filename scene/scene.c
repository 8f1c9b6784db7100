/* ivoct — scene files: the scene itself.
 *
 * Its sections and keys, the defaults, and how the stored values (ini.c reads
 * the file, values.c parses each value) become a scene: the octree settings
 * (oct_params_t), the camera (set up and checked by ray_camera_init) and the
 * method, then the lets (in file order) and f compiled to a tape.  A value
 * that spans lines is joined with '\n', so an error at (line k, column c) of
 * the joined text is at column piece[k].col + c - 1 of file line piece[k].line.
 * The error reported is the first in the file, except that expressions are
 * compiled only when the file's structure (sections, keys) is sound, the keys
 * that are missing are reported only when nothing else is wrong, and the
 * camera is checked last, as a whole (at the key that takes part in the
 * problem). */
#include <float.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scene_internal.h"

/* ---- sections and keys -------------------------------------------------------------- */

static const char *const SECTION_NAMES[] = {"", "surface", "octree", "camera", "render", ""};

const char scene_sections_expected[] = "[surface], [octree], [camera] or [render]";

static const struct {
    int sec;
    const char *key;
} KEYS[K_COUNT] = {
    [K_NAME] = {SEC_SURFACE, "name"},   [K_F] = {SEC_SURFACE, "f"},
    [K_BOX] = {SEC_SURFACE, "box"},     [K_PARAM_X] = {SEC_SURFACE, "param.x"},
    [K_PARAM_Y] = {SEC_SURFACE, "param.y"}, [K_PARAM_Z] = {SEC_SURFACE, "param.z"},
    [K_U] = {SEC_SURFACE, "u"},         [K_V] = {SEC_SURFACE, "v"},
    [K_IMPLICITIZE] = {SEC_SURFACE, "implicitize"}, [K_DEPTH] = {SEC_OCTREE, "depth"},
    [K_TESTS] = {SEC_OCTREE, "tests"},  [K_REFINE] = {SEC_OCTREE, "refine"},
    [K_EYE] = {SEC_CAMERA, "eye"},      [K_TARGET] = {SEC_CAMERA, "target"},
    [K_UP] = {SEC_CAMERA, "up"},        [K_FOV] = {SEC_CAMERA, "fov"},
    [K_SIZE] = {SEC_CAMERA, "size"},    [K_METHOD] = {SEC_RENDER, "method"},
    [K_LIGHT] = {SEC_RENDER, "light"},
};
static const char *const KEYS_EXPECTED[] = {
    "",
    "name, f, box, let.NAME, param.x, param.y, param.z, u, v or implicitize",
    "depth, tests or refine",
    "eye, target, up, fov or size",
    "method or light",
    "",
};

int scene_section_id(const char *name, size_t n)
{
    for (int i = SEC_SURFACE; i <= SEC_RENDER; i++)
        if (strlen(SECTION_NAMES[i]) == n && memcmp(name, SECTION_NAMES[i], n) == 0)
            return i;
    return SEC_UNKNOWN;
}

const char *scene_section_name(int sec)
{
    return sec >= SEC_NONE && sec <= SEC_UNKNOWN ? SECTION_NAMES[sec] : "";
}

int scene_key_kind(int sec, const char *key, size_t n)
{
    if (sec == SEC_SURFACE && n >= 4 && memcmp(key, "let.", 4) == 0)
        return K_LET;
    for (int k = 0; k < K_COUNT; k++)
        if (KEYS[k].sec == sec && strlen(KEYS[k].key) == n && memcmp(KEYS[k].key, key, n) == 0)
            return k;
    return -1;
}

const char *scene_key_name(int kind)
{
    return kind >= 0 && kind < K_COUNT ? KEYS[kind].key : "let.NAME";
}

const char *scene_keys_expected(int sec)
{
    return sec >= SEC_NONE && sec <= SEC_UNKNOWN ? KEYS_EXPECTED[sec] : "";
}

/* ---- defaults, the box, the camera ---------------------------------------------------- */

/* [camera] as written, before ray_camera_init. */
typedef struct camera_keys {
    double eye[3], target[3], up[3];
    double fov;
    int width, height;
} camera_keys_t;

static void set_defaults(scene_t *s, camera_keys_t *c)
{
    oct_params_default(&s->octree);
    for (int k = 0; k < 4; k++)
        s->source.patch[k] = NAN;
    ray_render_opts_t ro;
    ray_render_opts_default(&ro);
    s->method = ro.method;
    memset(c, 0, sizeof *c);
    c->up[2] = 1;
    c->fov = 30;
    c->width = 300;
    c->height = 300;
}

/* "box: xmin 2 > xmax 1"; 0 when fine, else the index of the bad minimum. */
static int check_box(const double b[6], char *msg, size_t n)
{
    static const char axis[] = "xyz";
    for (int i = 0; i < 6; i++) {
        if (!isfinite(b[i])) {
            snprintf(msg, n, "box: the bounds must be finite numbers");
            return i + 1;
        }
    }
    for (int i = 0; i < 3; i++) {
        if (b[2 * i] > b[2 * i + 1]) {
            snprintf(msg, n, "box: %cmin %.17g > %cmax %.17g", axis[i], b[2 * i], axis[i], b[2 * i + 1]);
            return 2 * i + 1;
        }
    }
    return 0;
}

/* Camera defaults that frame the box: looking at its centre from the
 * direction (1, 0.8, 0.6), far enough that the circumscribed sphere fits the
 * vertical field of view with a 10% margin. */
static void frame_box(const double b[6], camera_keys_t *c, bool have_eye, bool have_target)
{
    if (!have_target)
        for (int i = 0; i < 3; i++)
            c->target[i] = 0.5 * b[2 * i] + 0.5 * b[2 * i + 1];
    if (have_eye)
        return;
    double dx = b[1] - b[0], dy = b[3] - b[2], dz = b[5] - b[4];
    double diag = sqrt(dx * dx + dy * dy + dz * dz);
    if (!(diag > 0) || !isfinite(diag))
        diag = isfinite(diag) ? 1 : DBL_MAX / 4;
    double dist = 1.1 * 0.5 * diag / sin(c->fov * (3.14159265358979323846 / 360));
    double dir[3] = {1, 0.8, 0.6}, len = sqrt(1 + 0.64 + 0.36);
    for (int i = 0; i < 3; i++)
        c->eye[i] = c->target[i] + dist * dir[i] / len;
}

static int camera_init(scene_t *s, const camera_keys_t *c, ivoct_error_t *err)
{
    return ray_camera_init(&s->camera, c->eye, c->target, c->up, c->fov, c->width, c->height, err);
}

/* ---- scene_load ------------------------------------------------------------------- */

static char *dup_s(const char *s)
{
    size_t n = strlen(s);
    char *d = malloc(n + 1);
    if (d)
        memcpy(d, s, n + 1);
    return d;
}

/* Parse the stored values into s and c (not f and the lets). */
static void parse_values(loader_t *L, scene_t *s, camera_keys_t *c)
{
    const entry_t *e;
    static const int box_round[6] = {-1, 1, -1, 1, -1, 1};
    if ((e = L->cur = scene_entry(L, K_NAME)))
        scene_val_text(L, e, "name", &s->source.name);
    if ((e = L->cur = scene_entry(L, K_BOX))) {
        int pos[6][2];
        if (!scene_val_numbers(L, e, "box", "xmin xmax ymin ymax zmin zmax", 6, box_round, s->box, pos)) {
            char msg[256];
            int bad = check_box(s->box, msg, sizeof msg);
            if (bad)
                scene_fail_at(L, pos[bad - 1][0], pos[bad - 1][1], "%s", msg);
        }
    }
    if ((e = L->cur = scene_entry(L, K_DEPTH)))
        scene_val_ints(L, e, "depth", "the maximum octree depth", 1, 0, OCT_MAX_DEPTH, &s->octree.depth);
    if ((e = L->cur = scene_entry(L, K_TESTS)))
        scene_val_tests(L, e, &s->octree.tests);
    if ((e = L->cur = scene_entry(L, K_REFINE))) {
        int pos[1][2];
        if (!scene_val_numbers(L, e, "refine", "a length, 0 = off", 1, NULL, &s->octree.refine, pos) &&
            s->octree.refine < 0)
            scene_fail_at(L, pos[0][0], pos[0][1], "refine: expected a length >= 0 (0 = off)");
    }
    if ((e = L->cur = scene_entry(L, K_EYE)))
        scene_val_numbers(L, e, "eye", "x y z", 3, NULL, c->eye, NULL);
    if ((e = L->cur = scene_entry(L, K_TARGET)))
        scene_val_numbers(L, e, "target", "x y z", 3, NULL, c->target, NULL);
    if ((e = L->cur = scene_entry(L, K_UP)))
        scene_val_numbers(L, e, "up", "x y z", 3, NULL, c->up, NULL);
    /* its range is the camera's to check (ray_camera_init) */
    if ((e = L->cur = scene_entry(L, K_FOV)))
        scene_val_numbers(L, e, "fov", "degrees", 1, NULL, &c->fov, NULL);
    if ((e = L->cur = scene_entry(L, K_SIZE))) {
        int wh[2];
        if (!scene_val_ints(L, e, "size", "width height in pixels", 2, 1, RAY_MAX_SIZE, wh)) {
            c->width = wh[0];
            c->height = wh[1];
        }
    }
    if ((e = L->cur = scene_entry(L, K_METHOD)))
        scene_val_method(L, e, &s->method);
    if ((e = L->cur = scene_entry(L, K_LIGHT)) &&
        !scene_val_numbers(L, e, "light", "x y z of a point light", 3, NULL, s->light, NULL))
        s->has_light = 1;
    L->cur = NULL;
}

/* Set up the camera; a problem is reported at the key the user wrote that
 * takes part in it (the eye, else the target, for a problem of the view
 * direction; else the start of the file). */
static void check_camera(loader_t *L, scene_t *s, const camera_keys_t *c)
{
    ivoct_error_t ce;
    ivoct_error_clear(&ce);
    int bad = camera_init(s, c, &ce);
    if (!bad)
        return;
    const entry_t *e = bad == RAY_CAMERA_BAD_FOV    ? scene_entry(L, K_FOV)
                       : bad == RAY_CAMERA_BAD_SIZE ? scene_entry(L, K_SIZE)
                       : bad == RAY_CAMERA_BAD_UP   ? scene_entry(L, K_UP)
                                                    : NULL;
    if (!e)
        e = L->seen[K_EYE] ? scene_entry(L, K_EYE) : scene_entry(L, K_TARGET);
    if (e)
        scene_fail_at(L, e->pieces[0].line, e->pieces[0].col, "%s", ce.msg);
    else
        scene_fail_at(L, 1, 1, "%s", ce.msg);
}

/* An expression error of entry e, moved from text to file positions: the
 * error's own position, and the one a message may quote ("... opened at
 * L:C", written by expr/parse.c in text positions too). */
void scene_fail_expr(loader_t *L, const entry_t *e, const ivoct_error_t *ce)
{
    int fl, fc;
    scene_val_map_pos(e, ce->line, ce->col, &fl, &fc);
    char msg[sizeof ce->msg + 32];
    snprintf(msg, sizeof msg, "%s", ce->msg);
    const char *at = strstr(ce->msg, " opened at ");
    int ql, qc, used = 0;
    if (at && sscanf(at, " opened at %d:%d%n", &ql, &qc, &used) == 2 && used > 0) {
        int ml, mc;
        scene_val_map_pos(e, ql, qc, &ml, &mc);
        snprintf(msg, sizeof msg, "%.*s opened at %d:%d%s", (int)(at - ce->msg), ce->msg, ml, mc,
                 at + used);
    }
    L->cur = e;
    scene_fail_at(L, fl, fc, "%s", msg);
    L->cur = NULL;
}

/* Compile the lets (file order) and f. */
static int compile(loader_t *L, scene_t *s)
{
    tape_compiler_t *tc = tape_compiler_new();
    if (!tc) {
        scene_fail_oom(L);
        return -1;
    }
    size_t n_lets = 0;
    for (size_t i = 0; i < L->n_entries; i++)
        n_lets += L->entries[i].kind == K_LET;
    if (n_lets) {
        s->source.let_names = calloc(n_lets, sizeof *s->source.let_names);
        s->source.let_texts = calloc(n_lets, sizeof *s->source.let_texts);
        if (!s->source.let_names || !s->source.let_texts) {
            scene_fail_oom(L);
            tape_compiler_free(tc);
            return -1;
        }
    }
    ivoct_error_t ce;
    ivoct_error_clear(&ce);
    int rc = 0;
    for (size_t i = 0; i < L->n_entries && !rc; i++) {
        const entry_t *e = &L->entries[i];
        if (e->kind != K_LET)
            continue;
        char *name = dup_s(e->key + 4), *text = scene_val_join(e, '\n');
        s->source.let_names[s->source.n_lets] = name;
        s->source.let_texts[s->source.n_lets] = text;
        s->source.n_lets++;
        if (!name || !text) {
            scene_fail_oom(L);
            rc = -1;
        } else if (tape_compiler_define(tc, name, text, &ce)) {
            if (ce.line > 0)
                scene_fail_expr(L, e, &ce);
            else /* name errors have no position in the text: point at the name */
                scene_fail_at(L, e->line, e->col + 4, "%s", ce.msg);
            rc = -1;
        }
    }
    const entry_t *f = scene_entry(L, K_F);
    if (!rc) {
        s->source.f = scene_val_join(f, '\n');
        if (!s->source.f) {
            scene_fail_oom(L);
            rc = -1;
        } else if (tape_compiler_compile(tc, s->source.f, &s->tape, &ce)) {
            scene_fail_expr(L, f, &ce);
            rc = -1;
        }
    }
    tape_compiler_free(tc);
    return rc;
}

static char *base_name(const char *path)
{
    const char *b = strrchr(path, '/');
    b = b ? b + 1 : path;
    size_t n = strlen(b);
    if (n > 4 && strcmp(b + n - 4, ".ini") == 0)
        n -= 4;
    char *d = malloc(n + 1);
    if (d) {
        memcpy(d, b, n);
        d[n] = '\0';
    }
    return d;
}

static void set_file(ivoct_error_t *err, const char *path)
{
    if (err)
        snprintf(err->file, sizeof err->file, "%s", path);
}

int scene_load(const char *path, scene_t *s, ivoct_error_t *err)
{
    return scene_load_with(path, NULL, s, err);
}

/* The keys of a parametric surface given to an implicit one. */
static void check_implicit_only(loader_t *L)
{
    static const int kinds[] = {K_U, K_V, K_IMPLICITIZE};
    for (size_t i = 0; i < sizeof kinds / sizeof *kinds; i++) {
        const entry_t *e = scene_entry(L, kinds[i]);
        if (e)
            scene_fail_at(L, e->line, e->col,
                          "%s: only for a parametric surface (param.x, param.y, param.z)",
                          scene_key_name(kinds[i]));
    }
}

int scene_load_with(const char *path, const scene_options_t *opt, scene_t *s, ivoct_error_t *err)
{
    memset(s, 0, sizeof *s);
    ivoct_error_clear(err);
    set_file(err, path);
    loader_t L;
    memset(&L, 0, sizeof L);
    L.path = path;
    if (scene_ini_read(&L, err)) {
        scene_ini_free(&L);
        return -1;
    }
    camera_keys_t cam;
    set_defaults(s, &cam);
    bool have_eye = L.seen[K_EYE], have_target = L.seen[K_TARGET];
    /* The keys stored all come before any error of the file's structure, so
     * their values are complete and checked in any case; scene_fail_at keeps
     * the error that comes first in the file. */
    bool structure_ok = !L.failed;
    bool parametric = L.seen[K_PARAM_X] || L.seen[K_PARAM_Y] || L.seen[K_PARAM_Z];
    if (!L.oom)
        parse_values(&L, s, &cam);
    if (!L.oom && !parametric)
        check_implicit_only(&L);
    if (!L.oom && !L.failed) {
        if (!L.has_surface)
            scene_fail_at(&L, 1, 1, "missing [surface] section");
        else if (!L.seen[K_F] && !parametric)
            scene_fail_at(&L, 1, 1, "missing [surface] f (or param.x, param.y and param.z "
                                    "for a parametric surface)");
    }
    /* Expressions only in a sound file: after a structural error a name
     * may be defined in the part that was not read.  Compiled before the box
     * is required, as an indented "box = ..." line is read as more of f,
     * and the compiler's error then explains that. */
    if (!L.oom && structure_ok && parametric)
        scene_parametric(&L, s, opt, !L.seen[K_BOX]);
    else if (!L.oom && structure_ok && L.seen[K_F])
        compile(&L, s);
    if (!L.oom && !L.failed && !L.seen[K_BOX] && !parametric)
        scene_fail_at(&L, 1, 1, "missing [surface] box");
    if (!L.oom && !L.failed) {
        frame_box(s->box, &cam, have_eye, have_target);
        check_camera(&L, s, &cam);
    }
    if (!L.oom && !L.failed && !s->source.name)
        s->source.name = base_name(path);
    if (!L.oom && !L.failed && !(s->path = dup_s(path)))
        L.oom = true;
    if (!L.oom && !L.failed && !s->source.name)
        L.oom = true;
    if (L.oom || L.failed) {
        if (L.oom)
            ivoct_error_at(err, 0, 0, "out of memory while loading the scene");
        else
            ivoct_error_at(err, L.first.line, L.first.col, "%s", L.first.msg);
        bool runtime = L.oom || L.over_budget;
        scene_ini_free(&L);
        scene_free(s);
        return runtime ? SCENE_ERUNTIME : SCENE_EINPUT;
    }
    scene_ini_free(&L);
    return 0;
}

int scene_from_expr(const char *expr, const double box[6], scene_t *s, ivoct_error_t *err)
{
    memset(s, 0, sizeof *s);
    ivoct_error_clear(err);
    camera_keys_t cam;
    set_defaults(s, &cam);
    memcpy(s->box, box, sizeof s->box);
    char msg[256];
    if (check_box(s->box, msg, sizeof msg)) {
        ivoct_error_at(err, 0, 0, "%s", msg);
        memset(s, 0, sizeof *s);
        return -1;
    }
    frame_box(s->box, &cam, false, false);
    if (camera_init(s, &cam, err)) {
        memset(s, 0, sizeof *s);
        return -1;
    }
    if (tape_compile(expr, &s->tape, err)) {
        memset(s, 0, sizeof *s);
        return -1;
    }
    s->source.f = dup_s(expr);
    s->source.name = dup_s(expr);
    if (!s->source.f || !s->source.name) {
        scene_free(s);
        ivoct_error_at(err, 0, 0, "out of memory");
        return -1;
    }
    return 0;
}

void scene_free(scene_t *s)
{
    if (!s)
        return;
    free(s->path);
    oct_source_free(&s->source);
    tape_free(s->tape);
    if (s->implicit) {
        imp_result_free(s->implicit);
        free(s->implicit);
    }
    memset(s, 0, sizeof *s);
}
