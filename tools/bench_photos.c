/* bench_photos.c: the photo throughput section of `hdnet bench`: photos per second end to end
 * through `hdnet relight`'s per-photo steps (PNG decode, face detection, landmarks and alignment,
 * the model and the ratio rule on the full-size photo, PNG encode) on a 1024 x 1024 portrait (the
 * bundled photo enlarged), with the shipped model at the bench's thread count; each step the
 * median of a->repeats photos after one warm-up. */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "bench.h"
#include "hdnet_tool.h"

#define PORTRAIT_SIDE 1024

int bench_photos(const bench_args *a)
{
    FILE *out = a->out ? a->out : stdout;
    const int repeats = a->repeats > 0 ? a->repeats : 5;
    char path[4200], dir[] = "/tmp/hdnet-bench-photos.XXXXXX", in_png[64], out_png[64];
    hd_image photo = {0}, portrait = {0}, decoded = {0}, relit = {0};
    hd_model *model = NULL;
    hd_aligner *aligner = NULL;
    double *t[5];
    for (int k = 0; k < 5; k++) t[k] = hd_calloc((size_t)repeats, sizeof(double));
    int rc = 1, made_dir = 0, faces = 0;
    float light[HD_SH_COEFFS];
    hd_light_preset(3, light);
    if (!t[0] || !t[1] || !t[2] || !t[3] || !t[4]) goto done;
    if (hd_model_load(NULL, &model) != HD_OK) { /* no shipped model: say so, not a failure */
        if (a->json) fprintf(out, "\"photos_skipped\": \"%s\",\n", "no shipped model");
        else fprintf(out, "\nphotos end to end: skipped (%s)\n", hd_error());
        rc = 0;
        goto done;
    }
    if (bench_read_photo(&photo, path, sizeof path) != HD_OK ||
        hd_image_resize(&photo, PORTRAIT_SIDE, PORTRAIT_SIDE, &portrait) != HD_OK || hd_aligner_load(&aligner) != HD_OK)
        goto done;
    if (!mkdtemp(dir)) {
        hd_fail(HD_ERR_IO, "%s: cannot make a scratch folder", dir);
        goto done;
    }
    made_dir = 1;
    snprintf(in_png, sizeof in_png, "%s/in.png", dir);
    snprintf(out_png, sizeof out_png, "%s/out.png", dir);
    if (hd_image_write_png(in_png, &portrait, 8) != HD_OK) goto done;
    for (int r = -1; r < repeats; r++) { /* r = -1 warms up */
        double t0 = hd_seconds();
        if (hd_image_read_as(in_png, 3, &decoded) != HD_OK) goto done;
        double t1 = hd_seconds();
        hd_aligned_face *f = NULL;
        int n = 0;
        if (hd_photo_faces(aligner, model, &decoded, &f, &n) != HD_OK) goto done; /* alone, to split the time */
        hd_aligned_faces_free(f, n);
        double t2 = hd_seconds();
        if (hd_relight_photo(model, aligner, &decoded, (const float (*)[HD_SH_COEFFS])light, 1, HD_BRIGHTNESS_KEEP,
                             &relit, NULL, &faces) != HD_OK)
            goto done;
        double t3 = hd_seconds();
        if (hd_image_write_png(out_png, &relit, 8) != HD_OK) goto done;
        double t4 = hd_seconds();
        hd_image_free(&decoded);
        hd_image_free(&relit);
        if (r < 0) continue;
        t[0][r] = t1 - t0;             /* decode */
        t[1][r] = t2 - t1;             /* detect + landmarks + align */
        t[2][r] = (t3 - t2) - (t2 - t1); /* the model and the ratio rule on the photo */
        t[3][r] = t4 - t3;             /* encode */
        t[4][r] = (t1 - t0) + (t3 - t2) + (t4 - t3); /* one photo as `hdnet relight` does it */
    }
    double m[5];
    for (int k = 0; k < 5; k++) m[k] = bench_median(t[k], repeats);
    if (a->json) {
        fprintf(out, "\"photos_side\": %d,\n\"photos_faces\": %d,\n\"photos_decode_s\": %.6f,\n\"photos_align_s\": %.6f,\n"
                     "\"photos_model_blend_s\": %.6f,\n\"photos_encode_s\": %.6f,\n\"photos_total_s\": %.6f,\n"
                     "\"photos_per_s\": %.3f,\n",
                PORTRAIT_SIDE, faces, m[0], m[1], m[2], m[3], m[4], 1.0 / m[4]);
    } else {
        fprintf(out, "\nphotos end to end (%s enlarged to %dx%d, %d face, relit under preset 3 with the shipped model,\n"
                     "%d threads, median of %d)\n", path, PORTRAIT_SIDE, PORTRAIT_SIDE, faces, a->threads, repeats);
        fprintf(out, "  %-44s %8.1f ms\n", "PNG decode", 1e3 * m[0]);
        fprintf(out, "  %-44s %8.1f ms\n", "detect, landmarks, align", 1e3 * m[1]);
        fprintf(out, "  %-44s %8.1f ms\n", "model, relight (ratio rule on the photo)", 1e3 * m[2]);
        fprintf(out, "  %-44s %8.1f ms\n", "PNG encode", 1e3 * m[3]);
        fprintf(out, "  %-44s %8.1f ms  = %.2f photos/s\n", "per photo, end to end", 1e3 * m[4], 1.0 / m[4]);
    }
    rc = 0;
done:
    if (rc) fprintf(stderr, "hdnet bench: photos: %s\n", hd_error());
    if (made_dir) {
        unlink(in_png);
        unlink(out_png);
        rmdir(dir);
    }
    for (int k = 0; k < 5; k++) free(t[k]);
    hd_image_free(&photo);
    hd_image_free(&portrait);
    hd_image_free(&decoded);
    hd_image_free(&relit);
    if (model) hd_model_free(model);
    hd_aligner_free(aligner);
    return rc;
}
