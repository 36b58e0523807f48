/* cmd_bench.c: `hdnet bench`: the engine's figures: the machine's SGEMM peak (measured here, the
 * yardstick for every share), each Common-Net convolution (forward, backward-data,
 * backward-weights), the whole Common-Net forward and forward+backward, peak memory; then the
 * HD-Net and alignment sections when linked (tools/bench.h). Best of --repeats runs each. */
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <cblas.h>
#include <omp.h>
#include "cli.h"
#include "bench.h"
#include "hdnet_tool.h"

CLI_COMMAND("bench", cmd_bench, "measure SGEMM peak, convolution and network speed, memory")

#define BENCH_CIN 32
#define BENCH_COUT 3

static float *bench_buf(size_t n, hd_rng *rng)
{
    float *x = hd_malloc((n ? n : 1) * sizeof(float));
    if (x)
        for (size_t i = 0; i < n; i++) x[i] = hd_rng_range(rng, -0.5f, 0.5f);
    return x;
}

/* Best seconds of `repeats` SGEMMs of n x n matrices: GFLOP/s = 2 n^3 / t. */
static double sgemm_peak(int n, int repeats)
{
    hd_rng rng;
    hd_rng_seed(&rng, 1, 1);
    size_t nn = (size_t)n * n;
    float *a = bench_buf(nn, &rng), *b = bench_buf(nn, &rng), *c = bench_buf(nn, &rng);
    double best = 1e30;
    if (!a || !b || !c) best = 0;
    for (int r = 0; r < repeats + 1 && a && b && c; r++) {
        double t = hd_seconds();
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, n, n, n, 1.0f, a, n, b, n, 0.0f, c, n);
        t = hd_seconds() - t;
        if (r > 0 && t < best) best = t; /* the first run warms up */
    }
    free(a), free(b), free(c);
    return best > 0 && best < 1e30 ? 2.0 * n * n * (double)n / best * 1e-9 : 0.0;
}

/* The conv layers of a Common-Net (cin -> cout, width w) at size S: name, C, OC, side. */
typedef struct layer_shape {
    const char *name;
    int C, OC, side;
} layer_shape;

static int unet_layers(int w, int S, layer_shape *l)
{
    static const char *names[HD_UNET_LAYERS] = {"enc0", "enc1", "enc2", "enc3", "enc4", "enc5",
                                                "enc6", "dec5a", "dec5b", "dec4a", "dec4b", "dec3a",
                                                "dec3b", "dec2a", "dec2b", "dec1a", "dec1b", "dec1c"};
    static const int lev[HD_UNET_LAYERS] = {0, 0, 1, 2, 3, 4, 5, 4, 4, 3, 3, 2, 2, 1, 1, 0, 0, 0};
    for (int k = 0; k < HD_UNET_LAYERS; k++) {
        int C = w, OC = w;
        if (k == 0) C = BENCH_CIN;
        else if (k == 7 || k == 8) C = 2 * w, OC = 2 * w;
        else if (k >= 9 && k <= 14) C = (k % 2) ? 3 * w : 2 * w, OC = 2 * w;
        else if (k == 15) C = 2 * w + BENCH_CIN, OC = 64;
        else if (k == 16) C = 64, OC = 32;
        else if (k == 17) C = 32, OC = BENCH_COUT;
        l[k] = (layer_shape){names[k], C, OC, S >> lev[k]};
    }
    return HD_UNET_LAYERS;
}

typedef struct conv_times {
    double fwd, bwd_data, bwd_weights; /* best seconds */
    const char *kernel;                /* hd_conv3x3_kernel of the plan */
} conv_times;

