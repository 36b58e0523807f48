/* align.c: aligned faces on disk: the SPEC section 5 files of one face (texture, mask, coarse
 * normals, landmarks) and the .warp.txt file that holds everything needed to warp a result back
 * into the photo, and whole photos through detection and landmarks (hd_align_photo). */
#include <ctype.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "align/face_detect.h"
#include "align/face_landmarks.h"
#include "align/photo_raster.h"
#include "align/person_segment.h"
#include "align/align.h"

#define WARP_MAGIC "hdnet-warp"
#define WARP_VERSION 1

/* Joins dir and stem + suffix; NULL (with reason) on failure. */
static char *face_path(const char *dir, const char *stem, const char *suffix)
{
    size_t n = strlen(stem) + strlen(suffix) + 1;
    char *name = hd_malloc(n);
    if (!name) return NULL;
    snprintf(name, n, "%s%s", stem, suffix);
    char *path = hd_path_join(dir, name);
    free(name);
    return path;
}

static hd_status write_landmarks(const hd_aligned_face *face, const char *path)
{
    hd_atomic_file af;
    hd_status st = hd_atomic_open(&af, path);
    if (st) return st;
    for (int i = 0; i < HD_FACE_LANDMARKS; i++)
        fprintf(af.f, "%.9g %.9g %.9g\n", face->landmarks[i][0], face->landmarks[i][1], face->landmarks[i][2]);
    return hd_atomic_commit(&af);
}

static hd_status write_warp(const hd_aligned_face *face, const char *path)
{
    hd_atomic_file af;
    hd_status st = hd_atomic_open(&af, path);
    if (st) return st;
    FILE *f = af.f;
    const float *R = face->rotation, *t = face->translation;
    fprintf(f, "%s %d\n", WARP_MAGIC, WARP_VERSION);
    fprintf(f, "photo %d %d\n", face->photo_width, face->photo_height);
    fprintf(f, "size %d\n", face->size);
    fprintf(f, "score %.9g\n", face->score);
    fprintf(f, "box %.9g %.9g %.9g %.9g\n", face->box[0], face->box[1], face->box[2], face->box[3]);
    fprintf(f, "scale %.9g\n", face->scale);
    fprintf(f, "rotation %.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n", R[0], R[1], R[2], R[3], R[4], R[5], R[6],
            R[7], R[8]);
    fprintf(f, "translation %.9g %.9g %.9g\n", t[0], t[1], t[2]);
    fprintf(f, "depth_sign %.0f\n", face->depth_sign);
    fprintf(f, "fit_rms %.9g\n", face->fit_rms);
    fprintf(f, "landmarks %d\n", HD_FACE_LANDMARKS);
    for (int i = 0; i < HD_FACE_LANDMARKS; i++)
        fprintf(f, "%.9g %.9g %.9g\n", face->landmarks[i][0], face->landmarks[i][1], face->landmarks[i][2]);
    return hd_atomic_commit(&af);
}

hd_status hd_aligned_face_write(const hd_aligned_face *face, const char *dir, const char *stem)
{
    if (!face || !face->texture.data || !face->mask.data || !face->normal.data)
        return hd_fail(HD_ERR_ARG, "write aligned face: the face has no images");
    static const char *const suffix[5] = {".png", ".mask.png", ".normal.png", ".landmarks.txt", ".warp.txt"};
    char *path[5] = {0};
    hd_status st = HD_OK;
    for (int k = 0; k < 5 && !st; k++)
        if (!(path[k] = face_path(dir, stem, suffix[k]))) st = HD_ERR_NOMEM;
    hd_image rgb = {0};
    if (!st) st = hd_image_write_png(path[0], &face->texture, 8);
    if (!st) st = hd_image_write_png(path[1], &face->mask, 8);
    if (!st) st = hd_normal_encode(&face->normal, &face->mask, &rgb);
    if (!st) st = hd_image_write_png(path[2], &rgb, 16);
    if (!st) st = write_landmarks(face, path[3]);
    if (!st) st = write_warp(face, path[4]);
    hd_image_free(&rgb);
    for (int k = 0; k < 5; k++) free(path[k]);
    return st;
}

/* A cursor over the lines of a text file, for errors that name the file and the line. */
typedef struct reader {
    const char *path;
    char *p;
    int line;
} reader;

