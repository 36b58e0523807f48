/* light_rgb.c: coloured lights, 9 SH coefficients per colour channel (docs/formats.md, "RGB light
 * files"): from a grey light, from a direction and a colour, from an equirectangular environment
 * map, and their sphere previews. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "light/light.h"

/* The environment map is averaged down to at most this many columns (rows: half) before the
 * diffuse integral, which needs no more: the shading is a smooth function of the normal. */
#define ENV_COLUMNS 64
/* Normals the diffuse shading is fitted on: a Fibonacci sphere. */
#define ENV_NORMALS 1024

void hd_light_rgb_from_grey(const float light[HD_SH_COEFFS], hd_light_rgb *out)
{
    for (int c = 0; c < 3; c++) memcpy(out->sh[c], light, sizeof out->sh[c]);
}

int hd_light_rgb_is_grey(const hd_light_rgb *light)
{
    return memcmp(light->sh[0], light->sh[1], sizeof light->sh[0]) == 0 &&
           memcmp(light->sh[0], light->sh[2], sizeof light->sh[0]) == 0;
}

void hd_light_rgb_from_direction(float azimuth_deg, float elevation_deg, float intensity, float ambient,
                                 const float colour[3], hd_light_rgb *out)
{
    float grey[HD_SH_COEFFS];
    hd_light_from_direction(azimuth_deg, elevation_deg, intensity, ambient, grey);
    for (int c = 0; c < 3; c++)
        for (int k = 0; k < HD_SH_COEFFS; k++) out->sh[c][k] = grey[k] * colour[c];
}

/* The camera-frame direction of azimuth a and elevation e (radians), as hd_light_from_direction. */
static void direction(double a, double e, double d[3])
{
    d[0] = cos(e) * sin(a);
    d[1] = sin(e);
    d[2] = cos(e) * cos(a);
}

hd_status hd_light_from_envmap(const hd_image *map, float rotation_deg, hd_light_rgb *out)
{
    if (!map || !map->data || map->channels < 1 || map->width < 2 || map->height < 1)
        return hd_fail(HD_ERR_ARG, "environment map: empty or fewer than 2 columns");
    if (!isfinite(rotation_deg)) return hd_fail(HD_ERR_ARG, "environment map: the rotation is not finite");
    const int cols = map->width < ENV_COLUMNS ? map->width : ENV_COLUMNS;
    const int rows = map->height < cols / 2 ? map->height : (cols / 2 > 0 ? cols / 2 : 1);
    hd_image small = {0};
    hd_status st = hd_image_resize(map, cols, rows, &small);
    if (st != HD_OK) return st;
    const size_t cells = (size_t)cols * rows, plane = cells;
    for (size_t i = 0; i < cells * (size_t)small.channels; i++)
        if (!isfinite(small.data[i]) || small.data[i] < 0) {
            hd_image_free(&small);
            return hd_fail(HD_ERR_NUMERIC, "environment map: a radiance is negative or not finite");
        }
    /* each cell's direction and solid angle weight cos(e) de da */
    double *dir = hd_malloc(cells * 3 * sizeof(double)), *wt = hd_malloc(cells * sizeof(double));
    float *normals = hd_malloc(3 * ENV_NORMALS * sizeof(float)), *shade = hd_malloc(ENV_NORMALS * sizeof(float));
    if (!dir || !wt || !normals || !shade) st = HD_ERR_NOMEM;
    const double rot = rotation_deg * M_PI / 180.0;
    for (int y = 0; st == HD_OK && y < rows; y++)
        for (int x = 0; x < cols; x++) {
            /* u = 0.5 looks from the viewer (azimuth 0); the top row is elevation +90 */
            double a = (2.0 * M_PI) * ((x + 0.5) / cols - 0.5) + rot, e = M_PI / 2 - M_PI * (y + 0.5) / rows;
            size_t i = (size_t)y * cols + x;
            direction(a, e, dir + 3 * i);
            wt[i] = cos(e) * (M_PI / rows) * (2.0 * M_PI / cols);
        }
    /* Fibonacci sphere of normals, planar */
    for (int i = 0; st == HD_OK && i < ENV_NORMALS; i++) {
        double z = 1.0 - (2.0 * i + 1.0) / ENV_NORMALS, r = sqrt(1.0 - z * z), phi = i * M_PI * (3.0 - sqrt(5.0));
        normals[i] = (float)(r * cos(phi));
        normals[ENV_NORMALS + i] = (float)(r * sin(phi));
        normals[2 * ENV_NORMALS + i] = (float)z;
    }
    for (int c = 0; c < 3 && st == HD_OK; c++) {
        const float *L = small.data + (size_t)(small.channels >= 3 ? c : 0) * plane;
        for (int i = 0; i < ENV_NORMALS; i++) {
            double n[3] = {normals[i], normals[ENV_NORMALS + i], normals[2 * ENV_NORMALS + i]}, acc = 0;
            for (size_t k = 0; k < cells; k++) {
                double cosine = n[0] * dir[3 * k] + n[1] * dir[3 * k + 1] + n[2] * dir[3 * k + 2];
                if (cosine > 0) acc += L[k] * cosine * wt[k];
            }
            shade[i] = (float)(acc / M_PI);
        }
        st = hd_sh_fit(normals, shade, NULL, ENV_NORMALS, out->sh[c]);
    }
    /* a grey map gives a grey light exactly */
    if (st == HD_OK && small.channels < 3) memcpy(out->sh[1], out->sh[0], sizeof out->sh[0]), memcpy(out->sh[2], out->sh[0], sizeof out->sh[0]);
    free(dir), free(wt), free(normals), free(shade);
    hd_image_free(&small);
    return st;
}

hd_status hd_light_rgb_sphere(const hd_light_rgb *light, int size, hd_image *out)
{
    hd_status st = HD_OK;
    memset(out, 0, sizeof *out);
    for (int c = 0; c < 3 && st == HD_OK; c++) {
        hd_image one = {0};
        st = hd_light_sphere(light->sh[c], size, &one);
        if (st == HD_OK && c == 0) st = hd_image_alloc(out, size, size, 3);
        if (st == HD_OK) {
            size_t plane = (size_t)size * size;
            memcpy(out->data + c * plane, one.data + c * plane, plane * sizeof(float));
        }
        hd_image_free(&one);
    }
    if (st != HD_OK) hd_image_free(out);
    return st;
}
