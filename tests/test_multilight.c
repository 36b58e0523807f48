/* test_multilight.c: the pieces of `hdnet eval --multilight` (src/eval/multilight.c) against
 * answers known without them: photometric stereo on a rendered Lambertian sphere gives its normals
 * and albedo back, and leave-one-out predicts each photo; the set's light directions point where
 * its README says (azimuth > 0 lights the image's left) and hdnet's own light from the negated
 * azimuth shades that side; the scale-invariant MSE of a known pair; lights.csv read, and refused
 * with the file and line named. (The whole command runs in tests/multilight_cli.sh.) */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "test.h"
#include "core/core.h"
#include "eval/multilight.h"

enum { S = 64 };

static float albedo_at(int x, int y) { return 0.3f + 0.6f * (float)(x + y) / (2.0f * S); }

/* The unit sphere's normal at pixel (x, y) of an S x S picture (camera frame: y up), 0 outside. */
static int sphere_normal(int x, int y, float n[3])
{
    const float u = (x + 0.5f) / S * 2 - 1, v = 1 - (y + 0.5f) / S * 2, r2 = u * u + v * v;
    if (r2 >= 0.95f) return 0;
    n[0] = u, n[1] = v, n[2] = sqrtf(1 - r2);
    return 1;
}

static void test_photometric_stereo(void)
{
    static const float AZ[] = {0, 25, -25, 50, -50, 0, 0, 35, -35, 70, -70, 20};
    static const float EL[] = {0, 0, 0, 10, -10, 40, -35, 30, 30, 0, 0, -20};
    enum { N = (int)(sizeof AZ / sizeof AZ[0]) };
    hd_image photos[N];
    float dirs[N][3];
    memset(photos, 0, sizeof photos);
    for (int i = 0; i < N; i++) {
        hd_ml_direction(AZ[i], EL[i], dirs[i]);
        CHECK(hd_image_alloc(&photos[i], S, S, 1) == HD_OK);
        for (int y = 0; y < S; y++)
            for (int x = 0; x < S; x++) {
                float n[3];
                const float d = sphere_normal(x, y, n) ? n[0] * dirs[i][0] + n[1] * dirs[i][1] + n[2] * dirs[i][2] : 0;
                photos[i].data[y * S + x] = albedo_at(x, y) * (d > 0 ? d : 0);
            }
    }
    hd_ps ps;
    CHECK(hd_ps_build(photos, (const float (*)[3])dirs, N, &ps) == HD_OK);
    double worst_angle = 0, worst_albedo = 0, worst_predict = 0;
    int solved = 0, inside = 0;
    for (int y = 0; y < S && ps.sums; y++)
        for (int x = 0; x < S; x++) {
            float n[3], b[3];
            if (!sphere_normal(x, y, n)) continue;
            inside++;
            if (!hd_ps_solve(&ps, (size_t)y * S + x, NULL, NULL, b)) continue;
            solved++;
            const double len = sqrt((double)b[0] * b[0] + (double)b[1] * b[1] + (double)b[2] * b[2]);
            const double c = (b[0] * n[0] + b[1] * n[1] + b[2] * n[2]) / len;
            const double angle = acos(c > 1 ? 1 : c) * 180 / M_PI;
            worst_angle = angle > worst_angle ? angle : worst_angle;
            worst_albedo = fmax(worst_albedo, fabs(len - albedo_at(x, y)));
            /* leave each photo out in turn: what the others say it shows */
            for (int i = 0; i < N; i++) {
                const float v = photos[i].data[y * S + x];
                float bl[3];
                if (!hd_ps_solve(&ps, (size_t)y * S + x, &v, dirs[i], bl)) continue;
                const float d = bl[0] * dirs[i][0] + bl[1] * dirs[i][1] + bl[2] * dirs[i][2];
                if (v > HD_PS_DARK && v < HD_PS_BRIGHT) worst_predict = fmax(worst_predict, fabs((d > 0 ? d : 0) - v));
            }
        }
    printf("photometric stereo on a sphere: %d of %d pixels solved, worst normal %.4f degrees, albedo %.2g, "
           "leave-one-out %.2g\n", solved, inside, worst_angle, worst_albedo, worst_predict);
    CHECK(solved > inside * 3 / 4);
    CHECK(worst_angle < 0.05);
    CHECK(worst_albedo < 1e-4);
    CHECK(worst_predict < 1e-4);
    /* a pixel no light reaches has no answer */
    float b[3];
    CHECK(ps.sums && hd_ps_solve(&ps, 0, NULL, NULL, b) == 0);
    hd_ps_free(&ps);
    /* photos of different sizes are refused */
    hd_image odd = {0};
    CHECK(hd_image_alloc(&odd, S, S + 1, 1) == HD_OK);
    hd_image two[2] = {photos[0], odd};
    CHECK(hd_ps_build(two, (const float (*)[3])dirs, 2, &ps) == HD_ERR_ARG && !ps.sums);
    hd_image_free(&odd);
    for (int i = 0; i < N; i++) hd_image_free(&photos[i]);
}

/* The set's convention against hdnet's: a light at the set's azimuth +60 lights the image's LEFT
 * (x < 0), and hdnet's light from azimuth -60 shades the normal pointing there most. */
