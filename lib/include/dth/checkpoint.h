/* SPDX-License-Identifier: MIT */
/**
 * @file checkpoint.h  Checkpoint and restart, bit for bit.
 *
 * A checkpoint holds the complete step state of an integrator (every field of its state lists:
 * the vertex in double-double, the last midpoint, the predictor's history, the carried vertex
 * offset, direction, flags, the sign of psi that regularizers keep, the branch policy's memory,
 * the step counter), the regularizer's own state (its type's field list), the options that change
 * the steps, optionally the run driver's state (dth/run.h), plus named blobs the caller supplies
 * (for example the scene text), with a format version, a byte-order mark and an FNV-1a 64
 * checksum. Restoring it into an integrator created for the same model with the same options and
 * regularizer continues the run exactly: from any step, N steps, save, restore into a fresh
 * integrator, M steps gives the same bits as N + M steps.
 *
 * The format is documented field by field in docs/checkpoint.md. Every number in it is
 * little-endian by construction (doubles as their IEEE-754 bit patterns), whatever the host:
 *   "DTHCKPT\0", u32 version, u32 byte-order mark 0x01020304, u64 total length,
 *   method, model name, u64 n, u32 count, sections (the options that change the steps, the
 *   method's state), the regularizer's type name and its section, u32 0 or 1 and the run
 *   driver's section, u32 blob count, blobs (name, u64 size, bytes), u64 FNV-1a 64 of all before.
 * A section is a name, u64 vector length, u32 count and fields; a field a name, u32 type (1
 * doubles, 2 64-bit integers, 3 bytes of a string), u64 count and the values. Other versions, and
 * checkpoints whose byte-order mark says big-endian, are refused. A restore checks every value by
 * its field's check and the rules between fields (docs/checkpoint.md, "Checks"), naming the field;
 * on any refusal the integrator, its regularizer and the run state are untouched.
 */
#ifndef DTH_CHECKPOINT_H
#define DTH_CHECKPOINT_H

#include <stddef.h>
#include "dth/fields.h"
#include "dth/integrator.h"
#include "dth/run.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Format version written by this library. */
/* 7: the byte-order mark; the regularizer's state as a section of its type's fields (was raw host
 *    bytes); the run driver's state as an optional section "run" (was dth run's own blob);
 *    string fields; steps, counts and step sizes bounded (docs/checkpoint.md);
 * 6: the method's name, sections (the policy's apart from the step's), the option `order`;
 * 5: `rholo` and the carried offset as a double-double;
 * 4: state as named fields from one list (adds the branch policy's memory psi_prev, psi_step and
 *    the carried vertex offset rho), the options that change the steps, the regularizer's name;
 * 3: the predictor's three offsets; no LU factors (the tangent refactors) */
#define DTH_CHECKPOINT_VERSION 7

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

/**
 * dth_checkpoint_save with the run driver's state (dth_run: a caller's loop state at the
 * integrator's vertex, as its checkpoint callback sees it) as the checkpoint's "run" section;
 * run NULL: none (dth_checkpoint_save). dth_checkpoint_restore_run reads it back.
 */
DTH_API int dth_checkpoint_save_run(const dth_integrator *it, const dth_run_state *run, const dth_blob *blobs,
                                    size_t nblobs, void *buf, size_t cap, size_t *len);

/**
 * dth_checkpoint_restore, and the run state into *run: each field checked, the rules between them
 * (a state that has not started is all 0; k0 <= k; the counts of crossings and regularized steps
 * within k; the arriving step `in` set exactly when k > 0), and against the restored integrator
 * (t is its vertex's time; t_stop lies from t_first to t in its direction of travel). On any
 * failure neither `it` nor *run changes.
 * @return as dth_checkpoint_restore; DTH_ENOTFOUND: the checkpoint holds no run state.
 */
DTH_API int dth_checkpoint_restore_run(dth_integrator *it, dth_run_state *run, const void *buf, size_t len,
                                       char *err, size_t errlen);

/**
 * The run state of a checkpoint alone (no integrator), each field and the rules among the run
 * state's own fields checked (those against the integrator are dth_checkpoint_restore_run's).
 * @return DTH_OK, DTH_EPARSE (message names the field), DTH_ENOTFOUND (no run state), DTH_EINVAL.
 */
DTH_API int dth_checkpoint_run_state(const void *buf, size_t len, dth_run_state *run, char *err, size_t errlen);

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

/** dth_checkpoint_write_file with the run driver's state (dth_checkpoint_save_run; run may be NULL). */
DTH_API int dth_checkpoint_write_file_run(const dth_integrator *it, const dth_run_state *run, const dth_blob *blobs,
                                          size_t nblobs, const char *path, char *err, size_t errlen);

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
