/* SPDX-License-Identifier: MIT */
/*
 * HDF5 output of dth run (meson feature 'hdf5'): tables of doubles, one row per sample, written
 * crash-safely like the CSV (a temporary FILE.tmp.PID.XXXXXX of lib/tempfile.h, fsync'ed and
 * renamed when the run ends). Each table is a 2-D
 * dataset (rows x columns, chunked, extendible) with its column names as the attribute
 * "columns"; the file carries the scene text and the provenance as root attributes. The values
 * are the doubles the CSV prints, bit for bit.
 */
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "h5out.h"
#include "../lib/tempfile.h"

#ifdef DTH_HAVE_HDF5
#include <hdf5.h>

enum { CHUNK = 1024 };

struct h5table {
    hid_t dset;
    size_t ncol, rows, nbuf;
    double *buf; /* CHUNK rows */
};

struct h5file {
    hid_t file;
    char *path, *tmp;
    h5table *tables[4];
    int ntables;
};

static int attr_string(hid_t obj, const char *name, const char *text)
{
    hid_t t = H5Tcopy(H5T_C_S1);
    if (t < 0) return -1;
    H5Tset_size(t, strlen(text) + 1);
    H5Tset_strpad(t, H5T_STR_NULLTERM);
    hid_t sp = H5Screate(H5S_SCALAR);
    hid_t a = H5Acreate2(obj, name, t, sp, H5P_DEFAULT, H5P_DEFAULT);
    int rc = a >= 0 && H5Awrite(a, t, text) >= 0 ? 0 : -1;
    if (a >= 0) H5Aclose(a);
    H5Sclose(sp);
    H5Tclose(t);
    return rc;
}

h5file *h5_open(const char *path, char *err, size_t errlen)
{
    H5Eset_auto2(H5E_DEFAULT, NULL, NULL); /* no HDF5 error stack on stderr: we report */
    h5file *f = calloc(1, sizeof *f);
    if (!f) return NULL;
    f->path = strdup(path);
    size_t tcap = strlen(path) + 48;
    f->tmp = malloc(tcap);
    if (!f->path || !f->tmp) {
        free(f->path);
        free(f->tmp);
        free(f);
        snprintf(err, errlen, "out of memory");
        return NULL;
    }
    /* the name is the run's own (created empty, O_EXCL); HDF5 then writes the file there */
    int fd = dth__open_unique_temp(path, f->tmp, tcap);
    if (fd >= 0) close(fd);
    f->file = fd < 0 ? -1 : H5Fcreate(f->tmp, H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    if (f->file < 0) {
        if (fd < 0)
            snprintf(err, errlen, "cannot write '%s': %s", path, strerror(errno));
        else
            snprintf(err, errlen, "cannot write '%s': HDF5 cannot create '%s'", path, f->tmp);
        if (fd >= 0) unlink(f->tmp);
        free(f->path);
        free(f->tmp);
        free(f);
        return NULL;
    }
    return f;
}

int h5_attr(h5file *f, const char *name, const char *text)
{
    return attr_string(f->file, name, text);
}

h5table *h5_table(h5file *f, const char *name, size_t ncol, const char *columns)
{
    if (f->ntables >= 4) return NULL;
    h5table *t = calloc(1, sizeof *t);
    if (!t) return NULL;
    t->ncol = ncol;
    t->buf = malloc((size_t)CHUNK * ncol * sizeof *t->buf);
    hsize_t dims[2] = {0, ncol}, maxd[2] = {H5S_UNLIMITED, ncol}, chunk[2] = {CHUNK, ncol};
    hid_t sp = H5Screate_simple(2, dims, maxd);
    hid_t pl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(pl, 2, chunk);
    t->dset = H5Dcreate2(f->file, name, H5T_IEEE_F64LE, sp, H5P_DEFAULT, pl, H5P_DEFAULT);
    H5Pclose(pl);
    H5Sclose(sp);
    if (!t->buf || t->dset < 0 || attr_string(t->dset, "columns", columns)) {
        if (t->dset >= 0) H5Dclose(t->dset);
        free(t->buf);
        free(t);
        return NULL;
    }
    f->tables[f->ntables++] = t;
    return t;
}

static int flush_table(h5table *t)
{
    if (!t->nbuf) return 0;
    hsize_t dims[2] = {t->rows + t->nbuf, t->ncol}, start[2] = {t->rows, 0}, count[2] = {t->nbuf, t->ncol};
    if (H5Dset_extent(t->dset, dims) < 0) return -1;
    hid_t fs = H5Dget_space(t->dset);
    hid_t ms = H5Screate_simple(2, count, NULL);
    int rc = H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, NULL, count, NULL) >= 0 &&
                     H5Dwrite(t->dset, H5T_NATIVE_DOUBLE, ms, fs, H5P_DEFAULT, t->buf) >= 0
                 ? 0
                 : -1;
    H5Sclose(ms);
    H5Sclose(fs);
    if (!rc) {
        t->rows += t->nbuf;
        t->nbuf = 0;
    }
    return rc;
}