static void test_directions(void)
{
    float d[3];
    hd_ml_direction(90, 0, d);
    CHECK_NEAR(d[0], -1, 1e-6);
    CHECK_NEAR(d[1], 0, 1e-6);
    CHECK_NEAR(d[2], 0, 1e-6);
    hd_ml_direction(0, 90, d);
    CHECK_NEAR(d[1], 1, 1e-6);
    hd_ml_direction(0, 0, d);
    CHECK_NEAR(d[2], 1, 1e-6);
    hd_ml_direction(60, 20, d);
    float l[HD_SH_COEFFS];
    hd_light_from_direction(-60, 20, 1.0f, 0.0f, l);
    const float mirror[3] = {-d[0], d[1], d[2]};
    float s_d = 0, s_m = 0;
    hd_sh_shading_map(d, NULL, 1, l, &s_d);
    hd_sh_shading_map(mirror, NULL, 1, l, &s_m);
    CHECK(d[0] < 0);
    CHECK(s_d > s_m + 0.5f);
    CHECK_NEAR(s_d, 1.0, 0.1); /* the shading of a distant light of intensity 1 facing it */
}

static void test_si_mse(void)
{
    const float truth[4] = {0.2f, 0.4f, 0.6f, 0.8f}, twice[4] = {0.4f, 0.8f, 1.2f, 1.6f};
    CHECK_NEAR(hd_ml_si_mse(twice, truth, NULL, 4), 0.0, 1e-9);
    /* truth (1, 0), out (1, 1): the best gain is 1/2, the errors (-1/2, 1/2): MSE 1/4 */
    const float t2[2] = {1, 0}, o2[2] = {1, 1}, mask[2] = {1, 1}, none[2] = {0, 0};
    CHECK_NEAR(hd_ml_si_mse(o2, t2, mask, 2), 250.0, 1e-6);
    CHECK(isnan(hd_ml_si_mse(o2, t2, none, 2)));
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    CHECK(f != NULL);
    if (!f) return;
    fputs(text, f);
    fclose(f);
}

/* Reads lights.csv written into dir; returns the status, the message checked for want. */
static hd_status read_csv(const char *dir, const char *text, const char *want, hd_ml_set *set)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/lights.csv", dir);
    write_text(path, text);
    hd_status st = hd_ml_set_read(dir, set);
    if (want && !strstr(hd_error(), want)) {
        fprintf(stderr, "reason '%s' lacks '%s'\n", hd_error(), want);
        CHECK(0);
    }
    return st;
}

static void test_csv(void)
{
    char dir[] = "/tmp/hdnet-multilight-XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    hd_ml_set set;
    CHECK(read_csv(dir, "file,subject,azimuth_deg,elevation_deg\r\na/a_P00A+000E+00.png,a,0,0\r\n"
                        "a/a_P00A+025E-10.png, a ,+025,-10\n\nb/b.png,b,-130,90\n",
                   NULL, &set) == HD_OK);
    CHECK(set.count == 3);
    if (set.count == 3) {
        CHECK(!strcmp(set.rows[1].file, "a/a_P00A+025E-10.png") && !strcmp(set.rows[1].subject, "a"));
        CHECK_NEAR(set.rows[1].az, 25, 0);
        CHECK_NEAR(set.rows[1].el, -10, 0);
        CHECK(!strcmp(set.rows[2].subject, "b") && set.rows[2].az == -130 && set.rows[2].el == 90);
    }
    hd_ml_set_free(&set);
    CHECK(read_csv(dir, "file,subject,az,el\n", "lights.csv:1: the header", &set) == HD_ERR_FORMAT);
    CHECK(read_csv(dir, "file,subject,azimuth_deg,elevation_deg\na.png,a,0\n", "lights.csv:2: 3 columns", &set) == HD_ERR_FORMAT);
    CHECK(read_csv(dir, "file,subject,azimuth_deg,elevation_deg\na.png,a,0,0\nb.png,a,east,0\n",
                   "lights.csv:3: azimuth 'east'", &set) == HD_ERR_FORMAT);
    CHECK(read_csv(dir, "file,subject,azimuth_deg,elevation_deg\na.png,a,0,95\n", "lights.csv:2: elevation '95'", &set) ==
          HD_ERR_FORMAT);
    CHECK(read_csv(dir, "file,subject,azimuth_deg,elevation_deg\na.png,a,nan,0\n", "azimuth 'nan'", &set) == HD_ERR_FORMAT);
    CHECK(read_csv(dir, "file,subject,azimuth_deg,elevation_deg\n../x.png,a,0,0\n", "lights.csv:2: file '../x.png'", &set) ==
          HD_ERR_FORMAT);
    CHECK(read_csv(dir, "file,subject,azimuth_deg,elevation_deg\n/etc/x.png,a,0,0\n", "must be a name inside", &set) ==
          HD_ERR_FORMAT);
    CHECK(read_csv(dir, "file,subject,azimuth_deg,elevation_deg\nx.png,,0,0\n", "lights.csv:2: the subject is empty", &set) ==
          HD_ERR_FORMAT);
    CHECK(read_csv(dir, "file,subject,azimuth_deg,elevation_deg\n", "no photos listed", &set) == HD_ERR_FORMAT);
    CHECK(set.rows == NULL && set.count == 0);
    char path[4200];
    snprintf(path, sizeof path, "%s/lights.csv", dir);
    unlink(path);
    CHECK(hd_ml_set_read(dir, &set) != HD_OK && strstr(hd_error(), "lights.csv"));
    rmdir(dir);
}

int main(void)
{
    test_photometric_stereo();
    test_directions();
    test_si_mse();
    test_csv();
    return test_summary("test_multilight");
}
