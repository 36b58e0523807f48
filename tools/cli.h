/* cli.h: what every hdnet command shares: the option table that both parses the command line and
 * prints --help, the command registry, and error reporting with exit codes
 * (0 success, 1 the work failed: bad data, I/O, numbers; 2 the command line was wrong). */
#ifndef HD_CLI_H
#define HD_CLI_H

#include <stdio.h>
#include "hdnet.h"

/* Each tools/cmd_*.c registers its command at file scope with a line starting with
 * HD_COMMAND("name", function, "one-line summary"); the Makefile collects those lines. */
#define HD_COMMAND(name, fn, summary) int fn(int argc, char **argv);

enum { HD_EXIT_OK = 0, HD_EXIT_FAIL = 1, HD_EXIT_USAGE = 2 };

typedef enum hd_opt_kind {
    HD_OPT_FLAG,   /* int, set to 1 */
    HD_OPT_INT,    /* int */
    HD_OPT_FLOAT,  /* float */
    HD_OPT_STRING, /* const char * */
    HD_OPT_FLOATS  /* hd_opt_floats: comma-separated floats, e.g. --dir 30,10 */
} hd_opt_kind;

typedef struct hd_opt_floats {
    int count;     /* parsed so far (0 when absent) */
    int max;       /* capacity of v, set by the command */
    float v[16];
} hd_opt_floats;

typedef struct hd_opt {
    const char *name;  /* long name without dashes: "light" for --light */
    char short_name;   /* 'o' for -o, or 0 */
    hd_opt_kind kind;
    void *value;       /* where the parsed value goes */
    const char *metavar;
    const char *help;  /* the default, if any, is said here */
} hd_opt;

typedef struct hd_cmd_spec {
    const char *name;        /* "light" */
    const char *usage;       /* after "hdnet light ": "[options] --dir AZ,EL -o light.txt" */
    const char *description; /* a paragraph printed under the usage */
    const hd_opt *opts;      /* terminated by an entry with name == NULL */
    int positional_min, positional_max; /* max < 0: unlimited */
} hd_cmd_spec;

/* Parses argv (argv[0] is the command name). Returns 0 to go on, with the positional arguments
 * collected in *positional (argv order; free with free()); otherwise the exit code to return:
 * HD_EXIT_OK after --help, HD_EXIT_USAGE after a usage error (message printed). */
int hd_opts_parse(const hd_cmd_spec *spec, int argc, char **argv, char ***positional, int *npositional,
                  int *exit_code);
void hd_opts_help(const hd_cmd_spec *spec, FILE *out);
/* Prints "hdnet CMD: usage error: ..." and a hint to --help; returns HD_EXIT_USAGE. */
int hd_usage_error(const hd_cmd_spec *spec, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Prints "hdnet CMD: " + hd_error(); returns HD_EXIT_FAIL. */
int hd_report(const char *cmd);

/* What the commands that apply a model to a photo or an aligned face share: their option rows, */
#define HD_OPT_MODEL_ROW(var) {"model", 'm', HD_OPT_STRING, &(var), "MODEL", "model file (default: the shipped hdnet-synth model)"}
#define HD_OPT_FACE_MASK_ROW(var)                                                                                      \
    {"mask", 0, HD_OPT_STRING, &(var), "M.png",                                                                        \
     "with an aligned texture: face mask when IMG has no NAME.mask.png beside it (default: all ones)"}
#define HD_OPT_ALIGNED_ROW(var)                                                                                        \
    {"aligned", 0, HD_OPT_FLAG, &(var), NULL,                                                                          \
     "IMG is an aligned face texture, not a photo (automatic when NAME.mask.png or NAME.normal.png is beside it)"}
/* the report of a photo core's failure st for path ("no face found (give --aligned ...)" or the
 * error; returns HD_EXIT_FAIL), */
int hd_report_photo(const char *cmd, hd_status st, const char *path);
/* and the notes on --mask: a photo's faces bring their own; an aligned texture's NAME.mask.png
 * (mask_source, as hd_face_mask_read found it) wins over it. */
void hd_note_mask(const char *cmd, int photo, const char *mask_path, const char *mask_source);

#endif /* HD_CLI_H */
