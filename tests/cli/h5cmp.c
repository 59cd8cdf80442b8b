/* SPDX-License-Identifier: MIT */
/*
 * h5cmp FILE.h5 TABLE FILE.csv: dth run's HDF5 table TABLE (trajectory: the root group; events: the
 * group /events) holds the CSV's values, bit for bit: its "columns" attribute is the CSV header; each
 * column is a 1-D dataset of that name with one value per CSV row; numeric fields, read back with
 * strtod, equal the dataset's values (doubles as IEEE doubles, counts as integers); the name fields
 * region, branch and event are HDF5 enum datasets whose member names are the CSV's. The file carries
 * the scene and the provenance as root attributes. Exit 0 if so, 1 with a message.
 */
#include <hdf5.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static char *attr(hid_t obj, const char *name)
{
    if (H5Aexists(obj, name) <= 0) return NULL;
    hid_t a = H5Aopen(obj, name, H5P_DEFAULT), t = H5Aget_type(a);
    size_t n = H5Tget_size(t);
    char *s = calloc(n + 1, 1);
    H5Aread(a, t, s);
    H5Tclose(t);
    H5Aclose(a);
    return s;
}

/* One column: its values as doubles, or (enum) its member names. */
typedef struct column {
    const char *name;
    int is_enum;
    double *v;
    char **names;
} column;

static int fail(const char *fmt, const char *a, const char *b)
{
    fprintf(stderr, "h5cmp: ");
    fprintf(stderr, fmt, a, b);
    fprintf(stderr, "\n");
    return 1;
}

/* Read column `name` of group g (rows values); 0 or 1 (printed). */
static int read_column(hid_t g, column *c, hsize_t *rows)
{
    hid_t d = H5Dopen2(g, c->name, H5P_DEFAULT);
    if (d < 0) return fail("no dataset '%s'%s", c->name, "");
    hid_t sp = H5Dget_space(d), t = H5Dget_type(d);
    hsize_t dims[2];
    if (H5Sget_simple_extent_ndims(sp) != 1) return fail("'%s' is not 1-D%s", c->name, "");
    H5Sget_simple_extent_dims(sp, dims, NULL);
    *rows = dims[0];
    H5T_class_t cl = H5Tget_class(t);
    int want_enum = !strcmp(c->name, "region") || !strcmp(c->name, "branch") || !strcmp(c->name, "event");
    c->is_enum = cl == H5T_ENUM;
    if (c->is_enum != want_enum) return fail("column '%s' is %san enum type", c->name, c->is_enum ? "" : "not ");
    if (!c->is_enum && cl != H5T_FLOAT && cl != H5T_INTEGER) return fail("column '%s' is not numeric%s", c->name, "");
    c->v = malloc((dims[0] + 1) * sizeof *c->v);
    if (c->is_enum) {
        /* the codes, then their member names */
        hid_t nt = H5Tget_native_type(t, H5T_DIR_ASCEND);
        size_t sz = H5Tget_size(nt);
        unsigned char *raw = malloc((dims[0] + 1) * sz);
        H5Dread(d, nt, H5S_ALL, H5S_ALL, H5P_DEFAULT, raw);
        c->names = calloc(dims[0] + 1, sizeof *c->names);
        for (hsize_t i = 0; i < dims[0]; i++) {
            char nm[64];
            if (H5Tenum_nameof(nt, raw + i * sz, nm, sizeof nm) < 0) return fail("'%s': a value outside its enum%s", c->name, "");
            c->names[i] = strdup(nm);
        }
        free(raw);
        H5Tclose(nt);
    } else {
        H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, c->v);
    }
    H5Tclose(t);
    H5Sclose(sp);
    H5Dclose(d);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc != 4) {
        fprintf(stderr, "usage: h5cmp FILE.h5 TABLE FILE.csv\n");
        return 2;
    }
    H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
    hid_t f = H5Fopen(argv[1], H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) return fail("cannot open %s%s", argv[1], "");
    char *scene = attr(f, "scene"), *prov = attr(f, "provenance");
    if (!scene || !prov || !strstr(prov, "dth ")) return fail("no scene or provenance attribute%s%s", "", "");
    hid_t g = H5Gopen2(f, strcmp(argv[2], "trajectory") ? argv[2] : "/", H5P_DEFAULT);
    if (g < 0) return fail("no table %s%s", argv[2], "");
    char *cols = attr(g, "columns");
    FILE *csv = fopen(argv[3], "r");
    if (!csv) return fail("cannot read %s%s", argv[3], "");
    static char line[1 << 16];
    if (!fgets(line, sizeof line, csv)) return 1;
    line[strcspn(line, "\n")] = '\0';
    if (!cols || strcmp(cols, line)) return fail("columns '%s' != header '%s'", cols ? cols : "(none)", line);
    column c[512];
    size_t nc = 0;
    hsize_t rows = 0;
    for (char *t = strtok(cols, ","); t && nc < 512; t = strtok(NULL, ",")) {
        memset(&c[nc], 0, sizeof c[nc]);
        c[nc].name = t;
        hsize_t r;
        if (read_column(g, &c[nc], &r)) return 1;
        if (nc && r != rows) return fail("column '%s' has another length than '%s'", t, c[0].name);
        rows = r;
        nc++;
    }
    hsize_t r = 0;
    long checked = 0;
    while (fgets(line, sizeof line, csv)) {
        line[strcspn(line, "\n")] = '\0';
        if (r >= rows) return fprintf(stderr, "h5cmp: the CSV has more rows than %llu\n", (unsigned long long)rows), 1;
        size_t j = 0;
        for (char *p = line;; j++) {
            if (j >= nc) return fprintf(stderr, "h5cmp: row %llu has more than %zu fields\n", (unsigned long long)r, nc), 1;
            size_t l = strcspn(p, ",");
            char fld[64];
            snprintf(fld, sizeof fld, "%.*s", (int)l, p);
            if (c[j].is_enum) {
                if (strcmp(fld, c[j].names[r]))
                    return fprintf(stderr, "h5cmp: row %llu column %s: '%s' vs '%s'\n", (unsigned long long)r, c[j].name, fld,
                                   c[j].names[r]), 1;
            } else {
                char *end;
                double x = strtod(fld, &end), h = c[j].v[r];
                if (*end || end == fld || memcmp(&x, &h, sizeof x))
                    return fprintf(stderr, "h5cmp: row %llu column %s: CSV %s, HDF5 %.17g\n", (unsigned long long)r, c[j].name,
                                   fld, h), 1;
            }
            checked++;
            if (!p[l]) break;
            p += l + 1;
        }
        if (j + 1 != nc) return fprintf(stderr, "h5cmp: row %llu has %zu fields\n", (unsigned long long)r, j + 1), 1;
        r++;
    }
    if (r != rows) return fprintf(stderr, "h5cmp: %llu CSV rows, %llu HDF5 rows\n", (unsigned long long)r, (unsigned long long)rows), 1;
    printf("h5cmp: %s %s: %llu rows x %zu columns, %ld values identical to %s\n", argv[1], argv[2],
           (unsigned long long)r, nc, checked, argv[3]);
    fclose(csv);
    for (size_t k = 0; k < nc; k++) {
        for (hsize_t i = 0; c[k].names && i < rows; i++) free(c[k].names[i]);
        free(c[k].names);
        free(c[k].v);
    }
    free(cols);
    free(scene);
    free(prov);
    H5Gclose(g);
    H5Fclose(f);
    return 0;
}
