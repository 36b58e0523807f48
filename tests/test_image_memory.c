/* test_image_memory.c: images in memory and the writer's choice of format. Decoding a buffer gives
 * exactly what reading the file gives (PNG 8 and 16 bit, JPEG, PFM), with the same info; encoding
 * gives exactly the bytes the file writer puts on disk; PNG and PFM round trips are exact, JPEG's
 * close, and its quality matters; the extension chooses PNG, JPEG or PFM and any other is an error
 * that writes nothing; broken buffers fail naming "<memory>". EXIF orientation: one JPEG of four
 * coloured quadrants, with an APP1 segment carrying each orientation tag 1-8 spliced in (both byte
 * orders), reads upright: the size and the colour at each corner as the EXIF specification's table
 * says, and every pixel equal to the untagged image turned by hand; a malformed tag reads as stored. */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "test.h"
#include "hdnet.h"
#include "io/image_io.h"

static unsigned char *slurp(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *d = malloc(n > 0 ? (size_t)n : 1);
    *size = fread(d, 1, (size_t)n, f);
    fclose(f);
    return d;
}

static int same_image(const hd_image *a, const hd_image *b)
{
    return a->width == b->width && a->height == b->height && a->channels == b->channels &&
           memcmp(a->data, b->data, (size_t)a->width * a->height * a->channels * sizeof(float)) == 0;
}

/* A test picture: smooth gradients plus a few sharp values, w x h x c. */
static void make_picture(hd_image *im, int w, int h, int c)
{
    hd_image_alloc(im, w, h, c);
    for (int k = 0; k < c; k++)
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++)
                im->data[((size_t)k * h + y) * w + x] = (float)((x * 7 + y * 3 + k * 50) % 256) / 255.0f;
}

/* Writes with the file writer, reads the file back as bytes, encodes to memory: same bytes; decodes
 * the buffer and reads the file: same image. Returns the decoded image. */
static void check_format(const char *path, const hd_image *im, hd_image_format format, int quality, hd_image *back)
{
    CHECK(hd_image_write(path, im, quality) == HD_OK);
    size_t fsize = 0, msize = 0;
    unsigned char *file = slurp(path, &fsize), *mem = NULL;
    CHECK(hd_image_encode(im, format, quality, &mem, &msize) == HD_OK);
    CHECK(file && mem && fsize == msize && fsize > 0 && memcmp(file, mem, fsize) == 0);
    hd_image a = {0}, b = {0};
    hd_image_info ia, ib;
    CHECK(hd_image_read_info(path, &a, &ia) == HD_OK);
    CHECK(hd_image_decode(mem, msize, &b, &ib) == HD_OK);
    CHECK(same_image(&a, &b) && strcmp(ia.format, ib.format) == 0 && ia.bits == ib.bits && ia.channels == ib.channels);
    printf("%-10s %dx%dx%d: %zu bytes, file and buffer the same bytes, decoded the same\n", path, im->width, im->height,
           im->channels, msize);
    free(file);
    hd_buffer_free(mem);
    hd_image_free(&a);
    *back = b;
}

