/* SPDX-License-Identifier: MIT */
/*
 * The checkpoint format's internals shared by its writer and verifier (checkpoint.c) and its
 * restore (restore.c): the constants of the layout (docs/checkpoint.md), a verified checkpoint's
 * parts as reader positions, and the sections of an integrator.
 */
#ifndef DTH_CKPT_FORMAT_H
#define DTH_CKPT_FORMAT_H

#include <stdint.h>
#include "dth/run.h"
#include "dth_internal.h"
#include "fields.h"
#include "stepper.h"
#include "wire.h"

enum { DTH__CKPT_HEADER = 8 + 4 + 4 + 8, DTH__CKPT_TRAILER = 8, DTH__CKPT_MAX_NAME = 255 };
/** Most state sections: the options, the stepper's, the error estimate's. */
enum { DTH__CKPT_MAX_SECTIONS = 1 + DTH__MAX_SECTIONS + 1 };
/** The byte-order mark after the version: 04 03 02 01 in the file (a u32, little-endian). */
#define DTH__CKPT_BOM 0x01020304u

/** A verified checkpoint's parts: names point into the buffer, positions are reader positions. */
typedef struct dth__ckpt {
    const char *method, *name;
    size_t method_len, name_len;
    uint64_t n;
    uint32_t nsec;
    size_t pos_sec;      /* the first section */
    const char *reg;     /* regularizer type name ("" for none) */
    size_t reg_name_len;
    size_t pos_reg;      /* its section */
    int has_run;         /* a run section follows */
    size_t pos_run;      /* the run section */
} dth__ckpt;

/** Check the header, checksum and structure of buf; r is left after the state (at the blobs). */
int dth__ckpt_verify(const void *buf, size_t len, dth__rd *r, dth__ckpt *s, char *err, size_t errlen);
/** The options section, the state sections of `it` (sec[0] is the options) and, where it estimates
 *  (dth_options.estimate), the error estimate's section "estimate" last; their count (at most
 *  DTH__CKPT_MAX_SECTIONS). */
size_t dth__ckpt_sections(const dth_integrator *it, dth__section *sec, void *scratch);
/** The attached regularizer (NULL: none), its type name ("" for none), its state as a section. */
struct dth_regularizer *dth__ckpt_reg(const dth_integrator *it);
const char *dth__ckpt_reg_name(const dth_integrator *it);
void dth__ckpt_reg_section(const dth_integrator *it, dth__section *out);
/** The run state as the section "run". */
void dth__run_section(const dth_run_state *run, dth__section *out);
/** Write a section: name, u64 vector length, u32 field count, the fields. */
void dth__put_section(dth__wr *w, const dth__section *sec);

#endif
