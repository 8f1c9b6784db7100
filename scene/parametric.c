/* ivoct — scene files: a parametric surface.
 *
 * [surface] param.x, param.y, param.z give x = X(u,v), y = Y(u,v), z = Z(u,v);
 * u = U0 U1 and v = V0 V1 the patch (optional), implicitize = auto | resultant
 * | groebner the method.  implicit/ parses the three texts and finds the
 * implicit polynomial f; the tape is compiled from f's nested (Horner) text,
 * which is also source.f, so that a saved octree carries the very text it was
 * built from.  Without a box, the patch bounds one: implicit/'s rigorous
 * enclosure of the patch's image, widened by a margin so that the surface does
 * not lie on the box's faces.  Errors of a coordinate text are mapped back to
 * the file through the entry's pieces, as f's are (scene.c). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "scene_internal.h"

/* The margin added to each side of the patch's box, as a share of its largest
 * extent (a flat patch gets a box of some thickness too). */
#define PATCH_MARGIN (1.0 / 32)

static const int PARAM_KEYS[3] = {K_PARAM_X, K_PARAM_Y, K_PARAM_Z};

/* u or v: two finite numbers, the first below the second. */
static int read_range(loader_t *L, int kind, double out[2])
{
    const entry_t *e = L->cur = scene_entry(L, kind);
    if (!e)
        return 0;
    const char *name = scene_key_name(kind);
    int pos[2][2];
    char expected[16];
    snprintf(expected, sizeof expected, "%s0 %s1", name, name);
    int rc = scene_val_numbers(L, e, name, expected, 2, NULL, out, pos);
    if (!rc && !(isfinite(out[0]) && isfinite(out[1]))) {
        scene_fail_at(L, pos[0][0], pos[0][1], "%s: the bounds must be finite numbers", name);
        rc = -1;
    } else if (!rc && !(out[0] < out[1])) {
        scene_fail_at(L, pos[0][0], pos[0][1], "%s: %s0 %.17g must be below %s1 %.17g", name,
                      name, out[0], name, out[1]);
        rc = -1;
    }
    L->cur = NULL;
    if (rc)
        out[0] = out[1] = NAN;
    return rc;
}

/* The implicitize key, and the options' override. */
static int read_method(loader_t *L, const scene_options_t *opt, imp_method_t *m)
{
    *m = IMP_AUTO;
    const entry_t *e = L->cur = scene_entry(L, K_IMPLICITIZE);
    int rc = 0;
    if (e) {
        char *name;
        if (scene_val_text(L, e, "implicitize", &name))
            rc = -1;
        else if (imp_method_parse(name, m)) {
            scene_fail_at(L, e->pieces[0].line, e->pieces[0].col,
                          "implicitize: unknown method '%s'; expected auto, resultant or groebner",
                          name);
            rc = -1;
        }
        free(name);
    }
    L->cur = NULL;
    if (opt && opt->implicitize >= 0)
        *m = (imp_method_t)opt->implicitize;
    return rc;
}

/* Position of a key's value in the file (the key itself when it has none). */
static void value_pos(const entry_t *e, int *line, int *col)
{
    *line = e->n_pieces ? e->pieces[0].line : e->line;
    *col = e->n_pieces ? e->pieces[0].col : e->col;
}

/* Parse the three coordinates into *p. */
static int parse_param(loader_t *L, scene_t *s, imp_param_t **p)
{
    const char *texts[3];
    for (int k = 0; k < 3; k++) {
        const entry_t *e = scene_entry(L, PARAM_KEYS[k]);
        if (!(s->source.param[k] = scene_val_join(e, '\n'))) {
            scene_fail_oom(L);
            return -1;
        }
        texts[k] = s->source.param[k];
    }
    int which = 0;
    ivoct_error_t pe;
    ivoct_error_clear(&pe);
    int rc = imp_param_parse(texts, p, &which, &pe);
    if (rc == IMP_ENOMEM) {
        scene_fail_oom(L);
        return -1;
    }
    if (rc) {
        const entry_t *e = scene_entry(L, PARAM_KEYS[which < 0 || which > 2 ? 0 : which]);
        if (pe.line > 0) {
            scene_fail_expr(L, e, &pe);
        } else {
            int fl, fc;
            value_pos(e, &fl, &fc);
            scene_fail_at(L, fl, fc, "%s", pe.msg);
        }
        return -1;
    }
    return 0;
}

