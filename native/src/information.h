/* The information filter (docs/identification.md, "The information filter and the bound"):
 * the 20 inertial parameters from the momentum equations with the sensors' noise model, as
 * a square-root information filter (Bierman), and the first-order Cramér-Rao bound that the
 * same information implies.
 *
 * The measurement model. At every sample the momentum equations (eqs. 11/16, sr_equations'
 * momentum form, NOT differenced against a reference) hold exactly with three kinds of unknowns
 * besides the inertial parameters: the system's momentum at the thrust integrals' origin c0
 * (one constant per row), the thrust's scale-factor and misalignment errors c (8,
 * sr_thrust_sensitivity), and the gyro's bias b (3). With the inertias taken about the body
 * frames' origins (z_O = [mu, I_O#]) every row is linear in all of them: the quadratic part of
 * psi D(mu) is -phi P_AXES (c_i c_j / m), the parallel-axis terms, which the origin inertias
 * absorb. So u = [z_O (identified, nz), c0 (nr), c (8), b (3)] enters the rows as H u = y
 * exactly, and the only approximations are the first-order noise terms:
 *   - the rows' noise covariance R_k: the sensors' white noise (navigation position and
 *     velocity, star tracker, gyro, joint angles and rates) propagated through the rows at the
 *     linearisation point z_lin (recomputed every sample);
 *   - the regressors' noise (errors in variables): the expected noise part of the weighted
 *     normal equations, N = sum_k sum_l sigma_l^2 dH_l^T dH_l, taken out of the answer
 *     (bias-compensated least squares, (S - N) u_c = s - n_y, S the information; or to first
 *     order, u_c = u + S^-1 (N u - n_y));
 *   - the linearisation point (SR_INFO_REPLAY below).
 * The filter: [R d] <- QR of [[R d]; [W H, W y]], W = R_k^-1/2, a Householder update per
 * sample (the normal equations lose z to round-off next to c0). The bound: the inverse
 * information S^-1 = R^-1 R^-T mapped to the reported parameters (mass, centre of mass, inertia
 * about the centre of mass) by the first-order Jacobian of that map.
 *
 * Shaped as the estimator: a constant Model (sr_info_model, filled by sr_info_model_init) and a
 * pointer-free Data block (sr_info_data: a memcpy is a copy of the state). Vectors of 20
 * estimates are in the order of spacerobot.interface.ESTIMATE_NAMES (per body m, b (3),
 * Ixx Iyy Izz Ixy Ixz Iyz about the com).
 */
#ifndef SR_INFORMATION_H
#define SR_INFORMATION_H

#include "arm.h"
#include "equations.h"
#include "sr_api.h"

