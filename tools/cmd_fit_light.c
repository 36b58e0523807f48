/* cmd_fit_light.c: `hdnet fit-light`: the least-squares light of SPEC section 2 from a normal map
 * and either a shading map or an image with its albedo (s = I / A). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"

CLI_COMMAND("fit-light", cmd_fit_light, "fit the least-squares SH light to normals and shading")

/* Shading albedo below this is too dark to divide by (the pixel is left out of the fit). */
#define FIT_ALBEDO_MIN 0.02f

/* 1 if the file starts with the PFM magic ("PF" or "Pf"). */
static int is_pfm(const char *path)
{
    char magic[2] = {0, 0};
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    size_t got = fread(magic, 1, 2, f);
    fclose(f);
    return got == 2 && magic[0] == 'P' && (magic[1] == 'F' || magic[1] == 'f');
}

static int same_size(const char *pa, const hd_image *a, const char *pb, const hd_image *b)
{
    if (a->width == b->width && a->height == b->height) return 1;
    fprintf(stderr, "hdnet fit-light: %s is %dx%d but %s is %dx%d (they must have the same size)\n", pa,
            a->width, a->height, pb, b->width, b->height);
    return 0;
}

int cmd_fit_light(int argc, char **argv)
{
    const char *normal_path = NULL, *shading_path = NULL, *image_path = NULL, *albedo_path = NULL;
    const char *mask_path = NULL, *out = NULL;
    int quiet = 0;
    const cli_opt opts[] = {
        {"normal", 0, CLI_OPT_STRING, &normal_path, "N.png", "normal map, rgb = (n + 1) / 2, camera frame; 0 = no normal"},
        {"shading", 0, CLI_OPT_STRING, &shading_path, "S",
         "shading: 16-bit PNG holding s/2 (doubled on reading), or PFM holding s exactly"},
        {"image", 0, CLI_OPT_STRING, &image_path, "I", "an image, with --albedo: s = mean over channels of I/A"},
        {"albedo", 0, CLI_OPT_STRING, &albedo_path, "A", "the image's albedo (channels with A <= 0.02 are left out)"},
        {"mask", 0, CLI_OPT_STRING, &mask_path, "M.png", "per-pixel weight of the fit in [0, 1] (default 1)"},
        {"output", 'o', CLI_OPT_STRING, &out, "L.txt", "the light file written"},
        CLI_OPT_QUIET_ROW(quiet),
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const cli_cmd_spec spec = {
        "fit-light", "--normal N.png (--shading S | --image I --albedo A) [--mask M.png] -o L.txt",
        "Fits the 9 SH coefficients l minimising sum_p m_p (b(n_p) . l - s_p)^2 (docs/spec.md section 2) over\n"
        "the pixels with a normal and a positive mask, writes them as a light file and prints them\n"
        "with the root-mean-square residual.",
        opts, 0, 0};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    free(pos);
    if (!normal_path || !out) return cli_usage_error(&spec, "--normal and -o are required");
    if (shading_path ? (image_path || albedo_path) : !(image_path && albedo_path))
        return cli_usage_error(&spec, "give either --shading, or both --image and --albedo");

    hd_image normal_rgb = {0}, normal = {0}, weight = {0}, shading = {0}, image = {0}, albedo = {0}, mask = {0};
    int rc = CLI_EXIT_FAIL;
    if (hd_image_read_as(normal_path, 3, &normal_rgb) != HD_OK ||
        hd_normal_decode(&normal_rgb, &normal, &weight) != HD_OK) {
        rc = cli_report("fit-light");
        goto done;
    }
    const size_t npix = (size_t)normal.width * normal.height;
    if (shading_path) {
        if (hd_image_read_as(shading_path, 1, &shading) != HD_OK) {
            rc = cli_report("fit-light");
            goto done;
        }
        if (!same_size(shading_path, &shading, normal_path, &normal)) goto done;
        if (!is_pfm(shading_path))
            for (size_t p = 0; p < npix; p++) shading.data[p] *= 2.0f; /* PNG holds s / 2 */
    } else {
        if (hd_image_read_as(image_path, 3, &image) != HD_OK || hd_image_read_as(albedo_path, 3, &albedo) != HD_OK ||
            hd_image_alloc(&shading, normal.width, normal.height, 1) != HD_OK) {
            rc = cli_report("fit-light");
            goto done;
        }
        if (!same_size(image_path, &image, normal_path, &normal) ||
            !same_size(albedo_path, &albedo, normal_path, &normal))
            goto done;
        /* s = mean over the channels with A > 0.02 of I / A; no such channel: left out */
        for (size_t p = 0; p < npix; p++) {
            float sum = 0.0f;
            int n = 0;
            for (int c = 0; c < 3; c++) {
                float a = albedo.data[c * npix + p];
                if (a > FIT_ALBEDO_MIN) {
                    sum += image.data[c * npix + p] / a;
                    n++;
                }
            }
            shading.data[p] = n ? sum / n : 0.0f;
            if (!n) weight.data[p] = 0.0f;
        }
    }
    if (mask_path) {
        if (hd_image_read_as(mask_path, 1, &mask) != HD_OK) {
            rc = cli_report("fit-light");
            goto done;
        }
        if (!same_size(mask_path, &mask, normal_path, &normal)) goto done;
        for (size_t p = 0; p < npix; p++) weight.data[p] *= mask.data[p];
    }
    double wsum = 0.0;
    long used = 0;
    for (size_t p = 0; p < npix; p++)
        if (weight.data[p] > 0.0f) {
            wsum += weight.data[p];
            used++;
        }
    if (used == 0) {
        fprintf(stderr, "hdnet fit-light: no pixel to fit (no normal, mask or usable albedo anywhere)\n");
        goto done;
    }
    float light[HD_SH_COEFFS];
    if (hd_sh_fit(normal.data, shading.data, weight.data, (int)npix, light) != HD_OK ||
        hd_light_write(out, light) != HD_OK) {
        rc = cli_report("fit-light");
        goto done;
    }
    /* weighted RMS of the residual b(n_p) . l - s_p */
    double sq = 0.0;
    for (size_t p = 0; p < npix; p++) {
        if (!(weight.data[p] > 0.0f)) continue;
        const float n[3] = {normal.data[p], normal.data[npix + p], normal.data[2 * npix + p]};
        double r = hd_sh_shade(light, n) - shading.data[p];
        sq += weight.data[p] * r * r;
    }
    if (!quiet) {
        printf("light:");
        for (int k = 0; k < HD_SH_COEFFS; k++) printf(" %.6f", (double)light[k]);
        printf("\npixels: %ld  rms residual: %.6f\nwrote %s\n", used, sqrt(sq / wsum), out);
    }
    rc = CLI_EXIT_OK;
done:
    hd_image_free(&normal_rgb);
    hd_image_free(&normal);
    hd_image_free(&weight);
    hd_image_free(&shading);
    hd_image_free(&image);
    hd_image_free(&albedo);
    hd_image_free(&mask);
    return rc;
}
