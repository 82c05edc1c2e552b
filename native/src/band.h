/* The rigid band (the estimator's ident.band, est_band.h): the information filter's momentum
 * rows low-passed below the flexible parts' modes, with a quasi-static compliance block for
 * what stays of them, so that the composite rigid body is identified through the sensors where
 * the rigid model does not fit (docs/identification.md, "The rigid band"; the batch study it
 * ships: benchmarks/rigid_band.py).
 *
 * Why. The rows H(t) u = y(t) (information.h) hold for any constant u, so one linear filter
 * applied in time to both sides keeps them exact, whatever its phase; a low-pass below the
 * modes (SR_BAND_FC) removes the parts' ringing. What stays of a part in the band is
 * quasi-static: below its frequency a mode's deflection follows the base's motion,
 * eta ~ -u / w^2 (+ 2 zeta u' / w^3), so its momentum is est_modal.h's G and C columns with
 * eta' replaced by those terms; the columns of two well-damped fast filters (2 and 1 Hz,
 * damping 0.7; SR_BAND_NM = 114 unknowns) span them whatever the parts' frequencies and
 * number.
 *
 * Per sample (sr_band_add): the filter's unweighted rows [H | y] (info_sample_rows at the
 * caller's linearisation point) and the two filters' G and C columns M (at rest at the first
 * sample) as one row block [M | H | y], through a causal Butterworth low-pass of order 6 at
 * SR_BAND_FC (three second-order sections; from rest at the first sample's rows, so that their
 * initial value is no transient). From SR_BAND_SETTLE / SR_BAND_FC seconds on (the filter's
 * start) each filtered block, weighted by its sample's W (info_sample_weight) and with its
 * errors-in-variables products (info_eiv_sample), is added (Householder) to three
 * square-root informations: [M | H | y] (the compliance), [M1 | H | y] (the first filter's
 * compliance alone) and [H | y] (the low-pass alone). Every SR_BAND_SOLVE_EVERY rows
 * (sr_band_solve) they are solved, compensated for the errors in variables (the used samples'
 * sums times the low-pass's white-noise gain, the sum of its impulse response's squares),
 * M eliminated (it comes first, so H's block is R's last); the compliance's answer is taken
 * where it halves the low-pass's chi2 at least (SR_BAND_CHI2_DROP: on a rigid spacecraft the
 * block takes 14-20 % of it from the low-passed noise alone), else the low-pass's, with its
 * bound (the first-order Cramér-Rao sds of the filtered rows under the unfiltered rows'
 * weights), chi2, degrees of freedom and the answer of the model beside it (est_band.c makes
 * the estimator's sds of them).
 *
 * The found modes' band (sr_band_model_init_modes, sr_band_data_init_modes): the same rows with
 * the columns of given modes in place of the compliance, all four blocks of
 * docs/identification.md section 8 (G, C, D, T: EST_MODAL_COLS per mode, at most
 * SR_BAND_MAX_MODES, the lowest first), the filters at the modes' own frequency and damping:
 * the low-pass has then only to damp what their first order leaves of the modes, so that modes
 * of 0.2-0.3 Hz, where the compliance is no longer quasi-static, stay in its model
 * (benchmarks/low_band.py, the batch study it ships). Its "first filter alone" is the lowest
 * mode alone, and with one mode found [M | H | y] is not kept (it is [M1 | H | y]).
 *
 * Shaped as the information filter: a constant Model (sr_band_model, sr_band_model_init) over
 * the filter's (sr_info_model) and a pointer-free Data block of sr_band_data_size bytes (a
 * memcpy is a copy). */
#ifndef SR_BAND_H
#define SR_BAND_H

#include "information.h"
#include "modal_filter.h"
#include "sr_api.h"

