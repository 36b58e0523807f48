/* test_eval.c: SPEC section 7 metrics on hand-computed cases, k-means on separable clusters, the
 * lighting classification, and a whole run: a synthetic set's ground truth scored as a prediction
 * gives zero errors and 100 % classification, with the baselines filled. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "test.h"
#include "test_models.h"
#include "core/core.h"
#include "eval/metrics.h"
#include "synth/synth.h"
#include "eval/eval.h"
#include "model/model_probe.h"

static void test_normals(void)
{
    /* four pixels, planar: errors 0, 90, 45 degrees; the fourth (180) is masked out */
    const float s = (float)M_SQRT1_2;
    float pred[12] = {0, 1, s, 0, /* x */ 0, 0, 0, 0, /* y */ 1, 0, s, -1 /* z */};
    float gt[12] = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1};
    float mask[4] = {1, 1, 1, 0};
    hd_eval_sums sums;
    memset(&sums, 0, sizeof sums);
    hd_eval_add_normals(&sums, pred, gt, mask, 4);
    hd_eval_row row;
    memset(&row, 0, sizeof row);
    hd_eval_row_from_sums(&sums, &row);
    CHECK(row.has_normal && !row.has_albedo && !row.has_recon && !row.has_shading);
    CHECK_NEAR(row.normal_mean, 45.0, 1e-9);
    CHECK_NEAR(row.normal_std, sqrt((45.0 * 45.0 * 2) / 3.0), 1e-6);
    for (int k = 0; k < HD_EVAL_THRESHOLDS; k++) CHECK_NEAR(row.normal_under[k], 100.0 / 3.0, 1e-9);
    /* near-identical vectors: atan2 gives the tiny angle, not acos's noise */
    float a[3] = {0, 1e-5f, 1}, b[3] = {0, 0, 1};
    memset(&sums, 0, sizeof sums);
    hd_eval_add_normals(&sums, a, b, NULL, 1);
    CHECK_NEAR(sums.normal_sum, 1e-5 * 180.0 / M_PI, 1e-9);
    /* 10 degrees apart: under all thresholds; 22: under 25 and 30; 27: under 30 only */
    float p3[9], g3[9] = {0, 0, 0, 0, 0, 0, 1, 1, 1};
    const double deg[3] = {10, 22, 27};
    for (int i = 0; i < 3; i++) {
        p3[i] = (float)sin(deg[i] * M_PI / 180);
        p3[3 + i] = 0;
        p3[6 + i] = (float)cos(deg[i] * M_PI / 180);
    }
    memset(&sums, 0, sizeof sums);
    hd_eval_add_normals(&sums, p3, g3, NULL, 3);
    CHECK(sums.normal_under[0] == 1 && sums.normal_under[1] == 2 && sums.normal_under[2] == 3);
    CHECK_NEAR(sums.normal_sum, 59.0, 1e-4);
}

