/* test_reference_light.c: the light of a reference face (src/mesh/reference_light.c) against a
 * known point light. A face-like shape (a shallow ellipsoid, so that, as on a face, the normals fill
 * a cap around the viewer and the frontal texels outnumber the turned ones) is lit by a distant
 * light with some ambient, clamped at zero, with a specular highlight (Blinn-Phong) where the
 * face turns halfway between the light and the viewer, and a cast shadow darkening a band on the
 * far side (what a nose or a brow does). The highlight on the frontal texels pulls the own-light
 * fit's direction toward the viewer; the reference fit's direction must be at least a tenth closer
 * to the true one than the own-light fit's (hd_face_light_fit), both seeing the same texels (a
 * fifth with the floor 0.2 of sessions 20 to 26: 9.11 against 11.63 degrees in the first case; the
 * floor 0.5 weighs the turned texels up less, 10.45, and is nearer the truth on the Yale tuning
 * photos now that the rule casts shadows). (With
 * a cast shadow and no highlight the reference fit is about 1 degree worse here: the turned texels
 * it leans on are the shadowed ones. On the Yale tuning photos it is 2 degrees better on average,
 * docs/evaluation.md.) */
#include <stdlib.h>
#include <string.h>
#include "test.h"
#include "source_dir.h"
#include "core/core.h"
#include "mesh/mesh.h"
#include "light/light.h"

#define SIZE 64

/* The angle in degrees between the first band of light l (camera frame (l3, l2, -l1)) and d. */
static double direction_error(const float l[HD_SH_COEFFS], const double d[3])
{
    const double v[3] = {l[3], l[2], -l[1]};
    const double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    double c = (v[0] * d[0] + v[1] * d[1] + v[2] * d[2]) / len;
    c = c > 1 ? 1 : c < -1 ? -1 : c;
    return acos(c) * 180.0 / M_PI;
}

/* A shallow ellipsoid's normals over the texture (semi-axes 1, 1.2, 2.5 in x, y, z), the shading of a distant light from d with ambient 0.1 clamped at 0,
 * plus specular x the highlight, and a cast shadow (shading x 0.15) on
 * the texels with x beyond shadow_x on the side away from the light; mask 1 inside the outline. */
static void render(const double d[3], float shadow_x, double specular, float *normal, float *shading, float *mask)
{
    const int P = SIZE * SIZE;
    for (int y = 0; y < SIZE; y++)
        for (int x = 0; x < SIZE; x++) {
            const int p = y * SIZE + x;
            const double u = (x + 0.5) / SIZE * 2 - 1, v = 1 - (y + 0.5) / SIZE * 2; /* v up */
            const double r2 = u * u + (v / 1.2) * (v / 1.2);
            mask[p] = r2 < 0.95 ? 1.0f : 0.0f;
            const double h = sqrt(r2 < 0.999 ? 1 - r2 : 0.001);
            /* the ellipsoid's normal at (u, v): (u, v / 1.2^2, z / 2.5^2), z = 2.5 h */
            const double n[3] = {u, v / (1.2 * 1.2), h / 2.5};
            const double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            for (int c = 0; c < 3; c++) normal[c * P + p] = (float)(n[c] / len);
            double s = (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) / len;
            s = 0.1 + (s > 0 ? s : 0);
            /* a specular highlight (Blinn-Phong, exponent 20) around the half-vector of light and viewer */
            const double hv[3] = {d[0], d[1], d[2] + 1}, hl = sqrt(hv[0] * hv[0] + hv[1] * hv[1] + hv[2] * hv[2]);
            const double nh = (n[0] * hv[0] + n[1] * hv[1] + n[2] * hv[2]) / (len * hl);
            if (nh > 0) s += specular * pow(nh, 20);
            if (d[0] * u < 0 && fabs(u) > shadow_x) s *= 0.15; /* the cast shadow, away from the light */
            shading[p] = (float)s;
        }
}

static void test_point_light(float az, float el, float shadow_x, double specular)
{
    const int P = SIZE * SIZE;
    float *normal = malloc(3 * sizeof(float) * P), *shading = malloc(sizeof(float) * P), *mask = malloc(sizeof(float) * P);
    float *weight = malloc(sizeof(float) * P);
    hd_image layout = {0};
    CHECK(normal && shading && mask && weight);
    CHECK(hd_face_light_layout(SIZE, &layout) == HD_OK);
    if (!normal || !shading || !mask || !weight || !layout.data) exit(1);
    const double a = az * M_PI / 180, e = el * M_PI / 180;
    const double d[3] = {cos(e) * sin(a), sin(e), cos(e) * cos(a)};
    render(d, shadow_x, specular, normal, shading, mask);
    float own[HD_SH_COEFFS], lobe[HD_SH_COEFFS], ref[HD_SH_COEFFS];
    CHECK(hd_face_light_fit(normal, shading, layout.data, mask, P, weight, lobe, 0, own) == HD_OK);
    CHECK(hd_reference_light_fit(normal, shading, layout.data, mask, P, weight, ref) == HD_OK);
    const double e_own = direction_error(own, d), e_ref = direction_error(ref, d);
    printf("light az %g el %g, cast shadow beyond |x| %g, specular %g: own-light fit %.2f degrees off, "
           "reference fit %.2f\n", az, el, shadow_x, specular, e_own, e_ref);
    CHECK(e_ref < e_own);
    CHECK(e_ref < 0.9 * e_own);
    free(normal), free(shading), free(mask), free(weight);
    hd_image_free(&layout);
}

/* Arguments that are not a fit: an error, and the zero light. */
static void test_arguments(void)
{
    float light[HD_SH_COEFFS], w[4], layout[4] = {1, 1, 1, 1};
    CHECK(hd_reference_light_fit(NULL, NULL, layout, NULL, -1, w, light) == HD_ERR_ARG);
    CHECK(hd_reference_light_fit(NULL, NULL, NULL, NULL, 4, w, light) == HD_ERR_ARG);
    hd_clear_error();
    for (int k = 0; k < HD_SH_COEFFS; k++) CHECK(light[k] == 0.0f);
}

int main(void)
{
    /* the canonical mesh (for the face regions of the fit's layout): the source tree's models/ */
    if (!getenv("HDNET_DATA")) {
        char dir[4400];
        snprintf(dir, sizeof dir, "%s/models", test_source_dir());
        setenv("HDNET_DATA", dir, 1);
    }
    test_point_light(-50.0f, 30.0f, 0.3f, 1.0);
    test_point_light(40.0f, -20.0f, 0.4f, 1.0);
    test_point_light(25.0f, 0.0f, 0.5f, 1.0);
    test_point_light(-50.0f, 30.0f, 2.0f, 1.0); /* no cast shadow */
    test_arguments();
    return test_summary("test_reference_light");
}