/* Times one convolution shape (leaky ReLU fused, as in the net). */
static hd_status time_conv(int B, int C, int OC, int side, hd_act act, hd_conv_path path, int repeats, conv_times *t)
{
    /* the blocked layout, as inside the Common-Net, where oneDNN is there */
    hd_conv3x3 *p;
    int blocked = path == HD_CONV_AUTO && hd_conv3x3_plan_nc16(&p, B, C, side, side, OC, 1, act, 0.1f) == HD_OK;
    hd_status st = blocked ? HD_OK : hd_conv3x3_plan(&p, B, C, side, side, OC, 1, act, 0.1f, path);
    if (st != HD_OK) return st;
    hd_clear_error();
    t->kernel = hd_conv3x3_kernel(p);
    hd_rng rng;
    hd_rng_seed(&rng, 2, 1);
    int Cp = blocked ? hd_nc16_channels(C) : C, OCp = blocked ? hd_nc16_channels(OC) : OC;
    size_t nx = (size_t)B * Cp * side * side, no = (size_t)B * OCp * side * side, nw = (size_t)OC * C * 9;
    float *x = bench_buf(nx, &rng), *out = bench_buf(no, &rng), *dout = bench_buf(no, &rng);
    float *w = bench_buf(nw, &rng), *b = bench_buf((size_t)OC, &rng), *dx = bench_buf(nx, &rng);
    float *dw = bench_buf(nw, &rng), *db = bench_buf((size_t)OC, &rng);
    if (!x || !out || !dout || !w || !b || !dx || !dw || !db) st = HD_ERR_NOMEM;
    t->fwd = t->bwd_data = t->bwd_weights = 1e30;
    for (int r = 0; r < repeats + 1 && st == HD_OK; r++) {
        double t0 = hd_seconds();
        hd_conv3x3_forward(p, out, x, w, b);
        double t1 = hd_seconds();
        hd_conv3x3_backward(p, dx, NULL, NULL, dout, out, x, w);
        double t2 = hd_seconds();
        hd_conv3x3_backward(p, NULL, dw, db, dout, out, x, w);
        double t3 = hd_seconds();
        if (r == 0) continue; /* warm-up */
        if (t1 - t0 < t->fwd) t->fwd = t1 - t0;
        if (t2 - t1 < t->bwd_data) t->bwd_data = t2 - t1;
        if (t3 - t2 < t->bwd_weights) t->bwd_weights = t3 - t2;
    }
    free(x), free(out), free(dout), free(w), free(b), free(dx), free(dw), free(db);
    hd_conv3x3_free(p);
    return st;
}

typedef struct net_times {
    double fwd, fwd_bwd; /* best seconds */
    double layer[2 * HD_UNET_LAYERS]; /* per convolution inside the net, forward then backward (best) */
    double rest_fwd, rest_bwd;        /* the rest of a profiled forward, backward (best) */
    size_t arena;
} net_times;

