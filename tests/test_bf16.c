/* test_bf16.c: the bf16 convolutions (oneDNN, where the CPU has avx512_bf16) held to FP32: every
 * part of a convolution (forward, backward-data, and backward-weights and bias, FP32 by default and
 * bf16 with HD_BF16_WEIGHT_GRAD=1) on Common-Net and
 * discriminator shapes, in the blocked and the plain layout, within BF16_CONV_TOL of the FP32 plan's
 * result relative to its largest value; and the shipped model (models/hdnet-synth.safetensors) on
 * the first bundled example face, bf16 against FP32: albedo and normals within BF16_MODEL_MAX
 * (largest difference) and BF16_MODEL_MEAN (mean difference), the shading relative to its mean
 * likewise, the light within BF16_LIGHT_TOL. Exits 77 (skipped) where the CPU or the build has no
 * bf16 convolutions; the precision switch itself is checked everywhere. */
#include <stdlib.h>
#include <string.h>
#include "test.h"
#include "hdnet.h"
#include "nn/nn.h"
#include "io/dataset.h"

/* bf16 keeps 8 significant bits (relative rounding 2^-9 = 0.002 per input); sums of 9 C products
 * with FP32 accumulation stay well inside 1 % of the largest value (measured: 0.1-0.27 %). The
 * convolutions run without the leaky ReLU here: its backward's mask flips where bf16 moves an
 * output across zero, a kink, not a precision, effect. */
#define BF16_CONV_TOL 1e-2
/* the shipped model end to end at its 128 px (measured: albedo max 0.003 mean 0.0004, normals max
 * 0.06 mean 0.0011, shading / its mean max 0.013 mean 0.0017, light 0.0009 of 0.53) */
#define BF16_MODEL_MAX 0.08
#define BF16_MODEL_MEAN 0.005
#define BF16_LIGHT_TOL 0.03

static hd_rng rng;

static float *randu(size_t n)
{
    float *x = malloc((n ? n : 1) * sizeof(float));
    for (size_t i = 0; i < n; i++) x[i] = hd_rng_range(&rng, -1.0f, 1.0f);
    return x;
}

/* max |a - b| / max |b| */
static double rel(const float *a, const float *b, size_t n)
{
    double m = 1e-12, d = 0.0;
    for (size_t i = 0; i < n; i++) m = fmax(m, fabs(b[i])), d = fmax(d, fabs(a[i] - b[i]));
    return d / m;
}