static void test_maps(void)
{
    /* albedo: 2 pixels x 3 channels, differences (0.1, 0, -0.2) and (0, 0.3, 0); a third pixel masked */
    float gt[9] = {0.5f, 0.5f, 0.9f, 0.5f, 0.2f, 0.9f, 0.5f, 0.5f, 0.9f};
    float pred[9] = {0.6f, 0.5f, 0.1f, 0.5f, 0.5f, 0.1f, 0.3f, 0.5f, 0.1f};
    float mask[3] = {1, 1, 0};
    hd_eval_sums sums;
    memset(&sums, 0, sizeof sums);
    hd_eval_add_albedo(&sums, pred, gt, mask, 3);
    hd_eval_row row;
    memset(&row, 0, sizeof row);
    hd_eval_row_from_sums(&sums, &row);
    CHECK(row.has_albedo && !row.has_normal);
    CHECK_NEAR(row.albedo_mae, 0.6 / 6, 1e-7);
    CHECK_NEAR(row.albedo_rmse, sqrt(0.14 / 6), 1e-7);
    /* scale-invariant albedo: half the truth scores 0 after its best scale (2), not 0.5 * mean */
    {
        float half[9];
        for (int i = 0; i < 9; i++) half[i] = 0.5f * gt[i];
        memset(&sums, 0, sizeof sums);
        hd_eval_add_albedo(&sums, half, gt, mask, 3);
        memset(&row, 0, sizeof row);
        hd_eval_row_from_sums(&sums, &row);
        CHECK_NEAR(row.albedo_mae, 0.5 * (0.5 + 0.5 + 0.5 + 0.2 + 0.5 + 0.5) / 6, 1e-7);
        CHECK_NEAR(row.albedo_si_mae, 0.0, 1e-7);
        /* one pixel, pred (1, 1, 1) against (1, 2, 10): sum |k - t| is least at the median k = 2,
         * leaving (1 + 0 + 8) / 3 where the plain MAE is (0 + 1 + 9) / 3 */
        float one[3] = {1, 1, 1}, t[3] = {1, 2, 10};
        memset(&sums, 0, sizeof sums);
        hd_eval_add_albedo(&sums, one, t, NULL, 1);
        memset(&row, 0, sizeof row);
        hd_eval_row_from_sums(&sums, &row);
        CHECK_NEAR(row.albedo_mae, 10.0 / 3, 1e-6);
        CHECK_NEAR(row.albedo_si_mae, 3.0, 1e-6);
    }
    /* reconstruction: clamped to [0, 1] like a picture: 1.5 vs 1 and -0.5 vs 0 cost nothing */
    float rp[6] = {1.5f, 0.5f, -0.5f, 0.5f, 0.5f, 0.5f}, ri[6] = {1.0f, 0.25f, 0.0f, 0.5f, 0.5f, 0.5f};
    memset(&sums, 0, sizeof sums);
    hd_eval_add_recon(&sums, rp, ri, NULL, 2);
    memset(&row, 0, sizeof row);
    hd_eval_row_from_sums(&sums, &row);
    CHECK_NEAR(row.recon_mae, 0.25 / 6, 1e-7);
    CHECK_NEAR(row.recon_rmse, sqrt(0.0625 / 6), 1e-7);
    /* shading: |1.2 - 1.0| and |0.5 - 0.8| -> 0.25 */
    float sp[3] = {1.2f, 0.5f, 9.0f}, sg[3] = {1.0f, 0.8f, 0.0f};
    memset(&sums, 0, sizeof sums);
    hd_eval_add_shading(&sums, sp, sg, mask, 3);
    memset(&row, 0, sizeof row);
    hd_eval_row_from_sums(&sums, &row);
    CHECK_NEAR(row.shading_mae, 0.25, 1e-7);
    /* a NaN prediction is a full miss, not a NaN metric */
    float np[1] = {NAN}, ng[1] = {0.5f};
    memset(&sums, 0, sizeof sums);
    hd_eval_add_shading(&sums, np, ng, NULL, 1);
    CHECK(sums.shading_abs == 1.0);
}

static void test_kmeans(void)
{
    /* 3 well separated blobs of 20 points in 9-D */
    enum { N = 60, D = 9, K = 3 };
    float pts[N * D], cent[K * D];
    int assign[N], again[N];
    hd_rng r;
    hd_rng_seed(&r, 5, 0);
    for (int i = 0; i < N; i++)
        for (int j = 0; j < D; j++) pts[i * D + j] = (j == i % K ? 10.0f : 0.0f) + 0.3f * hd_rng_normal(&r);
    CHECK(hd_kmeans(pts, N, D, K, 42, 100, cent, assign) == HD_OK);
    /* every blob maps to one cluster, and the three clusters differ */
    for (int i = 0; i < N; i++) CHECK(assign[i] == assign[i % K]);
    CHECK(assign[0] != assign[1] && assign[1] != assign[2] && assign[0] != assign[2]);
    /* centroids are the blob means */
    for (int b = 0; b < K; b++) {
        double mean = 0;
        for (int i = b; i < N; i += K) mean += pts[i * D + b];
        CHECK_NEAR(cent[assign[b] * D + b], mean / (N / K), 1e-4);
    }
    /* deterministic for a seed */
    float cent2[K * D];
    CHECK(hd_kmeans(pts, N, D, K, 42, 100, cent2, again) == HD_OK);
    CHECK(memcmp(assign, again, sizeof assign) == 0 && memcmp(cent, cent2, sizeof cent) == 0);
    /* k > n is clamped; all-equal points do not break the seeding */
    float same[4 * 2] = {1, 1, 1, 1, 1, 1, 1, 1};
    float c4[10 * 2];
    int a4[4];
    CHECK(hd_kmeans(same, 4, 2, 10, 1, 10, c4, a4) == HD_OK);
    for (int i = 0; i < 4; i++) CHECK(a4[i] >= 0 && a4[i] < 4);
    CHECK(hd_kmeans(pts, 0, D, K, 1, 10, cent, assign) == HD_ERR_ARG);
    pts[5] = NAN;
    CHECK(hd_kmeans(pts, N, D, K, 1, 10, cent, assign) == HD_ERR_NUMERIC);
}

