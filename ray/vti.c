/* ivoct ray — the render buffers as a VTK XML ImageData file (.vti).
 *
 * Point arrays in VTK's uncompressed "binary" format: per array, base64 of a
 * UInt64 byte count followed by the raw doubles in the host's byte order
 * (NaN survives, which VTK's ASCII parsing does not promise).  Kept small on
 * purpose: the full VTK export lives in export/. */
#include <stdint.h>
#include <string.h>

#include "ray.h"

typedef struct b64 {
    FILE *f;
    unsigned char buf[3];
    int n;
} b64_t;

static const char B64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

static void b64_flush3(b64_t *b)
{
    unsigned v = (unsigned)b->buf[0] << 16 | (unsigned)(b->n > 1 ? b->buf[1] : 0) << 8 |
                 (unsigned)(b->n > 2 ? b->buf[2] : 0);
    char out[4] = {B64[v >> 18 & 63], B64[v >> 12 & 63], b->n > 1 ? B64[v >> 6 & 63] : '=',
                   b->n > 2 ? B64[v & 63] : '='};
    fwrite(out, 1, 4, b->f);
    b->n = 0;
}

static void b64_put(b64_t *b, const void *data, size_t len)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < len; i++) {
        b->buf[b->n++] = p[i];
        if (b->n == 3)
            b64_flush3(b);
    }
}

static void b64_end(b64_t *b)
{
    if (b->n)
        b64_flush3(b);
}

/* One Float64 point array of ncomp components; values in image order (row 0
 * at the top) are written in VTK order (y up).  Bytes are flags: 0 or 1. */
static void write_array(FILE *f, const char *name, const ray_image_t *img, int ncomp,
                        const double *vals, const unsigned char *bytes)
{
    const int W = img->width, H = img->height;
    fprintf(f,
            "        <DataArray type=\"Float64\" Name=\"%s\" NumberOfComponents=\"%d\" "
            "format=\"binary\">\n          ",
            name, ncomp);
    b64_t b = {f, {0}, 0};
    uint64_t nbytes = (uint64_t)W * H * ncomp * sizeof(double);
    b64_put(&b, &nbytes, sizeof nbytes);
    for (int vr = 0; vr < H; vr++) {
        size_t row = (size_t)(H - 1 - vr);
        for (int col = 0; col < W; col++) {
            size_t i = row * W + col;
            for (int k = 0; k < ncomp; k++) {
                double v = vals ? vals[(size_t)ncomp * i + k] : (double)(bytes[i] != 0);
                b64_put(&b, &v, sizeof v);
            }
        }
    }
    b64_end(&b);
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
    write_array(f, "t", img, 1, img->t, NULL);
    write_array(f, "hit", img, 1, NULL, img->hit);
    write_array(f, "point", img, 3, img->point, NULL);
    write_array(f, "normal", img, 3, img->normal, NULL);
    write_array(f, "dir", img, 3, img->dir, NULL);
    /* 0 lit, 1 in shadow (certified or undecided: ray/README.md, "Shadows") */
    if (img->lit)
        write_array(f, "shadow", img, 1, NULL, img->shadow);
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
