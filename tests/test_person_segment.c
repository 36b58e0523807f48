/* test_person_segment.c: where the person is (src/align/person_segment.c, issue 36) on a real
 * portrait (tests/data/faces-london/001/neutral.jpg, plain grey background): the aligner's map is a
 * probability, sure of the person on the face (nose, cheeks, forehead) and of the background beside
 * the head and in the top corners; the photo mirrored gives the map mirrored (the crop is placed
 * by the fit, on either side); a face re-aligned from its landmarks (the video's path) gets the
 * same map from hd_aligner_segment; a face near the photo's edge gets a window clipped to it; and
 * the relighting's head follows the map: the bun above the skull's reach is relit, and where the
 * map says background nothing changes beyond the face mesh, whatever the colour. With the
 * background relit (a wall), the corners take the wall's factor exactly, the head from the mouth up
 * is the picture with the background kept (the brightness too), and the body well below the chin
 * is relit (without the option, the shirt keeps the input). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "test.h"
#include "source_dir.h"
#include "core/core.h"
#include "align/align.h"
#include "align/person_segment.h"
#include "apply/apply.h"
#include "light/light.h"

static float at(const hd_aligned_face *f, int x, int y)
{
    x -= f->person_x0, y -= f->person_y0;
    if (x < 0 || y < 0 || x >= f->person.width || y >= f->person.height) return -1.0f;
    return f->person.data[(size_t)y * f->person.width + x];
}

static float at_landmark(const hd_aligned_face *f, int k)
{
    return at(f, (int)f->landmarks[k][0], (int)f->landmarks[k][1]);
}

static hd_image read_photo(const char *rel)
{
    const char *td = getenv("HDNET_TESTDATA");
    char path[4200];
    snprintf(path, sizeof path, "%s/%s", td ? td : "tests/data", rel);
    hd_image photo = {0};
    CHECK(hd_image_read_as(path, 3, &photo) == HD_OK);
    return photo;
}

static void mirror(hd_image *im)
{
    for (int c = 0; c < im->channels; c++)
        for (int y = 0; y < im->height; y++) {
            float *row = im->data + ((size_t)c * im->height + y) * im->width;
            for (int x = 0; x < im->width / 2; x++) {
                const float t = row[x];
                row[x] = row[im->width - 1 - x];
                row[im->width - 1 - x] = t;
            }
        }
}

static void test_map(hd_aligner *al)
{
    hd_image photo = read_photo("faces-london/001/neutral.jpg");
    hd_aligned_face *faces = NULL, *mf = NULL;
    int n = 0, mn = 0;
    CHECK(photo.data && hd_aligner_run(al, &photo, 128, &faces, &n) == HD_OK && n == 1);
    if (n != 1) return;
    const hd_aligned_face *f = &faces[0];
    const int W = photo.width, H = photo.height;
    CHECK(f->person.data && f->person.channels == 1);
    CHECK(f->person_x0 >= 0 && f->person_y0 >= 0 && f->person_x0 + f->person.width <= W &&
          f->person_y0 + f->person.height <= H);
    int in_range = 1;
    for (size_t p = 0; p < (size_t)f->person.width * f->person.height; p++)
        in_range &= f->person.data[p] >= 0.0f && f->person.data[p] <= 1.0f;
    CHECK(in_range);
    hd_face_frame fr;
    CHECK(hd_face_frame_of(f, &fr));
    /* the face: nose tip, cheeks, forehead's top; the background: beside the head at the eyes'
     * height (1.6 eye distances out, past the ears and the curls' ends), the top corners */
    const float nose = at_landmark(f, 1), cheek_l = at_landmark(f, 50), cheek_r = at_landmark(f, 280);
    const float brow = at_landmark(f, 10);
    const float left = at(f, (int)(fr.mx - 2.2f * fr.e), (int)fr.my), right = at(f, (int)(fr.mx + 2.2f * fr.e), (int)fr.my);
    printf("person: nose %.3f, cheeks %.3f %.3f, forehead %.3f; background beside the head %.3f %.3f; window %d x %d "
           "at %d, %d of %d x %d\n", nose, cheek_l, cheek_r, brow, left, right, f->person.width, f->person.height,
           f->person_x0, f->person_y0, W, H);
    CHECK(nose > 0.95f && cheek_l > 0.95f && cheek_r > 0.95f && brow > 0.9f);
    CHECK(left >= 0.0f && left < 0.05f && right >= 0.0f && right < 0.05f);
    const float corner_l = at(f, f->person_x0 + 2, f->person_y0 + 2);
    const float corner_r = at(f, f->person_x0 + f->person.width - 3, f->person_y0 + 2);
    CHECK(corner_l < 0.05f && corner_r < 0.05f);

    /* mirrored: the map mirrored, within the network's own asymmetry */
    mirror(&photo);
    CHECK(hd_aligner_run(al, &photo, 128, &mf, &mn) == HD_OK && mn == 1);
    if (mn == 1 && mf[0].person.data) {
        double diff = 0;
        long count = 0, off = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                const float a = at(f, x, y), b = at(&mf[0], W - 1 - x, y);
                if (a < 0 || b < 0) {
                    off += (a < 0) != (b < 0);
                    continue;
                }
                diff += fabs(a - b), count++;
            }
        printf("mirrored: mean difference %.4f over %ld pixels; %ld pixels in one window only\n", diff / count, count, off);
        CHECK(count > (long)W * H / 2 && diff / count < 0.03);
        CHECK(off < (long)(0.02 * W * H));
    }
    mirror(&photo);

    /* a face aligned from its landmarks has no map until hd_aligner_segment, which gives the same */
    hd_aligned_face g;
    memset(&g, 0, sizeof g);
    CHECK(hd_align_face(&photo, (const float (*)[3])f->landmarks, 128, &g) == HD_OK);
    CHECK(g.person.data == NULL);
    CHECK(hd_aligner_segment(al, &photo, &g) == HD_OK);
    int same = g.person.data && g.person.width == f->person.width && g.person.height == f->person.height &&
               g.person_x0 == f->person_x0 && g.person_y0 == f->person_y0;
    for (size_t p = 0; same && p < (size_t)g.person.width * g.person.height; p++) same = g.person.data[p] == f->person.data[p];
    CHECK(same);
    /* a face without a fit is refused */
    hd_aligned_face none;
    memset(&none, 0, sizeof none);
    CHECK(hd_aligner_segment(al, &photo, &none) == HD_ERR_ARG && strstr(hd_error(), "fit"));
    hd_aligned_face_free(&g);

    /* a map that does not see the face is dropped: the same landmarks on a flat grey photo (the
     * network sees no person there; Yale B's tight grey crops did the same to real faces) */
    hd_image grey = {0};
    CHECK(hd_image_alloc(&grey, W, H, 3) == HD_OK);
    for (size_t p = 0; grey.data && p < (size_t)3 * W * H; p++) grey.data[p] = 0.5f;
    memset(&g, 0, sizeof g);
    CHECK(hd_align_face(&photo, (const float (*)[3])f->landmarks, 128, &g) == HD_OK);
    CHECK(hd_aligner_segment(al, &grey, &g) == HD_OK);
    CHECK(g.person.data == NULL && g.person_x0 == 0 && g.person_y0 == 0);
    /* the check itself, on maps made by hand over the real face's window: all person, none, and
     * the face's landmarks just under and at one half */
    hd_aligned_face h = *f;
    memset(&h.person, 0, sizeof h.person);
    CHECK(!hd_person_map_sees_face(&h));
    CHECK(hd_image_alloc(&h.person, f->person.width, f->person.height, 1) == HD_OK);
    const size_t M = (size_t)f->person.width * f->person.height;
    for (size_t p = 0; h.person.data && p < M; p++) h.person.data[p] = 1.0f;
    CHECK(hd_person_map_sees_face(&h));
    for (size_t p = 0; h.person.data && p < M; p++) h.person.data[p] = 0.0f;
    CHECK(!hd_person_map_sees_face(&h));
    for (size_t p = 0; h.person.data && p < M; p++) h.person.data[p] = 0.49f;
    CHECK(!hd_person_map_sees_face(&h));
    for (size_t p = 0; h.person.data && p < M; p++) h.person.data[p] = 0.5f;
    CHECK(hd_person_map_sees_face(&h));
    /* a window that misses every landmark sees nothing */
    h.person_x0 = f->person_x0 + 100000;
    CHECK(!hd_person_map_sees_face(&h));
    hd_image_free(&h.person);
    hd_aligned_face_free(&g);
    hd_image_free(&grey);

    /* near the photo's edge: the left 40 % of the photo cut off, the window clipped to what is left */
    hd_image cut = {0};
    const int x0 = (int)(0.4f * W);
    CHECK(hd_image_alloc(&cut, W - x0, H, 3) == HD_OK);
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < H; y++)
            memcpy(cut.data + ((size_t)c * H + y) * cut.width, photo.data + ((size_t)c * H + y) * W + x0,
                   (size_t)cut.width * sizeof(float));
    hd_aligned_face *cf = NULL;
    int cn = 0;
    CHECK(hd_aligner_run(al, &cut, 128, &cf, &cn) == HD_OK && cn == 1);
    if (cn == 1) {
        CHECK(cf[0].person.data && cf[0].person_x0 == 0 && cf[0].person.width <= cut.width);
        CHECK(at_landmark(&cf[0], 1) > 0.95f);
    }
    hd_aligned_faces_free(cf, cn);
    hd_image_free(&cut);
    hd_aligned_faces_free(mf, mn);
    hd_aligned_faces_free(faces, n);
    hd_image_free(&photo);
}

