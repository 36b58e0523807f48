/* cmd_blend.c: `hdnet blend`: Poisson blending (seamless cloning) of a source image into a target,
 * either placed at an offset or, with --warp, warped back from the aligned texture space into the
 * photo a face was aligned from (the .warp.txt file `hdnet align` writes). */
#include <stdlib.h>
#include <string.h>
#include "cli.h"
#include "hdnet_tool.h"

CLI_COMMAND("blend", cmd_blend, "Poisson-blend an image (or an aligned face texture) into a photo")

int cmd_blend(int argc, char **argv)
{
    const char *source_path = NULL, *target_path = NULL, *mask_path = NULL, *warp_path = NULL, *out_path = NULL,
               *original_path = NULL;
    cli_opt_floats offset = {0, 2, {0}};
    float tolerance = (float)HD_POISSON_TOLERANCE;
    int quiet = 0, threads = 0;
    const cli_opt opts[] = {
        {"source", 0, CLI_OPT_STRING, &source_path, "S.png", "the image to blend in (required)"},
        {"target", 0, CLI_OPT_STRING, &target_path, "T.png", "the photo to blend into (required)"},
        {"mask", 0, CLI_OPT_STRING, &mask_path, "M.png",
         "where the source counts (> 0.5; source-sized; default: all of it, with --warp the mesh's UV layout; "
         "give the face's .mask.png)"},
        {"offset", 0, CLI_OPT_FLOATS, &offset, "X,Y", "target pixel of the source's top-left pixel (default 0,0)"},
        {"warp", 0, CLI_OPT_STRING, &warp_path, "W.warp.txt",
         "the source is an aligned texture of this face (from `hdnet align`): warp it back into the target first"},
        {"original", 0, CLI_OPT_STRING, &original_path, "FACE.png",
         "with --warp: the face's own unwarped texture (face<k>.png); only the change source - original is put "
         "into the photo, which keeps the photo's full-resolution detail"},
        {"tolerance", 0, CLI_OPT_FLOAT, &tolerance, "X", "relative residual the solver must reach (default 1e-4)"},
        {"output", 'o', CLI_OPT_STRING, &out_path, "OUT.png", "where to write the result, 8-bit PNG (required)"},
        CLI_OPT_THREADS_ROW(threads),
        CLI_OPT_QUIET_ROW(quiet),
        {0},
    };
    cli_cmd_spec spec = {
        "blend",
        "--source S.png --target T.png [--mask M.png] [--offset X,Y | --warp W.warp.txt [--original FACE.png]] "
        "-o OUT.png",
        "Seamless cloning (Perez et al. 2003): inside the mask, the result keeps the source's gradients and\n"
        "meets the target on the mask's boundary, so no seam shows. Solved per channel at full resolution by\n"
        "conjugate gradients with a multigrid preconditioner to the given relative residual, which is printed.\n"
        "With --warp, the source is a texture in the aligned texture space (any size) and is warped back into\n"
        "the target photo through the face's landmarks before blending; with --original as well, only the\n"
        "change it makes to the face's own texture is added to the photo (docs/alignment.md).",
        opts, 0, 0};
    char **pos;
    int np, code;
    if (cli_opts_parse(&spec, argc, argv, &pos, &np, &code)) return code;
    free(pos);
    if ((code = cli_opts_common(&spec, threads, 1.0f))) return code;
    if (!source_path) return cli_usage_error(&spec, "--source is required");
    if (!target_path) return cli_usage_error(&spec, "--target is required");
    if (!out_path) return cli_usage_error(&spec, "-o OUT.png is required");
    if (offset.count != 0 && offset.count != 2) return cli_usage_error(&spec, "--offset wants X,Y");
    if (offset.count && warp_path) return cli_usage_error(&spec, "--offset and --warp exclude each other");
    if (original_path && !warp_path) return cli_usage_error(&spec, "--original goes with --warp");
    if (!(tolerance > 0 && tolerance < 1)) return cli_usage_error(&spec, "--tolerance must be in (0, 1)");
    int ox = 0, oy = 0;
    if (offset.count) {
        if (offset.v[0] != (int)offset.v[0] || offset.v[1] != (int)offset.v[1] || offset.v[0] < -HD_IMAGE_MAX_SIDE ||
            offset.v[0] > HD_IMAGE_MAX_SIDE || offset.v[1] < -HD_IMAGE_MAX_SIDE || offset.v[1] > HD_IMAGE_MAX_SIDE)
            return cli_usage_error(&spec, "--offset wants two whole numbers of pixels within +-%d", HD_IMAGE_MAX_SIDE);
        ox = (int)offset.v[0];
        oy = (int)offset.v[1];
    }

    int rc = CLI_EXIT_FAIL, reported = 0;
    hd_image source = {0}, target = {0}, mask = {0};
    hd_aligned_face face;
    memset(&face, 0, sizeof face);
    hd_poisson_report rep;
    if (hd_image_read_as(source_path, 3, &source) || hd_image_read_as(target_path, 3, &target)) goto done;
    if (mask_path && hd_image_read_as(mask_path, 1, &mask)) goto done;
    if (mask.data && (mask.width != source.width || mask.height != source.height)) {
        fprintf(stderr, "hdnet blend: %s is %dx%d, the source %s is %dx%d: the mask must be source-sized\n", mask_path,
                mask.width, mask.height, source_path, source.width, source.height);
        reported = 1;
        goto done;
    }
    if (warp_path) {
        if (hd_aligned_face_read_warp(warp_path, &face)) goto done;
        if (target.width != face.photo_width || target.height != face.photo_height) {
            fprintf(stderr, "hdnet blend: %s is %dx%d but %s was aligned from a %dx%d photo\n", target_path,
                    target.width, target.height, warp_path, face.photo_width, face.photo_height);
            reported = 1;
            goto done;
        }
        /* the texture's own mask if given (borrowed: sampled where > 0.5), else the UV layout */
        face.mask = mask;
        hd_status st = HD_OK;
        if (original_path) {
            st = hd_image_read_as(original_path, 3, &face.texture);
            if (!st && (face.texture.width != face.size || face.texture.height != face.size))
                st = hd_fail(HD_ERR_ARG, "%s is %dx%d, but %s says the aligned texture is %dx%d", original_path,
                             face.texture.width, face.texture.height, warp_path, face.size, face.size);
        }
        if (!st)
            st = hd_warp_back_blend(&face, &source, original_path ? HD_WARP_CHANGE : HD_WARP_REPLACE, tolerance, &target,
                                    &rep);
        face.mask = (hd_image){0};
        hd_image_free(&face.texture);
        if (st) goto done;
    } else {
        if (!mask.data) {
            if (hd_image_alloc(&mask, source.width, source.height, 1)) goto done;
            for (size_t i = 0; i < (size_t)source.width * source.height; i++) mask.data[i] = 1.0f;
        }
        if (hd_poisson_blend(&source, &mask, ox, oy, tolerance, &target, &rep)) goto done;
    }
    if (hd_image_write_picture(out_path, &target)) goto done; /* PNG, JPEG or PFM by extension */
    if (!quiet) {
        printf("blended %d pixels x %d channels: CG iterations", rep.unknowns, rep.channels);
        for (int c = 0; c < rep.channels && c < 4; c++) printf(" %d", rep.iterations[c]);
        double worst = 0;
        for (int c = 0; c < rep.channels && c < 4; c++)
            if (rep.residual[c] > worst) worst = rep.residual[c];
        printf(", relative residual %.2g (tolerance %.2g), %.2f s -> %s\n", worst, rep.tolerance, rep.seconds, out_path);
    }
    rc = CLI_EXIT_OK;
done:
    if (rc != CLI_EXIT_OK && !reported) cli_report("blend");
    hd_image_free(&source);
    hd_image_free(&target);
    hd_image_free(&mask);
    return rc;
}
