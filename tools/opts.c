/* opts.c: one option table per command drives both the parser and the --help text. */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"

int cli_usage_error(const cli_cmd_spec *spec, const char *fmt, ...)
{
    va_list ap;
    fprintf(stderr, "hdnet %s: usage error: ", spec->name);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fprintf(stderr, "\n(see: hdnet %s --help)\n", spec->name);
    return CLI_EXIT_USAGE;
}

int cli_report(const char *cmd)
{
    fprintf(stderr, "hdnet %s: %s\n", cmd, hd_error());
    return CLI_EXIT_FAIL;
}

int cli_report_photo(const char *cmd, hd_status st, const char *path)
{
    if (st == HD_ERR_NOTFOUND)
        fprintf(stderr, "hdnet %s: %s: no face found (give --aligned if it is an aligned face texture)\n", cmd, path);
    else
        fprintf(stderr, "hdnet %s: %s: %s\n", cmd, path, hd_error());
    return CLI_EXIT_FAIL;
}

void cli_note_mask(const char *cmd, int photo, const char *mask_path, const char *mask_source)
{
    if (!mask_path) return;
    if (photo)
        fprintf(stderr, "hdnet %s: note: --mask is for aligned textures; a photo's faces bring their own\n", cmd);
    else if (mask_source && strcmp(mask_source, mask_path) != 0)
        fprintf(stderr, "hdnet %s: note: used %s beside the image, not --mask %s\n", cmd, mask_source, mask_path);
}

static const char *kind_metavar(const cli_opt *o)
{
    if (o->metavar) return o->metavar;
    switch (o->kind) {
    case CLI_OPT_INT: return "N";
    case CLI_OPT_FLOAT: return "X";
    case CLI_OPT_STRING: return "S";
    case CLI_OPT_FLOATS: return "A,B";
    case CLI_OPT_FLAG: break;
    }
    return "";
}

void cli_opts_help(const cli_cmd_spec *spec, FILE *out)
{
    fprintf(out, "usage: hdnet %s %s\n", spec->name, spec->usage);
    if (spec->description) fprintf(out, "\n%s\n", spec->description);
    fprintf(out, "\noptions:\n");
    for (const cli_opt *o = spec->opts; o && o->name; o++) {
        char left[96];
        int n = 0;
        if (o->short_name) n = snprintf(left, sizeof left, "-%c, ", o->short_name);
        else n = snprintf(left, sizeof left, "    ");
        snprintf(left + n, sizeof left - (size_t)n, "--%s%s%s", o->name, o->kind == CLI_OPT_FLAG ? "" : " ",
                 o->kind == CLI_OPT_FLAG ? "" : kind_metavar(o));
        fprintf(out, "  %-28s %s\n", left, o->help ? o->help : "");
    }
    fprintf(out, "  %-28s %s\n", "-h, --help", "show this help and exit");
}

static int parse_value(const cli_cmd_spec *spec, const cli_opt *o, const char *text)
{
    char *end = NULL;
    errno = 0;
    switch (o->kind) {
    case CLI_OPT_INT: {
        long v = strtol(text, &end, 10);
        if (end == text || *end || errno || v < -2147483647L || v > 2147483647L)
            return cli_usage_error(spec, "--%s wants an integer, got '%s'", o->name, text);
        *(int *)o->value = (int)v;
        return 0;
    }
    case CLI_OPT_FLOAT: {
        float v = strtof(text, &end);
        if (end == text || *end || errno || !isfinite(v))
            return cli_usage_error(spec, "--%s wants a number, got '%s'", o->name, text);
        *(float *)o->value = v;
        return 0;
    }
    case CLI_OPT_STRING:
        *(const char **)o->value = text;
        return 0;
    case CLI_OPT_FLOATS: {
        cli_opt_floats *f = o->value;
        int max = f->max > 0 && f->max <= 16 ? f->max : 16;
        f->count = 0;
        const char *s = text;
        for (;;) {
            if (f->count == max)
                return cli_usage_error(spec, "--%s takes at most %d numbers, got '%s'", o->name, max, text);
            errno = 0;
            float v = strtof(s, &end);
            if (end == s || errno || !isfinite(v))
                return cli_usage_error(spec, "--%s wants comma-separated numbers, got '%s'", o->name, text);
            f->v[f->count++] = v;
            if (*end == '\0') break;
            if (*end != ',') return cli_usage_error(spec, "--%s wants comma-separated numbers, got '%s'", o->name, text);
            s = end + 1;
        }
        return 0;
    }
    case CLI_OPT_FLAG:
        break;
    }
    return 0;
}

int cli_opts_parse(const cli_cmd_spec *spec, int argc, char **argv, char ***positional, int *npositional,
                  int *exit_code)
{
    char **pos = calloc((size_t)argc + 1, sizeof *pos);
    int np = 0, only_positional = 0;
    *positional = NULL;
    *npositional = 0;
    if (!pos) {
        fprintf(stderr, "hdnet %s: out of memory\n", spec->name);
        *exit_code = CLI_EXIT_FAIL;
        return 1;
    }
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (only_positional || a[0] != '-' || a[1] == '\0') {
            pos[np++] = argv[i];
            continue;
        }
        if (strcmp(a, "--") == 0) {
            only_positional = 1;
            continue;
        }
        if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
            cli_opts_help(spec, stdout);
            free(pos);
            *exit_code = CLI_EXIT_OK;
            return 1;
        }
        const cli_opt *found = NULL;
        const char *inline_value = NULL;
        if (a[1] == '-') {
            const char *name = a + 2;
            const char *eq = strchr(name, '=');
            size_t len = eq ? (size_t)(eq - name) : strlen(name);
            for (const cli_opt *o = spec->opts; o && o->name; o++)
                if (strlen(o->name) == len && strncmp(o->name, name, len) == 0) found = o;
            if (eq) inline_value = eq + 1;
        } else if (a[2] == '\0') {
            for (const cli_opt *o = spec->opts; o && o->name; o++)
                if (o->short_name == a[1]) found = o;
        } else if (a[1] == '.' || (a[1] >= '0' && a[1] <= '9')) {
            pos[np++] = argv[i]; /* a negative number */
            continue;
        }
        if (!found) {
            free(pos);
            *exit_code = cli_usage_error(spec, "unknown option '%s'", a);
            return 1;
        }
        if (found->kind == CLI_OPT_FLAG) {
            if (inline_value) {
                free(pos);
                *exit_code = cli_usage_error(spec, "--%s takes no value", found->name);
                return 1;
            }
            *(int *)found->value = 1;
            continue;
        }
        if (!inline_value) {
            if (i + 1 >= argc) {
                free(pos);
                *exit_code = cli_usage_error(spec, "--%s needs a value (%s)", found->name, kind_metavar(found));
                return 1;
            }
            inline_value = argv[++i];
        }
        int rc = parse_value(spec, found, inline_value);
        if (rc) {
            free(pos);
            *exit_code = rc;
            return 1;
        }
    }
    if (np < spec->positional_min || (spec->positional_max >= 0 && np > spec->positional_max)) {
        free(pos);
        if (np < spec->positional_min)
            *exit_code = cli_usage_error(spec, "missing argument (usage: hdnet %s %s)", spec->name, spec->usage);
        else
            *exit_code = cli_usage_error(spec, "too many arguments ('%s' is not expected)", argv[argc - 1]);
        return 1;
    }
    *positional = pos;
    *npositional = np;
    return 0;
}