/* The head's weight over the photo (the face's own and the head's, as hd_apply_photo computes it)
 * with face f as it is. */
static float *head_weight(const hd_aligned_face *f, const hd_image *photo, hd_head *head)
{
    const size_t P = (size_t)photo->width * photo->height;
    float *w = malloc(P * sizeof *w), own[HD_SH_COEFFS];
    hd_light_from_direction(0.0f, 0.0f, 1.5f, 0.5f, own);
    hd_decomposition d;
    memset(&d, 0, sizeof d);
    d.normal = f->normal; /* borrowed: the coarse normals as the model's */
    CHECK(w && hd_photo_face_weight(f, photo, w) == HD_OK);
    CHECK(hd_head_init(f, &d, photo, own, 0.0f, 0, head) == HD_OK && head->normal);
    CHECK(hd_head_weight(head, w) == HD_OK);
    return w;
}

static void test_head_follows_map(hd_aligner *al)
{
    hd_image photo = read_photo("faces-london/001/neutral.jpg");
    hd_aligned_face *faces = NULL;
    int n = 0;
    CHECK(photo.data && hd_aligner_run(al, &photo, 128, &faces, &n) == HD_OK && n == 1);
    if (n != 1) return;
    hd_aligned_face *f = &faces[0];
    const int W = photo.width;
    const size_t P = (size_t)W * photo.height;
    hd_head with, without, cleared;
    float *w_map = head_weight(f, &photo, &with);
    /* the same face without its map: the colour model alone */
    hd_image map = f->person;
    memset(&f->person, 0, sizeof f->person);
    float *w_colour = head_weight(f, &photo, &without);
    f->person = map;
    /* the bun: person pixels above the colour model's window (the skull's reach) take weight */
    long bun = 0, bun_lit = 0;
    for (int y = 0; y < without.y0; y++)
        for (int x = 0; x < W; x++)
            if (at(f, x, y) > 0.95f) bun++, bun_lit += w_map[(size_t)y * W + x] > 0.2f;
    printf("above the skull's reach: %ld person pixels, %ld relit (window top %d, with the map %d)\n", bun, bun_lit,
           without.y0, with.y0);
    CHECK(bun > 1000 && bun_lit > bun / 2);
    /* the map set to background everywhere but the face: beyond the face mesh's own weight nothing
     * changes, though the colour model found skin and hair there */
    float *face_w = malloc(P * sizeof *face_w);
    CHECK(face_w && hd_photo_face_weight(f, &photo, face_w) == HD_OK);
    for (size_t p = 0; p < (size_t)f->person.width * f->person.height; p++) f->person.data[p] = 0.0f;
    float *w_none = head_weight(f, &photo, &cleared);
    long colour_beyond = 0, none_beyond = 0;
    for (size_t p = 0; face_w && p < P; p++) {
        if (face_w[p] > 0.0f) continue;
        colour_beyond += w_colour[p] > 0.0f;
        none_beyond += w_none[p] > 0.0f;
    }
    printf("beyond the face mesh: %ld pixels weighted by the colour model, %ld with the map cleared\n", colour_beyond,
           none_beyond);
    CHECK(colour_beyond > 10000 && none_beyond == 0);
    hd_head_free(&with), hd_head_free(&without), hd_head_free(&cleared);
    free(w_map), free(w_colour), free(w_none), free(face_w);
    hd_aligned_faces_free(faces, n);
    hd_image_free(&photo);
}

