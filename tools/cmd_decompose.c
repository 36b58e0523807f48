/* cmd_decompose.c: `hdnet decompose`: photos and aligned face textures (files, or SPEC section 5
 * folders) into albedo, shading, normals, light and reconstruction, with a contact sheet per image,
 * textures in batches with a progress line (docs/usage.md gives the output layout, which `hdnet eval
 * --pred` reads). A photo goes through hd_decompose_photo_maps: each face k gets the same outputs as
 * NAME.face<k>.*, the reconstructions blended into NAME.recon.png, and the full-resolution maps
 * in the photo's frame NAME.photo.*.
 * decompose_textures is the texture-in, texture-out core; everything else is file handling. One
 * unreadable image (or a photo without a face, or a non-finite result) is reported and skipped; the
 * exit status is 1 at the end if any failed. An image's files are written as a set (all or none);
 * the first failure to write (a full disk, an unwritable folder) stops the run. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "batch.h"
#include "cli.h"
#include "hdnet_tool.h"

CLI_COMMAND("decompose", cmd_decompose, "albedo, shading, normals and light of the faces in photos or aligned textures")

#define SHEET_BORDER 4

/* One image to decompose: where it is and where its outputs go (out_dir/name.*). */
typedef struct job {
    char *image, *out_dir, *name;
} job;

typedef struct job_list {
    job *v;
    int count, cap;
} job_list;

static char *dup_str(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = malloc(n);
    if (d) memcpy(d, s, n);
    return d;
}

static int job_add(job_list *jobs, const char *image, const char *out_dir, const char *name)
{
    if (jobs->count == jobs->cap) {
        int cap = jobs->cap ? jobs->cap * 2 : 64;
        job *v = realloc(jobs->v, (size_t)cap * sizeof *v);
        if (!v) return 0;
        jobs->v = v;
        jobs->cap = cap;
    }
    job *j = &jobs->v[jobs->count];
    j->image = dup_str(image);
    j->out_dir = dup_str(out_dir);
    j->name = dup_str(name);
    if (!j->image || !j->out_dir || !j->name) {
        free(j->image);
        free(j->out_dir);
        free(j->name);
        return 0;
    }
    jobs->count++;
    return 1;
}

static void job_list_free(job_list *jobs)
{
    for (int i = 0; i < jobs->count; i++) {
        free(jobs->v[i].image);
        free(jobs->v[i].out_dir);
        free(jobs->v[i].name);
    }
    free(jobs->v);
}

/* The job of one input: OUT/REL.* goes to out_dir = OUT/dirname(REL), name = basename(REL). */
static hd_status add_input(job_list *jobs, const cli_input *in, const char *out)
{
    char *stem = cli_output_path(out, in, "");
    if (!stem) return HD_ERR_NOMEM;
    char *slash = strrchr(stem, '/');
    *slash = '\0';
    int ok = job_add(jobs, in->path, stem, slash + 1);
    free(stem);
    return ok ? HD_OK : hd_fail(HD_ERR_NOMEM, "out of memory");
}

/* The core: decomposes count aligned textures (d[i] at the model size) and draws the contact
 * sheet input | albedo | shading | normal | reconstruction of each into sheets[i]. */
static hd_status decompose_textures(hd_model *model, const hd_image *tex, int count, hd_decomposition *d,
                                    hd_sheet *sheets)
{
    for (int i = 0; i < count; i++) memset(&sheets[i], 0, sizeof sheets[i]);
    hd_status st = hd_model_decompose(model, tex, count, d);
    if (st != HD_OK) return st;
    for (int i = 0; i < count && st == HD_OK; i++) {
        st = hd_sheet_init(&sheets[i], 1, 5, d[i].albedo.width, SHEET_BORDER);
        if (st == HD_OK) st = hd_sheet_put_decomposition(&sheets[i], 0, &tex[i], &d[i]);
    }
    if (st != HD_OK) {
        for (int i = 0; i < count; i++) {
            hd_sheet_free(&sheets[i]);
            hd_decomposition_free(&d[i]);
        }
    }
    return st;
}

