/* write_set.c: a whole synthetic set on disk (SPEC section 5): OUT/subject_XXXX/YYYY.* for every
 * subject and image, and OUT/preview.sheet.png, a sheet of the first subjects (named with
 * two dots, so that dataset scanning ignores it like the other derived files).
 *
 * Work goes in blocks of subjects: the block's identities are made in parallel (one per
 * subject), then its images are rendered and written in parallel (one per image). Each image
 * depends only on (seed, subject, image), so the files do not depend on the thread count. An
 * image's files are written as a set (all or none), and the temporaries that killed runs left in
 * a subject folder are removed when it comes up. */
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "synth/synth_internal.h"
#include "io/image_io.h"
#include "synth/synth.h"

#define PREVIEW_SUBJECTS 8
#define PREVIEW_IMAGES 4
#define BLOCK_BYTES ((size_t)256 << 20) /* identities held at once */

/* The first failure inside a parallel region, carried to the calling thread (hd_error is per
 * thread). */
typedef struct first_error {
    hd_status status;
    char message[1024];
} first_error;

static void note_error(first_error *fe, hd_status st)
{
#pragma omp critical(synth_error)
    {
        if (fe->status == HD_OK) {
            fe->status = st;
            snprintf(fe->message, sizeof fe->message, "%s", hd_error());
        }
    }
}

/* Copies img (C channels) resized to cell x cell into the sheet (3 channels) at (x0, y0). */
/* dir/NAME.camera.txt: the camera effects applied to the image, one per line with its parameters. */
static hd_status write_camera_record(const char *dir, const char *name, const hd_synth_camera_record *r)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/%s.camera.txt", dir, name);
    hd_atomic_file af;
    hd_status st = hd_atomic_open(&af, path);
    if (st != HD_OK) return st;
    if (r->applied & HD_SYNTH_CAMERA_LIGHT_COLOUR)
        fprintf(af.f, "light_colour %.4f %.4f %.4f\n", r->light_gain[0], r->light_gain[1], r->light_gain[2]);
    if (r->applied & HD_SYNTH_CAMERA_BLUR) fprintf(af.f, "blur_sigma %.4f\n", r->blur_sigma);
    if (r->applied & HD_SYNTH_CAMERA_NOISE) fprintf(af.f, "noise %.5f %.6f\n", r->noise_read, r->noise_shot);
    if (r->applied & HD_SYNTH_CAMERA_WHITE_BALANCE)
        fprintf(af.f, "white_balance %.4f %.4f %.4f\n", r->wb_gain[0], r->wb_gain[1], r->wb_gain[2]);
    if (r->applied & HD_SYNTH_CAMERA_JPEG) fprintf(af.f, "jpeg_quality %d\n", r->jpeg_quality);
    return hd_atomic_commit(&af);
}

static hd_status paste(hd_image *sheet, const hd_image *img, int cell, int x0, int y0)
{
    hd_image small = {0}, rgb = {0};
    hd_status st = hd_image_resize(img, cell, cell, &small);
    if (st == HD_OK) st = hd_image_convert(&small, 3, &rgb);
    if (st == HD_OK) {
        size_t P = (size_t)sheet->width * sheet->height, Q = (size_t)cell * cell;
        for (int c = 0; c < 3; c++)
            for (int y = 0; y < cell; y++)
                memcpy(sheet->data + c * P + (size_t)(y0 + y) * sheet->width + x0, rgb.data + c * Q + (size_t)y * cell,
                       (size_t)cell * sizeof(float));
    }
    hd_image_free(&small);
    hd_image_free(&rgb);
    return st;
}

/* The preview sheet: one row per subject (up to 8): albedo, ground-truth normals, shading of the
 * first image, then up to 4 images. */
