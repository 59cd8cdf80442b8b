/* SPDX-License-Identifier: MIT */
/*
 * Field tables inside the library: a state struct's members listed once (an X-macro) as public
 * dth_field entries (dth/fields.h) and read by the field codec (fields.c) and the checkpoint
 * (checkpoint.c), so that a member cannot be left out of a checkpoint and each restored value is
 * checked. A list entry is X(name, kind, check, meaning):
 *   kind  VEC: `veclen` doubles behind a pointer (the section says how many; 2n + 2 for the DTH
 *         state); F64: double; INT: int; UINT: unsigned; LONG: long
 *   check what a restored value must satisfy: the public DTH_CHECK_* (FINITE, NONNEG, BOOL, COUNT,
 *         ANY) and the library's own below: NONZERO (finite, != 0), UNIT (+1 or -1), SIGN (-1, 0,
 *         1), NHIST (0..3), PSISTEP (-2 .. 2^53), STEP (finite), HSTEP (finite, != 0), TIME
 *         (finite), RATIO (0, or >= 1), RESID (finite >= 0 or NaN), BRANCH (a dth_branch), FLAGS
 *         (DTH_STEP_* bits), STOP (a dth_run_stop), MAG (>= 0: a norm or a sum of sizes of finite
 *         values, +inf where it overflowed), ERR (MAG or NaN: an estimate, NaN where there is none)
 */
#ifndef DTH_INTERNAL_FIELDS_H
#define DTH_INTERNAL_FIELDS_H

#include <stddef.h>
#include <stdint.h>
#include "dth/fields.h"
#include "wire.h"

#define DTH__CTYPE_VEC double *
#define DTH__CTYPE_F64 double
#define DTH__CTYPE_INT int
#define DTH__CTYPE_UINT unsigned
#define DTH__CTYPE_LONG long

/* kinds: the public ones, and the library's own (never in a public table) */
enum { DTH__K_VEC = DTH_FIELD_F64_PTR, DTH__K_F64 = DTH_FIELD_F64, DTH__K_INT = DTH_FIELD_INT,
       DTH__K_LONG = DTH_FIELD_LONG, DTH__K_U64 = DTH_FIELD_U64, DTH__K_STR = DTH_FIELD_STR, DTH__K_UINT = 32 };
enum { DTH__C_ANY = DTH_CHECK_ANY, DTH__C_FINITE = DTH_CHECK_FINITE, DTH__C_NONNEG = DTH_CHECK_NONNEG,
       DTH__C_POSITIVE = DTH_CHECK_POSITIVE, DTH__C_BOOL = DTH_CHECK_BOOL, DTH__C_COUNT = DTH_CHECK_COUNT,
       DTH__C_NONZERO = 32, DTH__C_UNIT, DTH__C_SIGN, DTH__C_NHIST, DTH__C_PSISTEP, DTH__C_STEP, DTH__C_HSTEP,
       DTH__C_TIME, DTH__C_RATIO, DTH__C_RESID, DTH__C_BRANCH, DTH__C_FLAGS, DTH__C_STOP, DTH__C_MAG, DTH__C_ERR };

/** The largest count a restored state may hold (steps, samples, vertex indices): 2^53, so that
 *  counting on, and the counts as doubles, stay exact and cannot overflow. */
#define DTH__MAX_COUNT (INT64_C(1) << 53)
/* Steps and times are bounded by what the integrator accepts, no more: dth_options.h and
 * dth_integrator_set_vertex's lambda may be any finite nonzero number, a start time any finite one
 * (a step that overflows ends with a status, never a non-finite state: tests/test_failstate.c runs
 * h = -1.06e270), so a restored step or time is any finite number. */

/** Backwards compatible name: one member of a state struct. */
typedef dth_field dth__field;

/** An entry of a field table for the struct `type` from an X-macro list entry. */
#define DTH__FIELD(type, name, kind, check) {#name, offsetof(type, name), DTH__K_##kind, DTH__C_##check, 0}

/** A struct's members as C declarations from an X-macro list entry. */
#define DTH__FIELD_MEMBER(name, kind, check, doc) DTH__CTYPE_##kind name;

/** Bytes of the member a field describes in its struct (a VEC: the pointer). */
size_t dth__field_size(const dth_field *f);

/* ---- the codec (fields.c): a field on the wire is its name (a string of at most 64 bytes), u32
 * type, u64 count, then count values of 8 bytes (a string: count bytes), little-endian ---- */

enum { DTH__T_F64 = 1, DTH__T_I64 = 2, DTH__T_STR = 3 }; /* how a field's values are written */
enum { DTH__MAX_FIELDS = 64 };                           /* most fields of a section or record */

/** The wire type of a kind. */
int dth__field_wire(int kind);
/** The values a field has on the wire (veclen: a VEC field's default count). */
uint64_t dth__field_count(const dth_field *f, size_t veclen);
/** Write one field of the struct at base. */
void dth__put_field(dth__wr *w, const dth_field *f, const void *base, size_t veclen);
/** Read the field `f` expects next and check every value; *pos gets the reader position of its
 *  values. DTH_OK, or DTH_EPARSE with a message naming the field. */
int dth__get_field(dth__rd *r, const dth_field *f, size_t veclen, size_t *pos, char *err, size_t errlen);
/** Store a checked field's values (at reader position pos) into base (not a string). */
void dth__load_field(const dth__rd *r, size_t pos, const dth_field *f, void *base, size_t veclen);
/** A table is well formed (names, kinds, checks, counts); reg: a regularizer's (public kinds of
 *  numbers only). DTH_OK or DTH_EINVAL with a message. */
int dth__fields_valid(const dth_field *f, size_t nf, int reg, char *err, size_t errlen);

#endif
