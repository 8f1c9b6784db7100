/* ivoct — cell addressing: bounds, Morton codes. */
#include <float.h>
#include <stdint.h>
#include <string.h>

#include "build_internal.h"

iv_box_t oct_cell_box(const double box[6], int depth, uint32_t ix, uint32_t iy, uint32_t iz)
{
    iv_box_t b = {
        {oct_coord(box[0], box[1], ix, depth), oct_coord(box[0], box[1], (uint64_t)ix + 1, depth)},
        {oct_coord(box[2], box[3], iy, depth), oct_coord(box[2], box[3], (uint64_t)iy + 1, depth)},
        {oct_coord(box[4], box[5], iz, depth), oct_coord(box[4], box[5], (uint64_t)iz + 1, depth)},
    };
    return b;
}

uint64_t oct_morton(uint32_t ix, uint32_t iy, uint32_t iz, int depth)
{
    uint64_t code = 0;
    for (int level = depth - 1; level >= 0; level--) {
        unsigned child = ((ix >> level) & 1u) | ((iy >> level) & 1u) << 1 | ((iz >> level) & 1u) << 2;
        code = code << 3 | child;
    }
    return code;
}

/* Every third bit of v from bit 0 on, packed: bit 3k goes to bit k (k < 21). */
static uint32_t every_third_bit(uint64_t v)
{
    v &= 0x1249249249249249ull;
    v = (v ^ (v >> 2)) & 0x10c30c30c30c30c3ull;
    v = (v ^ (v >> 4)) & 0x100f00f00f00f00full;
    v = (v ^ (v >> 8)) & 0x001f0000ff0000ffull;
    v = (v ^ (v >> 16)) & 0x001f00000000ffffull;
    v = (v ^ (v >> 32)) & 0x00000000001fffffull;
    return (uint32_t)v;
}

void oct_unmorton(uint64_t code, int depth, uint32_t *ix, uint32_t *iy, uint32_t *iz)
{
    /* the bits above the depth's 3·depth are not the cell's */
    if (depth <= 0)
        code = 0;
    else if (depth < 21)
        code &= ((uint64_t)1 << (3 * depth)) - 1;
    *ix = every_third_bit(code);
    *iy = every_third_bit(code >> 1);
    *iz = every_third_bit(code >> 2);
}

/* The bits of the float next to f (bits b) toward -inf (up = 0) or +inf
 * (up = 1): nextafterf, for the f that float_outward steps from (never NaN,
 * never the infinity it steps toward), in integer operations. */
static uint32_t float_step(uint32_t b, uint32_t up)
{
    uint32_t sign = b >> 31, zero = -(uint32_t)((b & 0x7fffffffu) == 0);
    uint32_t stepped = up ? b + 1 - 2 * sign : b - 1 + 2 * sign;
    uint32_t least = up ? 0x00000001u : 0x80000001u; /* the least subnormal */
    return (least & zero) | (stepped & ~zero);
}

/* The float nearest x, moved outward past x (down for up = 0, up for up = 1)
 * when the conversion rounded inward.  Without branches: that is a coin toss
 * from leaf to leaf, and the mispredicted branches (or nextafterf's calls) took
 * most of the time of making a leaf. */
static float float_outward(double x, uint32_t up)
{
    float f = (float)x;
    uint32_t b;
    memcpy(&b, &f, sizeof b);
    uint32_t inward = -(uint32_t)(up ? (double)f < x : (double)f > x);
    b = (float_step(b, up) & inward) | (b & ~inward);
    memcpy(&f, &b, sizeof f);
    return f;
}

oct_leaf_t oct_leaf_make(uint64_t code, int depth, double f_lo, double f_hi)
{
    oct_leaf_t l = {(uint64_t)1 << (3 * depth) | code, float_outward(f_lo, 0),
                    float_outward(f_hi, 1)};
    return l;
}

iv_box_t oct_leaf_box(const oct_tree_t *tree, const oct_leaf_t *leaf)
{
    uint32_t ix, iy, iz;
    int depth = oct_leaf_depth(leaf);
    oct_unmorton(oct_leaf_code(leaf), depth, &ix, &iy, &iz);
    return oct_cell_box(tree->box, depth, ix, iy, iz);
}

int oct_leaf_has_slab(const oct_tree_t *tree, uint32_t i)
{
    const oct_slab_t *s = tree->slabs ? &tree->slabs[i] : NULL;
    return s && (s->n[0] != 0 || s->n[1] != 0 || s->n[2] != 0);
}

double oct_leaf_error_bound(const oct_tree_t *tree, uint32_t i)
{
    if (oct_leaf_has_slab(tree, i))
        return tree->slabs[i].thickness;
    iv_box_t b = oct_leaf_box(tree, &tree->leaves[i]);
    return oct_box_diagonal(&b);
}

double cell_diagonal_of_squared(double d2) { return iv_sqrt(iv_make(d2, d2)).hi; }

double oct_box_diagonal(const iv_box_t *b)
{
    return cell_diagonal_of_squared(cell_diagonal_squared(b));
}
