/* SPDX-License-Identifier: MIT */
/* Fast number formatting for CSV rows (fmt.c): the same bytes as snprintf "%.17g" and "%ld". */
#ifndef DTH_CLI_FMT_H
#define DTH_CLI_FMT_H

#include <stddef.h>

/* Longest output of dth_fmt_g17, with its NUL. */
#define DTH_FMT_G17_MAX 32

/* Write x as snprintf(out, 32, "%.17g", x) would; returns the length (without the NUL). */
size_t dth_fmt_g17(double x, char *out);
/* Write v as "%ld"; returns the length. */
size_t dth_fmt_long(long v, char *out);

#endif
