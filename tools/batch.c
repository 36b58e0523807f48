/* batch.c: the inputs of the many-photo commands (files, folders walked recursively, @lists) and
 * their split across MPI ranks, the output naming rule OUT/REL + suffix, and the run loop with
 * progress, failure reports and the job's summary (batch.h, docs/usage.md "Many photos",
 * docs/scaling.md "Inference"). */
#include <ctype.h>
#include <dirent.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>
#include "batch.h"
#include "hdnet_tool.h"
#include "mpi.h"

#define MAX_DEPTH 32      /* folder nesting walked (a symlink loop stops here) */
#define MAX_LIST_LINE 4096

static const char *const image_ext[] = {".png", ".jpg", ".jpeg"};
enum { N_IMAGE_EXT = 3 };

/* The length of name without its image extension (any case), or 0 if it has none. */
static size_t image_stem_len(const char *name)
{
    size_t n = strlen(name);
    for (int k = 0; k < N_IMAGE_EXT; k++) {
        size_t e = strlen(image_ext[k]);
        if (n > e && strncasecmp(name + n - e, image_ext[k], e) == 0) return n - e;
    }
    return 0;
}

static int is_file(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0 && S_ISREG(sb.st_mode);
}

/* Whether dir/NAME.x.y.png is a companion or an output of an image dir/NAME.png (.jpg, .jpeg)
 * beside it: some prefix of its stem ending before a '.' names an image in the same folder. */
static int is_companion(const char *dir, const char *name, size_t stem)
{
    for (size_t i = 1; i < stem; i++) {
        if (name[i] != '.') continue;
        for (int k = 0; k < N_IMAGE_EXT; k++) {
            size_t n = strlen(dir) + i + strlen(image_ext[k]) + 2;
            char *p = malloc(n);
            if (!p) return 0;
            snprintf(p, n, "%s/%.*s%s", dir, (int)i, name, image_ext[k]);
            int yes = is_file(p);
            free(p);
            if (yes) return 1;
        }
    }
    return 0;
}

static hd_status add(cli_inputs *in, const char *path, const char *rel, size_t rel_len)
{
    if (in->count == in->cap) {
        int cap = in->cap ? 2 * in->cap : 64;
        cli_input *v = realloc(in->v, (size_t)cap * sizeof *v);
        if (!v) return hd_fail(HD_ERR_NOMEM, "out of memory listing the inputs");
        in->v = v;
        in->cap = cap;
    }
    cli_input *e = &in->v[in->count];
    e->path = strdup(path);
    e->rel = strndup(rel, rel_len);
    if (!e->path || !e->rel) {
        free(e->path);
        free(e->rel);
        return hd_fail(HD_ERR_NOMEM, "out of memory listing the inputs");
    }
    in->count++;
    return HD_OK;
}

