/* bench_profile.c: `hdnet bench --profile`: where a training step goes. Runs the trainer (as
 * `hdnet train` does: forward, the losses with their targets and fits, backward, the
 * discriminator's update, both Adams) on a synthetic batch at --size, --width and --batch pairs,
 * first unprofiled (the step's time and iterations per hour), then with the profiler on
 * (core.h, hd_prof_*): the phases as a tree with wall and CPU time per step and the cores' idle
 * time (threads x wall - CPU), and every convolution by shape (forward, its activation's
 * backward, backward-data, backward-weights) and the instance norms. With --data DIR, loading
 * a batch from that training set is timed too (the loader's work, which a run overlaps with
 * the step). Also the engine line every section shares: ISA, convolution path, precision. */
#include <stdlib.h>
#include <string.h>
#include "bench.h"
#include "hdnet_tool.h"

void bench_print_engine(FILE *o, int json)
{
    const char *isa = hd_conv_isa();
    int dnnl = strcmp(isa, "none") != 0;
    const char *prec = hd_conv_precision() == HD_PRECISION_BF16 ? "bf16" : "fp32";
    if (json)
        fprintf(o, "\"isa\": \"%s\",\n\"conv_path\": \"%s\",\n\"precision\": \"%s\",\n\"bf16_available\": %s,\n", isa,
                dnnl ? "onednn" : "portable", prec, hd_conv_bf16_available() ? "true" : "false");
    else
        fprintf(o, "engine: ISA %s, convolutions %s, precision %s (bf16 %s on this CPU)\n", isa,
                dnnl ? "oneDNN (blocked nChw16c layout in the Common-Nets, Winograd where FP32 pays)"
                     : "portable (im2col + OpenBLAS)",
                prec, hd_conv_bf16_available() ? "available" : "not available");
}

/* Phase names of the tree, indented by depth. */
static void print_phase(FILE *o, const hd_prof_entry *e, double per, double step, int threads)
{
    char label[64];
    snprintf(label, sizeof label, "%*s%s", 2 * e->depth, "", e->name);
    double w = e->wall * per, c = e->cpu * per, idle = threads * w - c;
    fprintf(o, "  %-34s %9.2f %5.1f%% %9.2f %5.2f %8.2f", label, w * 1e3, step > 0 ? 100 * w / step : 0.0, c * 1e3,
            w > 0 ? c / w : 0.0, (idle > 0 ? idle : 0.0) * 1e3);
    if (e->child_wall > 0) fprintf(o, "   (self %.2f)", (e->wall - e->child_wall) * per * 1e3);
    fprintf(o, "\n");
}

/* The ops of one name, by shape, and their sum; returns the sum (seconds per step). */
static double print_ops(FILE *o, const hd_prof_entry *t, int n, const char *name, double per, int conv)
{
    double sum = 0.0;
    for (int i = 0; i < n; i++) {
        if (t[i].parent != -2 || strcmp(t[i].name, name)) continue;
        sum += t[i].wall * per;
        if (conv)
            fprintf(o, "    %-22s %4d -> %-4d %4d px s%d  %8.2f ms  %5.2f cores  %ld calls\n", name, t[i].C, t[i].OC,
                    t[i].H, t[i].stride, t[i].wall * per * 1e3, t[i].wall > 0 ? t[i].cpu / t[i].wall : 0.0,
                    (long)(t[i].calls * per + 0.5));
        else
            fprintf(o, "    %-22s %4d ch %7d px    %8.2f ms  %5.2f cores  %ld calls\n", name, t[i].C, t[i].H,
                    t[i].wall * per * 1e3, t[i].wall > 0 ? t[i].cpu / t[i].wall : 0.0, (long)(t[i].calls * per + 0.5));
    }
    fprintf(o, "    %-22s total %8.2f ms per step\n", name, sum * 1e3);
    return sum;
}

/* Seconds to load one batch of the set at dir (the loader's work, in the foreground), median of
 * `repeats`; 0 and a reason on failure. */
static double time_loading(const char *dir, int size, int pairs, int repeats, hd_status *st)
{
    hd_dataset ds = {0};
    hd_pair_source src = {0};
    hd_pair_batch b = {0};
    hd_loader ld = {0};
    double *v = calloc((size_t)repeats, sizeof *v), med = 0.0;
    int skipped = 0, first = -1;
    *st = v ? HD_OK : HD_ERR_NOMEM;
    if (*st == HD_OK) *st = hd_dataset_scan(dir, &ds, NULL);
    if (*st == HD_OK) *st = hd_pair_source_init(&src, &ds, 1, 0, &skipped, &first);
    if (*st == HD_OK) *st = hd_pair_batch_alloc(&b, pairs, size);
    src.size = size;
    ld.src = &src;
    ld.batch = &b;
    for (int r = 0; r < repeats && *st == HD_OK; r++) {
        double t0 = hd_seconds();
        hd_loader_start(&ld, r);
        *st = hd_loader_wait(&ld, NULL);
        v[r] = hd_seconds() - t0;
    }
    if (*st == HD_OK) med = bench_median(v, repeats);
    hd_loader_stop(&ld);
    hd_pair_batch_free(&b);
    hd_pair_source_free(&src);
    hd_dataset_free(&ds);
    free(v);
    return med;
}

