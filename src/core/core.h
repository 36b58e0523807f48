/* core.h: internal services every part of the library shares: error reporting, arenas, the
 * seeded RNG, atomic file writes, checked size arithmetic, monotonic time. */
#ifndef HD_CORE_H
#define HD_CORE_H

#include <stdint.h>
#include <stdio.h>
#include <stddef.h>
#include "hdnet.h"

/* ---- errors: set the thread's reason and return the code, e.g.
 *      return hd_fail(HD_ERR_FORMAT, "%s: truncated PNG", path); */
hd_status hd_fail(hd_status code, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
void hd_clear_error(void);
/* Applies hd_set_threads' count to the calling thread's OpenMP setting (entry points that run
 * parallel loops call it first, so a count set in one thread holds in all). */
void hd_apply_threads(void);
/* Copies src into dst (size bytes, always terminated, cut at a whole character) with bytes below
 * 0x20 and 0x7f written as "\xNN": for printing text that came from input (hd_fail does it). */
void hd_escape_into(char *dst, size_t size, const char *src);

/* ---- checked size arithmetic: return 0 on overflow (and leave *out untouched). */
int hd_mul_size(size_t a, size_t b, size_t *out);
int hd_mul3_size(size_t a, size_t b, size_t c, size_t *out);

/* ---- allocation that reports: NULL and an HD_ERR_NOMEM reason on failure. */
void *hd_malloc(size_t bytes);
void *hd_calloc(size_t count, size_t size);

/* ---- arena: one block per role, carved in order, 64-byte aligned, freed at once. */
typedef struct hd_arena {
    unsigned char *base;
    size_t size, used;
} hd_arena;
hd_status hd_arena_init(hd_arena *a, size_t bytes);
/* Carves `count` floats; NULL (with reason) when the arena is full. */
float *hd_arena_floats(hd_arena *a, size_t count);
void hd_arena_reset(hd_arena *a);
void hd_arena_free(hd_arena *a);

/* ---- RNG: PCG32 (O'Neill), seeded, with its whole state in two words so that a checkpoint can
 * save and restore it exactly. */
typedef struct hd_rng {
    uint64_t state, inc;
} hd_rng;
void hd_rng_seed(hd_rng *r, uint64_t seed, uint64_t stream);
uint32_t hd_rng_u32(hd_rng *r);
/* Uniform in [0, 1). */
float hd_rng_uniform(hd_rng *r);
/* Uniform in [lo, hi). */
float hd_rng_range(hd_rng *r, float lo, float hi);
/* Standard normal (Box-Muller, two draws per call, nothing cached). */
float hd_rng_normal(hd_rng *r);
/* Uniform integer in [0, n). */
uint32_t hd_rng_below(hd_rng *r, uint32_t n);

/* ---- atomic files (atomic.c): write to "<path>.tmp.<host>.<pid>.<16 random hex digits>" in the
 * same folder, created O_CREAT|O_EXCL|O_NOFOLLOW with mode 0644 under the umask; fsync; rename
 * over path. A symlink at path is refused (never written through). */
#define HD_TMP_INFIX ".tmp."
/* This machine's name as temporaries carry it: gethostname() with every byte but [A-Za-z0-9-]
 * made '_' (so it holds no '.'), cut to HD_HOST_TAG_SIZE - 1 bytes; "localhost" if there is none. */
#define HD_HOST_TAG_SIZE 65
void hd_host_tag(char tag[HD_HOST_TAG_SIZE]);
typedef struct hd_atomic_file {
    FILE *f;
    char *path, *tmp_path;
    void *sink; /* the descriptor and the first write error */
} hd_atomic_file;
hd_status hd_atomic_open(hd_atomic_file *af, const char *path);
/* Flushes, fsyncs (unless durable writes are off: hd_set_durable_writes) and renames; on any
 * failure removes the temporary file and the reason carries the errno's text (e.g. "No space left
 * on device"). Either way the rename makes the file appear whole or not at all. Inside an output
 * set the rename waits for hd_atomic_set_end. */
hd_status hd_atomic_commit(hd_atomic_file *af);
/* As hd_atomic_commit, but always fsyncs: for checkpoints and models. */
hd_status hd_atomic_commit_durable(hd_atomic_file *af);
/* Abandons the write: closes and removes the temporary file. */
void hd_atomic_abort(hd_atomic_file *af);
/* The errno of the first failed write to af->f (EIO if none was recorded). */
int hd_atomic_errno(const hd_atomic_file *af);
/* The temporary's descriptor, for a writer that cannot use af->f (the video muxer writes and
 * seeks on it directly; nothing may be written through af->f then). */
int hd_atomic_fd(const hd_atomic_file *af);
/* HD_OK unless path is a symbolic link (then a reason naming it). */
hd_status hd_check_not_symlink(const char *path);
/* Opens path for appending (created 0644 under the umask), never through a symlink; NULL with a
 * reason on failure. */
FILE *hd_open_append(const char *path);
/* Output sets (this thread): after begin, commits write and close their temporaries but defer
 * the renames; end(1) renames them all (on a failure part way it removes the set's files already
 * renamed and returns the reason), end(0) removes every temporary. */
void hd_atomic_set_begin(void);
hd_status hd_atomic_set_end(int commit);
/* The errno of this thread's last failed output write (creating a temporary or a folder, writing,
 * syncing, renaming) since the previous call, 0 if none; the call resets it. A batch stops at the
 * first one hd_write_errno_is_fatal calls fatal (a full disk or quota, a read-only or unwritable
 * folder, an I/O error): every later output would fail the same way. */
int hd_take_write_errno(void);
int hd_write_errno_is_fatal(int err);
void hd_note_write_errno(int err);
/* Removes the temporaries in dir left by processes of this host that no longer run (another host's
 * and those without a host in the name are left alone); returns how many. */
int hd_remove_stale_temporaries(const char *dir);
/* Takes an exclusive flock on dir/.hdnet.lock (without waiting): a second writer gets a reason
 * saying another hdnet process holds the folder. The lock ends with the process or at unlock. */
hd_status hd_lock_folder(const char *dir, int *fd);
void hd_unlock_folder(int fd);
/* Reads a whole file (at most max_bytes) into a NUL-terminated buffer. */
hd_status hd_read_file(const char *path, size_t max_bytes, char **data, size_t *size);

/* ---- time (progress lines are the CLI's: tools/progress.c) */
double hd_seconds(void); /* monotonic */

/* ---- profiling (benchmarks only; profile.c). While enabled, the callers' hooks add wall and
 * process-CPU seconds to one process-wide table: phases form a tree (hd_prof_begin / hd_prof_end,
 * per thread, nested; hd_prof_lap adds a finished child), ops (the engine's layers, keyed by name and
 * shape) a flat table beside it that does not count as children. Disabled, every hook is a branch.
 * Names are static strings (compared by pointer and content). */
typedef struct hd_prof_mark {
    double wall, cpu;
} hd_prof_mark;
typedef struct hd_prof_entry {
    const char *name;
    int parent, depth;      /* phases: the enclosing phase's index (-1 at the top); ops: -2 */
    int C, OC, H, stride;   /* ops: the shape (0 when it has none) */
    double wall, cpu;       /* inclusive seconds */
    double child_wall, child_cpu;
    long calls;
} hd_prof_entry;
#define HD_PROF_MAX 512
/* Turns profiling on (the table cleared) or off (the table kept for reading). */
void hd_prof_enable(int on);
int hd_prof_enabled(void);
hd_prof_mark hd_prof_now(void); /* {0, 0} when disabled */
void hd_prof_begin(const char *name);
void hd_prof_end(void);
/* Adds [*since, now) as a finished child phase `name` of the open phase, then *since = now. */
void hd_prof_lap(const char *name, hd_prof_mark *since);
/* Adds [since, now) to op `name` of that shape. */
void hd_prof_op(const char *name, int C, int OC, int H, int stride, hd_prof_mark since);
/* The table (entries in order of first appearance); returns the count. */
int hd_prof_table(const hd_prof_entry **entries);

/* ---- paths */
/* A malloc'ed copy of s (NULL with reason on failure). */
char *hd_strdup(const char *s);
/* Joins dir and name with one '/'; result is malloc'ed (NULL with reason on failure). */
char *hd_path_join(const char *dir, const char *name);
/* Creates a directory and its parents (like mkdir -p). */
hd_status hd_mkdirs(const char *path);
/* "dir/NAME.ext" -> "NAME" (malloc'ed; NULL with reason on failure). A leading dot is not an
 * extension (".hidden" stays whole). */
char *hd_path_stem(const char *path);
/* "dir/NAME.ext" -> "dir/NAME<suffix>", e.g. the companion "dir/NAME.mask.png" (malloc'ed). */
char *hd_path_companion(const char *path, const char *suffix);
/* 1 if path is a directory. */
int hd_is_dir(const char *path);
/* Finds a data file shipped with hdnet (the canonical mesh, face models, the default model):
 * looks in $HDNET_DATA, then beside the executable (../models, ../share/hdnet), then in the
 * install prefix's PREFIX/share/hdnet (compiled in), then ./models (src/core/data_path.c).
 * Returns a malloc'ed path, or NULL with an HD_ERR_NOTFOUND reason listing where it looked. */
char *hd_find_data(const char *name);
/* The compiled-in PREFIX/share/hdnet. */
const char *hd_data_install_dir(void);

/* ---- the public settings' other halves, for the tool and the tests */
/* A short name for a status code ("format error", ...). */
const char *hd_status_name(hd_status status);
int hd_threads(void);

#endif /* HD_CORE_H */