/* out_dir/name + suffix (malloc'ed). */
static char *out_path(const job *j, const char *suffix)
{
    size_t n = strlen(j->out_dir) + strlen(j->name) + strlen(suffix) + 2;
    char *p = malloc(n);
    if (p) snprintf(p, n, "%s/%s%s", j->out_dir, j->name, suffix);
    else hd_fail(HD_ERR_NOMEM, "out of memory");
    return p;
}

/* Creates an output folder and, the first time it comes up, removes the temporaries that killed
 * runs left in it. A failure to create it is a write failure (*write_failed). */
static hd_status prepare_folder(const char *dir, char **cleaned, int *write_failed)
{
    if (*cleaned && strcmp(*cleaned, dir) == 0) return HD_OK;
    hd_status st = hd_mkdirs(dir);
    if (st != HD_OK) {
        *write_failed = 1;
        return st;
    }
    hd_remove_stale_temporaries(dir);
    free(*cleaned);
    size_t n = strlen(dir) + 1;
    if ((*cleaned = malloc(n)) != NULL) memcpy(*cleaned, dir, n);
    return HD_OK;
}

/* HD_OK when every map and the light of d are finite; else the reason names the input and the
 * stage (nothing of the image is written then). */
static hd_status check_finite(const job *j, const hd_decomposition *d)
{
    char what[1200];
    const hd_image *maps[] = {&d->albedo, &d->shading, &d->normal, &d->reconstruction};
    static const char *const names[] = {"albedo", "shading", "normal", "reconstruction"};
    for (int k = 0; k < 4; k++) {
        snprintf(what, sizeof what, "%s: the network's %s of %s%s", j->image, names[k], j->name,
                 " (nothing of it written)");
        if (hd_image_check_finite(maps[k], what) != HD_OK) return HD_ERR_NUMERIC;
    }
    for (int k = 0; k < HD_SH_COEFFS; k++)
        if (!isfinite(d->light[k]))
            return hd_fail(HD_ERR_NUMERIC, "%s: the network's light coefficient %d is not finite (nothing of it written)",
                           j->image, k);
    return HD_OK;
}

/* Writes every output of one image (inside the caller's output set); mask is at the
 * decomposition's size. */
static hd_status write_outputs(const job *j, const hd_decomposition *d, const hd_image *mask, const hd_sheet *sheet)
{
    static const char *const suffix[] = {".albedo.png", ".shading.png", ".shading.pfm", ".normal.png",
                                         ".light.txt",  ".recon.png",   ".sheet.png"};
    enum { N_OUT = 7 };
    char *path[N_OUT] = {0};
    hd_image half = {0}, rgb = {0};
    hd_status st = check_finite(j, d);
    if (st == HD_OK) st = hd_mkdirs(j->out_dir);
    for (int k = 0; k < N_OUT && st == HD_OK; k++)
        if (!(path[k] = out_path(j, suffix[k]))) st = HD_ERR_NOMEM;
    if (st == HD_OK) st = hd_image_write_png(path[0], &d->albedo, 8);
    if (st == HD_OK) st = hd_image_alloc(&half, d->shading.width, d->shading.height, 1);
    if (st == HD_OK) {
        /* NAME.shading.png stores s / 2, so shading up to 2 survives the [0, 1] of a PNG */
        size_t n = (size_t)half.width * (size_t)half.height;
        for (size_t p = 0; p < n; p++) half.data[p] = 0.5f * d->shading.data[p];
        st = hd_image_write_png(path[1], &half, 16);
    }
    if (st == HD_OK) st = hd_image_write_pfm(path[2], &d->shading);
    if (st == HD_OK) st = hd_normal_encode(&d->normal, mask, &rgb);
    if (st == HD_OK) st = hd_image_write_png(path[3], &rgb, 16);
    if (st == HD_OK) st = hd_light_write(path[4], d->light);
    if (st == HD_OK) st = hd_image_write_png(path[5], &d->reconstruction, 8);
    if (st == HD_OK) st = hd_sheet_write(sheet, path[6]);
    for (int k = 0; k < N_OUT; k++) free(path[k]);
    hd_image_free(&half);
    hd_image_free(&rgb);
    return st;
}

