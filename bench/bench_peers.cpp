// SPDX-License-Identifier: MIT
/*
 * Work-precision against the peers a user would pick (issue 22 item 4; the paper's DTH step, Theorem
 * "DTH Equations", of order 2 and its composition of order 4), built from Debian packages: GSL odeiv2
 * (rk8pd, msadams, rk4imp; libgsl-dev), Boost.Odeint (runge_kutta_fehlberg78, bulirsch_stoer,
 * symplectic_rkn_sb3a_mclachlan; libboost-dev) and dth's own baselines (gauss4, verlet), all on the
 * same model callbacks. Scenes: Kepler e = 0.6 and e = 0.9 over 10^3 and 10^4 orbits (exact reference:
 * Kepler's equation), Henon-Heiles at E = 1/8 to t = 10^4 (a regular orbit; reference GSL rk8pd at
 * 1e-14), a 2-D chain of 100 particles (reference rk8pd at 1e-14). Prints, per scene, CPU at equal
 * final position error (each curve interpolated in log-log) as dth/peer ratios for orders 2 and 4, and
 * writes each curve as CSV for scripts/plot-peers.sh (docs/performance.md).
 * Usage: bench_peers [--full] [--out DIR] [--only SCENE]   (quick mode: seconds, shortened scenes)
 */
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <utility>
#include <vector>
#include <boost/numeric/odeint.hpp>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_odeiv2.h>
#include "dth/dth.h"
#include "../docs/examples/henon_heiles.h"

namespace ode = boost::numeric::odeint;
typedef std::vector<double> vec;

