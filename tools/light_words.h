/* light_words.h: a light from the user's words, the one builder behind `hdnet light`, `hdnet
 * relight` and the requests of `hdnet serve`: a direction (--dir AZ,EL with --intensity,
 * --ambient and --colour), a built-in preset (--preset K) or an environment map (--env MAP with
 * --rotate), with one set of checks. */
#ifndef CLI_LIGHT_WORDS_H
#define CLI_LIGHT_WORDS_H

#include <stddef.h>
#include "cli.h"

typedef struct cli_light_words {
    int dir_count;        /* how many numbers --dir gave (0: no --dir) */
    float dir[2];         /* azimuth, elevation in degrees */
    float intensity;      /* NAN: not given (HD_LIGHT_DEFAULT_INTENSITY) */
    float ambient;        /* NAN: not given (HD_LIGHT_DEFAULT_AMBIENT) */
    int colour_count;     /* how many numbers --colour gave (0: white) */
    float colour[3];
    int preset;           /* INT_MIN: no preset */
    const char *env;      /* NULL: no environment map */
    float rotate;         /* degrees, with env */
} cli_light_words;

/* Writes the reason (printf-style) and returns HD_ERR_ARG: a request's words refused (here and in
 * `hdnet serve`'s requests). */
hd_status cli_refuse(char *reason, size_t size, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
/* Nothing given: no direction, preset (INT_MIN) or map; intensity and ambient NAN. */
cli_light_words cli_light_words_none(void);
/* The words of a command's options (preset INT_MIN: not given). */
cli_light_words cli_light_words_of(const cli_opt_floats *dir, float intensity, float ambient, const cli_opt_floats *colour,
                                   int preset, const char *env, float rotate);
/* How many of the three forms (direction, preset, map) the words give. */
int cli_light_words_forms(const cli_light_words *w);
/* The checks alone, made before anything is read: the words give at most one form and each
 * value goes with its form and is in range. HD_ERR_ARG with the reason (in the option names). */
hd_status cli_light_words_check(const cli_light_words *w, char *reason, size_t size);
/* Checks the words and builds the light of the one form they give. On failure, reason is set
 * (in the option names) when the words are wrong, a usage error, and left empty when the map could
 * not be read or used (hd_error() says why). */
hd_status cli_light_from_words(const cli_light_words *w, hd_light_rgb *light, char *reason, size_t size);

#endif /* CLI_LIGHT_WORDS_H */
