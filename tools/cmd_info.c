/* cmd_info.c: `hdnet info FILE...`: says what each file is (image, checkpoint or light file) and
 * what it holds, after reading it with the same checked readers every other command uses; a
 * broken file gets the reader's reason and exit status 1 (docs/formats.md lists the formats).
 * With --json the same facts go into one JSON document (j: the file's object; NULL for text). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "batch.h"
#include "cli.h"

CLI_COMMAND("info", cmd_info, "describe image, checkpoint (safetensors) and light files")

typedef enum file_kind { KIND_IMAGE, KIND_SAFETENSORS, KIND_LIGHT } file_kind;

static int ends_with(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && strcmp(s + a - b, suffix) == 0;
}

/* By name first (.safetensors, .txt), else by content: a safetensors header starts with a
 * length word and '{'; everything else goes to the image reader, which names unknown formats. */
static file_kind guess_kind(const char *path)
{
    if (ends_with(path, ".safetensors")) return KIND_SAFETENSORS;
    if (ends_with(path, ".txt")) return KIND_LIGHT;
    FILE *f = fopen(path, "rb");
    if (!f) return KIND_IMAGE;
    unsigned char head[9];
    size_t got = fread(head, 1, sizeof head, f);
    fclose(f);
    if (got == 9 && head[8] == '{' && head[6] == 0 && head[7] == 0) return KIND_SAFETENSORS;
    return KIND_IMAGE;
}

static int info_image(const char *path, cJSON *j)
{
    hd_image img = {0};
    hd_image_info info;
    if (hd_image_read_info(path, &img, &info) != HD_OK) return 1;
    static const char *const names[5][4] = {{""},
                                            {"gray"},
                                            {"gray", "alpha"},
                                            {"red", "green", "blue"},
                                            {"red", "green", "blue", "alpha"}};
    cJSON *stats = NULL;
    if (j) {
        cJSON_AddStringToObject(j, "kind", "image");
        cJSON_AddStringToObject(j, "format", info.format);
        cJSON_AddNumberToObject(j, "width", img.width);
        cJSON_AddNumberToObject(j, "height", img.height);
        cJSON_AddNumberToObject(j, "channels", img.channels);
        cJSON_AddNumberToObject(j, "bits", info.bits);
        cJSON_AddBoolToObject(j, "float", info.format[1] == 'F');
        cJSON_AddBoolToObject(j, "palette", info.palette != 0);
        stats = cJSON_AddArrayToObject(j, "channel_stats");
    } else {
        printf("%s: %s image, %d x %d, %d channel%s, %d bit%s%s\n", path, info.format, img.width, img.height,
               img.channels, img.channels == 1 ? "" : "s", info.bits, info.format[1] == 'F' ? " float" : "",
               info.palette ? " palette" : "");
    }
    size_t np = (size_t)img.width * img.height;
    for (int c = 0; c < img.channels; c++) {
        const float *p = img.data + c * np;
        float lo = p[0], hi = p[0];
        double sum = 0;
        for (size_t i = 0; i < np; i++) {
            if (p[i] < lo) lo = p[i];
            if (p[i] > hi) hi = p[i];
            sum += p[i];
        }
        if (stats) {
            cJSON *o = cJSON_CreateObject();
            cJSON_AddStringToObject(o, "name", names[img.channels][c]);
            cJSON_AddNumberToObject(o, "min", lo);
            cJSON_AddNumberToObject(o, "max", hi);
            cJSON_AddNumberToObject(o, "mean", sum / np);
            cJSON_AddItemToArray(stats, o);
        } else if (!j) {
            printf("  %-6s min %.6g  max %.6g  mean %.6g\n", names[img.channels][c], lo, hi, sum / np);
        }
    }
    hd_image_free(&img);
    return 0;
}

/* Prints at most max bytes of s with control characters escaped, "..." when cut. */
static void print_escaped(const char *s, size_t max)
{
    size_t i = 0;
    for (; s[i] && i < max; i++) {
        unsigned char c = (unsigned char)s[i];
        if (c == '\n') printf("\\n");
        else if (c < 32 || c == 127) printf("\\x%02x", c);
        else putchar(c);
    }
    if (s[i]) printf("...");
}