/* One face's head with the body (body: HD_HEAD_BODY_*) and its weights, for the body's tests. */
typedef struct body_case {
    hd_image photo;
    hd_aligned_face *faces;
    int n;
    hd_decomposition d;
    hd_head h;
    hd_face_frame fr;
    float *weight;
} body_case;

/* Sets up c from the photo at path; 0 (the failure checked) when it cannot. Free with body_free. */
static int body_setup(hd_aligner *al, hd_model *model, const char *path, int body, body_case *c)
{
    memset(c, 0, sizeof *c);
    CHECK(hd_image_read_as(path, 3, &c->photo) == HD_OK);
    CHECK(c->photo.data && hd_aligner_run(al, &c->photo, hd_photo_texture_size(model), &c->faces, &c->n) == HD_OK &&
          c->n == 1);
    if (c->n != 1 || !c->faces[0].person.data) {
        CHECK(c->n == 1 && c->faces[0].person.data);
        return 0;
    }
    const hd_aligned_face *f = &c->faces[0];
    float source[HD_SH_COEFFS];
    c->weight = malloc((size_t)c->photo.width * c->photo.height * sizeof(float));
    CHECK(c->weight && hd_face_frame_of(f, &c->fr) && hd_model_decompose(model, &f->texture, 1, &c->d) == HD_OK &&
          hd_face_light(&c->d, &f->mask, HD_SOURCE_FIT, source) == HD_OK &&
          hd_photo_face_weight(f, &c->photo, c->weight) == HD_OK &&
          hd_head_init(f, &c->d, &c->photo, source, 0.0f, body, &c->h) == HD_OK && hd_head_weight(&c->h, c->weight) == HD_OK);
    return c->weight && c->h.normal;
}

