/* SPDX-License-Identifier: MIT */
/*
 * Pieces of crash-safe files shared by the library (checkpoint.c) and the CLI (cli/outfile.c,
 * cli/h5out.c), which links the shared library where dth__ symbols are hidden: hence static
 * inline, a copy in each. Not installed.
 *
 * The temporaries' names are a contract: "PATH.tmp.PID.XXXXXX", where cli_clean_stale removes
 * those whose writer (PID) no longer runs, the library's checkpoint temporaries included.
 */
#ifndef DTH_TEMPFILE_H
#define DTH_TEMPFILE_H

#include <errno.h>
#include <fcntl.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <time.h>
#include <unistd.h>

/* FNV-1a 64: the hash of no bytes, and h continued over n more bytes. */
#define DTH__FNV_OFFSET 14695981039346656037ULL
static inline uint64_t dth__fnv1a(uint64_t h, const void *p, size_t n)
{
    const unsigned char *b = p;
    for (size_t i = 0; i < n; i++) {
        h ^= b[i];
        h *= 1099511628211ULL;
    }
    return h;
}

/* A temporary of the writer's own, "path.tmp.PID.XXXXXX" (into tmp, cap bytes), created with
 * O_EXCL (so it gets the mode any new file gets, where mkstemp's would be 0600); a name that
 * exists is drawn again. Its descriptor (write-only), or -1 with errno. */
static inline int dth__open_unique_temp(const char *path, char *tmp, size_t cap)
{
    static const char al[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789";
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    uint64_t x = ((uint64_t)ts.tv_nsec << 20) ^ (uint64_t)ts.tv_sec ^ ((uint64_t)getpid() << 32) ^ (uint64_t)(uintptr_t)tmp;
    for (int attempt = 0; attempt < 100; attempt++) {
        char s[7];
        for (int i = 0; i < 6; i++) {
            x = x * 6364136223846793005ULL + 1442695040888963407ULL;
            s[i] = al[(x >> 33) % 62];
        }
        s[6] = '\0';
        snprintf(tmp, cap, "%s.tmp.%ld.%s", path, (long)getpid(), s);
        int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd >= 0 || errno != EEXIST) return fd;
    }
    errno = EEXIST;
    return -1;
}

#endif