static void test_light_accuracy(void)
{
    /* 10 groups of lights from 10 directions, 5 each */
    enum { N = 50 };
    float gt[N * HD_SH_COEFFS], pred[N * HD_SH_COEFFS];
    hd_rng r;
    hd_rng_seed(&r, 9, 0);
    for (int i = 0; i < N; i++) {
        int g = i % 10;
        hd_light_from_direction(-80.0f + 17.0f * (float)g, g % 2 ? 30.0f : -20.0f, 1.0f + 0.02f * hd_rng_normal(&r), 0.5f,
                                gt + i * HD_SH_COEFFS);
    }
    double acc = 0;
    memcpy(pred, gt, sizeof gt);
    CHECK(hd_eval_light_accuracy(gt, pred, N, 10, HD_EVAL_KMEANS_SEED, &acc) == HD_OK);
    CHECK_NEAR(acc, 100.0, 1e-9);
    /* every predicted light replaced by one from the opposite side: almost nothing matches */
    for (int i = 0; i < N; i++) memcpy(pred + i * HD_SH_COEFFS, gt + ((i + 5) % N) * HD_SH_COEFFS, HD_SH_COEFFS * sizeof(float));
    CHECK(hd_eval_light_accuracy(gt, pred, N, 10, HD_EVAL_KMEANS_SEED, &acc) == HD_OK);
    CHECK(acc < 30.0);
    /* a NaN light is a miss */
    memcpy(pred, gt, sizeof gt);
    pred[0] = NAN;
    CHECK(hd_eval_light_accuracy(gt, pred, N, 10, HD_EVAL_KMEANS_SEED, &acc) == HD_OK);
    CHECK_NEAR(acc, 98.0, 1e-9);
}

static int copy_file(const char *from, const char *to)
{
    char *data = NULL;
    size_t n = 0;
    if (hd_read_file(from, 1 << 26, &data, &n) != HD_OK) return 0;
    FILE *f = fopen(to, "wb");
    int ok = f && fwrite(data, 1, n, f) == n;
    if (f) ok &= fclose(f) == 0;
    free(data);
    return ok;
}


