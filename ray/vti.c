/* ivoct ray — the render buffers as a VTK XML ImageData file (.vti).
 *
 * Point arrays in VTK's uncompressed "binary" format: per array, base64 of a
 * UInt64 byte count followed by the raw doubles in the host's byte order
 * (NaN survives, which VTK's ASCII parsing does not promise).  Kept small on
 * purpose: the full VTK export lives in export/. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "ray.h"

/* Base64 of a byte stream, encoded a block at a time into a text buffer and
 * written with one fwrite per block: the arrays of a 1024x1024 image are
 * 100 MB, and a library call per group of 3 bytes would cost more than the
 * render. */
enum { B64_IN = 3 * 8 * 1024 }; /* bytes encoded per block: whole groups of 3 */

typedef struct b64 {
    FILE *f;
    size_t n; /* bytes waiting in in[] */
    unsigned char in[B64_IN];
    char out[B64_IN / 3 * 4];
} b64_t;

static const char B64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/* Encode the n bytes waiting (n % 3 == 0 but at the end of the stream, where
 * the last group is padded with '=') and write them. */
static void b64_flush(b64_t *b)
{
    const unsigned char *p = b->in;
    char *o = b->out;
    size_t i = 0;
    for (; i + 3 <= b->n; i += 3, o += 4) {
        unsigned v = (unsigned)p[i] << 16 | (unsigned)p[i + 1] << 8 | p[i + 2];
        o[0] = B64[v >> 18];
        o[1] = B64[v >> 12 & 63];
        o[2] = B64[v >> 6 & 63];
        o[3] = B64[v & 63];
    }
    if (i < b->n) {
        unsigned v = (unsigned)p[i] << 16 | (unsigned)(i + 1 < b->n ? p[i + 1] : 0) << 8;
        o[0] = B64[v >> 18];
        o[1] = B64[v >> 12 & 63];
        o[2] = i + 1 < b->n ? B64[v >> 6 & 63] : '=';
        o[3] = '=';
        o += 4;
    }
    fwrite(b->out, 1, (size_t)(o - b->out), b->f);
    b->n = 0;
}

static void b64_put(b64_t *b, const void *data, size_t len)
{
    const unsigned char *p = data;
    while (len > 0) {
        size_t k = B64_IN - b->n < len ? B64_IN - b->n : len;
        memcpy(b->in + b->n, p, k);
        b->n += k, p += k, len -= k;
        if (b->n == B64_IN)
            b64_flush(b);
    }
}

static void b64_end(b64_t *b)
{
    if (b->n)
        b64_flush(b);
}

/* One Float64 point array of ncomp components; values in image order (row 0
 * at the top) are written in VTK order (y up).  Bytes are flags: 0 or 1.
 * b: the encoder's buffers (its stream starts here). */
static void write_array(FILE *f, b64_t *b, const char *name, const ray_image_t *img, int ncomp,
                        const double *vals, const unsigned char *bytes)
{
    const int W = img->width, H = img->height;
    fprintf(f,
            "        <DataArray type=\"Float64\" Name=\"%s\" NumberOfComponents=\"%d\" "
            "format=\"binary\">\n          ",
            name, ncomp);
    b->f = f;
    b->n = 0;
    uint64_t nbytes = (uint64_t)W * H * ncomp * sizeof(double);
    b64_put(b, &nbytes, sizeof nbytes);
    for (int vr = 0; vr < H; vr++) {
        size_t row = (size_t)(H - 1 - vr);
        if (vals) {
            b64_put(b, vals + (size_t)ncomp * row * W, (size_t)ncomp * W * sizeof(double));
            continue;
        }
        for (int col = 0; col < W; col++) {
            double v = bytes[row * W + col] != 0;
            b64_put(b, &v, sizeof v);
        }
    }
    b64_end(b);
    fputs("\n        </DataArray>\n", f);
}

static void field_vec(FILE *f, const char *name, const double *v, int n)
{
    fprintf(f,
            "      <DataArray type=\"Float64\" Name=\"%s\" NumberOfTuples=\"1\" "
            "NumberOfComponents=\"%d\" format=\"ascii\">",
            name, n);
    for (int i = 0; i < n; i++)
        fprintf(f, "%s%.17g", i ? " " : "", v[i]);
    fputs("</DataArray>\n", f);
}

int ray_write_vti(FILE *f, const ray_image_t *img, const ray_camera_t *cam,
                  const char *method, ivoct_error_t *err)
{
    const uint16_t probe = 1;
    unsigned char first;
    memcpy(&first, &probe, 1);
    const int W = img->width, H = img->height;
    fprintf(f,
            "<?xml version=\"1.0\"?>\n"
            "<VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"%s\" "
            "header_type=\"UInt64\">\n"
            "  <ImageData WholeExtent=\"0 %d 0 %d 0 0\" Origin=\"0 0 0\" Spacing=\"1 1 1\">\n"
            "    <FieldData>\n",
            first ? "LittleEndian" : "BigEndian", W - 1, H - 1);
    field_vec(f, "eye", cam->eye, 3);
    field_vec(f, "target", cam->target, 3);
    field_vec(f, "up", cam->up, 3);
    field_vec(f, "fov", &cam->fov, 1);
    if (img->lit)
        field_vec(f, "light", img->light, 3);
    /* a String array: the characters as numbers, each string closed by 0 */
    fputs("      <Array type=\"String\" Name=\"method\" NumberOfTuples=\"1\" format=\"ascii\">", f);
    for (const char *p = method ? method : ""; *p; p++)
        fprintf(f, "%d ", (unsigned char)*p);
    fputs("0</Array>\n    </FieldData>\n", f);
    fprintf(f,
            "    <Piece Extent=\"0 %d 0 %d 0 0\">\n"
            "      <PointData Scalars=\"t\" Normals=\"normal\">\n",
            W - 1, H - 1);
    b64_t *b = malloc(sizeof *b);
    if (!b) {
        ivoct_error_set(err, "vti: out of memory");
        return 1;
    }
    write_array(f, b, "t", img, 1, img->t, NULL);
    write_array(f, b, "hit", img, 1, NULL, img->hit);
    write_array(f, b, "point", img, 3, img->point, NULL);
    write_array(f, b, "normal", img, 3, img->normal, NULL);
    write_array(f, b, "dir", img, 3, img->dir, NULL);
    /* 0 lit, 1 in shadow (certified or undecided: ray/README.md, "Shadows") */
    if (img->lit)
        write_array(f, b, "shadow", img, 1, NULL, img->shadow);
    free(b);
    fputs("      </PointData>\n"
          "      <CellData>\n"
          "      </CellData>\n"
          "    </Piece>\n"
          "  </ImageData>\n"
          "</VTKFile>\n",
          f);
    if (fflush(f) != 0 || ferror(f)) {
        ivoct_error_set(err, "vti: write error");
        return 1;
    }
    return 0;
}
