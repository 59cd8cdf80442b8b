/* SPDX-License-Identifier: MIT */
/* A registry of named model types: how scene files select a model by name (no global state). */
#include <string.h>
#include "dth/models.h"
#include "dth/regularize.h"

struct dth_registry {
    const dth_allocator *alloc;
    const dth_model_type **models;
    size_t n_models, cap_models;
    const dth_regularizer_type **regs;
    size_t n_regs, cap_regs;
};

int dth_registry_new(const dth_allocator *alloc, dth_registry **out)
{
    if (!out) return DTH_EINVAL;
    *out = NULL;
    dth_registry *r = dth_calloc(alloc, 1, sizeof *r);
    if (!r) return DTH_ENOMEM;
    r->alloc = alloc;
    *out = r;
    return DTH_OK;
}

void dth_registry_free(dth_registry *r)
{
    if (!r) return;
    dth_free(r->alloc, r->models);
    dth_free(r->alloc, r->regs);
    dth_free(r->alloc, r);
}

int dth_registry_add_model(dth_registry *r, const dth_model_type *type)
{
    if (!r || !type || !type->name || !type->name[0] || !type->create || !type->eval)
        return DTH_EINVAL;
    if (dth_registry_find_model(r, type->name)) return DTH_EINVAL;
    if (r->n_models == r->cap_models) {
        size_t cap = r->cap_models ? 2 * r->cap_models : 8;
        const dth_model_type **m = dth_calloc(r->alloc, cap, sizeof *m);
        if (!m) return DTH_ENOMEM;
        if (r->n_models) memcpy(m, r->models, r->n_models * sizeof *m);
        dth_free(r->alloc, r->models);
        r->models = m;
        r->cap_models = cap;
    }
    r->models[r->n_models++] = type;
    return DTH_OK;
}

const dth_model_type *dth_registry_find_model(const dth_registry *r, const char *name)
{
    if (!r || !name) return NULL;
    for (size_t i = 0; i < r->n_models; i++)
        if (strcmp(r->models[i]->name, name) == 0) return r->models[i];
    return NULL;
}

size_t dth_registry_model_count(const dth_registry *r) { return r ? r->n_models : 0; }

const dth_model_type *dth_registry_model_at(const dth_registry *r, size_t i)
{
    return (r && i < r->n_models) ? r->models[i] : NULL;
}

/* ---- regularizers (regularize.h) ---- */

int dth_registry_add_regularizer(dth_registry *r, const dth_regularizer_type *type)
{
    if (!r || !type || !type->name || !type->name[0] || !type->apply) return DTH_EINVAL;
    if (dth_registry_find_regularizer(r, type->name)) return DTH_EINVAL;
    if (r->n_regs == r->cap_regs) {
        size_t cap = r->cap_regs ? 2 * r->cap_regs : 4;
        const dth_regularizer_type **m = dth_calloc(r->alloc, cap, sizeof *m);
        if (!m) return DTH_ENOMEM;
        if (r->n_regs) memcpy(m, r->regs, r->n_regs * sizeof *m);
        dth_free(r->alloc, r->regs);
        r->regs = m;
        r->cap_regs = cap;
    }
    r->regs[r->n_regs++] = type;
    return DTH_OK;
}

const dth_regularizer_type *dth_registry_find_regularizer(const dth_registry *r, const char *name)
{
    if (!r || !name) return NULL;
    for (size_t i = 0; i < r->n_regs; i++)
        if (strcmp(r->regs[i]->name, name) == 0) return r->regs[i];
    return NULL;
}

size_t dth_registry_regularizer_count(const dth_registry *r) { return r ? r->n_regs : 0; }

const dth_regularizer_type *dth_registry_regularizer_at(const dth_registry *r, size_t i)
{
    return (r && i < r->n_regs) ? r->regs[i] : NULL;
}