/* Runs forward and backward of one shape in FP32 and bf16 and compares the four results. */
static void conv_case(int B, int C, int H, int OC, int stride, int nc16)
{
    hd_conv3x3 *p[2] = {NULL, NULL};
    for (int k = 0; k < 2; k++) {
        hd_conv_set_precision(k ? HD_PRECISION_BF16 : HD_PRECISION_FP32);
        hd_status st = nc16 ? hd_conv3x3_plan_nc16(&p[k], B, C, H, H, OC, stride, HD_ACT_NONE, 0.1f)
                            : hd_conv3x3_plan(&p[k], B, C, H, H, OC, stride, HD_ACT_NONE, 0.1f, HD_CONV_AUTO);
        CHECK(st == HD_OK);
        if (st != HD_OK) {
            fprintf(stderr, "plan: %s\n", hd_error());
            return;
        }
    }
    hd_conv_set_precision(HD_PRECISION_FP32);
    CHECK(strcmp(hd_conv3x3_precision(p[0]), "fp32") == 0);
    CHECK(strcmp(hd_conv3x3_precision(p[1]), "bf16") == 0);
    int Ho = hd_conv3x3_out_h(p[0]), Cp = nc16 ? hd_nc16_channels(C) : C, OCp = nc16 ? hd_nc16_channels(OC) : OC;
    size_t ni = (size_t)B * Cp * H * H, no = (size_t)B * OCp * Ho * Ho, nw = (size_t)OC * C * 9;
    float *x = randu(ni), *w = randu(nw), *b = randu((size_t)OC), *g = randu(no);
    if (nc16) { /* the padding lanes are zero in nc16 */
        float *plain = randu((size_t)B * C * H * H), *gp = randu((size_t)B * OC * Ho * Ho);
        hd_nc16_from_plain(x, plain, B, C, H * H);
        hd_nc16_from_plain(g, gp, B, OC, Ho * Ho);
        free(plain), free(gp);
    }
    for (size_t i = 0; i < nw; i++) w[i] *= 0.1f;
    float *out[2], *dx[2], *dw[2], *db[2], *dout[2];
    for (int k = 0; k < 2; k++) {
        out[k] = calloc(no, sizeof(float));
        dx[k] = calloc(ni, sizeof(float));
        dw[k] = calloc(nw, sizeof(float));
        db[k] = calloc((size_t)OC, sizeof(float));
        dout[k] = malloc(no * sizeof(float));
        memcpy(dout[k], g, no * sizeof(float));
        hd_conv3x3_forward(p[k], out[k], x, w, b);
        hd_conv3x3_backward(p[k], dx[k], dw[k], db[k], dout[k], out[k], x, w);
    }
    double ef = rel(out[1], out[0], no), ed = rel(dx[1], dx[0], ni), ew = rel(dw[1], dw[0], nw),
           eb = rel(db[1], db[0], (size_t)OC);
    printf("bf16 vs fp32 %s %dx%dx%dx%d -> %d s%d: forward %.2e, backward-data %.2e, backward-weights %.2e, bias %.2e\n",
           nc16 ? "nc16 " : "plain", B, C, H, H, OC, stride, ef, ed, ew, eb);
    CHECK(ef <= BF16_CONV_TOL);
    CHECK(ed <= BF16_CONV_TOL);
    CHECK(ew <= BF16_CONV_TOL);
    CHECK(eb <= BF16_CONV_TOL);
    CHECK(ef > 0.0 && ed > 0.0); /* bf16 did round something: the plan is not FP32 in disguise */
    for (int k = 0; k < 2; k++) free(out[k]), free(dx[k]), free(dw[k]), free(db[k]), free(dout[k]), hd_conv3x3_free(p[k]);
    free(x), free(w), free(b), free(g);
}

/* The shipped model on the first example face, in one precision. */
static int decompose(const char *model_path, const hd_image *img, hd_precision prec, hd_decomposition *d)
{
    hd_conv_set_precision(prec);
    hd_model *model = NULL;
    int ok = hd_model_load(model_path, &model) == HD_OK && hd_model_decompose(model, img, 1, d) == HD_OK;
    if (!ok) fprintf(stderr, "shipped model: %s\n", hd_error());
    hd_model_free(model);
    hd_conv_set_precision(HD_PRECISION_FP32);
    return ok;
}

static void diff_stats(const hd_image *a, const hd_image *b, double scale, double *mx, double *mean)
{
    size_t n = (size_t)a->width * a->height * a->channels;
    double m = 0, s = 0;
    for (size_t i = 0; i < n; i++) {
        double e = fabs(a->data[i] - b->data[i]) / scale;
        m = fmax(m, e), s += e;
    }
    *mx = m, *mean = s / (double)n;
}

