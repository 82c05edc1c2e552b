/* The rigid band's stage in the estimator (ident.band = 1; the band itself: band.h): when it
 * starts, where its rows are linearised, and its answer for the report. */
#ifndef SR_EST_BAND_H
#define SR_EST_BAND_H

#include "band.h"
#include "est_modal.h"
#include "est_types.h"

/* est_band_answer's kind beside band.h's SR_BAND_*: the found modes' band (ident.modes = 1) */
#define EST_BAND_MODES 3
/* its rows' fit (chi2 over the low-passed noise's) at most this where it reports: the wings at
   0.3 Hz 1.0-2.0; the servicer's wings at 0.2 Hz, with a second mode found at 3 Hz, 3.0-3.3
   (7.3-10.5 % off; benchmarks/LOW_BAND.md) */
#define EST_BAND_MODES_FIT_MAX 2.5

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
 * of it.
 * With the modal columns (ident.modes = 1) the found modes' band too (band.h): the samples
 * from the band's first on kept (at most EST_MODAL_MAX_SAMPLES: 409.6 s at 0.1 s); from the
 * first sample where the search has modes and the compliance band has an answer whose rows
 * do not fit, and then wherever the search's modes change (at its searches, est_modal.h),
 * the band starts again with the lowest SR_BAND_MAX_MODES of them from the first sample (its
 * filters at rest there), linearised at its own answer where that fits, else the compliance
 * band's, else the filter's point; once a sample is not kept its modes stay. */
void est_band_step(const sr_estimator_model *m, void *data, double t, const double *x,
                   sr_band_work *w);

/* The band's answer (vec, sd: 20 each) where it has one and its own rows fit (chi2 within
 * SR_BAND_FIT_MAX times the low-passed noise's): its SR_BAND_* kind; else the found modes'
 * band's where its rows fit within EST_BAND_MODES_FIT_MAX, with the fewest modes that do
 * (the lowest mode's columns alone, else all found modes'; the other's answer the model
 * beside it in the sds): EST_BAND_MODES; else SR_BAND_NONE (vec, sd untouched) */
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
