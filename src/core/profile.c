/* profile.c: the benchmarks' profiler (core.h, "profiling"): a process-wide table of phases (a
 * tree built from each thread's stack of open phases) and ops (flat, keyed by name and shape),
 * each with wall and process-CPU seconds. Off by default; a disabled hook costs one load. */
#include <pthread.h>
#include <string.h>
#include <time.h>
#include "core/core.h"

#define STACK_MAX 32

static hd_prof_entry table[HD_PROF_MAX];
static int count;
static volatile int enabled;
static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;

typedef struct open_phase {
    int entry;
    hd_prof_mark start;
} open_phase;
static _Thread_local open_phase stack[STACK_MAX];
static _Thread_local int depth;

void hd_prof_enable(int on)
{
    pthread_mutex_lock(&lock);
    if (on) {
        memset(table, 0, sizeof table);
        count = 0;
    }
    enabled = on;
    pthread_mutex_unlock(&lock);
    depth = 0;
}

int hd_prof_enabled(void) { return enabled; }

hd_prof_mark hd_prof_now(void)
{
    hd_prof_mark m = {0.0, 0.0};
    if (!enabled) return m;
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    m.wall = ts.tv_sec + ts.tv_nsec * 1e-9;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    m.cpu = ts.tv_sec + ts.tv_nsec * 1e-9;
    return m;
}

static int same_name(const char *a, const char *b) { return a == b || strcmp(a, b) == 0; }

/* The entry (name, parent, shape), made on first use; -1 when the table is full. Lock held. */
static int entry_of(const char *name, int parent, int C, int OC, int H, int stride)
{
    for (int i = 0; i < count; i++)
        if (table[i].parent == parent && table[i].C == C && table[i].OC == OC && table[i].H == H &&
            table[i].stride == stride && same_name(table[i].name, name))
            return i;
    if (count == HD_PROF_MAX) return -1;
    hd_prof_entry *e = &table[count];
    memset(e, 0, sizeof *e);
    e->name = name;
    e->parent = parent;
    e->depth = parent >= 0 ? table[parent].depth + 1 : 0;
    e->C = C, e->OC = OC, e->H = H, e->stride = stride;
    return count++;
}

/* Adds [since, now) to entry k, and to its parent's children. Lock held. */
static void add(int k, hd_prof_mark since, hd_prof_mark now)
{
    if (k < 0) return;
    double w = now.wall - since.wall, c = now.cpu - since.cpu;
    table[k].wall += w;
    table[k].cpu += c;
    table[k].calls++;
    if (table[k].parent >= 0) {
        table[table[k].parent].child_wall += w;
        table[table[k].parent].child_cpu += c;
    }
}

static int open_entry(void) { return depth > 0 && depth <= STACK_MAX ? stack[depth - 1].entry : -1; }

void hd_prof_begin(const char *name)
{
    if (!enabled) return;
    hd_prof_mark now = hd_prof_now();
    pthread_mutex_lock(&lock);
    int k = entry_of(name, open_entry(), 0, 0, 0, 0);
    pthread_mutex_unlock(&lock);
    if (depth < STACK_MAX) stack[depth] = (open_phase){k, now};
    depth++;
}

void hd_prof_end(void)
{
    if (!enabled || depth == 0) return;
    depth--;
    if (depth >= STACK_MAX) return;
    hd_prof_mark now = hd_prof_now();
    pthread_mutex_lock(&lock);
    add(stack[depth].entry, stack[depth].start, now);
    pthread_mutex_unlock(&lock);
}

void hd_prof_lap(const char *name, hd_prof_mark *since)
{
    if (!enabled) return;
    hd_prof_mark now = hd_prof_now();
    pthread_mutex_lock(&lock);
    add(entry_of(name, open_entry(), 0, 0, 0, 0), *since, now);
    pthread_mutex_unlock(&lock);
    *since = now;
}

void hd_prof_op(const char *name, int C, int OC, int H, int stride, hd_prof_mark since)
{
    if (!enabled) return;
    hd_prof_mark now = hd_prof_now();
    pthread_mutex_lock(&lock);
    int k = entry_of(name, -2, C, OC, H, stride);
    if (k >= 0) {
        table[k].wall += now.wall - since.wall;
        table[k].cpu += now.cpu - since.cpu;
        table[k].calls++;
    }
    pthread_mutex_unlock(&lock);
}

int hd_prof_table(const hd_prof_entry **entries)
{
    *entries = table;
    return count;
}
