/* serve_weight.c: the check behind tests/serve_api.sh's weight map. Aligns and decomposes the
 * photo's faces as `hdnet serve` and `hdnet relight` do (the shipped model's texture size),
 * computes the weight the ratio rule applies each face's change with as hd_apply_photo does
 * (hd_photo_face_weight, then over the whole head hd_head_init and hd_head_weight under the face's
 * own light; the largest over the faces) and compares it with the 8-bit map the server sent: every
 * pixel within one level (half a level of rounding, and a weight under half a level is sent as
 * one), and 0 exactly where the weight is 0. Exits 1 on the first pixel that differs, printing it
 * and both values.
 *     serve_weight PHOTO.png WEIGHT.png */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "../tools/hdnet_tool.h"

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: serve_weight PHOTO WEIGHT.png\n");
        return 2;
    }
    hd_image photo = {0}, served = {0};
    hd_model *model = NULL;
    hd_aligner *aligner = NULL;
    hd_aligned_face *faces = NULL;
    int n = 0, rc = 1;
    float *weight = NULL, *one = NULL;
    hd_status st = hd_image_read_as(argv[1], 3, &photo);
    if (st == HD_OK) st = hd_image_read_as(argv[2], 1, &served);
    if (st == HD_OK && (served.width != photo.width || served.height != photo.height))
        st = hd_fail(HD_ERR_ARG, "the weight map is %d x %d, the photo %d x %d", served.width, served.height,
                     photo.width, photo.height);
    if (st == HD_OK) st = hd_model_load(NULL, &model);
    if (st == HD_OK) st = hd_aligner_load(&aligner);
    if (st == HD_OK) st = hd_photo_faces(aligner, model, &photo, &faces, &n);
    const size_t P = (size_t)photo.width * (size_t)photo.height;
    if (st == HD_OK && (!(weight = hd_calloc(P, sizeof *weight)) || !(one = hd_malloc(P * sizeof *one))))
        st = HD_ERR_NOMEM;
    for (int k = 0; k < n && st == HD_OK; k++) {
        hd_decomposition d;
        hd_head head;
        float light[HD_SH_COEFFS];
        memset(&d, 0, sizeof d), memset(&head, 0, sizeof head);
        st = hd_model_decompose(model, &faces[k].texture, 1, &d);
        if (st == HD_OK) st = hd_face_light(&d, &faces[k].mask, HD_SOURCE_FIT, light);
        if (st == HD_OK) st = hd_photo_face_weight(&faces[k], &photo, one);
        if (st == HD_OK) st = hd_head_init(&faces[k], &d, &photo, light, 0.0f, 0, &head);
        if (st == HD_OK) st = hd_head_weight(&head, one);
        for (size_t p = 0; st == HD_OK && p < P; p++)
            if (one[p] > weight[p]) weight[p] = one[p];
        hd_head_free(&head);
        hd_decomposition_free(&d);
    }
    if (st != HD_OK) {
        fprintf(stderr, "serve_weight: %s\n", hd_error());
    } else {
        size_t some = 0;
        rc = 0;
        for (size_t p = 0; p < P && rc == 0; p++) {
            const float got = served.data[p] * 255.0f, want = weight[p] * 255.0f;
            some += want > 0;
            if (fabsf(got - want) > 1.0f + 1e-3f || (want > 0) != (got > 0.5f)) {
                fprintf(stderr, "serve_weight: pixel (%zu, %zu): the server's weight %.1f / 255, "
                        "the library's %.3f / 255\n", p % (size_t)photo.width, p / (size_t)photo.width, got, want);
                rc = 1;
            }
        }
        if (rc == 0 && some == 0) {
            fprintf(stderr, "serve_weight: the library's weight is 0 everywhere\n");
            rc = 1;
        }
        if (rc == 0) printf("serve_weight: %d faces, %zu pixels weighted, the served map within a level\n", n, some);
    }
    free(weight), free(one);
    hd_aligned_faces_free(faces, n);
    hd_aligner_free(aligner);
    hd_model_free(model);
    hd_image_free(&photo), hd_image_free(&served);
    return rc;
}
