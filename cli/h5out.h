/* SPDX-License-Identifier: MIT */
/* HDF5 tables for dth run (h5out.c); stubs that report the missing feature when built without. */
#ifndef DTH_CLI_H5OUT_H
#define DTH_CLI_H5OUT_H

#include <stddef.h>

typedef struct h5file h5file;
typedef struct h5table h5table;

/* Create a temporary PATH.tmp.PID.XXXXXX (fsync'ed and renamed onto PATH by h5_finish); NULL with
 * a message in err. */
h5file *h5_open(const char *path, char *err, size_t errlen);
/* A string attribute on the file's root group. 0 or -1. */
int h5_attr(h5file *f, const char *name, const char *text);
/* A table `name` of ncol doubles per row; `columns`: its comma-separated column names. */
h5table *h5_table(h5file *f, const char *name, size_t ncol, const char *columns);
/* Append one row (ncol doubles). 0 or -1. */
int h5_row(h5table *t, const double *v);
/* Write out, close, rename into place; frees f. 0, or -1 with a message (the temporary is removed). */
int h5_finish(h5file *f, char *err, size_t errlen);
/* Close and remove the temporary file; frees f. */
void h5_abort(h5file *f);
/* 1 if built with HDF5. */
int h5_available(void);

#endif