/* The full-resolution maps of a photo in its own frame: NAME.photo.albedo.png (8 bit),
 * NAME.photo.shading.png (16 bit, s / 2) and .pfm, NAME.photo.normal.png (16 bit, 0 outside the
 * faces), NAME.photo.mask.png (8 bit), NAME.photo.person.png (8 bit: where the people are). */
static hd_status write_photo_maps(const job *j, const hd_photo_maps *m)
{
    static const char *const suffix[] = {".photo.albedo.png", ".photo.shading.png", ".photo.shading.pfm",
                                         ".photo.normal.png", ".photo.mask.png", ".photo.person.png"};
    enum { N_OUT = 6 };
    char *path[N_OUT] = {0};
    hd_image half = {0}, rgb = {0};
    hd_status st = HD_OK;
    for (int k = 0; k < N_OUT && st == HD_OK; k++)
        if (!(path[k] = out_path(j, suffix[k]))) st = HD_ERR_NOMEM;
    if (st == HD_OK) st = hd_image_write_png(path[0], &m->albedo, 8);
    if (st == HD_OK) st = hd_image_alloc(&half, m->shading.width, m->shading.height, 1);
    if (st == HD_OK) {
        size_t n = (size_t)half.width * (size_t)half.height;
        for (size_t p = 0; p < n; p++) half.data[p] = 0.5f * m->shading.data[p];
        st = hd_image_write_png(path[1], &half, 16);
    }
    if (st == HD_OK) st = hd_image_write_pfm(path[2], &m->shading);
    if (st == HD_OK) st = hd_normal_encode(&m->normal, &m->mask, &rgb);
    if (st == HD_OK) st = hd_image_write_png(path[3], &rgb, 16);
    if (st == HD_OK) st = hd_image_write_png(path[4], &m->mask, 8);
    if (st == HD_OK) st = hd_image_write_png(path[5], &m->person, 8);
    for (int k = 0; k < N_OUT; k++) free(path[k]);
    hd_image_free(&half);
    hd_image_free(&rgb);
    return st;
}

/* One photo: hd_decompose_photo_maps, then the outputs of each face k as out_dir/name.face<k>.* (the
 * face's mask resized to the model's size for the normals), the photo with the reconstructions
 * blended in as out_dir/name.recon.png, and the full-resolution maps, all as one output set.
 * *nfaces gets the faces; *write_failed is set when a write failed (HD_ERR_IO). */