static double cpu_now()
{
    timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* ---- the right-hand side from the model: x = (q, p) ---- */

struct Rhs {
    const dth_model *m;
    size_t n;
    mutable vec y, g, h;
    Rhs(const dth_model *mm) : m(mm), n(dth_model_dof(mm)), y(2 * n + 1), g(2 * n + 1), h(0) {}
    int eval(const double *x, double t, double *dx) const
    {
        std::copy(x, x + n, y.begin());
        y[n] = t;
        std::copy(x + n, x + 2 * n, y.begin() + (long)n + 1);
        if (dth_model_eval(m, y.data(), DTH_EVAL_GRAD, NULL, g.data(), NULL)) return 1;
        for (size_t i = 0; i < n; i++) {
            dx[i] = g[n + 1 + i];
            dx[n + i] = -g[i];
        }
        return 0;
    }
    void operator()(const vec &x, vec &dx, double t) const { eval(x.data(), t, dx.data()); }
};

static int gsl_f(double t, const double x[], double dx[], void *p)
{
    return static_cast<Rhs *>(p)->eval(x, t, dx) ? GSL_EBADFUNC : GSL_SUCCESS;
}

static int gsl_jac(double t, const double x[], double *dfdy, double dfdt[], void *p)
{
    Rhs *r = static_cast<Rhs *>(p);
    size_t n = r->n, d = 2 * n + 1, m = 2 * n;
    if (r->h.size() < d * d) r->h.resize(d * d);
    std::copy(x, x + n, r->y.begin());
    r->y[n] = t;
    std::copy(x + n, x + 2 * n, r->y.begin() + (long)n + 1);
    if (dth_model_eval(r->m, r->y.data(), DTH_EVAL_GRAD | DTH_EVAL_HESS, NULL, r->g.data(), r->h.data())) return GSL_EBADFUNC;
    const double *H = r->h.data();
    for (size_t i = 0; i < n; i++) {
        for (size_t k = 0; k < n; k++) {
            dfdy[i * m + k] = H[(n + 1 + i) * d + k];
            dfdy[i * m + n + k] = H[(n + 1 + i) * d + n + 1 + k];
            dfdy[(n + i) * m + k] = -H[i * d + k];
            dfdy[(n + i) * m + n + k] = -H[i * d + n + 1 + k];
        }
        dfdt[i] = 0;
        dfdt[n + i] = 0;
    }
    return GSL_SUCCESS;
}

/* ---- scenes ---- */

struct Scene {
    std::string name, label;
    dth_model *m = nullptr;
    size_t n = 0;
    vec q0, p0, ref; /* ref: q at T */
    double T = 0, ref_acc = 0;
    bool crossing = false; /* psi = 0 crossings: dth with the default regularizer */
    /* parameter sweeps: dth order 2, order 4 (h); gauss4, fixed-step symplectic (h); adaptive (tol) */
    vec h2, h4, hg, hs, tol, tol_imp;
    std::vector<double> targets; /* the decades the dth curves span (set after the runs) */
    bool quick = false;
};

static dth_model *make(const dth_model_type *t, const std::vector<dth_kv> &kv)
{
    dth_model *m = NULL;
    char err[256];
    if (dth_model_new(t, kv.data(), kv.size(), 0, NULL, &m, err, sizeof err)) {
        std::fprintf(stderr, "model %s: %s\n", t->name, err);
        std::exit(1);
    }
    return m;
}

/* GSL rk8pd at tolerance tol from (q0, p0) to T: q at T */
static vec gsl_ref(const Scene &s, double tol)
{
    Rhs r(s.m);
    gsl_odeiv2_system sys = {gsl_f, NULL, 2 * s.n, &r};
    gsl_odeiv2_driver *d = gsl_odeiv2_driver_alloc_y_new(&sys, gsl_odeiv2_step_rk8pd, 1e-3, tol, tol);
    vec x(s.q0);
    x.insert(x.end(), s.p0.begin(), s.p0.end());
    double t = 0;
    gsl_odeiv2_driver_apply(d, &t, s.T, x.data());
    gsl_odeiv2_driver_free(d);
    return vec(x.begin(), x.begin() + (long)s.n);
}

static void set_reference(Scene &s)
{
    vec y0(s.q0), y(2 * s.n + 1);
    y0.push_back(0);
    y0.insert(y0.end(), s.p0.begin(), s.p0.end());
    if (dth_model_exact(s.m, y0.data(), s.T, y.data()) == DTH_OK) {
        s.ref.assign(y.begin(), y.begin() + (long)s.n);
        s.ref_acc = 0;
        return;
    }
    s.ref = gsl_ref(s, 1e-14);
    vec r13 = gsl_ref(s, 1e-13);
    double e = 0;
    for (size_t i = 0; i < s.n; i++) e += (r13[i] - s.ref[i]) * (r13[i] - s.ref[i]);
    s.ref_acc = std::sqrt(e); /* the reference's own error is below this (rk8pd at 1e-13 vs 1e-14) */
}

static double kepler_T(double orbits) { return 2 * M_PI * orbits; } /* a = 1, mu = 1 */

static std::vector<Scene> scenes(bool full)
{
    std::vector<Scene> out;
    double f = full ? 1 : 0.001; /* quick: the scenes shortened 1000 times (Kepler: 1 and 10 orbits) */
    for (int e9 = 0; e9 < 2; e9++)
        for (int dec = 3; dec <= 4; dec++) {
            Scene s;
            double orbits = std::pow(10.0, dec), e = e9 ? 0.9 : 0.6;
            s.name = std::string("kepler") + (e9 ? "09" : "06") + "_1e" + std::to_string(dec);
            s.label = std::string("Kepler e = ") + (e9 ? "0.9 from apocentre" : "0.6 from pericentre") + ", 10^" +
                      std::to_string(dec) + " orbits";
            s.m = make(&dth_model_kepler, {});
            s.n = 2;
            if (e9) { /* scenes/kepler-e09.ini's orbit */
                s.q0 = {-(1 + e), 0};
                s.p0 = {0, -std::sqrt((1 - e) / (1 + e))};
            } else { /* the 1/10 target's */
                s.q0 = {1 - e, 0};
                s.p0 = {0, std::sqrt((1 + e) / (1 - e))};
            }
            s.T = kepler_T(orbits * f);
            s.crossing = e9;
            s.tol = {1e-7, 1e-9, 1e-11, 1e-13};
            s.tol_imp = {1e-6, 1e-8, 1e-10};
            bool long4 = dec == 4 && full; /* 10x longer: fewer, coarser points of the costly methods */
            if (!e9) {
                s.h2 = long4 ? vec{1.3e-4, 6.3e-5} : vec{4e-4, 2e-4, 1e-4};
                s.h4 = long4 ? vec{0.005, 0.0025, 0.00125} : vec{0.01, 0.005, 0.0025, 0.00125};
                s.hg = long4 ? vec{} : vec{2e-3, 1e-3, 5e-4}; /* gauss4 over 10^4 orbits: minutes a point */
                s.hs = long4 ? vec{5e-4} : vec{1e-3, 5e-4, 2.5e-4};
            } else {
                /* the fixed-step methods need h ~ 1e-4 for the pericentre (r = 0.1): not over 10^4 orbits */
                s.h2 = long4 ? vec{1.4e-3, 7e-4} : vec{2.8e-3, 1.4e-3, 7e-4};
                s.h4 = long4 ? vec{0.04, 0.02} : vec{0.04, 0.02, 0.01};
                s.hg = long4 ? vec{} : vec{4e-4};
                s.hs = long4 ? vec{} : vec{1e-4, 5e-5};
            }
            out.push_back(s);
        }
    Scene hh;
    hh.name = "henon_heiles";
    hh.label = "Henon-Heiles E = 1/8, t = 10^4 (regular orbit)";
    hh.m = make(&example_henon_heiles, {});
    hh.n = 2;
    hh.q0 = {0, 0.1};
    hh.p0 = {std::sqrt(2 * (0.125 - 0.005 + 0.001 / 3)), 0};
    hh.T = full ? 1e4 : 10;
    hh.h2 = {4e-3, 2e-3, 1e-3, 5e-4};
    hh.h4 = {0.2, 0.1, 0.05, 0.025};
    hh.hg = {0.05, 0.025, 0.0125};
    hh.hs = {0.05, 0.025, 0.0125};
    hh.tol = {1e-7, 1e-9, 1e-11, 1e-13};
    hh.tol_imp = {1e-6, 1e-8, 1e-10};
    out.push_back(hh);
    Scene ch;
    ch.name = "chain100";
    ch.label = "2-D chain of 100 particles (mass 25, rest length 1), T = 100";
    ch.m = make(&dth_model_coupled, {{"preset", "chain"}, {"size", "100"}, {"dim", "2"}, {"mass", "25"}});
    ch.n = 200;
    unsigned lcg = 12345;
    for (int i = 0; i < 100; i++) {
        ch.q0.push_back(i), ch.q0.push_back(0);
        lcg = lcg * 1103515245u + 12345u;
        ch.p0.push_back((lcg >> 16) & 1 ? 1 : -1);
        lcg = lcg * 1103515245u + 12345u;
        ch.p0.push_back((lcg >> 16) & 1 ? 0.3 : -0.3);
    }
    ch.T = full ? 100 : 2;
    ch.h2 = {0.1, 0.05, 0.025, 0.0125};
    ch.h4 = {0.4, 0.2, 0.1, 0.05};
    ch.hg = {0.2, 0.1}; /* gauss4's dense Newton over 800 unknowns: a minute a point */
    ch.hs = {0.2, 0.1, 0.05};
    ch.tol = {1e-6, 1e-8, 1e-10, 1e-12};
    ch.tol_imp = {1e-5, 1e-7};
    out.push_back(ch);
    return out;
}

/* ---- one run of a method at one parameter: the final position error and the CPU ---- */

struct Point {
    double param = 0, err = NAN, cpu = NAN;
    long steps = 0;
    bool ok = false;
};

static double qerr(const Scene &s, const double *q)
{
    double e = 0;
    for (size_t i = 0; i < s.n; i++) e += (q[i] - s.ref[i]) * (q[i] - s.ref[i]);
    return std::sqrt(e);
}

struct Grab {
    vec z;
};

static int on_end(void *user, const dth_sample *sm)
{
    Grab *g = static_cast<Grab *>(user);
    if (sm->kind == DTH_SAMPLE_END || sm->kind == DTH_SAMPLE_TIME) std::copy(sm->z, sm->z + g->z.size(), g->z.begin());
    return 0;
}

/* dth: order 2 or 4 (method "dth", the default regularizer where psi = 0 is crossed), or a baseline
 * (fixed steps that end on T); the state at T by the run driver's dense output. */
static Point run_dth(const Scene &s, const char *method, int order, double h)
{
    Point pt;
    pt.param = h;
    bool is_dth = !std::strcmp(method, "dth");
    dth_regularizer *reg = NULL;
    char err[256];
    if (is_dth && s.crossing && dth_regularizer_new(&dth_reg_land, NULL, 0, s.m, NULL, &reg, err, sizeof err)) return pt;
    dth_options o;
    dth_options_default(&o);
    o.method = method;
    o.order = order;
    o.h = is_dth ? h : s.T / std::max(1.0, std::round(s.T / h));
    o.regularizer = reg;
    double c0 = cpu_now();
    dth_integrator *it = NULL;
    if (dth_integrator_new(s.m, &o, &it) || dth_integrator_start(it, s.q0.data(), s.p0.data(), 0)) {
        dth_integrator_free(it);
        dth_regularizer_free(reg);
        return pt;
    }
    Grab g;
    g.z.assign(2 * s.n + 2, NAN);
    dth_run_config cfg;
    dth_run_config_default(&cfg);
    cfg.has_t_end = 1;
    cfg.t_end = s.T;
    cfg.t0 = 0;
    cfg.points = DTH_POINTS_TIMES;
    cfg.dt = 2 * s.T; /* the END sample only */
    cfg.sample = on_end;
    cfg.user = &g;
    dth_run_state st;
    dth_run_state_init(&st);
    int rc = dth_run(it, &cfg, &st);
    pt.cpu = cpu_now() - c0;
    pt.steps = st.k;
    pt.ok = rc == DTH_OK;
    if (pt.ok) pt.err = qerr(s, g.z.data());
    else std::fprintf(stderr, "  %s order %d h = %g stopped at t = %g: %s\n", method, order, h, st.t, dth_integrator_errmsg(it));
    dth_integrator_free(it);
    dth_regularizer_free(reg);
    return pt;
}

static Point run_gsl(const Scene &s, const gsl_odeiv2_step_type *type, double tol)
{
    Point pt;
    pt.param = tol;
    Rhs r(s.m);
    double c0 = cpu_now();
    gsl_odeiv2_system sys = {gsl_f, gsl_jac, 2 * s.n, &r};
    gsl_odeiv2_driver *d = gsl_odeiv2_driver_alloc_y_new(&sys, type, 1e-4, tol, tol);
    vec x(s.q0);
    x.insert(x.end(), s.p0.begin(), s.p0.end());
    double t = 0;
    int rc = gsl_odeiv2_driver_apply(d, &t, s.T, x.data());
    pt.cpu = cpu_now() - c0;
    pt.steps = (long)d->n;
    gsl_odeiv2_driver_free(d);
    pt.ok = rc == GSL_SUCCESS;
    if (pt.ok) pt.err = qerr(s, x.data());
    return pt;
}

template <class Stepper> static Point run_odeint_adaptive(const Scene &s, Stepper st, double tol)
{
    Point pt;
    pt.param = tol;
    Rhs r(s.m);
    vec x(s.q0);
    x.insert(x.end(), s.p0.begin(), s.p0.end());
    double c0 = cpu_now();
    pt.steps = (long)ode::integrate_adaptive(st, r, x, 0.0, s.T, 1e-4);
    pt.cpu = cpu_now() - c0;
    pt.ok = std::isfinite(x[0]);
    if (pt.ok) pt.err = qerr(s, x.data());
    return pt;
}

/* the separable system as odeint's symplectic steppers take it: dq/dt from p, dp/dt from q */
struct Coor {
    const Rhs *r;
    const vec *q;
    void operator()(const vec &p, vec &dq) const
    {
        size_t n = r->n;
        vec x(*q), dx(2 * n);
        x.insert(x.end(), p.begin(), p.end());
        r->eval(x.data(), 0, dx.data());
        std::copy(dx.begin(), dx.begin() + (long)n, dq.begin());
    }
};
struct Mom {
    const Rhs *r;
    const vec *p;
    void operator()(const vec &q, vec &dp) const
    {
        size_t n = r->n;
        vec x(q), dx(2 * n);
        x.insert(x.end(), p->begin(), p->end());
        r->eval(x.data(), 0, dx.data());
        std::copy(dx.begin() + (long)n, dx.end(), dp.begin());
    }
};

static Point run_sb3a(const Scene &s, double h)
{
    Point pt;
    long N = (long)std::max(1.0, std::round(s.T / h));
    double dt = s.T / (double)N, t = 0;
    pt.param = h;
    Rhs r(s.m);
    std::pair<vec, vec> st(s.q0, s.p0);
    ode::symplectic_rkn_sb3a_mclachlan<vec> rkn;
    double c0 = cpu_now();
    for (long k = 0; k < N; k++, t += dt) rkn.do_step(std::make_pair(Coor{&r, &st.first}, Mom{&r, &st.second}), st, t, dt);
    pt.cpu = cpu_now() - c0;
    pt.steps = N;
    pt.ok = std::isfinite(st.first[0]);
    if (pt.ok) pt.err = qerr(s, st.first.data());
    return pt;
}

/* ---- the curves and their comparison ---- */

struct Curve {
    std::string method;
    std::vector<Point> pts;
};

/* CPU at error `target` on a curve (log-log interpolation between the points that bracket it); *bound:
 * 0 exact, +1 the curve does not reach the target (its cpu is a lower bound), -1 all its points are
 * more accurate (an upper bound) */
static double cpu_at(const Curve &c, double target, int *bound)
{
    std::vector<Point> p;
    for (const Point &x : c.pts)
        if (x.ok && x.err > 0 && std::isfinite(x.err)) p.push_back(x);
    std::sort(p.begin(), p.end(), [](const Point &a, const Point &b) { return a.err > b.err; });
    *bound = 0;
    if (p.empty()) {
        *bound = 2;
        return NAN;
    }
    for (size_t i = 0; i + 1 < p.size(); i++)
        if (p[i].err >= target && p[i + 1].err <= target) {
            double w = std::log(target / p[i].err) / std::log(p[i + 1].err / p[i].err);
            return std::exp(std::log(p[i].cpu) + w * std::log(p[i + 1].cpu / p[i].cpu));
        }
    if (target < p.back().err) {
        *bound = 1;
        return p.back().cpu;
    }
    *bound = -1;
    double best = p[0].cpu;
    for (const Point &x : p) best = std::min(best, x.cpu);
    return best;
}

/* "12.3", ">= 12.3", "<= 12.3" or "-" for dth / peer */
static std::string ratio(const Curve &dth, const Curve &peer, double target)
{
    int bd, bp;
    double a = cpu_at(dth, target, &bd), b = cpu_at(peer, target, &bp);
    char buf[64];
    if (bd == 2 || bp == 2 || (bd && bp)) return "-";
    double r = a / b;
    const char *pre = bd == 1 || bp == -1 ? ">= " : bd == -1 || bp == 1 ? "<= " : "";
    std::snprintf(buf, sizeof buf, "%s%.3g", pre, r);
    return buf;
}

static std::vector<Curve> run_scene(Scene &s)
{
    std::vector<Curve> cv;
    auto add = [&cv](const char *name) -> Curve & {
        cv.push_back(Curve{name, {}});
        return cv.back();
    };
    Curve &d2 = add("dth order 2");
    for (double h : s.h2) d2.pts.push_back(run_dth(s, "dth", 2, h));
    Curve &d4 = add("dth order 4");
    for (double h : s.h4) d4.pts.push_back(run_dth(s, "dth", 4, h));
    Curve &g1 = add("gsl rk8pd");
    for (double t : s.tol) g1.pts.push_back(run_gsl(s, gsl_odeiv2_step_rk8pd, t));
    Curve &g2 = add("gsl msadams");
    for (double t : s.tol) g2.pts.push_back(run_gsl(s, gsl_odeiv2_step_msadams, t));
    /* the dense implicit methods on the chain (400 and 800 unknowns) only in the full mode */
    bool dense_ok = !s.quick || s.n <= 50;
    Curve &g3 = add("gsl rk4imp");
    for (double t : s.tol_imp)
        if (dense_ok) g3.pts.push_back(run_gsl(s, gsl_odeiv2_step_rk4imp, t));
    Curve &b1 = add("odeint rkf78");
    for (double t : s.tol)
        b1.pts.push_back(run_odeint_adaptive(s, ode::make_controlled(t, t, ode::runge_kutta_fehlberg78<vec>()), t));
    Curve &b2 = add("odeint bulirsch_stoer");
    for (double t : s.tol) b2.pts.push_back(run_odeint_adaptive(s, ode::bulirsch_stoer<vec>(t, t), t));
    Curve &b3 = add("odeint sb3a");
    for (double h : s.hs) b3.pts.push_back(run_sb3a(s, h));
    Curve &l1 = add("dth gauss4");
    for (double h : s.hg)
        if (dense_ok) l1.pts.push_back(run_dth(s, "gauss4", 2, h));
    Curve &l2 = add("dth verlet");
    for (double h : s.hs) l2.pts.push_back(run_dth(s, "verlet", 2, h / 2));
    /* the decades of error the dth curves span */
    double lo = INFINITY, hi = 0;
    for (int k = 0; k < 2; k++)
        for (const Point &p : cv[k].pts)
            if (p.ok && p.err > 0) lo = std::min(lo, p.err), hi = std::max(hi, p.err);
    for (int e = (int)std::floor(std::log10(hi)); e >= (int)std::ceil(std::log10(lo)); e--) s.targets.push_back(std::pow(10.0, e));
    return cv;
}

/* The error the headline compares at: the decade nearest the middle of the order-4 curve's range. */
static double headline_target(const Scene &s, const Curve &d4)
{
    double lo = INFINITY, hi = 0;
    for (const Point &p : d4.pts)
        if (p.ok && p.err > 0) lo = std::min(lo, p.err), hi = std::max(hi, p.err);
    double t = std::pow(10.0, std::round(0.5 * (std::log10(lo) + std::log10(hi))));
    return std::isfinite(t) ? t : s.targets.empty() ? 1e-6 : s.targets[0];
}

static void report(const Scene &s, const std::vector<Curve> &cv, const char *outdir)
{
    std::printf("\n### %s\n\nT = %.6g; reference: %s", s.label.c_str(), s.T, s.ref_acc == 0 ? "exact" : "GSL rk8pd at 1e-14");
    if (s.ref_acc > 0) std::printf(" (rk8pd at 1e-13 differs from it by %.1e)", s.ref_acc);
    std::printf("\n\n| method | h or tol | steps | final position error | CPU s |\n|---|---|---|---|---|\n");
    FILE *f = NULL;
    if (outdir) {
        std::string path = std::string(outdir) + "/peers_" + s.name + ".csv";
        f = std::fopen(path.c_str(), "w");
        if (f) std::fprintf(f, "method,param,steps,err,cpu\n");
    }
    for (const Curve &c : cv)
        for (const Point &p : c.pts) {
            if (p.ok) std::printf("| %s | %.3g | %ld | %.3e | %.4g |\n", c.method.c_str(), p.param, p.steps, p.err, p.cpu);
            else std::printf("| %s | %.3g | failed | | |\n", c.method.c_str(), p.param);
            if (f && p.ok) std::fprintf(f, "%s,%.6g,%ld,%.6e,%.6e\n", c.method.c_str(), p.param, p.steps, p.err, p.cpu);
        }
    if (f) std::fclose(f);
    std::printf("\nCPU at equal final position error, dth / peer (below 1: dth is cheaper; >= / <=: a curve does not "
                "reach the error, the ratio is a bound)\n\n| error | dth |");
    for (size_t k = 2; k < cv.size(); k++) std::printf(" %s |", cv[k].method.c_str());
    std::printf("\n|---|---|");
    for (size_t k = 2; k < cv.size(); k++) std::printf("---|");
    std::printf("\n");
    for (double target : s.targets)
        for (int o = 0; o < 2; o++) {
            std::printf("| %.0e | order %d |", target, o ? 4 : 2);
            for (size_t k = 2; k < cv.size(); k++) std::printf(" %s |", ratio(cv[o], cv[k], target).c_str());
            std::printf("\n");
        }
}

int main(int argc, char **argv)
{
    bool full = false;
    const char *outdir = NULL, *only = NULL;
    for (int i = 1; i < argc; i++) {
        if (!std::strcmp(argv[i], "--full")) full = true;
        else if (!std::strcmp(argv[i], "--out") && i + 1 < argc) outdir = argv[++i];
        else if (!std::strcmp(argv[i], "--only") && i + 1 < argc) only = argv[++i];
        else {
            std::fprintf(stderr, "usage: bench_peers [--full] [--out DIR] [--only SCENE]\n");
            return 2;
        }
    }
    gsl_set_error_handler_off();
    std::printf("# bench_peers (%s mode): CPU seconds of one run each (release build recommended)\n",
                full ? "full" : "quick, the scenes shortened");
    std::vector<Scene> sc = scenes(full);
    std::vector<std::string> head;
    for (Scene &s : sc) {
        if (only && s.name != only) continue;
        s.quick = !full;
        if (s.quick)
            for (vec *v : {&s.h2, &s.h4, &s.hg, &s.hs, &s.tol, &s.tol_imp})
                if (v->size() > 2) v->resize(2);
        set_reference(s);
        std::vector<Curve> cv = run_scene(s);
        report(s, cv, outdir);
        char line[512];
        double t = headline_target(s, cv[1]);
        std::snprintf(line, sizeof line, "| %s | %.0e | %s | %s |", s.label.c_str(), t, ratio(cv[0], cv[2], t).c_str(),
                      ratio(cv[1], cv[2], t).c_str());
        head.push_back(line);
    }
    std::printf("\n### Against GSL rk8pd at an error in the middle of the order-4 curve (the goal: <= 1)\n\n"
                "| scene | error | dth order 2 / rk8pd | dth order 4 / rk8pd |\n|---|---|---|---|\n");
    for (const std::string &l : head) std::printf("%s\n", l.c_str());
    for (Scene &s : sc) dth_model_free(s.m);
    return 0;
}