static int info_safetensors(const char *path, int show, cJSON *j)
{
    hd_safetensors st;
    if (hd_safetensors_read(path, &st) != HD_OK) return 1;
    long long params = 0;
    for (int i = 0; i < st.count; i++) {
        long long n = 1;
        for (int d = 0; d < st.tensors[i].ndim; d++) n *= st.tensors[i].shape[d];
        params += n;
    }
    if (j) { /* every tensor, the metadata as strings */
        cJSON_AddStringToObject(j, "kind", "safetensors");
        cJSON_AddNumberToObject(j, "parameters", (double)params);
        cJSON *meta = cJSON_AddObjectToObject(j, "metadata");
        for (int i = 0; i < st.meta_count && meta; i++) cJSON_AddStringToObject(meta, st.meta_keys[i], st.meta_values[i]);
        cJSON *tensors = cJSON_AddArrayToObject(j, "tensors");
        for (int i = 0; i < st.count && tensors; i++) {
            cJSON *t = cJSON_CreateObject(), *shape = cJSON_CreateArray();
            cJSON_AddStringToObject(t, "name", st.tensors[i].name);
            for (int d = 0; d < st.tensors[i].ndim; d++) cJSON_AddItemToArray(shape, cJSON_CreateNumber((double)st.tensors[i].shape[d]));
            cJSON_AddItemToObject(t, "shape", shape);
            cJSON_AddItemToArray(tensors, t);
        }
        hd_safetensors_free(&st);
        return 0;
    }
    printf("%s: safetensors, %d tensor%s, %lld parameters (F32), %d metadata entr%s\n", path, st.count,
           st.count == 1 ? "" : "s", params, st.meta_count, st.meta_count == 1 ? "y" : "ies");
    for (int i = 0; i < st.meta_count; i++) {
        printf("  meta ");
        print_escaped(st.meta_keys[i], 40);
        printf(" = ");
        print_escaped(st.meta_values[i], 60);
        printf("\n");
    }
    for (int i = 0; i < st.count && i < show; i++) {
        printf("  ");
        print_escaped(st.tensors[i].name, 200); /* a name may hold any byte: never drive the terminal */
        printf(" [");
        for (int d = 0; d < st.tensors[i].ndim; d++)
            printf("%s%lld", d ? ", " : "", (long long)st.tensors[i].shape[d]);
        printf("]\n");
    }
    if (st.count > show) printf("  ... and %d more (--tensors N to list more)\n", st.count - show);
    hd_safetensors_free(&st);
    return 0;
}

static int info_light(const char *path, cJSON *j)
{
    float light[HD_SH_COEFFS];
    if (hd_light_read(path, light) != HD_OK) return 1;
    static const float dirs[5][3] = {{0, 0, 1}, {1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}};
    static const char *const dir_names[5] = {"viewer", "right", "left", "up", "down"};
    if (j) {
        cJSON_AddStringToObject(j, "kind", "light");
        cJSON_AddItemToObject(j, "light", cJSON_CreateFloatArray(light, HD_SH_COEFFS));
        cJSON *sh = cJSON_AddObjectToObject(j, "shading");
        for (int i = 0; i < 5 && sh; i++) cJSON_AddNumberToObject(sh, dir_names[i], hd_sh_shade(light, dirs[i]));
        return 0;
    }
    printf("%s: light file, 9 spherical-harmonics coefficients (DPR order)\n ", path);
    for (int k = 0; k < HD_SH_COEFFS; k++) printf(" %.6g", light[k]);
    printf("\n  shading toward");
    for (int i = 0; i < 5; i++) printf(" %s %.4f%s", dir_names[i], hd_sh_shade(light, dirs[i]), i < 4 ? "," : "");
    printf("\n");
    return 0;
}

int cmd_info(int argc, char **argv)
{
    int show = 10, json = 0;
    const cli_opt opts[] = {
        {"tensors", 0, CLI_OPT_INT, &show, "N", "list the first N tensors of a checkpoint (default 10; --json: all)"},
        CLI_OPT_JSON_ROW(json),
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const cli_cmd_spec spec = {
        "info", "[--tensors N] [--json] FILE...",
        "Reads each file with hdnet's checked readers and says what it is: an image (PNG, JPEG or\n"
        "PFM: size, channels, bit depth, min/max/mean per channel), a checkpoint (safetensors:\n"
        "tensor count, parameters, metadata, the first tensors with their shapes) or a light file\n"
        "(*.txt: the 9 coefficients and the shading they give five directions). A broken file is\n"
        "reported with the reason; the exit status is then 1 (the other files are still shown).",
        opts, 1, -1};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    if (show < 0) {
        free(pos);
        return cli_usage_error(&spec, "--tensors must be >= 0");
    }
    int failed = 0;
    cJSON *doc = json ? cJSON_CreateObject() : NULL, *files = doc ? cJSON_AddArrayToObject(doc, "files") : NULL;
    if (json && !files) {
        cJSON_Delete(doc);
        free(pos);
        fprintf(stderr, "hdnet info: out of memory\n");
        return CLI_EXIT_FAIL;
    }
    for (int i = 0; i < npos; i++) {
        int bad = 0;
        cJSON *j = NULL;
        if (files) {
            j = cJSON_CreateObject();
            cJSON_AddStringToObject(j, "file", pos[i]);
            cJSON_AddItemToArray(files, j);
        }
        switch (guess_kind(pos[i])) {
        case KIND_IMAGE: bad = info_image(pos[i], j); break;
        case KIND_SAFETENSORS: bad = info_safetensors(pos[i], show, j); break;
        case KIND_LIGHT: bad = info_light(pos[i], j); break;
        }
        fflush(stdout);
        if (bad) {
            failed = cli_report("info");
            if (j) cJSON_AddStringToObject(j, "error", hd_error());
        }
    }
    free(pos);
    if (doc) cJSON_AddNumberToObject(doc, "failed", failed ? 1 : 0);
    int rc = failed ? CLI_EXIT_FAIL : CLI_EXIT_OK;
    return doc ? cli_json_print("info", doc, rc) : rc;
}
