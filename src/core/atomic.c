/* atomic.c: atomic output files that cannot be hijacked, output sets, stale temporaries.
 *
 * An output PATH is written to a temporary "PATH.tmp.HOST.PID.RANDOM" in the same folder, created with
 * open(O_CREAT | O_EXCL | O_NOFOLLOW) and mode 0644 under the umask (so a file or symlink planted
 * at that name is never opened, and the random part makes it unguessable), flushed, fsynced
 * (unless durable writes are off) and renamed over PATH. A symlink at PATH itself is refused:
 * hdnet never writes through one (rename() would replace the link, not follow it, so even a link
 * planted between the check and the rename leaves its target untouched). HOST is this machine's
 * name (hd_host_tag), so that processes on several hosts writing into one shared folder (MPI
 * ranks) each judge only their own host's temporaries stale.
 *
 * The FILE is a stdio cookie stream over the descriptor that remembers the first write error's
 * errno, so that a full disk is reported as "No space left on device" and not as a bare failure.
 *
 * Output sets: between hd_atomic_set_begin() and hd_atomic_set_end(), commits on this thread stop
 * before the rename; hd_atomic_set_end(commit) then renames every temporary of the set (or removes
 * them all), so an image's outputs appear together or not at all. */
#define _GNU_SOURCE
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <time.h>
#include <unistd.h>
#include "core/core.h"

typedef struct atomic_sink {
    int fd;
    int err; /* the first write error's errno, 0 if none */
} atomic_sink;

static ssize_t sink_write(void *cookie, const char *buf, size_t size)
{
    atomic_sink *s = cookie;
    size_t done = 0;
    while (done < size) {
        ssize_t n = write(s->fd, buf + done, size - done);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            if (!s->err) s->err = n < 0 ? errno : ENOSPC;
            return done > 0 ? (ssize_t)done : -1;
        }
        done += (size_t)n;
    }
    return (ssize_t)done;
}

static int sink_close(void *cookie)
{
    atomic_sink *s = cookie;
    int rc = close(s->fd);
    if (rc != 0 && !s->err) s->err = errno;
    return rc;
}

/* ---- the errno of this thread's last failed output write (hd_take_write_errno) */
static _Thread_local int last_write_errno;

void hd_note_write_errno(int err)
{
    if (err) last_write_errno = err;
}

int hd_take_write_errno(void)
{
    int err = last_write_errno;
    last_write_errno = 0;
    return err;
}

int hd_write_errno_is_fatal(int err)
{
    return err == ENOSPC || err == EDQUOT || err == EROFS || err == EACCES || err == EPERM || err == EIO ||
           err == EFBIG;
}

static uint64_t random_word(void)
{
    uint64_t v = 0;
    if (getrandom(&v, sizeof v, GRND_NONBLOCK) == (ssize_t)sizeof v) return v;
    /* no entropy source: still different per call and per process */
    static _Thread_local uint64_t counter;
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    v = ((uint64_t)ts.tv_nsec << 20) ^ (uint64_t)ts.tv_sec ^ ((uint64_t)getpid() << 40) ^ ++counter * 0x9E3779B97F4A7C15ull;
    return v;
}

void hd_host_tag(char tag[HD_HOST_TAG_SIZE])
{
    char name[256] = "";
    if (gethostname(name, sizeof name) != 0 || !name[0]) snprintf(name, sizeof name, "localhost");
    name[sizeof name - 1] = '\0';
    size_t i = 0;
    for (; name[i] && i + 1 < HD_HOST_TAG_SIZE; i++) {
        char c = name[i];
        int plain = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-';
        tag[i] = plain ? c : '_';
    }
    tag[i] = '\0';
}

hd_status hd_check_not_symlink(const char *path)
{
    struct stat sb;
    if (lstat(path, &sb) == 0 && S_ISLNK(sb.st_mode))
        return hd_fail(HD_ERR_IO, "%s: is a symbolic link; hdnet does not write through links (remove it or "
                       "give the real path)", path);
    return HD_OK;
}