static hd_status time_unet(const bench_args *a, net_times *t)
{
    hd_unet *net;
    hd_status st = hd_unet_create(&net, BENCH_CIN, BENCH_COUT, a->width, a->batch, a->size, a->size, HD_CONV_AUTO);
    if (st != HD_OK) return st;
    int np = 0;
    size_t total = 0;
    hd_unet_params("net", BENCH_CIN, BENCH_COUT, a->width, NULL, &np, &total);
    hd_rng rng;
    hd_rng_seed(&rng, 3, 1);
    size_t nx = (size_t)a->batch * BENCH_CIN * a->size * a->size, no = (size_t)a->batch * BENCH_COUT * a->size * a->size;
    float *params = bench_buf(total, &rng), *grads = hd_calloc(total, sizeof(float));
    float *x = bench_buf(nx, &rng), *out = bench_buf(no, &rng), *dout = bench_buf(no, &rng);
    if (!params || !grads || !x || !out || !dout) st = HD_ERR_NOMEM;
    for (size_t i = 0; params && i < total; i++) params[i] *= 0.1f;
    t->fwd = t->fwd_bwd = 1e30;
    if (st == HD_OK) hd_unet_bind(net, params, grads);
    for (int r = 0; r < a->repeats + 1 && st == HD_OK; r++) {
        double t0 = hd_seconds();
        hd_unet_forward(net, x, out);
        double t1 = hd_seconds();
        hd_unet_forward(net, x, out);
        hd_unet_backward(net, dout, NULL, NULL);
        double t2 = hd_seconds();
        if (r == 0) continue;
        if (t1 - t0 < t->fwd) t->fwd = t1 - t0;
        if (t2 - t1 < t->fwd_bwd) t->fwd_bwd = t2 - t1;
    }
    /* per layer inside the net: profiled runs of their own (the timers' calls stay out of the
     * figures above) */
    double prof[2 * HD_UNET_LAYERS];
    for (int k = 0; k < 2 * HD_UNET_LAYERS; k++) t->layer[k] = 1e30;
    t->rest_fwd = t->rest_bwd = 1e30;
    hd_unet_profile(net, prof);
    for (int r = 0; r < a->repeats && st == HD_OK; r++) {
        memset(prof, 0, sizeof prof);
        double t0 = hd_seconds();
        hd_unet_forward(net, x, out);
        double t1 = hd_seconds();
        hd_unet_backward(net, dout, NULL, NULL);
        double t2 = hd_seconds(), rf = t1 - t0, rb = t2 - t1;
        for (int k = 0; k < HD_UNET_LAYERS; k++) rf -= prof[k], rb -= prof[HD_UNET_LAYERS + k];
        if (rf < t->rest_fwd) t->rest_fwd = rf;
        if (rb < t->rest_bwd) t->rest_bwd = rb;
        for (int k = 0; k < 2 * HD_UNET_LAYERS; k++)
            if (prof[k] < t->layer[k]) t->layer[k] = prof[k];
    }
    hd_unet_profile(net, NULL);
    t->arena = st == HD_OK ? hd_unet_memory(net) : 0;
    free(params), free(grads), free(x), free(out), free(dout);
    hd_unet_free(net);
    return st;
}