static hd_status write_preview(const hd_synth *s, const char *out, const hd_synth_options *o)
{
    int rows = o->subjects < PREVIEW_SUBJECTS ? o->subjects : PREVIEW_SUBJECTS;
    int imgs = o->per_subject < PREVIEW_IMAGES ? o->per_subject : PREVIEW_IMAGES;
    int cols = 3 + imgs, cell = s->size < 128 ? s->size : 128, gap = 2;
    hd_image sheet = {0};
    hd_status st = hd_image_alloc(&sheet, cols * (cell + gap) - gap, rows * (cell + gap) - gap, 3);
    if (st != HD_OK) return st;
    hd_synth_face f = {0}; /* one set of buffers for every render (fresh pages cost more than a render) */
    for (int rsub = 0; rsub < rows && st == HD_OK; rsub++) {
        hd_synth_subject *sub = NULL;
        st = hd_synth_subject_make(s, o->seed, rsub, &sub);
        for (int k = 0; k < imgs && st == HD_OK; k++) {
            st = hd_synth_render_fit(s, sub, k, o->pose_jitter_deg, o->coarse_error_deg, o->coarse_pose_deg, &f);
            if (st == HD_OK) st = hd_synth_camera_apply(&f, &o->camera, o->seed, rsub, k, NULL);
            if (st != HD_OK) break;
            int y0 = rsub * (cell + gap);
            if (k == 0) {
                hd_image enc = {0}, half = {0};
                st = paste(&sheet, &f.albedo, cell, 0, y0);
                if (st == HD_OK) st = hd_normal_encode(&f.normal_gt, &f.mask, &enc);
                if (st == HD_OK) st = paste(&sheet, &enc, cell, cell + gap, y0);
                if (st == HD_OK) st = hd_image_alloc(&half, s->size, s->size, 1);
                if (st == HD_OK) {
                    for (size_t i = 0; i < (size_t)s->size * s->size; i++) half.data[i] = 0.5f * f.shading.data[i];
                    st = paste(&sheet, &half, cell, 2 * (cell + gap), y0);
                }
                hd_image_free(&enc);
                hd_image_free(&half);
            }
            if (st == HD_OK) st = paste(&sheet, &f.image, cell, (3 + k) * (cell + gap), y0);
        }
        hd_synth_subject_free(sub);
    }
    hd_synth_face_free(&f);
    char *path = st == HD_OK ? hd_path_join(out, "preview.sheet.png") : NULL;
    if (st == HD_OK && !path) st = HD_ERR_NOMEM;
    if (st == HD_OK) st = hd_image_write_png(path, &sheet, 8);
    free(path);
    hd_image_free(&sheet);
    return st;
}

