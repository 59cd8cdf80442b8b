/* SPDX-License-Identifier: MIT */
/*
 * The integrator handle (integrator.h): a stepper type and its state (stepper.h), chosen by
 * dth_options.method from the table below; every call is forwarded to the type. The DTH step is
 * dth_step.c's type (paper, Theorem "DTH Equations"), the fixed-step baselines are baselines.c's.
 */
#include <math.h>
#include <string.h>
#include "dth_internal.h"
#include "dth/methods.h"
#include "stepper.h"

const dth__stepper_type *dth__stepper_find(const char *name)
{
    if (!name || strcmp(name, dth__stepper_dth.name) == 0) return &dth__stepper_dth;
    for (size_t i = 0; i < dth__baseline_count(); i++)
        if (strcmp(dth__baseline_at(i)->name, name) == 0) return dth__baseline_at(i);
    return NULL;
}

const dth__stepper_type *dth__stepper_find_order(const char *name, int order)
{
    const dth__stepper_type *t = dth__stepper_find(name);
    return t == &dth__stepper_dth && order == 4 ? &dth__stepper_compose : t;
}

size_t dth_method_count(void) { return 1 + dth__baseline_count(); }
const char *dth_method_name(size_t i)
{
    return i == 0 ? dth__stepper_dth.name : i < dth_method_count() ? dth__baseline_at(i - 1)->name : NULL;
}
const char *dth_method_doc(const char *name)
{
    const dth__stepper_type *t = name ? dth__stepper_find(name) : NULL;
    return t ? t->doc : NULL;
}

int dth_integrator_new(const dth_model *model, const dth_options *opt_in, dth_integrator **out)
{
    if (!out) return DTH_EINVAL;
    *out = NULL;
    if (!model || !opt_in || opt_in->size != sizeof(dth_options)) return DTH_EINVAL;
    dth_options o = *opt_in;
    int rc = dth_options_check(model, &o, NULL, 0); /* resolves the method and linsolve AUTO */
    if (rc) return rc;
    dth_integrator *it = dth_calloc(o.alloc, 1, sizeof *it);
    if (!it) return DTH_ENOMEM;
    it->type = dth__stepper_find_order(o.method, o.order);
    it->model = model;
    it->alloc = o.alloc;
    it->n = dth_model_dof(model);
    it->N = 2 * it->n + 2;
    it->h = o.h;
    rc = it->type->create(model, &o, &it->state);
    if (!rc && o.estimate) rc = dth__estimate_init(&it->est, model, o.alloc);
    if (!rc && o.estimate) it->est.rk6 = o.order >= 4; /* a shadow of higher order than the method */
    if (rc) {
        dth_integrator_free(it);
        return rc;
    }
    *out = it;
    return DTH_OK;
}

void dth_integrator_free(dth_integrator *it)
{
    if (!it) return;
    if (it->state) it->type->destroy(it->state);
    dth__estimate_free(&it->est);
    dth_free(it->alloc, it);
}

/* The shadow of the error estimate from the state y (q, t, p) to the vertex's time. */
static int estimate_from(dth_integrator *it, const double *y)
{
    if (!it->est.on) return DTH_OK;
    const double *z = it->type->vertex(it->state);
    int rc = dth__estimate_start(&it->est, y, z[it->n]);
    /* no estimate where the shadow cannot start (the model fails at its first point): it says NaN */
    return rc == DTH_ENOMEM ? rc : DTH_OK;
}

int dth_integrator_start(dth_integrator *it, const double *q0, const double *p0, double t0)
{
    if (!it) return DTH_EINVAL;
    int rc = it->type->start(it->state, q0, p0, t0);
    if (rc || !it->est.on) return rc;
    double *y = it->est.xs; /* the initial state, (q0, t0, p0) */
    memcpy(y, q0, it->n * sizeof *y);
    y[it->n] = t0;
    memcpy(y + it->n + 1, p0, it->n * sizeof *y);
    return estimate_from(it, y);
}

int dth_integrator_set_vertex(dth_integrator *it, const double *z, double lambda)
{
    if (!it) return DTH_EINVAL;
    int rc = it->type->set_vertex(it->state, z, lambda);
    return rc ? rc : estimate_from(it, z);
}

int dth_integrator_step(dth_integrator *it, dth_step_info *info)
{
    dth_step_info tmp;
    if (!info) info = &tmp;
    memset(info, 0, sizeof *info);
    info->lerr = NAN;
    if (!it) return DTH_EINVAL;
    int rc = it->type->step(it->state, info);
    if (!rc && it->est.on) dth__estimate_step(&it->est, it->type->vertex(it->state)[it->n]);
    return rc;
}

int dth_integrator_error(dth_integrator *it, double *eq, double *ep)
{
    if (!it || !eq || !ep) return DTH_EINVAL;
    return dth__estimate_at(&it->est, it->type->vertex(it->state), eq, ep);
}

int dth_integrator_error_at(dth_integrator *it, const double *z, double *eq, double *ep)
{
    if (!it || !z || !eq || !ep) return DTH_EINVAL;
    return dth__estimate_at(&it->est, z, eq, ep);
}

void dth_integrator_reverse(dth_integrator *it)
{
    if (it) it->type->reverse(it->state);
}

int dth_integrator_tangent(dth_integrator *it, double *M)
{
    if (!it || !M) return DTH_EINVAL;
    return it->type->tangent ? it->type->tangent(it->state, M) : DTH_EUNSUPPORTED;
}

/* Accessors: NULL integrators give NULL, NaN or 0, never a crash. */
const double *dth_integrator_vertex(const dth_integrator *it) { return it ? it->type->vertex(it->state) : NULL; }
const double *dth_integrator_midpoint(const dth_integrator *it) { return it ? it->type->midpoint(it->state) : NULL; }
double dth_integrator_lambda(const dth_integrator *it) { return it ? it->type->lambda(it->state) : NAN; }
double dth_integrator_direction(const dth_integrator *it) { return it ? it->type->direction(it->state) : NAN; }
double dth_integrator_energy(const dth_integrator *it) { return it ? it->type->energy(it->state) : NAN; }
long dth_integrator_steps(const dth_integrator *it) { return it ? it->type->steps(it->state) : 0; }
size_t dth_integrator_dim(const dth_integrator *it) { return it ? it->N : 0; }
const dth_model *dth_integrator_model(const dth_integrator *it) { return it ? it->model : NULL; }
const char *dth_integrator_method(const dth_integrator *it) { return it ? it->type->name : NULL; }
int dth_integrator_order(const dth_integrator *it) { return it ? it->type->order(it->state) : 0; }
const char *dth_integrator_errmsg(const dth_integrator *it)
{
    return it ? it->type->errmsg(it->state) : "no integrator (NULL)";
}

struct dth__dth *dth__integrator_core(dth_integrator *it)
{
    return it && it->type == &dth__stepper_dth ? it->state : NULL;
}

int dth__integrator_wp_fixed(const dth_integrator *it) { return it->type->wp_fixed; }
double dth__integrator_h(const dth_integrator *it) { return it->h; }
int dth__integrator_has_midpoints(const dth_integrator *it) { return it->type->midpoints; }
int dth__integrator_dense5(const dth_integrator *it) { return it->type->dense5; }
const double *dth__integrator_prev_vertex(const dth_integrator *it)
{
    return it->type->prev_vertex ? it->type->prev_vertex(it->state) : NULL;
}
