/* SPDX-License-Identifier: MIT */
/*
 * The integrator's options contract: defaults, and one check of every rule (ranges, the method,
 * the linear solver and the finish against the model) with a message naming the option, used by
 * dth_integrator_new and by scene files alike (the DTH step of the paper's Theorem "DTH Equations").
 */
#include <math.h>
#include <string.h>
#include <stdio.h>
#include "dth/regularize.h"
#include "dth_internal.h"
#include "compose.h"
#include "stepper.h"

void dth_options_default(dth_options *o)
{
    memset(o, 0, sizeof *o);
    o->size = sizeof *o;
    o->method = "dth";
    o->order = 2;
    o->h = 0.01;
    o->start = DTH_START_MIDPOINT;
    o->max_iter = 30;
    o->branch_check = 1;
    o->linsolve = DTH_LINSOLVE_AUTO;
    o->finish = DTH_FINISH_COMPENSATED;
}

const char *dth_finish_name(dth_finish f)
{
    switch (f) {
    case DTH_FINISH_PLAIN: return "plain";
    case DTH_FINISH_COMPENSATED: return "compensated";
    case DTH_FINISH_REVERSIBLE: return "reversible";
    default: return NULL;
    }
}

/* The rules that hold whatever the model: ranges and known values. */
static int check_values(const dth_options *o, char *err, size_t len)
{
    if (!isfinite(o->h) || o->h == 0) {
        dth__set_err(err, len, "h = %g: the first step must be finite and nonzero (its sign sets the direction)", o->h);
        return DTH_EINVAL;
    }
    if (o->max_iter < 1) {
        dth__set_err(err, len, "max_iter = %d: at least one Newton iteration per step", o->max_iter);
        return DTH_EINVAL;
    }
    if (!isfinite(o->K) || o->K < 0) {
        dth__set_err(err, len, "K = %g: the paper's constant must be finite and >= 0 (0: estimated locally)", o->K);
        return DTH_EINVAL;
    }
    if (o->has_wp && !isfinite(o->wp)) {
        dth__set_err(err, len, "wp = %g: an explicit wp must be finite", o->wp);
        return DTH_EINVAL;
    }
    if (o->start != DTH_START_MIDPOINT && o->start != DTH_START_VERTEX) {
        dth__set_err(err, len, "start = %d is not DTH_START_MIDPOINT or DTH_START_VERTEX", (int)o->start);
        return DTH_EINVAL;
    }
    if (!dth__linsolve_find(o->linsolve)) {
        dth__set_err(err, len, "linsolve = %d is not a dth_linsolve choice", (int)o->linsolve);
        return DTH_EINVAL;
    }
    if (!dth_finish_name(o->finish)) {
        dth__set_err(err, len, "finish = %d is not a dth_finish choice (plain, compensated, reversible)", (int)o->finish);
        return DTH_EINVAL;
    }
    return DTH_OK;
}

/* The order, and the composition's table and band of order 4 (compose.c). */
static int check_order(const dth__stepper_type *type, const dth_options *o, char *err, size_t len)
{
    if (type != &dth__stepper_dth) {
        if (o->order == 2 && !o->table) return DTH_OK;
        dth__set_err(err, len, "order = %d%s: method '%s' has an order of its own (leave order at 2, table unset)",
                     o->order, o->table ? " with a table" : "", type->name);
        return DTH_EUNSUPPORTED;
    }
    if (o->order == 6 || o->order == 8) {
        dth__set_err(err, len, "order = %d: not offered. Compositions of level-shifted DTH steps measure order 4 with "
                               "every 6th- and 8th-order table (yoshida6a, kahanli6, kahanli8: with constant levels "
                               "sum lambda_i^3 = O(h^2), the order-3 condition; docs/theory.md): order = 4",
                     o->order);
        return DTH_EUNSUPPORTED;
    }
    if (o->order != 2 && o->order != 4) {
        dth__set_err(err, len, "order = %d: method 'dth' has order 2 or 4", o->order);
        return DTH_EINVAL;
    }
    if (o->order == 2 && (o->table || o->band_time != 0)) {
        dth__set_err(err, len, "%s applies to order = 4 only", o->table ? "table" : "band_time");
        return DTH_EINVAL;
    }
    if (o->order == 4 && !dth__table_find(o->table)) {
        char names[160] = "";
        for (size_t i = 0; dth__table_at(i); i++) {
            size_t l = strlen(names);
            snprintf(names + l, sizeof names - l, "%s%s", i ? ", " : "", dth__table_at(i)->name);
        }
        dth__set_err(err, len, "table = '%s': unknown (order 4 has %s)", o->table, names);
        return DTH_ENOTFOUND;
    }
    if (!isfinite(o->band_time) || o->band_time < 0) {
        dth__set_err(err, len, "band_time = %g: a time >= 0 (0: the default crossing rule)", o->band_time);
        return DTH_EINVAL;
    }
    return DTH_OK;
}

