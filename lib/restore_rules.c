/* SPDX-License-Identifier: MIT */
/*
 * The rules between the fields of a restored DTH step state (dth_core.h: DTH__STATE_FIELDS) and
 * its policy's (policy.h), which each field's own check cannot see: the direction of travel and
 * the steps it holds, the step history against its count, the double-double parts, the branch
 * test's memory against the step count. The DTH stepper's `consistent` (stepper.h), called by a
 * restore before it keeps the state; every rule names the fields it relates.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include "dth_core.h"
#include "stepper.h"

static int refuse(char *err, size_t errlen, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static int refuse(char *err, size_t errlen, const char *fmt, ...)
{
    if (err && errlen) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    return DTH_EPARSE;
}

/* lo is the low part of the double-double hi + lo: at most half an ulp of hi (2^-53 |hi|). */
static int dd_low(double hi, double lo) { return fabs(lo) <= ldexp(fabs(hi), -52); }

/* The step history: which steps it holds, in which direction. */
static int history(const dth__state *s, char *err, size_t errlen)
{
    if (!(s->lam_hint * s->dir > 0))
        return refuse(err, errlen, "field 'lam_hint' = %.17g points against field 'dir' = %g, the direction of travel",
                      s->lam_hint, s->dir);
    /* lam is the step that arrived (the incoming step of the branch test's range and of a regularizer's
     * event): 0 only where none did; a replaced step with a fresh start (dth_reg_action.fresh) leaves it
     * without a history to predict from (have_prev = 0) */
    if (s->have_prev || s->lam != 0) {
        if (!(s->lam * s->dir > 0))
            return refuse(err, errlen, "field 'lam' = %.17g is no step in the direction 'dir' = %g%s", s->lam, s->dir,
                          s->have_prev ? ", yet 'have_prev' = 1" : "");
        if (s->steps < 1 || !s->have_mid)
            return refuse(err, errlen, "field '%s' with 'steps' = %ld and 'have_mid' = %d",
                          s->have_prev ? "have_prev' = 1" : "lam' != 0", s->steps, s->have_mid);
    }
    if (!s->have_prev && s->nhist != 0)
        return refuse(err, errlen, "field 'nhist' = %d without a step held ('have_prev' = 0)", s->nhist);
    if (s->nhist > s->steps)
        return refuse(err, errlen, "field 'nhist' = %d exceeds field 'steps' = %ld", s->nhist, s->steps);
    if ((s->nhist >= 2 && !(s->lam2 * s->dir > 0)) || (s->nhist >= 3 && !(s->lam3 * s->dir > 0)))
        return refuse(err, errlen, "field '%s' = %.17g is no step in the direction 'dir' = %g, yet 'nhist' = %d",
                      s->nhist >= 2 && !(s->lam2 * s->dir > 0) ? "lam2" : "lam3",
                      s->nhist >= 2 && !(s->lam2 * s->dir > 0) ? s->lam2 : s->lam3, s->dir, s->nhist);
    if (s->pending_exact && (s->steps != 0 || s->have_prev || s->have_mid))
        return refuse(err, errlen, "field 'pending_exact' = 1 (the start's exact step is still to come) with 'steps' = %ld",
                      s->steps);
    if (s->fact_valid && !s->have_mid)
        return refuse(err, errlen, "field 'fact_valid' = 1 without a step ('have_mid' = 0)");
    return DTH_OK;
}

int dth__dth_consistent(const void *state, char *err, size_t errlen)
{
    const dth__dth *it = state;
    const dth__state *s = &it->st;
    int rc = history(s, err, errlen);
    if (rc) return rc;
    for (size_t j = 0; j < it->N; j++)
        if (!dd_low(s->z[j], s->zlo[j]))
            return refuse(err, errlen, "field 'zlo' (component %zu, %.17g) is no low part of field 'z' (%.17g)", j, s->zlo[j],
                          s->z[j]);
    if (!dd_low(s->rho, s->rholo))
        return refuse(err, errlen, "field 'rholo' = %.17g is no low part of field 'rho' = %.17g", s->rholo, s->rho);
    const dth__policy_state *p = &it->pol.st;
    if (p->psi_step != -2 && !(p->psi_step >= 0 && p->psi_step < s->steps))
        return refuse(err, errlen, "policy field 'psi_step' = %ld is no step before field 'steps' = %ld (nor -2: none)",
                      p->psi_step, s->steps);
    if (!p->psi_known && p->psi_sign != 0)
        return refuse(err, errlen, "policy field 'psi_sign' = %d with 'psi_known' = 0", p->psi_sign);
    return DTH_OK;
}
