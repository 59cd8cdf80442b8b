/* SPDX-License-Identifier: MIT */
/** @file models.h  The built-in model types and the model/regularizer registry. */
#ifndef DTH_MODELS_H
#define DTH_MODELS_H

#include "dth/model.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Pendulum: H = p^2/2 - omega2 cos q. */
DTH_API extern const dth_model_type dth_model_pendulum;
/** Harmonic oscillator: H = sum p_i^2/(2 m_i) + m_i w_i^2 q_i^2 / 2. */
DTH_API extern const dth_model_type dth_model_harmonic;
/** Kepler problem: H = |p|^2/2 - mu/|q| in 2 or 3 Cartesian dimensions (parameters mu, dim). */
DTH_API extern const dth_model_type dth_model_kepler;
/** Coupled oscillators: N particles in 1-3 dimensions joined by springs (chain, ring, lattice or explicit). */
DTH_API extern const dth_model_type dth_model_coupled;

/** A set of named model types (and, see regularize.h, regularizers). No global state. */
typedef struct dth_registry dth_registry;

/** Create an empty registry. @return DTH_OK, DTH_ENOMEM. */
DTH_API int dth_registry_new(const dth_allocator *alloc, dth_registry **out);
/** Free; NULL is a no-op. The registered tables are not freed (they are static). */
DTH_API void dth_registry_free(dth_registry *r);
/** Register a model type. @return DTH_OK, DTH_EINVAL (NULL, no name, duplicate name), DTH_ENOMEM. */
DTH_API int dth_registry_add_model(dth_registry *r, const dth_model_type *type);
/** Model type by name, or NULL. */
DTH_API const dth_model_type *dth_registry_find_model(const dth_registry *r, const char *name);
/** Number of registered model types. */
DTH_API size_t dth_registry_model_count(const dth_registry *r);
/** Model type i (0 <= i < count), in registration order. */
DTH_API const dth_model_type *dth_registry_model_at(const dth_registry *r, size_t i);
struct dth_regularizer_type; /* regularize.h */
/** Register a regularizer type (regularize.h). @return DTH_OK, DTH_EINVAL (NULL, no name, no apply,
 *  duplicate name), DTH_ENOMEM. */
DTH_API int dth_registry_add_regularizer(dth_registry *r, const struct dth_regularizer_type *type);
/** Regularizer type by name, or NULL. */
DTH_API const struct dth_regularizer_type *dth_registry_find_regularizer(const dth_registry *r, const char *name);
/** Number of registered regularizer types. */
DTH_API size_t dth_registry_regularizer_count(const dth_registry *r);
/** Regularizer type i (0 <= i < count), in registration order. */
DTH_API const struct dth_regularizer_type *dth_registry_regularizer_at(const dth_registry *r, size_t i);
/** Register every built-in model type (and built-in regularizer). */
DTH_API int dth_registry_add_builtin(dth_registry *r);

#ifdef __cplusplus
}
#endif
#endif
