/* test_image.c: image I/O and resampling. PNG 8/16-bit round trips for 1-4 channels (exact to
 * the quantisation step); palette (with and without tRNS) and gray+alpha PNGs written here with
 * libpng directly; a JPEG written here with libjpeg; PFM bit-exact; channel conversion; resize
 * (constant stays constant, area down equals block means, bilinear up of a ramp is linear);
 * normal-map encode/decode and resize; contact sheets; and errors on bad input. */
#include <math.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <jpeglib.h>
#include <unistd.h>
#include "test.h"
#include "core/core.h"
#include "io/image_io.h"

static void fill_random(hd_image *img, hd_rng *rng)
{
    size_t n = (size_t)img->width * img->height * img->channels;
    for (size_t i = 0; i < n; i++) img->data[i] = hd_rng_uniform(rng);
}

static float quantised(float v, float maxval) { return roundf(v * maxval) / maxval; }

static void test_png_round_trips(void)
{
    hd_rng rng;
    hd_rng_seed(&rng, 1, 1);
    for (int bits = 8; bits <= 16; bits += 8)
        for (int c = 1; c <= 4; c++) {
            hd_image img = {0}, back = {0};
            CHECK(hd_image_alloc(&img, 13, 7, c) == HD_OK);
            fill_random(&img, &rng);
            img.data[0] = -0.5f; /* clamped to 0 */
            img.data[1] = 1.5f;  /* clamped to 1 */
            char name[64];
            snprintf(name, sizeof name, "rt%d_%d.png", bits, c);
            CHECK(hd_image_write_png(name, &img, bits) == HD_OK);
            hd_image_info info;
            CHECK(hd_image_read_info(name, &back, &info) == HD_OK);
            CHECK(back.width == 13 && back.height == 7 && back.channels == c);
            CHECK(info.bits == bits && strcmp(info.format, "PNG") == 0);
            float maxval = bits == 8 ? 255.0f : 65535.0f;
            double worst = 0;
            for (size_t i = 0; i < (size_t)13 * 7 * c; i++) {
                float want = quantised(fminf(fmaxf(img.data[i], 0.0f), 1.0f), maxval);
                double e = fabs(back.data[i] - want);
                if (e > worst) worst = e;
            }
            CHECK_NEAR(worst, 0.0, 1e-7);
            hd_image_free(&img);
            hd_image_free(&back);
        }
    /* A failed write leaves nothing behind. */
    hd_image img = {0};
    CHECK(hd_image_alloc(&img, 2, 2, 3) == HD_OK);
    CHECK(hd_image_write_png("no_such_dir/x.png", &img, 8) != HD_OK);
    CHECK(strstr(hd_error(), "no_such_dir/x.png") != NULL);
    CHECK(hd_image_write_png("bad_bits.png", &img, 12) == HD_ERR_ARG);
    CHECK(access("bad_bits.png", F_OK) != 0);
    hd_image_free(&img);
}

