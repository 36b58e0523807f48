/* cmd_synth.c: `hdnet synth`: write a set of paired synthetic faces with full ground truth in the
 * SPEC section 5 layout (docs/synthetic-data.md describes the model of faces and lights). */
#include <stdlib.h>
#include <string.h>
#include "cli.h"
#include "hdnet_tool.h"

CLI_COMMAND("synth", cmd_synth, "generate paired synthetic faces with ground truth (albedo, normals, shading, light)")

/* The help text below quotes these. */
_Static_assert((int)HD_SYNTH_COARSE_ERROR_DEFAULT == 20 && (int)HD_SYNTH_COARSE_ERROR_MAX == 40,
               "update the --coarse-error help text");

static void on_progress(void *ctx, long done, long total)
{
    cli_progress *p = ctx;
    (void)total;
    if (done < p->total) cli_progress_update(p, done, NULL);
}

int cmd_synth(int argc, char **argv)
{
    int subjects = 0, per_subject = 0, size = 256, seed = 1, threads = 0;
    float jitter = 0.0f, coarse_error = HD_SYNTH_COARSE_ERROR_DEFAULT, coarse_pose = 0.0f;
    const char *png = "store", *effects = "all";
    float camera = 0.0f;
    const cli_opt opts[] = {
        {"subjects", 0, CLI_OPT_INT, &subjects, "N", "number of subjects (identities); required"},
        {"per-subject", 0, CLI_OPT_INT, &per_subject, "K", "images per subject, each with its own light (and pose); required"},
        {"size", 0, CLI_OPT_INT, &size, "S", "side of the aligned texture in pixels (default 256; 16..4096)"},
        {"seed", 0, CLI_OPT_INT, &seed, "X", "random seed; the same seed gives the same set (default 1)"},
        {"pose-jitter", 0, CLI_OPT_FLOAT, &jitter, "DEG", "maximum yaw, pitch and roll of the head in degrees (default 0: frontal)"},
        {"coarse-error", 0, CLI_OPT_FLOAT, &coarse_error, "DEG",
         "size of the coarse normals' fit error, 0..40 (default 20: about 23 degrees off; 0: exact pose)"},
        {"coarse-pose-error", 0, CLI_OPT_FLOAT, &coarse_pose, "DEG",
         "the fit's pose error alone, standard deviation per angle, (0, 40] (default: half of --coarse-error)"},
        {"png", 0, CLI_OPT_STRING, &png, "fast|store",
         "PNG compression: store (default: uncompressed, 1.6 MB an image at 256, ~110 images/s a thread) "
         "or fast (zlib: half the disk, ~65 images/s a thread); the pixels are the same"},
        {"camera", 0, CLI_OPT_FLOAT, &camera, "P",
         "probability of each camera effect per image, 0..1 (default 0: none); YYYY.camera.txt lists those applied"},
        {"camera-effects", 0, CLI_OPT_STRING, &effects, "LIST",
         "comma-separated: light-colour, blur, noise, white-balance, jpeg, or all (default all)"},
        {"threads", 'j', CLI_OPT_INT, &threads, "N", "threads (default 0: all cores); the output does not depend on it"},
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const cli_cmd_spec spec = {
        "synth", "OUT --subjects N --per-subject K [--size S] [--seed X] [--pose-jitter DEG] [--coarse-error DEG] [--coarse-pose-error DEG] [--png fast|store] [--camera P] [-j N]",
        "Renders synthetic faces straight into the aligned texture space (the UV layout of the\n"
        "canonical face mesh) and writes, per image, into OUT/subject_XXXX/: YYYY.png (the face),\n"
        "YYYY.mask.png, YYYY.normal.png (coarse normals, a modelled 3DMM fit: the canonical mesh\n"
        "with a random pose and shape error, see --coarse-error), and the ground truth\n"
        "YYYY.albedo.png, YYYY.normal_gt.png, YYYY.shading.png (16 bit, shading/2),\n"
        "YYYY.shading.pfm (exact) and YYYY.light.txt; plus OUT/preview.sheet.png, a sheet of the first\n"
        "subjects (albedo, normals, shading, images). A subject keeps its shape and albedo across\n"
        "its images; light (and pose) change per image. The coarse normals' error is zero-mean over\n"
        "images: --coarse-error DEG tilts them by DEG RMS with a smooth field, turns the fit's pose\n"
        "by DEG/2 (standard deviation per angle) and deforms its shape (docs/synthetic-data.md).",
        opts, 1, 1};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    const char *out = pos[0];
    free(pos);
    if (subjects < 1) return cli_usage_error(&spec, "--subjects N (N >= 1) is required");
    if (per_subject < 1) return cli_usage_error(&spec, "--per-subject K (K >= 1) is required");
    if (size < 16 || size > 4096) return cli_usage_error(&spec, "--size %d outside [16, 4096]", size);
    if (!(jitter >= 0.0f && jitter <= 45.0f)) return cli_usage_error(&spec, "--pose-jitter %g outside [0, 45]", jitter);
    if (!(coarse_error >= 0.0f && coarse_error <= HD_SYNTH_COARSE_ERROR_MAX))
        return cli_usage_error(&spec, "--coarse-error %g outside [0, %g]", coarse_error, HD_SYNTH_COARSE_ERROR_MAX);
    if (!(coarse_pose >= 0.0f && coarse_pose <= HD_SYNTH_COARSE_ERROR_MAX))
        return cli_usage_error(&spec, "--coarse-pose-error %g outside (0, %g]", coarse_pose, HD_SYNTH_COARSE_ERROR_MAX);
    if (strcmp(png, "fast") != 0 && strcmp(png, "store") != 0)
        return cli_usage_error(&spec, "--png %s is neither fast nor store", png);
    if (seed < 0) return cli_usage_error(&spec, "--seed %d must be >= 0", seed);
    if ((long)subjects * per_subject > 100000000L) return cli_usage_error(&spec, "too many images (%d x %d)", subjects, per_subject);
    if ((code = cli_opts_common(&spec, threads, 1.0f))) return code;
    /* Thousands of pictures: each still appears whole (rename), but is not fsynced one by one. */
    hd_set_durable_writes(0);
    if (!(camera >= 0.0f && camera <= 1.0f)) return cli_usage_error(&spec, "--camera %g outside [0, 1]", camera);
    unsigned flags = 0;
    static const struct { const char *name; unsigned flag; } names[] = {
        {"all", HD_SYNTH_CAMERA_ALL}, {"light-colour", HD_SYNTH_CAMERA_LIGHT_COLOUR}, {"blur", HD_SYNTH_CAMERA_BLUR},
        {"noise", HD_SYNTH_CAMERA_NOISE}, {"white-balance", HD_SYNTH_CAMERA_WHITE_BALANCE}, {"jpeg", HD_SYNTH_CAMERA_JPEG}};
    for (const char *p = effects; *p;) {
        size_t n = strcspn(p, ",");
        unsigned f = 0;
        for (size_t k = 0; k < sizeof names / sizeof names[0]; k++)
            if (strlen(names[k].name) == n && strncmp(p, names[k].name, n) == 0) f = names[k].flag;
        if (!f) return cli_usage_error(&spec, "--camera-effects: unknown effect '%.*s'", (int)n, p);
        flags |= f;
        p += n + (p[n] == ',');
    }
    hd_synth_options o = {subjects, per_subject, size, (uint64_t)seed, jitter, coarse_error, strcmp(png, "store") == 0,
                          {camera, flags}, coarse_pose};
    cli_progress p;
    cli_progress_start(&p, "synth", (long)subjects * per_subject);
    if (hd_synth_write_set(out, &o, on_progress, &p) != HD_OK) return cli_report("synth");
    cli_progress_finish(&p, (long)subjects * per_subject, NULL);
    printf("wrote %ld images of %d subjects into %s\n", (long)subjects * per_subject, subjects, out);
    return CLI_EXIT_OK;
}
