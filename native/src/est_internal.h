/* Internals of the estimator core (estimator.c, est_paper.c): the Model, the layout of the
 * Data block and the paper solver's step. Not part of the library's API.
 *
 * Sizes: p <= 8 identified entries of mu = [m1, m1 b1, mn, mn bn], r <= 12 of theta =
 * [I1#, In#]; the Gram matrices of the augmented rows [A | b] (nl = p + 1) and
 * [phi | y | psi] (na = r + 1 + 20). Matrices are row-major and compact (row stride = their
 * own column count) inside buffers sized for the largest case.
 */
#ifndef SR_EST_INTERNAL_H
#define SR_EST_INTERNAL_H

#include <stddef.h>

#include "equations.h"
#include "estimator.h"
#include "excite_design.h"
#include "information.h"

#define EST_NMU 8                 /* mu (8) */
#define EST_NTH 12                /* theta (12) */
#define EST_ND 20                 /* D(mu) (20) */
#define EST_NZ 20                 /* z = [mu, theta] and the estimates (20) */
#define EST_NL (EST_NMU + 1)      /* largest [A | b] width */
#define EST_NA (EST_NTH + 1 + EST_ND)  /* largest [phi | y | psi] width */
#define EST_NJ (EST_NZ + 1)       /* largest [Y | y] width of the joint solver */
#define EST_MAXK 6                /* most rows of one sample in one RLS update */
#define EST_MAXCH (6 + SR_MAX_JOINTS)  /* most noisy channels (accelerations or velocities) */

/* The accelerometer bias's running line fit (accel_bias.BiasFit): x(t) = v_S(t) - integral
 * a_S dt = c - b (t - t0) + noise per axis; t0 the first sample's time [s], t_last and a_last
 * (3) the last sample's time and measured acceleration (the trapezoid), integral (3) [m/s],
 * s (3) the sums of 1, tau, tau^2 and sx (2 x 3) of x, tau x over the samples, tau = t - t0. */
typedef struct est_bias_fit {
    double t0, t_last, a_last[3], integral[3], s[3], sx[6];
} est_bias_fit;

/* memory of the drift tracker's rate regression, in multiples of the estimator's
 * (tracking.RATE_MEMORY), and the lag taken as the estimate's own movement (NOISE_LAG) */
#define EST_RATE_MEMORY 2.0
#define EST_NOISE_LAG 1.0
/* the rate regression weighs a point by 1 / sd^2 with sd at least EST_SD_ROUNDOFF times the
 * estimate's error scale (the round-off of a double estimate: a smaller sd, e.g. the 0 of a
 * noise-free run's variance that round-off made <= 0, says nothing more) and sd^2 at least
 * EST_SD2_MIN: the weights stay <= 1e200, so that the regression's sums w, w dt^2, w dt dx
 * stay finite (a weight of 1 / 1e-300 overflowed them and every such sample was rejected) */
#define EST_SD_ROUNDOFF 1e-15
#define EST_SD2_MIN 1e-200

