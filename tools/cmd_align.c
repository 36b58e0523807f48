/* cmd_align.c: `hdnet align`: photos -> per face, the aligned texture, mask, coarse normals,
 * landmarks and warp file in the SPEC section 5 layout (one subject folder per photo: OUT/REL/,
 * the naming rule of batch.h), with a progress line, a summary, and --json. */
#include <stdlib.h>
#include <string.h>
#include "batch.h"
#include "cli.h"
#include "hdnet_tool.h"

CLI_COMMAND("align", cmd_align, "find the faces in photos and unwarp each into the aligned texture space")

typedef struct align_run {
    int size, verbose; /* verbose: a line per face (not with -q or --json) */
    hd_aligner *aligner;
    cJSON *results; /* --json: one object per photo done */
} align_run;

/* One photo: its faces into OUT/REL/face<k>.*. */
static hd_status align_one(void *ctx, const cli_input *in, const char *out, int single, cli_result *r)
{
    (void)single;
    align_run *run = ctx;
    hd_image photo = {0};
    hd_aligned_face *faces = NULL;
    int count = 0;
    char *dir = NULL;
    hd_status st = hd_image_read_as(in->path, 3, &photo);
    if (st == HD_OK) st = hd_aligner_run(run->aligner, &photo, run->size, &faces, &count);
    if (st == HD_OK && count == 0) st = hd_fail(HD_ERR_NOTFOUND, "no face found");
    if (st == HD_OK && !(dir = cli_output_path(out, in, ""))) st = HD_ERR_NOMEM;
    if (st == HD_OK) st = hd_mkdirs(dir);
    cJSON *faces_json = run->results ? cJSON_CreateArray() : NULL;
    for (int k = 0; k < count && st == HD_OK; k++) {
        char name[32];
        snprintf(name, sizeof name, "face%d", k);
        st = hd_aligned_face_write(&faces[k], dir, name);
        if (st == HD_OK) r->faces++;
        if (st == HD_OK && run->verbose)
            printf("%s: face %d score %.2f box %.0f,%.0f-%.0f,%.0f fit rms %.2f px -> %s/%s.*\n", in->path, k,
                   faces[k].score, faces[k].box[0], faces[k].box[1], faces[k].box[2], faces[k].box[3], faces[k].fit_rms,
                   dir, name);
        cJSON *f = faces_json ? cJSON_CreateObject() : NULL;
        if (f) {
            cJSON_AddNumberToObject(f, "index", k);
            cJSON_AddNumberToObject(f, "score", faces[k].score);
            cJSON *box = cJSON_AddArrayToObject(f, "box");
            for (int c = 0; c < 4 && box; c++) cJSON_AddItemToArray(box, cJSON_CreateNumber(faces[k].box[c]));
            cJSON_AddNumberToObject(f, "fit_rms", faces[k].fit_rms);
            char *stem = hd_path_join(dir, name);
            if (stem) cJSON_AddStringToObject(f, "output", stem);
            free(stem);
            cJSON_AddItemToArray(faces_json, f);
        }
    }
    if (st == HD_OK) snprintf(r->wrote, sizeof r->wrote, "%s/face*.*", dir);
    if (st == HD_OK && run->results) {
        cJSON *o = cJSON_CreateObject();
        if (o) {
            cJSON_AddStringToObject(o, "file", in->path);
            cJSON_AddNumberToObject(o, "width", photo.width);
            cJSON_AddNumberToObject(o, "height", photo.height);
            cJSON_AddStringToObject(o, "output", dir);
            cJSON_AddItemToObject(o, "faces", faces_json);
            faces_json = NULL;
            cJSON_AddItemToArray(run->results, o);
        }
    }
    cJSON_Delete(faces_json);
    free(dir);
    hd_aligned_faces_free(faces, count);
    hd_image_free(&photo);
    return st;
}

int cmd_align(int argc, char **argv)
{
    const char *out_dir = NULL;
    int size = 256, quiet = 0, threads = 0, json = 0;
    float min_score = cli_min_score_default();
    const cli_opt opts[] = {
        {"output", 'o', CLI_OPT_STRING, &out_dir, "DIR", "output folder: DIR/<photo name>/face<k>.* (required)"},
        {"size", 0, CLI_OPT_INT, &size, "S", "side of the aligned texture, 16..4096 (default 256)"},
        CLI_OPT_MIN_SCORE_ROW(min_score),
        CLI_OPT_THREADS_ROW(threads),
        CLI_OPT_QUIET_ROW(quiet),
        CLI_OPT_JSON_ROW(json),
        {0},
    };
    cli_cmd_spec spec = {
        "align", "IMG|DIR|@LIST ... -o DIR [--size S] [--json]",
        "Finds every face in each photo (a folder: its .png/.jpg/.jpeg files, recursively; @LIST: a file of\n"
        "paths), fits the canonical face mesh to its 468 landmarks and writes, per face k, into\n"
        "DIR/REL/<photo name>/ (REL the path below a folder given):\n"
        "  face<k>.png            the face unwarped into the aligned texture space (S x S)\n"
        "  face<k>.mask.png       1 where the texel is on the face and seen by the camera\n"
        "  face<k>.normal.png     coarse normals of the fitted mesh, camera frame, 16 bit\n"
        "  face<k>.landmarks.txt  the 468 landmarks, one 'x y z' per line, photo pixels\n"
        "  face<k>.warp.txt       what `hdnet blend --warp` needs to put a result back into the photo\n"
        "Faces are numbered from 0 by detection score. A photo without a face, or one that cannot be read,\n"
        "is reported and skipped. Exit status: 0 if every photo was aligned, 1 if any was skipped (the\n"
        "summary says how many), 2 for a command-line error.",
        opts, 1, -1};
    char **pos;
    int np, code;
    if (cli_opts_parse(&spec, argc, argv, &pos, &np, &code)) return code;
    if ((code = cli_opts_common(&spec, threads, min_score)) ||
        (!out_dir && (code = cli_usage_error(&spec, "-o DIR is required"))) ||
        ((size < 16 || size > 4096) && (code = cli_usage_error(&spec, "--size must be in 16..4096, got %d", size)))) {
        free(pos);
        return code;
    }
    cli_inputs in = {0};
    align_run run = {size, !quiet && !json, NULL, json ? cJSON_CreateArray() : NULL};
    int rc = CLI_EXIT_FAIL;
    /* an unwritable -o fails before any work */
    if (cli_inputs_collect(&in, pos, np) != HD_OK || hd_mkdirs(out_dir) != HD_OK || hd_aligner_load(&run.aligner) != HD_OK) {
        cli_report("align");
        goto done;
    }
    hd_aligner_set_min_score(run.aligner, min_score);
    cli_summary sum;
    rc = cli_batch_run("align", "aligned", "", &in, out_dir, 0, quiet || json, align_one, &run, &sum);
    if (json) rc = cli_json_print_run("align", &run.results, &in, &sum, out_dir, rc);
done:
    cJSON_Delete(run.results);
    hd_aligner_free(run.aligner);
    cli_inputs_free(&in);
    free(pos);
    return rc;
}
