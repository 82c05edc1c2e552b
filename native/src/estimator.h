/* The estimator core: online identification of the inertial parameters of a space robot's base
 * and grasped target, one sample at a time (Zhang, Yue, Yuan, IEEE Access 2020), with the
 * noise options, the information filter and the excitation design around it.
 *
 * Shaped as Pinocchio's Model / Data:
 *   - a Model (sr_estimator_model), constant after sr_estimator_model_new: the known arm, the
 *     options, the prior, and the layout of the identified parameters;
 *   - a Data block (sr_estimator_data_size bytes, NO pointers inside): every state that evolves
 *     (estimates, covariances, Gram matrices, tracker, history, counters). FMI get/set/serialize
 *     FMU state is a memcpy of it. Several Data blocks may share one Model (the Model is only
 *     read by update and report);
 *   - a work space (sr_estimator_work_size bytes, no part of the state) for the temporaries of
 *     an update, which then needs little stack (a host stepping FMUs on threads with small
 *     stacks);
 *   - one step path, sr_estimator_update: validation, the sample's equations (momentum eqs.
 *     11/16 or force eqs. 28/31), the solver's step (the paper's modified RLS, eqs. 34-38, or
 *     one RLS over the standard parameters), the standard deviations and the drift tracker,
 *     computed in the work space and committed only when every number came out finite (a
 *     rejected sample changes only the counters, status and message);
 *   - sr_estimator_report_get reads the Data only (pure).
 * Every table a host or binding needs comes from here: the options by their FMU parameter
 * names with their accepted ranges and defaults, the outputs by their FMU names, the status
 * texts; the sample's signals are sample.h's.
 *
 * Vectors of 20 estimates are in the order of spacerobot.interface.ESTIMATE_NAMES: per body
 * (base, then target) m [kg], b (3) [m], Ixx Iyy Izz Ixy Ixz Iyz [kg.m2] (about the com, body
 * frame).
 */
#ifndef SR_ESTIMATOR_H
#define SR_ESTIMATOR_H

#include <stddef.h>

#include "arm.h"
#include "sample.h"
#include "sensor_noise.h"
#include "sr_api.h"

