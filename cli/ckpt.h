/* SPDX-License-Identifier: MIT */
/* dth run's checkpoints (cli/ckpt.c): the "cli" blob field by field, and what a resume may change. */
#ifndef DTH_CLI_CKPT_H
#define DTH_CLI_CKPT_H

#include <stddef.h>
#include "cli.h"

/* One output file's progress: where it goes (absolute paths), the bytes already final, their hash. */
typedef struct cli_ckpt_out {
    char *path;   /* the final name; "" when there is none (standard output, no events) */
    char *tmp;    /* the temporary it is written to while the run lasts; "" for none */
    unsigned long long bytes, hash; /* bytes already final (header included) and their FNV-1a 64 */
} cli_ckpt_out;

/* What a checkpoint of dth run holds beyond the integrator: the run driver's state (the library's
 * "run" section), and in the "cli" blob the scene's hash and the outputs' progress. */
typedef struct cli_ckpt {
    dth_run_state S;               /* read by dth_checkpoint_run_state, restored by dth_checkpoint_restore_run */
    unsigned long long scene_hash; /* FNV-1a 64 of the checkpoint's "scene" blob */
    cli_ckpt_out out, ev;
} cli_ckpt;

/* The blob as bytes (malloc'd): a magic, a version, then the record of the library's field codec
 * (dth_fields_encode) of every field but S. 0 or -1 (memory). */
int cli_ckpt_encode(const cli_ckpt *c, unsigned char **blob, size_t *len);
/* Parse and validate a blob (S stays zero): every field in order, strings without NUL and at most
 * 4096 bytes, paths absolute. 0, or -1 with the reason in err. Free with cli_ckpt_clear. */
int cli_ckpt_decode(const void *blob, size_t len, cli_ckpt *c, char *err, size_t errlen);
void cli_ckpt_clear(cli_ckpt *c);

/* The first o->bytes bytes of the file `from`, which a resume continues, are the rows this run
 * would have written: the header line (`header`, hlen bytes, without its newline), then `rows`
 * lines (the run state's samples, or events: ev = 1), and they end with a line. 0, or -1 naming
 * the file and the field. */
int cli_ckpt_check_rows(const cli_ckpt_out *o, int ev, const char *from, const char *header, size_t hlen, long rows,
                        char *err, size_t errlen);

/* Write a checkpoint of the run to `path`: the integrator, the scene as text that loads back
 * (only the one of steps= and t_end= in force), and the blob (absolute paths of out and ev, which
 * may be NULL). 0, or a dth status with the reason in err. */
int cli_ckpt_write(const char *path, const dth_integrator *it, const dth_scene *scene, int has_t_end,
                   const dth_run_state *S, const cli_out *out, const cli_out *ev, char *err, size_t errlen);

/* Read a checkpoint of dth run: *buf (free) holds it for dth_checkpoint_restore_run, *scene points
 * to its scene text in *buf, c the decoded blob and run state. 0, or a dth status with the reason in
 * err. */
int cli_ckpt_read(const char *path, void **buf, size_t *len, const char **scene, size_t *scene_len, cli_ckpt *c,
                  char *err, size_t errlen);

/* A resume continues the same run: the scene as resumed (after -s) must equal the saved one except
 * for the keys that do not change what is computed or how rows are written (integrator.steps,
 * integrator.t_end, output.file, events.file): the library's rule, dth_scene_resume_check (scene.h). 0, or -1
 * naming the first change in err. */
int cli_ckpt_check_scene(const dth_scene *saved, const dth_scene *now, char *err, size_t errlen);

/* The resumed run's end must not lie behind what the checkpointed run has written. 0 or -1. */
int cli_ckpt_check_length(const cli_ckpt *c, const dth_run_setup *rs, char *err, size_t errlen);

#endif