int bench_profile(const bench_args *a)
{
    FILE *o = a->out ? a->out : stdout;
    hd_net_config cfg = {a->width, a->size};
    int pairs = a->batch, repeats = a->repeats;
    hd_trainer t;
    hd_step_result res;
    double *steps = calloc((size_t)repeats, sizeof *steps);
    if (!steps || hd_trainer_create(&t, &cfg, pairs, 0, 1) != HD_OK) {
        fprintf(stderr, "hdnet bench: profile: %s\n", steps ? hd_error() : "out of memory");
        free(steps);
        return 1;
    }
    bench_fill_batch(&t.batch);
    hd_status st = hd_trainer_step(&t, &res, NULL); /* warm-up: first touches of memory, oneDNN's JIT */
    for (int r = 0; r < repeats && st == HD_OK; r++) {
        double t0 = hd_seconds();
        st = hd_trainer_step(&t, &res, NULL);
        steps[r] = hd_seconds() - t0;
    }
    double step = st == HD_OK ? bench_median(steps, repeats) : 0.0, lo = steps[0], hi = steps[repeats - 1];
    /* profiled steps: the table sums them; per = 1 / steps */
    hd_prof_mark m0 = {0, 0};
    if (st == HD_OK) {
        hd_prof_enable(1);
        m0 = hd_prof_now();
        for (int r = 0; r < repeats && st == HD_OK; r++) {
            hd_prof_begin("step");
            st = hd_trainer_step(&t, &res, NULL);
            hd_prof_end();
        }
    }
    hd_prof_mark m1 = hd_prof_now();
    hd_prof_enable(0);
    hd_trainer_free(&t);
    free(steps);
    if (st != HD_OK) {
        fprintf(stderr, "hdnet bench: profile: %s\n", hd_error());
        return 1;
    }
    double per = 1.0 / repeats, pstep = (m1.wall - m0.wall) * per, pcpu = (m1.cpu - m0.cpu) * per;
    const hd_prof_entry *tab;
    int n = hd_prof_table(&tab);
    if (n < 0) n = 0;
    int T = a->threads;

    fprintf(o, "\nTraining step profile: %dx%d, width %d, batch %d pairs (micro-batch %d), %d threads, %d steps\n",
            a->size, a->size, a->width, pairs, pairs, T, repeats);
    fprintf(o, "  step (unprofiled)  median %.1f ms, min %.1f, max %.1f: %.0f iterations per hour, %.1f ms per pair\n",
            step * 1e3, lo * 1e3, hi * 1e3, step > 0 ? 3600.0 / step : 0.0, step * 1e3 / pairs);
    fprintf(o, "  step (profiled)    %.1f ms wall, %.1f ms CPU (%.2f cores busy; idle %.1f ms of %d cores x wall)\n",
            pstep * 1e3, pcpu * 1e3, pstep > 0 ? pcpu / pstep : 0.0, (T * pstep - pcpu) * 1e3, T);
    fprintf(o, "\n  %-34s %9s %6s %9s %5s %8s\n", "phase (ms per step)", "wall", "share", "CPU", "cores", "idle");
    double step_wall = 0.0;
    for (int i = 0; i < n; i++)
        if (tab[i].parent == -1 && strcmp(tab[i].name, "step") == 0) step_wall = tab[i].wall * per;
    /* the tree in depth-first order: children follow their parent */
    int *done = calloc((size_t)n, sizeof *done), *stack = calloc((size_t)n + 1, sizeof *stack);
    if (!done || !stack) {
        free(done), free(stack);
        return 1;
    }
    for (int root = 0; root < n; root++) {
        if (tab[root].parent != -1 || done[root]) continue;
        int sp = 0;
        stack[sp++] = root;
        while (sp) {
            int k = stack[--sp];
            done[k] = 1;
            print_phase(o, &tab[k], per, step_wall, T);
            for (int c = n - 1; c >= 0; c--)
                if (tab[c].parent == k && !done[c]) stack[sp++] = c;
        }
    }
    free(done), free(stack);
    fprintf(o, "\n  convolutions and normalisations by shape (ms per step; cores = CPU / wall):\n");
    double cf = print_ops(o, tab, n, "conv forward", per, 1);
    double ca = print_ops(o, tab, n, "conv act backward", per, 1);
    double cd = print_ops(o, tab, n, "conv backward-data", per, 1);
    double cw = print_ops(o, tab, n, "conv backward-weights", per, 1);
    double nf = print_ops(o, tab, n, "instnorm forward", per, 0);
    double nb = print_ops(o, tab, n, "instnorm backward", per, 0);
    fprintf(o, "  convolutions %.1f ms (%.0f%% of the step: forward %.1f, activation backward %.1f, backward-data %.1f,\n"
               "  backward-weights %.1f); instance norms %.1f ms; everything else %.1f ms\n",
            (cf + ca + cd + cw) * 1e3, step_wall > 0 ? 100 * (cf + ca + cd + cw) / step_wall : 0.0, cf * 1e3, ca * 1e3,
            cd * 1e3, cw * 1e3, (nf + nb) * 1e3, (step_wall - cf - ca - cd - cw - nf - nb) * 1e3);
    if (a->data) {
        hd_status ls;
        double load = time_loading(a->data, a->size, pairs, repeats, &ls);
        if (ls != HD_OK) {
            fprintf(stderr, "hdnet bench: profile: loading %s: %s\n", a->data, hd_error());
            return 1;
        }
        fprintf(o, "  data loading       %.1f ms per batch of %d pairs from %s (the loader thread's work; a run overlaps it\n"
                   "                     with the step, where it competes for the cores)\n",
                load * 1e3, pairs, a->data);
    } else {
        fprintf(o, "  data loading       not timed (give --data DIR, a training set at this size)\n");
    }
    fflush(o);
    return 0;
}
