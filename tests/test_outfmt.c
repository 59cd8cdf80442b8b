/* SPDX-License-Identifier: MIT */
/*
 * dth run's output formats (cli/outfmt.h, issue 21): the format follows the file name; a format is
 * one entry of the out_format type, and the rows reach it with no format branch elsewhere (a
 * recording format of this file's own gets the headers, every trajectory and event row's values
 * and the finish); the CSV entry prints codes as names.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "cu_main.h"
#include "run_out.h"

static void test_format_for(void)
{
    CU_ASSERT(run_format_for("out/a.h5") == &cli_format_hdf5);
    CU_ASSERT(run_format_for("a.hdf5") == &cli_format_hdf5);
    CU_ASSERT(run_format_for("a.csv") == &cli_format_csv);
    CU_ASSERT(run_format_for("a.txt") == &cli_format_csv);
    CU_ASSERT(run_format_for(".h5") == &cli_format_csv); /* an ending alone is no name */
    CU_ASSERT(run_format_for(NULL) == &cli_format_csv);  /* standard output */
    CU_ASSERT(cli_format_csv.resumable && !cli_format_csv.events_in_file);
    CU_ASSERT(!cli_format_hdf5.resumable && cli_format_hdf5.events_in_file);
}

/* ---- a format of the test's own: it records what it is handed */
typedef struct rec {
    int opened, headers, finished, released, rows[2];
    double last[2][64];
    size_t ncol[2];
} rec;

static int rec_open(run_out *r, const char *path, const char *ev_path, int argc, char **argv)
{
    (void)path, (void)ev_path, (void)argc, (void)argv;
    ((rec *)r->fmt_state)->opened++;
    return 0;
}
static int rec_header(run_out *r)
{
    ((rec *)r->fmt_state)->headers++;
    return 0;
}
static int rec_row(run_out *r, int ev, const double *v)
{
    rec *x = r->fmt_state;
    size_t n = ev ? r->encol : r->ncol;
    x->rows[ev]++;
    x->ncol[ev] = n;
    memcpy(x->last[ev], v, n * sizeof *v);
    return 0;
}
static int rec_finish(run_out *r)
{
    ((rec *)r->fmt_state)->finished++;
    return 0;
}
static void rec_failed(run_out *r, const char *path, const char *ev_path) { (void)r, (void)path, (void)ev_path; }
static void rec_release(run_out *r) { ((rec *)r->fmt_state)->released++; }
static const char *const rec_ext[] = {".rec", NULL};
static const out_format rec_format = {"REC", rec_ext, 1, 0, rec_open, rec_header, rec_row, rec_finish, rec_failed,
                                      rec_release};

/* The pendulum with a section event (diagnostics on), set up. */
static void setup(dth_scene **s, dth_registry **reg, dth_run_setup *rs)
{
    static const char text[] = "[model]\nname = pendulum\n[initial]\nq = 1\np = 0\n[integrator]\nh = 0.05\n"
                               "steps = 10\n[output]\ndiagnostics = yes\n[events]\nsection = p1\n";
    char err[512];
    memset(rs, 0, sizeof *rs);
    CU_ASSERT_FATAL(dth_scene_new(NULL, s) == DTH_OK);
    CU_ASSERT_FATAL(dth_scene_load_mem(*s, "t.ini", text, strlen(text), err, sizeof err) == DTH_OK);
    CU_ASSERT_FATAL(dth_registry_new(NULL, reg) == DTH_OK && dth_registry_add_builtin(*reg) == DTH_OK);
    CU_ASSERT_FATAL(dth_scene_setup(*s, *reg, rs, err, sizeof err) == DTH_OK);
}