static int compare_names(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

/* The images under dir (prefix: their rel so far, "" at the top), in name order, recursively. */
static hd_status walk(cli_inputs *in, const char *dir, const char *prefix, int depth)
{
    if (depth > MAX_DEPTH) return hd_fail(HD_ERR_RANGE, "%s: folders nested more than %d deep", dir, MAX_DEPTH);
    DIR *d = opendir(dir);
    if (!d) return hd_fail(HD_ERR_IO, "%s: cannot read the folder", dir);
    char **names = NULL;
    int n = 0, cap = 0;
    hd_status st = HD_OK;
    struct dirent *e;
    while ((e = readdir(d)) && st == HD_OK) {
        if (e->d_name[0] == '.') continue; /* hidden, . and .. */
        if (n == cap) {
            cap = cap ? 2 * cap : 64;
            char **nn = realloc(names, (size_t)cap * sizeof *nn);
            if (!nn) {
                st = hd_fail(HD_ERR_NOMEM, "out of memory listing %s", dir);
                break;
            }
            names = nn;
        }
        if (!(names[n] = strdup(e->d_name))) st = hd_fail(HD_ERR_NOMEM, "out of memory listing %s", dir);
        else n++;
    }
    closedir(d);
    if (n > 1) qsort(names, (size_t)n, sizeof *names, compare_names);
    for (int i = 0; i < n && st == HD_OK; i++) {
        char *path = hd_path_join(dir, names[i]);
        size_t rn = strlen(prefix) + strlen(names[i]) + 2;
        char *rel = malloc(rn);
        if (!path || !rel) {
            st = hd_fail(HD_ERR_NOMEM, "out of memory listing %s", dir);
        } else {
            snprintf(rel, rn, "%s%s%s", prefix, *prefix ? "/" : "", names[i]);
            size_t stem = image_stem_len(names[i]);
            if (hd_is_dir(path)) st = walk(in, path, rel, depth + 1);
            else if (stem && is_file(path) && !is_companion(dir, names[i], stem))
                st = add(in, path, rel, strlen(rel) - (strlen(names[i]) - stem));
        }
        free(path);
        free(rel);
    }
    for (int i = 0; i < n; i++) free(names[i]);
    free(names);
    return st;
}

static hd_status add_argument(cli_inputs *in, const char *arg)
{
    if (hd_is_dir(arg)) {
        int before = in->count;
        hd_status st = walk(in, arg, "", 0);
        if (st == HD_OK && in->count == before) return hd_fail(HD_ERR_NOTFOUND, "%s: no .png/.jpg/.jpeg image in the folder", arg);
        return st;
    }
    const char *base = strrchr(arg, '/');
    base = base ? base + 1 : arg;
    size_t stem = image_stem_len(base);
    if (!stem) {
        const char *dot = strrchr(base, '.');
        stem = dot && dot != base ? (size_t)(dot - base) : strlen(base);
    }
    return add(in, arg, base, stem);
}

static hd_status add_list(cli_inputs *in, const char *list)
{
    FILE *f = fopen(list, "r");
    if (!f) return hd_fail(HD_ERR_IO, "%s: cannot read the list", list);
    char line[MAX_LIST_LINE];
    hd_status st = HD_OK;
    long lineno = 0;
    while (st == HD_OK && fgets(line, sizeof line, f)) {
        lineno++;
        size_t n = strlen(line);
        if (n == sizeof line - 1 && line[n - 1] != '\n') {
            st = hd_fail(HD_ERR_FORMAT, "%s:%ld: line longer than %d characters", list, lineno, MAX_LIST_LINE - 2);
            break;
        }
        while (n > 0 && (line[n - 1] == '\n' || line[n - 1] == '\r' || line[n - 1] == ' ' || line[n - 1] == '\t'))
            line[--n] = '\0';
        const char *s = line;
        while (*s == ' ' || *s == '\t') s++;
        if (!*s || *s == '#') continue;
        st = add_argument(in, s);
        if (st == HD_ERR_NOTFOUND) st = hd_fail(st, "%s:%ld: %s", list, lineno, hd_error());
    }
    fclose(f);
    return st;
}

/* Keeps the inputs i with i % R == rank of the job's listing (every rank made the same one), and
 * the listing's paths for putting the ranks' JSON results back in order. */
static hd_status take_share(cli_inputs *in)
{
    const int rank = cli_mpi_rank(), ranks = cli_mpi_ranks();
    in->total = in->count;
    if (ranks <= 1) return HD_OK;
    if (!(in->listing = calloc((size_t)in->total + 1, sizeof *in->listing)))
        return hd_fail(HD_ERR_NOMEM, "out of memory listing the inputs");
    for (int i = 0; i < in->total; i++)
        if (!(in->listing[i] = strdup(in->v[i].path))) return hd_fail(HD_ERR_NOMEM, "out of memory listing the inputs");
    int kept = 0;
    for (int i = 0; i < in->total; i++) {
        if (i % ranks == rank) {
            in->v[kept++] = in->v[i];
        } else {
            free(in->v[i].path);
            free(in->v[i].rel);
        }
    }
    in->count = kept;
    return HD_OK;
}

static int by_rel(const void *a, const void *b)
{
    const cli_input *x = *(const cli_input *const *)a, *y = *(const cli_input *const *)b;
    const int c = strcmp(x->rel, y->rel);
    return c ? c : strcmp(x->path, y->path);
}

/* Two inputs of one name (a/face.jpg and b/face.jpg given as files; face.png beside face.jpg in a
 * folder) would write the same outputs, the second over the first: refused before any work. */
static hd_status check_names(const cli_inputs *in)
{
    if (in->count < 2) return HD_OK;
    const cli_input **v = malloc((size_t)in->count * sizeof *v);
    if (!v) return hd_fail(HD_ERR_NOMEM, "out of memory");
    for (int i = 0; i < in->count; i++) v[i] = &in->v[i];
    qsort(v, (size_t)in->count, sizeof *v, by_rel);
    hd_status st = HD_OK;
    for (int i = 1; i < in->count && st == HD_OK; i++)
        if (strcmp(v[i - 1]->rel, v[i]->rel) == 0)
            st = hd_fail(HD_ERR_ARG,
                         "%s and %s would write the same outputs (OUT/%s.*): give their folder, so that each "
                         "keeps its path below it, or run them apart",
                         v[i - 1]->path, v[i]->path, v[i]->rel);
    free(v);
    return st;
}

hd_status cli_inputs_collect(cli_inputs *in, char *const *args, int nargs)
{
    if (cli_mpi_init(NULL, NULL)) return hd_fail(HD_ERR_ARG, "cannot start as an MPI rank (see above)");
    for (int i = 0; i < nargs; i++) {
        hd_status st = args[i][0] == '@' && args[i][1] ? add_list(in, args[i] + 1) : add_argument(in, args[i]);
        if (st != HD_OK) return st;
    }
    hd_status st = check_names(in);
    return st != HD_OK ? st : take_share(in);
}

void cli_inputs_free(cli_inputs *in)
{
    for (int i = 0; i < in->count; i++) {
        free(in->v[i].path);
        free(in->v[i].rel);
    }
    for (int i = 0; in->listing && i < in->total; i++) free(in->listing[i]);
    free(in->listing);
    free(in->v);
    memset(in, 0, sizeof *in);
}

int cli_single_output(char *const *args, int nargs, const char *out)
{
    if (nargs != 1 || args[0][0] == '@' || hd_is_dir(args[0]) || !out) return 0;
    size_t n = strlen(out);
    return n > 0 && out[n - 1] != '/' && !hd_is_dir(out);
}

int cli_output_mode(const cli_cmd_spec *spec, char *const *args, int nargs, const char *out, const char *folder_only,
                    int *single)
{
    static const char *const file_ext[] = {".png", ".jpg", ".jpeg", ".pfm", ".txt", ".json"};
    *single = !folder_only && cli_single_output(args, nargs, out);
    if (*single || !out || hd_is_dir(out)) return 0;
    const char *base = strrchr(out, '/');
    base = base ? base + 1 : out;
    const char *dot = strrchr(base, '.');
    for (size_t k = 0; dot && k < sizeof file_ext / sizeof file_ext[0]; k++)
        if (strcasecmp(dot, file_ext[k]) == 0)
            return cli_usage_error(spec, "%s; -o %s names a file (give a folder, e.g. -o out/)",
                                  folder_only ? folder_only : "several inputs (or a folder) write into a folder",
                                  out);
    return 0;
}

char *cli_output_path(const char *out, const cli_input *in, const char *suffix)
{
    size_t n = strlen(out) + strlen(in->rel) + strlen(suffix) + 2;
    char *p = malloc(n);
    if (!p) {
        hd_fail(HD_ERR_NOMEM, "out of memory");
        return NULL;
    }
    size_t o = strlen(out);
    while (o > 1 && out[o - 1] == '/') o--;
    snprintf(p, n, "%.*s/%s%s", (int)o, out, in->rel, suffix);
    char *slash = strrchr(p, '/');
    *slash = '\0';
    hd_status st = hd_mkdirs(p);
    *slash = '/';
    if (st != HD_OK) {
        free(p);
        return NULL;
    }
    return p;
}

int cli_batch_reports(void) { return cli_mpi_rank() == 0; }

const char *cli_batch_label(const char *cmd, char *buf, size_t n)
{
    if (cli_mpi_ranks() > 1) snprintf(buf, n, "%s (rank 0 of %d)", cmd, cli_mpi_ranks());
    else snprintf(buf, n, "%s", cmd);
    return buf;
}

hd_status cli_summary_reduce(cli_summary *s, double t0)
{
    double n[5] = {s->inputs, s->done, s->no_face, s->failed, s->faces};
    hd_status st = cli_mpi_sum_doubles(NULL, n, 5);
    if (st == HD_OK) {
        s->inputs = (int)n[0], s->done = (int)n[1], s->no_face = (int)n[2], s->failed = (int)n[3], s->faces = (int)n[4];
    } else {
        s->failed++; /* counted as a failure here, so that this rank's exit status says so */
    }
    s->seconds = hd_seconds() - t0;
    return st;
}

int cli_summary_status(const cli_summary *s)
{
    return s->inputs > 0 && s->done == s->inputs ? CLI_EXIT_OK : CLI_EXIT_FAIL;
}

int cli_batch_run(const char *cmd, const char *verb, const char *no_face_hint, const cli_inputs *in, const char *out,
                  int single, int quiet, cli_photo_fn fn, void *ctx, cli_summary *summary)
{
    cli_summary s = {in->count, 0, 0, 0, 0, 0.0};
    const int many = in->total > 1, show = many && !quiet && cli_batch_reports();
    const int tty = isatty(fileno(stderr));
    cli_progress progress;
    char label[64];
    if (show) cli_progress_start(&progress, cli_batch_label(cmd, label, sizeof label), in->count);
    double t0 = hd_seconds();
    cli_result r;
    for (int i = 0; i < in->count; i++) {
        memset(&r, 0, sizeof r);
        hd_take_write_errno();
        hd_status st = fn(ctx, &in->v[i], out, single, &r);
        const int write_errno = st == HD_OK ? 0 : hd_take_write_errno();
        if (st != HD_OK && show && tty) fprintf(stderr, "\r\033[K"); /* off the progress line */
        if (st == HD_ERR_NOTFOUND) {
            fprintf(stderr, "hdnet %s: %s: no face found%s\n", cmd, in->v[i].path, many ? ", skipped" : no_face_hint);
            s.no_face++;
        } else if (st != HD_OK) {
            const char *why = hd_error();
            size_t n = strlen(in->v[i].path);
            int named = strncmp(why, in->v[i].path, n) == 0 && why[n] == ':'; /* the reason names the file */
            fprintf(stderr, "hdnet %s: %s%s%s%s\n", cmd, named ? "" : in->v[i].path, named ? "" : ": ", why,
                    many ? " (skipped)" : "");
            s.failed++;
            if (hd_write_errno_is_fatal(write_errno)) { /* a full disk, an unwritable folder: all the rest would fail */
                if (i + 1 < in->count)
                    fprintf(stderr, "hdnet %s: stopped at the first write failure (%d input%s after it not run)\n", cmd,
                            in->count - i - 1, in->count - i - 1 == 1 ? "" : "s");
                break;
            }
        } else {
            s.done++;
            s.faces += r.faces;
            if (!many && !quiet)
                printf("%s: %s %d face%s -> %s\n", in->v[i].path, verb, r.faces, r.faces == 1 ? "" : "s", r.wrote);
        }
        if (show) cli_progress_update(&progress, i + 1, NULL);
    }
    if (show) cli_progress_finish(&progress, in->count, NULL);
    if (cli_summary_reduce(&s, t0) != HD_OK) fprintf(stderr, "hdnet %s: %s\n", cmd, hd_error());
    if (show) {
        printf("%s: %d photos -> %s: %d done (%d face%s), %d without a face, %d failed; %.1f s, %.2f photos/s\n", cmd,
               s.inputs, out, s.done, s.faces, s.faces == 1 ? "" : "s", s.no_face, s.failed, s.seconds,
               s.seconds > 0 ? s.inputs / s.seconds : 0.0);
    }
    if (summary) *summary = s;
    return cli_summary_status(&s);
}

cJSON *cli_summary_json(const cli_summary *s, const char *out)
{
    cJSON *o = cJSON_CreateObject();
    if (!o) return NULL;
    cJSON_AddNumberToObject(o, "inputs", s->inputs);
    cJSON_AddNumberToObject(o, "done", s->done);
    cJSON_AddNumberToObject(o, "no_face", s->no_face);
    cJSON_AddNumberToObject(o, "failed", s->failed);
    cJSON_AddNumberToObject(o, "faces", s->faces);
    cJSON_AddNumberToObject(o, "seconds", s->seconds);
    if (out) cJSON_AddStringToObject(o, "output", out);
    return o;
}

/* A result, the place of its input in the job's listing, and its place in the gathered order. */
typedef struct ranked_result {
    int index, order;
    cJSON *item;
} ranked_result;

static int compare_ranked(const void *a, const void *b)
{
    const ranked_result *x = a, *y = b;
    if (x->index != y->index) return (x->index > y->index) - (x->index < y->index);
    return (x->order > y->order) - (x->order < y->order);
}

/* The listing's indices sorted by path (then index), for looking a result's "file" up. */
static const cli_inputs *sorting;
static int compare_listed(const void *a, const void *b)
{
    int i = *(const int *)a, j = *(const int *)b, c = strcmp(sorting->listing[i], sorting->listing[j]);
    return c ? c : (i > j) - (i < j);
}

/* The first place of path in the listing (by_path: the indices sorted by compare_listed), or
 * total if it is not there. */
static int listing_index(const cli_inputs *in, const int *by_path, const char *path)
{
    int lo = 0, hi = in->total;
    while (path && lo < hi) {
        int mid = lo + (hi - lo) / 2;
        if (strcmp(in->listing[by_path[mid]], path) < 0) lo = mid + 1;
        else hi = mid;
    }
    return path && lo < in->total && strcmp(in->listing[by_path[lo]], path) == 0 ? by_path[lo] : in->total;
}

/* Under MPI: the results of every rank, on rank 0, in the job's input order; NULL elsewhere (and
 * on failure, with the reason set). Every rank must call it. */
static cJSON *gather_results(cJSON *mine, const cli_inputs *in)
{
    char *text = cJSON_PrintUnformatted(mine);
    char **texts = cli_mpi_gather_text(text ? text : "[]");
    free(text);
    if (!texts || !cli_batch_reports()) {
        cli_mpi_free_texts(texts);
        return NULL;
    }
    cJSON *all = cJSON_CreateArray();
    for (int r = 0; r < cli_mpi_ranks() && all; r++) {
        cJSON *part = cJSON_Parse(texts[r]), *item;
        while (part && (item = cJSON_DetachItemFromArray(part, 0))) cJSON_AddItemToArray(all, item);
        cJSON_Delete(part);
    }
    cli_mpi_free_texts(texts);
    int n = all ? cJSON_GetArraySize(all) : 0, k = 0;
    ranked_result *v = calloc((size_t)n + 1, sizeof *v);
    int *by_path = calloc((size_t)in->total + 1, sizeof *by_path);
    if (!all || !v || !by_path) {
        free(v);
        free(by_path);
        cJSON_Delete(all);
        hd_fail(HD_ERR_NOMEM, "out of memory gathering the results");
        return NULL;
    }
    for (int i = 0; i < in->total; i++) by_path[i] = i;
    sorting = in;
    qsort(by_path, (size_t)in->total, sizeof *by_path, compare_listed);
    /* a result's input is its "file"; results of one input keep the order they were made in */
    cJSON *item;
    while ((item = cJSON_DetachItemFromArray(all, 0))) {
        v[k].index = listing_index(in, by_path, cJSON_GetStringValue(cJSON_GetObjectItem(item, "file")));
        v[k].order = k;
        v[k++].item = item;
    }
    qsort(v, (size_t)k, sizeof *v, compare_ranked);
    for (int i = 0; i < k; i++) cJSON_AddItemToArray(all, v[i].item);
    free(v);
    free(by_path);
    return all;
}

int cli_json_print_run(const char *cmd, cJSON **results, const cli_inputs *in, const cli_summary *s, const char *out,
                       int ok_status)
{
    if (cli_mpi_ranks() > 1) {
        cJSON *all = gather_results(*results, in);
        cJSON_Delete(*results);
        *results = all;
        if (!cli_batch_reports()) return ok_status;
        if (!all) {
            fprintf(stderr, "hdnet %s: %s\n", cmd, hd_error());
            return CLI_EXIT_FAIL;
        }
    }
    cJSON *doc = cJSON_CreateObject();
    if (doc) {
        cJSON_AddItemToObject(doc, "results", *results);
        *results = NULL;
        cJSON_AddItemToObject(doc, "summary", cli_summary_json(s, out));
    }
    return cli_json_print(cmd, doc, ok_status);
}

int cli_json_print(const char *cmd, cJSON *doc, int ok_status)
{
    char *text = doc ? cJSON_Print(doc) : NULL;
    cJSON_Delete(doc);
    if (!text) {
        fprintf(stderr, "hdnet %s: out of memory writing the JSON output\n", cmd);
        return CLI_EXIT_FAIL;
    }
    printf("%s\n", text);
    free(text);
    return ok_status;
}
