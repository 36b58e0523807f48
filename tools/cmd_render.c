/* cmd_render.c: `hdnet render`: the Lambertian image formation of the paper,
 *     image = albedo x s(normal, light),   s(n) = sum_k l_k b_k(n)   (SPEC section 2),
 * from an albedo picture, a normal map and a light file; optionally also the shading. */
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include "cli.h"
#include "hdnet_tool.h"

CLI_COMMAND("render", cmd_render, "render albedo x shading(normal, light) into an image")

static int ends_with_pfm(const char *path)
{
    size_t n = strlen(path);
    return n >= 4 && strcasecmp(path + n - 4, ".pfm") == 0;
}

/* 1 if a and b have the same size; else prints why not and returns 0. */
static int same_size(const char *cmd, const char *pa, const hd_image *a, const char *pb, const hd_image *b)
{
    if (a->width == b->width && a->height == b->height) return 1;
    fprintf(stderr, "hdnet %s: %s is %dx%d but %s is %dx%d (they must have the same size)\n", cmd, pa, a->width,
            a->height, pb, b->width, b->height);
    return 0;
}

int cmd_render(int argc, char **argv)
{
    const char *albedo_path = NULL, *normal_path = NULL, *light_path = NULL, *mask_path = NULL;
    const char *out = NULL, *shading_path = NULL;
    int quiet = 0;
    const cli_opt opts[] = {
        {"albedo", 0, CLI_OPT_STRING, &albedo_path, "A.png", "albedo (RGB or gray, values in [0, 1])"},
        {"normal", 0, CLI_OPT_STRING, &normal_path, "N.png", "normal map, rgb = (n + 1) / 2, camera frame; 0 = no normal"},
        {"light", 0, CLI_OPT_STRING, &light_path, "L.txt", "light file (9 SH coefficients, DPR order)"},
        {"mask", 0, CLI_OPT_STRING, &mask_path, "M.png",
         "render only where the mask is > 0.5 (default: where the normal map is not 0)"},
        {"output", 'o', CLI_OPT_STRING, &out, "image.png", "the rendered image (8-bit PNG, or PFM if it ends in .pfm)"},
        {"shading", 0, CLI_OPT_STRING, &shading_path, "S.png",
         "also write the shading: 16-bit PNG of s/2, or exact PFM if it ends in .pfm"},
        CLI_OPT_QUIET_ROW(quiet),
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const cli_cmd_spec spec = {
        "render", "--albedo A.png --normal N.png --light L.txt [--mask M.png] -o image.png [--shading S.png]",
        "Renders image = albedo x s(normal, light), the Lambertian model of the paper, with the\n"
        "spherical-harmonics shading of docs/conventions.md. Pixels outside the mask (or where the\n"
        "normal map holds 0) are black in the image and 0 in the shading.",
        opts, 0, 0};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    free(pos);
    if (!albedo_path || !normal_path || !light_path || !out)
        return cli_usage_error(&spec, "--albedo, --normal, --light and -o are required");

    hd_image albedo = {0}, normal_rgb = {0}, normal = {0}, normal_mask = {0}, mask = {0}, shading = {0},
             image = {0};
    float light[HD_SH_COEFFS];
    int rc = CLI_EXIT_FAIL;
    if (hd_light_read(light_path, light) != HD_OK || hd_image_read_as(albedo_path, 3, &albedo) != HD_OK ||
        hd_image_read_as(normal_path, 3, &normal_rgb) != HD_OK ||
        hd_normal_decode(&normal_rgb, &normal, &normal_mask) != HD_OK) {
        rc = cli_report("render");
        goto done;
    }
    if (!same_size("render", albedo_path, &albedo, normal_path, &normal)) goto done;
    if (mask_path) {
        if (hd_image_read_as(mask_path, 1, &mask) != HD_OK) {
            rc = cli_report("render");
            goto done;
        }
        if (!same_size("render", mask_path, &mask, normal_path, &normal)) goto done;
    }
    const int w = normal.width, h = normal.height;
    const size_t npix = (size_t)w * h;
    if (hd_image_alloc(&shading, w, h, 1) != HD_OK || hd_image_alloc(&image, w, h, 3) != HD_OK) {
        rc = cli_report("render");
        goto done;
    }
    /* the mask used: the given one (> 0.5) and a decodable normal */
    for (size_t p = 0; p < npix; p++) {
        int inside = normal_mask.data[p] > 0.5f && (!mask_path || mask.data[p] > 0.5f);
        normal_mask.data[p] = inside ? 1.0f : 0.0f;
    }
    hd_sh_shading_map(normal.data, normal_mask.data, (int)npix, light, shading.data);
    for (int c = 0; c < 3; c++)
        for (size_t p = 0; p < npix; p++) image.data[c * npix + p] = albedo.data[c * npix + p] * shading.data[p];

    /* a non-finite result (an albedo PFM of huge values) is an error naming the inputs; the image
     * and the shading are written as a set, both or neither */
    char what[1400];
    snprintf(what, sizeof what, "%s: the render of albedo %s under light %s (nothing written)", out, albedo_path, light_path);
    hd_status st = hd_image_check_finite(&image, what);
    if (st == HD_OK) {
        snprintf(what, sizeof what, "%s: the shading of %s under light %s (nothing written)",
                 shading_path ? shading_path : out, normal_path, light_path);
        st = hd_image_check_finite(&shading, what);
    }
    hd_atomic_set_begin();
    if (st == HD_OK) st = hd_image_write_picture(out, &image); /* PNG, JPEG or PFM by extension */
    if (st == HD_OK && shading_path) {
        if (ends_with_pfm(shading_path)) {
            st = hd_image_write_pfm(shading_path, &shading);
        } else {
            for (size_t p = 0; p < npix; p++) shading.data[p] *= 0.5f; /* PNG holds s / 2 */
            st = hd_image_write_png(shading_path, &shading, 16);
        }
    }
    hd_status set_end = hd_atomic_set_end(st == HD_OK);
    if (st == HD_OK) st = set_end;
    rc = st == HD_OK ? CLI_EXIT_OK : cli_report("render");
    if (st == HD_OK && !quiet) printf("wrote %s%s%s\n", out, shading_path ? " and " : "", shading_path ? shading_path : "");
done:
    hd_image_free(&albedo);
    hd_image_free(&normal_rgb);
    hd_image_free(&normal);
    hd_image_free(&normal_mask);
    hd_image_free(&mask);
    hd_image_free(&shading);
    hd_image_free(&image);
    return rc;
}