/* The ground truth of a small synthetic set, scored as a prediction. */
static void test_run(void)
{
    hd_synth_options o = {4, 3, 32, 3, 4.0f, 0.0f, 0, {0.0f, 0}, 0.0f};
    if (hd_synth_write_set("set", &o, NULL, NULL) != HD_OK) {
        fprintf(stderr, "synth: %s\n", hd_error());
        test_failures++;
        return;
    }
    for (int s = 0; s < 4; s++) {
        char dir[64];
        snprintf(dir, sizeof dir, "pred/subject_%04d", s);
        CHECK(hd_mkdirs(dir) == HD_OK);
        for (int i = 0; i < 3; i++) {
            static const char *const pairs[][2] = {{".albedo.png", ".albedo.png"}, {".shading.pfm", ".shading.pfm"},
                                                   {".normal_gt.png", ".normal.png"}, {".light.txt", ".light.txt"},
                                                   {".png", ".recon.png"}};
            for (int k = 0; k < 5; k++) {
                char a[128], b[128];
                snprintf(a, sizeof a, "set/subject_%04d/%04d%s", s, i, pairs[k][0]);
                snprintf(b, sizeof b, "%s/%04d%s", dir, i, pairs[k][1]);
                CHECK(copy_file(a, b));
            }
        }
    }
    hd_eval_report rep, rep1;
    hd_set_threads(1);
    CHECK(hd_eval_run("set", "pred", NULL, &rep1, NULL) == HD_OK);
    hd_set_threads(2);
    CHECK(hd_eval_run("set", "pred", NULL, &rep, NULL) == HD_OK);
    /* the same numbers whatever the thread count (slots merged in order) */
    CHECK(memcmp(rep.rows, rep1.rows, sizeof rep.rows) == 0);
    CHECK(rep.images == 12 && rep.skipped == 0 && rep.nrows == 4 && rep.kmeans_k == 10);
    const hd_eval_row *p = &rep.rows[0];
    CHECK(p->has_normal && p->has_albedo && p->has_recon && p->has_shading && p->has_light);
    CHECK(p->normal_mean < 1e-3 && p->normal_under[0] == 100.0);
    CHECK(p->albedo_mae == 0.0 && p->albedo_si_mae == 0.0 && p->recon_mae == 0.0 && p->shading_mae == 0.0);
    CHECK(p->light_accuracy == 100.0);
    /* the baselines: coarse normals off by degrees, LS light classified, mean colour off */
    CHECK(rep.rows[1].has_normal && rep.rows[1].normal_mean > 3.0 && !rep.rows[1].has_albedo);
    CHECK(rep.rows[2].has_light && rep.rows[2].has_shading && rep.rows[2].shading_mae > 0.0);
    CHECK(rep.rows[3].has_albedo && rep.rows[3].albedo_mae > 0.01);
    CHECK(hd_eval_report_write_json("eval.json", &rep) == HD_OK);
    char *json = NULL;
    size_t n = 0;
    CHECK(hd_read_file("eval.json", 1 << 20, &json, &n) == HD_OK);
    CHECK(json && strstr(json, "\"light_accuracy_pct\":\t100") && strstr(json, "\"images\":\t12"));
    free(json);
    CHECK(rep.source == HD_SOURCE_LNET);
    /* --source-light fit: the light scored is the least-squares light of the prediction's shading
     * on its normals (hd_face_light over the set's mask), not its light file. With every light file
     * zeroed, the prediction's own light misses and the fit of the true shading on the true normals
     * still classifies all; every other column is the same */
    for (int s = 0; s < 4; s++)
        for (int i = 0; i < 3; i++) {
            char path[128];
            snprintf(path, sizeof path, "pred/subject_%04d/%04d.light.txt", s, i);
            FILE *f = fopen(path, "w");
            CHECK(f != NULL);
            if (!f) continue;
            for (int k = 0; k < HD_SH_COEFFS; k++) fputs("0\n", f);
            fclose(f);
        }
    hd_eval_report zero, fit;
    CHECK(hd_eval_run_light("set", "pred", NULL, HD_SOURCE_LNET, &zero, NULL) == HD_OK);
    CHECK(hd_eval_run_light("set", "pred", NULL, HD_SOURCE_FIT, &fit, NULL) == HD_OK);
    CHECK(zero.source == HD_SOURCE_LNET && fit.source == HD_SOURCE_FIT);
    CHECK(zero.rows[0].light_accuracy < 50.0);
    CHECK(fit.rows[0].has_light && fit.rows[0].light_accuracy == 100.0);
    CHECK(fit.rows[0].albedo_mae == zero.rows[0].albedo_mae && fit.rows[0].normal_mean == zero.rows[0].normal_mean &&
          fit.rows[0].shading_mae == zero.rows[0].shading_mae && fit.rows[0].recon_mae == zero.rows[0].recon_mae);
    CHECK(memcmp(&fit.rows[1], &zero.rows[1], 3 * sizeof fit.rows[1]) == 0); /* the baselines */
    json = hd_eval_report_json(&fit);
    CHECK(json && strstr(json, "\"source_light\":\t\"fit\""));
    free(json);
    json = hd_eval_report_json(&zero);
    CHECK(json && strstr(json, "\"source_light\":\t\"lnet\""));
    free(json);
    CHECK(hd_eval_run_light("set", "pred", NULL, (hd_source_light)7, &fit, NULL) == HD_ERR_ARG);
    /* --repose: the true normals (the prediction) turned all the way to the coarse normals' pose
     * (the exact pose here, the canonical mesh's shape) move a little, not far; nothing else moves;
     * a share of 0 is the plain run and one outside 0..1 is refused */
    hd_eval_report turned, none;
    CHECK(hd_eval_run_options("set", "pred", NULL, &(hd_eval_options){HD_SOURCE_LNET, 1.0f, 0}, &turned, NULL) == HD_OK);
    CHECK(hd_eval_run_options("set", "pred", NULL, &(hd_eval_options){HD_SOURCE_LNET, 0.0f, 0}, &none, NULL) == HD_OK);
    fprintf(stderr, "eval --repose 1 on the true normals: %.3f degrees off the truth (%.4f unturned)\n",
            turned.rows[0].normal_mean, none.rows[0].normal_mean);
    CHECK(turned.repose == 1.0f && none.repose == 0.0f);
    CHECK(memcmp(none.rows, zero.rows, sizeof none.rows) == 0);
    CHECK(turned.rows[0].normal_mean > 0.05 && turned.rows[0].normal_mean < 5.0);
    CHECK(turned.rows[0].albedo_mae == zero.rows[0].albedo_mae && turned.rows[0].shading_mae == zero.rows[0].shading_mae);
    json = hd_eval_report_json(&turned);
    CHECK(json && strstr(json, "\"repose\":\t1"));
    free(json);
    CHECK(hd_eval_run_options("set", "pred", NULL, &(hd_eval_options){HD_SOURCE_LNET, 1.5f, 0}, &turned, NULL) == HD_ERR_ARG);
    CHECK(hd_eval_run_options("set", "pred", NULL, &(hd_eval_options){HD_SOURCE_LNET, NAN, 0}, &turned, NULL) == HD_ERR_ARG);
    /* a missing prediction is skipped with a reason; no prediction at all is an error */
    CHECK(remove("pred/subject_0002/0001.albedo.png") == 0);
    CHECK(hd_eval_run("set", "pred", NULL, &rep, NULL) == HD_OK);
    CHECK(rep.images == 11 && rep.skipped == 1);
    CHECK(hd_eval_run("set", "nothing_here", NULL, &rep, NULL) == HD_ERR_NOTFOUND);
    CHECK(hd_eval_run("set", NULL, NULL, &rep, NULL) == HD_ERR_ARG);
}

