/* opts.c: one option table per command drives both the parser and the --help text. */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"
#include "hdnet_tool.h"

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

const char *cli_min_score_help(void)
{
    static char help[96];
    snprintf(help, sizeof help, "face detection threshold in (0, 1] (default %.2f)", (double)HD_FACE_MIN_SCORE);
    return help;
}

float cli_min_score_default(void) { return HD_FACE_MIN_SCORE; }

int cli_opts_common(const cli_cmd_spec *spec, int threads, float min_score)
{
    if (threads < 0 || threads > 1024) return cli_usage_error(spec, "--threads wants 0..1024, got %d", threads);
    if (!(min_score > 0.0f && min_score <= 1.0f))
        return cli_usage_error(spec, "--min-score must be in (0, 1], got %g", (double)min_score);
    if (threads > 0) hd_set_threads(threads);
    return 0;
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

const char *cli_opt_metavar(const cli_opt *o)
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

/* Prints text word-wrapped to HELP_WIDTH columns, continuation lines indented by `indent`;
 * a '\n' in text starts a new (indented) line. `col` is the column the text starts at. */
#define HELP_WIDTH 100
static void print_wrapped(FILE *out, const char *text, int col, int indent)
{
    const char *s = text;
    while (*s) {
        if (*s == '\n') {
            fprintf(out, "\n%*s", indent, "");
            col = indent;
            s++;
            continue;
        }
        if (*s == ' ') {
            s++;
            continue;
        }
        size_t n = strcspn(s, " \n");
        if (col > indent && col + 1 + (int)n > HELP_WIDTH) {
            fprintf(out, "\n%*s", indent, "");
            col = indent;
        } else if (col > indent) {
            fputc(' ', out);
            col++;
        }
        fprintf(out, "%.*s", (int)n, s);
        col += (int)n;
        s += n;
    }
    fputc('\n', out);
}

/* "-o, --output OUT" or "    --size S": the left column of an option's help line. */
void cli_opt_synopsis(const cli_opt *o, char *left, size_t size)
{
    int n = o->short_name ? snprintf(left, size, "-%c, ", o->short_name) : snprintf(left, size, "    ");
    if (n < 0 || (size_t)n >= size) return;
    snprintf(left + n, size - (size_t)n, "--%s%s%s", o->name, o->kind == CLI_OPT_FLAG ? "" : " ",
             o->kind == CLI_OPT_FLAG ? "" : cli_opt_metavar(o));
}

void cli_opts_help(const cli_cmd_spec *spec, FILE *out)
{
    fprintf(out, "usage: hdnet %s %s\n", spec->name, spec->usage);
    if (spec->description) fprintf(out, "\n%s\n", spec->description);
    fprintf(out, "\noptions:\n");
    for (const cli_opt *o = spec->opts; o && o->name; o++) {
        char left[96];
        cli_opt_synopsis(o, left, sizeof left);
        int col = fprintf(out, "  %-28s ", left);
        print_wrapped(out, o->help ? o->help : "", col, 31);
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

static void (*visit_fn)(const cli_cmd_spec *spec, void *ctx);
static void *visit_ctx;

void cli_opts_visit(void (*fn)(const cli_cmd_spec *spec, void *ctx), void *ctx)
{
    visit_fn = fn;
    visit_ctx = ctx;
}

int cli_opts_parse(const cli_cmd_spec *spec, int argc, char **argv, char ***positional, int *npositional,
                  int *exit_code)
{
    if (visit_fn) {
        visit_fn(spec, visit_ctx);
        *positional = NULL;
        *npositional = 0;
        *exit_code = CLI_EXIT_OK;
        return 1;
    }
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
        } else if (a[1] == '.' || (a[1] >= '0' && a[1] <= '9')) {
            pos[np++] = argv[i]; /* a negative number */
            continue;
        } else {
            for (const cli_opt *o = spec->opts; o && o->name; o++)
                if (o->short_name == a[1]) found = o;
            if (found && a[2] != '\0') { /* -oFILE, -j2 */
                if (found->kind == CLI_OPT_FLAG) {
                    free(pos);
                    *exit_code = cli_usage_error(spec, "-%c takes no value (in '%s')", a[1], a);
                    return 1;
                }
                inline_value = a + 2;
            }
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
                *exit_code = cli_usage_error(spec, "--%s needs a value (%s)", found->name, cli_opt_metavar(found));
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
        if (np < spec->positional_min)
            *exit_code = cli_usage_error(spec, "missing argument (usage: hdnet %s %s)", spec->name, spec->usage);
        else /* the first word past what the command takes */
            *exit_code = cli_usage_error(spec, "too many arguments ('%s' is not expected)", pos[spec->positional_max]);
        free(pos);
        return 1;
    }
    *positional = pos;
    *npositional = np;
    return 0;
}