#define SR_BAND_FC 0.15            /* the low-pass's cut-off [Hz]: below modes of 0.2 Hz */
#define SR_BAND_ORDER 6            /* its order (SR_BAND_ORDER / 2 second-order sections) */
#define SR_BAND_NSOS (SR_BAND_ORDER / 2)
#define SR_BAND_SETTLE 3.0         /* its start: the rows of the first 3 / fc s left out */
#define SR_BAND_DT_MIN 0.01        /* the sample times it takes [s] */
#define SR_BAND_DT_MAX 2.0         /* (below its Nyquist frequency's 3.3 s) */
#define SR_BAND_NQS 2              /* the compliance's filters */
#define SR_BAND_NM (SR_BAND_NQS * EST_MODAL_GC_COLS)        /* its unknowns (114) */
#define SR_BAND_MAX_MODES 2        /* the found modes' band's filters (the lowest modes) */
#define SR_BAND_MAX_F (SR_BAND_NQS > SR_BAND_MAX_MODES ? SR_BAND_NQS : SR_BAND_MAX_MODES)
#define SR_BAND_NM_MAX (SR_BAND_MAX_MODES * EST_MODAL_COLS) /* most unknowns M (330) */
#define SR_BAND_NC (SR_BAND_NM_MAX + SR_INFO_MAX_U + 1)     /* widest row [M | H | y] */
#define SR_BAND_CHI2_DROP 0.5
#define SR_BAND_PRIOR_INFO 1e-12   /* each column's unknown's prior information */
#define SR_BAND_SOLVE_EVERY 10     /* rows between solves */
/* the band's own fit: its answer's chi2 over the low-passed noise's (the gain) at most this
   (est_band.c: beyond, its model does not hold either, e.g. modes at or below the low-pass:
   the sizes 1.1-2.9; wings at 0.3 Hz 12-109, at 0.2 Hz 530-2900, slosh at 0.1 Hz
   106-136) */
#define SR_BAND_FIT_MAX 5.0

/* sr_band_answer: which answer the last solve took (SR_BAND_COMPLIANCE: with the columns, the
   modes' in the found modes' band); sr_band_variant: SR_BAND_FIRST too, the first filter's
   columns alone (the lowest mode's alone) */
#define SR_BAND_NONE 0
#define SR_BAND_LOWPASS 1
#define SR_BAND_COMPLIANCE 2
#define SR_BAND_FIRST 3

/** One variant's answer of the last solve (reported form) */
typedef struct sr_band_variant_answer {
    double vec[20], bound[20];  /* the estimates and their first-order Cramér-Rao sds */
    double chi2;                /* the weighted residual sum of squares per degree of freedom */
    double dof;                 /* the degrees of freedom (rows less unknowns in use) */
} sr_band_variant_answer;

/** The constant part: the low-pass's second-order sections (b0 b1 b2 a1 a2 each: y = b0 x +
 *  b1 x' + b2 x'' - a1 y' - a2 y''), its white-noise gain (the sum of its impulse response's
 *  squares) and start (samples left out), the columns' unknowns (nm), the widths of the
 *  rows [M | H | y] (nc), [H | y] (nl) and [M1 | H | y] (n1: the first filter's columns
 *  alone), the filters (nq) and each one's columns (cols), modes (0: the compliance, its
 *  filters fixed; 1: the found modes', set per Data block), the sample time. */
typedef struct sr_band_model {
    int settle, nm, nl, nc, n1, nq, cols, modes;
    double dt, gain;
    double sos[SR_BAND_NSOS][5];
} sr_band_model;

/** The state's head (followed in the Data block by the three [R]s, the errors-in-variables
 *  sums, the first sample's rows and the low-pass's states). */
typedef struct sr_band_data {
    int added;                  /* samples added */
    int used;                   /* filtered rows added to the informations */
    int pick;                   /* the last solve's answer (SR_BAND_*) */
    int nf;                     /* filters in use (the modes' band: modes given) */
    double t_prev;              /* the previous sample's time [s] */
    double K[SR_THRUST_LEN];    /* the thrust integrals (equations.h) */
    double u_prev[EST_MODAL_U]; /* the previous sample's drive */
    est_modal_filter f[SR_BAND_MAX_F];
    /* the last solve's answers: the low-pass alone, all filters' columns, the first
       filter's alone (SR_BAND_LOWPASS .. SR_BAND_FIRST, less 1) */
    sr_band_variant_answer var[3];
} sr_band_data;

/** The temporaries of one sample or solve (beside the state, never part of it). */
typedef struct sr_band_work {
    sr_info_work info;                       /* the filter's rows' temporaries */
    double row[6 * SR_BAND_NC];              /* a sample's [M | H | y], then filtered */
    double wrow[6 * SR_BAND_NC];             /* weighted */
    double low[6 * SR_BAND_NC];              /* the low-pass's input: the rows less the
                                                first sample's */
    double cols[6 * EST_MODAL_COLS];
    double hy[6 * (SR_INFO_MAX_U + 1)], xs[SR_X_LEN(SR_MAX_JOINTS)];
    double R[SR_INFO_MAX_U * SR_INFO_MAX_U], Ri[SR_INFO_MAX_U * SR_INFO_MAX_U];
    double N[SR_INFO_MAX_U * SR_INFO_MAX_U];
    double mvec[SR_BAND_NM_MAX];
} sr_band_work;

