/* SPDX-License-Identifier: MIT */
/* A registry of named model types: how scene files select a model by name (no global state). */
#include <string.h>
#include "dth/models.h"
#include "dth/regularize.h"
#include "dth_internal.h"

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
    if (!r || dth_model_type_check(type, NULL, 0)) return DTH_EINVAL;
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
    if (!r || dth_regularizer_type_check(type, NULL, 0)) return DTH_EINVAL;
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

int dth__abi_check(unsigned abi, size_t size, unsigned oldest, unsigned version, size_t full, const char *kind, char *err,
                   size_t len)
{
    if ((abi & ~0xffu) != DTH_ABI_MAGIC) {
        dth__set_err(err, len,
                     "%s table has no layout version (built for a dth before tables were versioned?): rebuild it "
                     "with DTH_%s_HEAD as its first member",
                     kind, kind[0] == 'm' ? "MODEL_TYPE" : "REG_TYPE");
        return DTH_EINVAL;
    }
    unsigned v = abi & 0xffu, cur = version & 0xffu;
    if (v < oldest || v > cur) {
        if (oldest == cur)
            dth__set_err(err, len, "%s table has layout version %u, this library reads version %u only (%s)", kind, v,
                         cur, v > cur ? "built against a newer dth" : "rebuild it against this dth's headers");
        else
            dth__set_err(err, len, "%s table has layout version %u, this library reads versions %u to %u%s", kind, v,
                         oldest, cur, v > cur ? " (built against a newer dth)" : "");
        return DTH_EINVAL;
    }
    /* one layout per kind so far (models 2, regularizers 3: the older regularizer layout is
     * refused above); a later version keeps each earlier version's size here, so that a smaller
     * table reads as its own layout */
    if (size != full) {
        dth__set_err(err, len, "%s table of layout version %u says it has %zu bytes, that layout has %zu", kind, v, size,
                     full);
        return DTH_EINVAL;
    }
    return DTH_OK;
}

void dth__table_copy(void *dst, size_t full, const void *src, size_t size)
{
    size_t k = size < full ? size : full;
    memcpy(dst, src, k);
    memset((char *)dst + k, 0, full - k);
}