static hd_status decompose_photo(hd_model *model, hd_aligner *aligner, const job *j, int *nfaces, int *write_failed)
{
    *nfaces = 0;
    *write_failed = 0;
    hd_image photo = {0};
    hd_photo_maps m;
    hd_status st = hd_image_read_as(j->image, 3, &photo);
    if (st != HD_OK) return st;
    st = hd_decompose_photo_maps(model, aligner, &photo, &m);
    hd_image_free(&photo);
    if (st != HD_OK)
        return st == HD_ERR_NOTFOUND ? hd_fail(st, "%s: no face found (give --aligned if it is an aligned face texture)",
                                               j->image)
                                     : hd_fail(st, "%s: %s", j->image, hd_error());
    const int size = hd_model_size(model);
    hd_atomic_set_begin(); /* the photo's files appear together or not at all */
    for (int k = 0; k < m.nfaces && st == HD_OK; k++) {
        char name[64];
        snprintf(name, sizeof name, ".face%d", k);
        size_t len = strlen(j->name) + strlen(name) + 1;
        job fj = {j->image, j->out_dir, malloc(len)};
        hd_image mask = {0};
        hd_sheet sheet;
        memset(&sheet, 0, sizeof sheet);
        if (!fj.name) st = hd_fail(HD_ERR_NOMEM, "out of memory");
        else snprintf(fj.name, len, "%s%s", j->name, name);
        if (st == HD_OK) st = hd_image_resize(&m.faces[k].mask, size, size, &mask);
        if (st == HD_OK) st = hd_sheet_init(&sheet, 1, 5, m.d[k].albedo.width, SHEET_BORDER);
        if (st == HD_OK) st = hd_sheet_put_decomposition(&sheet, 0, &m.faces[k].texture, &m.d[k]);
        if (st == HD_OK) st = write_outputs(&fj, &m.d[k], &mask, &sheet);
        hd_sheet_free(&sheet);
        free(fj.name);
        hd_image_free(&mask);
        if (st == HD_OK) ++*nfaces;
    }
    if (st == HD_OK) {
        char *path = out_path(j, ".recon.png");
        st = path ? hd_image_write_png(path, &m.recon, 8) : HD_ERR_NOMEM;
        free(path);
    }
    if (st == HD_OK) st = write_photo_maps(j, &m);
    if (st == HD_ERR_IO) *write_failed = 1;
    hd_status set_end = hd_atomic_set_end(st == HD_OK);
    if (st == HD_OK && set_end != HD_OK) {
        st = set_end;
        *write_failed = 1;
    }
    hd_photo_maps_free(&m);
    return st;
}

/* The command line, parsed. */
typedef struct decompose_args {
    const char *model_path, *out, *mask_path, *white_balance;
    int batch, aligned, threads, quiet, json;
    float min_score;
} decompose_args;

static int decompose_check(const cli_cmd_spec *spec, const decompose_args *a)
{
    int code;
    if ((code = cli_opts_common(spec, a->threads, a->min_score)) || (code = cli_white_balance_set(spec, a->white_balance, NULL)))
        return code;
    if (!a->out) return cli_usage_error(spec, "-o is required");
    if (a->batch < 1 || a->batch > 256) return cli_usage_error(spec, "--batch wants 1..256, got %d", a->batch);
    return 0;
}

/* What a run holds and counts (photos and textures alike). */
typedef struct decompose_run {
    const decompose_args *a;
    hd_model *model;
    hd_aligner *aligner;
    cJSON *results; /* with --json: every input's outcome */
    int failed, written, no_face, faces, stop; /* stop: a write failed, the rest is not run */
    char *cleaned;  /* the last output folder cleared of stale temporaries */
    int show;       /* the progress line */
    cli_progress progress;
} decompose_run;

/* One input's outcome in the --json results. */
static void add_result(decompose_run *run, const job *j, const char *kind, const char *status, int faces)
{
    if (!run->results) return;
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "file", j->image);
    cJSON_AddStringToObject(o, "kind", kind);
    cJSON_AddStringToObject(o, "status", status);
    cJSON_AddNumberToObject(o, "faces", faces);
    char *stem = hd_path_join(j->out_dir, j->name);
    if (strcmp(status, "done") == 0 && stem) cJSON_AddStringToObject(o, "output", stem);
    free(stem);
    cJSON_AddItemToArray(run->results, o);
}

static void job_free(job *j)
{
    free(j->image);
    free(j->out_dir);
    free(j->name);
}

/* The photos of jobs one at a time (each aligned first); the aligned textures are kept, in order,
 * at the front of jobs, their number returned. */
