/* bench_align.c: the alignment section of `hdnet bench`: on the bundled photo
 * (examples/astronaut.png), the time to load the two face models, to detect the face, to find its
 * landmarks (two face-mesh passes), and the whole of hd_align_photo (detection, landmarks, mesh
 * fit, unwarp at the bench size), each the median of a->repeats runs; and the face search of a
 * 2000 x 1500 group-sized photo (the bundled photo tiled, searched down to 40 px faces over the
 * image pyramid), per megapixel, the median of up to 3 runs. */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "bench.h"
#include "hdnet_tool.h"

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

double bench_median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* The bundled photo: ./examples, or beside the executable (../examples, ../../examples). */
hd_status bench_read_photo(hd_image *photo, char *path, size_t cap)
{
    char exe[4096];
    const char *tries[3] = {"examples/astronaut.png", "/../examples/astronaut.png", "/../../examples/astronaut.png"};
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n > 0) {
        exe[n] = '\0';
        *strrchr(exe, '/') = '\0';
    } else exe[0] = '\0';
    for (int i = 0; i < 3; i++) {
        if (i == 0) snprintf(path, cap, "%s", tries[0]);
        else snprintf(path, cap, "%s%s", exe, tries[i]);
        if (access(path, R_OK) == 0) return hd_image_read_as(path, 3, photo);
    }
    return hd_fail(HD_ERR_NOTFOUND, "examples/astronaut.png: not found in . or beside the executable");
}

int bench_align(const bench_args *a)
{
    FILE *out = a->out ? a->out : stdout;
    int repeats = a->repeats > 0 ? a->repeats : 5, size = a->size > 0 ? a->size : 256;
    char path[4200];
    hd_image photo = {0}, tile = {0}, group = {0};
    hd_face_detector *det = NULL;
    hd_face_mesh *mesh = NULL;
    hd_face_box *faces = NULL;
    double *t_detect = hd_calloc((size_t)repeats, sizeof(double));
    double *t_mesh = hd_calloc((size_t)repeats, sizeof(double));
    double *t_align = hd_calloc((size_t)repeats, sizeof(double));
    int count = 0, rc = 1;
    float lm[HD_FACE_MESH_POINTS][3], presence;
    if (!t_detect || !t_mesh || !t_align || bench_read_photo(&photo, path, sizeof path) != HD_OK) goto done;
    double t0 = hd_seconds();
    if (hd_face_detector_load(NULL, &det) != HD_OK || hd_face_mesh_load(NULL, &mesh) != HD_OK) goto done;
    double t_load = hd_seconds() - t0;
    for (int r = 0; r < repeats; r++) {
        free(faces);
        faces = NULL;
        t0 = hd_seconds();
        if (hd_face_detector_run(det, &photo, HD_FACE_MIN_SCORE, &faces, &count) != HD_OK) goto done;
        t_detect[r] = hd_seconds() - t0;
        if (count < 1) {
            hd_fail(HD_ERR_NOTFOUND, "%s: no face found", path);
            goto done;
        }
        t0 = hd_seconds();
        if (hd_face_mesh_fit(mesh, &photo, &faces[0], 2, lm, &presence) != HD_OK) goto done;
        t_mesh[r] = hd_seconds() - t0;
        hd_aligned_face *aligned = NULL;
        int naligned = 0;
        t0 = hd_seconds();
        if (hd_align_photo(&photo, size, &aligned, &naligned) != HD_OK) goto done;
        t_align[r] = hd_seconds() - t0;
        hd_aligned_faces_free(aligned, naligned);
    }
    double md = bench_median(t_detect, repeats), mm = bench_median(t_mesh, repeats), ma = bench_median(t_align, repeats);
    /* The group-sized photo: the bundled photo tiled 4 x 3 at 500 x 500. */
    const int GW = 2000, GH = 1500, GT = 500;
    if (hd_image_resize(&photo, GT, GT, &tile) || hd_image_alloc(&group, GW, GH, 3)) goto done;
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < GH; y++)
            for (int x = 0; x < GW; x++)
                group.data[((size_t)c * GH + y) * GW + x] = tile.data[((size_t)c * GT + y % GT) * GT + x % GT];
    int group_runs = repeats < 3 ? repeats : 3, group_faces = 0;
    int windows = hd_face_pyramid(det, GW, GH, HD_FACE_MIN_SIZE, NULL, 0);
    for (int r = 0; r < group_runs; r++) {
        free(faces);
        faces = NULL;
        t0 = hd_seconds();
        if (hd_face_detector_run(det, &group, HD_FACE_MIN_SCORE, &faces, &group_faces) != HD_OK) goto done;
        t_detect[r] = hd_seconds() - t0;
    }
    double mg = bench_median(t_detect, group_runs), mpix = 1e-6 * GW * GH;
    if (a->json) {
        fprintf(out, "\"align_models_load_s\": %.6f,\n", t_load);
        fprintf(out, "\"align_detect_s\": %.6f,\n", md);
        fprintf(out, "\"align_landmarks_s\": %.6f,\n", mm);
        fprintf(out, "\"align_photo_s\": %.6f,\n", ma);
        fprintf(out, "\"detect_group_s_per_mpixel\": %.6f,\n", mg / mpix);
    } else {
        fprintf(out, "\nalignment (%s, %dx%d, median of %d)\n", path, photo.width, photo.height, repeats);
        fprintf(out, "  %-44s %8.1f ms\n", "load detector + face mesh models", 1e3 * t_load);
        fprintf(out, "  %-44s %8.1f ms\n", "face detection (BlazeFace back + NMS)", 1e3 * md);
        fprintf(out, "  %-44s %8.1f ms\n", "landmarks (2 face-mesh passes, 192x192)", 1e3 * mm);
        char label[64];
        snprintf(label, sizeof label, "hd_align_photo, texture %d (per photo)", size);
        fprintf(out, "  %-44s %8.1f ms\n", label, 1e3 * ma);
        snprintf(label, sizeof label, "face search %dx%d to 40 px (%d windows)", GW, GH, windows);
        fprintf(out, "  %-44s %8.1f ms (%.0f ms per megapixel, %d faces)\n", label, 1e3 * mg, 1e3 * mg / mpix,
                group_faces);
    }
    rc = 0;
done:
    if (rc) fprintf(stderr, "hdnet bench: alignment: %s\n", hd_error());
    free(faces);
    free(t_detect);
    free(t_mesh);
    free(t_align);
    hd_face_detector_free(det);
    hd_face_mesh_free(mesh);
    hd_image_free(&photo);
    hd_image_free(&tile);
    hd_image_free(&group);
    return rc;
}
