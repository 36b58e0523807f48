/* cli.h: what every hdnet command shares, under the CLI's own prefix (cli_, not the library's
 * hd_): the option table that both parses the command line and prints --help, the command
 * registry, and error reporting with exit codes (0 success, 1 the work failed: bad data, I/O,
 * numbers; 2 the command line was wrong). */
#ifndef CLI_H
#define CLI_H

#include <stdio.h>
#include "hdnet.h"

/* Each tools/cmd_*.c registers its command at file scope with a line starting with
 * CLI_COMMAND("name", function, "one-line summary"); the Makefile collects those lines. */
#define CLI_COMMAND(name, fn, summary) int fn(int argc, char **argv);

enum { CLI_EXIT_OK = 0, CLI_EXIT_FAIL = 1, CLI_EXIT_USAGE = 2 };

/* A registered command (main.c's table, from the CLI_COMMAND lines). */
typedef struct cli_command {
    const char *name;
    int (*run)(int argc, char **argv);
    const char *summary;
} cli_command;

typedef enum cli_opt_kind {
    CLI_OPT_FLAG,   /* int, set to 1 */
    CLI_OPT_INT,    /* int */
    CLI_OPT_FLOAT,  /* float */
    CLI_OPT_STRING, /* const char * */
    CLI_OPT_FLOATS  /* cli_opt_floats: comma-separated floats, e.g. --dir 30,10 */
} cli_opt_kind;

typedef struct cli_opt_floats {
    int count;     /* parsed so far (0 when absent) */
    int max;       /* capacity of v, set by the command */
    float v[16];
} cli_opt_floats;

typedef struct cli_opt {
    const char *name;  /* long name without dashes: "light" for --light */
    char short_name;   /* 'o' for -o, or 0 */
    cli_opt_kind kind;
    void *value;       /* where the parsed value goes */
    const char *metavar;
    const char *help;  /* the default, if any, is said here */
} cli_opt;

typedef struct cli_cmd_spec {
    const char *name;        /* "light" */
    const char *usage;       /* after "hdnet light ": "[options] --dir AZ,EL -o light.txt" */
    const char *description; /* a paragraph printed under the usage */
    const cli_opt *opts;      /* terminated by an entry with name == NULL */
    int positional_min, positional_max; /* max < 0: unlimited */
} cli_cmd_spec;

/* Parses argv (argv[0] is the command name). Returns 0 to go on, with the positional arguments
 * collected in *positional (argv order; free with free()); otherwise the exit code to return:
 * CLI_EXIT_OK after --help, CLI_EXIT_USAGE after a usage error (message printed). */
int cli_opts_parse(const cli_cmd_spec *spec, int argc, char **argv, char ***positional, int *npositional,
                  int *exit_code);
void cli_opts_help(const cli_cmd_spec *spec, FILE *out);
/* While fn is set, cli_opts_parse hands each spec to fn(spec, ctx) and returns at once (exit code
 * 0) instead of parsing: how the man page and the completion read every command's table without
 * running it. NULL turns it off. */
void cli_opts_visit(void (*fn)(const cli_cmd_spec *spec, void *ctx), void *ctx);
/* `hdnet --man` and `hdnet --completion bash` (docgen.c): generated from the option tables. */
int cli_print_man(const cli_command *commands, int count, FILE *out);
int cli_print_completion(const cli_command *commands, int count, FILE *out);
/* An option's value placeholder ("N", "OUT.png"; "" for a flag) and its help-line synopsis
 * ("-o, --output OUT.png"). */
