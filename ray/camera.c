/* ivoct ray — the pinhole camera, points along a ray, clipping to a box. */
#include <math.h>
#include <string.h>

#include "ray.h"

#define RAY_PI 3.14159265358979323846

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3(const double a[3], const double b[3], double r[3])
{
    r[0] = a[1] * b[2] - a[2] * b[1];
    r[1] = a[2] * b[0] - a[0] * b[2];
    r[2] = a[0] * b[1] - a[1] * b[0];
}

/* Normalise v in place; 0 when v is zero or not finite. */
static int normalize3(double v[3])
{
    double n = sqrt(dot3(v, v));
    if (!(n > 0) || !isfinite(n))
        return 0;
    for (int i = 0; i < 3; i++)
        v[i] /= n;
    return 1;
}

int ray_camera_init(ray_camera_t *cam, const double eye[3], const double target[3],
                    const double up[3], double fov_deg, int width, int height,
                    ivoct_error_t *err)
{
    memset(cam, 0, sizeof *cam);
    /* fov first: a scene's default eye is placed from it */
    if (!(fov_deg > 0 && fov_deg < 180)) {
        ivoct_error_set(err, "camera: fov must be between 0 and 180 degrees (exclusive), got %g",
                        fov_deg);
        return RAY_CAMERA_BAD_FOV;
    }
    if (width < 1 || height < 1 || width > RAY_MAX_SIZE || height > RAY_MAX_SIZE) {
        ivoct_error_set(err, "camera: size %dx%d: width and height must be in [1, %d]", width,
                        height, RAY_MAX_SIZE);
        return RAY_CAMERA_BAD_SIZE;
    }
    double fwd[3];
    for (int i = 0; i < 3; i++)
        fwd[i] = target[i] - eye[i];
    if (!isfinite(eye[0]) || !isfinite(eye[1]) || !isfinite(eye[2]) || !isfinite(target[0]) ||
        !isfinite(target[1]) || !isfinite(target[2]) || !normalize3(fwd)) {
        ivoct_error_set(err, "camera: eye and target must be distinct finite points");
        return RAY_CAMERA_BAD_EYE;
    }
    if (!isfinite(up[0]) || !isfinite(up[1]) || !isfinite(up[2])) {
        ivoct_error_set(err, "camera: up must be finite");
        return RAY_CAMERA_BAD_UP;
    }
    double upn = sqrt(dot3(up, up));
    if (!(upn > 0) || !isfinite(upn)) {
        ivoct_error_set(err, "camera: up must be a non-zero vector");
        return RAY_CAMERA_BAD_UP;
    }
    double right[3];
    cross3(fwd, up, right);
    /* |fwd x up| = |up| sin(angle): relative to |up|, so a short up vector is fine */
    if (!(sqrt(dot3(right, right)) > 1e-9 * upn) || !normalize3(right)) {
        ivoct_error_set(err, "camera: up is parallel to the view direction (target - eye)");
        return RAY_CAMERA_BAD_UP;
    }
    memcpy(cam->eye, eye, sizeof cam->eye);
    memcpy(cam->target, target, sizeof cam->target);
    memcpy(cam->up, up, sizeof cam->up);
    cam->fov = fov_deg;
    cam->width = width;
    cam->height = height;
    memcpy(cam->fwd, fwd, sizeof cam->fwd);
    memcpy(cam->right, right, sizeof cam->right);
    cross3(cam->right, cam->fwd, cam->vup);
    normalize3(cam->vup);
    cam->tan_half = tan(fov_deg * (RAY_PI / 360.0));
    return 0;
}

void ray_camera_dir(const ray_camera_t *cam, int col, int row, double d[3])
{
    double aspect = (double)cam->width / (double)cam->height;
    double sx = (2.0 * (col + 0.5) / cam->width - 1.0) * cam->tan_half * aspect;
    double sy = (1.0 - 2.0 * (row + 0.5) / cam->height) * cam->tan_half;
    for (int i = 0; i < 3; i++)
        d[i] = cam->fwd[i] + sx * cam->right[i] + sy * cam->vup[i];
    normalize3(d);
}

int ray_camera_orbit(const ray_camera_t *cam, double angle, ray_camera_t *out,
                     ivoct_error_t *err)
{
    /* Rodrigues' rotation of eye - target about the unit up axis */
    double k[3] = {cam->up[0], cam->up[1], cam->up[2]};
    if (!normalize3(k)) {
        ivoct_error_set(err, "camera: up is zero");
        return 1;
    }
    double v[3], kxv[3], eye[3];
    for (int i = 0; i < 3; i++)
        v[i] = cam->eye[i] - cam->target[i];
    cross3(k, v, kxv);
    double c = cos(angle), s = sin(angle), kv = dot3(k, v);
    for (int i = 0; i < 3; i++)
        eye[i] = cam->target[i] + v[i] * c + kxv[i] * s + k[i] * kv * (1.0 - c);
    return ray_camera_init(out, eye, cam->target, cam->up, cam->fov, cam->width, cam->height,
                           err);
}

void ray_point(const double o[3], const double d[3], double t, double p[3])
{
    /* the one definition of the rounded point: tape_eval_ray evaluates at
     * the same points */
    tape_ray_point(o, d, t, p);
}

int ray_clip_box(const double box[6], const double o[3], const double d[3], double *t0,
                 double *t1)
{
    double lo = 0.0, hi = INFINITY;
    for (int i = 0; i < 3; i++) {
        if (!isfinite(o[i]) || !isfinite(d[i]) || !isfinite(box[2 * i]) ||
            !isfinite(box[2 * i + 1]))
            return 0;
        if (d[i] == 0.0) {
            if (o[i] < box[2 * i] || o[i] > box[2 * i + 1])
                return 0;
            continue;
        }
        /* enclosures of (face - o) / d, so the exact slab lies inside [a, b] */
        iv_t di = iv_point(d[i]);
        iv_t a = iv_div(iv_sub(iv_point(box[2 * i]), iv_point(o[i])), di);
        iv_t b = iv_div(iv_sub(iv_point(box[2 * i + 1]), iv_point(o[i])), di);
        double enter = fmin(a.lo, b.lo), leave = fmax(a.hi, b.hi);
        if (enter > lo)
            lo = enter;
        if (leave < hi)
            hi = leave;
    }
    if (!(lo <= hi) || !isfinite(hi))
        return 0;
    *t0 = lo;
    *t1 = hi;
    return 1;
}
