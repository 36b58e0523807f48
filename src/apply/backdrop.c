/* backdrop.c: the background relit as a flat backdrop under the same light (issue 36; docs/usage.md,
 * "The background"), for hd_model_set_background(HD_BACKGROUND_RELIGHT). By default a photo's
 * background keeps the input bit for bit. With the option, every pixel that is not the person
 * (one minus the larger of the people's weights and their segmentation, whose last row goes on
 * down the photo: the body below the segmented crop; where the head relights the body, its
 * weights alone; where the head's own masks call it the background, none of the segmentation)
 * takes the change of a flat wall facing the camera (normal (0, 0, 1)) from the first face's own
 * light to the target, by the same ratio rule and guard as the face, with the first face's
 * brightness factor:
 *     out = in * exp(b * (log((s(n0, target) + g) / (s(n0, source) + g)) + t)),   b = 1 - people.
 * A distant light lights a flat wall evenly, so the change is one factor per channel; the person's
 * outline mixes the person's change and the wall's by its share. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "apply/apply.h"
#include "align/person_segment.h"

hd_status hd_backdrop_add_person(const hd_aligned_face *f, const float *weight, const hd_head *head, int W, int H,
                                 float *people)
{
    const size_t P = (size_t)W * H;
    float *map = hd_calloc(P ? P : 1, sizeof(float));
    if (!map) return HD_ERR_NOMEM;
    hd_person_map_max(f, W, H, 1, map);
    /* in the head's body the weights are the person, the map's outline refined to the photo's
     * edges (head.c): the raw map's soft edge would keep a rim of the wall unchanged; where the
     * body's zone fades (beside the shoulders) the refined person, not the raw map, shares the
     * outline with the wall too, so the outline is the photo's there as well; in the head, what
     * its masks call the background (the wall seen between curls, which the network's coarse
     * map takes for the person) is the wall's: else it took neither the head's change nor the
     * wall's, a patch of the old light beside the neck (London 001) */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            const size_t p = (size_t)y * W + x;
            const float w = weight[p] > 1.0f ? 1.0f : weight[p];
            const float body = hd_head_body_person(head, x, y), person = body >= 0 ? body : map[p];
            const float m = person * (1.0f - hd_head_body_zone(head, x, y)) * (1.0f - hd_head_background(head, x, y));
            const float v = w > m ? w : m;
            if (v > people[p]) people[p] = v;
        }
    free(map);
    return HD_OK;
}

void hd_backdrop_log_ratio(const float source[HD_SH_COEFFS], const hd_light_rgb *target, float guard,
                           float log_ratio[3])
{
    const float n0[3] = {0.0f, 0.0f, 1.0f};
    const float s = fmaxf(hd_sh_shade(source, n0), 0.0f);
    const float g = (guard > 0 && isfinite(guard) ? guard : HD_RATIO_GUARD) * (s > 1e-6f ? s : 1e-6f);
    for (int c = 0; c < 3; c++) {
        const float t = target ? fmaxf(hd_sh_shade(target->sh[c], n0), 0.0f) : 1.0f;
        log_ratio[c] = t == s ? 0.0f : logf((t + g) / (s + g));
    }
}

void hd_backdrop_apply(const float log_ratio[3], double offset, const float *people, hd_image *image)
{
    const size_t P = (size_t)image->width * image->height;
    for (size_t p = 0; p < P; p++) {
        const float b = 1.0f - (people[p] < 0 ? 0.0f : people[p] > 1 ? 1.0f : people[p]);
        if (!(b > 0)) continue;
        for (int c = 0; c < 3; c++) {
            if (log_ratio[c] == 0.0f && offset == 0.0) continue;
            float *v = &image->data[(size_t)c * P + p];
            const float o = *v * (float)exp(b * (log_ratio[c] + offset));
            *v = o > 1.0f ? 1.0f : o;
        }
    }
}
