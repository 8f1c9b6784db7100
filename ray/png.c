/* ivoct ray — the shaded image as an 8-bit RGB PNG (libpng).
 *
 * libpng reports errors through a callback that must not return: ours keeps
 * the message and longjmps back, so nothing is printed (library code never
 * prints) and the caller gets the message in its ivoct_error_t. */
#include <setjmp.h>
#include <string.h>

#include <png.h>

#include "ray.h"

typedef struct png_err {
    char msg[256];
} png_err_t;

static void on_error(png_structp png, png_const_charp msg)
{
    png_err_t *e = png_get_error_ptr(png);
    if (e) {
        strncpy(e->msg, msg ? msg : "libpng error", sizeof e->msg - 1);
        e->msg[sizeof e->msg - 1] = '\0';
    }
    png_longjmp(png, 1);
}

static void on_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg;
}

int ray_write_png(FILE *f, const ray_image_t *img, ivoct_error_t *err)
{
    png_err_t e = {"libpng error"};
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &e, on_error, on_warning);
    if (!png) {
        ivoct_error_set(err, "png: out of memory");
        return 1;
    }
    png_infop info = png_create_info_struct(png);
    if (!info) {
        png_destroy_write_struct(&png, NULL);
        ivoct_error_set(err, "png: out of memory");
        return 1;
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        ivoct_error_set(err, "png: %s", e.msg);
        return 1;
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, (png_uint_32)img->width, (png_uint_32)img->height, 8,
                 PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    for (int r = 0; r < img->height; r++)
        png_write_row(png, img->rgb + (size_t)3 * img->width * r);
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    if (fflush(f) != 0 || ferror(f)) {
        ivoct_error_set(err, "png: write error");
        return 1;
    }
    return 0;
}
