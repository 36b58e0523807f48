/* cmd_light.c: `hdnet light`: make a light file from a direction (with a colour), a preset or an
 * environment map, show a light file (grey or RGB) on a sphere, or draw all presets side by side
 * (docs/conventions.md explains the direction convention and the presets; docs/img/presets.png is
 * made with `hdnet light --presets`). */
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include "cli.h"
#include "light_words.h"

CLI_COMMAND("light", cmd_light, "make a light file (direction or preset) or show one on a sphere")

/* Writes the sphere picture of light to path (8-bit PNG). */
static int write_sphere(const hd_light_rgb *light, int size, const char *path)
{
    hd_image sphere = {0};
    if (hd_light_rgb_sphere(light, size, &sphere) != HD_OK || hd_image_write_png(path, &sphere, 8) != HD_OK) {
        hd_image_free(&sphere);
        return cli_report("light");
    }
    hd_image_free(&sphere);
    return CLI_EXIT_OK;
}

/* Writes the HD_LIGHT_PRESETS preset spheres side by side (preset 0 on the left) to path. */
static int write_presets(int size, const char *path)
{
    hd_image row = {0}, sphere = {0};
    float light[HD_SH_COEFFS];
    if (hd_image_alloc(&row, size * HD_LIGHT_PRESETS, size, 3) != HD_OK) return cli_report("light");
    for (int k = 0; k < HD_LIGHT_PRESETS; k++) {
        if (hd_light_preset(k, light) != HD_OK || hd_light_sphere(light, size, &sphere) != HD_OK) {
            hd_image_free(&row);
            return cli_report("light");
        }
        for (int c = 0; c < 3; c++)
            for (int y = 0; y < size; y++)
                for (int x = 0; x < size; x++)
                    row.data[((size_t)c * size + y) * row.width + (size_t)k * size + x] =
                        sphere.data[((size_t)c * size + y) * size + x];
        hd_image_free(&sphere);
    }
    int rc = hd_image_write_png(path, &row, 8) == HD_OK ? CLI_EXIT_OK : cli_report("light");
    hd_image_free(&row);
    return rc;
}

int cmd_light(int argc, char **argv)
{
    cli_opt_floats dir = {.max = 2}, colour = {.max = 3};
    int preset = INT_MIN, size = 256, presets = 0, quiet = 0;
    float intensity = NAN, ambient = NAN, rotate = 0.0f;
    const char *show = NULL, *out = NULL, *preview = NULL, *env = NULL;
    static char intensity_help[96], ambient_help[96];
    snprintf(intensity_help, sizeof intensity_help, "strength of the directional light (default %g)",
             (double)HD_LIGHT_DEFAULT_INTENSITY);
    snprintf(ambient_help, sizeof ambient_help, "constant shading added everywhere (default %g)",
             (double)HD_LIGHT_DEFAULT_AMBIENT);
    const cli_opt opts[] = {
        {"dir", 0, CLI_OPT_FLOATS, &dir, "AZ,EL",
         "light from azimuth AZ and elevation EL in degrees (0,0 = from the viewer; AZ > 0 right, EL > 0 up)"},
        {"intensity", 0, CLI_OPT_FLOAT, &intensity, "I", intensity_help},
        {"ambient", 0, CLI_OPT_FLOAT, &ambient, "A", ambient_help},
        {"colour", 0, CLI_OPT_FLOATS, &colour, "R,G,B", "with --dir: the light's colour (linear factors; an RGB light file)"},
        {"env", 0, CLI_OPT_STRING, &env, "MAP.pfm", "the light of an equirectangular environment map (RGB light file)"},
        {"rotate", 0, CLI_OPT_FLOAT, &rotate, "DEG", "with --env: turn the map about the vertical axis (default 0)"},
        {"preset", 0, CLI_OPT_INT, &preset, "K", "built-in light K in 0..6 (a light circling the view axis)"},
        {"presets", 0, CLI_OPT_FLAG, &presets, NULL, "draw all presets side by side (0 on the left) into -o"},
        {"show", 0, CLI_OPT_STRING, &show, "LIGHT.txt", "draw this light file on a sphere into -o"},
        {"output", 'o', CLI_OPT_STRING, &out, "FILE", "the light file written (with --show, --presets: the PNG)"},
        {"preview", 0, CLI_OPT_STRING, &preview, "SPHERE.png", "also draw the light on a sphere"},
        {"size", 0, CLI_OPT_INT, &size, "N", "side of the sphere picture in pixels (default 256)"},
        CLI_OPT_QUIET_ROW(quiet),
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const cli_cmd_spec spec = {
        "light",
        "(--dir AZ,EL [--intensity I] [--ambient A] [--colour R,G,B] | --preset K | --env MAP [--rotate DEG])\n"
        "       -o light.txt [--preview sphere.png]\n"
        "       hdnet light --show light.txt -o sphere.png [--size N]\n"
        "       hdnet light --presets -o presets.png [--size N]",
        "Writes a light file of 9 spherical-harmonics coefficients (DPR's order and scale) for a\n"
        "distant light plus ambient, or for a built-in preset; or draws a light file on a unit sphere\n"
        "seen from the front (shown as shading/2, so shading up to 2 is not clipped). A coloured light\n"
        "(--colour, --env) is written as 27 numbers: red's 9, green's, blue's (docs/formats.md).",
        opts, 0, 0};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    free(pos);

    const int modes = (dir.count > 0) + (preset != INT_MIN) + (show != NULL) + presets + (env != NULL);
    if (modes != 1) return cli_usage_error(&spec, "give exactly one of --dir, --preset, --env, --show and --presets");
    const cli_light_words words = cli_light_words_of(&dir, intensity, ambient, &colour, preset, env, rotate);
    char why[200];
    if (cli_light_words_check(&words, why, sizeof why) != HD_OK) return cli_usage_error(&spec, "%s", why);
    if (!out) return cli_usage_error(&spec, "-o is required");
    if (size < 1 || size > 4096) return cli_usage_error(&spec, "--size must be in 1..4096, got %d", size);
    if ((show || presets) && preview)
        return cli_usage_error(&spec, "--preview goes with --dir or --preset (--show and --presets write -o)");
    if (presets) {
        int rc = write_presets(size, out);
        if (rc == CLI_EXIT_OK && !quiet) printf("wrote %s\n", out);
        return rc;
    }

    hd_light_rgb light;
    if (show) {
        if (hd_light_read_rgb(show, &light) != HD_OK) return cli_report("light");
        int rc = write_sphere(&light, size, out);
        if (rc == CLI_EXIT_OK && !quiet) printf("wrote %s\n", out);
        return rc;
    }
    if (cli_light_from_words(&words, &light, why, sizeof why) != HD_OK)
        return why[0] ? cli_usage_error(&spec, "%s", why) : cli_report("light");
    if (hd_light_write_rgb(out, &light) != HD_OK) return cli_report("light");
    if (!quiet) printf("wrote %s\n", out);
    if (preview) {
        int rc = write_sphere(&light, size, preview);
        if (rc == CLI_EXIT_OK && !quiet) printf("wrote %s\n", preview);
        return rc;
    }
    return CLI_EXIT_OK;
}