#ifdef __cplusplus
extern "C" {
#endif

/* status codes (diag.status; sr_estimator_status_text) */
#define SR_EST_NO_SAMPLE 0           /* no sample yet */
#define SR_EST_REFERENCE 1           /* momentum reference / differencing history stored */
#define SR_EST_ESTIMATING 2          /* last sample used */
/* ident.flag_confidence's range: from a coin's toss to a billion to one */
#define SR_EST_FLAG_CONFIDENCE_MIN 0.5
#define SR_EST_FLAG_CONFIDENCE_MAX (1.0 - 1e-9)
#define SR_EST_REJECT_NONFINITE 3    /* non-finite / out-of-range input, or an update overflowed */
#define SR_EST_REJECT_INCONSISTENT 4 /* base.A not a rotation, or time not increasing */

/* largest accepted input magnitude, SI units (every input's range; sr_estimator_param_range):
 * the sample's physical range */
#define SR_EST_INPUT_LIMIT SR_SAMPLE_LIMIT
/* base.A is accepted as a rotation when max |A^T A - I| <= this and det A > 0 */
#define SR_EST_ROTATION_TOL 1e-6
/* largest ident.diff_half_window and ident.corr_lags */
#define SR_EST_MAX_HALF_WINDOW 50
#define SR_EST_MAX_CORR_LAGS 10000
/* the accepted range of the initial covariances: 1e-12 to 1e16 (SI units; a prior sd of 1e8 kg
 * or kg.m2 says no more than "unknown", and beyond it the covariance update P - K H P cancels
 * every digit of a double: the samples are then rejected; 1 / P0 <= 1e12). The guesses' ranges:
 * body.h. */
#define SR_EST_P0_MIN 1e-12
#define SR_EST_P0_MAX 1e16
/* the momentum window's ring (sr_estimator_options.momentum_window_samples): the most
 * samples it may hold, and the sample spacing its automatic size allows for (the plant's
 * internal step; the project samples every 0.1 s). Its memory: 8 (1 + 24 + 3 n + 12 (+ 15
 * with sd_thrust)) bytes per sample, 0.9 MB for a 2 s window of a 6-joint arm. */
#define SR_EST_MAX_WINDOW_SAMPLES 100000
#define SR_EST_WINDOW_MIN_STEP 1e-3
/* largest ident.sd_thrust.scale / misalign, and ident.momentum_window [s] */
#define SR_EST_MAX_THRUST_SD 1.0
#define SR_EST_MAX_WINDOW 1e6
/* ident.noise_profile: none, the sensors' (noise_profile.h); the largest noise.scale, noise.scale
 * times a magnitude (SI units) and noise_dt [s] */
#define SR_NOISE_PROFILE_NONE 0
#define SR_NOISE_PROFILE_SENSORS 1
#define SR_NOISE_PROFILE_MAX 1e6
/* largest ident.mode_f [Hz]; most modes of the modal columns (ident.mode_f[1..], diag.mode_*) */
#define SR_EST_MAX_MODE_F 3.0
#define SR_EST_MIN_MODE_F 0.05
#define SR_EST_MAX_MODES 4
/* length of the message buffers (rejections, model errors) */
#define SR_EST_MSG_LEN 256

/** The estimator's options: the estimator FMU's parameters (their FMI names in the comments; the
 *  table of est_options.c gives each its name, range and default: sr_estimator_options_set,
 *  sr_estimator_param_range). */
typedef struct sr_estimator_options {
    int method;            /* method: 1 momentum (eqs. 11/16), 2 force (eqs. 28/31) */
    int solver;            /* solver: 1 the paper's modified RLS, 2 joint RLS over the 20
                              standard parameters */
    int accel_source;      /* accel_source: 1 measured, 2 differenced (force method) */
    double lambda;         /* lambda: forgetting factor, 0 < lambda <= 1 */
    double P0_mu, P0_theta;/* P0_mu, P0_theta: initial covariances (diagonal),
                              SR_EST_P0_MIN..SR_EST_P0_MAX */
    double guess_base[10], guess_target[10];  /* guess.base.*, guess.target.*: m, b(3) [m],
                                                 Ixx Iyy Izz Ixy Ixz Iyz about the com
                                                 (body.h's ranges) */
    double sd_rel;         /* ident.sd_rel: identified threshold, 0 < sd_rel < 1 (1e-3) */
    double flag_confidence;/* ident.flag_confidence: with the information filter, the
                              probability under the reported sd that every identified
                              estimate of a flagged body lies within the threshold,
                              SR_EST_FLAG_CONFIDENCE_MIN..MAX (0.99) */
    int excite_mode;       /* ident.excite_mode: 0 off, 1 until identified, 2 always */
    double excite_level;   /* ident.excite_level: 0..1 */
    double row_sd[4];      /* ident.sd_row.momentum_lin, .momentum_ang, .force_lin,
                              .force_ang: the equations' row sd (the chosen method's pair
                              weighs the rows); 0 = unit weight */
    int diff_half_window;  /* ident.diff_half_window: 1..50 (1..10 with diff_momentum) */
    int diff_momentum;     /* ident.diff_momentum: 0 automatic (on unless diff_half_window >
                              SR_DIFF_MAX_DISPLACEMENT_HALF_WINDOW), 1 on, 2 off (force,
                              differenced: the derivative's weights on the momentum equations
                              of the window's samples, not on the velocities) */
    int corr_lags;         /* ident.corr_lags: 0..10000 */
    double signal_sd[6];   /* ident.noise.*: a_S, alpha_B, qdd (measured); v_S, omega_B, qd
                              (differenced): white-noise sd per sample; > 0: the force method's
                              estimates bias-compensated (errors in variables, est_eiv.h;
                              either solver, with diff_momentum too); v_S, omega_B, qd also
                              the modal columns' window rows' (ident.modes = 1, est_modal.h) */
    double momentum_window;/* ident.momentum_window [s], 0..1e6 (momentum method: each
                              sample's equations differenced against the newest stored sample
                              at least this much older, the first until then; 0 = against the
                              first sample, eqs. 11/16) */
    int momentum_point;    /* ident.momentum_point: 0/1 (momentum method: the angular rows
                              about the base's position at the newer sample) */
    double sd_thrust_scale;     /* ident.sd_thrust.scale [1], 0..1: sd of the thrust's scale
                                   factor error (force and moment, constant over the run) */
    double sd_thrust_misalign;  /* ident.sd_thrust.misalign [rad], 0..1: sd of its
                                   misalignment per axis; either > 0: a consider covariance
                                   adds what they leave in the estimates to the sd (the
                                   estimates are unchanged; est_consider.h) */
    int momentum_window_samples;/* no FMU parameter: the most samples the momentum window's
                                   ring holds, 2..SR_EST_MAX_WINDOW_SAMPLES; 0 = automatic,
                                   momentum_window / SR_EST_WINDOW_MIN_STEP + 2 (samples at
                                   least 1 ms apart). A sample that would overfill it is
                                   rejected (status 4; the estimates are then those of the
                                   accepted samples, exactly) */
    int accel_bias;             /* ident.accel_bias: 0/1 (force method, measured
                                   accelerations: a_S minus the accelerometer bias estimated
                                   online from the navigation velocity, the slope of
                                   v_S - integral a_S dt; ignored otherwise) */
    /* -- the noise profile (noise_profile.h; docs/identification.md "One switch") -- */
    int noise_profile;          /* ident.noise_profile: 0 none (the options as given: without
                                   other settings the paper's equations), 1 sensors: the noise
                                   model of the sensors described below fills each noise option
                                   still at its default */
    double noise_scale;         /* noise.scale, 0..1e6: multiplies every magnitude in noise[] */
    double noise[SR_NOISE_COUNT]; /* noise.<name>: the sensors' error magnitudes (sensor_noise.h,
                                     the sensors FMU's parameters and units; the estimator FMU
                                     has those the profile reads); default 0 */
    double noise_dt;            /* no FMU parameter: the sample interval [s] the sensors draw
                                   their white noise at (densities over 1 s become
                                   d / sqrt(noise_dt) per sample); the FMU's: the scenario's
                                   sample time; default 0.1 */
    int information;            /* ident.information: 1 on: the reported estimates and sds from
                                   the information filter (information.h: the momentum
                                   equations with the sensors' noise model, linearised at this
                                   estimator's own estimates) and the Cramer-Rao bound as
                                   report.crb; needs noise_profile 1; 2 off; 0 (default)
                                   automatic: noise_profile 1 turns it on where the sensors
                                   have white noise */
    /* -- the excitation's rate (excite_design.h; docs/identification.md "Excitation that
     *    buys information") -- */
    int excite_adapt;           /* ident.excite_adapt: 1 the estimator tries excite_rate_try
                                   against the plant's own rate and keeps it where its bound
                                   shrinks clearly faster (SR_EXD_MARGIN; output
                                   ident.excite_rate); needs the information filter; 2 off
                                   (rate 1); 0 (default) automatic: on where the information
                                   filter runs and excitation is requested
                                   (ident.excite_mode 1 or 2) */
    double excite_rate_try;     /* ident.excite_rate_try: the candidate rate, in
                                   [SR_EXD_RATE_MIN, SR_EXD_RATE_MAX], != 1 (4) */
    double excite_window;       /* ident.excite_window [s] > 0: the information measured over
                                   (30) */
    double excite_settle;       /* ident.excite_settle [s] >= 0: the plant's time to switch
                                   rates (20: 2 excite.ramp of the project's plant) */
    double excite_horizon;      /* ident.excite_horizon [s] > 0: the run's length the bound is
                                   predicted for (300) */
    /* -- the modal columns (est_modal.h; docs/identification.md "Flexible parts: the modal
     *    columns") -- */
    int modes;                  /* ident.modes: 1 on (needs the momentum method and the
                                   joint solver), 2 off (default) */
    double mode_f[SR_EST_MAX_MODES]; /* ident.mode_f[1..4] [Hz]: the modes' frequencies where known,
                                   0 = not given (then found from the data) */
    /* -- the rigid band (est_band.h; docs/identification.md "The rigid band") -- */
    int band;                   /* ident.band: 0 automatic (default: on where the
                                   information filter runs and noise_dt is 0.01-2 s), 1 on
                                   (needs them), 2 off */
    /* -- the model-fit test (docs/identification.md "When the rigid model does not fit") -- */
    double fit_window;          /* ident.fit_window [s] > 0: the exponential window of the
                                   relative residual (60) */
    int fit_lags;               /* ident.fit_lags: lags of the whiteness test, 1..100 (50) */
    double fit_rho_max;         /* ident.fit_rho_max: misfit where the relative residual is
                                   above it (no noise model; 1e-2) */
    double fit_whiteness_max;   /* ident.fit_whiteness_max: misfit where the Ljung-Box Q/L is
                                   above it (information filter; 30) */
    double fit_chi2_max;        /* ident.fit_chi2_max: misfit where diag.info_chi2 is above
                                   it (2) */
    double fit_thrust_max;      /* ident.fit_thrust_max: misfit where a thrust scale is more
                                   than this many prior sds from 0 (3) */
    double fit_bias_k;          /* ident.fit_bias_k: the model-error term's factor k (the
                                   absorbed misfit over the residual's), the equations' own
                                   sds (0.5) */
    double fit_bias_k_info;     /* ident.fit_bias_k_info: the same for the information
                                   filter's (0.25) */
    double eiv_uncertainty;     /* ident.eiv_uncertainty: the errors-in-variables correction's
                                   relative uncertainty, its share of the information filter's
                                   sds (0.05) */
} sr_estimator_options;

/** The options' defaults (the table's: the core's own, base 600 kg and target 100 kg guesses
 *  with P0 = 1e6; an FMU's start values are its scenario's). */
SR_API void sr_estimator_options_default(sr_estimator_options *o);

/* -- the options' table (est_options.c): each option by the name of the estimator FMU's
 *    parameter that sets it (noise_dt and momentum_window_samples: no parameter) -- */

/** Number of options in the table, and option i's name (NULL out of range). */
SR_API int sr_estimator_option_count(void);
SR_API const char *sr_estimator_option_name(int i);
/** Option i's place in sr_estimator_options: its field's name, the index in the field's array
 *  (0 for a scalar) and the byte offset of the value; 1 for an Integer option (an int field),
 *  0 for a Real one; 1 where an estimator FMU parameter sets it. -1 / NULL out of range. */
SR_API const char *sr_estimator_option_field(int i);
SR_API int sr_estimator_option_index(int i);
SR_API long sr_estimator_option_offset(int i);
SR_API int sr_estimator_option_integer(int i);
SR_API int sr_estimator_option_parameter(int i);

/** The closed range [*min, *max] the core accepts for the estimator FMU's parameter or input
 *  fmi_name (an option's name, or an input's, e.g. "base.A[1,2]", "arm.q[3]": every input
 *  within +-SR_EST_INPUT_LIMIT): 0, or 1 for a name that is neither (nothing written). A value
 *  in its range may still be refused with the others (the rules between options, e.g.
 *  ident.information = 1 needs ident.noise_profile = 1; a guess's inertia must be a real
 *  body's): sr_estimator_options_check. */
SR_API int sr_estimator_param_range(const char *fmi_name, double *min, double *max);

/** Set the option name (its FMU name) of o to value: 0, 1 for a value an Integer option cannot
 *  hold (not an integer: the option's message in err, errlen bytes), 2 for an unknown name. The
 *  value's range is not checked here (sr_estimator_options_check). */
SR_API int sr_estimator_options_set(sr_estimator_options *o, const char *name, double value,
                                    char *err, size_t errlen);
/** The value of the option name of o into *value: 0, or 2 for an unknown name. */
SR_API int sr_estimator_options_get(const sr_estimator_options *o, const char *name,
                                    double *value);

/** 0 when the options o are valid: every value in its range (the noise.* magnitudes, noise.scale
 *  and noise_dt where ident.noise_profile = 1), the guesses real bodies (sr_body_check), and
 *  the rules between options; else 1 with a one-line message in err (errlen bytes,
 *  NUL-terminated when errlen > 0; err may be NULL) naming the FMU parameter, e.g.
 *  "forgetting factor lambda must satisfy 0 < lambda <= 1, got 1.5". */
SR_API int sr_estimator_options_check(const sr_estimator_options *o, char *err, size_t errlen);

/** The constant part: robot, options, prior, parameter layout. */
typedef struct sr_estimator_model sr_estimator_model;

/** A new Model, or NULL on invalid options (sr_estimator_options_check, on the options as given
 *  and with their noise profile applied) or robot with a one-line message in err (errlen
 *  bytes, NUL-terminated when errlen > 0; err may be NULL) naming the parameter by its FMU
 *  name. The robot is copied. Free with sr_estimator_model_free. */
SR_API sr_estimator_model *sr_estimator_model_new(const sr_robot *robot,
                                                  const sr_estimator_options *opt,
                                                  char *err, size_t errlen);
SR_API void sr_estimator_model_free(sr_estimator_model *m);

/** The options the Model m runs with into *out: its noise profile applied, and those that do
 *  not apply to its method and accelerations at 0 (ident.momentum_window: the momentum
 *  method's, with a window; ident.momentum_point: the momentum method's; ident.accel_bias:
 *  the force method's with measured accelerations; ident.diff_momentum: with differenced
 *  ones; ident.noise.*: the force method's, and v_S, omega_B, qd the modal columns' window
 *  rows'). */
SR_API void sr_estimator_model_options(const sr_estimator_model *m, sr_estimator_options *out);


/** Bytes of one Data block of this Model (depends on diff_half_window, corr_lags, n, the
 *  momentum window's ring, and with diff_momentum and ident.noise.* the window's noise rows:
 *  1008 bytes per noisy channel and stored sample). */
SR_API size_t sr_estimator_data_size(const sr_estimator_model *m);

/** Initialise the Data block data (sr_estimator_data_size(m) bytes, any alignment of a malloc'ed
 *  or double-aligned buffer) to the state before any sample. */
SR_API void sr_estimator_data_init(const sr_estimator_model *m, void *data);

/** Number of values of a flat sample of the Model's robot (sample.h: its signals in the order
 *  of SR_SAMPLE_SIGNALS, base.A row-major). */
SR_API int sr_estimator_sample_length(const sr_estimator_model *m);

/** Bytes of the work space of this Model: the temporaries of one update (the new state of
 *  its transaction, the sample's equations, the information filter's and the excitation
 *  design's matrices), kept off the stack so that an update needs little of it (hosts step
 *  FMUs on threads with small stacks). Allocate it once beside the Data block, any alignment
 *  of a malloc'ed or double-aligned buffer; it is no part of the state (never copied or
 *  saved; its contents between updates mean nothing). One work space per thread that
 *  updates. */
SR_API size_t sr_estimator_work_size(const sr_estimator_model *m);

/** One sample taken at time t [s]; sample (sr_estimator_sample_length(m) values) as above;
 *  work: the work space (sr_estimator_work_size(m) bytes).
 *  Never fails hard: returns the status (SR_EST_*). A rejected sample (3, 4) leaves every
 *  estimate, covariance and internal state untouched except the rejected counter, the status
 *  and the message. msg (msglen bytes; may be NULL) gets the reason of a rejection ("" when
 *  accepted). Sample times must increase only where the state depends on them (differenced
 *  accelerations, the momentum window, the thrust integrals of sd_thrust, the information
 *  filter). A Data block
 *  whose counters are out of range (not initialised, corrupt, or of another Model) is not
 *  used: status 3, nothing written; so is a missing work space. */
SR_API int sr_estimator_update(const sr_estimator_model *m, void *data, void *work, double t,
                               const double *sample, char *msg, size_t msglen);

/** Check a Data block restored from outside (FMI set / deserialize state, a file) before it is
 *  used: the magic, every count, index, flag and status within its range for this Model (the
 *  differencing history's, the momentum window's and the residual rings' heads and counts,
 *  the momentum reference, noise-compensation, thrust-integral and accelerometer-bias
 *  flags, the sample counters, the status, the message's terminating NUL).
 *  Its floating-point values are not judged: whatever they are, an update reads and writes
 *  only within the block and commits only finite numbers (else it rejects the sample). The
 *  block must be sr_estimator_data_size(m) bytes (the caller knows its size). Returns 0 when
 *  valid, else 1 with a one-line reason in err (errlen bytes, NUL-terminated when errlen > 0;
 *  err may be NULL). sr_estimator_update and the readers refuse a block that fails it. */
SR_API int sr_estimator_data_check(const sr_estimator_model *m, const void *data, char *err,
                                   size_t errlen);

/** What the estimator reports (the estimator FMU's outputs). */
typedef struct sr_estimator_report {
    double vector[20], sd[20];        /* physically consistent estimates and their standard
                                         deviations (sd.<estimate>) */
    int identified[2], physical[2];   /* diag.identified.base/target, diag.physical.* */
    double residual_lin, residual_ang, excitation_mu, excitation_theta;   /* diag.* */
    int samples, rejected, status;    /* diag.samples, diag.rejected, diag.status (the
                                         counters saturate at INT_MAX) */
    double excite;                    /* the excitation level requested (output ident.excite) */
    /* -- the information filter (options.information; else 0) -- */
    double crb[20];                   /* crb.<estimate>: the first-order Cramer-Rao bound's
                                         standard deviations of the data so far */
    double info_chi2;                 /* diag.info_chi2: its weighted residuals' mean square
                                         (1 where the noise model is right; the sds are the
                                         bound times sqrt(max(1, info_chi2))) */
    /* -- the excitation's rate (options.excite_adapt; else 1, 0, 0) -- */
    double excite_rate;               /* ident.excite_rate: the rate requested from the plant */
    double excite_score[2];           /* diag.excite_score.rate_1 / .rate_try: the predicted
                                         largest scaled bound at the horizon of each (0 before
                                         the choice) */
    /* -- the modal columns (options.modes = 1; else 0) -- */
    double mode_f[SR_EST_MAX_MODES];  /* diag.mode_f[k] [Hz], diag.mode_zeta[k]: the modes */
    double mode_zeta[SR_EST_MAX_MODES];  /* in use, given or found (0: none) */
    /* -- the model-fit test -- */
    double model_fit;                 /* diag.model_fit: the relative residual over
                                         ident.fit_window (no noise model), or the Ljung-Box
                                         Q/L of the information filter's whitened residuals */
    int misfit;                       /* diag.misfit: 1 where the model-fit test fails */
    int misfit_cause;                 /* diag.misfit_cause: SR_EST_MISFIT_MODEL (the rigid
                                         model does not fit: the estimates held), _THRUST (a
                                         thrust scale beyond its prior, white residuals),
                                         _NOISE (chi2 alone: the noise.* values too small);
                                         0 without a misfit */
    int band;                         /* diag.band: the rigid band's answer reported (1 the
                                         low-pass alone, 2 with the compliance block, 3
                                         with the found modes' columns; where the rigid
                                         model does not fit), 0 none */
} sr_estimator_report;

/* sr_estimator_report.misfit_cause */
#define SR_EST_MISFIT_MODEL 1
#define SR_EST_MISFIT_NOISE 2
#define SR_EST_MISFIT_THRUST 3

/** The excitation level the Model m requests (output ident.excite) for the bodies' identified
 *  flags: ident.excite_level while excitation is wanted (ident.excite_mode 2 always, 1 while
 *  a body is not identified), else 0. */
SR_API double sr_estimator_excite_request(const sr_estimator_model *m, int identified_base,
                                          int identified_target);

/** The report of the Data block (reads it only). */
SR_API void sr_estimator_report_get(const sr_estimator_model *m, const void *data,
                                    sr_estimator_report *r);

/** The message of the last sample ("" when it was accepted) into msg (msglen bytes). */
SR_API void sr_estimator_message(const sr_estimator_model *m, const void *data, char *msg,
                                 size_t msglen);

/** The least-squares estimates (20, before the physical projection) and the standard
 *  deviations (20) of the Data block (the information filter's where it runs). */
SR_API void sr_estimator_estimates(const sr_estimator_model *m, const void *data, double *vec,
                                   double *sd);

/** Bytes at the start of a Data block that hold the counters (samples, rejected), the status
 *  and the message: what a rejected sample changes. The rest (estimates, covariances, Gram
 *  matrices, tracker, history) changes only with an accepted sample. */
SR_API size_t sr_estimator_data_head_size(void);

/** The standard deviations (20) of this estimator's least-squares estimates without the drift
 *  tracker's lag term: the data's scatter, the prior's pull, the unobserved floor, computed
 *  from the Data block. A diagnostic: the report's sd adds the lag (est_tracker.h). */
SR_API void sr_estimator_sd_without_lag(const sr_estimator_model *m, const void *data,
                                        double *sd);

/* -- the outputs' and the status's tables (est_report.c) -- */

/** Number of the estimator FMU's outputs; output i's FMU name (NULL out of range) and 1 where
 *  it is an Integer variable. */
SR_API int sr_estimator_output_count(void);
SR_API const char *sr_estimator_output_name(int i);
SR_API int sr_estimator_output_integer(int i);

/** The outputs of the report r, in the table's order, into out (sr_estimator_output_count()
 *  values; the Integer ones as exact doubles). */
SR_API void sr_estimator_outputs(const sr_estimator_report *r, double *out);

/** What status code s means (diag.status), or NULL for a code out of range. */
SR_API const char *sr_estimator_status_text(int s);

/** SR_EST_INPUT_LIMIT and SR_EST_ROTATION_TOL, for bindings. */
SR_API double sr_estimator_input_limit(void);
SR_API double sr_estimator_rotation_tol(void);

/** sizeof(sr_estimator_options) and sizeof(sr_estimator_report), for bindings that check their
 *  view of the structs. */
SR_API size_t sr_estimator_options_size(void);
SR_API size_t sr_estimator_report_size(void);

#ifdef __cplusplus
}
#endif

#endif /* SR_ESTIMATOR_H */
