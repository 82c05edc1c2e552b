/* The identified flags' hold (est_hold.h). */
#include "est_hold.h"

#include <math.h>
#include <string.h>

#include "information.h"
#include "physical.h"

/* a move within this fraction of the flag's threshold always passes (the round-off of the
 * filter's relinearisation: its standard deviations then barely change) */
#define EST_HOLD_FLOOR 0.01
/* sample times are compared to within this relative tolerance */
#define EST_HOLD_TIME_TOL 1e-9

static int replayed(const sr_estimator_model *m, const void *data)
{
    return m->info && est_info_data(m, data)->replayed;
}

static int newest(const est_hold *h) { return (h->head + EST_HOLD_SNAPS - 1) % EST_HOLD_SNAPS; }

int est_hold_due(const sr_estimator_model *m, const void *data, double t)
{
    const est_hold *h = &((const est_data *)data)->hold;
    if (!replayed(m, data))
        return 0;
    double step = m->opt.fit_window / EST_HOLD_STEPS;
    return h->count == 0 || t - h->t[newest(h)] >= step * (1.0 - EST_HOLD_TIME_TOL);
}

void est_hold_commit(const sr_estimator_model *m, void *data, double t, const double *ls,
                     const double *sd)
{
    est_hold *h = &((est_data *)data)->hold;
    h->t_last = t;
    if (!replayed(m, data)) {
        h->head = h->count = 0;
        return;
    }
    if (!ls || !sd)                          /* no snapshot due */
        return;
    for (int i = 0; i < EST_NZ; i++)
        if (!isfinite(ls[i]) || !(sd[i] >= 0.0))
            return;                          /* no snapshot of a singular answer */
    h->t[h->head] = t;
    memcpy(h->vec + h->head * EST_NZ, ls, sizeof(double) * EST_NZ);
    memcpy(h->sd + h->head * EST_NZ, sd, sizeof(double) * EST_NZ);
    h->head = (h->head + 1) % EST_HOLD_SNAPS;
    if (h->count < EST_HOLD_SNAPS)
        h->count++;
}

/* the newest snapshot at least ident.fit_window older than the last sample, or -1 */
static int reference(const sr_estimator_model *m, const est_hold *h)
{
    double age = m->opt.fit_window * (1.0 - EST_HOLD_TIME_TOL);
    for (int j = 1; j <= h->count; j++) {
        int s = (h->head + EST_HOLD_SNAPS - j) % EST_HOLD_SNAPS;
        if (h->t_last - h->t[s] >= age)
            return s;
    }
    return -1;
}

void est_hold_gate(const sr_estimator_model *m, const void *data, const double *ls,
                   const double *sd, int *identified)
{
    if (!m->info)
        return;
    const est_hold *h = &((const est_data *)data)->hold;
    int r = replayed(m, data) ? reference(m, h) : -1;
    if (r < 0) {
        identified[0] = identified[1] = 0;
        return;
    }
    const double *v0 = h->vec + r * EST_NZ, *s0 = h->sd + r * EST_NZ;
    double scale[EST_NZ];
    sr_error_scale(ls, SR_COM_SCALE_MIN, scale);
    for (int k = 0; k < 2; k++)
        for (int i = 10 * k; i < 10 * k + 10 && identified[k]; i++) {
            if (!m->identified[i])
                continue;
            /* Var(x(t) - x(t_r)) = P(t_r) - P(t) for a filter whose model holds */
            double dvar = s0[i] * s0[i] - sd[i] * sd[i];
            double allow = m->flag_z * sqrt(dvar > 0.0 ? dvar : 0.0)
                           + EST_HOLD_FLOOR * m->opt.sd_rel * scale[i];
            if (!(fabs(ls[i] - v0[i]) <= allow))
                identified[k] = 0;
        }
}

int est_hold_check(const est_hold *h)
{
    if (h->head < 0 || h->head >= EST_HOLD_SNAPS || h->count < 0 || h->count > EST_HOLD_SNAPS
        || !isfinite(h->t_last))
        return 1;
    for (int j = 0; j < EST_HOLD_SNAPS; j++) {
        if (!isfinite(h->t[j]))
            return 1;
        for (int i = 0; i < EST_NZ; i++)
            if (!isfinite(h->vec[j * EST_NZ + i]) || !(h->sd[j * EST_NZ + i] >= 0.0))
                return 1;
    }
    return 0;
}
