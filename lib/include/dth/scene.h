/* SPDX-License-Identifier: MIT */
/**
 * @file scene.h  Scene files (INI): what to integrate, from where, how, and where to write it.
 *
 * Sections and keys (see docs/user-guide.md):
 *   [model]      name=, then the model's own parameters
 *   [initial]    q=, p= (n comma-separated values each), t= (default 0), wp= (explicit wp)
 *   [integrator] method=dth, start=midpoint|vertex, h=, steps= or t_end=, max_iter=, K=, branch_check=,
 *                linsolve=auto|dense|small|small-lu|banded|banded-lu
 *   [regularize] method=none, then the regularizer's parameters
 *   [output]     file=, points=auto|vertices|midpoints, every=, dt=, diagnostics=yes|no
 *   [events]     section=q<i>|p<i>, section_value=, section_direction=up|down|both,
 *                section_terminal=, time= (list), time_terminal=, distance=, distance_dofs=,
 *                distance_direction=, distance_terminal=, file=
 * Unknown sections and keys are errors naming the file and line (or the -s override).
 * steps= and t_end= exclude each other, except that an override of one replaces the other
 * when that one comes from a file.
 * Lines are limited to 197 characters (inih's default buffer); longer lines are an error.
 * An indented line continues the previous key's value as more comma-separated list items.
 */
#ifndef DTH_SCENE_H
#define DTH_SCENE_H

#include <stddef.h>
#include "dth/model.h"
#include "dth/models.h"
#include "dth/integrator.h"
#include "dth/run.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Parsed key/value contents of a scene, with where each value came from. Opaque. */
typedef struct dth_scene dth_scene;

/** Create an empty scene. @return DTH_OK, DTH_ENOMEM. */
DTH_API int dth_scene_new(const dth_allocator *alloc, dth_scene **out);
/** Free; NULL is a no-op. */
DTH_API void dth_scene_free(dth_scene *s);
/**
 * Read an INI file into the scene (later values for the same key replace earlier ones, also
 * across files and overrides). On failure the scene is unchanged.
 * @return DTH_OK, DTH_EIO (cannot read; message names the file), DTH_EPARSE (message names
 * file and line), DTH_ENOMEM.
 */
DTH_API int dth_scene_load(dth_scene *s, const char *path, char *err, size_t errlen);
/**
 * Read scene text from memory (`len` bytes; `name` stands for the file in messages), exactly
 * as dth_scene_load reads a file. @return as dth_scene_load.
 */
DTH_API int dth_scene_load_mem(dth_scene *s, const char *name, const char *text, size_t len,
                               char *err, size_t errlen);
/**
 * Apply an override "section.key=value" (spaces around the parts are trimmed; the value may
 * be empty). Only what a scene file could hold is accepted (no control characters, no comment
 * ';' after a blank, names of at most 49 characters without '=', ':' or ']', values that fit
 * lines of 197 characters between commas), so that dth_scene_text can always write the scene.
 * @return DTH_OK, DTH_EPARSE (message names the override and what is wrong), DTH_ENOMEM.
 */
DTH_API int dth_scene_set(dth_scene *s, const char *assignment, char *err, size_t errlen);
/**
 * dth_scene_set for a caller whose overrides come from elsewhere than a -s option: `from` names the
 * assignment's source in messages and in dth_scene_origin (e.g. "--vary initial.q=0.5",
 * "list.csv:3", "set={'initial.q': ...}"; cut after 80 characters). NULL: "-s ASSIGNMENT", as
 * dth_scene_set. @return as dth_scene_set.
 */
DTH_API int dth_scene_set_from(dth_scene *s, const char *assignment, const char *from, char *err, size_t errlen);
/** Value of section.key, or NULL. */
DTH_API const char *dth_scene_get(const dth_scene *s, const char *section, const char *key);
/** Where section.key was set: "FILE:LINE" or "-s section.key=value"; NULL if absent. */
DTH_API const char *dth_scene_origin(const dth_scene *s, const char *section, const char *key);
/** Number of stored keys (for validating a section's keys, e.g. a regularizer's). */
DTH_API size_t dth_scene_count(const dth_scene *s);
/**
 * Entry i (0 <= i < count, in order of first appearance): any output pointer may be NULL.
 * @return DTH_OK, DTH_EINVAL (i out of range).
 */
DTH_API int dth_scene_entry(const dth_scene *s, size_t i, const char **section, const char **key,
                            const char **value, const char **origin);

/**
 * The scene as INI text that dth_scene_load_mem reads back to the same sections, keys and values
 * (by construction: long values are split at commas where the loader joins them back exactly).
 * Entries for which keep(ctx, section, key) returns 0 are left out (keep may be NULL). *text is
 * NUL-terminated, allocated with the scene's allocator (free with dth_free).
 * @return DTH_OK, DTH_EINVAL, DTH_ENOMEM.
 */
DTH_API int dth_scene_text(const dth_scene *s, int (*keep)(void *ctx, const char *section, const char *key),
                           void *ctx, char **text, size_t *len);

/** Everything needed to run a scene, validated. Free with dth_run_setup_clear(). */
typedef struct dth_run_setup {
    dth_model *model;   /**< the model instance (owned) */
    size_t n;           /**< degrees of freedom */
    double *q0, *p0;    /**< initial values, n each (owned) */
    double t0;          /**< initial time */
    dth_options opt;    /**< integrator options (h, start, wp, max_iter, K, branch_check, linsolve) */
    char method[32];    /**< integrator method name ("dth") */
    int has_t_end;      /**< 1: run until t_end; 0: run `steps` steps */
    long steps;         /**< number of steps (when !has_t_end; may be 0) */
    double t_end;       /**< end time (when has_t_end) */
    char regularize[32];/**< regularizer name ("none") */
    char *out_file;     /**< output path or NULL for stdout (owned) */
    long every;         /**< write every k-th vertex (>= 1) */
    double dt;          /**< output times t0 + j dt (0: vertices or midpoints) */
    dth_points points;  /**< what is written: [output] points= resolved (auto: MIDPOINTS for a DTH
                             midpoint start, whose first midpoint is the initial condition, else
                             VERTICES; TIMES when dt > 0) */
    int diagnostics;    /**< write psi, dpsi, region, iters */
    dth_event *events;  /**< [events] as event functions for dth_run (owned; each user points into
                             event_specs), nevents of them */
    dth_event_spec *event_specs; /**< their parameters (owned) */
    const char **event_names;    /**< "section", "time" or "distance" for each (owned array) */
    size_t nevents;
    size_t *event_dofs;          /**< distance_dofs as 0-based indices (owned) */
    char *events_file;           /**< [events] file= (owned), NULL if not given */
    const dth_allocator *alloc; /**< what the owned members were allocated with */
    dth_regularizer *regularizer; /**< [regularize] method= other than none (owned; also in
                                       opt.regularizer), NULL for raw DTH */
} dth_run_setup;

/**
 * Validate the scene against the registry and build a run setup: unknown model or key,
 * malformed number, wrong number of q/p values, h == 0, NaN... each give DTH_EINVAL with a
 * one-line message naming the file and line (or the override) and the key. The first error
 * in the order the keys were first set is reported. On failure *out is left untouched;
 * on success it must be released with dth_run_setup_clear(). Uses the scene's allocator.
 */
DTH_API int dth_scene_setup(const dth_scene *s, const dth_registry *reg, dth_run_setup *out,
                            char *err, size_t errlen);
/** Release what a run setup owns (safe on a zeroed or already cleared setup). */
DTH_API void dth_run_setup_clear(dth_run_setup *rs);

#ifdef __cplusplus
}
#endif
#endif
