/* SPDX-License-Identifier: MIT */
/*
 * Field tables: a state struct's members listed once (an X-macro) and read by the checkpoint
 * codec (checkpoint.c), so that a member cannot be left out of a checkpoint and each restored
 * value is checked. A list entry is X(name, kind, check, meaning):
 *   kind  VEC: `veclen` doubles behind a pointer (the section says how many; 2n + 2 for the DTH
 *         state); F64: double; INT: int; LONG: long
 *   check what a restored value must satisfy: FINITE, NONZERO (finite, != 0), UNIT (+1 or -1),
 *         BOOL (0 or 1), SIGN (-1, 0, 1), NHIST (0..3), COUNT (>= 0), PSISTEP (>= -2), ANY
 */
#ifndef DTH_FIELDS_H
#define DTH_FIELDS_H

#include <stddef.h>

#define DTH__CTYPE_VEC double *
#define DTH__CTYPE_F64 double
#define DTH__CTYPE_INT int
#define DTH__CTYPE_LONG long

enum { DTH__K_VEC = 1, DTH__K_F64, DTH__K_INT, DTH__K_LONG };
enum { DTH__C_FINITE, DTH__C_NONZERO, DTH__C_UNIT, DTH__C_BOOL, DTH__C_SIGN, DTH__C_NHIST, DTH__C_COUNT, DTH__C_PSISTEP,
       DTH__C_ANY };

/** One member of a state struct. */
typedef struct dth__field {
    const char *name;
    size_t off;  /* offsetof in its struct */
    int kind;    /* DTH__K_* */
    int check;   /* DTH__C_* */
} dth__field;

/** An entry of a field table for the struct `type` from an X-macro list entry. */
#define DTH__FIELD(type, name, kind, check) {#name, offsetof(type, name), DTH__K_##kind, DTH__C_##check}

/** A struct's members as C declarations from an X-macro list entry. */
#define DTH__FIELD_MEMBER(name, kind, check, doc) DTH__CTYPE_##kind name;

#endif
