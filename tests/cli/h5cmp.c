/* SPDX-License-Identifier: MIT */
/*
 * h5cmp FILE.h5 TABLE FILE.csv: the HDF5 table holds the same doubles as the CSV, bit for bit
 * (every numeric CSV field read back with strtod; name fields through the file's *_codes
 * attributes), and its "columns" attribute is the CSV header. Exit 0 if so, 1 with a message.
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

/* code of `name` in "0 -, 1 I, 2 II" style lists, or -1 */
static long code_of(const char *codes, const char *name)
{
    if (!codes) return -1;
    const char *p = codes;
    while (*p) {
        char *end;
        long c = strtol(p, &end, 10);
        if (end == p) return -1;
        p = end + 1;
        size_t l = strcspn(p, ",");
        if (strlen(name) == l && !strncmp(p, name, l)) return c;
        p += l;
        while (*p == ',' || *p == ' ') p++;
    }
    return -1;
}

int main(int argc, char **argv)
{
    if (argc != 4) {
        fprintf(stderr, "usage: h5cmp FILE.h5 TABLE FILE.csv\n");
        return 2;
    }
    H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
    hid_t f = H5Fopen(argv[1], H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) return fprintf(stderr, "h5cmp: cannot open %s\n", argv[1]), 1;
    hid_t d = H5Dopen2(f, argv[2], H5P_DEFAULT);
    if (d < 0) return fprintf(stderr, "h5cmp: no table %s\n", argv[2]), 1;
    hid_t sp = H5Dget_space(d);
    hsize_t dims[2];
    H5Sget_simple_extent_dims(sp, dims, NULL);
    double *v = malloc((size_t)(dims[0] * dims[1] + 1) * sizeof *v);
    H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v);
    char *cols = attr(d, "columns"), *reg = attr(f, "region_codes"), *br = attr(f, "branch_codes"),
         *ev = attr(f, "event_codes"), *scene = attr(f, "scene"), *prov = attr(f, "provenance");
    if (!scene || !prov || !strstr(prov, "dth ")) return fprintf(stderr, "h5cmp: no scene or provenance attribute\n"), 1;
    FILE *c = fopen(argv[3], "r");
    if (!c) return fprintf(stderr, "h5cmp: cannot read %s\n", argv[3]), 1;
    static char line[1 << 16];
    if (!fgets(line, sizeof line, c)) return 1;
    line[strcspn(line, "\n")] = '\0';
    if (!cols || strcmp(cols, line)) return fprintf(stderr, "h5cmp: columns '%s' != header '%s'\n", cols, line), 1;
    /* the column names, to pick the code list of a name field */
    char *names[512];
    size_t nc = 0;
    for (char *t = strtok(cols, ","); t && nc < 512; t = strtok(NULL, ",")) names[nc++] = t;
    if (nc != dims[1]) return fprintf(stderr, "h5cmp: %zu names, %llu columns\n", nc, (unsigned long long)dims[1]), 1;
    hsize_t r = 0;
    long checked = 0;
    while (fgets(line, sizeof line, c)) {
        line[strcspn(line, "\n")] = '\0';
        if (r >= dims[0]) return fprintf(stderr, "h5cmp: the CSV has more rows than %llu\n", (unsigned long long)dims[0]), 1;
        size_t j = 0;
        for (char *p = line;; j++) {
            if (j >= dims[1])
                return fprintf(stderr, "h5cmp: row %llu has more than %llu fields\n", (unsigned long long)r,
                               (unsigned long long)dims[1]), 1;
            size_t l = strcspn(p, ",");
            char fld[64];
            snprintf(fld, sizeof fld, "%.*s", (int)l, p);
            double h = v[r * dims[1] + j], x;
            char *end;
            x = strtod(fld, &end);
            if (*end || end == fld) {
                const char *codes = !strcmp(names[j], "region") ? reg : !strcmp(names[j], "branch") ? br
                                    : !strcmp(names[j], "event") ? ev : NULL;
                long k = code_of(codes, fld);
                if (k < 0 || (double)k != h)
                    return fprintf(stderr, "h5cmp: row %llu column %s: '%s' vs code %g\n", (unsigned long long)r, names[j], fld, h), 1;
            } else if (memcmp(&x, &h, sizeof x)) {
                return fprintf(stderr, "h5cmp: row %llu column %s: CSV %s, HDF5 %.17g\n", (unsigned long long)r, names[j], fld, h), 1;
            }
            checked++;
            if (!p[l]) break;
            p += l + 1;
        }
        if (j + 1 != dims[1]) return fprintf(stderr, "h5cmp: row %llu has %zu fields\n", (unsigned long long)r, j + 1), 1;
        r++;
    }
    if (r != dims[0]) return fprintf(stderr, "h5cmp: %llu CSV rows, %llu HDF5 rows\n", (unsigned long long)r, (unsigned long long)dims[0]), 1;
    printf("h5cmp: %s %s: %llu rows, %ld values identical to %s\n", argv[1], argv[2], (unsigned long long)r, checked, argv[3]);
    fclose(c);
    free(v);
    free(cols);
    free(reg);
    free(br);
    free(ev);
    free(scene);
    free(prov);
    H5Sclose(sp);
    H5Dclose(d);
    H5Fclose(f);
    return 0;
}