int h5_row(h5table *t, const double *v)
{
    memcpy(t->buf + t->nbuf * t->ncol, v, t->ncol * sizeof *v);
    if (++t->nbuf == CHUNK) return flush_table(t);
    return 0;
}

static void release(h5file *f)
{
    for (int i = 0; i < f->ntables; i++) {
        if (f->tables[i]->dset >= 0) H5Dclose(f->tables[i]->dset);
        free(f->tables[i]->buf);
        free(f->tables[i]);
    }
    if (f->file >= 0) H5Fclose(f->file);
    free(f->path);
    free(f->tmp);
    free(f);
}

int h5_finish(h5file *f, char *err, size_t errlen)
{
    int rc = 0;
    for (int i = 0; i < f->ntables && !rc; i++) rc = flush_table(f->tables[i]);
    if (!rc && H5Fflush(f->file, H5F_SCOPE_GLOBAL) < 0) rc = -1;
    for (int i = 0; i < f->ntables; i++) {
        H5Dclose(f->tables[i]->dset);
        f->tables[i]->dset = -1;
    }
    if (H5Fclose(f->file) < 0) rc = -1;
    f->file = -1;
    /* the data reach the disk before the name does, as with the CSV */
    if (!rc) {
        int fd = open(f->tmp, O_RDONLY | O_CLOEXEC);
        if (fd < 0 || (fsync(fd) && errno != EINVAL)) rc = -1;
        if (fd >= 0) close(fd);
    }
    if (!rc && rename(f->tmp, f->path)) rc = -1;
    if (rc) {
        snprintf(err, errlen, "cannot write '%s' (HDF5)", f->path);
        unlink(f->tmp);
    }
    release(f);
    return rc;
}

void h5_abort(h5file *f)
{
    if (!f) return;
    char *tmp = strdup(f->tmp);
    release(f);
    if (tmp) unlink(tmp);
    free(tmp);
}

int h5_available(void) { return 1; }

#else /* without HDF5 */

h5file *h5_open(const char *path, char *err, size_t errlen)
{
    snprintf(err, errlen, "cannot write '%s': this dth was built without HDF5 (meson setup -Dhdf5=enabled, "
             "Debian package libhdf5-dev)", path);
    return NULL;
}
int h5_attr(h5file *f, const char *name, const char *text) { (void)f, (void)name, (void)text; return -1; }
h5table *h5_table(h5file *f, const char *name, size_t ncol, const char *columns)
{
    (void)f, (void)name, (void)ncol, (void)columns;
    return NULL;
}
int h5_row(h5table *t, const double *v) { (void)t, (void)v; return -1; }
int h5_finish(h5file *f, char *err, size_t errlen) { (void)f, (void)err, (void)errlen; return -1; }
void h5_abort(h5file *f) { (void)f; }
int h5_available(void) { return 0; }

#endif