static void test_shipped_model(void)
{
    const char *testdata = getenv("HDNET_TESTDATA");
    char model_path[4096], faces[4096];
    CHECK(testdata != NULL);
    if (!testdata) return;
    snprintf(model_path, sizeof model_path, "%s/../../models/hdnet-synth.safetensors", testdata);
    snprintf(faces, sizeof faces, "%s/../../examples/faces", testdata);
    hd_dataset ds;
    CHECK(hd_dataset_scan(faces, &ds, NULL) == HD_OK);
    if (ds.count == 0) return;
    hd_image img = {0};
    CHECK(hd_image_read_as(ds.samples[0].image, 3, &img) == HD_OK);
    hd_decomposition f, h;
    memset(&f, 0, sizeof f), memset(&h, 0, sizeof h);
    int ok = decompose(model_path, &img, HD_PRECISION_FP32, &f) && decompose(model_path, &img, HD_PRECISION_BF16, &h);
    CHECK(ok);
    if (ok) {
        double am, aa, nm, na, sm, sa, smean = 0, lm = 0, lmax = 1e-12;
        size_t ns = (size_t)f.shading.width * f.shading.height;
        for (size_t i = 0; i < ns; i++) smean += f.shading.data[i];
        smean /= (double)ns;
        diff_stats(&h.albedo, &f.albedo, 1.0, &am, &aa);
        diff_stats(&h.normal, &f.normal, 1.0, &nm, &na);
        diff_stats(&h.shading, &f.shading, smean, &sm, &sa);
        for (int k = 0; k < HD_SH_COEFFS; k++)
            lm = fmax(lm, fabs(h.light[k] - f.light[k])), lmax = fmax(lmax, fabs(f.light[k]));
        printf("shipped model bf16 vs fp32 (%dx%d): albedo max %.4f mean %.5f; normal max %.4f mean %.5f; shading / its mean "
               "max %.4f mean %.5f; light max %.4f of %.3f\n",
               f.albedo.width, f.albedo.height, am, aa, nm, na, sm, sa, lm, lmax);
        CHECK(am <= BF16_MODEL_MAX && aa <= BF16_MODEL_MEAN);
        CHECK(nm <= BF16_MODEL_MAX && na <= BF16_MODEL_MEAN);
        CHECK(sm <= BF16_MODEL_MAX && sa <= BF16_MODEL_MEAN);
        CHECK(lm <= BF16_LIGHT_TOL * lmax);
        CHECK(aa > 0.0); /* the two runs did differ */
    }
    hd_decomposition_free(&f);
    hd_decomposition_free(&h);
    hd_image_free(&img);
    hd_dataset_free(&ds);
}

int main(void)
{
    /* the switch: FP32 by default, and FP32 whatever is asked where bf16 is not had */
    CHECK(hd_conv_precision() == HD_PRECISION_FP32);
    hd_conv_set_precision(HD_PRECISION_AUTO);
    CHECK(hd_conv_precision() == (hd_conv_bf16_available() ? HD_PRECISION_BF16 : HD_PRECISION_FP32));
    hd_conv_set_precision(HD_PRECISION_FP32);
    CHECK(hd_conv_precision() == HD_PRECISION_FP32);
    hd_precision p;
    CHECK(hd_precision_parse("bf16", "t", &p) == HD_OK && p == HD_PRECISION_BF16);
    CHECK(hd_precision_parse("fp16", "t", &p) == HD_ERR_ARG);
    if (test_failures) return test_summary("test_bf16");
    if (!hd_conv_bf16_available()) {
        printf("test_bf16: skipped: no bf16 convolutions on this CPU (oneDNN ISA %s)\n", hd_conv_isa());
        return 77;
    }
    hd_rng_seed(&rng, 38, 1);
    conv_case(2, 32, 32, 32, 1, 1);  /* Common-Net levels */
    conv_case(1, 96, 16, 64, 1, 1);
    conv_case(2, 32, 24, 3, 1, 1);   /* the output layer */
    conv_case(2, 3, 20, 64, 2, 0);   /* discriminator, plain layout */
    conv_case(1, 64, 16, 128, 2, 0);
    conv_case(1, 16, 12, 32, 1, 0);
    /* the weight gradients in bf16 too (HD_BF16_WEIGHT_GRAD=1; by default a bf16 plan computes
     * them in FP32, the figures above show 0 there) */
    setenv("HD_BF16_WEIGHT_GRAD", "1", 1);
    conv_case(2, 32, 32, 32, 1, 1);
    conv_case(1, 64, 16, 128, 2, 0);
    unsetenv("HD_BF16_WEIGHT_GRAD");
    test_shipped_model();
    return test_summary("test_bf16");
}
