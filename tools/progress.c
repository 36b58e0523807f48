/* progress.c: the CLI's progress lines on stderr (a rewritten line on a terminal, plain log lines
 * otherwise) with rate and time left; the library reports progress by callback and never prints. */
#include <stdio.h>
#include <unistd.h>
#include "cli.h"
#include "hdnet_tool.h"

void cli_progress_start(cli_progress *p, const char *label, long total)
{
    p->label = label;
    p->total = total;
    p->start = hd_seconds();
    p->last_print = -1e30;
    p->log_every = 10.0;
    p->tty = isatty(fileno(stderr));
}

static void format_duration(double s, char *buf, size_t n)
{
    if (s < 0 || s > 1e7) {
        snprintf(buf, n, "?");
        return;
    }
    long t = (long)(s + 0.5);
    if (t >= 3600) snprintf(buf, n, "%ldh%02ldm", t / 3600, (t / 60) % 60);
    else if (t >= 60) snprintf(buf, n, "%ldm%02lds", t / 60, t % 60);
    else snprintf(buf, n, "%lds", t);
}

static void progress_print(cli_progress *p, long done, const char *extra, int final)
{
    double now = hd_seconds(), elapsed = now - p->start;
    double rate = elapsed > 0 ? (double)done / elapsed : 0.0;
    char left[32], spent[32];
    format_duration(rate > 0 && p->total > 0 ? (double)(p->total - done) / rate : -1, left, sizeof left);
    format_duration(elapsed, spent, sizeof spent);
    if (p->tty) {
        fprintf(stderr, "\r\033[K%s %ld/%ld  %.2f/s  %s %s%s%s", p->label, done, p->total, rate,
                final ? "took" : "left", final ? spent : left, extra ? "  " : "", extra ? extra : "");
        if (final) fputc('\n', stderr);
    } else {
        fprintf(stderr, "%s %ld/%ld %.2f/s %s %s%s%s\n", p->label, done, p->total, rate,
                final ? "took" : "left", final ? spent : left, extra ? " " : "", extra ? extra : "");
    }
    fflush(stderr);
    p->last_print = now;
}

void cli_progress_update(cli_progress *p, long done, const char *extra)
{
    double now = hd_seconds();
    double every = p->tty ? 0.2 : p->log_every;
    if (now - p->last_print >= every) progress_print(p, done, extra, 0);
}

void cli_progress_finish(cli_progress *p, long done, const char *extra) { progress_print(p, done, extra, 1); }