struct sr_estimator_model {
    sr_robot robot;
    sr_estimator_options opt;
    int n, nflat;                 /* joints, flat sample length */
    int force, differenced;       /* force method; differenced accelerations */
    int diffmom;                  /* differenced: the derivative of the momentum equations */
    int eiv;                      /* the accelerations' noise compensated (signal_sd > 0) */
    double accel_sd[6 + SR_MAX_JOINTS];   /* its sd per acceleration channel (differenced:
                                             of the velocities; times the derivative's gain,
                                             or with diffmom the derivative's weights) */
    int accel_ch[6 + SR_MAX_JOINTS];      /* a_S, alpha_B, qdd in a flat sample */
    int vel_ch[6 + SR_MAX_JOINTS];        /* v_S, omega_B, qd in a flat sample */
    int n_used, used[6 + SR_MAX_JOINTS];  /* the channels with sd > 0 (eiv.noise_rows) */
    int bias;                     /* the accelerometer bias fitted and subtracted (accel_bias,
                                     force method with measured accelerations; accel_bias.py) */
    int slot;                     /* doubles per history sample: t, sample (, own-point rows
                                     and, with the consider term, their consider columns, and
                                     with eiv their noise rows: n_used blocks of 3 x 42) */
    int slot_noise;               /* offset of those noise rows in a slot */
    /* the thrust's consider term (sd_thrust > 0, consider.py): its prior sd per consider
     * parameter (8), and whether the thrust integrals are kept (the momentum form's
     * sensitivities: the momentum method, or the differenced momentum equations) */
    int consider, thrust_int;
    double sd_c[SR_N_CONSIDER];
    /* the momentum window (momentum method, momentum_window > 0): its length [s], the
     * ring's capacity and doubles per sample (t, sample, with thrust_int its 15 integrals) */
    int window, win_cap, win_slot;
    double win_len;
    double w_lin, w_ang;          /* row weights 1 / row_sd (1: unweighted) */
    /* the identified parameters and rows (spacerobot.interface.ParameterLayout) */
    int p, r, nl, na;
    int mu_active[EST_NMU], theta_active[EST_NTH];
    int n_mu_out, mu_out[EST_NMU], n_th_out, th_out[EST_NTH];
    int k1, k2, rows_lin[3], rows_ang[3];
    int identified[EST_NZ];
    int sharp_to_project[6];
    /* the joint solver's standard parameters [m, m b, I_O#] per body (20): the identified
     * ones (q), the others, and which identified ones are masses / first moments */
    int q, std_active[EST_NZ], n_std_out, std_out[EST_NZ];
    int n_lin_cols, lin_cols[EST_NZ], n_ang_cols, ang_cols[EST_NZ];
    double pi0_full[EST_NZ], prior[EST_NZ];       /* guesses; P0 per standard parameter */
    double mu0_full[EST_NMU], th0_full[EST_NTH];   /* the guesses (8), (12) */
    double mu0[EST_NMU], th0[EST_NTH];             /* their identified entries (p), (r) */
    /* layout of the Data block's variable tail (byte offsets from its start) */
    int half;                     /* diff_half_window m: history of 2 m samples */
    int lags;                     /* corr_lags L */
    size_t off_hist, off_corr_lin, off_corr_ang, off_win, size;
    /* the information filter (options.information): its model and its Data's offset */
    int info;
    sr_info_model info_m;
    size_t off_info, off_info_buf;   /* its state; its replay buffer (information.h) */
    int adapt;                    /* the excitation's rate chosen (excite_design.h) */
    sr_exd_options exd;
    size_t off_exd;               /* its state (sr_exd_data) */
};

/* Everything an accepted sample changes except the variable tail (history, residual ring):
 * an update computes a new one on the stack and commits it only when it came out finite. */
