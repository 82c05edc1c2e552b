/* The identified flags' hold (docs/identification.md, "The identified flags"): with the
 * information filter a body is flagged only once the filter has replayed its first samples
 * at its own estimate (before, its standard deviations are those of a linearisation at the
 * guess) and only where its estimates moved, over the last ident.fit_window, as little as
 * their standard deviations say they can. For a filter whose model holds, the estimate at t
 * less the one at t_r < t is independent of the error at t with covariance
 * P(t_r) - P(t); a move beyond z sqrt(sd_i(t_r)^2 - sd_i(t)^2) (z the flags' quantile,
 * ident.flag_confidence) is an error the standard deviations do not cover: a drift, or a
 * step the sds did not foresee. */
#ifndef SR_EST_HOLD_H
#define SR_EST_HOLD_H
#include "est_types.h"
/* 1 where the committed sample at t makes a snapshot due (the information filter runs and
 * has replayed; none stored yet, or ident.fit_window / EST_HOLD_STEPS since the newest) */
int est_hold_due(const sr_estimator_model *m, const void *data, double t);
/* After a committed sample at t: its time kept; the ring emptied while the filter has not
 * replayed; the reported least-squares estimates ls (20) and sds (20) stored where due (the
 * caller computes them only then: est_hold_due). */
void est_hold_commit(const sr_estimator_model *m, void *data, double t, const double *ls,
                     const double *sd);
/* The identified flags (2) as the hold allows them (the information filter only): none
 * before its replay, nor before a snapshot ident.fit_window old exists (the newest such is
 * the reference r); a body's flag down where one of its identified estimates i moved since r
 * by more than flag_z sqrt(max(sd_r,i^2 - sd_i^2, 0)) + EST_HOLD_FLOOR x the flag's threshold
 * (ident.sd_rel of its error scale). ls, sd: the reported least-squares estimates and sds. */
void est_hold_gate(const sr_estimator_model *m, const void *data, const double *ls,
                   const double *sd, int *identified);
/* 0, or 1 where the hold's counts or numbers are out of range (a corrupt block) */
int est_hold_check(const est_hold *h);
#endif /* SR_EST_HOLD_H */