static void body_free(body_case *c)
{
    hd_head_free(&c->h);
    hd_decomposition_free(&c->d);
    free(c->weight);
    hd_aligned_faces_free(c->faces, c->n);
    hd_image_free(&c->photo);
}

/* The body's weights (hd_head with the body, as the background relit has it): at least 0.9 wherever
 * the network is sure of the person (over 13 x 13 pixels) two eye distances and more below the eyes.
 * The torso proxy must not end the body inside the person: when its reach (1.8 radii) ended it, a
 * stripe of the old light ran down the astronaut's far arm (664 of its 20108 sure pixels under 0.9;
 * at 4 radii, none). */
static void test_body_weight(hd_aligner *al, hd_model *model, const char *path)
{
    body_case c;
    if (body_setup(al, model, path, HD_HEAD_BODY_ALL, &c)) {
        const int W = c.photo.width;
        long sure = 0, partial = 0;
        for (size_t p = 0; p < (size_t)W * c.photo.height; p++) {
            const int x = (int)(p % (size_t)W), y = (int)(p / (size_t)W);
            int inside = hd_face_height(&c.fr, x, y) < -2.0f;
            for (int dy = -6; dy <= 6 && inside; dy++)
                for (int dx = -6; dx <= 6 && inside; dx++) inside = at(&c.faces[0], x + dx, y + dy) >= 1.0f;
            if (inside) sure++, partial += c.weight[p] < 0.9f;
        }
        printf("%s: the body's weight under 0.9 on %ld of %ld sure pixels\n", path, partial, sure);
        CHECK(sure > 5000 && partial < sure / 100);
    }
    body_free(&c);
}

/* The body's normals (hd_head with the body) follow the person's outline: just under the top of
 * each shoulder (1.8 to 3 eye distances to the side, the first pixel the network is sure of below
 * the chin) they face up and outward, and the chest's middle faces the camera. A vertical cylinder
 * standing for the chest gave the shoulders' tops sideways normals, a little down (London 001: up
 * -0.06 on average, the astronaut -0.16; now 0.57 and 0.27), and under a side light the whole side
 * of a shirt one grey block. */
