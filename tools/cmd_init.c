/* cmd_init.c: `hdnet init`: writes a freshly initialised HD-Net model (PyTorch's default
 * initialisation from a seed), the same parameters `hdnet train --seed N` starts from. */
#include <stdlib.h>
#include "cli.h"
#include "hdnet_tool.h"

CLI_COMMAND("init", cmd_init, "write a freshly initialised model (width, size, seed)")

int cmd_init(int argc, char **argv)
{
    int width = 48, size = 256, seed = -1;
    const char *out = NULL;
    const cli_opt opts[] = {
        {"width", 0, CLI_OPT_INT, &width, "W", "Common-Net width (default 48, the paper's)"},
        {"size", 0, CLI_OPT_INT, &size, "S", "input side, a multiple of 32 (default 256)"},
        {"seed", 0, CLI_OPT_INT, &seed, "N", "seed of the initialisation (required, >= 0)"},
        {"output", 'o', CLI_OPT_STRING, &out, "FILE", "the model written (safetensors)"},
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const cli_cmd_spec spec = {
        "init", "[--width W] [--size S] --seed N -o model.safetensors",
        "Writes an HD-Net model with every convolution and linear layer initialised uniformly in\n"
        "+-1/sqrt(fan_in) (PyTorch's default) from the seed. `hdnet train --init` starts from it;\n"
        "`hdnet train --seed N` starts from exactly these parameters.",
        opts, 0, 0};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    free(pos);
    if (!out) return cli_usage_error(&spec, "-o FILE is required");
    if (seed < 0) return cli_usage_error(&spec, "--seed N (>= 0) is required");
    hd_net_config cfg = {width, size};
    if (hd_net_config_check(&cfg) != HD_OK) return cli_usage_error(&spec, "%s", hd_error());
    hd_param_table t;
    hd_net_param_table(&cfg, &t);
    float *params = calloc(t.total, sizeof(float));
    if (!params) {
        fprintf(stderr, "hdnet init: out of memory\n");
        return CLI_EXIT_FAIL;
    }
    hd_train_init_params(&cfg, (uint64_t)seed, params, NULL);
    hd_status s = hd_model_write(out, &cfg, params, 0, 0);
    free(params);
    if (s != HD_OK) return cli_report("init");
    printf("wrote %s: HD-Net width %d, size %d, %zu parameters, seed %d\n", out, width, size, t.total, seed);
    return CLI_EXIT_OK;
}