/* N-Net on a shading from outside (hd_model_normals_from_shading, eval --true-shading), with the
 * shipped model on the set test_run wrote: S-Net's own shading gives hd_model_decompose's normals
 * and light bit for bit, at any scale the same normals, another shading other normals; a run with
 * the row adds it and leaves the other four as they were. */
static void test_true_shading(void)
{
    hd_model *model = NULL;
    if (hd_model_load(NULL, &model) != HD_OK) {
        fprintf(stderr, "model: %s\n", hd_error());
        test_failures++;
        return;
    }
    hd_image img = {0}, truth = {0}, scaled = {0}, rgb = {0}, zero = {0}, n = {0};
    hd_decomposition d;
    memset(&d, 0, sizeof d);
    float light[HD_SH_COEFFS];
    CHECK(hd_image_read_as("set/subject_0001/0002.png", 3, &img) == HD_OK);
    CHECK(hd_image_read_as("set/subject_0001/0002.shading.pfm", 1, &truth) == HD_OK);
    CHECK(hd_model_decompose(model, &img, 1, &d) == HD_OK);
    const size_t HW = (size_t)d.shading.width * d.shading.height;
    CHECK(hd_model_normals_from_shading(model, &img, &d.shading, NULL, &n, light) == HD_OK);
    CHECK(n.data && n.width == d.normal.width && n.channels == 3);
    CHECK(n.data && memcmp(n.data, d.normal.data, 3 * HW * sizeof(float)) == 0);
    CHECK(memcmp(light, d.light, sizeof light) == 0);
    hd_image_free(&n);
    CHECK(hd_image_alloc(&scaled, d.shading.width, d.shading.height, 1) == HD_OK);
    for (size_t p = 0; scaled.data && p < HW; p++) scaled.data[p] = 3.0f * d.shading.data[p];
    CHECK(hd_model_normals_from_shading(model, &img, &scaled, NULL, &n, NULL) == HD_OK);
    double worst = 0, moved = 0;
    for (size_t p = 0; n.data && p < 3 * HW; p++) worst = fmax(worst, fabs(n.data[p] - d.normal.data[p]));
    CHECK(n.data && worst < 1e-4);
    hd_image_free(&n);
    CHECK(hd_model_normals_from_shading(model, &img, &truth, NULL, &n, NULL) == HD_OK);
    for (size_t p = 0; n.data && p < 3 * HW; p++) moved += fabs(n.data[p] - d.normal.data[p]);
    fprintf(stderr, "N-Net on S-Net's shading x 3: %.2g off; on the true shading: %.4f mean change\n", worst,
            moved / (3.0 * (double)HW));
    CHECK(moved / (3.0 * (double)HW) > 1e-3);
    hd_image_free(&n);
    /* refused: a shading of 3 channels, one with no positive mean; nothing is left allocated */
    CHECK(hd_image_convert(&truth, 3, &rgb) == HD_OK);
    CHECK(hd_model_normals_from_shading(model, &img, &rgb, NULL, &n, NULL) == HD_ERR_ARG && !n.data);
    CHECK(hd_image_alloc(&zero, truth.width, truth.height, 1) == HD_OK);
    CHECK(hd_model_normals_from_shading(model, &img, &zero, NULL, &n, NULL) == HD_ERR_ARG && !n.data);
    /* the run (one subject, 3 images): a fifth row with normals only, the first four unchanged; with
     * predictions, refused */
    hd_eval_report plain, with;
    const hd_eval_options po = {HD_SOURCE_LNET, 0.0f, 0}, wo = {HD_SOURCE_LNET, 0.0f, 1};
    CHECK(hd_eval_run_options("set/subject_0001", NULL, model, &po, &plain, NULL) == HD_OK);
    CHECK(hd_eval_run_options("set/subject_0001", NULL, model, &wo, &with, NULL) == HD_OK);
    CHECK(plain.nrows == 4 && with.nrows == 5 && with.true_shading && !plain.true_shading);
    CHECK(memcmp(plain.rows, with.rows, 4 * sizeof plain.rows[0]) == 0);
    const hd_eval_row *t = &with.rows[4];
    CHECK(t->has_normal && !t->has_albedo && !t->has_shading && !t->has_light && !t->has_recon);
    CHECK(t->normal_mean > 0.1 && t->normal_mean < 60.0 && t->normal_mean != with.rows[0].normal_mean);
    CHECK(strcmp(t->name, "N-Net on true shading") == 0);
    fprintf(stderr, "eval --true-shading: %.2f degrees (S-Net's shading %.2f)\n", t->normal_mean, with.rows[0].normal_mean);
    char *json = hd_eval_report_json(&with);
    CHECK(json && strstr(json, "\"N-Net on true shading\""));
    free(json);
    CHECK(hd_eval_run_options("set", "pred", NULL, &wo, &with, NULL) == HD_ERR_ARG);
    hd_image_free(&img), hd_image_free(&truth), hd_image_free(&scaled), hd_image_free(&rgb), hd_image_free(&zero);
    hd_decomposition_free(&d);
    hd_model_free(model);
}

int main(void)
{
    test_use_source_models(0);
    test_normals();
    test_maps();
    test_kmeans();
    test_light_accuracy();
    test_run();
    test_true_shading();
    return test_summary("test_eval");
}