int scene_parametric(loader_t *L, scene_t *s, const scene_options_t *opt, bool need_box)
{
    /* the file's shape first: all three coordinates, no f, no lets */
    const entry_t *px = NULL;
    for (int k = 0; k < 3; k++)
        if (scene_entry(L, PARAM_KEYS[k])) {
            px = scene_entry(L, PARAM_KEYS[k]);
            break;
        }
    const entry_t *f = scene_entry(L, K_F);
    if (f) {
        scene_fail_at(L, f->line, f->col,
                      "f and param.x, param.y, param.z: a surface is either implicit (f) or "
                      "parametric (param.x, param.y, param.z), not both");
        return -1;
    }
    for (size_t i = 0; i < L->n_entries; i++)
        if (L->entries[i].kind == K_LET) {
            scene_fail_at(L, L->entries[i].line, L->entries[i].col,
                          "%s: named subexpressions are for f; a parametrization is written out",
                          L->entries[i].key);
            return -1;
        }
    for (int k = 0; k < 3; k++)
        if (!scene_entry(L, PARAM_KEYS[k])) {
            scene_fail_at(L, px->line, px->col,
                          "missing [surface] %s: a parametric surface needs param.x, param.y "
                          "and param.z",
                          scene_key_name(PARAM_KEYS[k]));
            return -1;
        }
    double u[2], v[2];
    int bad = read_range(L, K_U, u) | read_range(L, K_V, v);
    imp_method_t m;
    bad |= read_method(L, opt, &m);
    if (bad)
        return -1;
    s->source.patch[0] = L->seen[K_U] ? u[0] : NAN;
    s->source.patch[1] = L->seen[K_U] ? u[1] : NAN;
    s->source.patch[2] = L->seen[K_V] ? v[0] : NAN;
    s->source.patch[3] = L->seen[K_V] ? v[1] : NAN;
    if (need_box && !(L->seen[K_U] && L->seen[K_V])) {
        scene_fail_at(L, 1, 1, "missing [surface] box (or u and v: the patch of the "
                               "parametrization, which bounds one)");
        return -1;
    }

    imp_param_t *p = NULL;
    if (parse_param(L, s, &p))
        return -1;
    /* implicitizing is the costly part: not for a file with an error elsewhere */
    int rc = -1;
    if (L->failed)
        goto out;
    int fl, fc;
    value_pos(px, &fl, &fc);
    ivoct_error_t ie;
    ivoct_error_clear(&ie);
    if (need_box) {
        if (imp_param_bounds(p, u, v, s->box, &ie)) {
            scene_fail_at(L, fl, fc, "%s", ie.msg);
            goto out;
        }
        double ext = 0;
        for (int k = 0; k < 3; k++)
            ext = fmax(ext, s->box[2 * k + 1] - s->box[2 * k]);
        double pad = ext > 0 ? PATCH_MARGIN * ext : 1;
        for (int k = 0; k < 3; k++) {
            s->box[2 * k] -= pad;
            s->box[2 * k + 1] += pad;
        }
        if (!(isfinite(s->box[0]) && isfinite(s->box[1]) && isfinite(s->box[2]) &&
              isfinite(s->box[3]) && isfinite(s->box[4]) && isfinite(s->box[5]))) {
            scene_fail_at(L, fl, fc, "the patch's image is too large for a box of doubles: "
                                     "give a box");
            goto out;
        }
    }
    if (!(s->implicit = calloc(1, sizeof *s->implicit))) {
        scene_fail_oom(L);
        goto out;
    }
    int ir = imp_implicitize(p, m, opt ? &opt->budget : NULL, s->implicit, &ie);
    if (ir == IMP_ENOMEM) {
        scene_fail_oom(L);
    } else if (ir == IMP_EBUDGET) {
        L->over_budget = true;
        scene_fail_at(L, fl, fc, "%s", ie.msg);
    } else if (ir) {
        scene_fail_at(L, fl, fc, "%s", ie.msg);
    }
    if (ir) {
        free(s->implicit);
        s->implicit = NULL;
        goto out;
    }
    if (!(s->source.f = malloc(strlen(s->implicit->f_tape) + 1))) {
        scene_fail_oom(L);
        goto out;
    }
    strcpy(s->source.f, s->implicit->f_tape);
    if (tape_compile(s->source.f, &s->tape, &ie)) {
        /* implicit/ writes texts of the expression grammar: not the user's error */
        scene_fail_at(L, fl, fc, "the implicit equation does not compile (%s)", ie.msg);
        goto out;
    }
    rc = 0;
out:
    imp_param_free(p);
    return rc;
}
