/* cmd_detect.c: `hdnet detect`: the face detector and the face mesh on one photo, for debugging
 * and for the pictures of docs/alignment.md: prints each face's score, box and keypoints, writes
 * the landmarks as text, and draws the box, keypoints, landmark crop and landmarks on the photo
 * (docs/img/align-detect.png and align-landmarks.png are made with it). */
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include "batch.h"
#include "cli.h"
#include "hdnet_tool.h"

CLI_COMMAND("detect", cmd_detect, "find faces and their 468 landmarks in a photo; print, save or draw them")

enum { DRAW_BOX = 1, DRAW_KEYPOINTS = 2, DRAW_ROI = 4, DRAW_LANDMARKS = 8, DRAW_MESH = 16 };

static const char *keypoint_names[HD_FACE_KEYPOINTS] = {"right eye", "left eye", "nose tip", "mouth", "right ear", "left ear"};
static const float keypoint_colors[HD_FACE_KEYPOINTS][3] = {
    {1, 0.1f, 0.1f}, {0.2f, 0.4f, 1}, {1, 1, 0.1f}, {1, 0.2f, 1}, {1, 0.6f, 0.1f}, {0.1f, 1, 1}};

/* The canvas: an RGB picture and the map from photo coordinates to it, q = (p - origin) * zoom. */
typedef struct canvas {
    hd_image img;
    float origin[2], zoom;
    int thick;
    float alpha; /* opacity of what is drawn */
} canvas;

static void plot(canvas *cv, int x, int y, const float rgb[3])
{
    if (x < 0 || y < 0 || x >= cv->img.width || y >= cv->img.height) return;
    size_t plane = (size_t)cv->img.width * cv->img.height;
    for (int c = 0; c < 3; c++) {
        float *p = &cv->img.data[c * plane + (size_t)y * cv->img.width + x];
        *p = (1.0f - cv->alpha) * *p + cv->alpha * rgb[c];
    }
}

/* A filled disc of radius r (canvas pixels) centred on photo point p. */
static void dot(canvas *cv, const float p[2], float r, const float rgb[3])
{
    float qx = (p[0] - cv->origin[0]) * cv->zoom, qy = (p[1] - cv->origin[1]) * cv->zoom;
    if (!isfinite(qx) || !isfinite(qy) || fabsf(qx) > 1e6f || fabsf(qy) > 1e6f) return;
    for (int y = (int)floorf(qy - r); y <= (int)ceilf(qy + r); y++)
        for (int x = (int)floorf(qx - r); x <= (int)ceilf(qx + r); x++) {
            float dx = (float)x + 0.5f - qx, dy = (float)y + 0.5f - qy;
            if (dx * dx + dy * dy <= r * r) plot(cv, x, y, rgb);
        }
}

/* A line between photo points a and b, cv->thick canvas pixels wide. */
static void line(canvas *cv, const float a[2], const float b[2], const float rgb[3])
{
    float ax = (a[0] - cv->origin[0]) * cv->zoom, ay = (a[1] - cv->origin[1]) * cv->zoom;
    float bx = (b[0] - cv->origin[0]) * cv->zoom, by = (b[1] - cv->origin[1]) * cv->zoom;
    float len = hypotf(bx - ax, by - ay);
    if (!isfinite(len) || len > 1e5f) return;
    int steps = (int)ceilf(len) + 1;
    float r = 0.5f * (float)cv->thick;
    for (int i = 0; i <= steps; i++) {
        float t = (float)i / (float)steps, q[2];
        /* back to photo coordinates for dot() */
        q[0] = (ax + t * (bx - ax)) / cv->zoom + cv->origin[0];
        q[1] = (ay + t * (by - ay)) / cv->zoom + cv->origin[1];
        dot(cv, q, r, rgb);
    }
}