static void test_body_normals(hd_aligner *al, hd_model *model, const char *path)
{
    body_case c;
    if (body_setup(al, model, path, HD_HEAD_BODY_ALL, &c)) {
        const hd_head *h = &c.h;
        const size_t N = (size_t)h->w * h->h;
        double up = 0, out = 0, front = 0;
        int tops = 0, middle = 0;
        for (int x = h->x0; x < h->x0 + h->w; x++) {
            const int y_eyes = (int)c.fr.my;
            const float side = hd_face_side(&c.fr, x, y_eyes);
            if (fabsf(side) < 1.8f || fabsf(side) > 3.0f) continue;
            for (int y = h->y0; y < h->y0 + h->h; y++) {
                if (-hd_face_height(&c.fr, x, y) < 1.5f || at(&c.faces[0], x, y) < 1.0f) continue;
                const int yy = y + (int)(0.1f * c.fr.e);
                if (yy < h->y0 + h->h) {
                    const size_t i = (size_t)(yy - h->y0) * h->w + (size_t)(x - h->x0);
                    up += h->normal[N + i], out += (side > 0 ? 1 : -1) * h->normal[i], tops++;
                }
                break;
            }
        }
        for (int y = h->y0; y < h->y0 + h->h; y++)
            for (int x = h->x0; x < h->x0 + h->w; x++) {
                const float depth = -hd_face_height(&c.fr, x, y), side = fabsf(hd_face_side(&c.fr, x, y));
                if (depth > 3.0f && depth < 3.5f && side < 0.3f && at(&c.faces[0], x, y) >= 1.0f)
                    front += h->normal[2 * N + (size_t)(y - h->y0) * h->w + (size_t)(x - h->x0)], middle++;
            }
        up /= tops > 0 ? tops : 1, out /= tops > 0 ? tops : 1, front /= middle > 0 ? middle : 1;
        printf("%s: the shoulders' tops: up %.2f, outward %.2f (%d columns); the chest's middle faces the camera %.3f "
               "(%d pixels)\n",
               path, up, out, tops, front, middle);
        CHECK(tops > 50 && up > 0.2 && out > 0.1);
        CHECK(middle > 100 && front > 0.95);
    }
    body_free(&c);
}

/* The body near the neck (HD_HEAD_BODY_NEAR, the background kept): the neck's change goes on down,
 * whole, on every sure pixel of the person just below it (skin or collar alike: on a skin test
 * alone it ended in blotches where a pale chest failed it), and ends inside the person: nothing
 * changes far down the chest or out on the shoulders. */
static void test_body_near(hd_aligner *al, hd_model *model, const char *path)
{
    body_case c;
    if (body_setup(al, model, path, HD_HEAD_BODY_NEAR, &c)) {
        CHECK(!c.h.wb); /* near the neck, the body's share counts in the brightness kept */
        const int W = c.photo.width;
        long below = 0, partial = 0, far = 0, far_changed = 0;
        for (size_t p = 0; p < (size_t)W * c.photo.height; p++) {
            const int x = (int)(p % (size_t)W), y = (int)(p / (size_t)W);
            const float depth = -hd_face_height(&c.fr, x, y), side = fabsf(hd_face_side(&c.fr, x, y));
            if (depth > 4.2f || side > 2.6f) {
                far++, far_changed += c.weight[p] != 0.0f;
                continue;
            }
            int inside = depth > 2.0f && depth < 2.4f && side < 0.5f;
            for (int dy = -6; dy <= 6 && inside; dy++)
                for (int dx = -6; dx <= 6 && inside; dx++) inside = at(&c.faces[0], x + dx, y + dy) >= 1.0f;
            if (inside) below++, partial += c.weight[p] < 0.9f;
        }
        printf("%s: near the neck, the weight under 0.9 on %ld of %ld sure pixels just below it; %ld of %ld pixels "
               "far down the chest or out on the shoulders changed\n",
               path, partial, below, far_changed, far);
        CHECK(below > 500 && partial == 0);
        CHECK(far > 10000 && far_changed == 0);
    }
    body_free(&c);
}

/* The background relit as a flat wall (hd_model_set_background, backdrop.c): the model's change of
 * a wall facing the camera, one factor per channel, where the person is not; the person as with
 * the background kept; the face's own light changes nothing. */