/* Next line, NUL-terminated in place; NULL at the end. */
static char *next_line(reader *r)
{
    if (!*r->p) return NULL;
    char *s = r->p, *e = strchr(s, '\n');
    if (e) {
        *e = '\0';
        r->p = e + 1;
    } else {
        r->p = s + strlen(s);
    }
    r->line++;
    return s;
}

/* Reads the line "key v1 ... vn" into floats; errors name the file and the line. */
static hd_status read_floats(reader *r, const char *key, int n, float *v)
{
    char *s = next_line(r);
    if (!s) return hd_fail(HD_ERR_FORMAT, "%s:%d: ends early, expected '%s'", r->path, r->line + 1, key);
    size_t kl = strlen(key);
    if (key[0]) {
        if (strncmp(s, key, kl) != 0 || !isspace((unsigned char)s[kl]))
            return hd_fail(HD_ERR_FORMAT, "%s:%d: expected '%s', got '%.40s'", r->path, r->line, key, s);
        s += kl;
    }
    for (int i = 0; i < n; i++) {
        char *end;
        double x = strtod(s, &end);
        if (end == s) return hd_fail(HD_ERR_FORMAT, "%s:%d: expected %d numbers", r->path, r->line, n);
        if (!isfinite(x) || fabs(x) > 1e30) return hd_fail(HD_ERR_NUMERIC, "%s:%d: number %d is not finite", r->path, r->line, i + 1);
        v[i] = (float)x;
        s = end;
    }
    while (isspace((unsigned char)*s)) s++;
    if (*s) return hd_fail(HD_ERR_FORMAT, "%s:%d: unexpected text '%.20s'", r->path, r->line, s);
    return HD_OK;
}

hd_status hd_aligned_face_read_warp(const char *path, hd_aligned_face *face)
{
    memset(face, 0, sizeof *face);
    char *text;
    size_t size;
    hd_status st = hd_read_file(path, 1 << 20, &text, &size);
    if (st) return st;
    reader r = {path, text, 0};
    float v[9];
    char *s = next_line(&r);
    int version = 0;
    if (!s || sscanf(s, WARP_MAGIC " %d", &version) != 1) {
        st = hd_fail(HD_ERR_FORMAT, "%s:1: not an hdnet warp file (expected '%s %d')", path, WARP_MAGIC, WARP_VERSION);
        goto done;
    }
    if (version != WARP_VERSION) {
        st = hd_fail(HD_ERR_FORMAT, "%s:1: warp file version %d, this hdnet reads version %d", path, version, WARP_VERSION);
        goto done;
    }
    if ((st = read_floats(&r, "photo", 2, v))) goto done;
    if (v[0] != floorf(v[0]) || v[1] != floorf(v[1]) || v[0] < 1 || v[1] < 1 || v[0] > HD_IMAGE_MAX_SIDE ||
        v[1] > HD_IMAGE_MAX_SIDE) {
        st = hd_fail(HD_ERR_RANGE, "%s:%d: photo size %gx%g out of range", path, r.line, v[0], v[1]);
        goto done;
    }
    face->photo_width = (int)v[0];
    face->photo_height = (int)v[1];
    if ((st = read_floats(&r, "size", 1, v))) goto done;
    if (v[0] != floorf(v[0]) || v[0] < 16 || v[0] > 4096) {
        st = hd_fail(HD_ERR_RANGE, "%s:%d: texture size %g not in [16, 4096]", path, r.line, v[0]);
        goto done;
    }
    face->size = (int)v[0];
    if ((st = read_floats(&r, "score", 1, &face->score)) || (st = read_floats(&r, "box", 4, face->box)) ||
        (st = read_floats(&r, "scale", 1, &face->scale)) || (st = read_floats(&r, "rotation", 9, face->rotation)) ||
        (st = read_floats(&r, "translation", 3, face->translation)) || (st = read_floats(&r, "depth_sign", 1, v)))
        goto done;
    if (v[0] != 1.0f && v[0] != -1.0f) {
        st = hd_fail(HD_ERR_FORMAT, "%s:%d: depth_sign must be 1 or -1", path, r.line);
        goto done;
    }
    face->depth_sign = v[0];
    if ((st = read_floats(&r, "fit_rms", 1, &face->fit_rms)) || (st = read_floats(&r, "landmarks", 1, v))) goto done;
    if (v[0] != HD_FACE_LANDMARKS) {
        st = hd_fail(HD_ERR_FORMAT, "%s:%d: %g landmarks, expected %d", path, r.line, v[0], HD_FACE_LANDMARKS);
        goto done;
    }
    for (int i = 0; i < HD_FACE_LANDMARKS && !st; i++) st = read_floats(&r, "", 3, face->landmarks[i]);
done:
    free(text);
    return st;
}

