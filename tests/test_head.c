/* test_head.c: the change of light beyond the face mesh (src/apply/head.c, issue 36) on a real face
 * (tests/data/faces-london/001/smiling.jpg) with its coarse normals standing in for the model's:
 * under the face's own light nothing changes; under a light from the side the background keeps
 * the photo bit for bit, the neck below the chin and the forehead above the mesh take weight,
 * the change is continuous across the mesh's edge (no step larger than the steps inside the face),
 * and it stays within the face's own range. */
#include <stdlib.h>
#include <string.h>
#include "test.h"
#include "core/core.h"
#include "apply/apply.h"
#include "light/light.h"

static void test_head(void)
{
    const char *td = getenv("HDNET_TESTDATA");
    char path[4200];
    snprintf(path, sizeof path, "%s/faces-london/001/smiling.jpg", td ? td : "tests/data");
    hd_image photo = {0}, warped = {0}, cover = {0};
    hd_aligned_face *faces = NULL;
    int n = 0;
    CHECK(hd_image_read_as(path, 3, &photo) == HD_OK);
    CHECK(photo.data && hd_align_photo(&photo, 128, &faces, &n) == HD_OK && n >= 1);
    if (n < 1) {
        hd_image_free(&photo);
        return;
    }
    const hd_aligned_face *f = &faces[0];
    const int W = photo.width, H = photo.height;
    const size_t P = (size_t)W * H;
    hd_decomposition d;
    memset(&d, 0, sizeof d);
    d.normal = f->normal; /* borrowed: the coarse normals as the model's */
    float own[HD_SH_COEFFS], side[HD_SH_COEFFS];
    hd_light_from_direction(0.0f, 0.0f, 1.5f, 0.5f, own);    /* from the viewer */
    hd_light_from_direction(-60.0f, 20.0f, 1.5f, 0.5f, side); /* from one side, a little above */
    hd_light_rgb target;
    hd_light_rgb_from_grey(side, &target);

    float *weight = malloc(P * sizeof *weight), *face_w = malloc(P * sizeof *face_w);
    hd_head head;
    CHECK(weight && face_w && hd_photo_face_weight(f, &photo, face_w) == HD_OK);
    memcpy(weight, face_w, P * sizeof *weight);
    CHECK(hd_head_init(f, &d, &photo, own, 0.0f, &head) == HD_OK);
    CHECK(head.normal != NULL);
    CHECK(hd_head_weight(&head, weight) == HD_OK);
    CHECK(hd_warp_back(f, &f->mask, NULL, &warped, &cover) == HD_OK);

    /* the face's frame: the eyes' midpoint and distance, the chin */
    hd_face_frame fr;
    CHECK(hd_face_frame_of(f, &fr));
    const int cx = (int)fr.mx, neck_y = (int)(f->landmarks[152][1] + 0.5f * fr.e);
    const int top_y = (int)(fr.my - 1.05f * fr.e);
    printf("head window %d x %d at %d, %d; weight: neck %.3f, forehead above the mesh %.3f (face %.3f), corner %.3f\n",
           head.w, head.h, head.x0, head.y0, weight[(size_t)neck_y * W + cx], weight[(size_t)top_y * W + cx],
           face_w[(size_t)top_y * W + cx], weight[0]);
    CHECK(weight[(size_t)neck_y * W + cx] > 0.5f);    /* the neck: not in the mesh, now relit */
    CHECK(face_w[(size_t)neck_y * W + cx] == 0.0f);
    CHECK(weight[0] == 0.0f && weight[P - 1] == 0.0f); /* the corners: background */

    /* the face's own light: a field of zeros stays zeros */
    hd_image field = {0};
    CHECK(hd_image_alloc(&field, W, H, 1) == HD_OK);
    memset(field.data, 0, P * sizeof(float));
    hd_light_rgb same;
    hd_light_rgb_from_grey(own, &same);
    CHECK(hd_head_apply(&head, own, &same, &field) == HD_OK);
    int zero = 1;
    for (size_t p = 0; p < P; p++) zero &= field.data[p] == 0.0f;
    CHECK(zero);
    hd_image_free(&field);

    /* a light from the side: the face's field as the rule makes it, extended over the head */
    hd_image tex_field = {0}, coverage = {0};
    CHECK(hd_ratio_field(&d, &f->mask, f->texture.width, own, 0.0f, &target, &tex_field) == HD_OK);
    CHECK(hd_warp_back(f, &tex_field, NULL, &field, &coverage) == HD_OK);
    CHECK(hd_field_fill(field.data, coverage.data, W, H) == HD_OK);
    float lo = 1e9f, hi = -1e9f;
    for (size_t p = 0; p < P; p++)
        if (coverage.data[p] > 0.5f) lo = fminf(lo, field.data[p]), hi = fmaxf(hi, field.data[p]);
    CHECK(hd_head_apply(&head, own, &target, &field) == HD_OK);
    /* within the face's range; the largest step across the mesh's edge on the skin against the
     * largest inside the face */
    int within = 1;
    double step_edge = 0, step_in = 0;
    for (int y = 1; y + 1 < H; y++)
        for (int x = 1; x + 1 < W; x++) {
            const size_t p = (size_t)y * W + x;
            if (weight[p] <= 0) continue;
            within &= field.data[p] >= lo - 1e-4f && field.data[p] <= hi + 1e-4f;
            const double g = fmax(fabs(field.data[p + 1] - field.data[p]), fabs(field.data[p + W] - field.data[p]));
            const int edge = (coverage.data[p] > 0.5f) != (coverage.data[p + 1] > 0.5f) ||
                             (coverage.data[p] > 0.5f) != (coverage.data[p + W] > 0.5f);
            if (edge && weight[p] > 0.9f) step_edge = fmax(step_edge, g);
            else if (coverage.data[p] > 0.5f) step_in = fmax(step_in, g);
        }
    printf("field range %.4f .. %.4f; largest step across the mesh's edge %.5f, inside the face %.5f\n", lo, hi,
           step_edge, step_in);
    CHECK(within);
    CHECK(hi - lo > 0.1f);
    CHECK(step_edge <= step_in);

    /* applied: the background bit for bit */
    hd_image out = {0};
    CHECK(hd_image_alloc(&out, W, H, 3) == HD_OK);
    memcpy(out.data, photo.data, 3 * P * sizeof(float));
    CHECK(hd_ratio_apply(&field, weight, HD_BRIGHTNESS_KEEP, &out) == HD_OK);
    int kept = 1, changed = 0;
    for (size_t p = 0; p < P; p++)
        for (int c = 0; c < 3; c++) {
            const int same_px = out.data[c * P + p] == photo.data[c * P + p];
            if (weight[p] == 0.0f) kept &= same_px;
            else changed += !same_px;
        }
    CHECK(kept);
    CHECK(changed > 1000);

    hd_head_free(&head);
    CHECK(head.normal == NULL);
    hd_image_free(&out), hd_image_free(&field), hd_image_free(&tex_field), hd_image_free(&coverage);
    hd_image_free(&warped), hd_image_free(&cover), hd_image_free(&photo);
    free(weight), free(face_w);
    hd_aligned_faces_free(faces, n);
}

int main(void)
{
    const char *td = getenv("HDNET_TESTDATA");
    if (!getenv("HDNET_DATA") && td) {
        char dir[4096];
        snprintf(dir, sizeof dir, "%s/../../models", td); /* HDNET_TESTDATA is <source>/tests/data */
        setenv("HDNET_DATA", dir, 1);
    }
    test_head();
    return test_summary("test_head");
}