/* Writes a PNG with libpng directly: color_type and bit_depth as given, rows of bytes. */
static void write_raw_png(const char *path, int w, int h, int color_type, int bit_depth,
                          const png_color *palette, int npalette, const png_byte *trns, int ntrns,
                          const png_byte *pixels, size_t rowbytes)
{
    FILE *f = fopen(path, "wb");
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png_create_info_struct(png);
    if (setjmp(png_jmpbuf(png))) {
        CHECK(!"libpng failed writing the test image");
        fclose(f);
        return;
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, w, h, bit_depth, color_type, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    if (palette) png_set_PLTE(png, info, palette, npalette);
    if (trns) png_set_tRNS(png, info, trns, ntrns, NULL);
    png_write_info(png, info);
    for (int y = 0; y < h; y++) png_write_row(png, pixels + (size_t)y * rowbytes);
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    fclose(f);
}

static void test_png_variants(void)
{
    const png_color palette[3] = {{255, 0, 0}, {0, 128, 0}, {10, 20, 30}};
    const png_byte idx[6] = {0, 1, 2, 2, 1, 0}; /* 3x2, 8-bit indices */
    hd_image img = {0};
    hd_image_info info;
    write_raw_png("pal.png", 3, 2, PNG_COLOR_TYPE_PALETTE, 8, palette, 3, NULL, 0, idx, 3);
    CHECK(hd_image_read_info("pal.png", &img, &info) == HD_OK);
    CHECK(img.channels == 3 && info.palette == 1);
    if (img.channels == 3) {
        size_t np = 6;
        CHECK_NEAR(img.data[0], 1.0, 0);          /* (0,0) red */
        CHECK_NEAR(img.data[np + 1], 128 / 255.0, 1e-7); /* (1,0) green */
        CHECK_NEAR(img.data[2 * np + 2], 30 / 255.0, 1e-7); /* (2,0) blue of entry 2 */
        CHECK_NEAR(img.data[3], 10 / 255.0, 1e-7); /* (0,1) red of entry 2 */
    }
    hd_image_free(&img);

    /* Palette with transparency: RGBA. */
    const png_byte trns[2] = {0, 128};
    write_raw_png("pal_trns.png", 3, 2, PNG_COLOR_TYPE_PALETTE, 8, palette, 3, trns, 2, idx, 3);
    CHECK(hd_image_read("pal_trns.png", &img) == HD_OK);
    CHECK(img.channels == 4);
    if (img.channels == 4) {
        size_t np = 6;
        CHECK_NEAR(img.data[3 * np + 0], 0.0, 0);             /* entry 0: alpha 0 */
        CHECK_NEAR(img.data[3 * np + 1], 128 / 255.0, 1e-7);  /* entry 1: alpha 128 */
        CHECK_NEAR(img.data[3 * np + 2], 1.0, 0);             /* entry 2: opaque */
    }
    hd_image_free(&img);

    /* 4-bit palette (packed indices) */
    const png_byte packed[4] = {0x01, 0x20, 0x21, 0x00}; /* 3x2: rows 0,1,2 and 2,1,0 */
    write_raw_png("pal4.png", 3, 2, PNG_COLOR_TYPE_PALETTE, 4, palette, 3, NULL, 0, packed, 2);
    CHECK(hd_image_read_info("pal4.png", &img, &info) == HD_OK);
    CHECK(img.channels == 3 && info.bits == 4);
    if (img.channels == 3) CHECK_NEAR(img.data[6 + 4], 128 / 255.0, 1e-7); /* (1,1) green */
    hd_image_free(&img);

    /* 8-bit gray + alpha. */
    const png_byte ga[8] = {0, 255, 64, 128, 200, 0, 255, 7}; /* 2x2 */
    write_raw_png("ga.png", 2, 2, PNG_COLOR_TYPE_GRAY_ALPHA, 8, NULL, 0, NULL, 0, ga, 4);
    CHECK(hd_image_read("ga.png", &img) == HD_OK);
    CHECK(img.channels == 2);
    if (img.channels == 2)
        for (int p = 0; p < 4; p++) {
            CHECK_NEAR(img.data[p], ga[2 * p] / 255.0, 1e-7);
            CHECK_NEAR(img.data[4 + p], ga[2 * p + 1] / 255.0, 1e-7);
        }
    hd_image_free(&img);

    /* 16-bit gray + alpha (big-endian samples). */
    const png_byte ga16[8] = {0x12, 0x34, 0xFF, 0xFF, 0xAB, 0xCD, 0x00, 0x01}; /* 2x1 */
    write_raw_png("ga16.png", 2, 1, PNG_COLOR_TYPE_GRAY_ALPHA, 16, NULL, 0, NULL, 0, ga16, 8);
    CHECK(hd_image_read("ga16.png", &img) == HD_OK);
    if (img.channels == 2) {
        CHECK_NEAR(img.data[0], 0x1234 / 65535.0, 1e-7);
        CHECK_NEAR(img.data[1], 0xABCD / 65535.0, 1e-7);
        CHECK_NEAR(img.data[3], 1 / 65535.0, 1e-9);
    }
    hd_image_free(&img);

    /* 1-bit gray expands to 0 / 1. */
    const png_byte bits1[1] = {0xA0}; /* 3x1: 1 0 1 */
    write_raw_png("g1.png", 3, 1, PNG_COLOR_TYPE_GRAY, 1, NULL, 0, NULL, 0, bits1, 1);
    CHECK(hd_image_read("g1.png", &img) == HD_OK);
    if (img.channels == 1) {
        CHECK_NEAR(img.data[0], 1, 0);
        CHECK_NEAR(img.data[1], 0, 0);
        CHECK_NEAR(img.data[2], 1, 0);
    }
    hd_image_free(&img);

    /* read_as: gray+alpha to RGB replicates gray and drops alpha; RGB to gray is the luma. */
    CHECK(hd_image_read_as("ga.png", 3, &img) == HD_OK);
    CHECK(img.channels == 3);
    if (img.channels == 3) CHECK_NEAR(img.data[8 + 1], 64 / 255.0, 1e-7);
    hd_image_free(&img);
    CHECK(hd_image_read_as("pal.png", 1, &img) == HD_OK);
    if (img.channels == 1) CHECK_NEAR(img.data[0], 0.299, 1e-6);
    hd_image_free(&img);
}

/* An Adam7-interlaced 16-bit RGB PNG (written with png_write_image) reads like its pixels. */
static void test_png_interlaced(void)
{
    enum { W = 11, H = 9 };
    static png_byte pixels[H][W * 6];
    png_bytep rows[H];
    for (int y = 0; y < H; y++) {
        rows[y] = pixels[y];
        for (int k = 0; k < W * 6; k++) pixels[y][k] = (png_byte)(y * 31 + k * 7);
    }
    FILE *f = fopen("adam7.png", "wb");
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png_create_info_struct(png);
    if (setjmp(png_jmpbuf(png))) {
        CHECK(!"libpng failed writing the interlaced test image");
        fclose(f);
        return;
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, W, H, 16, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_ADAM7, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    png_write_image(png, rows);
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    fclose(f);
    hd_image img = {0};
    CHECK(hd_image_read("adam7.png", &img) == HD_OK);
    CHECK(img.width == W && img.height == H && img.channels == 3);
    int bad = 0;
    for (int y = 0; img.data && y < H; y++)
        for (int x = 0; x < W; x++)
            for (int c = 0; c < 3; c++) {
                int k = (x * 3 + c) * 2;
                float want = (float)((pixels[y][k] << 8) | pixels[y][k + 1]) / 65535.0f;
                bad += img.data[((size_t)c * H + y) * W + x] != want;
            }
    CHECK(bad == 0);
    hd_image_free(&img);
}

/* Writes pixels (interleaved, 1 or 3 components) as a quality-95 JPEG with libjpeg. */
static void write_jpeg(const char *path, int w, int h, int comps, const unsigned char *pixels)
{
    struct jpeg_compress_struct cinfo;
    struct jpeg_error_mgr jerr;
    cinfo.err = jpeg_std_error(&jerr);
    jpeg_create_compress(&cinfo);
    FILE *f = fopen(path, "wb");
    jpeg_stdio_dest(&cinfo, f);
    cinfo.image_width = w;
    cinfo.image_height = h;
    cinfo.input_components = comps;
    cinfo.in_color_space = comps == 1 ? JCS_GRAYSCALE : JCS_RGB;
    jpeg_set_defaults(&cinfo);
    jpeg_set_quality(&cinfo, 95, TRUE);
    jpeg_start_compress(&cinfo, TRUE);
    for (int y = 0; y < h; y++) {
        JSAMPROW row = (JSAMPROW)(pixels + (size_t)y * w * comps);
        jpeg_write_scanlines(&cinfo, &row, 1);
    }
    jpeg_finish_compress(&cinfo);
    jpeg_destroy_compress(&cinfo);
    fclose(f);
}

static void test_jpeg(void)
{
    const int w = 32, h = 24;
    unsigned char rgb[32 * 24 * 3], gray[32 * 24];
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            rgb[(y * w + x) * 3 + 0] = (unsigned char)(x * 255 / (w - 1));
            rgb[(y * w + x) * 3 + 1] = (unsigned char)(y * 255 / (h - 1));
            rgb[(y * w + x) * 3 + 2] = 100;
            gray[y * w + x] = (unsigned char)((x + y) * 255 / (w + h - 2));
        }
    write_jpeg("smooth.jpg", w, h, 3, rgb);
    write_jpeg("gray.jpg", w, h, 1, gray);
    hd_image g = {0};
    CHECK(hd_image_read("gray.jpg", &g) == HD_OK);
    CHECK(g.channels == 1 && g.width == w && g.height == h);
    double gworst = 0;
    for (int p = 0; g.data && p < w * h; p++) gworst = fmax(gworst, fabs(g.data[p] - gray[p] / 255.0));
    CHECK(gworst < 6 / 255.0);
    hd_image_free(&g);

    hd_image img = {0};
    hd_image_info info;
    CHECK(hd_image_read_info("smooth.jpg", &img, &info) == HD_OK);
    CHECK(img.width == w && img.height == h && img.channels == 3 && strcmp(info.format, "JPEG") == 0);
    if (img.channels == 3) {
        double worst = 0, sum = 0;
        size_t np = (size_t)w * h;
        for (int c = 0; c < 3; c++)
            for (size_t p = 0; p < np; p++) {
                double e = fabs(img.data[c * np + p] - rgb[p * 3 + c] / 255.0);
                sum += e;
                if (e > worst) worst = e;
            }
        /* quality 95 on a smooth gradient: a few levels at worst, well under one on average */
        CHECK(worst < 12 / 255.0);
        CHECK(sum / (3 * np) < 2 / 255.0);
    }
    hd_image_free(&img);

    /* Truncated: an error naming the file, not a gray-filled image. */
    char *data;
    size_t size;
    CHECK(hd_read_file("smooth.jpg", 1 << 20, &data, &size) == HD_OK);
    FILE *f = fopen("cut.jpg", "wb");
    fwrite(data, 1, size * 2 / 3, f);
    fclose(f);
    free(data);
    CHECK(hd_image_read("cut.jpg", &img) == HD_ERR_FORMAT);
    CHECK(strstr(hd_error(), "cut.jpg") != NULL);
    CHECK(img.data == NULL);

    /* Junk bytes between header segments (before SOF0) only draw libjpeg's harmless
     * "extraneous bytes before marker" warning: the image still reads. */
    CHECK(hd_read_file("smooth.jpg", 1 << 20, &data, &size) == HD_OK);
    size_t sof = 2;
    while (sof + 1 < size && !((unsigned char)data[sof] == 0xFF && (unsigned char)data[sof + 1] == 0xC0)) sof++;
    CHECK(sof + 1 < size);
    f = fopen("junk.jpg", "wb");
    fwrite(data, 1, sof, f);
    fwrite("\x12\x34\x56", 1, 3, f);
    fwrite(data + sof, 1, size - sof, f);
    fclose(f);
    free(data);
    CHECK(hd_image_read("junk.jpg", &img) == HD_OK);
    CHECK(img.width == w && img.height == h);
    hd_image_free(&img);
}

static void test_pfm(void)
{
    hd_rng rng;
    hd_rng_seed(&rng, 2, 1);
    for (int c = 1; c <= 3; c += 2) {
        hd_image img = {0}, back = {0};
        CHECK(hd_image_alloc(&img, 9, 5, c) == HD_OK);
        fill_random(&img, &rng);
        img.data[3] = 1e30f;
        img.data[4] = -2.5e-30f;
        img.data[5] = 1.7f;
        CHECK(hd_image_write_pfm("rt.pfm", &img) == HD_OK);
        CHECK(hd_image_read("rt.pfm", &back) == HD_OK);
        CHECK(back.width == 9 && back.height == 5 && back.channels == c);
        if (back.data)
            CHECK(memcmp(img.data, back.data, (size_t)9 * 5 * c * sizeof(float)) == 0);
        hd_image_free(&img);
        hd_image_free(&back);
    }
    /* Bottom-to-top rows and a big-endian file written by hand. */
    FILE *f = fopen("be.pfm", "wb");
    fputs("Pf\n2 2\n1.0\n", f);
    const unsigned char rows[16] = {0x3F, 0x80, 0, 0, 0x40, 0, 0, 0, /* bottom: 1, 2 */
                                    0x40, 0x40, 0, 0, 0x40, 0x80, 0, 0}; /* top: 3, 4 */
    fwrite(rows, 1, 16, f);
    fclose(f);
    hd_image img = {0};
    CHECK(hd_image_read("be.pfm", &img) == HD_OK);
    if (img.data) {
        CHECK_NEAR(img.data[0], 3, 0);
        CHECK_NEAR(img.data[1], 4, 0);
        CHECK_NEAR(img.data[2], 1, 0);
        CHECK_NEAR(img.data[3], 2, 0);
    }
    hd_image_free(&img);
    /* 2-channel images do not fit PFM. */
    CHECK(hd_image_alloc(&img, 2, 2, 2) == HD_OK);
    CHECK(hd_image_write_pfm("two.pfm", &img) == HD_ERR_ARG);
    hd_image_free(&img);
}

static void test_resize(void)
{
    hd_image img = {0}, out = {0};
    /* A constant stays constant under every combination of shrinking and enlarging. */
    CHECK(hd_image_alloc(&img, 17, 11, 3) == HD_OK);
    for (size_t i = 0; i < (size_t)17 * 11 * 3; i++) img.data[i] = 0.375f;
    const int sizes[4][2] = {{5, 3}, {40, 29}, {6, 30}, {17, 11}};
    for (int s = 0; s < 4; s++) {
        CHECK(hd_image_resize(&img, sizes[s][0], sizes[s][1], &out) == HD_OK);
        double worst = 0;
        for (size_t i = 0; i < (size_t)sizes[s][0] * sizes[s][1] * 3; i++)
            worst = fmax(worst, fabs(out.data[i] - 0.375));
        CHECK_NEAR(worst, 0, 1e-6);
        hd_image_free(&out);
    }
    hd_image_free(&img);

    /* Area 4x4 -> 2x2 is the mean of each 2x2 block, exactly. */
    CHECK(hd_image_alloc(&img, 4, 4, 1) == HD_OK);
    for (int i = 0; i < 16; i++) img.data[i] = (float)(i * i % 7) / 8.0f;
    CHECK(hd_image_resize(&img, 2, 2, &out) == HD_OK);
    for (int by = 0; by < 2; by++)
        for (int bx = 0; bx < 2; bx++) {
            float sum = 0;
            for (int y = 0; y < 2; y++)
                for (int x = 0; x < 2; x++) sum += img.data[(by * 2 + y) * 4 + bx * 2 + x];
            CHECK(out.data[by * 2 + bx] == sum / 4);
        }
    hd_image_free(&out);
    /* A fractional shrink 4 -> 3: output 0 covers samples 0 (whole) and 1 (a third). */
    CHECK(hd_image_resize(&img, 3, 4, &out) == HD_OK);
    CHECK_NEAR(out.data[0], (img.data[0] * 1.0 + img.data[1] / 3.0) * 3 / 4, 1e-6);
    CHECK_NEAR(out.data[1], (img.data[1] * 2 / 3.0 + img.data[2] * 2 / 3.0) * 3 / 4, 1e-6);
    hd_image_free(&out);
    hd_image_free(&img);

    /* Bilinear up of a ramp v = x is linear inside (slope n/m), clamped at the edges. */
    CHECK(hd_image_alloc(&img, 5, 3, 1) == HD_OK);
    for (int y = 0; y < 3; y++)
        for (int x = 0; x < 5; x++) img.data[y * 5 + x] = (float)x;
    CHECK(hd_image_resize(&img, 20, 7, &out) == HD_OK);
    for (int y = 0; y < 7; y++)
        for (int x = 0; x < 20; x++) {
            double sx = (x + 0.5) * 5 / 20.0 - 0.5;
            double want = sx < 0 ? 0 : sx > 4 ? 4 : sx;
            CHECK_NEAR(out.data[y * 20 + x], want, 1e-5);
        }
    hd_image_free(&out);
    hd_image_free(&img);
}

static void test_normals(void)
{
    hd_rng rng;
    hd_rng_seed(&rng, 3, 1);
    const int w = 16, h = 16;
    size_t np = (size_t)w * h;
    hd_image n = {0}, m = {0}, rgb = {0}, back = {0}, file = {0}, mask_back = {0};
    CHECK(hd_image_alloc(&n, w, h, 3) == HD_OK);
    CHECK(hd_image_alloc(&m, w, h, 1) == HD_OK);
    for (size_t p = 0; p < np; p++) {
        float x = hd_rng_range(&rng, -1, 1), y = hd_rng_range(&rng, -1, 1), z = hd_rng_range(&rng, 0.05f, 1);
        float len = sqrtf(x * x + y * y + z * z);
        n.data[p] = x / len;
        n.data[np + p] = y / len;
        n.data[2 * np + p] = z / len;
        m.data[p] = p % 5 == 0 ? 0.0f : 1.0f;
    }
    CHECK(hd_normal_encode(&n, &m, &rgb) == HD_OK);
    CHECK(rgb.data[0] == 0 && rgb.data[np] == 0 && rgb.data[2 * np] == 0);
    CHECK(hd_image_write_png("normal.png", &rgb, 16) == HD_OK);
    CHECK(hd_image_read("normal.png", &file) == HD_OK);
    CHECK(hd_normal_decode(&file, &back, &mask_back) == HD_OK);
    double worst = 0;
    for (size_t p = 0; p < np; p++) {
        CHECK(mask_back.data[p] == m.data[p]);
        for (int c = 0; c < 3; c++) {
            double want = m.data[p] > 0 ? n.data[c * np + p] : 0.0;
            worst = fmax(worst, fabs(back.data[c * np + p] - want));
        }
    }
    CHECK_NEAR(worst, 0, 2.0 / 65535);
    hd_image_free(&n);
    hd_image_free(&m);
    hd_image_free(&rgb);
    hd_image_free(&back);
    hd_image_free(&file);
    hd_image_free(&mask_back);
    /* Mid gray is too short to be a normal: masked out. */
    hd_image gray = {0};
    CHECK(hd_image_alloc(&gray, 1, 1, 3) == HD_OK);
    gray.data[0] = gray.data[1] = gray.data[2] = 0.5f;
    CHECK(hd_normal_decode(&gray, &back, &mask_back) == HD_OK);
    CHECK(mask_back.data[0] == 0 && back.data[2] == 0);
    hd_image_free(&back);
    hd_image_free(&mask_back);
    hd_image_free(&gray);
}

static void expect_error(const char *path, const char *bytes, size_t n, const char *needle)
{
    FILE *f = fopen(path, "wb");
    fwrite(bytes, 1, n, f);
    fclose(f);
    hd_image img = {0};
    hd_status st = hd_image_read(path, &img);
    CHECK(st != HD_OK);
    CHECK(img.data == NULL);
    if (!strstr(hd_error(), path) || (needle && !strstr(hd_error(), needle))) {
        fprintf(stderr, "reason for %s lacks '%s': %s\n", path, needle ? needle : path, hd_error());
        test_failures++;
    }
}

static void test_errors(void)
{
    hd_image img = {0};
    CHECK(hd_image_read("missing.png", &img) == HD_ERR_IO);
    CHECK(strstr(hd_error(), "missing.png") != NULL);
    expect_error("empty.png", "", 0, "empty");
    expect_error("text.png", "hello world", 11, "unknown image format");
    expect_error("neg.pfm", "PF\n-3 2\n-1.0\n", 14, "size");
    expect_error("huge.pfm", "PF\n20000 2\n-1.0\n", 16, "limit");
    expect_error("scale.pfm", "Pf\n1 1\nabc\n\1\1\1\1", 16, "scale");
    expect_error("short.pfm", "Pf\n2 2\n-1.0\n\0\0\0\0\0\0", 18, "truncated");
    /* A valid PNG cut in its image data. */
    hd_image big = {0};
    hd_rng rng;
    hd_rng_seed(&rng, 4, 1);
    CHECK(hd_image_alloc(&big, 64, 64, 3) == HD_OK);
    fill_random(&big, &rng);
    CHECK(hd_image_write_png("whole.png", &big, 8) == HD_OK);
    hd_image_free(&big);
    char *data;
    size_t size;
    CHECK(hd_read_file("whole.png", 1 << 20, &data, &size) == HD_OK);
    expect_error("cut.png", data, size / 2, "truncated");
    expect_error("cut_end.png", data, size - 6, NULL);
    free(data);
}

/* Every prefix and many random corruptions of valid PNG, JPEG and PFM files either read or fail
 * cleanly (no crash, no leak under make check, no half-filled image, a reason naming the file). */
static void fuzz_file(const char *source, const char *path, hd_rng *rng, int flips)
{
    char *data;
    size_t size;
    if (hd_read_file(source, 1 << 20, &data, &size) != HD_OK) {
        CHECK(!"cannot read the fuzz source");
        return;
    }
    int failures = 0;
    for (int trial = 0; trial < (int)size + flips; trial++) {
        size_t n = size;
        char *copy = malloc(size);
        memcpy(copy, data, size);
        if (trial < (int)size) {
            n = (size_t)trial; /* every prefix */
        } else {
            int k = 1 + (int)hd_rng_below(rng, 4);
            for (int i = 0; i < k; i++) copy[hd_rng_below(rng, (uint32_t)size)] = (char)hd_rng_u32(rng);
        }
        remove(path); /* a fresh file: overwriting in place makes ext4 flush on every close */
        FILE *f = fopen(path, "wb");
        fwrite(copy, 1, n, f);
        fclose(f);
        free(copy);
        hd_image img = {0};
        if (hd_image_read(path, &img) == HD_OK) {
            CHECK(img.data && img.width > 0 && img.height > 0);
        } else {
            failures++;
            CHECK(img.data == NULL);
            CHECK(strstr(hd_error(), path) != NULL);
        }
        hd_image_free(&img);
    }
    CHECK(failures >= (int)size - 1); /* at least every strict prefix fails */
    free(data);
}

/* Contact sheets (io/sheet.c): the canvas size, each kind's display colours, the border, errors, the PNG. */
static void test_sheet(void)
{
    hd_sheet sheet;
    CHECK(hd_sheet_init(&sheet, 2, 3, 8, 2) == HD_OK);
    CHECK(sheet.canvas.width == 3 * 10 + 2 && sheet.canvas.height == 2 * 10 + 2 && sheet.canvas.channels == 3);
    hd_image gray = {0}, nrm = {0}, shade = {0};
    CHECK(hd_image_alloc(&gray, 8, 8, 1) == HD_OK && hd_image_alloc(&nrm, 4, 4, 3) == HD_OK &&
          hd_image_alloc(&shade, 16, 16, 1) == HD_OK);
    for (int p = 0; p < 64; p++) gray.data[p] = 0.4f;
    for (int p = 0; p < 16; p++) nrm.data[2 * 16 + p] = 1.0f; /* (0, 0, 1) */
    nrm.data[0] = 1.0f, nrm.data[2 * 16] = 0.0f;              /* texel (0,0): (1, 0, 0) */
    for (int p = 0; p < 256; p++) shade.data[p] = 1.0f;
    CHECK(hd_sheet_put(&sheet, 0, 0, &gray, HD_SHEET_PICTURE) == HD_OK);
    CHECK(hd_sheet_put(&sheet, 1, 2, &nrm, HD_SHEET_NORMAL) == HD_OK);
    CHECK(hd_sheet_put(&sheet, 0, 1, &shade, HD_SHEET_SHADING) == HD_OK);
    const int W = sheet.canvas.width, H = sheet.canvas.height;
#define AT(c, x, y) sheet.canvas.data[((size_t)(c) * H + (y)) * W + (x)]
    for (int c = 0; c < 3; c++) {
        CHECK_NEAR(AT(c, 2 + 3, 2 + 3), 0.4f, 1e-6);          /* gray shown gray */
        CHECK_NEAR(AT(c, 12 + 3, 2 + 3), 0.5f, 1e-6);         /* shading 1 shown as 0.5 */
        CHECK_NEAR(AT(c, 0, 0), AT(c, 1, 21), 0);             /* border colour everywhere */
        CHECK(AT(c, 1, 1) < 0.3f);
    }
    /* normal (0,0,1) -> (0.5, 0.5, 1) far from the odd texel */
    CHECK_NEAR(AT(0, 22 + 7, 12 + 7), 0.5f, 1e-6);
    CHECK_NEAR(AT(2, 22 + 7, 12 + 7), 1.0f, 1e-6);
#undef AT
    CHECK(hd_sheet_put(&sheet, 2, 0, &gray, HD_SHEET_PICTURE) == HD_ERR_ARG);
    CHECK(hd_sheet_put(&sheet, 0, 0, &gray, HD_SHEET_NORMAL) == HD_ERR_ARG);
    CHECK(hd_sheet_write(&sheet, "sheet.png") == HD_OK);
    hd_image back = {0};
    CHECK(hd_image_read("sheet.png", &back) == HD_OK);
    CHECK(back.width == W && back.height == H && back.channels == 3);
    if (back.data) CHECK_NEAR(back.data[(size_t)(2 + 3) * W + 2 + 3], 0.4f, 1.0 / 255);
    hd_image_free(&back);
    hd_sheet_free(&sheet);
    CHECK(hd_sheet_init(&sheet, 0, 3, 8, 2) == HD_ERR_ARG);
    hd_image_free(&gray);
    hd_image_free(&nrm);
    hd_image_free(&shade);
}

/* hd_normal_resize: every pixel of the result unit length (blends of unit vectors are shorter) in
 * the direction of the plain resize, zero vectors stay zero; hd_normal_renormalise alone on
 * vectors of length 2; a 1-channel map is refused. */
static void test_normal_resize(void)
{
    hd_image n = {0}, r = {0}, plain = {0}, gray = {0};
    CHECK(hd_image_alloc(&n, 4, 4, 3) == HD_OK);
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 4; x++) {
            size_t p = (size_t)y * 4 + x;
            if (y == 3) continue;                  /* row 3: no normal (0, 0, 0) */
            n.data[(x < 2 ? 0 : 16) + p] = 1.0f;   /* left half (1, 0, 0), right half (0, 1, 0) */
        }
    CHECK(hd_normal_resize(&n, 9, 9, &r) == HD_OK && hd_image_resize(&n, 9, 9, &plain) == HD_OK);
    int blended = 0;
    for (size_t p = 0; r.data && p < 81; p++) {
        double lp = sqrt(pow(plain.data[p], 2) + pow(plain.data[81 + p], 2) + pow(plain.data[162 + p], 2));
        double lr = sqrt(pow(r.data[p], 2) + pow(r.data[81 + p], 2) + pow(r.data[162 + p], 2));
        if (lp <= 1e-6) {
            CHECK(lr == 0);
            continue;
        }
        CHECK_NEAR(lr, 1.0, 1e-6);
        for (int c = 0; c < 3; c++) CHECK_NEAR(r.data[c * 81 + p], plain.data[c * 81 + p] / lp, 1e-6);
        blended += lp < 0.99;
    }
    CHECK(blended > 0); /* the resize did blend the two halves (and the empty row) */
    for (size_t i = 0; i < 48; i++) n.data[i] = i < 16 ? 0.0f : i < 32 ? 0.0f : 2.0f; /* (0, 0, 2) */
    hd_normal_renormalise(&n);
    for (size_t p = 0; p < 16; p++) CHECK(n.data[p] == 0 && n.data[16 + p] == 0 && n.data[32 + p] == 1.0f);
    CHECK(hd_image_alloc(&gray, 4, 4, 1) == HD_OK);
    hd_image_free(&r);
    CHECK(hd_normal_resize(&gray, 8, 8, &r) == HD_ERR_ARG && r.data == NULL);
    hd_image_free(&n);
    hd_image_free(&r);
    hd_image_free(&plain);
    hd_image_free(&gray);
}

static void test_fuzz(void)
{
    hd_rng rng;
    hd_rng_seed(&rng, 6, 1);
    hd_image img = {0};
    CHECK(hd_image_alloc(&img, 6, 5, 3) == HD_OK);
    fill_random(&img, &rng);
    CHECK(hd_image_write_png("fz.png", &img, 16) == HD_OK);
    CHECK(hd_image_write_pfm("fz.pfm", &img) == HD_OK);
    hd_image_free(&img);
    fuzz_file("fz.png", "fuzz.png", &rng, 400);
    fuzz_file("fz.pfm", "fuzz.pfm", &rng, 200);
    fuzz_file("smooth.jpg", "fuzz.jpg", &rng, 400);
}

int main(void)
{
    test_png_round_trips();
    test_png_variants();
    test_png_interlaced();
    test_jpeg();
    test_pfm();
    test_resize();
    test_normals();
    test_errors();
    test_sheet();
    test_normal_resize();
    test_fuzz();
    return test_summary("test_image");
}