int cmd_bench(int argc, char **argv)
{
    bench_args a = {.size = 256, .batch = 1, .threads = 2, .width = 48, .json = 0, .repeats = 5, .out = stdout};
    int layers = 1, portable = 1, photos = 1, photos_only = 0, no_photos = 0, profile = 0;
    const char *precision = NULL;
    const cli_opt opts[] = {
        {"size", 0, CLI_OPT_INT, &a.size, "S", "image side, a multiple of 32 (default 256)"},
        {"batch", 0, CLI_OPT_INT, &a.batch, "B", "images per forward (default 1)"},
        {"threads", 'j', CLI_OPT_INT, &a.threads, "T", "OpenMP and OpenBLAS threads (default 2)"},
        {"width", 0, CLI_OPT_INT, &a.width, "W", "Common-Net width (default 48, the paper's)"},
        {"repeats", 0, CLI_OPT_INT, &a.repeats, "R", "timed runs per figure after one warm-up; the best counts (default 5)"},
        {"json", 0, CLI_OPT_FLAG, &a.json, NULL, "print one JSON object instead of tables"},
        {"photos-only", 0, CLI_OPT_FLAG, &photos_only, NULL, "only the photos-per-second section (1024 x 1024 portraits)"},
        {"no-photos", 0, CLI_OPT_FLAG, &no_photos, NULL, "skip the photos-per-second section"},
        {"profile", 0, CLI_OPT_FLAG, &profile, NULL, "only a training step at --size, --width, --batch pairs, split into phases"},
        {"data", 0, CLI_OPT_STRING, &a.data, "DIR", "with --profile: also time loading a batch from this training set"},
        {"precision", 0, CLI_OPT_STRING, &precision, "P", "convolutions in fp32, bf16 or auto (bf16 where the CPU has it; default: HD_CONV_PRECISION, else fp32)"},
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const cli_cmd_spec spec = {
        "bench", "[--size S] [--batch B] [-j T] [--width W] [--repeats R] [--json] [--photos-only | --no-photos]\n"
                 "       [--precision fp32|bf16|auto] [--profile [--data DIR]]",
        "Measures the machine's SGEMM peak (OpenBLAS, 2048^3), then every 3x3 convolution of a\n"
        "Common-Net (cin 32, cout 3) forward, backward-data and backward-weights, the whole Common-Net\n"
        "forward and forward+backward, and peak memory; then the HD-Net and alignment sections, and\n"
        "photos per second end to end (decode, detect, align, model, blend, encode) on 1024 x 1024\n"
        "portraits with the shipped model.\n"
        "GFLOP/s count direct-convolution FLOPs (2 x multiply-adds) over the best time.\n"
        "--profile runs a training step only (as `hdnet train`: forward, the losses with their fits,\n"
        "backward, the discriminator, both Adams): its median time and iterations per hour, then a\n"
        "profiled run split into phases (wall, CPU, idle cores) and every convolution by shape.",
        opts, 0, 0};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    free(pos);
    if (a.size < 32 || a.size % 32 || a.size > 4096)
        return cli_usage_error(&spec, "--size must be a multiple of 32 in 32..4096, got %d", a.size);
    if (a.batch < 1 || a.batch > 256) return cli_usage_error(&spec, "--batch must be in 1..256, got %d", a.batch);
    if (a.threads < 1 || a.threads > 1024) return cli_usage_error(&spec, "--threads must be in 1..1024, got %d", a.threads);
    if (a.width < 1 || a.width > 1024) return cli_usage_error(&spec, "--width must be in 1..1024, got %d", a.width);
    if (a.repeats < 1 || a.repeats > 1000) return cli_usage_error(&spec, "--repeats must be in 1..1000, got %d", a.repeats);
    if (photos_only && no_photos) return cli_usage_error(&spec, "--photos-only and --no-photos exclude each other");
    photos = !no_photos;
    if (precision) {
        hd_precision p;
        if (hd_precision_parse(precision, "--precision", &p) != HD_OK) return cli_usage_error(&spec, "%s", hd_error());
        hd_conv_set_precision(p);
    }
    if (a.data && !profile) return cli_usage_error(&spec, "--data goes with --profile");
    omp_set_num_threads(a.threads);
    openblas_set_num_threads(a.threads);
    FILE *o = stdout;
    int J = a.json;
    if (profile) {
        a.out = o;
        fprintf(o, "hdnet bench --profile: threads %d, OMP_WAIT_POLICY %s\n", a.threads,
                getenv("OMP_WAIT_POLICY") ? getenv("OMP_WAIT_POLICY") : "unset");
        bench_print_engine(o, 0);
        return bench_profile && bench_profile(&a) == 0 ? CLI_EXIT_OK : CLI_EXIT_FAIL;
    }
    if (photos_only) {
        a.out = o;
        if (J) fprintf(o, "{\n\"threads\": %d,\n", a.threads);
        else fprintf(o, "hdnet bench: threads %d, median of %d\n", a.threads, a.repeats);
        int prc = bench_photos ? bench_photos(&a) : 1;
        if (J) fprintf(o, "\"ok\": %s\n}\n", prc ? "false" : "true");
        return prc ? CLI_EXIT_FAIL : CLI_EXIT_OK;
    }

    /* the OpenMP wait policy decides how fast a waiting thread joins the next parallel region
     * (a helper session may set passive for a shared machine): reported with the figures */
    const char *wait = getenv("OMP_WAIT_POLICY");
    if (!wait || !*wait) wait = "unset";
    if (J) fprintf(o, "{\n\"omp_wait_policy\": \"%s\",\n", wait);
    else fprintf(o, "hdnet bench: size %d, batch %d, threads %d, width %d, best of %d, OMP_WAIT_POLICY %s\n", a.size,
                 a.batch, a.threads, a.width, a.repeats, wait);
    bench_print_engine(o, J);
    fflush(o);
    a.sgemm_peak_gflops = sgemm_peak(2048, a.repeats < 3 ? a.repeats : 3);
    double peak = a.sgemm_peak_gflops;
    if (J) fprintf(o, "\"size\": %d,\n\"batch\": %d,\n\"threads\": %d,\n\"width\": %d,\n\"sgemm_peak_gflops\": %.1f,\n",
                   a.size, a.batch, a.threads, a.width, peak);
    else fprintf(o, "SGEMM peak (OpenBLAS, 2048^3): %.1f GFLOP/s\n", peak);

    layer_shape ls[HD_UNET_LAYERS];
    int nl = unet_layers(a.width, a.size, ls);
    if (layers) {
        if (J) fprintf(o, "\"layers\": [\n");
        else fprintf(o, "\nCommon-Net convolutions (oneDNN in its blocked layout when built with it; GFLOP/s, share of SGEMM peak)\n"
                        "%-6s %5s %5s %5s %-8s | %9s %7s %5s | %9s %7s | %9s %7s\n",
                     "layer", "C", "OC", "side", "kernel", "fwd ms", "GFLOP/s", "peak", "bwd-d ms", "GFLOP/s", "bwd-w ms", "GFLOP/s");
        for (int k = 0; k < nl; k++) {
            conv_times t;
            if (time_conv(a.batch, ls[k].C, ls[k].OC, ls[k].side, k == nl - 1 ? HD_ACT_NONE : HD_ACT_LRELU,
                          HD_CONV_AUTO, a.repeats, &t) != HD_OK)
                return cli_report("bench");
            double fl = 2.0 * 9 * ls[k].C * ls[k].OC * (double)ls[k].side * ls[k].side * a.batch * 1e-9;
            if (J)
                fprintf(o, "  {\"name\": \"%s\", \"C\": %d, \"OC\": %d, \"side\": %d, \"kernel\": \"%s\", \"fwd_s\": %.6f, \"bwd_data_s\": %.6f, \"bwd_weights_s\": %.6f, \"fwd_gflops\": %.1f, \"bwd_data_gflops\": %.1f, \"bwd_weights_gflops\": %.1f}%s\n",
                        ls[k].name, ls[k].C, ls[k].OC, ls[k].side, t.kernel, t.fwd, t.bwd_data, t.bwd_weights, fl / t.fwd,
                        fl / t.bwd_data, fl / t.bwd_weights, k == nl - 1 ? "" : ",");
            else
                fprintf(o, "%-6s %5d %5d %5d %-8s | %9.3f %7.1f %4.0f%% | %9.3f %7.1f | %9.3f %7.1f\n", ls[k].name,
                        ls[k].C, ls[k].OC, ls[k].side, t.kernel, t.fwd * 1e3, fl / t.fwd, peak > 0 ? 100 * fl / t.fwd / peak : 0.0,
                        t.bwd_data * 1e3, fl / t.bwd_data, t.bwd_weights * 1e3, fl / t.bwd_weights);
            fflush(o);
        }
        if (J) fprintf(o, "],\n");
    }
    if (portable) {
        /* the portable path on the paper's 48 -> 48 layer at the full size, for comparison */
        conv_times t;
        if (time_conv(a.batch, a.width, a.width, a.size, HD_ACT_LRELU, HD_CONV_PORTABLE, a.repeats < 3 ? a.repeats : 3, &t) != HD_OK)
            return cli_report("bench");
        double fl = 2.0 * 9 * a.width * a.width * (double)a.size * a.size * a.batch * 1e-9;
        if (J) fprintf(o, "\"portable_conv_fwd_gflops\": %.1f,\n\"portable_conv_bwd_data_gflops\": %.1f,\n\"portable_conv_bwd_weights_gflops\": %.1f,\n",
                       fl / t.fwd, fl / t.bwd_data, fl / t.bwd_weights);
        else fprintf(o, "portable path (im2col + sgemm), %d->%d at %d: fwd %.1f, bwd-data %.1f, bwd-weights %.1f GFLOP/s\n",
                     a.width, a.width, a.size, fl / t.fwd, fl / t.bwd_data, fl / t.bwd_weights);
    }

    net_times nt;
    if (time_unet(&a, &nt) != HD_OK) return cli_report("bench");
    double gf = 2.0 * hd_unet_macs(BENCH_CIN, BENCH_COUT, a.width, a.size, a.size) * a.batch * 1e-9;
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    if (J)
        fprintf(o, "\"commonnet_gflop\": %.3f,\n\"commonnet_fwd_s\": %.6f,\n\"commonnet_fwd_gflops\": %.1f,\n"
                   "\"commonnet_fwd_bwd_s\": %.6f,\n\"commonnet_fwd_bwd_ratio\": %.3f,\n\"commonnet_arena_bytes\": %zu,\n"
                   "\"peak_rss_bytes\": %ld,\n",
                gf, nt.fwd, gf / nt.fwd, nt.fwd_bwd, nt.fwd_bwd / nt.fwd, nt.arena, ru.ru_maxrss * 1024L);
    else
        fprintf(o, "\nCommon-Net (cin %d, cout %d, width %d) at %dx%d, batch %d: %.2f GFLOP per forward\n"
                   "  forward          %8.1f ms  %7.1f GFLOP/s  (%.0f%% of SGEMM peak)\n"
                   "  forward+backward %8.1f ms  %7.1f GFLOP/s  (%.2fx the forward)\n"
                   "  activation arena %.1f MB; peak resident memory so far %.1f MB\n",
                BENCH_CIN, BENCH_COUT, a.width, a.size, a.size, a.batch, gf, nt.fwd * 1e3, gf / nt.fwd,
                peak > 0 ? 100 * gf / nt.fwd / peak : 0.0, nt.fwd_bwd * 1e3, 3 * gf / nt.fwd_bwd,
                nt.fwd_bwd / nt.fwd, nt.arena / 1048576.0, ru.ru_maxrss / 1024.0);
    /* the convolutions inside the net, where the 2-thread losses of a shared machine show */
    double sf = 0.0, sb = 0.0;
    for (int k = 0; k < nl; k++) sf += nt.layer[k], sb += nt.layer[HD_UNET_LAYERS + k];
    if (J) {
        fprintf(o, "\"commonnet_layers\": [\n");
        for (int k = 0; k < nl; k++)
            fprintf(o, "  {\"name\": \"%s\", \"fwd_s\": %.6f, \"bwd_s\": %.6f}%s\n", ls[k].name, nt.layer[k],
                    nt.layer[HD_UNET_LAYERS + k], k == nl - 1 ? "" : ",");
        fprintf(o, "],\n\"commonnet_rest_fwd_s\": %.6f,\n\"commonnet_rest_bwd_s\": %.6f,\n", nt.rest_fwd, nt.rest_bwd);
    } else {
        fprintf(o, "  inside the net, per convolution (best of %d; backward = activation gradient, input and weight\n"
                   "  gradients), ms:\n", a.repeats);
        for (int k = 0; k < nl; k++)
            fprintf(o, "    %-6s fwd %8.3f  bwd %8.3f%s", ls[k].name, nt.layer[k] * 1e3, nt.layer[HD_UNET_LAYERS + k] * 1e3,
                    k % 2 ? "\n" : "   ");
        fprintf(o, "%s    convolutions fwd %.1f ms, bwd %.1f ms; the rest (pooling, upsampling, concatenation,\n"
                   "    conversions) %.1f ms forward, %.1f ms backward\n", nl % 2 ? "\n" : "", sf * 1e3, sb * 1e3,
                nt.rest_fwd * 1e3, nt.rest_bwd * 1e3);
    }
    fflush(o);
    a.out = o;
    int rc = 0;
    if (bench_hdnet && bench_hdnet(&a) != 0) rc = 1;
    if (bench_align && bench_align(&a) != 0) rc = 1;
    if (photos && bench_photos && bench_photos(&a) != 0) rc = 1;
    if (J) fprintf(o, "\"ok\": %s\n}\n", rc ? "false" : "true");
    return rc ? CLI_EXIT_FAIL : CLI_EXIT_OK;
}