typedef struct est_core {
    /* the modified RLS (eqs. 34-38): identified mu (p), theta (r), their P, M = dtheta/dD
     * (r x 20), D(mu) (20) of the full mu */
    double mu[EST_NMU], P_mu[EST_NMU * EST_NMU];
    double theta[EST_NTH], P_th[EST_NTH * EST_NTH];
    double M[EST_NTH * EST_ND], D[EST_ND];
    /* Gram matrices of the weighted rows [A | b] (nl x nl), [phi | y | psi] (na x na) and
     * their counts (uncertainty.Gram) */
    double S_lin[EST_NL * EST_NL], S_ang[EST_NA * EST_NA];
    double rows_lin, rows_ang, decay_lin, decay_ang, n1_lin, n2_lin, n1_ang, n2_ang;
    /* the drift tracker (tracking.DriftTracker; clock = the sample count) */
    double tr_s0, tr_s1, tr_t_ref, tr_t, tr_a_bar;
    double tr_w[EST_NZ], tr_mt[EST_NZ], tr_mx[EST_NZ], tr_ctt[EST_NZ], tr_ctx[EST_NZ];
    double age_lin[EST_NL * EST_NL], age_ang[EST_NA * EST_NA];
    /* the joint solver (solver 2): the standard parameters (20, identified ones active), the
     * covariance of the identified ones (q x q), the Gram matrix of [Y | y] and its
     * age-weighted copy ((q + 1)^2; counts in the *_lin fields), the information of the
     * masses / first moments and of the inertias for the excitation diagnostics */
    double pi[EST_NZ], P_pi[EST_NZ * EST_NZ];
    double S_pi[EST_NJ * EST_NJ], age_pi[EST_NJ * EST_NJ];
    double info_lin[EST_NZ * EST_NZ], info_ang[EST_NZ * EST_NZ];
    /* errors in variables (eiv.py; the paper solver with signal_sd > 0): the expected noise
     * parts of S_lin, S_ang (has_eiv once the first noise rows came) and the bias-compensated
     * identified mu (p), theta (r) that the estimates report */
    int has_eiv;
    double N_lin[EST_NL * EST_NL], N_ang[EST_NA * EST_NA];
    double mu_c[EST_NMU], th_c[EST_NTH];
    /* the joint solver's: the expected noise part of S_pi ((q + 1)^2) and the compensated
     * standard parameters (20; pi stays the RLS's own answer) */
    double N_pi[EST_NJ * EST_NJ], pi_c[EST_NZ];
    /* residual autocorrelation rings (lin, ang; the joint solver: one): next row, rows stored */
    int corr_head[2], corr_count[2];
    /* what the report reads after the latest accepted sample */
    double vec[EST_NZ], sd[EST_NZ];          /* least-squares estimates, total sd */
    double residual_lin, residual_ang, rcond_mu, rcond_theta;
    /* momentum reference sample's equations (3 x 42) */
    int has_ref;
    double ref[3 * 42];
    /* differencing history ring (2 m samples of [t, flat]): next slot, samples stored */
    int hist_head, hist_count;
    /* -- the thrust's consider term (consider.py; in use where the model's consider is set) --
     * the consider sums sum w H^T R_c of the weighted identified rows H and their consider
     * right-hand sides R_c: the paper solver's A^T b_c (p x 8) and phi^T y_c (r x 8), the
     * joint solver's Y^T [b_c; y_c] (q x 8, in cons_lin) */
    double cons_lin[EST_NZ * SR_N_CONSIDER], cons_ang[EST_NTH * SR_N_CONSIDER];
    /* the momentum reference's consider columns (3 x 16) */
    double ref_c[3 * SR_N_CCOLS];
    /* the thrust integrals (equations.h, SR_THRUST_*; thr_started once a sample came) */
    int thr_started;
    double thr[SR_THRUST_LEN];
    /* the momentum window's ring (win_cap samples of [t, flat (, 15 integrals)]): next slot,
     * samples stored; the oldest is the reference of the next sample */
    int win_head, win_count;
    /* the accelerometer bias's fit (accel_bias; has_bias once a sample came) */
    int has_bias;
    est_bias_fit bias;
} est_core;

/* The Data block's fixed head; the variable tail follows at the model's offsets. */
typedef struct est_data {
    unsigned magic;
    int samples, rejected, status;
    char msg[SR_EST_MSG_LEN];
    est_core core;
} est_data;

#define EST_MAGIC 0x53524531u     /* "SRE1" */

/* doubles of est_noise_add's scratch: the noise blocks' identified rows */
#define EST_NOISE_SCRATCH (3 * EST_MAXCH * (EST_NL + EST_NA))

/* The work space of one update (sr_estimator_work_size bytes beside the Data block, never part
 * of the state): the new state of the sample's transaction and every temporary too large for
 * a small stack. Its contents between updates mean nothing. */
typedef struct est_work {
    est_core nw;                  /* the new state, committed when it came out finite */
    sr_info_data nwi;             /* the information filter's new state */
    sr_exd_work exd;              /* the information filter's and the excitation design's */
    /* the sample's equations (3 x 42) and their consider columns (3 x 16); the own-point rows
     * (, consider); the sample as the equations take it (the centre of the differencing
     * window, or a_S less the accelerometer bias) */
    double E[3 * SR_N_COLS], Ec[3 * SR_N_CCOLS];
    double own[3 * SR_N_COLS + 3 * SR_N_CCOLS];
    double xc[SR_X_LEN(SR_MAX_JOINTS)], xb[SR_X_LEN(SR_MAX_JOINTS)];
    /* the expected noise parts of the Gram matrices after this sample, the noise rows of the
     * sample, a block of the window's (diff_momentum), est_noise_add's rows */
    double N_a[EST_NJ * EST_NJ], N_b[EST_NA * EST_NA];
    double own_noise[EST_MAXCH * 3 * SR_N_COLS];
    double blk[EST_MAXCH * 3 * SR_N_COLS];
    double noise_rows[EST_NOISE_SCRATCH];
} est_work;

/* -- shared by the solvers (est_paper.c) -- */
double est_pymax(double a, double b);
void est_gram_add(const double *S, int n, const double *R, int k, double lam, double *out);
void est_gram_count(double lam, int k, double *rows, double *decay, double *n1, double *n2);
double est_gram_dof(double lam, double rows, double n1, double n2, int p);
double est_gram_var_scale(double lam, double n1, double n2);
double est_residual_variance(const double *S, const double *z, int n, double dof);
int est_rls_step(const double *x, const double *P, const double *H, const double *y, int p,
                 int k, double lam, double *x_new, double *P_new, double *e, double *K);
