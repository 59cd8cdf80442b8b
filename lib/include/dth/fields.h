/* SPDX-License-Identifier: MIT */
/**
 * @file fields.h  Field lists: the members of a struct that hold state, described once as data, so
 * that the library can save them (little-endian, by name) and check each restored value.
 *
 * A regularizer lists the members of its instance that carry from step to step
 * (dth_regularizer_type.fields, regularize.h); checkpoints save them with the integrator's state.
 * A program may encode a struct of its own by such a list (dth_fields_encode / dth_fields_decode,
 * checkpoint.h), as `dth run` does for its output counters.
 *
 *     typedef struct my_reg { double arc; int arc_fixed; double *seed; ... } my_reg;
 *     static const dth_field my_fields[] = {
 *         {"arc", offsetof(my_reg, arc), DTH_FIELD_F64, DTH_CHECK_NONNEG, 1},
 *         {"arc_fixed", offsetof(my_reg, arc_fixed), DTH_FIELD_INT, DTH_CHECK_BOOL, 1},
 *         {"seed", offsetof(my_reg, seed), DTH_FIELD_F64_PTR, DTH_CHECK_FINITE, 0}, // 2n + 2 doubles
 *     };
 */
#ifndef DTH_FIELDS_H
#define DTH_FIELDS_H

#include <stddef.h>
#include "dth/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/** How a field's value is held in its struct. */
typedef enum dth_field_kind {
    DTH_FIELD_F64 = 1,     /**< double (count > 1: an array of that many doubles in the struct) */
    DTH_FIELD_F64_PTR = 2, /**< a pointer to `count` doubles; count 0: the model's 2n + 2 (a
                                regularizer's field) */
    DTH_FIELD_INT = 3,     /**< int */
    DTH_FIELD_LONG = 4,    /**< long */
    DTH_FIELD_U64 = 5,     /**< unsigned long long (a hash, a byte count): not for regularizers */
    DTH_FIELD_STR = 6      /**< char *, NUL-terminated, at most DTH_FIELD_STR_MAX bytes, no NUL inside;
                                decoded into memory from the caller's allocator: not for regularizers */
} dth_field_kind;

/** What each restored value must satisfy; a value that does not is refused, naming the field. */
typedef enum dth_field_check {
    DTH_CHECK_ANY = 0,      /**< anything (a double may be NaN or infinite) */
    DTH_CHECK_FINITE = 1,   /**< a finite double (integers: any) */
    DTH_CHECK_NONNEG = 2,   /**< >= 0 (doubles: and finite) */
    DTH_CHECK_POSITIVE = 3, /**< > 0 (doubles: and finite) */
    DTH_CHECK_BOOL = 4,     /**< 0 or 1 */
    DTH_CHECK_COUNT = 5     /**< an integer from 0 to 2^53 (a count that later arithmetic cannot overflow) */
} dth_field_check;

/** Longest string of a DTH_FIELD_STR field, in bytes. */
#define DTH_FIELD_STR_MAX 4096

/** One member of a struct. Rules between fields (one nonzero only if another is set...) are the
 *  owner's: a regularizer's state_loaded callback, the caller's after dth_fields_decode. */
typedef struct dth_field {
    const char *name;     /**< unique in its list; letters, digits, '_' and '.'; at most 64 bytes */
    size_t offset;        /**< offsetof the member in its struct */
    int kind;             /**< dth_field_kind */
    int check;            /**< dth_field_check */
    size_t count;         /**< F64: 1 (or 0), or an array's length; F64_PTR: the doubles it points to
                               (0: the model's 2n + 2); other kinds: 1 (or 0) */
} dth_field;

#ifdef __cplusplus
}
#endif
#endif