hd_status hd_synth_write_set(const char *out, const hd_synth_options *o, hd_synth_progress_fn progress, void *ctx)
{
    if (o->subjects < 1 || o->subjects > 1000000)
        return hd_fail(HD_ERR_RANGE, "synth: --subjects %d outside [1, 1000000]", o->subjects);
    if (o->per_subject < 1 || o->per_subject > 10000)
        return hd_fail(HD_ERR_RANGE, "synth: --per-subject %d outside [1, 10000]", o->per_subject);
    if (!(o->pose_jitter_deg >= 0.0f && o->pose_jitter_deg <= 45.0f))
        return hd_fail(HD_ERR_RANGE, "synth: --pose-jitter %g outside [0, 45] degrees", o->pose_jitter_deg);
    if (o->png_store != 0 && o->png_store != 1)
        return hd_fail(HD_ERR_RANGE, "synth: png_store %d is neither 0 nor 1", o->png_store);
    const hd_png_effort effort = o->png_store ? HD_PNG_STORE : HD_PNG_FAST;
    if (!(o->coarse_error_deg >= 0.0f && o->coarse_error_deg <= HD_SYNTH_COARSE_ERROR_MAX))
        return hd_fail(HD_ERR_RANGE, "synth: --coarse-error %g outside [0, %g] degrees", o->coarse_error_deg,
                       HD_SYNTH_COARSE_ERROR_MAX);
    if (!(o->coarse_pose_deg >= 0.0f && o->coarse_pose_deg <= HD_SYNTH_COARSE_ERROR_MAX))
        return hd_fail(HD_ERR_RANGE, "synth: --coarse-pose-error %g outside [0, %g] degrees", o->coarse_pose_deg,
                       HD_SYNTH_COARSE_ERROR_MAX);
    hd_synth *s = NULL;
    hd_status st = hd_synth_create(o->size, &s);
    if (st != HD_OK) return st;
    if ((st = hd_mkdirs(out)) != HD_OK) {
        hd_synth_free(s);
        return st;
    }
    const long total = (long)o->subjects * o->per_subject;
    size_t per_subject_bytes = (size_t)s->size * s->size * 5 * sizeof(float) + 1;
    int block = (int)(BLOCK_BYTES / per_subject_bytes);
    int threads = omp_get_max_threads();
    if (block < threads) block = threads;
    if (block > o->subjects) block = o->subjects;
    hd_synth_subject **subs = hd_calloc((size_t)block, sizeof *subs);
    if (!subs) {
        hd_synth_free(s);
        return HD_ERR_NOMEM;
    }
    first_error fe = {HD_OK, ""};
    long done = 0;
    for (int s0 = 0; s0 < o->subjects && fe.status == HD_OK; s0 += block) {
        int n = o->subjects - s0 < block ? o->subjects - s0 : block;
#pragma omp parallel for schedule(dynamic, 1)
        for (int j = 0; j < n; j++) {
            if (fe.status != HD_OK) continue;
            char name[32];
            snprintf(name, sizeof name, "subject_%04d", s0 + j);
            char *dir = hd_path_join(out, name);
            hd_status e = dir ? hd_mkdirs(dir) : HD_ERR_NOMEM;
            if (e == HD_OK) hd_remove_stale_temporaries(dir); /* of killed runs */
            if (e == HD_OK) e = hd_synth_subject_make(s, o->seed, s0 + j, &subs[j]);
            if (e != HD_OK) note_error(&fe, e);
            free(dir);
        }
        long nimg = (long)n * o->per_subject;
#pragma omp parallel
        {
            hd_synth_face f = {0}; /* one set of buffers per thread */
#pragma omp for schedule(dynamic, 1)
            for (long k = 0; k < nimg; k++) {
                if (fe.status != HD_OK) continue;
                int j = (int)(k / o->per_subject), image = (int)(k % o->per_subject);
                char dir[4096], name[32];
                snprintf(dir, sizeof dir, "%s/subject_%04d", out, s0 + j);
                snprintf(name, sizeof name, "%04d", image);
                hd_status e = hd_synth_render_fit(s, subs[j], image, o->pose_jitter_deg, o->coarse_error_deg,
                                                  o->coarse_pose_deg, &f);
                hd_synth_camera_record rec;
                if (e == HD_OK) e = hd_synth_camera_apply(&f, &o->camera, o->seed, s0 + j, image, &rec);
                if (e == HD_OK) {
                    hd_atomic_set_begin(); /* the image's files appear together or not at all */
                    e = hd_synth_face_write_effort(dir, name, &f, effort);
                    if (e == HD_OK && rec.applied) e = write_camera_record(dir, name, &rec);
                    hd_status end = hd_atomic_set_end(e == HD_OK);
                    if (e == HD_OK) e = end;
                }
                if (e != HD_OK) note_error(&fe, e);
                long now;
#pragma omp atomic capture
                now = ++done;
                if (progress && omp_get_thread_num() == 0) progress(ctx, now, total);
            }
            hd_synth_face_free(&f);
        }
        for (int j = 0; j < n; j++) {
            hd_synth_subject_free(subs[j]);
            subs[j] = NULL;
        }
    }
    free(subs);
    if (fe.status == HD_OK) st = write_preview(s, out, o);
    else st = hd_fail(fe.status, "%s", fe.message);
    if (progress && st == HD_OK) progress(ctx, total, total);
    hd_synth_free(s);
    return st;
}
