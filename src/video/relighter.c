/* relighter.c: one frame of a clip through the photo pipeline, with the state that keeps it steady
 * (video.h). Faces are tracked by their box centres from frame to frame; each track may smooth its
 * 468 landmarks (one-euro, in face widths, so the filter behaves the same at any face size; the
 * face is then unwarped again from them) and, after the face is decomposed, smooths the light and
 * the shading and normal maps (a first-order low-pass: the maps are in the aligned texture space, where every
 * texel stays on the same point of the face). The frame is then changed by the photo's relighting
 * rule on that decomposition (hd_apply_face, src/apply/apply.c), as hdnet relight changes a photo,
 * its background too when the model says so (HD_BACKGROUND_RELIGHT: a wall under the first face's
 * light change, the body relit with the head). A frame that cannot give the wall its change (no face,
 * or a face whose person the segmentation did not find) takes the last one that could (wall_hold). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "apply/apply.h"
#include "video/smooth.h"
#include "video/video.h"
#include "align/align.h"

#define MAX_TRACKS 16
#define NLM (HD_FACE_LANDMARKS * 3)
#define MATCH_DISTANCE 0.5f /* a face continues a track when its centre is within this many widths */
/* How long a frame without the wall's own change keeps the last one over the last people map: a
 * detector's miss or a blurred face lasts a frame or a few, a hand or a turn of the head under a
 * second, and in a second the person has moved little; beyond it the people map fades out over as
 * long again and the wall's change stays alone (docs/video.md, "Limits"). */
#define WALL_HOLD_SECONDS 1.0

typedef struct track {
    int used, seen;
    float cx, cy, width;        /* the last box */
    float scale;                /* the first box's width: the landmark filter's unit */
    hd_one_euro landmarks;      /* NLM values in face widths */
    hd_ema light, shading, normal;
    int maps;                   /* shading / normal filters are set up (their size is the model's) */
} track;

/* The wall's change of the last frame that had its own (the background relit), for the frames
 * after it that have none. */
typedef struct wall_hold {
    int width, height;  /* the frame's; 0: nothing held (no face with its person seen yet) */
    long age;           /* frames since that frame */
    float log_ratio[3]; /* hd_backdrop_log_ratio of its first face's light */
    double offset;      /* its brightness offset (log k) */
    float *people;      /* (H, W) its people map */
} wall_hold;

struct hd_video_relighter {
    hd_model *model;
    hd_aligner *aligner;
    int delight;
    float light[HD_SH_COEFFS];
    hd_brightness brightness;
    hd_video_options opt;
    float dt;
    track tracks[MAX_TRACKS];
    float lm[NLM];
    wall_hold wall;
};

void hd_video_options_default(hd_video_options *o)
{
    o->smooth = 1;
    o->smooth_landmarks = 0;
    o->landmark_min_cutoff = 3.0f;
    o->landmark_beta = 60.0f;
    o->light_cutoff = 1.5f;
}

static void track_free(track *t)
{
    hd_one_euro_free(&t->landmarks);
    hd_ema_free(&t->light);
    hd_ema_free(&t->shading);
    hd_ema_free(&t->normal);
    memset(t, 0, sizeof *t);
}

hd_status hd_video_relighter_new(hd_model *model, hd_aligner *aligner, const float *light, hd_brightness brightness,
                                 const hd_video_options *options, hd_video_relighter **out)
{
    *out = NULL;
    hd_video_options o;
    if (options) o = *options;
    else hd_video_options_default(&o);
    if (!model || !aligner) return hd_fail(HD_ERR_ARG, "video: no model or aligner");
    if (!(o.landmark_min_cutoff > 0.0f) || !(o.landmark_beta >= 0.0f) || !(o.light_cutoff > 0.0f) ||
        !isfinite(o.landmark_min_cutoff) || !isfinite(o.landmark_beta) || !isfinite(o.light_cutoff))
        return hd_fail(HD_ERR_ARG, "video: smoothing cutoffs must be positive and finite");
    hd_video_relighter *v = hd_calloc(1, sizeof *v);
    if (!v) return HD_ERR_NOMEM;
    v->model = model;
    v->aligner = aligner;
    v->delight = light == NULL;
    if (light) memcpy(v->light, light, sizeof v->light);
    v->brightness = brightness;
    v->opt = o;
    v->dt = 1.0f / 30.0f;
    *out = v;
    return HD_OK;
}