void est_sparse_lu_solve(double *A, int n, double *b);
void est_block_lag(const double *G_full, const double *M_full, int n, int q,
                   const double *rate, double growth, double *Ar, double *r_out,
                   double *extra);
void est_tracker_add(const sr_estimator_model *m, const est_core *old, est_core *nw,
                     double t, const double *x, const double *sd, const double *J,
                     const double *mu_full);
double est_relative_norm(const double *e, const double *rhs, int k);
void est_scatter_sd(const sr_estimator_model *m, const double *J, const double *C,
                    const double *pull, const int *unobserved_z, const double *x,
                    int nan_to_zero, double *sd);

/* -- the joint solver (est_joint.c) -- */
/* ParameterLayout.sharp_to_project: I = I#[s2p] (I# = I11 I12 I13 I22 I23 I33) */
extern const int EST_S2P[6];
/* The standard parameters z (20: per body m, c = m b (3), I_O# (6), the inertia about the body
 * frame's origin) of the reported x (20: per body m, b, Ixx Iyy Izz Ixy Ixz Iyz about the com;
 * parameters.standard_from_physical: I_O = I_c + m (|b|^2 1 - b b^T)). */
void est_standard_of_reported(const double *x, double *z);
/* Its inverse, the reported x (20) of z (report_kernels.joint_vector_of), and that map's
 * Jacobian d x / d z (20 x 20, report_kernels.joint_jacobian); s2p: EST_S2P. */
void est_joint_vector_of(const int *s2p, const double *z, double *out);
void est_joint_jacobian(const int *s2p, const double *z, double *J);
/* sd, data_only, J, vec as est_std_parts, for the joint solver (its covariance scaled by the
 * residual variance times the autocorrelation inflation infl). 0, or 3 not converged. */
int est_joint_std_parts(const sr_estimator_model *m, const est_core *c, double infl,
                        double *sd, double *data_only, double *J, double *vec);
/* the lag (20) of the joint solver's estimates (tracking eq. 2); 1 if finite */
int est_joint_lag(const sr_estimator_model *m, const est_core *c, const double *J,
                  const double *rate_x, double growth, double *lag);
/* est_paper_step for the joint solver: one RLS over the identified standard parameters;
 * e (k1 + k2) the a-priori residuals; Ec as est_paper_step's; N_pi the noise Gram matrix
 * after this sample ((q + 1) x (q + 1), est_noise_begin / est_noise_add) or NULL */
int est_joint_step(const sr_estimator_model *m, const void *data, const est_core *old,
                   est_core *nw, const double *E, const double *Ec, const double *N_pi,
                   double clock, double *e);
/* The joint solver's rows of one block E (3 x 42, full 3D rows; JointSolver._stack of the
 * identified rows): H (k1 + k2 x q) over the identified standard parameters, yy (k1 + k2)
 * the right-hand sides (the fixed parameters' columns moved there at c's pi); b (k1, may be
 * NULL) the weighted linear right-hand sides before that. */
void est_joint_rows(const sr_estimator_model *m, const est_core *c, const double *E,
                    double *H, double *yy, double *b);
/* the joint solver's initial standard parameters and covariance into c */
void est_joint_init(const sr_estimator_model *m, est_core *c);

/* The standard deviations of the solver's estimates for the state c (uncertainty of
 * solvers.ParameterSolver.std_parts): sd (20) floored at the error scale where unobserved,
 * data_only (20) the estimate without the prior's pull, J (20 x 20) the Jacobian of the
 * estimates in z, vec (20) the estimates, rcond (2) the excitation diagnostics.
 * infl_lin, infl_ang: the residual autocorrelation's inflations (1: none). Returns 0, or 3
 * where an eigen-decomposition did not converge. */
int est_std_parts(const sr_estimator_model *m, const est_core *c, double infl_lin,
                  double infl_ang, double *sd, double *data_only, double *J, double *vec,
                  double *rcond);

/* The full mu (8) and theta (12) of the state c: the guesses with the identified entries. */
void est_full_vectors(const sr_estimator_model *m, const est_core *c, double *mu_full,
                      double *theta_full);

/* The autocorrelation inflation after adding the residual e (k) to the ring of equation eq
 * (0 lin, 1 ang) of the Data block data, without writing (Autocorrelation.add/inflation). */