#ifdef __cplusplus
extern "C" {
#endif

/* largest unknown vector: z_O (20), c0 (6), thrust errors (8), gyro bias (3) */
#define SR_INFO_MAX_U (20 + 6 + SR_N_CONSIDER + 3)
/* the linearisation point: the rows' weights hinge on it (their noise covariance spans 7
 * decades, and its near-null directions move with the centres of mass: linearised 10 cm off,
 * the errors grew 10-fold). The first SR_INFO_REPLAY samples are linearised at the caller's
 * estimate (the estimator's own equations) and kept; at sample SR_INFO_REPLAY the filter
 * starts again from its prior and adds them once more, linearised at its own estimate by then
 * (errors as linearised at the truth: 0.25-0.56 % where they were 0.3-2.0 %, four hardest
 * random cases); afterwards its own estimate, refreshed every SR_INFO_RELIN samples, is the
 * point. */
#define SR_INFO_REPLAY 600
#define SR_INFO_RELIN 10
/* the whiteness test's most lags (ident.fit_lags) */
#define SR_INFO_MAX_LAGS 100
/* the whiteness test counts where chi2 is above this: noise-free data under a noise model
 * give 1e-5 to 1e-4 (round-off's colour); with the sensors, rigid runs 0.87-1.3 and a
 * servicer's slosh misfit, plainly coloured, 0.40-0.46 */
#define SR_INFO_FIT_CHI2_MIN 0.1
/* The rows' noise covariance is recomputed at every sample: its square root held over 10
 * samples of 0.1 s left the whitened rows' covariance between 0.5 and 1.7 and the bound
 * optimistic by up to 1.5x (tests/test_information.py). */

/** The sensors' white noise per sample and the priors of the nuisance unknowns (SI units; a
 *  zero sd: that channel noise-free, or that nuisance unknown absent). */
typedef struct sr_info_noise {
    double r, v;             /* navigation position [m], velocity [m/s] */
    double omega;            /* gyro white noise per sample [rad/s] (arw / sqrt(dt)) */
    double att[3];           /* star tracker about base x, y, z [rad] */
    double q, qd;            /* joint angle (noise and quantisation) [rad], rate [rad/s] */
    double thrust[SR_N_CONSIDER];  /* prior sd of c = [s_F, phi_F (3), s_M, phi_M (3)] */
    double gyro_bias;        /* prior sd of the gyro's bias per axis [rad/s] */
} sr_info_noise;

/** The model-fit test's options (the estimator's ident.fit_*; sr_info_model_init sets the
 *  defaults in brackets): lags L of the whiteness test [50], 1..SR_INFO_MAX_LAGS; the
 *  thresholds of its Ljung-Box Q/L [30], of chi2 [2] and of the thrust scales' |s| / prior sd
 *  [3] above which the rigid model does not fit. */
typedef struct sr_info_fit_options {
    int lags;
    double whiteness_max, chi2_max, thrust_max;
} sr_info_fit_options;

/** What the model-fit test says (sr_info_fit_of): the Ljung-Box Q/L of the whitened
 *  residuals (the innovations up to and at the replay; from it on, restarted, the
 *  residuals at the compensated estimate, sr_info_data.u_fit; 0 before 2 L samples of
 *  each), chi2 (the weighted residual sum of squares per degree of
 *  freedom, the thrust errors estimated), the larger thrust scale's |s| / prior sd (0 without
 *  a thrust prior); decided from the filter's replay on (before, its linearisation point is
 *  the caller's): model (1 where the rigid model does not fit: the whiteness beyond its
 *  threshold, counted only where chi2 > SR_INFO_FIT_CHI2_MIN (far below, the data are less
 *  noisy than their model and the residuals' colour is round-off's); found at the replay it
 *  stays: the replay then adds the samples again with the thrust errors held and the model
 *  error's variances (sr_info_data.me_var, from the kept samples' residuals) in the rows'
 *  noise covariance; found after it, it stays too, without those variances: sr_info_step),
 *  scale (1 where, without model, the thrust scale is beyond its
 *  threshold: a thrust miscalibration or a model error the scale absorbs; found at the
 *  replay it stays, sr_info_data.scale_misfit; the estimates are not held), noise (1 where
 *  chi2 is beyond its threshold with neither: white residuals larger than the noise
 *  model's, the noise values too small; found at the replay it stays,
 *  sr_info_data.noise_misfit; the estimates are not held) and misfit (any of them: no
 *  flag). */
typedef struct sr_info_fit {
    double whiteness, chi2, thrust;
    int model, scale, noise, misfit;
} sr_info_fit;

/** The constant part. */
typedef struct sr_info_model {
    sr_robot robot;
    int n, planar;
    int nz, nr, nu, nb;           /* identified z, rows, unknowns, gyro bias unknowns (0/3) */
    int zi[20], rows[6];          /* identified z entries; rows of the 6 used */
    sr_info_noise noise;
    double zO0[20];               /* the guesses' z_O (inertias about the frames' origins) */
    double prior_sqrt[SR_INFO_MAX_U];  /* square roots of the prior's (diagonal) information */
    double u0[SR_INFO_MAX_U];     /* the prior's mean */
    sr_info_fit_options fit;      /* the model-fit test (sr_info_fit_of) */
} sr_info_model;

/** The state: the square-root information [R d] (R upper triangular nu x nu, row stride
 *  SR_INFO_MAX_U), the errors-in-variables sums, the thrust integrals, the rows' weight. */
typedef struct sr_info_data {
    int samples;
    double K[SR_THRUST_LEN];              /* thrust integrals (equations.h) */
    double R[SR_INFO_MAX_U * SR_INFO_MAX_U], d[SR_INFO_MAX_U];
    double N_HH[SR_INFO_MAX_U * SR_INFO_MAX_U], N_Hy[SR_INFO_MAX_U];
    double rss, rows;                     /* weighted residual sum of squares, rows added */
    /* the replay (SR_INFO_REPLAY): done once; the linearisation point since (20, reported) */
    int replayed;
    double z_lin[20];
    /* the whiteness test: a ring of the last lags + 1 whitened residual rows (nr each, row
       stride 6; next slot fit_head, fit_count rows added) and per row the running sums of
       the lag products sum_t e_t e_(t-k), k = 0..lags (fit_sum[6 k + row]) */
    int fit_head, fit_count;
    double fit_ring[(SR_INFO_MAX_LAGS + 1) * 6], fit_sum[(SR_INFO_MAX_LAGS + 1) * 6];
    /* the unknowns (nu) the whiteness test's residuals are taken at where fit_at (1): from
       the replay on (the sums restarted there) the compensated estimate with the thrust
       errors estimated, refreshed every SR_INFO_RELIN samples (kept where not finite); up
       to and at the replay, or where it was not finite at the replay (fit_at 0), the QR's
       innovations */
    int fit_at;
    double u_fit[SR_INFO_MAX_U];
    /* the model misfit found at the replay or by the whiteness test after it (sr_info_fit.model;
       kept: the thrust errors held from then on, the other two kept misfits cleared; 0 or 1,
       at most one of the three kept misfits) and the model error's variances a misfit at the
       replay added to every row's noise covariance since (0 for one found after it): the
       linear momentum's [N^2 s^2] and the angular momentum's about the base point
       [N^2 m^2 s^2] */
    int misfit;
    double me_var[2];
    /* chi2 alone beyond its threshold at the replay (sr_info_fit.noise; kept): the noise
       values too small */
    int noise_misfit;
    /* the thrust scale beyond its prior with white residuals at the replay (sr_info_fit.scale;
       kept) */
    int scale_misfit;
} sr_info_data;

/** The filter's temporaries: a work space beside the state, never part of it (a host copies
 *  the state, not this): sr_info_add's new R and N_HH (committed only when finite) and
 *  rows at the navigation's unit steps, and sr_info_predict's matrices. Its contents between
 *  calls mean nothing. */
typedef struct sr_info_work {
    double R[SR_INFO_MAX_U * SR_INFO_MAX_U], N_HH[SR_INFO_MAX_U * SR_INFO_MAX_U];
    double S[SR_INFO_MAX_U * SR_INFO_MAX_U], L[SR_INFO_MAX_U * SR_INFO_MAX_U];
    double Ri[SR_INFO_MAX_U * SR_INFO_MAX_U];
    /* sr_info_add's rows [H | y] at the navigation's unit steps, their mixed differences
       in (r_S, v_S) (the product's noise in R_k and its share of N) and one weighed */
    double nav_v[4][6 * (SR_INFO_MAX_U + 1)], nav_g[9][6 * (SR_INFO_MAX_U + 1)];
    double nav_wg[6 * (SR_INFO_MAX_U + 1)];
} sr_info_work;

/** Fill *m for robot (copied) with the noise model, the guesses z0 (20, reported form) and the
 *  estimator's prior covariances P0_mu, P0_theta (> 0). Planar robots: the in-plane unknowns
 *  (m, b_x, b_y, I_zz per body) and rows (linear x, y, angular z). Returns 0, or 1 for a NULL
 *  pointer, n out of range, a non-finite or negative sd, no white noise at all (r, v, omega,
 *  att, q, qd all 0: nothing to weigh the rows by), a guess with m <= 0, P0 <= 0. */

/** 1 if any of the white-noise sds of n (r, v, omega, att, q, qd) is > 0: something to weigh
 *  the rows by (the filter needs it), else 0. */
SR_API int sr_info_noise_white(const sr_info_noise *n);

/** 1 if every number of the state d is finite and its flags consistent (fit_at, misfit,
 *  noise_misfit and scale_misfit 0 or 1 and only once replayed, at most one of the misfits,
 *  me_var 0 without misfit):
 *  what a restored state must satisfy; else 0. */
SR_API int sr_info_data_finite(const sr_info_model *m, const sr_info_data *d);
SR_API int sr_info_model_init(sr_info_model *m, const sr_robot *robot, const sr_info_noise *noise,
                              const double *z0, double P0_mu, double P0_theta);

/** The state before any sample (the prior). */
SR_API void sr_info_data_init(const sr_info_model *m, sr_info_data *d);

/** Add the sample x (flat, SR_X_LEN(n)) taken at t [s], linearised at z_lin (20, reported
 *  form: its masses > 0); w: the work space. In place; returns 0, or 1 (d unchanged) for a
 *  NULL pointer, a t not finite or not after the last sample's, a z_lin with a mass <= 0, a
 *  rows' noise covariance that is not positive definite, or non-finite numbers. */
SR_API int sr_info_add(const sr_info_model *m, sr_info_data *d, double t, const double *x,
                       const double *z_lin, sr_info_work *w);

/** Doubles of the replay buffer of a robot with n joints: SR_INFO_REPLAY samples of
 *  [t, x (SR_X_LEN(n))]. */
SR_API size_t sr_info_buffer_length(int n);

/** One sample with the replay (SR_INFO_REPLAY): d = before with the sample x taken at t,
 *  linearised at the caller's estimate z_est (20, reported form) before the replay and at the
 *  filter's own after it. buffer (sr_info_buffer_length(n) doubles, owned by the caller, kept
 *  across calls): before the replay the sample is written at slot before->samples (a step the
 *  caller does not commit leaves only that slot, which the next sample overwrites). The
 *  replaying sample costs SR_INFO_REPLAY + 1 adds; where a kept sample cannot be added again
 *  (a corrupted buffer), the filter goes on from before without the replay. before and d must
 *  not overlap; w: the work space. Returns as sr_info_add (d = before on failure). */
SR_API int sr_info_step(const sr_info_model *m, const sr_info_data *before, sr_info_data *d,
                        double *buffer, double t, const double *x, const double *z_est,
                        sr_info_work *w);

/** What the filter says (reads d only; its temporaries on the stack, under 12 kB a frame):
 *  vec (20) the estimates (compensated for the noise in the regressors (errors in
 *  variables): 0 not, 1 to first order, 2 exactly, (S - N) u = s - n, falling back to 1
 *  where S - N is singular), bound (20) the first-order Cramér-Rao standard deviations (0
 *  for a parameter not identified, e.g. out of plane), chi2 (may be NULL) the weighted
 *  residual sum of squares per degree of freedom (1 when the noise model is right; 0 before
 *  nu rows). Returns 0, or 1 for a NULL pointer or a singular information (vec, bound then
 *  NaN). */
SR_API int sr_info_estimate(const sr_info_model *m, const sr_info_data *d, int compensated,
                            double *vec, double *bound, double *chi2);

/** The model-fit test of the state d into *f (sr_info_fit). Returns 0, or 1 for a NULL
 *  pointer or a singular information (f then the whiteness and chi2, and only the misfits
 *  kept from the replay). */
SR_API int sr_info_fit_of(const sr_info_model *m, const sr_info_data *d, sr_info_fit *f);

/** As sr_info_estimate, with the 8 thrust errors held at their prior means (0) and their
 *  prior sds taken as a consider term in the bound: what the filter says where a thrust scale
 *  would absorb a model error. chi2 (may be NULL) of the held unknowns; rss_held (may be
 *  NULL) their weighted residual sum of squares. Returns as sr_info_estimate. */
SR_API int sr_info_estimate_held(const sr_info_model *m, const sr_info_data *d, int compensated,
                                 double *vec, double *bound, double *chi2, double *rss_held);

/** The information of the state d: S = R^T R (nu x nu, the unknowns u; row stride
 *  SR_INFO_MAX_U), the prior's included. Differences of two states' S are the information the
 *  samples between them added (the filter never re-weighs a sample once added). */
SR_API void sr_info_information(const sr_info_model *m, const sr_info_data *d, double *S);

/** The bound (20, as sr_info_estimate's) that the information S(d) + factor dS would give,
 *  mapped at d's own estimate: dS (nu x nu, row stride SR_INFO_MAX_U) e.g. what a window of
 *  samples added, factor >= 0 how many such windows are to come; w: the work space. Returns
 *  0, or 1 (bound NaN) for a NULL pointer, a factor not finite or < 0, a sum that is not
 *  positive definite. */
SR_API int sr_info_predict(const sr_info_model *m, const sr_info_data *d, const double *dS,
                           double factor, double *bound, sr_info_work *w);

/** sizeof(sr_info_model), sizeof(sr_info_data), sizeof(sr_info_work), for bindings that
 *  check their view or allocate them. */
SR_API size_t sr_info_model_size(void);
SR_API size_t sr_info_data_size(void);
SR_API size_t sr_info_work_size(void);

#ifdef __cplusplus
}
#endif

#endif
