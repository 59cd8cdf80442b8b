/* SPDX-License-Identifier: MIT */
/**
 * @file checkpoint.h  Checkpoint and restart, bit for bit.
 *
 * A checkpoint holds the complete step state of an integrator (every field of its state list:
 * the vertex in double-double, the last midpoint, the predictor's history, the carried vertex
 * offset, direction, flags, the sign of psi that regularizers keep, the branch policy's memory,
 * the step counter), the regularizer's own state, the options that change the steps, plus named
 * blobs the caller supplies (for example the scene text and output counters), with a format
 * version and an FNV-1a 64 checksum. Restoring it into an integrator created for the same model
 * with the same options and regularizer continues the run exactly: from any step, N steps, save,
 * restore into a fresh integrator, M steps gives the same bits as N + M steps.
 *
 * The format is documented field by field in docs/checkpoint.md. All integers and doubles are
 * little-endian, doubles as their IEEE-754 bit patterns:
 *   "DTHCKPT\0", u32 version, u32 0, u64 total length,
 *   model name, u64 n, u32 m, u32 autonomous,
 *   u32 count, options (branch_check, compensate, max_iter, linsolve, K) as fields,
 *   u32 count, state fields (name, u32 type, u64 count, values),
 *   regularizer type name, u64 length, its state bytes,
 *   u32 blob count, blobs (name, u64 size, bytes), u64 FNV-1a 64 of everything before it.
 * Other versions are refused. The start options (start mode, explicit wp) act at the start only
 * and are not recorded.
 */
#ifndef DTH_CHECKPOINT_H
#define DTH_CHECKPOINT_H

#include <stddef.h>
#include "dth/fields.h"
#include "dth/integrator.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Format version written by this library. */
/* 4: state as named fields from one list (adds the branch policy's memory psi_prev, psi_step and
 *    the carried vertex offset rho), the options that change the steps, the regularizer's name;
 * 3: the predictor's three offsets; no LU factors (the tangent refactors) */
#define DTH_CHECKPOINT_VERSION 6

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
 * type and dimension, with the same step-changing options and a regularizer of the same type
 * (or none). On any failure `it` and its regularizer are untouched.
 * @return DTH_OK, DTH_EPARSE (corrupted, truncated, other version, invalid field: the message
 *         names it), DTH_EINVAL (a different model, dimension, option or regularizer: the message
 *         says which; NULL arguments).
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
 * Write a checkpoint to `path` crash-safely: into a temporary of its own, "path.tmp.PID.XXXXXX"
 * (two writers of one path cannot collide; a killed writer's temporary is recognised by its PID),
 * write, fsync, then rename over `path` (and fsync the directory), so `path` always holds either
 * the old or the new checkpoint. On failure the temporary is removed and `path` is unchanged.
 * Memory comes from the integrator's allocator.
 * @return DTH_OK, DTH_EIO (message names the file and the system's reason), DTH_ENOMEM, DTH_EINVAL.
 */
DTH_API int dth_checkpoint_write_file(const dth_integrator *it, const dth_blob *blobs, size_t nblobs,
                                      const char *path, char *err, size_t errlen);

/**
 * Read a whole checkpoint file into memory allocated with `alloc` (free with dth_free) and
 * verify it.
 * @return DTH_OK, DTH_EIO (cannot read, or not a regular file), DTH_EPARSE (corrupted /
 *         truncated), DTH_ENOMEM.
 */
DTH_API int dth_checkpoint_read_file(const char *path, const dth_allocator *alloc, void **buf,
                                     size_t *len, char *err, size_t errlen);

/* ---- records of caller data by a field list (dth/fields.h), in the checkpoint's encoding ---- */

/**
 * Encode the members of the struct at `base` that `fields` lists (a F64_PTR field needs its count
 * here) as a record: u32 field count, then each field as a checkpoint section's (name, u32 type,
 * u64 count, values; a string's count is its length in bytes), little-endian. *len receives the
 * size needed (also when buf is NULL: call once to size the buffer, or when cap is too small).
 * @return DTH_OK, DTH_EINVAL (a bad list, a string longer than DTH_FIELD_STR_MAX, cap too small).
 */
DTH_API int dth_fields_encode(const dth_field *fields, size_t nfields, const void *base, void *buf, size_t cap,
                              size_t *len);

/**
 * Decode a record of dth_fields_encode into the struct at `base`: the fields in the list's order,
 * each by name, type and count, each value by its check; strings are allocated with `alloc` (NULL:
 * malloc; free each with dth_free). Nothing else may follow. On failure base is untouched.
 * @return DTH_OK, DTH_EPARSE (the message names the field), DTH_EINVAL (a bad list), DTH_ENOMEM.
 */
DTH_API int dth_fields_decode(const dth_field *fields, size_t nfields, void *base, const void *buf, size_t len,
                              const dth_allocator *alloc, char *err, size_t errlen);

#ifdef __cplusplus
}
#endif
#endif
