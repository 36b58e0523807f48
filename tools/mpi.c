/* mpi.c: MPI_COMM_WORLD for the hdnet tool (see mpi.h). Built with MPI when the Makefile found
 * mpicc (HD_HAVE_MPI); otherwise every process is rank 0 of 1, and a launch under mpirun with more
 * than one rank is refused with the packages to install. */
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "mpi.h"
#include "hdnet.h"
#include "hdnet_tool.h"
#if HD_HAVE_MPI
#include <mpi.h>
#endif

#if HD_HAVE_MPI
static int mpi_on; /* MPI_Init was called */
#endif
static int mpi_tried, mpi_init_code, mpi_rank, mpi_ranks = 1;
static double mpi_seconds;

/* The size of the job the launcher says this process belongs to (1 when not launched by one). */
static int launcher_ranks(void)
{
    const char *vars[] = {"OMPI_COMM_WORLD_SIZE", "PMIX_SIZE", "PMI_SIZE", "SLURM_NTASKS", NULL};
    for (int i = 0; vars[i]; i++) {
        const char *v = getenv(vars[i]);
        if (v && atoi(v) > 0) return atoi(v);
    }
    return 1;
}

int cli_mpi_init(int *argc, char ***argv)
{
    if (mpi_tried) return mpi_init_code; /* once per process: train and the batch layer both call it */
    mpi_tried = 1;
    mpi_init_code = 1; /* until it succeeds */
    int want = launcher_ranks();
#if HD_HAVE_MPI
    /* Under Slurm without srun's MPI plugin SLURM_NTASKS alone does not make an MPI job. */
    if (want > 1 || getenv("OMPI_COMM_WORLD_SIZE") || getenv("PMIX_RANK")) {
        int provided;
        if (MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
            fprintf(stderr, "hdnet: MPI_Init failed\n");
            return 1;
        }
        mpi_on = 1;
        MPI_Comm_rank(MPI_COMM_WORLD, &mpi_rank);
        MPI_Comm_size(MPI_COMM_WORLD, &mpi_ranks);
    }
    return mpi_init_code = 0;
#else
    (void)argc;
    (void)argv;
    if (want > 1 && !getenv("SLURM_NTASKS")) {
        fprintf(stderr, "hdnet: started as one of %d MPI ranks, but this hdnet was built without MPI: install "
                        "Open MPI (apt-get install libopenmpi-dev openmpi-bin) and rebuild (make)\n", want);
        return 1;
    }
    return mpi_init_code = 0;
#endif
}

void cli_mpi_finish(void)
{
#if HD_HAVE_MPI
    if (mpi_on) MPI_Finalize();
    mpi_on = 0;
#endif
}

int cli_mpi_rank(void) { return mpi_rank; }
int cli_mpi_ranks(void) { return mpi_ranks; }
double cli_mpi_seconds(void) { return mpi_seconds; }

void cli_mpi_abort(int code)
{
#if HD_HAVE_MPI
    if (mpi_on && mpi_ranks > 1) MPI_Abort(MPI_COMM_WORLD, code);
#endif
    (void)code;
}

#if HD_HAVE_MPI
/* Rank 0 cannot gather what the ranks send: ends the job rather than leave them waiting. */
static void root_out_of_memory(void)
{
    fprintf(stderr, "hdnet: rank 0: out of memory gathering the results of %d ranks\n", mpi_ranks);
    MPI_Abort(MPI_COMM_WORLD, 1);
}

static hd_status sum(void *x, size_t n, MPI_Datatype type, const char *what)
{
    double t0 = MPI_Wtime();
    /* one call per buffer; counts beyond INT_MAX go in INT_MAX pieces */
    size_t esz = type == MPI_FLOAT ? sizeof(float) : sizeof(double);
    for (size_t done = 0; done < n;) {
        int k = n - done > INT_MAX ? INT_MAX : (int)(n - done);
        if (MPI_Allreduce(MPI_IN_PLACE, (char *)x + done * esz, k, type, MPI_SUM, MPI_COMM_WORLD) != MPI_SUCCESS)
            return hd_fail(HD_ERR_IO, "MPI_Allreduce of %zu %s failed", n, what);
        done += (size_t)k;
    }
    mpi_seconds += MPI_Wtime() - t0;
    return HD_OK;
}
#endif

hd_status cli_mpi_sum_floats(void *ctx, float *x, size_t n)
{
    (void)ctx;
#if HD_HAVE_MPI
    if (mpi_on && mpi_ranks > 1) return sum(x, n, MPI_FLOAT, "floats");
#endif
    (void)x;
    (void)n;
    return HD_OK;
}

hd_status cli_mpi_sum_doubles(void *ctx, double *x, size_t n)
{
    (void)ctx;
#if HD_HAVE_MPI
    if (mpi_on && mpi_ranks > 1) return sum(x, n, MPI_DOUBLE, "doubles");
#endif
    (void)x;
    (void)n;
    return HD_OK;
}

char **cli_mpi_gather_text(const char *text)
{
    char **all = calloc((size_t)mpi_ranks, sizeof *all);
#if HD_HAVE_MPI
    if (mpi_on && mpi_ranks > 1) {
        /* every rank takes part in both collectives whatever happened: one that left would hang the
         * rest; the root, which cannot do without its buffers, ends the job instead */
        size_t n = strlen(text) + 1;
        int len = n < INT_MAX ? (int)n : 1, *lens = NULL, *offs = NULL;
        char *buf = NULL;
        if (mpi_rank == 0) {
            lens = calloc((size_t)mpi_ranks, sizeof *lens);
            offs = calloc((size_t)mpi_ranks, sizeof *offs);
            if (!all || !lens || !offs) root_out_of_memory();
        }
        MPI_Gather(&len, 1, MPI_INT, lens, 1, MPI_INT, 0, MPI_COMM_WORLD);
        if (mpi_rank == 0) {
            long long total = 0;
            for (int r = 0; r < mpi_ranks; r++) {
                offs[r] = (int)total;
                total += lens[r];
                if (total >= INT_MAX) root_out_of_memory();
            }
            if (!(buf = malloc((size_t)total))) root_out_of_memory();
        }
        MPI_Gatherv(n < INT_MAX ? text : "", len, MPI_CHAR, buf, lens, offs, MPI_CHAR, 0, MPI_COMM_WORLD);
        for (int r = 0; mpi_rank == 0 && r < mpi_ranks; r++)
            if (!(all[r] = strdup(buf + offs[r]))) root_out_of_memory();
        free(buf);
        free(lens);
        free(offs);
        if (!all) hd_fail(HD_ERR_NOMEM, "out of memory gathering the results");
        return all;
    }
#endif
    if (all && !(all[0] = strdup(text))) {
        free(all);
        all = NULL;
    }
    if (!all) hd_fail(HD_ERR_NOMEM, "out of memory");
    return all;
}

void cli_mpi_free_texts(char **texts)
{
    for (int r = 0; texts && r < mpi_ranks; r++) free(texts[r]);
    free(texts);
}