static void draw_face(canvas *cv, const hd_face_box *f, const hd_face_roi *roi, const float (*lm)[3],
                      const hd_mesh *mesh, int draw)
{
    static const float green[3] = {0.1f, 1, 0.2f}, cyan[3] = {0.2f, 0.9f, 1}, yellow[3] = {1, 0.95f, 0.2f};
    static const float white[3] = {1, 1, 1};
    if ((draw & DRAW_MESH) && lm && mesh) {
        int thick = cv->thick;
        cv->thick = 1;
        cv->alpha = 0.45f;
        for (int t = 0; t < mesh->nt; t++)
            for (int e = 0; e < 3; e++) {
                int a = mesh->tri[3 * t + e], b = mesh->tri[3 * t + (e + 1) % 3];
                line(cv, lm[a], lm[b], white);
            }
        cv->thick = thick;
        cv->alpha = 1.0f;
    }
    if (draw & DRAW_BOX) {
        float c[4][2] = {{f->x0, f->y0}, {f->x1, f->y0}, {f->x1, f->y1}, {f->x0, f->y1}};
        for (int k = 0; k < 4; k++) line(cv, c[k], c[(k + 1) % 4], green);
    }
    if ((draw & DRAW_ROI) && roi) {
        float ux = cosf(roi->angle) * 0.5f * roi->size, uy = sinf(roi->angle) * 0.5f * roi->size;
        float c[4][2] = {{roi->cx - ux + uy, roi->cy - uy - ux},
                         {roi->cx + ux + uy, roi->cy + uy - ux},
                         {roi->cx + ux - uy, roi->cy + uy + ux},
                         {roi->cx - ux - uy, roi->cy - uy + ux}};
        for (int k = 0; k < 4; k++) line(cv, c[k], c[(k + 1) % 4], cyan);
    }
    if ((draw & DRAW_LANDMARKS) && lm)
        for (int i = 0; i < HD_FACE_MESH_POINTS; i++) dot(cv, lm[i], 0.6f * (float)cv->thick + 0.6f, yellow);
    if (draw & DRAW_KEYPOINTS)
        for (int k = 0; k < HD_FACE_KEYPOINTS; k++) dot(cv, f->keypoints[k], 1.5f * (float)cv->thick + 1.0f, keypoint_colors[k]);
}

static int parse_draw(const char *text, int *draw)
{
    *draw = 0;
    const char *s = text;
    while (*s) {
        size_t n = strcspn(s, ",");
        if (n == 3 && strncmp(s, "box", 3) == 0) *draw |= DRAW_BOX;
        else if (n == 9 && strncmp(s, "keypoints", 9) == 0) *draw |= DRAW_KEYPOINTS;
        else if (n == 3 && strncmp(s, "roi", 3) == 0) *draw |= DRAW_ROI;
        else if (n == 9 && strncmp(s, "landmarks", 9) == 0) *draw |= DRAW_LANDMARKS;
        else if (n == 4 && strncmp(s, "mesh", 4) == 0) *draw |= DRAW_MESH;
        else return 0;
        s += n;
        if (*s == ',') s++;
    }
    return *draw != 0;
}

/* Writes every face's landmarks: a comment line per face, then 468 lines "x y z". */
static hd_status write_landmarks(const char *path, const hd_face_box *faces, const float (*lm)[HD_FACE_MESH_POINTS][3],
                                 const float *presence, int count)
{
    hd_atomic_file af;
    hd_status st = hd_atomic_open(&af, path);
    if (st != HD_OK) return st;
    fprintf(af.f, "# hdnet detect: %d face(s); per face 468 lines \"x y z\" (photo pixels, x right, y down; "
                  "z smaller = closer)\n", count);
    for (int i = 0; i < count; i++) {
        fprintf(af.f, "# face %d score %.4f presence %.4f\n", i, (double)faces[i].score, (double)presence[i]);
        for (int k = 0; k < HD_FACE_MESH_POINTS; k++)
            fprintf(af.f, "%.3f %.3f %.3f\n", (double)lm[i][k][0], (double)lm[i][k][1], (double)lm[i][k][2]);
    }
    return hd_atomic_commit(&af);
}

