/* light_file.c: light files (SPEC section 2): text holding exactly 9 finite numbers separated by
 * white space, in DPR's order (DPR's rotate_light_NN.txt load unchanged), or 27 for a coloured
 * light (docs/formats.md), each of magnitude at most HD_LIGHT_MAX_COEFF. Written one number per
 * line with %.9g (exact for float32), through a temporary file that is renamed. */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "light/light.h"

/* Light files are tiny; anything larger is not one. */
#define LIGHT_FILE_MAX_BYTES 65536

static int is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f'; }

/* Reads up to max numbers into v (*count of them); any other content (more numbers, a word, NaN or
 * infinity, a NUL byte) fails with a reason "PATH:LINE: what is wrong"; *end_line_out is the
 * file's last line. */
static hd_status read_numbers(const char *path, float *v, int max, int *count_out, int *end_line_out)
{
    char *data = NULL;
    size_t size = 0;
    hd_status st = hd_read_file(path, LIGHT_FILE_MAX_BYTES, &data, &size);
    if (st != HD_OK) {
        if (st == HD_ERR_RANGE)
            return hd_fail(HD_ERR_FORMAT, "%s: not a light file (larger than %d bytes)", path, LIGHT_FILE_MAX_BYTES);
        return st;
    }
    int line = 1, count = 0;
    size_t i = 0;
    while (i < size) {
        char c = data[i];
        if (c == '\n') {
            line++;
            i++;
            continue;
        }
        if (is_space(c)) {
            i++;
            continue;
        }
        /* a token: up to the next white space (or NUL, which is never valid) */
        size_t start = i;
        while (i < size && !is_space(data[i]) && data[i] != '\0') i++;
        size_t len = i - start;
        if (len == 0) {
            free(data);
            return hd_fail(HD_ERR_FORMAT, "%s:%d: not a light file (binary data)", path, line);
        }
        char tok[64];
        int shown = len < 40 ? (int)len : 40;
        if (len >= sizeof tok) {
            st = hd_fail(HD_ERR_FORMAT, "%s:%d: '%.*s...' is not a number", path, line, shown, data + start);
            free(data);
            return st;
        }
        memcpy(tok, data + start, len);
        tok[len] = '\0';
        if (count == max) {
            st = hd_fail(HD_ERR_FORMAT, "%s:%d: more than %d numbers (found '%s')", path, line, max, tok);
            free(data);
            return st;
        }
        char *end = NULL;
        errno = 0;
        double d = strtod(tok, &end);
        if (end == tok || *end != '\0') {
            st = hd_fail(HD_ERR_FORMAT, "%s:%d: '%s' is not a number", path, line, tok);
            free(data);
            return st;
        }
        if (!isfinite(d) || !isfinite((float)d)) {
            st = hd_fail(HD_ERR_NUMERIC, "%s:%d: '%s' is not a finite number", path, line, tok);
            free(data);
            return st;
        }
        if (fabs(d) > HD_LIGHT_MAX_COEFF) {
            st = hd_fail(HD_ERR_RANGE, "%s:%d: '%s' is out of range for a light coefficient (|c| <= %g: a larger "
                         "light's shading could overflow)", path, line, tok, (double)HD_LIGHT_MAX_COEFF);
            free(data);
            return st;
        }
        v[count++] = (float)d;
    }
    /* the last line of the file (a final newline does not start a new one) */
    *end_line_out = size > 0 && data[size - 1] == '\n' && line > 1 ? line - 1 : line;
    *count_out = count;
    free(data);
    return HD_OK;
}

hd_status hd_light_read(const char *path, float light[HD_SH_COEFFS])
{
    float v[HD_SH_COEFFS];
    int count = 0, end_line = 1;
    hd_status st = read_numbers(path, v, HD_SH_COEFFS, &count, &end_line);
    if (st != HD_OK) return st;
    if (count < HD_SH_COEFFS)
        return hd_fail(HD_ERR_FORMAT, "%s:%d: the file ends after %d number%s, a light file holds %d", path,
                       end_line, count, count == 1 ? "" : "s", HD_SH_COEFFS);
    memcpy(light, v, sizeof v);
    return HD_OK;
}

hd_status hd_light_write(const char *path, const float light[HD_SH_COEFFS])
{
    for (int k = 0; k < HD_SH_COEFFS; k++)
        if (!isfinite(light[k]))
            return hd_fail(HD_ERR_NUMERIC, "%s: light coefficient %d is not finite (not written)", path, k);
        else if (fabsf(light[k]) > HD_LIGHT_MAX_COEFF)
            return hd_fail(HD_ERR_RANGE, "%s: light coefficient %d (%g) is beyond %g (not written)", path, k,
                           (double)light[k], (double)HD_LIGHT_MAX_COEFF);
    hd_atomic_file af;
    hd_status st = hd_atomic_open(&af, path);
    if (st != HD_OK) return st;
    for (int k = 0; k < HD_SH_COEFFS; k++) fprintf(af.f, "%.9g\n", (double)light[k]);
    return hd_atomic_commit(&af);
}

hd_status hd_light_read_rgb(const char *path, hd_light_rgb *light)
{
    float v[3 * HD_SH_COEFFS];
    int count = 0, end_line = 1;
    hd_status st = read_numbers(path, v, 3 * HD_SH_COEFFS, &count, &end_line);
    if (st != HD_OK) return st;
    if (count == HD_SH_COEFFS) {
        hd_light_rgb_from_grey(v, light);
        return HD_OK;
    }
    if (count != 3 * HD_SH_COEFFS)
        return hd_fail(HD_ERR_FORMAT, "%s:%d: the file ends after %d number%s, a light file holds %d (grey) or %d (RGB)",
                       path, end_line, count, count == 1 ? "" : "s", HD_SH_COEFFS, 3 * HD_SH_COEFFS);
    for (int c = 0; c < 3; c++) memcpy(light->sh[c], v + c * HD_SH_COEFFS, sizeof light->sh[c]);
    return HD_OK;
}

hd_status hd_light_write_rgb(const char *path, const hd_light_rgb *light)
{
    if (hd_light_rgb_is_grey(light)) return hd_light_write(path, light->sh[0]);
    for (int c = 0; c < 3; c++)
        for (int k = 0; k < HD_SH_COEFFS; k++)
            if (!isfinite(light->sh[c][k]))
                return hd_fail(HD_ERR_NUMERIC, "%s: light coefficient %d of channel %d is not finite (not written)",
                               path, k, c);
            else if (fabsf(light->sh[c][k]) > HD_LIGHT_MAX_COEFF)
                return hd_fail(HD_ERR_RANGE, "%s: light coefficient %d of channel %d (%g) is beyond %g (not written)",
                               path, k, c, (double)light->sh[c][k], (double)HD_LIGHT_MAX_COEFF);
    hd_atomic_file af;
    hd_status st = hd_atomic_open(&af, path);
    if (st != HD_OK) return st;
    for (int c = 0; c < 3; c++)
        for (int k = 0; k < HD_SH_COEFFS; k++) fprintf(af.f, "%.9g\n", (double)light->sh[c][k]);
    return hd_atomic_commit(&af);
}