/* MediaPipe drops a face whose landmark model gives a presence below this. */
#define MIN_PRESENCE 0.5f

/* One detector and one landmark model with their working memory: what one hd_aligner_run uses. */
typedef struct align_runner {
    hd_face_detector *detector;
    hd_face_mesh *landmarks;
    hd_person_segmenter *person;
    struct align_runner *next;
} align_runner;

/* An aligner is a pool of runners: a run takes an idle one (or loads another, when every runner is
 * busy in another thread) and puts it back, so one aligner serves any number of threads. */
struct hd_aligner {
    pthread_mutex_t lock; /* guards idle */
    align_runner *idle;
    float min_score, min_face; /* detection settings (hd_aligner_set_detection) */
    hd_mesh canonical; /* the canonical face mesh, loaded once, read-only: unwarp and warp back stand on it */
    int have_canonical;
};

const hd_mesh *hd_aligner_mesh(const hd_aligner *aligner) { return &aligner->canonical; }

static void runner_free(align_runner *r)
{
    if (!r) return;
    if (r->detector) hd_face_detector_free(r->detector);
    if (r->landmarks) hd_face_mesh_free(r->landmarks);
    hd_person_segmenter_free(r->person);
    free(r);
}

static hd_status runner_load(align_runner **out)
{
    *out = NULL;
    align_runner *r = hd_calloc(1, sizeof *r);
    if (!r) return HD_ERR_NOMEM;
    hd_status st = hd_face_detector_load(NULL, &r->detector);
    if (!st) st = hd_face_mesh_load(NULL, &r->landmarks);
    if (!st) st = hd_person_segmenter_load(NULL, &r->person);
    if (st) {
        runner_free(r);
        return st;
    }
    *out = r;
    return HD_OK;
}

hd_status hd_aligner_load(hd_aligner **aligner)
{
    *aligner = NULL;
    hd_aligner *a = hd_calloc(1, sizeof *a);
    if (!a) return HD_ERR_NOMEM;
    pthread_mutex_init(&a->lock, NULL);
    a->min_score = HD_DETECT_MIN_SCORE;
    a->min_face = HD_DETECT_MIN_FACE;
    hd_status st = runner_load(&a->idle);
    if (!st && !(st = hd_mesh_load_canonical(&a->canonical))) a->have_canonical = 1;
    if (st) {
        hd_aligner_free(a);
        return st;
    }
    *aligner = a;
    return HD_OK;
}

hd_status hd_aligner_set_detection(hd_aligner *aligner, float min_score, float min_face)
{
    if (!(min_score > 0.0f && min_score <= 1.0f))
        return hd_fail(HD_ERR_ARG, "face detection: the score threshold %g is not in (0, 1]", (double)min_score);
    if (!(min_face >= 0.0f && min_face <= (float)HD_IMAGE_MAX_SIDE))
        return hd_fail(HD_ERR_ARG, "face detection: the smallest face %g is not in [0, %d] pixels", (double)min_face,
                       HD_IMAGE_MAX_SIDE);
    aligner->min_score = min_score;
    aligner->min_face = min_face;
    return HD_OK;
}

void hd_aligner_free(hd_aligner *aligner)
{
    if (!aligner) return;
    while (aligner->idle) {
        align_runner *r = aligner->idle;
        aligner->idle = r->next;
        runner_free(r);
    }
    pthread_mutex_destroy(&aligner->lock);
    if (aligner->have_canonical) hd_mesh_free(&aligner->canonical);
    free(aligner);
}

/* The faces of nboxes detections: the face mesh fitted on each (MediaPipe's two passes) in seen,
 * those the landmark model doubts dropped (counted in *dropped), the rest aligned from the photo p3
 * into *out (allocated; *count of them). seen is p3 or a copy of it with its shadows lifted, the
 * same size. presences (may be NULL) gets each aligned face's landmark presence, in the order of
 * *out (allocated with it). *last gets the reason of the last face that failed to align. */