void hd_video_relighter_set_fps(hd_video_relighter *v, double fps)
{
    if (fps > 0.0 && fps < 1e4) v->dt = (float)(1.0 / fps);
}

void hd_video_relighter_free(hd_video_relighter *v)
{
    if (!v) return;
    for (int i = 0; i < MAX_TRACKS; i++) track_free(&v->tracks[i]);
    free(v->wall.people);
    free(v);
}

/* The track a face continues (nearest centre within MATCH_DISTANCE widths, not yet taken this
 * frame), or a new one; NULL when all are taken. */
static track *track_for(hd_video_relighter *v, const hd_aligned_face *f, hd_status *st)
{
    float cx = 0.5f * (f->box[0] + f->box[2]), cy = 0.5f * (f->box[1] + f->box[3]), w = f->box[2] - f->box[0];
    track *best = NULL;
    float best_d = INFINITY;
    for (int i = 0; i < MAX_TRACKS; i++) {
        track *t = &v->tracks[i];
        if (!t->used || t->seen) continue;
        float d = hypotf(cx - t->cx, cy - t->cy);
        if (d < MATCH_DISTANCE * t->width && d < best_d) best = t, best_d = d;
    }
    if (!best) {
        for (int i = 0; i < MAX_TRACKS && !best; i++)
            if (!v->tracks[i].used) best = &v->tracks[i];
        if (!best) return NULL;
        *st = hd_one_euro_init(&best->landmarks, NLM, v->opt.landmark_min_cutoff, v->opt.landmark_beta,
                               v->opt.landmark_min_cutoff);
        if (*st == HD_OK) *st = hd_ema_init(&best->light, HD_SH_COEFFS, hd_lowpass_alpha(v->opt.light_cutoff, v->dt));
        if (*st != HD_OK) {
            track_free(best);
            return NULL;
        }
        best->used = 1;
        best->scale = w > 1.0f ? w : 1.0f;
    }
    best->seen = 1;
    best->cx = cx;
    best->cy = cy;
    best->width = w > 1.0f ? w : 1.0f;
    return best;
}

/* Smooths the decomposition's light, shading and normals (renormalised) in place. */
static hd_status smooth_maps(hd_video_relighter *v, track *t, hd_decomposition *d)
{
    size_t hw = (size_t)d->shading.width * d->shading.height;
    if (!t->maps) {
        float a = hd_lowpass_alpha(v->opt.light_cutoff, v->dt);
        hd_status st = hd_ema_init(&t->shading, (int)hw, a);
        if (st == HD_OK) st = hd_ema_init(&t->normal, (int)(3 * hw), a);
        if (st != HD_OK) return st;
        t->maps = 1;
    }
    if ((size_t)t->shading.n != hw) return hd_fail(HD_ERR_ARG, "video: the model's map size changed");
    hd_ema_step(&t->light, d->light);
    hd_ema_step(&t->shading, d->shading.data);
    hd_ema_step(&t->normal, d->normal.data);
    hd_normal_renormalise(&d->normal);
    return HD_OK;
}

