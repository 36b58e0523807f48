/* cmd_serve.c: `hdnet serve`: interactive relighting in the browser (docs/serve.md). Parses the
 * options, starts the server of tools/serve/ and waits for Ctrl-C (SIGINT) or SIGTERM, then stops
 * it cleanly: no new connections, the requests in progress finish, everything is freed. Built
 * without libmicrohttpd the command only says how to get it. */
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"
#ifdef HD_HAVE_MHD
#include <pthread.h>
#include "serve/serve.h"
#endif

CLI_COMMAND("serve", cmd_serve, "serve a web page for relighting photos interactively (drag the light, render, download)")

int cmd_serve(int argc, char **argv)
{
    const char *host = "127.0.0.1", *model_path = NULL;
    int port = 8080, threads = 0, max_photos = 8, timeout_s = 30, max_connections = 64;
    float max_upload_mb = 25.0f, max_megapixels = 16.0f;
    const cli_opt opts[] = {
        {"port", 'p', CLI_OPT_INT, &port, "PORT", "TCP port to listen on (default 8080; 0: any free port, printed)"},
        {"host", 0, CLI_OPT_STRING, &host, "ADDR",
         "address to bind (default 127.0.0.1: this machine only; 0.0.0.0 opens it to the network)"},
        CLI_OPT_MODEL_ROW(model_path),
        {"threads", 'j', CLI_OPT_INT, &threads, "N", "threads of the model's computations (default: all cores)"},
        {"max-upload", 0, CLI_OPT_FLOAT, &max_upload_mb, "MB", "largest photo upload accepted, in MB (default 25)"},
        {"max-pixels", 0, CLI_OPT_FLOAT, &max_megapixels, "MP",
         "largest photo accepted, in megapixels, checked before decoding (default 16)"},
        {"max-photos", 0, CLI_OPT_INT, &max_photos, "N",
         "photos kept in memory; the least recently used is forgotten first (default 8)"},
        {"timeout", 0, CLI_OPT_INT, &timeout_s, "S", "close a connection idle for S seconds (default 30)"},
        {"max-connections", 0, CLI_OPT_INT, &max_connections, "N", "connections served at once (default 64)"},
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const cli_cmd_spec spec = {
        "serve", "[--port 8080] [--host 127.0.0.1] [-m MODEL] [--threads N] [--max-photos N] ...",
        "Serves a page at http://HOST:PORT/ where a photo is dropped, its faces found and decomposed once,\n"
        "and the light is dragged on a sphere while the face relights live in the browser; \"render\"\n"
        "fetches the server's exact result (the pixels of `hdnet relight`). Also a JSON API (docs/serve.md).\n"
        "Photos stay in memory only, never on disk. Stop it with Ctrl-C.",
        opts, 0, 0};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    free(pos);
#ifndef HD_HAVE_MHD
    (void)host;
    (void)model_path;
    fprintf(stderr, "hdnet serve: this hdnet was built without libmicrohttpd; install it (Debian: apt-get install "
                    "libmicrohttpd-dev, or `make deps`) and rebuild with `make`\n");
    return CLI_EXIT_FAIL;
#else
    if (port < 0 || port > 65535) return cli_usage_error(&spec, "--port wants 0..65535, got %d", port);
    if (!(max_upload_mb > 0.0f && max_upload_mb <= 4096.0f)) return cli_usage_error(&spec, "--max-upload wants 0..4096 MB");
    if (!(max_megapixels > 0.0f && max_megapixels <= 268.0f))
        return cli_usage_error(&spec, "--max-pixels wants 0..268 megapixels (16384 x 16384)");
    if (max_photos < 1 || max_photos > 1000) return cli_usage_error(&spec, "--max-photos wants 1..1000");
    if (timeout_s < 1 || timeout_s > 3600) return cli_usage_error(&spec, "--timeout wants 1..3600 seconds");
    if (max_connections < 1 || max_connections > 1000) return cli_usage_error(&spec, "--max-connections wants 1..1000");
    if (threads < 0) return cli_usage_error(&spec, "--threads wants a count >= 0");
    if (threads) hd_set_threads(threads);
    serve_options o = {
        .host = host,
        .port = port,
        .model_path = model_path,
        .threads = threads,
        .max_upload = (size_t)(max_upload_mb * 1e6),
        .max_pixels = (long)(max_megapixels * 1e6),
        .max_photos = max_photos,
        .timeout_s = timeout_s,
        .max_connections = max_connections,
    };
    /* the server's threads inherit this mask, so the signals come to sigwait below */
    sigset_t stop;
    sigemptyset(&stop);
    sigaddset(&stop, SIGINT);
    sigaddset(&stop, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &stop, NULL);
    signal(SIGPIPE, SIG_IGN);
    serve_server *server = NULL;
    int bound = 0;
    if (serve_server_start(&o, &server, &bound) != HD_OK) return cli_report("serve");
    const int v6 = strchr(host, ':') != NULL;
    printf("hdnet serve: listening on http://%s%s%s:%d/ (photos in memory: at most %d, least recently used "
           "forgotten first; uploads up to %.0f MB and %.0f megapixels); Ctrl-C stops\n",
           v6 ? "[" : "", host, v6 ? "]" : "", bound, max_photos, (double)max_upload_mb, (double)max_megapixels);
    fflush(stdout);
    int sig = 0;
    sigwait(&stop, &sig);
    printf("hdnet serve: %s, stopping\n", sig == SIGINT ? "interrupted" : "terminated");
    fflush(stdout);
    serve_server_stop(server);
    printf("hdnet serve: stopped\n");
    return CLI_EXIT_OK;
#endif
}
