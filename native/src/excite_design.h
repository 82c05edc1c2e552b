/* The estimator's choice of how fast the plant excites (docs/identification.md, "Excitation
 * that buys information").
 *
 * Offline (`spacerobot design-excitation`) the period that shrinks the Cramér-Rao bound most
 * differed by target: on random spatial targets four times faster than the plant's default
 * gave a bound four times smaller, on the paper's target the default was best. So the estimator
 * measures instead of guessing: with the information filter on (information.h), it
 *   1. waits for the filter's replay (its linearisation settled), then takes the information
 *      one window of samples adds at the rate in effect (1: the plant's own excitation),
 *   2. asks the plant for the candidate rate (output ident.excite_rate; the plant switches
 *      through a dip of its excitation level), lets it settle, and takes the information one
 *      window adds at that rate,
 *   3. predicts, for each rate, the bound at the horizon if the rest of the run added what its
 *      window did (sr_info_predict: S + (time left / window) dS), and keeps the candidate where
 *      its largest scaled bound (bound / error scale of the estimate over the identified
 *      estimates, as the Monte Carlo's errors) is below SR_EXD_MARGIN times rate 1's; going back
 *      to rate 1 costs one more settle, which its prediction leaves out.
 * The choice is made once. Judged by the information the data actually carried, not by a model
 * of the motion: a prediction from the motion (the arm's share) misled the offline tool.
 * Where the estimator stops asking for excitation before the choice (both bodies identified,
 * ident.excite_mode 1), or the trial would not end before the horizon (counted from the first
 * sample), nothing is tried and the rate stays 1.
 *
 * Model (options) and a pointer-free Data block (a memcpy is a copy of the state).
 */
#ifndef SR_EXCITE_DESIGN_H
#define SR_EXCITE_DESIGN_H

#include "information.h"
#include "sr_api.h"

#ifdef __cplusplus
extern "C" {
#endif

/* the candidate rate's range: the wire's contract (the project's plant: SR_PLANT_RATE_MIN,
 * SR_PLANT_RATE_MAX; the estimator never includes plant code) */
#define SR_EXD_RATE_MIN 0.1
#define SR_EXD_RATE_MAX 10.0
/* the candidate wins only where its predicted bound is below SR_EXD_MARGIN times rate 1's:
 * two windows at the same rate (the plant not following) gave ratios of 0.87-1.11 on three
 * random spatial targets (the later window holds more information: it grows along a run), the
 * candidate's window on random spatial targets 0.64-0.82 */
#define SR_EXD_MARGIN 0.85
/* the longest window, settle time and horizon [s] */
#define SR_EXD_TIME_MAX 1e7

/** The phases of the choice (sr_exd_data.phase). */
enum sr_exd_phase {
    SR_EXD_WAIT = 0,        /* the information filter has not replayed yet */
    SR_EXD_MEASURE = 1,     /* a window at rate 1 */
    SR_EXD_SETTLE = 2,      /* the plant switching to the candidate */
    SR_EXD_MEASURE_FAST = 3,/* a window at the candidate rate */
    SR_EXD_DONE = 4         /* chosen (or nothing to choose) */
};

/** The options (the estimator FMU's parameters ident.excite_*; the estimator's options table
 *  checks them: est_options.c). */
typedef struct sr_exd_options {
    double rate;            /* ident.excite_rate_try: the candidate rate tried against 1,
                               in [SR_EXD_RATE_MIN, SR_EXD_RATE_MAX], != 1 */
    double window;          /* ident.excite_window [s] > 0: the information measured over */
    double settle;          /* ident.excite_settle [s] >= 0: after a request, the plant's time
                               to switch (the project's plant: 2 excite.ramp) */
    double horizon;         /* ident.excite_horizon [s] > 0: the time the bound is predicted
                               for (the run's length) */
    int identified[20];     /* 1 for the reported estimates the robot identifies (the
                               estimator's layout): the score's maximum runs over these */
} sr_exd_options;

/** The state. S_mark and dS are nu x nu, row stride SR_INFO_MAX_U (the filter's unknowns). */
typedef struct sr_exd_data {
    int phase;              /* enum sr_exd_phase */
    double rate;            /* the rate asked for now (output ident.excite_rate) */
    double t_first;         /* the first sample's time [s]: the horizon counts from it */
    double t_mark;          /* start of the present phase [s] */
    double w_slow;          /* length of the rate-1 window [s] */
    double score[2];        /* predicted largest scaled bound at the horizon: rate 1, the
                               candidate (0 before the choice, and where it failed) */
    double S_mark[SR_INFO_MAX_U * SR_INFO_MAX_U];   /* information at the window's start */
    double dS[SR_INFO_MAX_U * SR_INFO_MAX_U];       /* information the rate-1 window added */
} sr_exd_data;

/** The choice's temporaries (a work space beside the state, never part of it): the
 *  information filter's (sr_info_predict) and the information the candidate's window added. */
typedef struct sr_exd_work {
    sr_info_work info;
    double dS_fast[SR_INFO_MAX_U * SR_INFO_MAX_U];
} sr_exd_work;

/** The state before any sample: phase SR_EXD_WAIT, rate 1. */
SR_API void sr_exd_init(sr_exd_data *x);

/** 1 where the step at t [s] ends the window at rate 1: the step then reads whether the
 *  estimator still asks for excitation (sr_exd_step's wanted); else 0. */
SR_API int sr_exd_reads_wanted(const sr_exd_options *o, const sr_exd_data *x, double t);

/** After the information filter took the sample at t [s] (fd: its state then): the choice's
 *  next step. wanted: 1 while the estimator asks for excitation (ident.excite > 0), read only
 *  where sr_exd_reads_wanted says (where the rate-1 window ends: no excitation wanted then,
 *  nothing is tried). w: the work space. Returns 0, or 1 for a NULL pointer or a prediction
 *  that failed (the rate then stays 1, phase done). */
SR_API int sr_exd_step(const sr_exd_options *o, sr_exd_data *x, const sr_info_model *im,
                       const sr_info_data *fd, double t, int wanted, sr_exd_work *w);

/** 1 if every number of x is finite and its phase in range, else 0 (a restored state). */
SR_API int sr_exd_data_valid(const sr_exd_options *o, const sr_exd_data *x);

#ifdef __cplusplus
}
#endif

#endif