static int run_photos(decompose_run *run, job_list *jobs)
{
    const decompose_args *a = run->a;
    int textures = 0;
    for (int i = 0; i < jobs->count; i++) {
        job *j = &jobs->v[i];
        if (a->aligned || hd_input_kind_of(j->image) == HD_INPUT_TEXTURE) {
            jobs->v[textures++] = *j;
            continue;
        }
        int nfaces = 0, write_failed = 0;
        if (run->stop) { /* a write failed before: the rest is not run */
            job_free(j);
            continue;
        }
        hd_status st = run->aligner ? HD_OK : hd_aligner_load(&run->aligner);
        if (st == HD_OK) hd_aligner_set_min_score(run->aligner, a->min_score);
        if (st == HD_OK) st = prepare_folder(j->out_dir, &run->cleaned, &write_failed);
        if (st == HD_OK) st = decompose_photo(run->model, run->aligner, j, &nfaces, &write_failed);
        if (st != HD_OK) {
            cli_report("decompose"); /* the reason names the photo */
            if (st == HD_ERR_NOTFOUND) run->no_face++;
            else run->failed++;
            run->stop = write_failed;
        } else {
            if (!a->quiet && !a->json)
                printf("%s: %d face%s -> %s/%s.face*.*, %s/%s.recon.png\n", j->image, nfaces, nfaces == 1 ? "" : "s",
                       j->out_dir, j->name, j->out_dir, j->name);
            run->written++;
            run->faces += nfaces;
        }
        add_result(run, j, "photo", st == HD_OK ? "done" : st == HD_ERR_NOTFOUND ? "no_face" : "failed", nfaces);
        job_free(j);
        if (run->show && !run->stop) cli_progress_update(&run->progress, run->written + run->failed + run->no_face, NULL);
    }
    return textures;
}

/* Writes the outputs of texture j (decomposed as d, its mask and sheet) as one set; the status
 * string of its --json result. */
static const char *write_texture(decompose_run *run, const job *j, const hd_decomposition *d, const hd_image *mask,
                                 const hd_sheet *sheet)
{
    if (run->stop) return "not_run"; /* a write failed before */
    int write_failed = 0;
    hd_status st = prepare_folder(j->out_dir, &run->cleaned, &write_failed);
    if (st == HD_OK) {
        hd_atomic_set_begin(); /* the image's files appear together or not at all */
        st = write_outputs(j, d, mask, sheet);
        hd_status set_end = hd_atomic_set_end(st == HD_OK);
        write_failed = st == HD_ERR_IO || (st == HD_OK && set_end != HD_OK);
        if (st == HD_OK) st = set_end;
    }
    if (st != HD_OK) {
        cli_report("decompose");
        run->failed++;
        run->stop = write_failed;
        return "failed";
    }
    run->written++;
    run->faces++;
    return "done";
}

/* Buffers of one forward pass of up to `batch` textures. */
typedef struct texture_batch {
    hd_image *tex, *mask;
    hd_decomposition *d;
    hd_sheet *sheets;
    int *index;
} texture_batch;

/* The textures jobs->v[start, end) as one forward pass. */
static void run_texture_batch(decompose_run *run, const job_list *jobs, int start, int end, texture_batch *b)
{
    const int size = hd_model_size(run->model);
    const char *status[256] = {0};
    int n = 0;
    for (int i = start; i < end; i++) {
        char *source = NULL;
        status[i - start] = "failed";
        if (hd_image_read_as(jobs->v[i].image, 3, &b->tex[n]) != HD_OK ||
            hd_face_mask_read(jobs->v[i].image, run->a->mask_path, size, size, &b->mask[n], &source) != HD_OK) {
            cli_report("decompose");
            hd_image_free(&b->tex[n]);
            run->failed++;
        } else {
            b->index[n++] = i;
        }
        free(source);
    }
    if (n > 0 && decompose_textures(run->model, b->tex, n, b->d, b->sheets) != HD_OK) {
        cli_report("decompose");
        run->failed += n;
    } else {
        for (int k = 0; k < n; k++) {
            status[b->index[k] - start] = write_texture(run, &jobs->v[b->index[k]], &b->d[k], &b->mask[k], &b->sheets[k]);
            hd_sheet_free(&b->sheets[k]);
            hd_decomposition_free(&b->d[k]);
        }
    }
    for (int k = 0; k < n; k++) {
        hd_image_free(&b->tex[k]);
        hd_image_free(&b->mask[k]);
    }
    for (int i = start; i < end; i++)
        add_result(run, &jobs->v[i], "aligned", status[i - start], strcmp(status[i - start], "done") == 0);
}