/* Order 4 and the regularizer: the composition carries psi = 0 crossings by its own band (compose_band.c),
 * switched on by `land` (the default; its replaced step of order 2 is not called) and off by none; a
 * regularizer that replaces steps in other ways (`prescribed`, a plugin) would never be called. */
static int check_order_regularizer(const dth_options *o, char *err, size_t len)
{
    if (o->order != 4 || !o->regularizer) return DTH_OK;
    const char *rn = dth_regularizer_get_type(o->regularizer)->name;
    if (!strcmp(rn, "land") || !strcmp(rn, "none")) return DTH_OK;
    dth__set_err(err, len, "order = 4 with regularizer '%s': not supported (order 4 carries psi = 0 crossings by its "
                           "own band under 'land', the default, and stops at them with none; '%s' would never be "
                           "called): order = 2 for '%s'", rn, rn, rn);
    return DTH_EUNSUPPORTED;
}

int dth_options_check(const dth_model *model, dth_options *o, char *err, size_t len)
{
    if (!model || !o) {
        dth__set_err(err, len, "invalid arguments to dth_options_check (NULL model or options)");
        return DTH_EINVAL;
    }
    if (o->size != sizeof *o) {
        dth__set_err(err, len, "dth_options has size %zu, this library's has %zu: initialize it with dth_options_default "
                               "(a program built against another dth?)", o->size, sizeof *o);
        return DTH_EINVAL;
    }
    int rc = check_values(o, err, len);
    if (rc) return rc;
    const dth__stepper_type *type = dth__stepper_find(o->method);
    if (!type) {
        char names[160] = "dth";
        for (size_t i = 0; i < dth__baseline_count(); i++) {
            size_t l = strlen(names);
            snprintf(names + l, sizeof names - l, ", %s", dth__baseline_at(i)->name);
        }
        dth__set_err(err, len, "unknown method '%s' (available: %s)", o->method, names);
        return DTH_ENOTFOUND;
    }
    if ((rc = check_order(type, o, err, len)) != DTH_OK) return rc;
    if (type != &dth__stepper_dth && o->regularizer) {
        dth__set_err(err, len, "a regularizer applies to method = dth only (this is method '%s')", type->name);
        return DTH_EUNSUPPORTED;
    }
    if ((rc = check_order_regularizer(o, err, len)) != DTH_OK) return rc;
    if (type->check && (rc = type->check(model, o, err, len)) != DTH_OK) return rc;
    const char *mname = dth_model_get_type(model)->name;
    size_t n = dth_model_dof(model);
    if (n == 0 || n > DTH__MAX_DOF) {
        dth__set_err(err, len, "model '%s' has %zu degrees of freedom (1 to 2^40 supported)", mname, n);
        return DTH_EINVAL;
    }
    int banded_model = dth__model_banded(model);
    size_t m = dth_model_get_info(model)->autonomous ? 2 * n + 1 : 2 * n + 3;
    const dth__linsolve_info *ls = dth__linsolve_find(o->linsolve);
    if (ls->banded && !banded_model) {
        dth__set_err(err, len, "linsolve '%s' needs a model with a banded Hessian (model '%s' has a dense one)", ls->name,
                     mname);
        return DTH_EUNSUPPORTED;
    }
    ls = dth__linsolve_find(dth__linsolve_resolve(o->linsolve, banded_model, m));
    if (!ls->banded && m > (size_t)1 << 15) {
        dth__set_err(err, len, "model '%s' has %zu Newton unknowns: a dense solver's %zu x %zu matrix would not fit (a "
                               "banded model takes linsolve 'banded')", mname, m, m, m);
        return DTH_EUNSUPPORTED;
    }
    if (o->finish == DTH_FINISH_REVERSIBLE && ls->banded) {
        dth__set_err(err, len, "the reversible finish needs a dense Hessian, and model '%s' takes the banded solver here: "
                               "linsolve 'dense'", mname);
        return DTH_EUNSUPPORTED;
    }
    o->method = type->name;
    o->linsolve = ls->kind;
    return DTH_OK;
}
