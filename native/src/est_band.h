/* The rigid band's stage in the estimator (ident.band = 1; the band itself: band.h): when it
 * starts, where its rows are linearised, and its answer for the report. */
#ifndef SR_EST_BAND_H
#define SR_EST_BAND_H

#include "band.h"
#include "est_modal.h"
#include "est_types.h"

/* bytes of the band's state in the estimator's Data block (0 where ident.band is off) */
size_t est_band_size(const sr_estimator_model *m);

/* the state before any sample */
void est_band_init(const sr_estimator_model *m, void *data);

/* 0, or 1 where the state is not valid (a corrupt block) */
int est_band_check(const sr_estimator_model *m, const void *data);

/* The committed sample x at t (after the information filter's commit): nothing before the
 * filter's replay (SR_INFO_REPLAY samples: 60 s at 0.1 s); there the band starts with the
 * filter's replay buffer, linearised (the rows' weights, the gyro bias's columns) at the
 * filter's point, and where the low-pass alone does not fit those rows, again at its own
 * first answer, kept where its rows fit that better (else the first replay again); from its
 * first answer on at that answer. A sample the band cannot add (rows not finite) is left out
 * of it. */
void est_band_step(const sr_estimator_model *m, void *data, double t, const double *x,
                   sr_band_work *w);

/* The band's answer (vec, sd: 20 each) where it has one and its own rows fit (chi2 within
 * SR_BAND_FIT_MAX times the low-passed noise's): its SR_BAND_* kind, else SR_BAND_NONE (vec,
 * sd untouched) */
int est_band_answer(const sr_estimator_model *m, const void *data, double *vec, double *sd);

/* the band's temporaries in the work space w (after the modal columns') */
static inline sr_band_work *est_band_work_of(const sr_estimator_model *m, est_work *w)
{
    return (sr_band_work *)((char *)(w->noise + m->work_noise) + est_modal_work_size(m));
}

/* bytes of the band's temporaries (0 where ident.band is off) */
static inline size_t est_band_work_size(const sr_estimator_model *m)
{
    return m->band ? sizeof(sr_band_work) : 0;
}

#endif /* SR_EST_BAND_H */