hd_status hd_atomic_open(hd_atomic_file *af, const char *path)
{
    memset(af, 0, sizeof *af);
    hd_status st = hd_check_not_symlink(path);
    if (st != HD_OK) return st;
    char host[HD_HOST_TAG_SIZE];
    hd_host_tag(host);
    size_t n = strlen(path) + HD_HOST_TAG_SIZE + 64;
    af->path = hd_strdup(path);
    af->tmp_path = hd_malloc(n);
    atomic_sink *sink = hd_malloc(sizeof *sink);
    if (!af->path || !af->tmp_path || !sink) {
        free(af->path);
        free(af->tmp_path);
        free(sink);
        af->path = af->tmp_path = NULL;
        return hd_fail(HD_ERR_NOMEM, "%s: out of memory opening", path);
    }
    int fd = -1, err = 0;
    for (int attempt = 0; attempt < 64 && fd < 0; attempt++) {
        snprintf(af->tmp_path, n, "%s" HD_TMP_INFIX "%s.%ld.%016llx", path, host, (long)getpid(),
                 (unsigned long long)random_word());
        fd = open(af->tmp_path, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
        err = errno;
        if (fd < 0 && err != EEXIST) break;
    }
    if (fd >= 0) {
        sink->fd = fd;
        sink->err = 0;
        cookie_io_functions_t io = {.read = NULL, .write = sink_write, .seek = NULL, .close = sink_close};
        af->f = fopencookie(sink, "w", io);
        if (!af->f) {
            err = errno;
            close(fd);
            unlink(af->tmp_path);
        }
    }
    if (!af->f) {
        hd_note_write_errno(err);
        st = hd_fail(HD_ERR_IO, "%s: cannot create: %s", path, strerror(err));
        free(af->path);
        free(af->tmp_path);
        free(sink);
        af->path = af->tmp_path = NULL;
        return st;
    }
    af->sink = sink;
    return HD_OK;
}

int hd_atomic_fd(const hd_atomic_file *af)
{
    const atomic_sink *sink = af->sink;
    return sink ? sink->fd : -1;
}

int hd_atomic_errno(const hd_atomic_file *af)
{
    const atomic_sink *sink = af->sink;
    return sink && sink->err ? sink->err : EIO;
}

static void atomic_release(hd_atomic_file *af)
{
    free(af->path);
    free(af->tmp_path);
    free(af->sink);
    af->path = af->tmp_path = NULL;
    af->sink = NULL;
    af->f = NULL;
}

void hd_atomic_abort(hd_atomic_file *af)
{
    const atomic_sink *sink = af->sink;
    if (af->f) fclose(af->f);
    if (sink) hd_note_write_errno(sink->err); /* a writer gave up after a failed write */
    if (af->tmp_path) unlink(af->tmp_path);
    atomic_release(af);
}

static int durable_writes = 1;

void hd_set_durable_writes(int on) { durable_writes = on != 0; }

/* ---- output sets: the pending renames of this thread's open set */
typedef struct pending_rename {
    char *tmp_path, *path;
} pending_rename;

static _Thread_local int set_open;
static _Thread_local pending_rename *set_v;
static _Thread_local int set_n, set_cap;

void hd_atomic_set_begin(void)
{
    set_open = 1;
    set_n = 0;
}

hd_status hd_atomic_set_end(int commit)
{
    hd_status st = HD_OK;
    int renamed = 0;
    for (int i = 0; i < set_n; i++) {
        if (commit && st == HD_OK) {
            if (rename(set_v[i].tmp_path, set_v[i].path) == 0) {
                renamed = i + 1;
                continue;
            }
            hd_note_write_errno(errno);
            st = hd_fail(HD_ERR_IO, "%s: write failed: %s", set_v[i].path, strerror(errno));
        }
        unlink(set_v[i].tmp_path);
    }
    /* a rename failed part way: take back the set's files already renamed */
    if (st != HD_OK)
        for (int i = 0; i < renamed; i++) unlink(set_v[i].path);
    for (int i = 0; i < set_n; i++) {
        free(set_v[i].tmp_path);
        free(set_v[i].path);
    }
    free(set_v);
    set_v = NULL;
    set_n = set_cap = 0;
    set_open = 0;
    return st;
}

static hd_status atomic_commit(hd_atomic_file *af, int sync)
{
    atomic_sink *sink = af->sink;
    int failed = ferror(af->f) || fflush(af->f) != 0 || (sync && fsync(sink->fd) != 0);
    int err = sink->err ? sink->err : errno;
    if (fclose(af->f) != 0 && !failed) {
        failed = 1;
        err = sink->err ? sink->err : errno;
    }
    af->f = NULL;
    if (!failed && set_open) {
        if (set_n == set_cap) {
            int cap = set_cap ? 2 * set_cap : 8;
            pending_rename *v = realloc(set_v, (size_t)cap * sizeof *v);
            if (!v) {
                failed = 1;
                err = ENOMEM;
            } else {
                set_v = v;
                set_cap = cap;
            }
        }
        if (!failed) {
            set_v[set_n].tmp_path = af->tmp_path;
            set_v[set_n].path = af->path;
            set_n++;
            af->tmp_path = af->path = NULL;
            atomic_release(af);
            return HD_OK;
        }
    }
    if (!failed && rename(af->tmp_path, af->path) != 0) {
        failed = 1;
        err = errno;
    }
    if (failed) {
        hd_note_write_errno(err ? err : EIO);
        hd_status st = hd_fail(HD_ERR_IO, "%s: write failed: %s", af->path, strerror(err ? err : EIO));
        unlink(af->tmp_path);
        atomic_release(af);
        return st;
    }
    atomic_release(af);
    return HD_OK;
}

hd_status hd_atomic_commit(hd_atomic_file *af) { return atomic_commit(af, durable_writes); }

hd_status hd_atomic_commit_durable(hd_atomic_file *af) { return atomic_commit(af, 1); }

FILE *hd_open_append(const char *path)
{
    if (hd_check_not_symlink(path) != HD_OK) return NULL;
    int fd = open(path, O_WRONLY | O_APPEND | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0644);
    if (fd < 0) {
        hd_fail(HD_ERR_IO, "%s: cannot open for appending: %s", path, strerror(errno));
        return NULL;
    }
    FILE *f = fdopen(fd, "a");
    if (!f) {
        hd_fail(HD_ERR_IO, "%s: cannot open for appending: %s", path, strerror(errno));
        close(fd);
    }
    return f;
}

/* ---- stale temporaries: "NAME.tmp.HOST.PID.HEX16" of this host whose PID is not a live process */

/* The PID of a temporary's name when it is one of ours made on this host (HOST equal to `host`),
 * else 0: another host's PID says nothing about the processes here, and a name without a host
 * (earlier hdnet wrote "NAME.tmp.PID.HEX16") cannot say where it was made. */
static long temporary_pid(const char *name, const char *host)
{
    /* read from the end: ".HEX16", ".PID", then ".tmp.HOST" must end what is left */
    size_t len = strlen(name), hn = strlen(host), infix = strlen(HD_TMP_INFIX);
    if (len < 17 || name[len - 17] != '.' || strspn(name + len - 16, "0123456789abcdef") != 16) return 0;
    size_t dot = len - 17, start = dot;
    while (start > 0 && name[start - 1] >= '0' && name[start - 1] <= '9') start--;
    if (start == dot || dot - start > 10 || start < infix + hn + 1 || name[start - 1] != '.') return 0;
    const char *tail = name + start - 1 - hn - infix; /* ".tmp.HOST" */
    if (memcmp(tail, HD_TMP_INFIX, infix) != 0 || memcmp(tail + infix, host, hn) != 0) return 0;
    long pid = strtol(name + start, NULL, 10);
    return pid > 0 ? pid : 0;
}

int hd_remove_stale_temporaries(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) return 0;
    char host[HD_HOST_TAG_SIZE];
    hd_host_tag(host);
    int removed = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        long pid = temporary_pid(e->d_name, host);
        if (pid <= 0 || pid == (long)getpid()) continue;
        if (kill((pid_t)pid, 0) == 0 || errno != ESRCH) continue; /* alive (or not ours to judge) */
        if (unlinkat(dirfd(d), e->d_name, 0) == 0) removed++;
    }
    closedir(d);
    return removed;
}

/* ---- the run-folder lock: flock() on DIR/.hdnet.lock, released when the process ends (even by
 * kill -9), so a stale lock file never blocks a later run. */
hd_status hd_lock_folder(const char *dir, int *fd_out)
{
    *fd_out = -1;
    char *path = hd_path_join(dir, ".hdnet.lock");
    if (!path) return HD_ERR_NOMEM;
    int fd = open(path, O_RDWR | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0644);
    if (fd < 0) {
        hd_status st = hd_fail(HD_ERR_IO, "%s: cannot create the lock file: %s", path, strerror(errno));
        free(path);
        return st;
    }
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
        int err = errno;
        close(fd);
        hd_status st = err == EWOULDBLOCK
                           ? hd_fail(HD_ERR_IO, "%s: another hdnet process is writing into this folder (it holds %s)",
                                     dir, path)
                           : hd_fail(HD_ERR_IO, "%s: cannot lock: %s", path, strerror(err));
        free(path);
        return st;
    }
    free(path);
    *fd_out = fd;
    return HD_OK;
}

void hd_unlock_folder(int fd)
{
    if (fd >= 0) close(fd);
}