static void test_formats(void)
{
    hd_image im = {0}, back = {0};
    make_picture(&im, 37, 23, 3);
    /* PNG: exact at 8 bits */
    check_format("a.png", &im, HD_FORMAT_PNG, 0, &back);
    CHECK(same_image(&back, &im)); /* values are multiples of 1/255 */
    hd_image_free(&back);
    /* PFM: exact floats */
    for (size_t i = 0; i < (size_t)37 * 23 * 3; i++) im.data[i] += 1e-4f * (float)(i % 7);
    check_format("a.pfm", &im, HD_FORMAT_PFM, 0, &back);
    CHECK(same_image(&back, &im));
    hd_image_free(&back);
    /* JPEG (upper case extension): close at 95, quality changes the size */
    check_format("a.JPG", &im, HD_FORMAT_JPEG, 0, &back);
    double err = 0;
    for (size_t i = 0; i < (size_t)37 * 23 * 3; i++) err += fabsf(back.data[i] - im.data[i]);
    err /= 37 * 23 * 3;
    CHECK(err < 0.05); /* the picture's sawtooth edges are JPEG's worst case */
    hd_image_free(&back);
    unsigned char *q30 = NULL, *q95 = NULL;
    size_t n30 = 0, n95 = 0;
    CHECK(hd_image_encode(&im, HD_FORMAT_JPEG, 30, &q30, &n30) == HD_OK);
    CHECK(hd_image_encode(&im, HD_FORMAT_JPEG, 95, &q95, &n95) == HD_OK);
    printf("JPEG: mean error %.4f at quality 95; %zu bytes at 30, %zu at 95\n", err, n30, n95);
    CHECK(n30 < n95);
    hd_buffer_free(q30);
    hd_buffer_free(q95);
    check_format("b.jpeg", &im, HD_FORMAT_JPEG, 60, &back);
    hd_image_free(&back);
    CHECK(hd_image_encode(&im, HD_FORMAT_JPEG, 101, &q30, &n30) == HD_ERR_ARG && q30 == NULL);
    /* gray 16-bit PNG: the file reader and the buffer decoder agree */
    hd_image gray = {0};
    make_picture(&gray, 20, 30, 1);
    CHECK(hd_image_write_png("g16.png", &gray, 16) == HD_OK);
    size_t n = 0;
    unsigned char *bytes = slurp("g16.png", &n);
    hd_image a = {0}, b = {0};
    hd_image_info ib;
    CHECK(hd_image_read("g16.png", &a) == HD_OK && hd_image_decode(bytes, n, &b, &ib) == HD_OK);
    CHECK(same_image(&a, &b) && ib.bits == 16 && ib.orientation == 1);
    hd_image_free(&a);
    hd_image_free(&b);
    free(bytes);
    hd_image_free(&gray);

    /* The extension chooses; any other is an error naming the path, and nothing is written. */
    static const char *const bad[] = {"out.tif", "out", "out.png.bak", "dir.png/out", ".png"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        hd_status st = hd_image_write_picture(bad[i], &im);
        CHECK(st == HD_ERR_ARG && strstr(hd_error(), bad[i]) && access(bad[i], F_OK) != 0);
        if (i == 0) printf("write out.tif: %s\n", hd_error());
    }
    hd_image_format f;
    CHECK(hd_image_format_of("x/y.Jpeg", &f) == HD_OK && f == HD_FORMAT_JPEG);
    CHECK(hd_image_format_of("x.y/z.PFM", &f) == HD_OK && f == HD_FORMAT_PFM);

    /* Broken buffers fail naming <memory>. */
    unsigned char *png = NULL;
    size_t npng = 0;
    CHECK(hd_image_encode(&im, HD_FORMAT_PNG, 0, &png, &npng) == HD_OK);
    CHECK(hd_image_decode(png, npng / 2, &a, NULL) == HD_ERR_FORMAT && strstr(hd_error(), "<memory>") && !a.data);
    CHECK(hd_image_decode(png, 0, &a, NULL) == HD_ERR_FORMAT && strstr(hd_error(), "empty"));
    CHECK(hd_image_decode("GIF89a..", 8, &a, NULL) == HD_ERR_FORMAT && strstr(hd_error(), "unknown image format"));
    hd_buffer_free(png);
    hd_image_free(&im);
}

/* An APP1 "Exif" segment with one IFD entry, orientation o, in byte order little or big. */
static size_t exif_segment(unsigned char *seg, int o, int little)
{
    unsigned char tiff[26];
    memset(tiff, 0, sizeof tiff);
#define P16(at, v) (little ? (tiff[at] = (unsigned char)(v), tiff[at + 1] = (unsigned char)((v) >> 8)) \
                           : (tiff[at] = (unsigned char)((v) >> 8), tiff[at + 1] = (unsigned char)(v)))
#define P32(at, v) (little ? (P16(at, (v) & 0xffff), P16(at + 2, (v) >> 16)) : (P16(at, (v) >> 16), P16(at + 2, (v) & 0xffff)))
    tiff[0] = tiff[1] = little ? 'I' : 'M';
    P16(2, 42);
    P32(4, 8);      /* IFD0 at 8 */
    P16(8, 1);      /* one entry */
    P16(10, 0x0112); /* orientation */
    P16(12, 3);     /* SHORT */
    P32(14, 1);     /* count 1 */
    P16(18, o);     /* value */
    P32(22, 0);     /* no next IFD */
#undef P16
#undef P32
    size_t len = 2 + 6 + sizeof tiff;
    seg[0] = 0xFF;
    seg[1] = 0xE1;
    seg[2] = (unsigned char)(len >> 8);
    seg[3] = (unsigned char)len;
    memcpy(seg + 4, "Exif\0\0", 6);
    memcpy(seg + 10, tiff, sizeof tiff);
    return 2 + len;
}

