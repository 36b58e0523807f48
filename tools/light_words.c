/* light_words.c: a light from the user's words (light_words.h): the checks every command that
 * takes --dir, --preset or --env makes, in one place, and the library calls that build the light. */
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include "light_words.h"

cli_light_words cli_light_words_none(void)
{
    return (cli_light_words){.intensity = NAN, .ambient = NAN, .preset = INT_MIN};
}

cli_light_words cli_light_words_of(const cli_opt_floats *dir, float intensity, float ambient, const cli_opt_floats *colour,
                                   int preset, const char *env, float rotate)
{
    cli_light_words w = cli_light_words_none();
    w.dir_count = dir->count;
    for (int i = 0; i < dir->count && i < 2; i++) w.dir[i] = dir->v[i];
    w.colour_count = colour->count;
    for (int c = 0; c < colour->count && c < 3; c++) w.colour[c] = colour->v[c];
    w.intensity = intensity, w.ambient = ambient, w.preset = preset, w.env = env, w.rotate = rotate;
    return w;
}

int cli_light_words_forms(const cli_light_words *w)
{
    return (w->dir_count > 0) + (w->preset != INT_MIN) + (w->env != NULL);
}

hd_status cli_refuse(char *reason, size_t size, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(reason, size, fmt, ap);
    va_end(ap);
    return HD_ERR_ARG;
}

hd_status cli_light_words_check(const cli_light_words *w, char *reason, size_t size)
{
    if (size) reason[0] = 0;
    if (cli_light_words_forms(w) > 1) return cli_refuse(reason, size, "give exactly one of --dir, --preset and --env");
    if (w->colour_count && (w->dir_count == 0 || w->colour_count != 3))
        return cli_refuse(reason, size, "--colour wants R,G,B and goes with --dir");
    for (int c = 0; c < w->colour_count; c++)
        if (!(w->colour[c] >= 0 && isfinite(w->colour[c]))) return cli_refuse(reason, size, "--colour factors are >= 0");
    if (w->rotate != 0.0f && !w->env) return cli_refuse(reason, size, "--rotate goes with --env");
    if (!isfinite(w->rotate)) return cli_refuse(reason, size, "--rotate must be a finite number of degrees");
    if (w->dir_count == 0 && (!isnan(w->intensity) || !isnan(w->ambient)))
        return cli_refuse(reason, size, "--intensity and --ambient go with --dir");
    if (w->dir_count > 0) {
        if (w->dir_count != 2) return cli_refuse(reason, size, "--dir wants two numbers AZ,EL");
        if (!isfinite(w->dir[0])) return cli_refuse(reason, size, "the azimuth must be a finite number of degrees");
        if (!(w->dir[1] >= -90.0f && w->dir[1] <= 90.0f))
            return cli_refuse(reason, size, "the elevation must be in -90..90 degrees, got %g", (double)w->dir[1]);
        if (w->intensity < 0.0f || w->ambient < 0.0f || isinf(w->intensity) || isinf(w->ambient))
            return cli_refuse(reason, size, "--intensity and --ambient must not be negative");
    }
    if (w->preset != INT_MIN && (w->preset < 0 || w->preset >= HD_LIGHT_PRESETS))
        return cli_refuse(reason, size, "--preset must be in 0..%d, got %d", HD_LIGHT_PRESETS - 1, w->preset);
    return HD_OK;
}

hd_status cli_light_from_words(const cli_light_words *w, hd_light_rgb *light, char *reason, size_t size)
{
    hd_status st = cli_light_words_check(w, reason, size);
    if (st != HD_OK) return st;
    if (cli_light_words_forms(w) != 1) return cli_refuse(reason, size, "give exactly one of --dir, --preset and --env");
    if (w->dir_count > 0) {
        const float white[3] = {1, 1, 1};
        hd_light_rgb_from_direction(w->dir[0], w->dir[1], isnan(w->intensity) ? HD_LIGHT_DEFAULT_INTENSITY : w->intensity,
                                    isnan(w->ambient) ? HD_LIGHT_DEFAULT_AMBIENT : w->ambient,
                                    w->colour_count ? w->colour : white, light);
        return HD_OK;
    }
    if (w->env) {
        hd_image map = {0};
        st = hd_image_read_as(w->env, 3, &map);
        if (st == HD_OK) st = hd_light_from_envmap(&map, w->rotate, light);
        hd_image_free(&map);
        return st;
    }
    float grey[HD_SH_COEFFS];
    if ((st = hd_light_preset(w->preset, grey)) != HD_OK) return st;
    hd_light_rgb_from_grey(grey, light);
    return HD_OK;
}