static void test_background(hd_aligner *al)
{
    hd_image photo = read_photo("faces-london/001/neutral.jpg");
    hd_model *model = NULL;
    CHECK(hd_model_load(NULL, &model) == HD_OK);
    if (!photo.data || !model) {
        hd_model_free(model);
        hd_image_free(&photo);
        return;
    }
    float l[HD_SH_COEFFS];
    hd_light_from_direction(60.0f, 20.0f, 1.5f, 0.3f, l);
    hd_light_rgb target;
    hd_light_rgb_from_grey(l, &target);
    target.sh[0][0] *= 1.2f; /* a warm light: the channels' factors differ */
    hd_apply_request q = {&target, 1, 0, 1, HD_RULE_RATIO, HD_BRIGHTNESS_KEEP, HD_SOURCE_FIT, 0.0f, NULL};
    hd_apply_result keep, wall;
    CHECK(hd_apply_photo(model, al, &photo, &q, &keep) == HD_OK);
    CHECK(hd_model_set_background(model, HD_BACKGROUND_RELIGHT) == HD_OK &&
          hd_model_background(model) == HD_BACKGROUND_RELIGHT);
    CHECK(hd_apply_photo(model, al, &photo, &q, &wall) == HD_OK);
    const size_t P = (size_t)photo.width * photo.height;
    if (keep.nfaces == 1 && wall.nfaces == 1) {
        const hd_aligned_face *f = &wall.faces[0];
        /* the wall's factor, from the definition: shading at n = (0, 0, 1), the rule's guard */
        const float n0[3] = {0, 0, 1};
        float s, t[3];
        hd_sh_shading_map(n0, NULL, 1, wall.face_light[0], &s);
        s = s > 0 ? s : 0;
        const float g = HD_RATIO_GUARD * s;
        for (int c = 0; c < 3; c++) {
            hd_sh_shading_map(n0, NULL, 1, target.sh[c], &t[c]);
            t[c] = ((t[c] > 0 ? t[c] : 0) + g) / (s + g);
        }
        CHECK(fabsf(t[0] - t[1]) > 0.05f && fabsf(t[1] - 1.0f) > 0.05f);
        /* the corners (sure background, the map's 0): each channel by the wall's factor, times the one
         * factor that keeps the head's brightness (the same for every pixel: read off one corner pixel) */
        double worst = 0, k = 0;
        for (int y = 0; y < 40 && k == 0; y++)
            for (int x = 0; x < 40 && k == 0; x++) {
                const size_t p = (size_t)y * photo.width + x;
                const float in = photo.data[P + p], out = wall.relit[0].data[P + p];
                if (in > 0.05f && out < 0.95f) k = out / (in * t[1]);
            }
        CHECK(k > 0.5 && k < 2.0);
        long corners = 0, self_changed = 0, person = 0;
        for (int y = 0; y < 40; y++)
            for (int x = 0; x < 40; x++) {
                const size_t p = (size_t)y * photo.width + x;
                CHECK(at(f, x, y) < 0.02f);
                for (int c = 0; c < 3; c++) {
                    const float in = photo.data[c * P + p], want = fminf(1.0f, (float)(in * t[c] * k));
                    worst = fmax(worst, fabs(wall.relit[0].data[c * P + p] - want));
                    CHECK(keep.relit[0].data[c * P + p] == in);
                }
                corners++;
            }
        printf("background as a wall: factors %.4f %.4f %.4f, brightness %.4f, worst corner pixel off by %.2e over "
               "%ld pixels\n", t[0], t[1], t[2], k, worst, corners);
        CHECK(worst < 1e-5);
        hd_face_frame fr;
        CHECK(hd_face_frame_of(f, &fr));
        long body = 0, body_relit = 0, body_far = 0, body_kept = 0;
        float worst_person = 0, worst_gap = 0;
        long gaps = 0, mixed = 0;
        /* the head as the render sets it up, for what its masks call the background */
        hd_decomposition d;
        memset(&d, 0, sizeof d);
        hd_head h;
        memset(&h, 0, sizeof h);
        CHECK(hd_model_decompose(model, &f->texture, 1, &d) == HD_OK &&
              hd_head_init(f, &d, &photo, wall.face_light[0], 0.0f, HD_HEAD_BODY_ALL, &h) == HD_OK && h.normal);
        for (size_t p = 0; p < P; p++) {
            /* the face under its own light: nothing moves, the background included */
            for (int c = 0; c < 3; c++) self_changed += wall.self.data[c * P + p] != photo.data[c * P + p];
            const int x = (int)(p % (size_t)photo.width), y = (int)(p / (size_t)photo.width);
            const float height = hd_face_height(&fr, x, y);
            int inside = 1; /* the person sure over 13 x 13 pixels: not a strand against the wall */
            for (int dy = -6; dy <= 6 && inside; dy++)
                for (int dx = -6; dx <= 6 && inside; dx++) inside = at(f, x + dx, y + dy) >= 1.0f;
            if (!inside) continue;
            const float head_bg = hd_head_background(&h, x, y);
            if (head_bg > 0.0f && head_bg < 1.0f && height > -2.0f) {
                mixed++; /* a strand's edge: the wall's share of it takes the wall's change */
            } else if (head_bg >= 1.0f && height > -2.0f) {
                /* the wall seen between curls, which the network's coarse map takes for the
                 * person: the wall's change, as at the corners (it took neither the head's change
                 * nor the wall's, a patch of the old light beside the neck) */
                gaps++;
                for (int c = 0; c < 3; c++) {
                    const float in = photo.data[c * P + p], want = fminf(1.0f, (float)(in * t[c] * k));
                    if (want < 1.0f) worst_gap = fmaxf(worst_gap, fabsf(wall.relit[0].data[c * P + p] - want));
                }
            } else if (height > -0.5f) {
                /* the head from the mouth up is the picture with the background kept (the
                 * brightness kept over the head, not the body: within a level's rounding) */
                person++;
                for (int c = 0; c < 3; c++)
                    worst_person = fmaxf(worst_person, fabsf(wall.relit[0].data[c * P + p] - keep.relit[0].data[c * P + p]));
            } else if (height < -2.0f) {
                /* the shirt and the shoulders, well below the chin: relit with the background;
                 * without it only the body near the neck changes (HD_HEAD_BODY_NEAR: nothing
                 * beyond 4 eye distances below the eyes or 2.4 to the side) */
                float dw = 0, dk = 0;
                for (int c = 0; c < 3; c++) {
                    dw = fmaxf(dw, fabsf(wall.relit[0].data[c * P + p] - photo.data[c * P + p]));
                    dk = fmaxf(dk, fabsf(keep.relit[0].data[c * P + p] - photo.data[c * P + p]));
                }
                body++, body_relit += dw > 2.0f / 255;
                if (height < -4.2f || fabsf(hd_face_side(&fr, x, y)) > 2.6f) body_far++, body_kept += dk == 0.0f;
            }
        }
        printf("the body (%ld sure pixels two eye distances below the eyes): %ld relit with the background; without, "
               "%ld of the %ld beyond the neck's reach kept; the head from the mouth up (%ld sure pixels): worst "
               "difference %.2f levels\n",
               body, body_relit, body_kept, body_far, person, 255 * worst_person);
        printf("the wall between the curls (%ld pixels the map is sure are the person, the head's masks the "
               "background): worst pixel off the wall's change by %.2e; %ld strands' edge pixels partly the wall's\n",
               gaps, worst_gap, mixed);
        CHECK(gaps > 100 && worst_gap < 1e-5);
        hd_head_free(&h);
        hd_decomposition_free(&d);
        CHECK(self_changed == 0);
        CHECK(person > 10000 && worst_person < 2.5f / 255);
        CHECK(body > 10000 && body_relit > body * 9 / 10 && body_far > 300 && body_kept == body_far);
    }
    hd_apply_result_free(&keep);
    hd_apply_result_free(&wall);
    hd_model_free(model);
    hd_image_free(&photo);
}

int main(void)
{
    if (!getenv("HDNET_DATA")) {
        char dir[4300];
        snprintf(dir, sizeof dir, "%s/models", test_source_dir());
        setenv("HDNET_DATA", dir, 1);
    }
    hd_aligner *al = NULL;
    hd_status st = hd_aligner_load(&al);
    if (st != HD_OK) fprintf(stderr, "%s\n", hd_error());
    CHECK(st == HD_OK);
    if (al) {
        test_map(al);
        test_head_follows_map(al);
        test_background(al);
        hd_model *model = NULL;
        CHECK(hd_model_load(NULL, &model) == HD_OK);
        if (model) {
            char path[4300];
            const char *td = getenv("HDNET_TESTDATA");
            snprintf(path, sizeof path, "%s/faces-london/001/neutral.jpg", td ? td : "tests/data");
            test_body_weight(al, model, path);
            test_body_near(al, model, path);
            test_body_normals(al, model, path);
            snprintf(path, sizeof path, "%s/examples/astronaut.png", test_source_dir());
            test_body_weight(al, model, path);
            test_body_near(al, model, path);
            test_body_normals(al, model, path);
            hd_model_free(model);
        }
        hd_aligner_free(al);
    }
    return test_summary("person_segment");
}
