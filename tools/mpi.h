/* mpi.h: the hdnet tool's side of data-parallel work on MPI (Open MPI from Debian). The library
 * knows nothing of MPI: the trainer takes an hd_reducer (a rank, a rank count and a sum over all
 * ranks), and the batch commands take a share of their files; this file supplies both from
 * MPI_COMM_WORLD when the tool was built with MPI (HD_HAVE_MPI) and was started by mpirun or srun.
 * Without MPI, or outside a launcher, the process is rank 0 of 1 and nothing here calls MPI. */
#ifndef HD_TOOLS_MPI_H
#define HD_TOOLS_MPI_H

#include "hdnet.h"

/* Initialises MPI if this process was started by an MPI launcher (and the tool has MPI); 0 on
 * success. Without MPI support under a launcher with more than one rank it prints how to get it
 * and returns nonzero. Call before any other cli_mpi_ call; later calls return the first one's
 * result. */
int cli_mpi_init(int *argc, char ***argv);
/* MPI_Finalize, if cli_mpi_init initialised MPI. */
void cli_mpi_finish(void);
int cli_mpi_rank(void);
int cli_mpi_ranks(void);
/* Ends every rank of the job with exit code `code` (MPI_Abort); a no-op for a single process. */
void cli_mpi_abort(int code);
/* Sums x[0..n) over all ranks, in place (MPI_Allreduce); HD_OK at once for one rank. */
hd_status cli_mpi_sum_floats(void *ctx, float *x, size_t n);
hd_status cli_mpi_sum_doubles(void *ctx, double *x, size_t n);
/* Gathers one string per rank on rank 0 (MPI_Gather + MPI_Gatherv; every rank must call it):
 * rank 0 gets an array of cli_mpi_ranks() strings in rank order, other ranks an array of NULLs
 * (free both with cli_mpi_free_texts). NULL with the reason set when out of memory. */
char **cli_mpi_gather_text(const char *text);
void cli_mpi_free_texts(char **texts);
/* Seconds spent in the sums so far (for the scaling figures). */
double cli_mpi_seconds(void);

#endif /* HD_TOOLS_MPI_H */