static hd_status fit_boxes(align_runner *aligner, const hd_mesh *canonical, const hd_image *seen, const hd_image *p3,
                           int size, const hd_face_box *boxes, int nboxes, hd_aligned_face **out, int *count,
                           float **presences, int *dropped, hd_status *last)
{
    *out = NULL;
    *count = 0;
    if (presences) *presences = NULL;
    if (nboxes <= 0) return HD_OK;
    hd_aligned_face *faces = hd_calloc((size_t)nboxes, sizeof *faces);
    float (*landmarks)[3] = hd_malloc(sizeof(float[HD_FACE_LANDMARKS][3]));
    float *sure = presences ? hd_malloc((size_t)nboxes * sizeof *sure) : NULL;
    hd_status st = faces && landmarks && (sure || !presences) ? HD_OK : HD_ERR_NOMEM;
    for (int b = 0; b < nboxes && st == HD_OK; b++) {
        float presence = 1;
        hd_status fs = hd_face_mesh_fit(aligner->landmarks, seen, &boxes[b], 2, landmarks, &presence);
        if (fs == HD_ERR_NOMEM) {
            st = fs;
            break;
        }
        if (fs == HD_OK && presence < MIN_PRESENCE) {
            (*dropped)++;
            continue;
        }
        if (fs == HD_OK) fs = hd_align_face_on(canonical, p3, (const float (*)[3])landmarks, size, &faces[*count]);
        if (fs != HD_OK) {
            *last = fs;
            continue;
        }
        if (sure) sure[*count] = presence;
        hd_aligned_face *f = &faces[(*count)++];
        f->score = boxes[b].score;
        f->box[0] = boxes[b].x0;
        f->box[1] = boxes[b].y0;
        f->box[2] = boxes[b].x1;
        f->box[3] = boxes[b].y1;
    }
    free(landmarks);
    if (st != HD_OK) {
        hd_aligned_faces_free(faces, *count);
        free(sure);
        *count = 0;
        return st;
    }
    *out = faces;
    if (presences) *presences = sure;
    return HD_OK;
}

static hd_status runner_run(align_runner *runner, const hd_mesh *canonical, float min_score, float min_face,
                            const hd_image *photo, int size,
                            hd_aligned_face **faces, int *count);

/* An idle runner of the pool (another loaded when every one is busy), and giving it back. */
static hd_status runner_take(hd_aligner *aligner, align_runner **r)
{
    pthread_mutex_lock(&aligner->lock);
    *r = aligner->idle;
    if (*r) aligner->idle = (*r)->next;
    pthread_mutex_unlock(&aligner->lock);
    return *r ? HD_OK : runner_load(r);
}

static void runner_give(hd_aligner *aligner, align_runner *r)
{
    pthread_mutex_lock(&aligner->lock);
    r->next = aligner->idle;
    aligner->idle = r;
    pthread_mutex_unlock(&aligner->lock);
}

hd_status hd_aligner_run(hd_aligner *aligner, const hd_image *photo, int size, hd_aligned_face **faces, int *count)
{
    *faces = NULL;
    *count = 0;
    if (!aligner) return hd_fail(HD_ERR_ARG, "align: no aligner");
    hd_apply_threads();
    align_runner *r;
    hd_status st = runner_take(aligner, &r);
    if (st) return st;
    st = runner_run(r, &aligner->canonical, aligner->min_score, aligner->min_face, photo, size, faces, count);
    runner_give(aligner, r);
    return st;
}

hd_status hd_aligner_segment(hd_aligner *aligner, const hd_image *photo, hd_aligned_face *face)
{
    if (!aligner) return hd_fail(HD_ERR_ARG, "segment: no aligner");
    if (!photo || !photo->data || photo->channels != 3)
        return hd_fail(HD_ERR_ARG, "segment: a 3-channel photo is needed");
    hd_apply_threads();
    align_runner *r;
    hd_status st = runner_take(aligner, &r);
    if (st) return st;
    st = hd_person_segment(r->person, photo, face);
    runner_give(aligner, r);
    return st;
}

hd_status hd_align_photo(const hd_image *photo, int size, hd_aligned_face **faces, int *count)
{
    *faces = NULL;
    *count = 0;
    hd_aligner *a;
    hd_status st = hd_aligner_load(&a);
    if (st) return st;
    st = hd_aligner_run(a, photo, size, faces, count);
    hd_aligner_free(a);
    return st;
}

/* The photo with its shadows lifted, for the landmark model's eyes only: each value v becomes
 * sqrt(v), which raises a value of 0.04 to 0.2 and leaves white white. */
