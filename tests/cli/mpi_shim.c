/* SPDX-License-Identifier: MIT */
/*
 * An LD_PRELOAD shim for dth sweep's MPI tests (check_sweep.sh), through MPI's profiling interface:
 *   DTH_SHIM_THREAD_SINGLE=1   MPI_Init_thread reports MPI_THREAD_SINGLE as the level provided
 *   DTH_SHIM_FAIL_MALLOC=N     on rank 0 (OMPI_COMM_WORLD_RANK=0), malloc(N) fails (NULL, ENOMEM)
 */
#define _GNU_SOURCE
#include <errno.h>
#include <mpi.h>
#include <stdlib.h>
#include <string.h>

void *__libc_malloc(size_t n); /* glibc's own */
void *malloc(size_t n);

int MPI_Init_thread(int *argc, char ***argv, int required, int *provided)
{
    int rc = PMPI_Init_thread(argc, argv, required, provided);
    const char *e = getenv("DTH_SHIM_THREAD_SINGLE");
    if (e && !strcmp(e, "1")) *provided = MPI_THREAD_SINGLE;
    return rc;
}

void *malloc(size_t n)
{
    static long fail = -1; /* the size that fails on rank 0; 0: none */
    if (fail < 0) {
        const char *e = getenv("DTH_SHIM_FAIL_MALLOC"), *r = getenv("OMPI_COMM_WORLD_RANK");
        fail = e && r && !strcmp(r, "0") ? strtol(e, NULL, 10) : 0;
    }
    if (fail > 0 && n == (size_t)fail) {
        errno = ENOMEM;
        return NULL;
    }
    return __libc_malloc(n);
}
