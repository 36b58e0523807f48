/* batch.h: many inputs for the commands that apply a model (relight, delight, transfer,
 * estimate-light, decompose, align): collecting them from files, folders (recursively) and
 * @lists, the one naming rule for their outputs, and the loop that runs a per-photo function over
 * them with a progress line and a summary (docs/usage.md, "Many photos"). */
#ifndef HD_BATCH_H
#define HD_BATCH_H

#include <cjson/cJSON.h>
#include "cli.h"

/* One input image and where its outputs go: OUT/rel + a suffix per output. */
typedef struct cli_input {
    char *path; /* the image as given or found */
    char *rel;  /* "NAME" for a file (its name without the extension), "SUB/NAME" for an image
                 * found at DIR/SUB/NAME.ext under a folder DIR given */
} cli_input;

typedef struct cli_inputs {
    cli_input *v; /* this process's share of the job's inputs */
    int count, cap;
    int total;       /* the job's inputs over every rank (count, for a single process) */
    char **listing;  /* under MPI with more than one rank: the job's input paths, in order (total) */
} cli_inputs;

/* Lists the images of each argument: a file (kept even if it cannot be read: the run reports
 * it), a folder (its .png/.jpg/.jpeg images, recursively, in name order, without companions such
 * as NAME.mask.png or outputs such as NAME.relit.png beside NAME.png), or @LIST (a text file of
 * files and folders, one a line; blank lines and lines starting with '#' skipped). Under mpirun
 * (or srun) with R ranks every rank makes this same listing and keeps its share: input i goes to
 * rank i % R (docs/scaling.md, "Inference"); in->total is the job's count. */
hd_status cli_inputs_collect(cli_inputs *in, char *const *args, int nargs);
void cli_inputs_free(cli_inputs *in);

/* 1 when the command line is one image to one output file: a single argument that is a file
 * (not a folder, not @LIST), and an -o that is neither an existing folder nor ends in '/'. */
int cli_single_output(char *const *args, int nargs, const char *out);

/* Decides how -o is read: *single = cli_single_output (unless folder_only, the reason the outputs
 * always go into a folder: "--preset all writes seven images into a folder");
 * otherwise -o is a folder, and an -o that names a file (ends in .png, .jpg, .jpeg, .pfm, .txt or
 * .json and is not an existing folder) is a usage error: it returns the exit code (else 0). */
int cli_output_mode(const cli_cmd_spec *spec, char *const *args, int nargs, const char *out, const char *folder_only,
                    int *single);

/* OUT/rel + suffix (malloc'ed; its folder is created). NULL with the reason set on failure. */
char *cli_output_path(const char *out, const cli_input *in, const char *suffix);

/* What a per-photo function reports: how many faces it did, and the main file it wrote. */
typedef struct cli_result {
    int faces;
    char wrote[4096];
} cli_result;

/* Does one input; returns HD_OK, HD_ERR_NOTFOUND when a photo has no face, or another error
 * (with hd_error's reason). single: out is the output file itself, else the OUT folder. */
typedef hd_status (*cli_photo_fn)(void *ctx, const cli_input *in, const char *out, int single, cli_result *r);

/* Runs fn over every input with a progress line (stderr: rewritten on a terminal, log lines
 * otherwise), reports each failure ("hdnet CMD: PATH: reason") and skips it, then prints a
 * summary (one input: "PATH: <verb> K faces -> FILE"; many: "CMD: N photos -> OUT: D done
 * (F faces), X without a face, Y failed; T s, R photos/s"). -q keeps only the problems. Returns
 * the exit status: 0 when every input was done, 1 when any had no face or failed (or none was
 * given). summary (may be NULL) receives the counts, for --json. Under MPI each rank runs its
 * share and reports its own failures; the progress line is rank 0's share, and the summary, the
 * counts and the exit status are the job's, summed over the ranks (the same on every rank).
 * no_face_hint follows "no face found" when the one input has none: CLI_NO_FACE_ALIGNED for the
 * commands that take --aligned, "" for the others. */
#define CLI_NO_FACE_ALIGNED " (give --aligned if it is an aligned face texture)"
typedef struct cli_summary {
    int inputs, done, no_face, failed, faces;
    double seconds;
} cli_summary;
int cli_batch_run(const char *cmd, const char *verb, const char *no_face_hint, const cli_inputs *in, const char *out,
                  int single, int quiet, cli_photo_fn fn, void *ctx, cli_summary *summary);
/* Sums a rank's counts over every rank of the job (MPI_Allreduce; nothing for one process) and
 * sets seconds to the time since t0 (every rank has waited for the slowest by then). */
hd_status cli_summary_reduce(cli_summary *s, double t0);
/* 1 on the rank that prints the job's summary and progress (rank 0; always, for one process). */
int cli_batch_reports(void);
/* The progress line's label: CMD, or "CMD (rank 0 of R)" under MPI (the line counts rank 0's
 * share); written into buf. */
const char *cli_batch_label(const char *cmd, char *buf, size_t n);
/* The exit status of a summary (as cli_batch_run returns it). */
int cli_summary_status(const cli_summary *s);

/* The summary as JSON: {"inputs", "done", "no_face", "failed", "faces", "seconds", "output"}. */
cJSON *cli_summary_json(const cli_summary *s, const char *out);
/* Prints a JSON document on stdout (indented) and deletes it; returns CLI_EXIT_FAIL (with a
 * message) if it could not be printed (out of memory), else ok_status. */
int cli_json_print(const char *cmd, cJSON *doc, int ok_status);
/* Prints {"results": *results, "summary": cli_summary_json(s, out)} that way; takes *results
 * (set to NULL). Under MPI every rank calls it: the results of all ranks are gathered on rank 0,
 * put in the order of the job's inputs (by their "file") and printed there alone. */
int cli_json_print_run(const char *cmd, cJSON **results, const cli_inputs *in, const cli_summary *s, const char *out,
                       int ok_status);

#endif /* HD_BATCH_H */
