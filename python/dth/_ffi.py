# SPDX-License-Identifier: MIT
"""The C declarations of libdth that the Python package uses (cffi ABI mode), and where the library
is found.

ABI mode needs every struct declared exactly as the C headers lay it out, every function with the
headers' prototype and every constant with the headers' value. The meson test `python-layout`
compiles a C program generated from these declarations (gen_layout.py) against the headers: it
compares every struct size and field offset, every enumerator's value and every function's type
with the compiler's, so a header change that is not mirrored here fails a test instead of
corrupting memory.

Where libdth.so is looked up, in order (the first that exists is used):
  1. the environment variable DTH_LIBRARY (a path to libdth.so; if set, nothing else is tried);
  2. libdth.so in this package's own directory (pip install . puts it there: pyproject.toml);
  3. the library `meson install` installed next to this package (_config.LIBRARY, written at
     install time);
  4. a build of this checkout: <checkout>/build/libdth.so (the package lives in <checkout>/python);
  5. libdth.so.0 through the dynamic linker (LD_LIBRARY_PATH, ld.so.conf).
Each place is found from this file's own path, never from the current directory or sys.path, so
an installed copy loads its own library, whoever else is installed on the machine.
"""
import os

from cffi import FFI

CDEF = r"""
/* status.h */
typedef enum dth_status {
    DTH_OK = 0, DTH_ENOCONV = 1, DTH_ESINGULAR = 2, DTH_ENOROOT = 3, DTH_ENEGOFFSET = 4, DTH_EGHOST = 5,
    DTH_EFOLD = 6, DTH_EDOMAIN = 7, DTH_EREFUSED = 8, DTH_ESTEPSIZE = 9, DTH_ESTOPPED = 10,
    DTH_EINVAL = -1, DTH_ENOMEM = -2, DTH_ELAPACK = -3, DTH_EMODEL = -4, DTH_EIO = -5, DTH_EPARSE = -6,
    DTH_ENOTFOUND = -7, DTH_EUNSUPPORTED = -8
} dth_status;
const char *dth_strerror(int status);
const char *dth_status_name(int status);

/* model.h */
typedef struct dth_allocator {
    void *(*alloc)(void *ctx, size_t size);
    void (*free)(void *ctx, void *ptr);
    void *ctx;
} dth_allocator;
void *dth_calloc(const dth_allocator *a, size_t n, size_t size);
void dth_free(const dth_allocator *a, void *ptr);
typedef struct dth_kv { const char *key; const char *value; } dth_kv;
typedef struct dth_param_spec { const char *key; const char *def; const char *doc; } dth_param_spec;
typedef struct dth_model_args {
    const dth_kv *kv;
    size_t nkv;
    size_t n_hint;
    const dth_allocator *alloc;
    char *err;
    size_t errlen;
} dth_model_args;
typedef enum dth_hess_kind { DTH_HESS_DENSE = 0, DTH_HESS_BANDED = 1 } dth_hess_kind;
enum { DTH_EVAL_H = 1, DTH_EVAL_GRAD = 2, DTH_EVAL_HESS = 4 };
typedef struct dth_model_info {
    size_t n;
    int autonomous;
    int separable;
    dth_hess_kind hess_kind;
    size_t bandwidth;
    double K;
} dth_model_info;
#define DTH_MODEL_TYPE_VERSION 0x44544802
typedef struct dth_model_type {
    unsigned abi;
    size_t size;
    const char *name;
    const char *doc;
    const dth_param_spec *params;
    size_t n_params;
    int (*create)(const dth_model_args *args, void **self, dth_model_info *info);
    void (*destroy)(void *self, const dth_allocator *alloc);
    int (*eval)(const void *self, const double *y, unsigned what, double *H, double *grad, double *hess);
    int (*third)(const void *self, const double *y, const double *u, double *d3);
    size_t (*n_invariants)(const void *self);
    const char *(*invariant_name)(const void *self, size_t i);
    int (*invariants)(const void *self, const double *y, double *out);
    int (*exact)(const void *self, const double *y0, double t, double *y);
    int (*hess_band)(const void *self, const double *y, double *band);
    int (*hdiff)(const void *self, const double *y1, const double *y0, double *dH);
    int (*domain)(const void *self, const double *y, char *why, size_t len);
} dth_model_type;
typedef struct dth_model dth_model;
int dth_model_new(const dth_model_type *type, const dth_kv *kv, size_t nkv, size_t n_hint,
                  const dth_allocator *alloc, dth_model **out, char *err, size_t errlen);
void dth_model_free(dth_model *m);
const dth_model_info *dth_model_get_info(const dth_model *m);
const dth_model_type *dth_model_get_type(const dth_model *m);
size_t dth_model_dof(const dth_model *m);
int dth_model_eval(const dth_model *m, const double *y, unsigned what, double *H, double *grad, double *hess);
size_t dth_model_n_invariants(const dth_model *m);
const char *dth_model_invariant_name(const dth_model *m, size_t i);
int dth_model_invariants(const dth_model *m, const double *y, double *out);
size_t dth_model_work_size(const dth_model *m);
int dth_model_psi(const dth_model *m, const double *y, double *psi, double *dpsi, double *work);
typedef struct dth_model_check_report {
    double grad_err;
    size_t grad_idx;
    double hess_err;
    size_t hess_i, hess_j;
    double sym_err;
    double third_err;
    double band_err;
    double tol;
    int pass;
    char message[200];
} dth_model_check_report;
int dth_model_check(const dth_model *m, const double *y, dth_model_check_report *rep);
const char *dth_args_get(const dth_model_args *a, const char *key);

/* models.h */
typedef struct dth_registry dth_registry;
int dth_registry_new(const dth_allocator *alloc, dth_registry **out);
void dth_registry_free(dth_registry *r);
int dth_registry_add_model(dth_registry *r, const dth_model_type *type);
const dth_model_type *dth_registry_find_model(const dth_registry *r, const char *name);
size_t dth_registry_model_count(const dth_registry *r);
const dth_model_type *dth_registry_model_at(const dth_registry *r, size_t i);
int dth_registry_add_builtin(dth_registry *r);

/* integrator.h */
typedef enum dth_start { DTH_START_MIDPOINT = 0, DTH_START_VERTEX = 1 } dth_start;
typedef enum dth_linsolve {
    DTH_LINSOLVE_AUTO = 0, DTH_LINSOLVE_DENSE = 1, DTH_LINSOLVE_SMALL = 2, DTH_LINSOLVE_BANDED = 3,
    DTH_LINSOLVE_BANDED_LU = 4, DTH_LINSOLVE_SMALL_LU = 5
} dth_linsolve;
typedef enum dth_finish { DTH_FINISH_PLAIN = 0, DTH_FINISH_COMPENSATED = 1, DTH_FINISH_REVERSIBLE = 2 } dth_finish;
typedef struct dth_regularizer dth_regularizer;
typedef struct dth_options {
    size_t size;
    const char *method;
    int order;
    double h;
    dth_start start;
    int has_wp;
    double wp;
    int max_iter;
    double K;
    const dth_allocator *alloc;
    int branch_check;
    dth_regularizer *regularizer;
    dth_linsolve linsolve;
    dth_finish finish;
    int estimate;
    const char *table;
    double band_time;
} dth_options;
typedef enum dth_branch {
    DTH_BRANCH_NONE = 0, DTH_BRANCH_MINUS = 1, DTH_BRANCH_PLUS = 2, DTH_BRANCH_GHOST = 3,
    DTH_BRANCH_EXACT = 4, DTH_BRANCH_REG = 5
} dth_branch;
typedef struct dth_step_info {
    double lambda;
    int iters;
    double residual;
    dth_branch branch;
    unsigned flags;
    int proj_iters;
    double lerr;
} dth_step_info;
enum { DTH_STEP_REGULARIZED = 1, DTH_STEP_CROSSING = 2, DTH_STEP_RESET = 4, DTH_STEP_CLOCK = 8, DTH_STEP_ONEWAY = 16,
       DTH_STEP_NONREVERSIBLE = 28 };
typedef struct dth_integrator dth_integrator;
int dth_options_check(const dth_model *model, dth_options *opt, char *err, size_t errlen);
int dth_integrator_new(const dth_model *model, const dth_options *opt, dth_integrator **out);
void dth_integrator_free(dth_integrator *it);
int dth_integrator_start(dth_integrator *it, const double *q0, const double *p0, double t0);
int dth_integrator_set_vertex(dth_integrator *it, const double *z, double lambda);
int dth_integrator_step(dth_integrator *it, dth_step_info *info);
const double *dth_integrator_vertex(const dth_integrator *it);
const double *dth_integrator_midpoint(const dth_integrator *it);
double dth_integrator_lambda(const dth_integrator *it);
double dth_integrator_direction(const dth_integrator *it);
const char *dth_integrator_method(const dth_integrator *it);
int dth_integrator_order(const dth_integrator *it);
long dth_integrator_steps(const dth_integrator *it);
size_t dth_integrator_dim(const dth_integrator *it);
const char *dth_integrator_errmsg(const dth_integrator *it);
int dth_integrator_tangent(dth_integrator *it, double *M);
int dth_integrator_error(dth_integrator *it, double *eq, double *ep);
int dth_integrator_error_at(dth_integrator *it, const double *z, double *eq, double *ep);
typedef enum dth_region { DTH_REGION_NONE = 0, DTH_REGION_I = 1, DTH_REGION_II = 2, DTH_REGION_III = 3 } dth_region;
typedef struct dth_diag {
    double H;
    double psi;
    double dpsi;
    double K;
    dth_region region;
} dth_diag;
int dth_diagnose(const dth_model *model, const double *z, double lambda_root, double K, dth_diag *d, double *work);
const char *dth_region_name(dth_region r);
const char *dth_branch_name(dth_branch b);

/* methods.h */
size_t dth_method_count(void);
const char *dth_method_name(size_t i);
const char *dth_method_doc(const char *name);

/* run.h */
typedef enum dth_points { DTH_POINTS_VERTICES = 0, DTH_POINTS_MIDPOINTS = 1, DTH_POINTS_TIMES = 2 } dth_points;
typedef enum dth_sample_kind {
    DTH_SAMPLE_VERTEX = 0, DTH_SAMPLE_MIDPOINT = 1, DTH_SAMPLE_TIME = 2, DTH_SAMPLE_END = 3, DTH_SAMPLE_EVENT = 4
} dth_sample_kind;
typedef struct dth_sample {
    dth_sample_kind kind;
    long index;
    long k;
    const double *z;
    const dth_step_info *step;
    double lambda_out;
    const double *za, *zb;
    int event;
    int direction;
    double err_q, err_p;
} dth_sample;
typedef int (*dth_sample_fn)(void *user, const dth_sample *s);
typedef int (*dth_event_fn)(void *user, size_t n, const double *z, double *g);
typedef struct dth_event {
    dth_event_fn g;
    void *user;
    int direction;
    int terminal;
} dth_event;
typedef struct dth_event_spec {
    size_t index;
    double value;
    const size_t *dofs;
    size_t ndofs;
} dth_event_spec;
typedef enum dth_run_stop {
    DTH_RUN_RUNNING = 0, DTH_RUN_END = 1, DTH_RUN_EVENT = 2, DTH_RUN_CALLBACK = 3, DTH_RUN_FAILED = 4,
    DTH_RUN_SAMPLES = 5
} dth_run_stop;
#define DTH_RUN_MAX_SAMPLES_PER_STEP 1000000
typedef struct dth_run_state {
    int started;
    int pending;
    long k;
    long k0;
    long samples;
    long events;
    long j;
    double t;
    double t_first;
    dth_step_info in;
    long crossings;
    long regularized;
    double max_ratio;
    int prev_crossing;
    int stop;
    double t_stop;
    double err_q, err_p;
    double q_max, p_max;
    double lam_max;
    double t_lam_max;
    long nonreversible;
    double e_err, e_scale;
} dth_run_state;
void dth_run_state_init(dth_run_state *st);
typedef struct dth_run_config {
    size_t size;
    int has_t_end;
    double t_end;
    long steps;
    double t0;
    dth_points points;
    long every;
    double dt;
    const double *times;
    size_t ntimes;
    dth_sample_fn sample;
    void *user;
    const dth_event *events;
    size_t nevents;
    dth_sample_fn on_event;
    int (*checkpoint)(void *user, const dth_run_state *st);
    long checkpoint_every;
    int (*progress)(void *user, const dth_run_state *st);
    long progress_every;
    const dth_allocator *alloc;
    double stop_error;
    double step_ratio;
    int local_error;
    double step_max;
} dth_run_config;
void dth_run_config_default(dth_run_config *cfg);
int dth_run_check(const dth_integrator *it, const dth_run_config *cfg, const dth_run_state *st, char *err,
                  size_t errlen);
int dth_run(dth_integrator *it, const dth_run_config *cfg, dth_run_state *st);
int dth_event_coordinate(void *user, size_t n, const double *z, double *g);

/* scene.h */
typedef struct dth_scene dth_scene;
int dth_scene_new(const dth_allocator *alloc, dth_scene **out);
void dth_scene_free(dth_scene *s);
int dth_scene_load(dth_scene *s, const char *path, char *err, size_t errlen);
int dth_scene_load_mem(dth_scene *s, const char *name, const char *text, size_t len, char *err, size_t errlen);
int dth_scene_set(dth_scene *s, const char *assignment, char *err, size_t errlen);
int dth_scene_set_from(dth_scene *s, const char *from, const char *assignment, char *err, size_t errlen);
int dth_scene_check_entry(const char *section, const char *key, const char *value, char *err, size_t errlen);
const char *dth_scene_origin(const dth_scene *s, const char *section, const char *key);
const char *dth_scene_get(const dth_scene *s, const char *section, const char *key);
size_t dth_scene_count(const dth_scene *s);
int dth_scene_entry(const dth_scene *s, size_t i, const char **section, const char **key, const char **value,
                    const char **origin);
enum { DTH_RESUME_ROWS = 1 };
int dth_scene_resume_may_change(const char *section, const char *key, unsigned flags);
int dth_scene_resume_check(const dth_scene *saved, const dth_scene *now, unsigned flags, const char *what,
                           char *err, size_t errlen);
typedef struct dth_run_setup {
    dth_model *model;
    size_t n;
    double *q0, *p0;
    double t0;
    dth_options opt;
    char method[32];
    int has_t_end;
    long steps;
    double t_end;
    char regularize[32];
    char *out_file;
    long every;
    double dt;
    dth_points points;
    int diagnostics;
    dth_event *events;
    dth_event_spec *event_specs;
    const char **event_names;
    size_t nevents;
    size_t *event_dofs;
    char *events_file;
    const dth_allocator *alloc;
    dth_regularizer *regularizer;
    double stop_error;
    double warn_ratio;
    double h_max;
    double tol;
    double pilot;
    double h_asked;
    double step_max;
} dth_run_setup;
int dth_scene_setup(const dth_scene *s, const dth_registry *reg, dth_run_setup *out, char *err, size_t errlen);
void dth_run_setup_clear(dth_run_setup *rs);

/* branch.h */
enum { DTH_ROOT_DOUBLE = 1, DTH_ROOT_ZERO = 2, DTH_ROOT_UNPOLISHED = 4 };
typedef struct dth_root {
    double lambda;
    double s;
    dth_branch cls;
    unsigned flags;
    double residual;
    double slope;
} dth_root;
typedef struct dth_root_set {
    dth_diag vertex;
    int psi_zero;
    int sign_H_psi;
    int sign_H_dpsi;
    double lo, hi;
    double tol;
    long evals;
    size_t count;
    int truncated;
    dth_root root[16];
} dth_root_set;
typedef struct dth_root_options {
    int n_uniform;
    int n_geom;
    int max_iter;
    int polish;
    double K;
} dth_root_options;
void dth_root_options_default(dth_root_options *o);
typedef struct dth_rootfinder dth_rootfinder;
int dth_rootfinder_new(const dth_model *model, const dth_root_options *opt, const dth_allocator *alloc,
                       dth_rootfinder **out);
void dth_rootfinder_free(dth_rootfinder *rf);
int dth_find_roots(dth_rootfinder *rf, const double *z, double L, dth_root_set *out);
const char *dth_root_class_name(const dth_root *r);

/* checkpoint.h */
typedef struct dth_blob { const char *name; const void *data; size_t size; } dth_blob;
int dth_checkpoint_save(const dth_integrator *it, const dth_blob *blobs, size_t nblobs, void *buf, size_t cap,
                        size_t *len);
int dth_checkpoint_verify(const void *buf, size_t len, char *err, size_t errlen);
int dth_checkpoint_restore(dth_integrator *it, const void *buf, size_t len, char *err, size_t errlen);
int dth_checkpoint_save_run(const dth_integrator *it, const dth_run_state *run, const dth_blob *blobs, size_t nblobs,
                            void *buf, size_t cap, size_t *len);
int dth_checkpoint_restore_run(dth_integrator *it, dth_run_state *run, const void *buf, size_t len, char *err,
                               size_t errlen);
int dth_checkpoint_blob(const void *buf, size_t len, const char *name, const void **data, size_t *size);
int dth_checkpoint_model_name(const void *buf, size_t len, char *name, size_t namelen);

/* chaos.h */
typedef struct dth_megno dth_megno;
typedef struct dth_megno_result {
    double megno;
    double y;
    double lyapunov;
    double span;
    long steps;
    double t_stop;
} dth_megno_result;
int dth_megno_new(const dth_integrator *it, const double *delta0, const dth_allocator *alloc, dth_megno **out);
int dth_megno_new_len(const dth_integrator *it, const double *delta0, size_t len, const dth_allocator *alloc,
                      dth_megno **out);
void dth_megno_free(dth_megno *g);
int dth_megno_update(dth_megno *g, dth_integrator *it);
void dth_megno_get(const dth_megno *g, dth_megno_result *r);

/* control.h */
typedef struct dth_control_report {
    size_t size;
    double h0;
    double C;
    double C_hmax;
    double C_tol;
    double step_max;
    int passes;
    long steps;
    double t_pilot;
    int extrapolated;
    double est;
    double est_pred;
    int hmax_restarts;
    int hmax_settled;
    double t_excursion;
    int pilot_status;
    double t_failed;
} dth_control_report;
int dth_run_setup_control(dth_run_setup *rs, dth_control_report *rep, char *err, size_t errlen);
double dth_control_law(double C, double psi, double dpsi);
"""