double est_corr_inflation(const sr_estimator_model *m, const void *data, const est_core *c,
                          int eq, const double *e, int k);

/* The autocorrelation inflation of the sums as they are (Autocorrelation.inflation). */
double est_corr_current(const sr_estimator_model *m, const void *data, int eq);

/* Add the residual e (k) to the ring of equation eq: the sums and the ring (the commit). */
void est_corr_commit(const sr_estimator_model *m, void *data, est_core *c, int eq,
                     const double *e, int k);

/* Commit the new state src of est_paper_step into dst: the parts of its arrays in use (the
 * rest of dst, e.g. a planar robot's unused entries, keeps its bytes), its scalars and the
 * autocorrelation rings' heads; not the momentum reference and the history (which the step
 * does not change). */
void est_core_commit(const sr_estimator_model *m, est_core *dst, const est_core *src);

/* One sample of the paper solver and everything the report reads after it: the rows E
 * (3 x 42, full 3D rows of one sample) in, the new state *nw from the old *old, at the
 * tracker's clock: every part of *nw that est_core_commit copies is written (nw need not be
 * initialised but for corr_head, corr_count). e_lin (k1), e_ang (k2): the a-priori residuals
 * (for the residual autocorrelation's commit). data: the Data block (read only: the
 * autocorrelation rings). Returns 0 ok, 1 the covariance lost definiteness, 2 non-finite
 * numbers, 3 an eigen-decomposition did not converge. N_lin, N_ang: the expected noise parts
 * of the Gram matrices after this sample (est_noise_begin / est_noise_add), or NULL where no
 * noise rows came. Ec (3 x 16): E's consider columns (equations.h, SR_N_CCOLS; read only
 * where the model's consider is set). */
int est_paper_step(const sr_estimator_model *m, const void *data, const est_core *old,
                   est_core *nw, const double *E, const double *Ec, const double *N_lin,
                   const double *N_ang, double clock, double *e_lin, double *e_ang);

/* The expected noise part of the Gram matrices after a sample (eiv.py eq. 1,
 * N = sum_k w_k sum_l sigma_l^2 C_l,k^T C_l,k): est_noise_begin writes lam times the old
 * ones (zeros before the first noise rows) into N_a, N_b; est_noise_add adds the identified
 * rows of nblocks (<= EST_MAXCH) blocks sigma_l C_l (3 x 42 each, full 3D rows), weighted
 * and selected as the sample's rows. The paper solver's N_a (nl x nl) of [A | b] and N_b
 * (na x na) of [phi | y | psi]; the joint solver's N_a ((q + 1) x (q + 1)) of [H | yy], N_b
 * unused. scratch: EST_NOISE_SCRATCH doubles. */
void est_noise_begin(const sr_estimator_model *m, const est_core *old, double *N_a,
                     double *N_b);
void est_noise_add(const sr_estimator_model *m, const est_core *old, const double *blocks,
                   int nblocks, double *N_a, double *N_b, double *scratch);

/* K P K^T (q x q) with K = 1 + (S - N)^-1 N in the directions S - N observes
 * (solvers.compensation_gain): the covariance of a bias-compensated answer. S, N (n x n),
 * their leading q x q blocks (q <= 20); P (q x q). */
void est_compensated_covariance(const double *S, const double *N, int n, int q,
                                const double *P, double *out);

/* The thrust's consider term of the state nw after a step (consider.py; the model's consider
 * set): the consider sums from the identified rows with their consider columns Ec (3 x 16),
 * weighted and selected as the rows: R_lin (k1 x nl_rows, the first p entries of each row
 * the weighted active A) against b_c, R_ang (k2 x ...) against y_c; then, where add_sd,
 * nw->sd (the tracker's total) gets the consider variance, sd^2 + sum_c (J dz/dc sigma_c)^2,
 * J (20 x 20) the Jacobian of the estimates in the solver's z.
 * est_consider_sums: the paper solver's sums from A (k1 x p) and phi (k2 x r); the joint
 * solver's from H (k1 + k2 rows x q). */
void est_consider_sums(const sr_estimator_model *m, const est_core *old, est_core *nw,
                       const double *Ec, const double *A, const double *phi, const double *H);
void est_consider_sd(const sr_estimator_model *m, est_core *nw, const double *J);

#endif /* SR_EST_INTERNAL_H */