/* Refits face f to its track's smoothed landmarks (the face is unwarped again from them). */
static hd_status smooth_landmarks(hd_video_relighter *v, track *t, const hd_image *frame, hd_aligned_face *f)
{
    float scale = t->scale; /* fixed per track: a unit that moved with the box would add its jitter */
    for (int i = 0; i < HD_FACE_LANDMARKS; i++)
        for (int k = 0; k < 3; k++) v->lm[3 * i + k] = f->landmarks[i][k] / scale;
    hd_one_euro_step(&t->landmarks, v->lm, v->dt);
    float (*lm)[3] = (float (*)[3])v->lm;
    for (int i = 0; i < NLM; i++) v->lm[i] *= scale;
    hd_aligned_face g;
    memset(&g, 0, sizeof g);
    hd_status st = hd_align_face(frame, (const float (*)[3])lm, f->size, &g);
    if (st != HD_OK) return st;
    g.score = f->score;
    memcpy(g.box, f->box, sizeof g.box);
    /* where the person is was found about the frame's own fit: it moves to the smoothed face */
    g.person = f->person, g.person_x0 = f->person_x0, g.person_y0 = f->person_y0;
    memset(&f->person, 0, sizeof f->person);
    hd_aligned_face_free(f);
    *f = g;
    return HD_OK;
}

/* Keeps this frame's wall change (its log ratio, offset and W x H people map) for the frames after it. */
static hd_status wall_keep(wall_hold *w, const float log_ratio[3], double offset, const float *people, int W, int H)
{
    const size_t P = (size_t)W * H;
    if (w->width != W || w->height != H) {
        free(w->people);
        w->width = w->height = 0;
        if (!(w->people = hd_malloc((P ? P : 1) * sizeof(float)))) return HD_ERR_NOMEM;
        w->width = W, w->height = H;
    }
    memcpy(w->people, people, P * sizeof(float));
    memcpy(w->log_ratio, log_ratio, sizeof w->log_ratio);
    w->offset = offset;
    w->age = 0;
    return HD_OK;
}

/* The wall of a frame that has no change of its own: out takes the held change over
 * max(people, fade * held people) (people: what this frame's faces hold off the wall, 0 elsewhere;
 * changed in place), fade 1 for the first `hold` frames after the held one, then falling linearly
 * to 0 over as many (the wall's change alone from then on). 0 (out untouched) when nothing of this
 * frame's size is held. */
static int wall_from_hold(wall_hold *w, long hold, float *people, hd_image *out)
{
    if (!w->people || w->width != out->width || w->height != out->height) return 0;
    if (w->age < 2 * hold) w->age++;
    const double fade = w->age <= hold ? 1.0 : (double)(2 * hold - w->age) / (double)hold;
    const size_t P = (size_t)out->width * out->height;
    if (fade > 0.0)
        for (size_t i = 0; i < P; i++) {
            const float h = (float)(fade * w->people[i]);
            if (h > people[i]) people[i] = h;
        }
    hd_backdrop_apply(w->log_ratio, w->offset, people, out);
    return 1;
}

/* Face f was relit without its person (the segmentation found none): its weights (over the frame
 * as given) join people, so that a held wall's change does not land on it too. weight: scratch,
 * allocated on first use. */
static hd_status face_off_wall(const hd_aligned_face *f, const hd_image *frame, float **weight, float *people)
{
    const size_t P = (size_t)frame->width * frame->height;
    if (!*weight && !(*weight = hd_malloc((P ? P : 1) * sizeof(float)))) return HD_ERR_NOMEM;
    hd_status st = hd_photo_face_weight(f, frame, *weight);
    for (size_t i = 0; st == HD_OK && i < P; i++)
        if ((*weight)[i] > people[i]) people[i] = (*weight)[i];
    return st;
}

