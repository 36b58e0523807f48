/* lights.c: the target light of a `hdnet serve` request (and its background mode), in the three forms `hdnet relight` takes
 * (9 coefficients, a preset, a direction with intensity and ambient; a preset or a direction by
 * the same builder, tools/light_words.c, so the same checks and the same light), from a JSON body or a URL query, and a light as a DPR-style text file. */
#include <cjson/cJSON.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "../light_words.h"
#include "serve.h"

/* A finite number from a JSON item, or a refusal naming the key. */
static hd_status json_number(const cJSON *item, const char *key, float *v, char *reason, size_t size)
{
    if (!cJSON_IsNumber(item) || !isfinite(item->valuedouble) || fabs(item->valuedouble) > 1e6)
        return cli_refuse(reason, size, "\"%s\" must be a finite number", key);
    *v = (float)item->valuedouble;
    return HD_OK;
}

/* The grey light of a direction or a preset, by the builder `hdnet light` and `hdnet relight` use
 * (tools/light_words.c: the same checks, the same light); intensity and ambient NULL: the defaults. */
static hd_status from_words(float az, float el, const float *intensity, const float *ambient, int preset,
                            float light[HD_SH_COEFFS], char *reason, size_t size)
{
    cli_light_words w = cli_light_words_none();
    if (preset == INT_MIN) w.dir_count = 2, w.dir[0] = az, w.dir[1] = el;
    w.preset = preset;
    if (intensity) w.intensity = *intensity;
    if (ambient) w.ambient = *ambient;
    hd_light_rgb rgb;
    hd_status st = cli_light_from_words(&w, &rgb, reason, size);
    if (st == HD_OK) memcpy(light, rgb.sh[0], sizeof rgb.sh[0]);
    else if (!reason[0]) snprintf(reason, size, "%s", hd_error());
    return st;
}

hd_status serve_background_from_word(const char *word, hd_background *background, char *reason, size_t size)
{
    if (word && strcmp(word, "keep") == 0) *background = HD_BACKGROUND_KEEP;
    else if (word && strcmp(word, "relight") == 0) *background = HD_BACKGROUND_RELIGHT;
    else return cli_refuse(reason, size, "\"background\" is \"keep\" (the default) or \"relight\" (as hdnet relight --background)");
    return HD_OK;
}

