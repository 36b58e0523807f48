/* main.c: the hdnet command: dispatches `hdnet <command> [options]` to the registered commands. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>
#include "cli.h"
#include "mpi.h"
#include "nn/nn.h"

#include "commands.inc"

#undef CLI_COMMAND
#define CLI_COMMAND(name, fn, summary) {name, fn, summary},

static const cli_command commands[] = {
#include "commands.inc"
};

static void print_help(FILE *out)
{
    fprintf(out, "usage: hdnet <command> [options]\n\n"
                 "Face inverse rendering and relighting (HD-Net) in plain C.\n\ncommands:\n");
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        fprintf(out, "  %-16s %s\n", commands[i].name, commands[i].summary);
    fprintf(out, "  %-16s %s\n", "help", "this list; `hdnet help <command>` (= `hdnet <command> --help`) for one");
    fprintf(out, "\n  %-16s %s\n", "--version", "print the version and exit");
    fprintf(out, "  %-16s %s\n", "--max-pixels N",
            "before the command: the largest image any reader accepts (default 100000000; HDNET_MAX_PIXELS)");
    fprintf(out, "  %-16s %s\n", "-h, --help", "this list");
}

/* Under an address-space limit (ulimit -v) OpenBLAS's worker threads, started when the library is
 * loaded, each reserve a 128 MB buffer and retry forever when the reservation fails, so the tool
 * hung (at exit, or at its first matrix product) under about 700 MB. OpenBLAS reads
 * OPENBLAS_NUM_THREADS only when it is loaded: under a finite limit, unless the variable is set,
 * the tool sets it to 1 (no worker thread; hdnet's own loops still use every thread) and starts
 * itself again. docs/reliability.md section 3 gives the limits that work. */
static void fit_address_limit(char **argv)
{
    struct rlimit rl;
    if (getrlimit(RLIMIT_AS, &rl) != 0 || rl.rlim_cur == RLIM_INFINITY || getenv("OPENBLAS_NUM_THREADS")) return;
    if (setenv("OPENBLAS_NUM_THREADS", "1", 1) != 0) return;
    execv("/proc/self/exe", argv);
    /* no /proc: go on; the limit may still be enough */
}

int main(int argc, char **argv)
{
    fit_address_limit(argv);
    if (argc < 2) {
        print_help(stderr);
        return CLI_EXIT_USAGE;
    }
    /* hdnet --max-pixels N CMD ...: the readers' pixel limit (hd_set_max_pixels), before the command */
    while (argc >= 2 && strcmp(argv[1], "--max-pixels") == 0) {
        char *end = NULL;
        long long n = argc >= 3 ? strtoll(argv[2], &end, 10) : 0;
        if (argc < 3 || end == argv[2] || *end || n < 1 || n > 1000000000000LL) {
            fprintf(stderr, "hdnet: --max-pixels wants a pixel count from 1 to 1000000000000%s%s%s\n",
                    argc >= 3 ? ", not '" : "", argc >= 3 ? argv[2] : "", argc >= 3 ? "'" : "");
            return CLI_EXIT_USAGE;
        }
        hd_set_max_pixels(n);
        argc -= 2;
        argv += 2;
        argv[0] = "hdnet";
    }
    if (argc < 2) {
        print_help(stderr);
        return CLI_EXIT_USAGE;
    }
    const char *name = argv[1];
    if (strcmp(name, "help") == 0 || strcmp(name, "--help") == 0 || strcmp(name, "-h") == 0) {
        if (argc > 3) {
            fprintf(stderr, "hdnet help: too many arguments ('%s' is not expected)\n", argv[3]);
            return CLI_EXIT_USAGE;
        }
        if (argc > 2 && strcmp(argv[2], "--help") != 0 && strcmp(argv[2], "-h") != 0) {
            for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
                if (strcmp(commands[i].name, argv[2]) == 0) {
                    char *help_argv[] = {argv[2], "--help", NULL};
                    return commands[i].run(2, help_argv);
                }
            fprintf(stderr, "hdnet help: unknown command '%s' (see: hdnet help)\n", argv[2]);
            return CLI_EXIT_USAGE;
        }
        print_help(stdout);
        return CLI_EXIT_OK;
    }
    if (strcmp(name, "--version") == 0) {
        printf("hdnet %s\n", hd_version());
        return CLI_EXIT_OK;
    }
    /* generated documentation, not listed: `make install` writes the man page and completion */
    const int ncommands = (int)(sizeof commands / sizeof commands[0]);
    if (strcmp(name, "--man") == 0 && argc == 2) return cli_print_man(commands, ncommands, stdout);
    if (strcmp(name, "--completion") == 0 && argc == 3 && strcmp(argv[2], "bash") == 0)
        return cli_print_completion(commands, ncommands, stdout);
    if (strcmp(name, "--completion") == 0) {
        fprintf(stderr, "hdnet: --completion wants 'bash'\n");
        return CLI_EXIT_USAGE;
    }
    /* HD_CONV_PRECISION=fp32|bf16|auto: the oneDNN convolutions' precision (bf16 only where the CPU
     * has it; FP32 by default, docs/performance.md) */
    const char *prec = getenv("HD_CONV_PRECISION");
    if (prec && *prec) {
        hd_precision p;
        if (hd_precision_parse(prec, "HD_CONV_PRECISION", &p) != HD_OK) {
            fprintf(stderr, "hdnet: %s\n", hd_error());
            return CLI_EXIT_USAGE;
        }
        hd_conv_set_precision(p);
    }
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (strcmp(commands[i].name, name) == 0) {
            int rc = commands[i].run(argc - 1, argv + 1);
            cli_mpi_finish(); /* if the command ran as an MPI rank (train, the batch commands) */
            return rc;
        }
    fprintf(stderr, "hdnet: unknown command '%s' (see: hdnet help)\n", name);
    return CLI_EXIT_USAGE;
}