/* printf when on (the text lines, which --json replaces). */
static void say(int on, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void say(int on, const char *fmt, ...)
{
    if (!on) return;
    va_list ap;
    va_start(ap, fmt);
    vprintf(fmt, ap);
    va_end(ap);
}

/* The --json document (docs/usage.md, "hdnet detect"). */
static cJSON *detect_json(const char *path, const hd_image *photo, float min_score, double seconds,
                          const hd_face_box *faces, int count, const float (*lm)[HD_FACE_MESH_POINTS][3],
                          const float *presence, const char *out, const char *landmarks_path)
{
    static const char *const keys[HD_FACE_KEYPOINTS] = {"right_eye", "left_eye", "nose_tip", "mouth", "right_ear", "left_ear"};
    cJSON *doc = cJSON_CreateObject();
    if (!doc) return NULL;
    cJSON_AddStringToObject(doc, "file", path);
    cJSON_AddNumberToObject(doc, "width", photo->width);
    cJSON_AddNumberToObject(doc, "height", photo->height);
    cJSON_AddNumberToObject(doc, "min_score", min_score);
    cJSON_AddNumberToObject(doc, "detection_ms", 1e3 * seconds);
    cJSON *arr = cJSON_AddArrayToObject(doc, "faces");
    for (int i = 0; i < count && arr; i++) {
        cJSON *f = cJSON_CreateObject();
        if (!f) break;
        cJSON_AddNumberToObject(f, "index", i);
        cJSON_AddNumberToObject(f, "score", faces[i].score);
        const float b[4] = {faces[i].x0, faces[i].y0, faces[i].x1, faces[i].y1};
        cJSON_AddItemToObject(f, "box", cJSON_CreateFloatArray(b, 4));
        cJSON *kp = cJSON_AddObjectToObject(f, "keypoints");
        for (int k = 0; k < HD_FACE_KEYPOINTS && kp; k++)
            cJSON_AddItemToObject(kp, keys[k], cJSON_CreateFloatArray(faces[i].keypoints[k], 2));
        if (lm) {
            cJSON_AddNumberToObject(f, "presence", presence[i]);
            cJSON *pts = cJSON_AddArrayToObject(f, "landmarks");
            for (int k = 0; k < HD_FACE_MESH_POINTS && pts; k++)
                cJSON_AddItemToArray(pts, cJSON_CreateFloatArray(lm[i][k], 3));
        }
        cJSON_AddItemToArray(arr, f);
    }
    if (out) cJSON_AddStringToObject(doc, "output", out);
    if (landmarks_path) cJSON_AddStringToObject(doc, "landmarks_file", landmarks_path);
    return doc;
}

/* The canvas -o draws on: the photo itself, or (zoom_size > 0) the axis-aligned square around the
 * first face's landmark crop (rois[0]; without landmarks the crop of its box), enlarged to
 * zoom_size x zoom_size pixels. */
static hd_status canvas_of(const hd_image *photo, const hd_face_box *faces, const hd_face_roi *rois, int zoom_size,
                           canvas *cv)
{
    hd_status st;
    if (zoom_size > 0) {
        const hd_face_roi *r = rois ? &rois[0] : NULL;
        hd_face_roi from_box;
        if (!r) {
            hd_face_roi_from_box(&faces[0], &from_box);
            r = &from_box;
        }
        float side = r->size * (fabsf(cosf(r->angle)) + fabsf(sinf(r->angle)));
        cv->zoom = (float)zoom_size / side;
        cv->origin[0] = r->cx - 0.5f * side;
        cv->origin[1] = r->cy - 0.5f * side;
        if ((st = hd_image_alloc(&cv->img, zoom_size, zoom_size, 3)) != HD_OK) return st;
        float *rgb = hd_malloc((size_t)zoom_size * zoom_size * 3 * sizeof *rgb);
        if (!rgb) return HD_ERR_NOMEM;
        float ax[2] = {1.0f / cv->zoom, 0.0f}, ay[2] = {0.0f, 1.0f / cv->zoom};
        hd_face_sample(photo, cv->origin, ax, ay, zoom_size, zoom_size, 0.0f, 1.0f, HD_BORDER_ZERO, rgb);
        size_t plane = (size_t)zoom_size * zoom_size;
        for (size_t p = 0; p < plane; p++)
            for (int c = 0; c < 3; c++) cv->img.data[c * plane + p] = rgb[3 * p + c];
        free(rgb);
    } else {
        cv->zoom = 1.0f;
        if ((st = hd_image_alloc(&cv->img, photo->width, photo->height, 3)) != HD_OK) return st;
        memcpy(cv->img.data, photo->data, (size_t)photo->width * photo->height * 3 * sizeof(float));
    }
    cv->alpha = 1.0f;
    int side = cv->img.width > cv->img.height ? cv->img.width : cv->img.height;
    cv->thick = side / 400 > 1 ? side / 400 : 1;
    return HD_OK;
}

/* The command line, parsed. */
typedef struct detect_args {
    const char *out, *landmarks_path, *draw_text;
    float min_score, min_face;
    int no_landmarks, zoom_size, threads, json;
    int draw; /* DRAW_* bits of draw_text */
} detect_args;

static int detect_check(const cli_cmd_spec *spec, detect_args *a)
{
    int code;
    if (!parse_draw(a->draw_text, &a->draw))
        return cli_usage_error(spec, "--draw wants a list of box, keypoints, roi, landmarks, mesh; got '%s'", a->draw_text);
    if ((code = cli_opts_common(spec, a->threads, a->min_score))) return code;
    if (!(a->min_face >= 0.0f && a->min_face <= (float)HD_IMAGE_MAX_SIDE))
        return cli_usage_error(spec, "--min-face must be in [0, %d] pixels, got %g", HD_IMAGE_MAX_SIDE, (double)a->min_face);
    if (a->zoom_size < 0 || a->zoom_size > 4096) return cli_usage_error(spec, "--zoom must be in 0..4096, got %d", a->zoom_size);
    if (a->no_landmarks && a->landmarks_path)
        return cli_usage_error(spec, "--landmarks needs the face mesh (drop --no-landmarks)");
    if (a->zoom_size && !a->out) return cli_usage_error(spec, "--zoom goes with -o");
    return 0;
}

int cmd_detect(int argc, char **argv)
{
    detect_args a = {.draw_text = "box,keypoints,landmarks", .min_score = HD_FACE_MIN_SCORE, .min_face = HD_FACE_MIN_SIZE};
    const cli_opt opts[] = {
        {"output", 'o', CLI_OPT_STRING, &a.out, "OUT.png", "draw the faces on the photo into this PNG"},
        {"landmarks", 0, CLI_OPT_STRING, &a.landmarks_path, "L.txt",
         "write the landmarks: per face a '# face' line and 468 lines 'x y z'"},
        CLI_OPT_MIN_SCORE_ROW(a.min_score),
        {"min-face", 0, CLI_OPT_FLOAT, &a.min_face, "PX",
         "smallest face to look for, pixels wide (default 40; 0: one pass over the whole photo)"},
        CLI_OPT_THREADS_ROW(a.threads),
        {"no-landmarks", 0, CLI_OPT_FLAG, &a.no_landmarks, NULL, "detection only (no face mesh)"},
        {"draw", 0, CLI_OPT_STRING, &a.draw_text, "LIST",
         "what -o shows, comma-separated from box, keypoints, roi (the crop the face mesh first sees), "
         "landmarks, mesh (the canonical mesh's triangles on the landmarks) (default box,keypoints,landmarks)"},
        {"zoom", 0, CLI_OPT_INT, &a.zoom_size, "N",
         "draw only the first face's landmark crop, enlarged to N x N pixels (default 0: the whole photo)"},
        CLI_OPT_JSON_ROW(a.json),
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const cli_cmd_spec spec = {
        "detect", "IMG [-o annotated.png] [--landmarks L.txt] [options]",
        "Finds the faces in a photo with MediaPipe's BlazeFace detector (back-camera model) over an\n"
        "image pyramid, down to --min-face pixels wide, and, for each, the 468 face-mesh landmarks\n"
        "(the vertex order of models/canonical_face_model.obj). Prints one line per face (score, box)\n"
        "and its six keypoints.\n"
        "Photo coordinates: pixels, x right, y down, pixel (i, j) centred at (i + 0.5, j + 0.5).\n"
        "A photo without a face is not an error: it prints 'no face found' (--json: an empty \"faces\").",
        opts, 1, 1};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    const char *path = pos[0];
    free(pos);
    if ((code = detect_check(&spec, &a))) return code;
    const char *out = a.out, *landmarks_path = a.landmarks_path;
    const float min_score = a.min_score;
    const int json = a.json, draw = a.draw;
    int zoom_size = a.zoom_size;

    hd_image photo = {0};
    hd_face_detector *det = NULL;
    hd_face_mesh *mesh = NULL;
    hd_face_box *faces = NULL;
    float (*lm)[HD_FACE_MESH_POINTS][3] = NULL;
    float *presence = NULL;
    hd_face_roi *rois = NULL;
    canvas cv = {0};
    hd_mesh canonical = {0};
    int count = 0, rc = CLI_EXIT_FAIL, reported = 0;
    if (hd_image_read_as(path, 3, &photo) != HD_OK || hd_face_detector_load(NULL, &det) != HD_OK) goto done;
    double t0 = hd_seconds();
    if (hd_face_detector_find(det, &photo, min_score, a.min_face, &faces, &count) != HD_OK) goto done;
    double t_detect = hd_seconds() - t0;
    say(!json, "%s: %dx%d, %d face(s) (detection %.1f ms)\n", path, photo.width, photo.height, count, 1e3 * t_detect);
    if (count == 0) {
        say(!json, "no face found (score threshold %.2f)%s\n", (double)min_score,
               zoom_size && out ? ": nothing to zoom to, drawing the whole photo" : "");
        zoom_size = 0;
    }
    if (!a.no_landmarks && count > 0) {
        lm = hd_calloc((size_t)count, sizeof *lm);
        presence = hd_calloc((size_t)count, sizeof *presence);
        rois = hd_calloc((size_t)count, sizeof *rois);
        if (!lm || !presence || !rois || hd_face_mesh_load(NULL, &mesh) != HD_OK) goto done;
    }
    for (int i = 0; i < count; i++) {
        const hd_face_box *f = &faces[i];
        say(!json, "face %d: score %.3f box (%.1f, %.1f)-(%.1f, %.1f)\n", i, (double)f->score, (double)f->x0,
               (double)f->y0, (double)f->x1, (double)f->y1);
        for (int k = 0; k < HD_FACE_KEYPOINTS; k++)
            say(!json, "  %-9s (%.1f, %.1f)\n", keypoint_names[k], (double)f->keypoints[k][0], (double)f->keypoints[k][1]);
        if (!mesh) continue;
        t0 = hd_seconds();
        if (hd_face_mesh_fit(mesh, &photo, f, 2, lm[i], &presence[i]) != HD_OK) goto done;
        hd_face_roi_from_landmarks((const float(*)[3])lm[i], &rois[i]);
        say(!json, "  landmarks: presence %.3f, crop %.1f px at %.1f degrees (%.1f ms)\n", (double)presence[i],
               (double)rois[i].size, (double)(rois[i].angle * 57.29578f), 1e3 * (hd_seconds() - t0));
        if (presence[i] < 0.5f) say(!json, "  (the face mesh doubts this is a face)\n");
    }
    if (landmarks_path && write_landmarks(landmarks_path, faces, (const float(*)[HD_FACE_MESH_POINTS][3])lm, presence,
                                          count) != HD_OK)
        goto done;
    if (out) {
        if (canvas_of(&photo, faces, rois, zoom_size, &cv) != HD_OK) goto done;
        if ((draw & DRAW_MESH) && lm && hd_mesh_load_canonical(&canonical) != HD_OK) goto done;
        for (int i = count - 1; i >= 0; i--) {
            hd_face_roi box_roi;
            hd_face_roi_from_box(&faces[i], &box_roi);
            draw_face(&cv, &faces[i], &box_roi, lm ? (const float(*)[3])lm[i] : NULL, &canonical, draw);
        }
        if (hd_image_write_png(out, &cv.img, 8) != HD_OK) goto done;
        say(!json, "wrote %s\n", out);
    }
    rc = json ? cli_json_print("detect",
                               detect_json(path, &photo, min_score, t_detect, faces, count,
                                           (const float(*)[HD_FACE_MESH_POINTS][3])lm, presence, out, landmarks_path),
                               CLI_EXIT_OK)
              : CLI_EXIT_OK;
    reported = rc != CLI_EXIT_OK; /* cli_json_print said why */
done:
    if (rc != CLI_EXIT_OK && !reported) cli_report("detect");
    hd_image_free(&cv.img);
    hd_mesh_free(&canonical);
    hd_image_free(&photo);
    hd_face_detector_free(det);
    hd_face_mesh_free(mesh);
    free(faces);
    free(lm);
    free(presence);
    free(rois);
    return rc;
}