hd_status serve_light_from_json(const char *body, size_t n, float light[HD_SH_COEFFS], hd_brightness *brightness,
                             hd_background *background, char *reason, size_t size)
{
    *brightness = HD_BRIGHTNESS_KEEP;
    *background = HD_BACKGROUND_KEEP;
    if (n == 0) return cli_refuse(reason, size, "the body is empty: send a JSON light");
    cJSON *root = cJSON_ParseWithLength(body, n);
    if (!root || !cJSON_IsObject(root)) {
        cJSON_Delete(root);
        return cli_refuse(reason, size, "the body is not a JSON object");
    }
    hd_status st = HD_OK;
    const cJSON *coeffs = cJSON_GetObjectItemCaseSensitive(root, "light");
    const cJSON *preset = cJSON_GetObjectItemCaseSensitive(root, "preset");
    const cJSON *az = cJSON_GetObjectItemCaseSensitive(root, "azimuth");
    const cJSON *el = cJSON_GetObjectItemCaseSensitive(root, "elevation");
    const cJSON *in = cJSON_GetObjectItemCaseSensitive(root, "intensity");
    const cJSON *am = cJSON_GetObjectItemCaseSensitive(root, "ambient");
    const cJSON *br = cJSON_GetObjectItemCaseSensitive(root, "brightness");
    const cJSON *bg = cJSON_GetObjectItemCaseSensitive(root, "background");
    const int forms = (coeffs != NULL) + (preset != NULL) + (az != NULL || el != NULL);
    if (forms != 1) {
        st = cli_refuse(reason, size, "give exactly one of \"light\" (9 numbers), \"preset\" (0..%d) and "
                    "\"azimuth\" with \"elevation\"", HD_LIGHT_PRESETS - 1);
    } else if (coeffs) {
        if (!cJSON_IsArray(coeffs) || cJSON_GetArraySize(coeffs) != HD_SH_COEFFS)
            st = cli_refuse(reason, size, "\"light\" must be an array of %d numbers", HD_SH_COEFFS);
        for (int k = 0; k < HD_SH_COEFFS && st == HD_OK; k++)
            st = json_number(cJSON_GetArrayItem(coeffs, k), "light", &light[k], reason, size);
    } else if (preset) {
        if (!cJSON_IsNumber(preset) || preset->valuedouble != floor(preset->valuedouble) || preset->valuedouble < 0 ||
            preset->valuedouble >= HD_LIGHT_PRESETS)
            st = cli_refuse(reason, size, "\"preset\" must be an integer in 0..%d", HD_LIGHT_PRESETS - 1);
        else
            st = from_words(0, 0, NULL, NULL, (int)preset->valuedouble, light, reason, size);
    } else {
        float a = 0, e = 0, i = 0, m = 0;
        if (!az || !el) st = cli_refuse(reason, size, "\"azimuth\" and \"elevation\" go together");
        if (st == HD_OK) st = json_number(az, "azimuth", &a, reason, size);
        if (st == HD_OK) st = json_number(el, "elevation", &e, reason, size);
        if (st == HD_OK && in) st = json_number(in, "intensity", &i, reason, size);
        if (st == HD_OK && am) st = json_number(am, "ambient", &m, reason, size);
        if (st == HD_OK) st = from_words(a, e, in ? &i : NULL, am ? &m : NULL, INT_MIN, light, reason, size);
    }
    if (st == HD_OK && (in || am) && !(az || el))
        st = cli_refuse(reason, size, "\"intensity\" and \"ambient\" go with \"azimuth\" and \"elevation\"");
    if (st == HD_OK && br) {
        if (cJSON_IsString(br) && strcmp(br->valuestring, "keep") == 0) *brightness = HD_BRIGHTNESS_KEEP;
        else if (cJSON_IsString(br) && strcmp(br->valuestring, "free") == 0) *brightness = HD_BRIGHTNESS_FREE;
        else st = cli_refuse(reason, size, "\"brightness\" is \"keep\" or \"free\"");
    }
    if (st == HD_OK && bg) st = serve_background_from_word(cJSON_IsString(bg) ? bg->valuestring : NULL, background, reason, size);
    cJSON_Delete(root);
    return st;
}

/* A finite number from a query value. */
static hd_status query_number(const char *s, const char *key, float *v, char *reason, size_t size)
{
    char *end = NULL;
    double d = s ? strtod(s, &end) : NAN;
    if (!s || end == s || *end || !isfinite(d) || fabs(d) > 1e6)
        return cli_refuse(reason, size, "%s must be a finite number", key);
    *v = (float)d;
    return HD_OK;
}

hd_status serve_light_from_query(const char *preset, const char *azimuth, const char *elevation, const char *intensity,
                              const char *ambient, float light[HD_SH_COEFFS], char *reason, size_t size)
{
    if ((preset != NULL) == (azimuth != NULL || elevation != NULL))
        return cli_refuse(reason, size, "give preset=K or azimuth=AZ&elevation=EL");
    if (preset) {
        char *end = NULL;
        long k = strtol(preset, &end, 10);
        if (end == preset || *end || k < 0 || k >= HD_LIGHT_PRESETS)
            return cli_refuse(reason, size, "preset must be 0..%d", HD_LIGHT_PRESETS - 1);
        return from_words(0, 0, NULL, NULL, (int)k, light, reason, size);
    }
    float a, e, i, m;
    hd_status st = query_number(azimuth, "azimuth", &a, reason, size);
    if (st == HD_OK) st = query_number(elevation, "elevation", &e, reason, size);
    if (st == HD_OK && intensity) st = query_number(intensity, "intensity", &i, reason, size);
    if (st == HD_OK && ambient) st = query_number(ambient, "ambient", &m, reason, size);
    if (st == HD_OK) st = from_words(a, e, intensity ? &i : NULL, ambient ? &m : NULL, INT_MIN, light, reason, size);
    return st;
}

char *serve_light_text(const float light[HD_SH_COEFFS])
{
    char *text = malloc(HD_SH_COEFFS * 24 + 1);
    if (!text) return NULL;
    size_t at = 0;
    for (int k = 0; k < HD_SH_COEFFS; k++) at += (size_t)snprintf(text + at, 24, "%.9g\n", (double)light[k]);
    return text;
}