hd_status hd_video_relight_frame(hd_video_relighter *v, const hd_image *frame, hd_image *out,
                                 hd_video_frame_info *info)
{
    memset(out, 0, sizeof *out);
    if (info) memset(info, 0, sizeof *info);
    if (!frame || !frame->data || frame->channels != 3)
        return hd_fail(HD_ERR_ARG, "video: a frame has 3 channels (has %d)", frame ? frame->channels : 0);
    hd_aligned_face *faces = NULL;
    int n = 0;
    hd_status st = hd_aligner_run(v->aligner, frame, hd_photo_texture_size(v->model), &faces, &n);
    if (st == HD_ERR_NOTFOUND) st = HD_OK, n = 0; /* a frame without a face is passed through */
    if (st != HD_OK) return st;
    st = hd_image_alloc(out, frame->width, frame->height, 3);
    if (st == HD_OK)
        memcpy(out->data, frame->data, (size_t)frame->width * frame->height * 3 * sizeof(float));
    for (int i = 0; i < MAX_TRACKS; i++) v->tracks[i].seen = 0;
    hd_light_rgb target;
    hd_light_rgb_from_grey(v->light, &target);
    int done = 0;
    /* the background relit as a wall (the model's setting), from the first face's light */
    hd_face_backdrop backdrop = {0}, first = {0};
    const int wall = hd_model_background(v->model) == HD_BACKGROUND_RELIGHT;
    int lost = 0;         /* faces relit without their person (the head alone; the frame's wall held) */
    float *weight = NULL; /* face_off_wall's scratch */
    if (st == HD_OK && wall && !(backdrop.people = hd_calloc((size_t)frame->width * frame->height, sizeof(float))))
        st = HD_ERR_NOMEM;
    for (int k = 0; k < n && st == HD_OK; k++) {
        hd_aligned_face *f = &faces[k];
        track *t = v->opt.smooth ? track_for(v, f, &st) : NULL;
        if (st != HD_OK) break;
        if (t && v->opt.smooth_landmarks) st = smooth_landmarks(v, t, frame, f);
        if (st != HD_OK) break;
        hd_decomposition d;
        memset(&d, 0, sizeof d);
        st = hd_face_decompose(v->model, f, &d);
        if (st == HD_OK && t) st = smooth_maps(v, t, &d);
        if (st == HD_OK && info && k == 0) {
            info->has_light = 1;
            memcpy(info->light, d.light, sizeof info->light);
        }
        /* the photo's rule on the (smoothed) decomposition; a face whose person was not found is
         * relit without the body (a photo would fail: hd_apply_face's backdrop needs the person),
         * and the frame's wall is held from the last frame that had it */
        const int person = wall && f->person.data;
        if (st == HD_OK)
            st = hd_apply_face(f, &d, v->delight ? NULL : &target, v->delight ? HD_BRIGHTNESS_KEEP : v->brightness,
                               HD_SOURCE_FIT, hd_model_shadows(v->model), out, person ? &backdrop : NULL);
        if (st == HD_OK && wall && !person) {
            lost++;
            st = face_off_wall(f, frame, &weight, backdrop.people);
        }
        hd_decomposition_free(&d);
        if (st == HD_OK && done++ == 0) first = backdrop;
    }
    hd_video_wall kind = HD_VIDEO_WALL_KEPT;
    if (st == HD_OK && wall && done > 0 && lost == 0) {
        float lr[3];
        hd_backdrop_log_ratio(first.source, v->delight ? NULL : &target, 0.0f, lr);
        hd_backdrop_apply(lr, first.offset, backdrop.people, out);
        st = wall_keep(&v->wall, lr, first.offset, backdrop.people, frame->width, frame->height);
        kind = HD_VIDEO_WALL_OWN;
    } else if (st == HD_OK && wall) {
        const long hold = lround(WALL_HOLD_SECONDS / v->dt);
        if (wall_from_hold(&v->wall, hold > 1 ? hold : 1, backdrop.people, out)) kind = HD_VIDEO_WALL_HELD;
    }
    free(weight);
    free(backdrop.people);
    /* Tracks not seen in this frame end: a face that comes back starts afresh. */
    for (int i = 0; i < MAX_TRACKS; i++)
        if (v->tracks[i].used && !v->tracks[i].seen) track_free(&v->tracks[i]);
    hd_aligned_faces_free(faces, n);
    if (st != HD_OK) {
        hd_image_free(out);
        return st;
    }
    if (info) info->faces = done, info->wall = kind;
    return HD_OK;
}
