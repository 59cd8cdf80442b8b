/* SPDX-License-Identifier: MIT */
/**
 * @file scene.h  Scene files (INI): what to integrate, from where, how, and where to write it.
 *
 * Sections and keys (docs/user-guide.md has their tables, made from dth_scene_key_at):
 *   [model]      name=, then the model's own parameters
 *   [initial]    q=, p= (n comma-separated values each), t=, wp=
 *   [integrator] method=, start=, h= (or h_max=, tol=), steps= or t_end=, max_iter=, K=, branch_check=,
 *                reversible=, estimate=, stop_error=, warn_ratio=, h_max=, tol=, pilot=, linsolve=
 *   [regularize] method=, then the regularizer's parameters
 *   [output]     file=, points=, every=, dt=, diagnostics=
 *   [events]     section=, time=, distance= and their options
 * Unknown sections and keys are errors naming the file and line (or the -s override), and the
 * closest known name ("did you mean t_end?").
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
 * dth_scene_set with the override's origin named by the caller: `from` (at most 80 characters are
 * kept) stands for "-s section.key=value" in messages and dth_scene_origin, e.g. a binding's
 * "set={'integrator.h': 0.01}"; NULL: "-s ASSIGNMENT" (dth_scene_set). The entry is an override as
 * dth_scene_set's are (an override of steps= or t_end= replaces the other from a file).
 * @return as dth_scene_set.
 */
DTH_API int dth_scene_set_from(dth_scene *s, const char *from, const char *assignment, char *err, size_t errlen);
/**
 * Whether a scene file can hold section.key = value as dth_scene_set stores it (the same rules:
 * no control characters, no comment ';' after a blank, names of at most 49 characters without '=',
 * ':' or ']', values that fit lines of 197 characters between commas), for a caller that writes scene
 * text itself (e.g. from a dictionary). @return DTH_OK, DTH_EPARSE (message "section.key: a scene
 * file cannot hold this (why)"), DTH_EINVAL (NULL).
 */
DTH_API int dth_scene_check_entry(const char *section, const char *key, const char *value, char *err, size_t errlen);
/** Value of section.key, or NULL. */
DTH_API const char *dth_scene_get(const dth_scene *s, const char *section, const char *key);
/** Where section.key was set: "FILE:LINE", "-s section.key=value" or dth_scene_set_from's `from`; NULL if
 *  absent. */
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

/** What a key of the table below accepts. */
typedef enum dth_scene_key_type {
    DTH_SCENE_NUMBER = 0,     /**< a finite number (bounds: dth_scene_key_describe) */
    DTH_SCENE_INTEGER = 1,    /**< an integer in a range (1e6 and 2.0 count) */
    DTH_SCENE_BOOL = 2,       /**< yes or no (also true/false, 1/0) */
    DTH_SCENE_CHOICE = 3,     /**< one of the names dth_scene_key_choice lists */
    DTH_SCENE_NUMBERS = 4,    /**< a comma-separated list of finite numbers */
    DTH_SCENE_DOFS = 5,       /**< a comma-separated list of degrees of freedom (1-based) */
    DTH_SCENE_TEXT = 6,       /**< nonempty text (a file name) */
    DTH_SCENE_COORDINATE = 7  /**< q<i> or p<i> (1-based i) */
} dth_scene_key_type;

/** One key of [initial], [integrator], [output] or [events] ([model] and [regularize] hold the
 *  model's and the regularizer's parameters: dth models, dth regularizers). */
typedef struct dth_scene_key_info {
    const char *section;     /**< "integrator" */
    const char *key;         /**< "t_end" */
    dth_scene_key_type type;
    int required;            /**< 1: every scene gives it */
    const char *def;         /**< the default as the user guide shows it ("30", "auto", "standard output"),
                                  "" if the key has none */
    const char *doc;         /**< what it does (Markdown, without table pipes) */
} dth_scene_key_info;

/** Number of keys in the table (the order of the user guide: by section, then as documented). */
DTH_API size_t dth_scene_key_count(void);
/** Key i (0 <= i < count), NULL out of range. Static storage. */
DTH_API const dth_scene_key_info *dth_scene_key_at(size_t i);
/** The j-th name a BOOL or CHOICE key i accepts (aliases such as true/false are left out), with its
 *  description in *doc (may be NULL; *doc NULL if there is none); NULL past the last. */
DTH_API const char *dth_scene_key_choice(size_t i, size_t j, const char **doc);
/** What key i accepts, as the error messages say it ("an integer in 1..100000", "one of midpoint,
 *  vertex", "a finite number >= 0 (0: estimate K locally)"), written as snprintf does. @return the
 *  length snprintf returns (0 for i out of range). */
DTH_API size_t dth_scene_key_describe(size_t i, char *buf, size_t len);
/** dth_scene_resume_may_change / dth_scene_resume_check flags. */
enum {
    /** output.every and output.diagnostics may change too: for a caller that keeps each leg's rows
     *  apart (dth run appends to the checkpointed run's files, so it passes 0). */
    DTH_RESUME_ROWS = 1u
};

/**
 * Whether a resume from a checkpoint may change section.key: integrator.steps, integrator.t_end,
 * output.file and events.file (how far the run goes and where its rows go), with DTH_RESUME_ROWS also
 * output.every and output.diagnostics. Everything else changes the trajectory or its rows (the model
 * and its parameters, the initial state, h, the method, the regularizer, events, output times).
 */
DTH_API int dth_scene_resume_may_change(const char *section, const char *key, unsigned flags);

/**
 * A resume continues the same run: the scene as resumed (`now`, after its overrides) must hold the
 * checkpointed scene's keys with the same values, but for those dth_scene_resume_may_change allows.
 * The message names the first change by its origin in `now` (or `what`, e.g. "--resume", where the
 * key is absent from `now`), its new and old values, and the keys a resume may change.
 * @return DTH_OK, DTH_EINVAL.
 */
DTH_API int dth_scene_resume_check(const dth_scene *saved, const dth_scene *now, unsigned flags, const char *what,
                                   char *err, size_t errlen);

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
    double stop_error;  /**< dth_run_config.stop_error (default 0.25) */
    double warn_ratio;  /**< warn where a step exceeds this multiple of h (default 16; 0: never) */
    double h_max;       /**< [integrator] h_max: every step at most this (0: not asked for; control.h,
                             dth_run_setup_control chooses the first step for it) */
    double tol;         /**< [integrator] tol: the estimated global position error at t_end at most this
                             (0: not asked for; dth_run_setup_control) */
    double pilot;       /**< [integrator] pilot: the time the calibration's pilots run to (NaN: t_end) */
    double h_asked;     /**< the h the scene gave (h_max where it gave none; opt.h is the calibrated first
                             step after dth_run_setup_control) */
    double step_max;    /**< dth_run_config.step_max (dth_run_config_from_setup copies it): 1.05 h_max with
                             h_max, set by dth_scene_setup, so that an uncalibrated run cannot pass h_max
                             silently either; 0: no bound */
} dth_run_setup;

/**
 * Validate the scene against the registry and build a run setup: unknown model or key,
 * malformed number, wrong number of q/p values, h == 0, NaN... each give DTH_EINVAL with a
 * one-line message naming the file and line (or the override) and the key. Each key's value is
 * checked on its own first (the first error in the order the keys were first set is reported),
 * then the rules between keys, then the model, then dth_options_check's rules (the method, the
 * linear solver and the finish against the model, a regularizer with a baseline), named at the
 * line of the key whose value they refuse (of two, the one set later). On failure *out is left untouched;
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
