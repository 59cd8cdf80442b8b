/* SPDX-License-Identifier: MIT */
/*
 * dth run's CSV output format (outfmt.h): the trajectory and the events as two CSV files written
 * crash-safely by cli_out (outfile.c), numbers as %.17g, codes (region, branch, event) as names.
 * The only format checkpoints can continue: the files' bytes are hashed as they are written.
 */
#include <stdio.h>
#include <string.h>
#include "fmt.h"
#include "run_out.h"

static int csv_open(run_out *r, const char *path, const char *ev_path, int argc, char **argv)
{
    (void)argc, (void)argv;
    if (cli_out_open_from(&r->out, path, r->out_origin)) return CLI_USAGE; /* the output cannot be written */
    if (r->has_ev && cli_out_open_from(&r->ev, ev_path, r->ev_origin)) return CLI_USAGE;
    return 0;
}

static int csv_header(run_out *r)
{
    const char *cols = run_columns(r, 0);
    if (cli_out_line(&r->out, cols, strlen(cols))) return -1;
    if (!r->has_ev) return 0;
    cols = run_columns(r, 1);
    return cli_out_line(&r->ev, cols, strlen(cols));
}

static int csv_row(run_out *r, int ev, const double *v)
{
    const unsigned char *kind = ev ? r->ekind : r->kind;
    size_t ncol = ev ? r->encol : r->ncol;
    char *p = r->line;
    for (size_t c = 0; c < ncol; c++) {
        if (c) *p++ = ',';
        switch (kind[c]) {
        case COL_INT: p += dth_fmt_long((long)v[c], p); break;
        case COL_DBL: p += dth_fmt_g17(v[c], p); break;
        default: {
            const char *s = run_code_name(r, kind[c], (long)v[c]);
            size_t l = strlen(s);
            memcpy(p, s, l);
            p += l;
        }
        }
    }
    cli_out *o = ev ? &r->ev : &r->out;
    if (cli_out_line(o, r->line, (size_t)(p - r->line))) return -1;
    cli_out_maybe_flush(o);
    return 0;
}

static int csv_finish(run_out *r)
{
    return cli_out_finish(&r->out) || (r->has_ev && cli_out_finish(&r->ev)) ? -1 : 0;
}

static void csv_failed(run_out *r, const char *path, const char *ev_path)
{
    if (r->out.failed) cli_error("cannot write '%s': %s", path ? path : "standard output", strerror(r->out.err));
    else if (r->ev.failed) cli_error("cannot write '%s': %s", ev_path, strerror(r->ev.err));
}

static void csv_release(run_out *r)
{
    if (r->out.fd >= 0 && r->out.buf) cli_out_abort(&r->out);
    if (r->ev.fd >= 0 && r->ev.buf) cli_out_abort(&r->ev);
}

static const char *const csv_ext[] = {".csv", NULL};

const out_format cli_format_csv = {"CSV", csv_ext, 0, 1, csv_open, csv_header, csv_row, csv_finish, csv_failed,
                                   csv_release};
