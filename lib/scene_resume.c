/* SPDX-License-Identifier: MIT */
/*
 * What a resume from a checkpoint may change in its scene (scene.h: dth_scene_resume_check): one rule
 * for dth run --resume and the Python package's Simulation.resume.
 */
#include <stdio.h>
#include <string.h>
#include "dth/scene.h"
#include "dth_internal.h"

int dth_scene_resume_may_change(const char *section, const char *key, unsigned flags)
{
    if (!section || !key) return 0;
    if (!strcmp(section, "integrator")) return !strcmp(key, "steps") || !strcmp(key, "t_end");
    if (!strcmp(section, "events")) return !strcmp(key, "file");
    if (!strcmp(section, "output"))
        return !strcmp(key, "file") ||
               ((flags & DTH_RESUME_ROWS) && (!strcmp(key, "every") || !strcmp(key, "diagnostics")));
    return 0;
}

int dth_scene_resume_check(const dth_scene *saved, const dth_scene *now, unsigned flags, const char *what, char *err,
                           size_t errlen)
{
    if (!saved || !now) {
        dth__set_err(err, errlen, "invalid arguments to dth_scene_resume_check");
        return DTH_EINVAL;
    }
    const dth_scene *sc[2] = {saved, now};
    for (int pass = 0; pass < 2; pass++)
        for (size_t i = 0; i < dth_scene_count(sc[pass]); i++) {
            const char *sec, *key, *val;
            dth_scene_entry(sc[pass], i, &sec, &key, &val, NULL);
            const char *other = dth_scene_get(sc[1 - pass], sec, key);
            if (dth_scene_resume_may_change(sec, key, flags) || (other && !strcmp(other, val))) continue;
            const char *was = pass ? other : val, *is = pass ? val : other;
            const char *org = dth_scene_origin(now, sec, key);
            dth__set_err(err, errlen,
                         "%s: %s.%s = %s%s%s would change the checkpointed run (it ran %s%s%s): a resume may change "
                         "only integrator.steps, integrator.t_end, output.file%s and events.file",
                         org ? org : what ? what : "the resumed scene", sec, key, is ? "'" : "", is ? is : "(unset)",
                         is ? "'" : "", was ? "with '" : "without it", was ? was : "", was ? "'" : "",
                         flags & DTH_RESUME_ROWS ? ", output.every, output.diagnostics" : "");
            return DTH_EINVAL;
        }
    return DTH_OK;
}
