/* SPDX-License-Identifier: MIT */
/*
 * dth run's HDF5 output format (outfmt.h; meson feature 'hdf5'), written crash-safely like the CSV
 * (a temporary FILE.tmp.PID.XXXXXX of lib/tempfile.h, fsync'ed and renamed when the run ends). A
 * table is one 1-D dataset per column, named as the CSV's column: the trajectory's at the root (so
 * h5py.File(out)['q1'][:] is q1), the events' in the group /events; each table's CSV header is its
 * group's attribute "columns". Numbers are IEEE doubles, counts (k, iters, ...) 64-bit integers, and
 * region, branch and event HDF5 enum types whose members are the CSV's names. The file carries the
 * scene text and the provenance as root attributes. The values are those the CSV prints, bit for bit.
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

enum { CHUNK = 1024, MAX_TABLES = 2 };

/* One column: its dataset and the memory type its values are written as. */
typedef struct h5col {
    hid_t dset, mtype; /* mtype: a double, a long long, or the column's enum (of signed chars) */
    int kind;          /* COL_* (run_out.h) */
} h5col;

struct h5table {
    hid_t group;
    h5col *col;
    size_t ncol, rows, nbuf;
    double *buf; /* CHUNK rows of ncol values */
    void *cbuf;  /* one column of CHUNK values, converted */
};

struct h5file {
    hid_t file;
    char *path, *tmp;
    h5table *tables[MAX_TABLES];
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

/* The enum type of a code column: its members are the codes' names (run_code_name). */
static hid_t code_type(const run_out *r, int kind)
{
    hid_t t = H5Tenum_create(H5T_NATIVE_SCHAR);
    for (size_t v = 0; t >= 0 && v < run_code_count(r, kind); v++) {
        signed char c = (signed char)v;
        if (H5Tenum_insert(t, run_code_name(r, kind, (long)v), &c) < 0) {
            H5Tclose(t);
            t = -1;
        }
    }
    return t;
}

static void table_free(h5table *t)
{
    for (size_t c = 0; t->col && c < t->ncol; c++) {
        if (t->col[c].dset > 0) H5Dclose(t->col[c].dset);
        if (t->col[c].mtype > 0 && t->col[c].kind >= COL_REGION) H5Tclose(t->col[c].mtype);
    }
    if (t->group > 0) H5Gclose(t->group);
    free(t->col);
    free(t->buf);
    free(t->cbuf);
    free(t);
}

/* One dataset per column of the trajectory (ev = 0: at the root) or the events table (ev = 1: the
 * group /events), with the table's CSV header as the group's attribute "columns". */
static h5table *h5_table(h5file *f, run_out *r, int ev)
{
    if (f->ntables >= MAX_TABLES) return NULL;
    h5table *t = calloc(1, sizeof *t);
    if (!t) return NULL;
    const unsigned char *kind = ev ? r->ekind : r->kind;
    t->ncol = ev ? r->encol : r->ncol;
    t->col = calloc(t->ncol, sizeof *t->col);
    t->buf = malloc((size_t)CHUNK * t->ncol * sizeof *t->buf);
    t->cbuf = malloc((size_t)CHUNK * sizeof(double));
    t->group = ev ? H5Gcreate2(f->file, "events", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT) : H5Gopen2(f->file, "/", H5P_DEFAULT);
    char *names = t->col && t->buf && t->cbuf ? strdup(run_columns(r, ev)) : NULL;
    int ok = names && t->group >= 0 && !attr_string(t->group, "columns", names);
    hsize_t dims[1] = {0}, maxd[1] = {H5S_UNLIMITED}, chunk[1] = {CHUNK};
    hid_t sp = H5Screate_simple(1, dims, maxd), pl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(pl, 1, chunk);
    char *save = NULL, *name = names ? strtok_r(names, ",", &save) : NULL;
    for (size_t c = 0; ok && c < t->ncol; c++, name = strtok_r(NULL, ",", &save)) {
        h5col *col = &t->col[c];
        col->kind = kind[c];
        col->mtype = kind[c] == COL_DBL ? H5T_NATIVE_DOUBLE : kind[c] == COL_INT ? H5T_NATIVE_LLONG : code_type(r, kind[c]);
        hid_t ftype = kind[c] == COL_DBL ? H5T_IEEE_F64LE : kind[c] == COL_INT ? H5T_STD_I64LE : col->mtype;
        col->dset = name && col->mtype >= 0 ? H5Dcreate2(t->group, name, ftype, sp, H5P_DEFAULT, pl, H5P_DEFAULT) : -1;
        ok = col->dset >= 0;
    }
    H5Pclose(pl);
    H5Sclose(sp);
    free(names);
    if (!ok) {
        table_free(t);
        return NULL;
    }
    f->tables[f->ntables++] = t;
    return t;
}

/* Column c of the buffered rows, as its memory type, into t->cbuf. */
static void column_values(h5table *t, size_t c)
{
    for (size_t i = 0; i < t->nbuf; i++) {
        double v = t->buf[i * t->ncol + c];
        if (t->col[c].kind == COL_DBL) ((double *)t->cbuf)[i] = v;
        else if (t->col[c].kind == COL_INT) ((long long *)t->cbuf)[i] = (long long)v;
        else ((signed char *)t->cbuf)[i] = (signed char)v;
    }
}

static int flush_table(h5table *t)
{
    if (!t->nbuf) return 0;
    hsize_t dims[1] = {t->rows + t->nbuf}, start[1] = {t->rows}, count[1] = {t->nbuf};
    hid_t ms = H5Screate_simple(1, count, NULL);
    int rc = ms < 0 ? -1 : 0;
    for (size_t c = 0; !rc && c < t->ncol; c++) {
        hid_t d = t->col[c].dset;
        column_values(t, c);
        hid_t fs = H5Dset_extent(d, dims) < 0 ? -1 : H5Dget_space(d);
        rc = fs >= 0 && H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, NULL, count, NULL) >= 0 &&
                     H5Dwrite(d, t->col[c].mtype, ms, fs, H5P_DEFAULT, t->cbuf) >= 0
                 ? 0
                 : -1;
        if (fs >= 0) H5Sclose(fs);
    }
    if (ms >= 0) H5Sclose(ms);
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
    for (int i = 0; i < f->ntables; i++) table_free(f->tables[i]);
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
    for (int i = 0; i < f->ntables; i++) table_free(f->tables[i]);
    f->ntables = 0;
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
static h5table *h5_table(h5file *f, run_out *r, int ev)
{
    (void)f, (void)r, (void)ev;
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
              !(st->traj = h5_table(st->f, r, 0));
    free(text);
    free(prov);
    if (!hrc && r->rs->nevents) hrc = !(st->ev = h5_table(st->f, r, 1));
    if (hrc) {
        cli_error("cannot write '%s': HDF5 error", path);
        h5fmt_release(r);
        return CLI_FAIL;
    }
    return 0; /* rows go to HDF5; standard output stays empty */
}

static int h5fmt_header(run_out *r)
{
    (void)r; /* the column names are the datasets' names and the groups' attribute, made with them */
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