# Types whose layout the meson test compares with the C compiler's (gen_layout.py).
STRUCTS = ["dth_allocator", "dth_kv", "dth_param_spec", "dth_model_args", "dth_model_info", "dth_model_type",
           "dth_model_check_report", "dth_options", "dth_step_info", "dth_diag", "dth_sample", "dth_event",
           "dth_event_spec", "dth_run_state", "dth_run_config", "dth_run_setup", "dth_root", "dth_root_set",
           "dth_root_options", "dth_blob", "dth_megno_result", "dth_control_report"]

ffi = FFI()
ffi.cdef(CDEF)

_lib = None


def candidates():
    """The paths tried for libdth, in order, as (origin, path)."""
    env = os.environ.get("DTH_LIBRARY")
    if env:
        return [("DTH_LIBRARY", env)]  # only this one: a wrong setting is an error, not a fallback
    here = os.path.dirname(os.path.abspath(__file__))
    out = [("package", os.path.join(here, "libdth.so"))]   # pip install .
    try:
        from . import _config  # written by `meson install`
        out.append(("installed", _config.LIBRARY))
    except ImportError:
        pass
    out.append(("checkout build", os.path.join(here, "..", "..", "build", "libdth.so")))
    out.append(("dynamic linker", "libdth.so.0"))
    return out


def lib():
    """The loaded library (loaded at the first call)."""
    global _lib
    if _lib is None:
        tried = []
        for origin, path in candidates():
            if os.sep in path and not os.path.exists(path):
                tried.append("%s: %s (missing)" % (origin, path))
                continue
            try:
                _lib = ffi.dlopen(path)
                break
            except OSError as e:
                tried.append("%s: %s (%s)" % (origin, path, e))
        if _lib is None:
            raise ImportError("dth: cannot load libdth.so; tried\n  " + "\n  ".join(tried) +
                              "\ninstall the package with its library (pip install --no-build-isolation ., "
                              "docs/python.md) or set DTH_LIBRARY=/path/to/libdth.so")
    return _lib