static hd_status lift_shadows(const hd_image *p3, hd_image *out)
{
    hd_status st = hd_image_alloc(out, p3->width, p3->height, p3->channels);
    if (st) return st;
    size_t n = (size_t)p3->width * (size_t)p3->height * (size_t)p3->channels;
    for (size_t i = 0; i < n; i++) out->data[i] = sqrtf(fmaxf(p3->data[i], 0.0f));
    return HD_OK;
}

/* Another round of detection and fit: the boxes found in seen (by the pyramid, or zoomed out of the
 * crop when zoomed) replace *boxes, and their faces *out (with their presences when asked, as
 * fit_boxes). */
static hd_status refind(align_runner *aligner, const hd_mesh *canonical, float min_score, float min_face,
                        const hd_image *seen, const hd_image *p3, int size, int zoomed, hd_face_box **boxes,
                        int *nboxes, hd_aligned_face **out, int *count, float **presences, int *dropped,
                        hd_status *last)
{
    hd_aligned_faces_free(*out, *count);
    *out = NULL;
    *count = 0;
    free(*boxes);
    *boxes = NULL;
    *nboxes = 0;
    hd_status st = zoomed ? hd_face_detector_find_zoomed(aligner->detector, seen, min_score, boxes, nboxes)
                          : hd_face_detector_find(aligner->detector, seen, min_score, min_face, boxes, nboxes);
    if (st == HD_OK) st = fit_boxes(aligner, canonical, seen, p3, size, *boxes, *nboxes, out, count, presences, dropped, last);
    return st;
}

/* Under hard side light the pyramid may find part of a tight crop's face (its lit half, or the nose
 * and mouth) as a face of its own, and the landmark model, fitted in that box, follows it (Yale's
 * A-050E+00, docs/face_detect.md). Where a face found crosses the photo's border or is wider or
 * taller than CLOSE_UP_SHARE of the photo's shorter side (a crop or a close-up: a portrait with
 * context has its faces well inside and smaller), the photo is seen zoomed out too: a face found
 * there replaces every face whose box centre lies inside its own box when it is larger
 * (WHOLE_FACE_AREA times the box) and its landmarks are at least as sure. */
#define CLOSE_UP_SHARE 0.4f
#define WHOLE_FACE_AREA 1.5f
static float box_area(const float b[4]) { return (b[2] - b[0]) * (b[3] - b[1]); }
static int centre_inside(const float b[4], const float Z[4])
{
    const float cx = 0.5f * (b[0] + b[2]), cy = 0.5f * (b[1] + b[3]);
    return cx >= Z[0] && cx <= Z[2] && cy >= Z[1] && cy <= Z[3];
}

static hd_status prefer_whole_faces(align_runner *aligner, const hd_mesh *canonical, float min_score,
                                    const hd_image *p3, int size, hd_aligned_face **out, int *count,
                                    const float *presences)
{
    const float W = (float)p3->width, H = (float)p3->height, close = CLOSE_UP_SHARE * (W < H ? W : H);
    int doubt = 0;
    for (int k = 0; k < *count; k++) {
        const float *b = (*out)[k].box;
        doubt |= b[0] < 0 || b[1] < 0 || b[2] > W || b[3] > H || b[2] - b[0] > close || b[3] - b[1] > close;
    }
    if (!doubt) return HD_OK;
    hd_face_box *zb = NULL;
    int nz = 0, zc = 0, zd = 0;
    hd_aligned_face *zf = NULL;
    float *zp = NULL;
    hd_status zl = HD_OK;
    hd_status st = refind(aligner, canonical, min_score, 0, p3, p3, size, 1, &zb, &nz, &zf, &zc, &zp, &zd, &zl);
    free(zb);
    if (st == HD_ERR_NOMEM) return st;
    hd_clear_error(); /* the zoom-out is a second opinion: what it does not find keeps the first faces */
    for (int z = 0; z < zc; z++) {
        float Z[4]; /* a copy: zf[z] is moved out below */
        memcpy(Z, zf[z].box, sizeof Z);
        int inside = 0, sure = 1;
        for (int k = 0; k < *count; k++)
            if (centre_inside((*out)[k].box, Z)) {
                inside++;
                sure &= box_area(Z) >= WHOLE_FACE_AREA * box_area((*out)[k].box) && zp[z] >= presences[k];
            }
        if (!inside || !sure) continue;
        /* the zoomed face takes the first place it covers; the others it covers go */
        int kept = 0, placed = 0;
        for (int k = 0; k < *count; k++) {
            if (centre_inside((*out)[k].box, Z)) {
                hd_aligned_face_free(&(*out)[k]);
                if (placed) continue;
                (*out)[k] = zf[z];
                memset(&zf[z], 0, sizeof zf[z]);
                placed = 1;
            }
            if (kept != k) (*out)[kept] = (*out)[k];
            kept++;
        }
        *count = kept;
    }
    hd_aligned_faces_free(zf, zc);
    free(zp);
    for (int k = 1; k < *count; k++) /* largest score first, as found */
        for (int j = k; j > 0 && (*out)[j].score > (*out)[j - 1].score; j--) {
            hd_aligned_face t = (*out)[j];
            (*out)[j] = (*out)[j - 1];
            (*out)[j - 1] = t;
        }
    return HD_OK;
}

