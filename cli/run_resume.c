/* SPDX-License-Identifier: MIT */
/*
 * dth run's checkpoints and resume: the checkpoint callback of the run driver (cli/ckpt.c writes
 * the file), the rows a resumed run copies from the checkpointed run's output, and the removal of
 * temporaries that killed runs left behind; reading the checkpoint a resume continues.
 */
#include <stdio.h>
#include <string.h>
#include <unistd.h>
#include "ckpt.h"
#include "run_out.h"

/* A checkpoint (cli/ckpt.c) every checkpoint_every steps and at the end, after the rows so far are
 * on disk. From the first one on, the temporaries it names are kept if the run fails. */
int run_on_checkpoint(void *user, const dth_run_state *st)
{
    run_out *r = user;
    if (cli_out_sync(&r->out) || (r->has_ev && cli_out_sync(&r->ev))) return DTH_EIO;
    char err[1200];
    int rc = cli_ckpt_write(r->ckpt_path, r->it, r->scene, r->rs->has_t_end, st, &r->out, r->has_ev ? &r->ev : NULL,
                            err, sizeof err);
    if (rc) {
        cli_error("%s", err);
        r->ckpt_failed = 1;
        return DTH_EIO;
    }
    cli_out_keep(&r->out);
    if (r->has_ev) cli_out_keep(&r->ev);
    r->ckpt_k = st->k;
    r->ckpt_written = 1;
    return 0;
}

/* Remove the temporaries that killed runs left next to the outputs and the checkpoint, and next to
 * the checkpoint a resume read and the outputs it names (resume_path and c may be NULL). */
void run_clean_stale(const char *path, const char *ev_path, const char *ckpt_path, const char *resume_path,
                     const cli_ckpt *c)
{
    const char *p[6] = {path, ev_path, ckpt_path, c && c->out.path[0] ? c->out.path : NULL,
                        c && c->ev.path[0] ? c->ev.path : NULL,
                        resume_path && !(ckpt_path && cli_same_file(resume_path, ckpt_path)) ? resume_path : NULL};
    for (int i = 0; i < 6; i++) {
        if (i == 3 || i == 4)
            if (p[i] && ((path && cli_same_file(p[i], path)) || (ev_path && cli_same_file(p[i], ev_path)))) continue;
        int k = p[i] ? cli_clean_stale(p[i], NULL) : 0;
        if (k) cli_error("removed %d temporar%s of '%s' left by runs that no longer run", k, k > 1 ? "ies" : "y", p[i]);
    }
}

/* The rows the checkpointed run had made final, into the new outputs: from its temporary file if it
 * was killed (or failed), else from the file it finished; the bytes must hash as recorded and be
 * this run's header and one row per sample (per event) the run state counts. */
int run_resume_prefix(run_out *r, const cli_ckpt *c, const char *ckpt, const char *ev_path)
{
    const cli_ckpt_out *src[2] = {&c->out, &c->ev};
    cli_out *dst[2] = {&r->out, &r->ev};
    for (int i = 0; i < (r->has_ev ? 2 : 1); i++) {
        const cli_ckpt_out *s = src[i];
        const char *from = s->tmp[0] && access(s->tmp, R_OK) == 0 ? s->tmp : s->path;
        if (i == 1 && !s->path[0]) {
            cli_error("%s: the checkpointed run wrote no events file ('%s' cannot continue one)", ckpt, ev_path);
            return -1;
        }
        int rc = cli_out_copy_prefix(dst[i], from, s->bytes, s->hash);
        if (rc == CLI_PREFIX_SHORT)
            cli_error("%s: the checkpointed run's output '%s' is missing or shorter than its %llu bytes", ckpt, from,
                      s->bytes);
        else if (rc == CLI_PREFIX_CHANGED)
            cli_error("%s: the checkpointed run's output '%s' was changed since the checkpoint (its first %llu bytes "
                      "differ from what the run wrote)", ckpt, from, s->bytes);
        else if (rc == CLI_PREFIX_WRITE)
            cli_error("cannot write '%s': %s", dst[i]->path ? dst[i]->path : "standard output", strerror(dst[i]->err));
        if (rc) return -1;
        /* the bytes are the ones the run wrote: they must also be the rows this run continues */
        const char *head;
        size_t hlen;
        char why[1400];
        run_header_line(r, i, &head, &hlen);
        if (cli_ckpt_check_rows(s, i, from, head, hlen, i ? c->S.events : c->S.samples, why, sizeof why)) {
            cli_error("%s: the checkpointed run's output: %s", ckpt, why);
            return -1;
        }
    }
    return 0;
}

int run_first_checkpoint(run_out *r, const dth_run_state *S)
{
    if (!run_on_checkpoint(r, S)) return 0;
    if (r->out.failed || r->ev.failed) return 1;
    r->out.keep = r->ev.keep = 0;
    cli_out_abort(&r->out);
    if (r->has_ev) cli_out_abort(&r->ev);
    return -1;
}

int run_resume_load(run_resume *res, const char *path, dth_scene *scene, char *err, size_t errlen)
{
    const char *text;
    size_t tlen;
    int rc = cli_ckpt_read(path, &res->buf, &res->len, &text, &tlen, &res->c, err, errlen);
    if (rc) return rc;
    char name[1100];
    snprintf(name, sizeof name, "%s(scene)", path);
    rc = dth_scene_load_mem(scene, name, text, tlen, err, errlen);
    if (!rc) rc = dth_scene_new(NULL, &res->saved);
    if (!rc) rc = dth_scene_load_mem(res->saved, name, text, tlen, err, errlen);
    return rc;
}

void run_resume_clear(run_resume *res)
{
    dth_free(NULL, res->buf);
    cli_ckpt_clear(&res->c);
    dth_scene_free(res->saved);
}