static void test_rows_reach_format(void)
{
    dth_scene *s;
    dth_registry *reg;
    dth_run_setup rs;
    setup(&s, &reg, &rs);
    run_out r;
    memset(&r, 0, sizeof r);
    r.out.fd = r.ev.fd = -1;
    rec x;
    memset(&x, 0, sizeof x);
    CU_ASSERT_FATAL(run_rows_init(&r, &rs, 0) == 0);
    r.scene = s;
    r.fmt = &rec_format;
    r.fmt_state = &x;
    CU_ASSERT(run_outputs_open(&r, "t.rec", NULL, 0, NULL) == 0 && x.opened == 1);
    CU_ASSERT(run_headers(&r) == 0 && x.headers == 1);
    /* a vertex sample and an event: z = (q, t, p, wp) */
    double z[4] = {0.5, 1.25, -0.75, 0.125};
    dth_step_info in = {.lambda = 0.05, .iters = 3, .branch = DTH_BRANCH_PLUS, .lerr = NAN};
    dth_sample sm = {.kind = DTH_SAMPLE_VERTEX, .index = 7, .k = 7, .z = z, .step = &in, .lambda_out = 0.05, .event = -1,
                     .err_q = 0.25, .err_p = 0.5};
    CU_ASSERT(run_on_sample(&r, &sm) == 0);
    CU_ASSERT(x.rows[0] == 1 && x.ncol[0] == r.ncol);
    /* k, t, lambda, q1, p1, wp, H, E, (ordinary: the default regularizer), psi, dpsi, region, iters, branch,
     * reversible (with a regularizer), err_q, err_p (the scene's estimate is on) */
    CU_ASSERT(x.last[0][0] == 7 && x.last[0][1] == 1.25 && x.last[0][2] == 0.05 && x.last[0][3] == 0.5 &&
              x.last[0][4] == -0.75 && x.last[0][5] == 0.125);
    CU_ASSERT(x.last[0][r.ncol - 4] == DTH_BRANCH_PLUS && x.last[0][r.ncol - 5] == 3 && x.last[0][r.ncol - 3] == 1);
    CU_ASSERT(x.last[0][r.ncol - 2] == 0.25 && x.last[0][r.ncol - 1] == 0.5);
    /* a step that is not its own reverse (an offset reset): reversible 0 */
    in.flags = DTH_STEP_REGULARIZED | DTH_STEP_RESET;
    CU_ASSERT(run_on_sample(&r, &sm) == 0);
    CU_ASSERT(x.rows[0] == 2 && x.last[0][r.ncol - 3] == 0 && x.last[0][8] == 0);
    in.flags = 0;
    dth_sample ev = {.kind = DTH_SAMPLE_EVENT, .index = 2, .k = 6, .z = z, .step = &in, .event = 0, .direction = -1};
    CU_ASSERT(run_on_event(&r, &ev) == 0);
    /* i, event, direction, k, t, q1, p1, wp, H, E */
    CU_ASSERT(x.rows[1] == 1 && x.ncol[1] == 10);
    CU_ASSERT(x.last[1][0] == 2 && x.last[1][1] == 0 && x.last[1][2] == -1 && x.last[1][3] == 6 && x.last[1][4] == 1.25);
    double H = 0.75 * 0.75 / 2 - cos(0.5);
    CU_ASSERT(fabs(x.last[1][8] - (0.125 + H)) < 1e-15 && fabs(x.last[1][9] - H) < 1e-15); /* H = wp + E, E */
    CU_ASSERT(run_outputs_finish(&r) == 0 && x.finished == 1);
    run_out_free(&r);
    CU_ASSERT(x.released == 1);
    dth_run_setup_clear(&rs);
    dth_scene_free(s);
    dth_registry_free(reg);
}

/* The CSV entry: numbers as %.17g, the event's code as its name, into the events file. */
static void test_csv_names(void)
{
    dth_scene *s;
    dth_registry *reg;
    dth_run_setup rs;
    setup(&s, &reg, &rs);
    run_out r;
    memset(&r, 0, sizeof r);
    r.out.fd = r.ev.fd = -1;
    CU_ASSERT_FATAL(run_rows_init(&r, &rs, 0) == 0);
    r.scene = s;
    r.fmt = run_format_for("x.csv");
    r.has_ev = 1;
    char dir[] = "/tmp/dth_outfmt.XXXXXX", tr[64], evp[64];
    CU_ASSERT_FATAL(mkdtemp(dir) != NULL);
    snprintf(tr, sizeof tr, "%s/t.csv", dir);
    snprintf(evp, sizeof evp, "%s/e.csv", dir);
    CU_ASSERT_FATAL(run_outputs_open(&r, tr, evp, 0, NULL) == 0);
    CU_ASSERT(run_headers(&r) == 0);
    double z[4] = {0.5, 1.25, -0.75, 0.125};
    dth_step_info in = {.lambda = 0.05, .iters = 3, .branch = DTH_BRANCH_PLUS, .lerr = NAN};
    dth_sample ev = {.kind = DTH_SAMPLE_EVENT, .index = 2, .k = 6, .z = z, .step = &in, .event = 0, .direction = -1};
    CU_ASSERT(run_on_event(&r, &ev) == 0);
    CU_ASSERT(run_outputs_finish(&r) == 0);
    char line[2][256] = {"", ""};
    FILE *f = fopen(evp, "r");
    CU_ASSERT_FATAL(f != NULL);
    CU_ASSERT(fgets(line[0], sizeof line[0], f) && fgets(line[1], sizeof line[1], f));
    fclose(f);
    CU_ASSERT_STRING_EQUAL(line[0], "i,event,direction,k,t,q1,p1,wp,H,E\n");
    CU_ASSERT(strncmp(line[1], "2,section,-1,6,1.25,0.5,-0.75,0.125,", 36) == 0);
    unlink(tr);
    unlink(evp);
    rmdir(dir);
    run_out_free(&r);
    dth_run_setup_clear(&rs);
    dth_scene_free(s);
    dth_registry_free(reg);
}

static CU_TestInfo outfmt_tests[] = {
    {"the format follows the file name", test_format_for},
    {"rows, headers and the finish reach a format's entry", test_rows_reach_format},
    {"CSV prints codes as names", test_csv_names},
    CU_TEST_INFO_NULL,
};

CU_SuiteInfo dth_test_suites[] = {
    {.pName = "outfmt", .pTests = outfmt_tests},
    CU_SUITE_INFO_NULL,
};
