/* photo_calls.c: the whole-photo calls for decompose and transfer, in memory on hd_image, beside
 * hd_relight_photo and hd_estimate_light_photo (photo.c): what `hdnet decompose` and
 * `hdnet transfer` do to a photo, for programs that hold the photo in memory. */
#include <string.h>
#include "core/core.h"

hd_status hd_decompose_photo(hd_model *model, hd_aligner *aligner, const hd_image *photo, hd_decomposition *d,
                             hd_aligned_face *face)
{
    memset(d, 0, sizeof *d);
    if (face) memset(face, 0, sizeof *face);
    hd_aligned_face *faces = NULL;
    int n = 0;
    hd_status st = hd_photo_faces(aligner, model, photo, &faces, &n);
    if (st == HD_OK) st = hd_model_decompose(model, &faces[0].texture, 1, d);
    if (st == HD_OK && face) {
        *face = faces[0]; /* the best face moves to the caller */
        memset(&faces[0], 0, sizeof faces[0]);
    }
    hd_aligned_faces_free(faces, n);
    return st;
}

hd_status hd_transfer_photo(hd_model *model, hd_aligner *aligner, const hd_image *photo, const hd_image *reference,
                            hd_brightness brightness, hd_image *out, int *nfaces)
{
    memset(out, 0, sizeof *out);
    if (nfaces) *nfaces = 0;
    float light[HD_SH_COEFFS];
    hd_status st = hd_estimate_light_photo(model, aligner, reference, light, NULL);
    if (st != HD_OK) return st;
    return hd_relight_photo(model, aligner, photo, (const float (*)[HD_SH_COEFFS])light, 1, brightness, out, NULL,
                            nfaces);
}
