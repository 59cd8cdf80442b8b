/* SPDX-License-Identifier: MIT */
/*
 * dth run's HDF5 output format (outfmt.h; meson feature 'hdf5'): tables of doubles, one row per
 * sample, written crash-safely like the CSV (a temporary FILE.tmp.PID.XXXXXX of lib/tempfile.h,
 * fsync'ed and renamed when the run ends). Each table is a 2-D dataset (rows x columns, chunked,
 * extendible) with its column names as the attribute "columns"; the file carries the scene text
 * and the provenance as root attributes; the events are its table /events. The values are the
 * doubles the CSV prints, bit for bit.
 */
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "run_out.h"

typedef struct h5file h5file;
typedef struct h5table h5table;
#include "tempfile.h" /* lib/ (cli/meson.build puts it on the include path) */

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

static h5file *h5_open(const char *path, char *err, size_t errlen)
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

static int h5_attr(h5file *f, const char *name, const char *text)
{
    return attr_string(f->file, name, text);
}

static h5table *h5_table(h5file *f, const char *name, size_t ncol, const char *columns)
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

static int h5_row(h5table *t, const double *v)
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

static int h5_finish(h5file *f, char *err, size_t errlen)
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

static void h5_abort(h5file *f)
{
    if (!f) return;
    char *tmp = strdup(f->tmp);
    release(f);
    if (tmp) unlink(tmp);
    free(tmp);
}


#else /* without HDF5 */

static h5file *h5_open(const char *path, char *err, size_t errlen)
{
    snprintf(err, errlen, "cannot write '%s': this dth was built without HDF5 (meson setup -Dhdf5=enabled, "
             "Debian package libhdf5-dev)", path);
    return NULL;
}
static int h5_attr(h5file *f, const char *name, const char *text) { (void)f, (void)name, (void)text; return -1; }
static h5table *h5_table(h5file *f, const char *name, size_t ncol, const char *columns)
{
    (void)f, (void)name, (void)ncol, (void)columns;
    return NULL;
}
static int h5_row(h5table *t, const double *v) { (void)t, (void)v; return -1; }
static int h5_finish(h5file *f, char *err, size_t errlen) { (void)f, (void)err, (void)errlen; return -1; }
static void h5_abort(h5file *f) { (void)f; }

#endif

/* ---------------------------------------------------------------- the format */

/* The format's state: the file and its tables. */
typedef struct h5state {
    h5file *f;
    h5table *traj, *ev;
} h5state;

/* "dth VERSION; command: dth ARGS..." (malloc'd; NULL: out of memory). */
static char *provenance(int argc, char **argv)
{
    size_t cl = 64;
    for (int i = 0; i < argc; i++) cl += strlen(argv[i]) + 1;
    char *prov = malloc(cl);
    if (prov) {
        size_t k = (size_t)snprintf(prov, cl, "dth %s; command: dth", DTH_VERSION_STRING);
        for (int i = 0; i < argc; i++) k += (size_t)snprintf(prov + k, cl - k, " %s", argv[i]);
    }
    return prov;
}

/* The attribute NAME_codes of a code kind: "0 NAME, 1 NAME, ...". 0 or -1. */
static int code_attr(run_out *r, h5file *f, const char *attr, int kind)
{
    size_t n = run_code_count(r, kind), nl = 8;
    for (size_t i = 0; i < n; i++) nl += strlen(run_code_name(r, kind, (long)i)) + 24;
    char *names = malloc(nl);
    if (!names) return -1;
    size_t k = 0;
    for (size_t i = 0; i < n; i++)
        k += (size_t)snprintf(names + k, nl - k, "%s%zu %s", i ? ", " : "", i, run_code_name(r, kind, (long)i));
    int rc = h5_attr(f, attr, names);
    free(names);
    return rc;
}

static void h5fmt_release(run_out *r)
{
    h5state *st = r->fmt_state;
    if (!st) return;
    h5_abort(st->f);
    free(st);
    r->fmt_state = NULL;
}

static int h5fmt_open(run_out *r, const char *path, const char *ev_path, int argc, char **argv)
{
    (void)ev_path;
    char herr[1200];
    size_t tl;
    char *text = NULL;
    h5state *st = calloc(1, sizeof *st);
    if (st && dth_scene_text(r->scene, NULL, NULL, &text, &tl)) text = NULL;
    if (st && text) st->f = h5_open(path, herr, sizeof herr);
    if (!st || !st->f) {
        if (st && text) cli_error("%s%s%s", r->out_origin ? r->out_origin : "", r->out_origin ? ": " : "", herr);
        else cli_error("out of memory");
        free(text);
        free(st);
        return CLI_USAGE;
    }
    r->fmt_state = st;
    /* provenance: the version and the command line; the scene as run */
    char *prov = provenance(argc, argv);
    int hrc = !prov || h5_attr(st->f, "scene", text) || h5_attr(st->f, "provenance", prov) ||
              code_attr(r, st->f, "region_codes", COL_REGION) || code_attr(r, st->f, "branch_codes", COL_BRANCH) ||
              !(st->traj = h5_table(st->f, "trajectory", r->ncol, run_columns(r, 0)));
    free(text);
    free(prov);
    if (!hrc && r->rs->nevents)
        hrc = code_attr(r, st->f, "event_codes", COL_EVENT) ||
              !(st->ev = h5_table(st->f, "events", r->encol, run_columns(r, 1)));
    if (hrc) {
        cli_error("cannot write '%s': HDF5 error", path);
        h5fmt_release(r);
        return CLI_FAIL;
    }
    return 0; /* rows go to HDF5; standard output stays empty */
}

static int h5fmt_header(run_out *r)
{
    (void)r; /* the column names are the tables' attributes, written when they were made */
    return 0;
}

static int h5fmt_row(run_out *r, int ev, const double *v)
{
    h5state *st = r->fmt_state;
    return h5_row(ev ? st->ev : st->traj, v) ? -1 : 0;
}

static int h5fmt_finish(run_out *r)
{
    h5state *st = r->fmt_state;
    char herr[1200];
    int hrc = h5_finish(st->f, herr, sizeof herr);
    free(st);
    r->fmt_state = NULL;
    if (hrc) cli_error("%s", herr);
    return hrc ? -1 : 0;
}

static void h5fmt_failed(run_out *r, const char *path, const char *ev_path)
{
    (void)ev_path;
    cli_error("cannot write '%s' (HDF5)", path);
    h5fmt_release(r);
}

static const char *const h5_ext[] = {".h5", ".hdf5", NULL};

const out_format cli_format_hdf5 = {"HDF5", h5_ext, 1, 0, h5fmt_open, h5fmt_header, h5fmt_row, h5fmt_finish,
                                    h5fmt_failed, h5fmt_release};
