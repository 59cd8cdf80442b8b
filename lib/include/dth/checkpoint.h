/* SPDX-License-Identifier: MIT */
/**
 * @file checkpoint.h  Checkpoint and restart, bit for bit.
 *
 * A checkpoint holds the complete dynamic state of an integrator (the vertex in double-double,
 * the last midpoint, the predictor's offset and step, direction, flags (including the sign of psi
 * at the vertex that regularizers keep), step counter and the
 * predictor's last three offsets) plus named blobs the caller supplies
 * (for example the scene text and output counters), with a format version and an FNV-1a 64
 * checksum. Restoring it into an integrator created for the same model with the same options
 * continues the run exactly: N steps, save, restore, N steps gives the same bits as 2N steps.
 *
 * Layout (all integers and doubles little-endian, doubles as their IEEE-754 bit patterns):
 *   "DTHCKPT\0", u32 version, u32 0, u64 total length, model name, state, u32 blob count,
 *   blobs (name, u64 size, bytes), u64 FNV-1a 64 of everything before it.
 * The static options (start, max_iter, K, explicit wp) are not restored: they come from the
 * integrator the checkpoint is restored into (the scene the caller rebuilds it from).
 */
#ifndef DTH_CHECKPOINT_H
#define DTH_CHECKPOINT_H

#include <stddef.h>
#include "dth/integrator.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Format version written by this library. */
#define DTH_CHECKPOINT_VERSION 3 /* 3: the predictor's three offsets; no LU factors (the tangent refactors) */

/** A named blob of caller data stored alongside the state. */
typedef struct dth_blob {
    const char *name; /**< non-empty, unique within a checkpoint */
    const void *data; /**< `size` bytes (may be NULL when size is 0) */
    size_t size;
} dth_blob;

/**
 * Serialize `it` and the blobs into buf[0 .. cap-1]. *len receives the size needed (also when
 * it does not fit, or when buf is NULL: call once with buf = NULL to size the buffer).
 * @return DTH_OK, DTH_EINVAL (bad arguments or cap too small; *len is still set).
 */
DTH_API int dth_checkpoint_save(const dth_integrator *it, const dth_blob *blobs, size_t nblobs,
                                void *buf, size_t cap, size_t *len);

/**
 * Check a checkpoint (magic, version, length, checksum, structure) without restoring it.
 * @return DTH_OK, DTH_EPARSE (corrupted, truncated or unknown version; message in err).
 */
DTH_API int dth_checkpoint_verify(const void *buf, size_t len, char *err, size_t errlen);

/**
 * Restore the state in buf into `it`, which must have been created for a model of the same
 * type and dimension. On any failure `it` is untouched.
 * @return DTH_OK, DTH_EPARSE (corrupted, truncated, unknown version, invalid state),
 *         DTH_EINVAL (a different model or dimension; NULL arguments).
 */
DTH_API int dth_checkpoint_restore(dth_integrator *it, const void *buf, size_t len, char *err,
                                   size_t errlen);

/**
 * Find the blob `name` in a checkpoint; *data points into buf.
 * @return DTH_OK, DTH_ENOTFOUND, DTH_EPARSE (the checkpoint is not valid).
 */
DTH_API int dth_checkpoint_blob(const void *buf, size_t len, const char *name, const void **data,
                                size_t *size);

/** Name of the model type recorded in a checkpoint (NUL-terminated copy into `name`). */
DTH_API int dth_checkpoint_model_name(const void *buf, size_t len, char *name, size_t namelen);

/**
 * Write a checkpoint to `path` crash-safely: into "path.tmp", fflush + fsync, then rename over
 * `path` (and fsync the directory), so `path` always holds either the old or the new checkpoint.
 * Memory comes from the integrator's allocator.
 * @return DTH_OK, DTH_EIO (message names the file), DTH_ENOMEM, DTH_EINVAL.
 */
DTH_API int dth_checkpoint_write_file(const dth_integrator *it, const dth_blob *blobs, size_t nblobs,
                                      const char *path, char *err, size_t errlen);

/**
 * Read a whole checkpoint file into memory allocated with `alloc` (free with dth_free) and
 * verify it.
 * @return DTH_OK, DTH_EIO (cannot read), DTH_EPARSE (corrupted / truncated), DTH_ENOMEM.
 */
DTH_API int dth_checkpoint_read_file(const char *path, const dth_allocator *alloc, void **buf,
                                     size_t *len, char *err, size_t errlen);

#ifdef __cplusplus
}
#endif
#endif