/** Fill *b for the filter's model im and the sample time dt [s] (SR_BAND_DT_MIN ..
 *  SR_BAND_DT_MAX: the low-pass is designed for it, the samples taken as uniformly spaced by
 *  it). Returns 0, or 1 for a NULL pointer or dt out of range. */
SR_API int sr_band_model_init(sr_band_model *b, const sr_info_model *im, double dt);

/** Fill *b as sr_band_model_init, for the found modes' band: SR_BAND_MAX_MODES filters of
 *  EST_MODAL_COLS columns each, their modes given per Data block (sr_band_data_init_modes). */
SR_API int sr_band_model_init_modes(sr_band_model *b, const sr_info_model *im, double dt);

/** Bytes of the Data block of b over the filter's model im. */
SR_API size_t sr_band_data_size(const sr_band_model *b, const sr_info_model *im);

/** The state before any sample (the prior; the found modes' band without modes: its answer is
 *  then the low-pass's). */
SR_API void sr_band_data_init(const sr_band_model *b, const sr_info_model *im, void *data);

/** The found modes' band's state before any sample, with nf (1 .. b->nq) modes: frequencies
 *  f_hz [Hz] (ascending, > 0) and damping zeta (0 .. 1]. Returns 0, or 1 (nothing written) for
 *  a NULL pointer, a model that is not the modes', or modes out of range. */
SR_API int sr_band_data_init_modes(const sr_band_model *b, const sr_info_model *im, void *data,
                                   int nf, const double *f_hz, const double *zeta);

/** 1 if the state's counts are in range, its filters the model's (the compliance's, or
 *  modes in range) and its head's numbers finite, else 0. */
SR_API int sr_band_data_valid(const sr_band_model *b, const sr_info_model *im,
                              const void *data);

/** Add the sample x (flat, SR_X_LEN(n)) taken at t [s] (after the previous one's), its rows
 *  linearised at z_lin (20, reported form: its masses > 0): through the low-pass, and from the
 *  filter's start on into the informations, a solve every SR_BAND_SOLVE_EVERY rows. w: the
 *  work space. Returns 0, or 1 (the state unchanged) for a NULL pointer, a time not after the
 *  previous sample's, a mass <= 0 in z_lin, or rows that are not finite. */
SR_API int sr_band_add(const sr_band_model *b, const sr_info_model *im, void *data, double t,
                       const double *x, const double *z_lin, sr_band_work *w);

/** Solve now (the state's answer kept where it is not finite or there are too few rows: the
 *  unknowns in use twice over). */
SR_API void sr_band_solve(const sr_band_model *b, const sr_info_model *im, void *data,
                          sr_band_work *w);

/** The last solve's answer: vec and bound (20 each: the reported parameters and their
 *  first-order Cramér-Rao sds), alt (20: the answer of the model beside it, the columns of
 *  the first filter alone beside all filters' (the lowest mode alone beside all modes'), all
 *  filters' beside the low-pass: what the choice of model changes), chi2 (2: the low-pass's
 *  and all filters' columns' weighted residual sum of squares per degree of freedom, the
 *  filtered noise's own about the model's gain), dof (the answer's degrees of freedom); each
 *  may be NULL. Returns its SR_BAND_* kind (SR_BAND_NONE: none yet, the outputs untouched). */
SR_API int sr_band_answer(const sr_band_model *b, const void *data, double *vec,
                          double *bound, double *alt, double *chi2, double *dof);

/** The last solve's answer of one variant, which (SR_BAND_LOWPASS, SR_BAND_COMPLIANCE: all
 *  filters' columns, SR_BAND_FIRST: the first filter's alone), into *a: 0, or 1 where there
 *  is none yet or which is out of range (*a untouched). */
SR_API int sr_band_variant(const sr_band_model *b, const void *data, int which,
                           sr_band_variant_answer *a);

/** sizeof(sr_band_model), sizeof(sr_band_work), for bindings that allocate them. */
SR_API size_t sr_band_model_size(void);
SR_API size_t sr_band_work_size(void);

#endif /* SR_BAND_H */