static void test_exif(void)
{
    /* 48 x 32, quadrants: top-left red, top-right green, bottom-left blue, bottom-right white */
    enum { W = 48, H = 32 };
    static const float colours[4][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
    hd_image im = {0};
    hd_image_alloc(&im, W, H, 3);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int c = 0; c < 3; c++) im.data[((size_t)c * H + y) * W + x] = colours[(y >= H / 2) * 2 + (x >= W / 2)][c];
    unsigned char *jpg = NULL;
    size_t n = 0;
    CHECK(hd_image_encode(&im, HD_FORMAT_JPEG, 95, &jpg, &n) == HD_OK);
    hd_image plain = {0};
    CHECK(hd_image_decode(jpg, n, &plain, NULL) == HD_OK);
    /* EXIF's table: which stored corner is shown top-left, top-right, bottom-left (0 TL, 1 TR, 2 BL, 3 BR) */
    static const int shown[9][3] = {{0}, {0, 1, 2}, {1, 0, 3}, {3, 2, 1}, {2, 3, 0}, {0, 2, 1}, {2, 0, 3}, {3, 1, 2}, {1, 3, 0}};
    unsigned char *tagged = malloc(n + 64);
    int ok = 0;
    for (int little = 0; little <= 1; little++)
        for (int o = 1; o <= 8; o++) {
            tagged[0] = 0xFF;
            tagged[1] = 0xD8;
            size_t s = exif_segment(tagged + 2, o, little);
            memcpy(tagged + 2 + s, jpg + 2, n - 2);
            hd_image up = {0}, want = {0};
            hd_image_info info;
            CHECK(hd_image_decode(tagged, n + s, &up, &info) == HD_OK);
            int swap = o >= 5;
            CHECK(up.width == (swap ? H : W) && up.height == (swap ? W : H) && info.orientation == o &&
                  info.width == up.width && info.height == up.height);
            int w = up.width, h = up.height, corner[3][2] = {{2, 2}, {w - 3, 2}, {2, h - 3}};
            int good = 1;
            for (int k = 0; k < 3; k++)
                for (int c = 0; c < 3; c++) {
                    float v = up.data[((size_t)c * h + corner[k][1]) * w + corner[k][0]];
                    if (fabsf(v - colours[shown[o][k]][c]) > 0.1f) good = 0;
                }
            CHECK(good);
            /* every pixel: the untagged decode turned by hand */
            hd_image_alloc(&want, w, h, 3);
            for (int c = 0; c < 3; c++)
                for (int y = 0; y < h; y++)
                    for (int x = 0; x < w; x++) {
                        /* (x, y) shown comes from stored (sx, sy): invert the table with corner geometry */
                        int u = x, v = y, sx, sy;
                        if (swap) u = y, v = x; /* transpose first */
                        int o2 = swap ? (int[]){0, 0, 0, 0, 0, 1, 4, 3, 2}[o] : o;
                        sx = (o2 == 2 || o2 == 3) ? W - 1 - u : u;
                        sy = (o2 == 3 || o2 == 4) ? H - 1 - v : v;
                        want.data[((size_t)c * h + y) * w + x] = plain.data[((size_t)c * H + sy) * W + sx];
                    }
            CHECK(same_image(&up, &want));
            ok += good && same_image(&up, &want);
            hd_image_free(&up);
            hd_image_free(&want);
        }
    printf("EXIF orientations 1-8, both byte orders: %d of 16 upright (size, corners, every pixel)\n", ok);
    /* a tag whose IFD offset points past the segment reads as stored */
    tagged[0] = 0xFF;
    tagged[1] = 0xD8;
    size_t s = exif_segment(tagged + 2, 6, 1);
    tagged[2 + 10 + 4] = 200; /* IFD0 offset 200 > segment */
    memcpy(tagged + 2 + s, jpg + 2, n - 2);
    hd_image up = {0};
    hd_image_info info;
    CHECK(hd_image_decode(tagged, n + s, &up, &info) == HD_OK && info.orientation == 1 && same_image(&up, &plain));
    hd_image_free(&up);
    free(tagged);
    hd_buffer_free(jpg);
    hd_image_free(&plain);
    hd_image_free(&im);
}

int main(void)
{
    test_formats();
    test_exif();
    return test_summary("test_image_memory");
}
