/* serve_weight.c: the check behind tests/serve_api.sh's weight maps. Aligns and decomposes the
 * photo's faces as `hdnet serve` and `hdnet relight` do (the shipped model's texture size),
 * computes the weight the ratio rule applies each face's change with as hd_apply_photo does
 * (hd_face_weights: hd_photo_face_weight, then over the whole head hd_head_init and hd_head_weight
 * under the face's own light; the largest over the faces) and compares it with the 8-bit map the
 * server sent: every pixel within one level (half a level of rounding, and a weight under half a
 * level is sent as one), and 0 exactly where the weight is 0. Given the people map too, the weights
 * are those of the background relit (the body's too, the server's body_weight map) and the people
 * (hd_backdrop_add_person over the faces) are held within a level of the map as well. Exits 1 on
 * the first pixel that differs, printing it and both values.
 *     serve_weight PHOTO.png WEIGHT.png [PEOPLE.png] */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "../tools/hdnet_tool.h"

/* 1 at the first pixel where the 8-bit map differs from want by more than a level or is not 0
 * exactly where want is (printed); *some counts want's pixels above 0. */
static int differs(const char *what, const hd_image *served, const float *want_map, int W, size_t *some)
{
    const size_t P = (size_t)served->width * (size_t)served->height;
    for (size_t p = 0; p < P; p++) {
        const float got = served->data[p] * 255.0f, want = fminf(want_map[p], 1.0f) * 255.0f;
        *some += want > 0;
        if (fabsf(got - want) > 1.0f + 1e-3f || (want > 0) != (got > 0.5f)) {
            fprintf(stderr, "serve_weight: pixel (%zu, %zu): the server's %s %.1f / 255, the library's %.3f / 255\n",
                    p % (size_t)W, p / (size_t)W, what, got, want);
            return 1;
        }
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc != 3 && argc != 4) {
        fprintf(stderr, "usage: serve_weight PHOTO WEIGHT.png [PEOPLE.png]\n");
        return 2;
    }
    hd_image photo = {0}, served = {0}, served_people = {0};
    hd_model *model = NULL;
    hd_aligner *aligner = NULL;
    hd_aligned_face *faces = NULL;
    int n = 0, rc = 1;
    float *weight = NULL, *one = NULL, *people = NULL;
    hd_status st = hd_image_read_as(argv[1], 3, &photo);
    if (st == HD_OK) st = hd_image_read_as(argv[2], 1, &served);
    if (st == HD_OK && argc == 4) st = hd_image_read_as(argv[3], 1, &served_people);
    if (st == HD_OK && argc == 4 && (served_people.width != photo.width || served_people.height != photo.height))
        st = hd_fail(HD_ERR_ARG, "the people map is %d x %d, the photo %d x %d", served_people.width,
                     served_people.height, photo.width, photo.height);
    if (st == HD_OK && (served.width != photo.width || served.height != photo.height))
        st = hd_fail(HD_ERR_ARG, "the weight map is %d x %d, the photo %d x %d", served.width, served.height,
                     photo.width, photo.height);
    if (st == HD_OK) st = hd_model_load(NULL, &model);
    if (st == HD_OK) st = hd_aligner_load(&aligner);
    if (st == HD_OK) st = hd_photo_faces(aligner, model, &photo, &faces, &n);
    const size_t P = (size_t)photo.width * (size_t)photo.height;
    if (st == HD_OK && (!(weight = hd_calloc(P, sizeof *weight)) || !(one = hd_malloc(P * sizeof *one)) ||
                        (argc == 4 && !(people = hd_calloc(P, sizeof *people)))))
        st = HD_ERR_NOMEM;
    for (int k = 0; k < n && st == HD_OK; k++) {
        hd_decomposition d;
        hd_head head;
        float light[HD_SH_COEFFS];
        memset(&d, 0, sizeof d), memset(&head, 0, sizeof head);
        st = hd_model_decompose(model, &faces[k].texture, 1, &d);
        if (st == HD_OK) st = hd_face_light(&d, &faces[k].mask, HD_SOURCE_FIT, light);
        if (st == HD_OK) st = hd_face_weights(&faces[k], &d, &photo, light, 0.0f, people, k, one, &head);
        for (size_t p = 0; st == HD_OK && p < P; p++)
            if (one[p] > weight[p]) weight[p] = one[p];
        hd_head_free(&head);
        hd_decomposition_free(&d);
    }
    if (st != HD_OK) {
        fprintf(stderr, "serve_weight: %s\n", hd_error());
    } else {
        size_t some = 0;
        rc = differs("weight", &served, weight, photo.width, &some);
        if (rc == 0 && some == 0) {
            fprintf(stderr, "serve_weight: the library's weight is 0 everywhere\n");
            rc = 1;
        }
        size_t persons = 0;
        if (rc == 0 && people) rc = differs("people", &served_people, people, photo.width, &persons);
        if (rc == 0)
            printf("serve_weight: %d faces, %zu pixels weighted%s, the served map%s within a level\n", n, some,
                   people ? " with the body, the people's" : "", people ? "s" : "");
    }
    free(weight), free(one), free(people);
    hd_aligned_faces_free(faces, n);
    hd_aligner_free(aligner);
    hd_model_free(model);
    hd_image_free(&photo), hd_image_free(&served), hd_image_free(&served_people);
    return rc;
}