const char *cli_opt_metavar(const cli_opt *o);
void cli_opt_synopsis(const cli_opt *o, char *left, size_t size);
/* Prints "hdnet CMD: usage error: ..." and a hint to --help; returns CLI_EXIT_USAGE. */
int cli_usage_error(const cli_cmd_spec *spec, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Prints "hdnet CMD: " + hd_error(); returns CLI_EXIT_FAIL. */
int cli_report(const char *cmd);

/* The options every command spells the same way (docs/usage.md, "Options every command shares"):
 * -o output, -m model, -q quiet, -j/--threads, --min-score (every command that uses the face
 * detector), --json (print the result as JSON on stdout). */
#define CLI_OPT_THREADS_ROW(var) {"threads", 'j', CLI_OPT_INT, &(var), "N", "threads for the computation (default 0: all cores)"}
#define CLI_OPT_QUIET_ROW(var) {"quiet", 'q', CLI_OPT_FLAG, &(var), NULL, "print only problems (and what --json asks for)"}
#define CLI_OPT_MIN_SCORE_ROW(var) {"min-score", 0, CLI_OPT_FLOAT, &(var), "S", cli_min_score_help()}
#define CLI_OPT_JSON_ROW(var) {"json", 0, CLI_OPT_FLAG, &(var), NULL, "print the result as one JSON object on stdout (fields: docs/usage.md)"}
/* "face detection threshold in (0, 1] (default 0.75)", with the library's default. */
const char *cli_min_score_help(void);
/* The face detector's default threshold, for a command's min-score variable. */
float cli_min_score_default(void);
/* Checks --threads (>= 0) and --min-score (in (0, 1]) and applies --threads (hd_set_threads);
 * returns 0, or the usage error's exit code. Pass min_score 1 for a command without it. */
int cli_opts_common(const cli_cmd_spec *spec, int threads, float min_score);

/* What the commands that apply a model to a photo or an aligned face share: their option rows, */
#define CLI_OPT_MODEL_ROW(var) {"model", 'm', CLI_OPT_STRING, &(var), "MODEL", "model file (default: the shipped hdnet-synth model)"}
#define CLI_OPT_WHITE_BALANCE_ROW(var)                                                                                  \
    {"white-balance", 0, CLI_OPT_STRING, &(var), "off|eyes",                                                          \
     "eyes: divide the colour cast read from the whites of the eyes out of each face first (default off; "           \
     "docs/usage.md, \"White balance\")"}
/* sets model's white balance from the --white-balance value (NULL: leave the default); returns 0,
 * or the usage error's exit code. */
int cli_white_balance_set(const cli_cmd_spec *spec, const char *value, hd_model *model);
#define CLI_OPT_FACE_MASK_ROW(var)                                                                                      \
    {"mask", 0, CLI_OPT_STRING, &(var), "M.png",                                                                        \
     "with an aligned texture: face mask when IMG has no NAME.mask.png beside it (default: all ones)"}
#define CLI_OPT_ALIGNED_ROW(var)                                                                                        \
    {"aligned", 0, CLI_OPT_FLAG, &(var), NULL,                                                                          \
     "IMG is an aligned face texture, not a photo (automatic when NAME.mask.png or NAME.normal.png is beside it)"}
/* the report of a photo core's failure st for path ("no face found (give --aligned ...)" or the
 * error; returns CLI_EXIT_FAIL), */
int cli_report_photo(const char *cmd, hd_status st, const char *path);
/* and the notes on --mask: a photo's faces bring their own; an aligned texture's NAME.mask.png
 * (mask_source, as hd_face_mask_read found it) wins over it. */
void cli_note_mask(const char *cmd, int photo, const char *mask_path, const char *mask_source);

/* A progress reporter on stderr (tools/progress.c): on a terminal one rewritten line with rate and
 * time left; otherwise a plain log line at most every `log_every` seconds (and at the end). */
typedef struct cli_progress {
    const char *label;
    long total;
    double start, last_print, log_every;
    int tty;
} cli_progress;
void cli_progress_start(cli_progress *p, const char *label, long total);
/* done = items finished so far; extra = a short text shown after the rate (may be NULL). */
void cli_progress_update(cli_progress *p, long done, const char *extra);
void cli_progress_finish(cli_progress *p, long done, const char *extra);

#endif /* CLI_H */