/* The aligned textures (jobs, after run_photos), `batch` per forward pass; photos_seen counts the
 * progress line's photos before them. */
static void run_textures(decompose_run *run, const job_list *jobs, int photos_seen)
{
    const int batch = run->a->batch;
    texture_batch b = {calloc((size_t)batch, sizeof *b.tex), calloc((size_t)batch, sizeof *b.mask),
                       calloc((size_t)batch, sizeof *b.d), calloc((size_t)batch, sizeof *b.sheets),
                       calloc((size_t)batch, sizeof *b.index)};
    if (!b.tex || !b.mask || !b.d || !b.sheets || !b.index) {
        /* the textures fail; the counts still meet those of the other MPI ranks */
        fprintf(stderr, "hdnet decompose: out of memory for %d aligned texture%s\n", jobs->count,
                jobs->count == 1 ? "" : "s");
        run->failed += jobs->count;
    } else {
        for (int start = 0; start < jobs->count && !run->stop; start += batch) {
            int end = start + batch < jobs->count ? start + batch : jobs->count;
            run_texture_batch(run, jobs, start, end, &b);
            if (run->show && !run->stop) cli_progress_update(&run->progress, photos_seen + end, NULL);
        }
    }
    free(b.tex), free(b.mask), free(b.d), free(b.sheets), free(b.index);
}

