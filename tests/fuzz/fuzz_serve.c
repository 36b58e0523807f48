/* fuzz_serve.c: libFuzzer harness for what `hdnet serve` parses itself (libmicrohttpd parses the
 * HTTP): the upload's magic sniff, header probe and in-memory decode (tools/serve/image_memory.c),
 * the JSON light of POST .../relight and the query light of GET /api/light.txt
 * (tools/serve/lights.c). The first byte chooses the part; the rest is the body (or, for the
 * query, up to five '\n'-separated values, the second byte saying which are present). Beyond
 * the sanitizers it checks what the server relies on: a probe that passes is the size the
 * decoder produces (the pixel cap is checked on the probe), and every accepted light is finite
 * and within HD_LIGHT_MAX_COEFF. */
#include <math.h>
#include "fuzz_common.h"
#include "../../tools/serve/serve.h"

static void check_light(const float light[HD_SH_COEFFS])
{
    for (int k = 0; k < HD_SH_COEFFS; k++)
        if (!(fabsf(light[k]) <= HD_LIGHT_MAX_COEFF)) abort();
}

static void upload(const unsigned char *d, size_t n)
{
    if (serve_picture_sniff(d, n) == SERVE_PICTURE_UNKNOWN) return;
    long w = 0, h = 0;
    if (serve_picture_probe(d, n, "upload", &w, &h) != HD_OK) return;
    if (w <= 0 || h <= 0) abort();
    if ((double)w * (double)h > 1e6) return; /* the server refuses it here (in double), before decoding */
    hd_image rgb = {0};
    if (serve_picture_decode(d, n, "upload", &rgb) == HD_OK) {
        /* EXIF orientation may swap the sides, never change the count */
        if ((long)rgb.width * rgb.height != w * h || rgb.channels != 3) abort();
        hd_image_free(&rgb);
    }
}

static void json_light(const unsigned char *d, size_t n)
{
    float light[HD_SH_COEFFS];
    hd_brightness b;
    hd_background bg;
    char reason[256];
    if (serve_light_from_json((const char *)d, n, light, &b, &bg, reason, sizeof reason) == HD_OK) {
        check_light(light);
        if (bg != HD_BACKGROUND_KEEP && bg != HD_BACKGROUND_RELIGHT) abort();
    }
}

static void query_light(const unsigned char *d, size_t n)
{
    if (n < 1) return;
    const unsigned present = d[0];
    char *text = malloc(n);
    if (!text) return;
    memcpy(text, d + 1, n - 1);
    text[n - 1] = '\0';
    const char *v[5] = {NULL, NULL, NULL, NULL, NULL};
    char *p = text;
    for (int k = 0; k < 5; k++) {
        char *end = strchr(p, '\n');
        if (end) *end = '\0';
        if (present & (1u << k)) v[k] = p;
        if (!end) break;
        p = end + 1;
    }
    float light[HD_SH_COEFFS];
    char reason[256];
    if (serve_light_from_query(v[0], v[1], v[2], v[3], v[4], light, reason, sizeof reason) == HD_OK) check_light(light);
    free(text);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1) return 0;
    fuzz_folder(); /* the pixel limit */
    switch (data[0] % 3) {
    case 0: upload(data + 1, size - 1); break;
    case 1: json_light(data + 1, size - 1); break;
    default: query_light(data + 1, size - 1); break;
    }
    return 0;
}