static hd_status runner_run(align_runner *aligner, const hd_mesh *canonical, float min_score, float min_face,
                            const hd_image *photo, int size,
                            hd_aligned_face **faces, int *count)
{
    *faces = NULL;
    *count = 0;
    if (!photo || !photo->data || photo->width < 1 || photo->height < 1)
        return hd_fail(HD_ERR_ARG, "align: empty photo");
    if (size < 16 || size > 4096) return hd_fail(HD_ERR_RANGE, "align: texture size %d is not in [16, 4096]", size);
    hd_image rgb = {0};
    const hd_image *p3 = photo;
    hd_status st = HD_OK;
    if (photo->channels != 3) {
        if ((st = hd_image_convert(photo, 3, &rgb))) return st;
        p3 = &rgb;
    }
    hd_face_box *boxes = NULL;
    int nboxes = 0, dropped = 0;
    hd_aligned_face *out = NULL;
    hd_status last = HD_OK;
    if ((st = hd_face_detector_find(aligner->detector, p3, min_score, min_face, &boxes, &nboxes))) goto done;
    float *presences = NULL;
    st = fit_boxes(aligner, canonical, p3, p3, size, boxes, nboxes, &out, count, &presences, &dropped, &last);
    if (st == HD_OK && *count > 0) st = prefer_whole_faces(aligner, canonical, min_score, p3, size, &out, count, presences);
    free(presences);
    /* what the pyramid found in a tight crop may be no face (the landmark model doubts it) while the
     * face itself, without context, scored under the threshold: the zoom-out of the crop */
    if (st == HD_OK && *count == 0 && nboxes > 0) {
        int more = 0;
        st = refind(aligner, canonical, min_score, min_face, p3, p3, size, 1, &boxes, &more, &out, count, NULL, &dropped,
                    &last);
        nboxes += more;
    }
    /* a face under hard side light, half of it near black, is found but doubted by the landmark
     * model (its presence falls under MIN_PRESENCE): both rounds again on the photo with its
     * shadows lifted, the texture still cut from the photo itself */
    if (st == HD_OK && *count == 0 && nboxes > 0) {
        hd_image lifted = {0};
        if ((st = lift_shadows(p3, &lifted))) goto done;
        int more = 0;
        st = refind(aligner, canonical, min_score, min_face, &lifted, p3, size, 0, &boxes, &more, &out, count,
                    NULL, &dropped, &last);
        nboxes += more;
        if (st == HD_OK && *count == 0) {
            st = refind(aligner, canonical, min_score, min_face, &lifted, p3, size, 1, &boxes, &more, &out, count,
                        NULL, &dropped, &last);
            nboxes += more;
        }
        hd_image_free(&lifted);
    }
    /* where each face's person is (the relighting's head) */
    for (int k = 0; st == HD_OK && k < *count; k++) st = hd_person_segment(aligner->person, p3, &out[k]);
    if (st == HD_OK && *count == 0) {
        if (last != HD_OK) st = last; /* its reason is already set */
        else
            st = hd_fail(HD_ERR_NOTFOUND, "no face found (%d detection(s), %d rejected by the landmark model)", nboxes,
                         dropped);
    }
done:
    if (st) {
        hd_aligned_faces_free(out, *count);
        *count = 0;
        out = NULL;
    }
    *faces = out;
    free(boxes);
    hd_image_free(&rgb);
    return st;
}

void hd_aligner_set_min_score(hd_aligner *aligner, float min_score)
{
    if (aligner && min_score > 0.0f && min_score <= 1.0f) aligner->min_score = min_score;
}