int cmd_decompose(int argc, char **argv)
{
    decompose_args a = {.batch = 4, .min_score = cli_min_score_default()};
    const cli_opt opts[] = {
        CLI_OPT_MODEL_ROW(a.model_path),
        {"output", 'o', CLI_OPT_STRING, &a.out, "DIR", "output folder (created; folder inputs keep their layout below it)"},
        {"batch", 0, CLI_OPT_INT, &a.batch, "N", "aligned textures per forward pass (default 4)"},
        {"mask", 0, CLI_OPT_STRING, &a.mask_path, "M.png",
         "face mask for aligned textures without a NAME.mask.png beside them (default: all ones)"},
        {"aligned", 0, CLI_OPT_FLAG, &a.aligned, NULL,
         "the inputs are aligned face textures, not photos (automatic for an image with NAME.mask.png or "
         "NAME.normal.png beside it)"},
        CLI_OPT_WHITE_BALANCE_ROW(a.white_balance),
        CLI_OPT_MIN_SCORE_ROW(a.min_score),
        CLI_OPT_THREADS_ROW(a.threads),
        CLI_OPT_QUIET_ROW(a.quiet),
        {"json", 0, CLI_OPT_FLAG, &a.json, NULL, "print the summary (and every input's outcome) as JSON on stdout"},
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const cli_cmd_spec spec = {
        "decompose", "IMG|DIR|@LIST ... [-m MODEL] -o DIR [--batch N] [--aligned [--mask M.png]] [--json]",
        "Decomposes the faces of photos, or aligned face textures (docs/spec.md section 2: --aligned, or an image\n"
        "with NAME.mask.png or NAME.normal.png beside it), into intrinsic components. For each texture\n"
        "NAME it writes, at the model's size: NAME.albedo.png (8 bit), NAME.shading.png (16 bit,\n"
        "storing shading / 2), NAME.shading.pfm (exact), NAME.normal.png (16 bit, (n + 1) / 2, 0\n"
        "outside the mask), NAME.light.txt, NAME.recon.png (albedo x shading) and NAME.sheet.png\n"
        "(input | albedo | shading | normal | reconstruction). A folder input is walked recursively and\n"
        "keeps its layout: DIR/SUB/NAME.png gives OUT/SUB/NAME.* (a docs/spec.md section 5 set: OUT/SUBJECT/NAME.*,\n"
        "what `hdnet eval --pred` reads); @LIST is a file of paths. A photo NAME is aligned first: face k\n"
        "gets the same files as NAME.face<k>.*, NAME.recon.png is the photo with each face's\n"
        "reconstruction warped back and Poisson-blended in, and NAME.photo.{albedo,shading,normal,mask,person}.png\n"
        "(and NAME.photo.shading.pfm) are the maps warped back into the photo's frame at its full size.\n"
        "An unreadable image, a photo without a face or a non-finite result is reported and skipped (none\n"
        "of its files is written); the exit status is then 1, after every other image is written. An\n"
        "image's files appear together or not at all; the first failed write (a full disk, an unwritable\n"
        "folder) stops the run.",
        opts, 1, -1};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    if ((code = decompose_check(&spec, &a))) {
        free(pos);
        return code;
    }
    hd_set_durable_writes(0); /* bulk pictures: atomic (renamed into place) but not fsynced */
    job_list jobs = {0};
    cli_inputs in = {0};
    decompose_run run = {&a, NULL, NULL, a.json ? cJSON_CreateArray() : NULL, 0, 0, 0, 0, 0, NULL, 0, {0}};
    int rc = CLI_EXIT_OK, inputs = 0;
    hd_status st = cli_inputs_collect(&in, pos, npos);
    for (int i = 0; i < in.count && st == HD_OK; i++) st = add_input(&jobs, &in.v[i], a.out);
    free(pos);
    if (st != HD_OK || in.total == 0 || hd_model_load(a.model_path, &run.model) != HD_OK ||
        cli_white_balance_set(&spec, a.white_balance, run.model) || hd_mkdirs(a.out) != HD_OK) {
        rc = cli_report("decompose");
        goto done;
    }
    inputs = jobs.count;
    const double t0 = hd_seconds();
    char label[64];
    run.show = !a.quiet && !a.json && in.total > 1 && cli_batch_reports(); /* under MPI: rank 0's share */
    if (run.show) cli_progress_start(&run.progress, cli_batch_label("decompose", label, sizeof label), jobs.count);
    const int textures = run_photos(&run, &jobs);
    const int photos_seen = jobs.count - textures;
    jobs.count = textures;
    run_textures(&run, &jobs, photos_seen);
    if (run.show && !run.stop) cli_progress_finish(&run.progress, inputs, NULL);
    if (run.stop)
        fprintf(stderr, "hdnet decompose: stopped at the first write failure (the images after it were not decomposed)\n");
    cli_summary sum = {inputs, run.written, run.no_face, run.failed, run.faces, 0.0};
    if (cli_summary_reduce(&sum, t0) != HD_OK) cli_report("decompose"); /* the job's counts, on every rank */
    if (!a.quiet && !a.json && cli_batch_reports()) {
        printf("decomposed %d image%s into %s", sum.done, sum.done == 1 ? "" : "s", a.out);
        if (sum.failed) printf(" (%d failed)", sum.failed);
        if (sum.no_face) printf(" (%d photo%s without a face)", sum.no_face, sum.no_face == 1 ? "" : "s");
        printf("\n");
    }
    rc = cli_summary_status(&sum);
    if (a.json) rc = cli_json_print_run("decompose", &run.results, &in, &sum, a.out, rc);
done:
    free(run.cleaned);
    cJSON_Delete(run.results);
    if (run.model) hd_model_free(run.model);
    hd_aligner_free(run.aligner);
    job_list_free(&jobs);
    cli_inputs_free(&in);
    return rc;
}
