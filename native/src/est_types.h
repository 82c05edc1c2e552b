/* The estimator core's private types (not part of the library's API): its constant Model, the
 * Data block that holds its state (what FMI get/set FMU state copies: no pointers inside, a
 * memcpy is a copy), the work space of one update (no part of the state), and the sample's
 * rows that pass from one stage of an update to the next.
 *
 * One sample passes through the core in one direction: est_update.c validates it,
 * est_rows.c forms its equations (and their consider columns and noise rows), the solver
 * (est_paper.c or est_joint.c, with the shared est_rls, est_uncertainty, est_tracker,
 * est_corr, est_consider, est_eiv) computes the new state, est_update.c commits it, and
 * est_report.c reads the committed state. est_model.c builds the Model and lays out the
 * Data block, est_options.c holds the options' table.
 *
 * Sizes: p <= 8 identified entries of mu = [m1, m1 b1, mn, mn bn], r <= 12 of theta =
 * [I1#, In#]; the Gram matrices of the augmented rows [A | b] (nl = p + 1) and
 * [phi | y | psi] (na = r + 1 + 20). Matrices are row-major and compact (row stride = their
 * own column count) inside buffers sized for the largest case.
 */
#ifndef SR_EST_TYPES_H
#define SR_EST_TYPES_H

#include <stddef.h>

#include "equations.h"
#include "estimator.h"
#include "excite_design.h"
#include "band.h"
#include "information.h"
#include "modal_filter.h"

#define EST_NMU 8                 /* mu (8) */
#define EST_NTH 12                /* theta (12) */
#define EST_ND 20                 /* D(mu) (20) */
#define EST_NZ 20                 /* z = [mu, theta] and the estimates (20) */
#define EST_NL (EST_NMU + 1)      /* largest [A | b] width */
#define EST_NA (EST_NTH + 1 + EST_ND)  /* largest [phi | y | psi] width */
#define EST_NJ (EST_NZ + 1)       /* largest [Y | y] width of the joint solver */
#define EST_MAXK 6                /* most rows of one sample in one RLS update */
#define EST_MAXCH (6 + SR_MAX_JOINTS)  /* most noisy channels (accelerations or velocities) */
#define EST_NB (3 * SR_N_COLS)    /* doubles of one block of rows (3 x 42) */
/* the modal columns (est_modal.h): most mode frequencies, those the search's scan uses per
 * frequency (G, C; all four blocks: EST_MODAL_COLS, modal_filter.h), most unknowns of the
 * modal solve, most samples kept for the mode search and the replay */
#define EST_MODAL_MAX_F SR_EST_MAX_MODES
#define EST_MODAL_SCAN_COLS EST_MODAL_GC_COLS
#define EST_MODAL_NMAX (EST_MODAL_MAX_F * EST_MODAL_COLS + EST_NZ)
#define EST_MODAL_SCAN_NMAX (EST_MODAL_MAX_F * EST_MODAL_SCAN_COLS + EST_NZ + 1)
#define EST_MODAL_MAX_SAMPLES 4096

/* The accelerometer bias's running line fit: x(t) = v_S(t) - integral a_S dt =
 * c - b (t - t0) + noise per axis; t0 the first sample's time [s], t_last and a_last (3) the
 * last sample's time and measured acceleration (the trapezoid), integral (3) [m/s], s (3)
 * the sums of 1, tau, tau^2 and sx (2 x 3) of x, tau x over the samples, tau = t - t0. */
typedef struct est_bias_fit {
    double t0, t_last, a_last[3], integral[3], s[3], sx[6];
} est_bias_fit;

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
    int n_used, used[6 + SR_MAX_JOINTS];  /* the channels with sd > 0 */
    int bias;                     /* the accelerometer bias fitted and subtracted (accel_bias,
                                     force method with measured accelerations) */
    int slot;                     /* doubles per history sample: t, sample (, own-point rows
                                     and, with the consider term, their consider columns, and
                                     with eiv their noise rows: n_used blocks of 3 x 42) */
    int slot_noise;               /* offset of those noise rows in a slot */
    /* the thrust's consider term (sd_thrust > 0): its prior sd per consider
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
    /* with the information filter, a flagged body's sd are at most its threshold / flag_z:
     * flag_z = the two-sided normal quantile of (1 - ident.flag_confidence) / (its identified
     * estimates) (Bonferroni: whatever their correlation) */
    double flag_z;
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
    size_t work_noise;            /* doubles of the work space's noise rows (est_work.noise) */
    /* the information filter (options.information): its model and its Data's offset */
    int info;
    sr_info_model info_m;
    size_t off_info, off_info_buf;   /* its state; its replay buffer (information.h) */
    int adapt;                    /* the excitation's rate chosen (excite_design.h) */
    sr_exd_options exd;
    size_t off_exd;               /* its state (sr_exd_data) */
    int modes;                    /* the modal columns (ident.modes = 1, est_modal.h) */
    int n_win;                    /* their window rows' noisy channels (errors in
                                     variables, est_modal.h): r_S, v_S, omega_B, qd with sd > 0 */
    int win_ch[9 + SR_MAX_JOINTS];        /* each one's place in a flat sample */
    double win_sd[9 + SR_MAX_JOINTS];     /* and its white noise's sd per sample */
    size_t off_modal;             /* their state, [R d] and the kept samples */
    /* the rigid band (ident.band, est_band.h): its model (band.h) and its state */
    int band;
    sr_band_model band_m;
    size_t off_band;
    /* with the modal columns too, the band over their found modes (band.h's modes model,
       est_band.h) */
    sr_band_model band_modes_m;
};

/* Everything an accepted sample changes except the variable tail (history, residual ring):
 * an update computes a new one in its work space and commits it only when it came out
 * finite. */
typedef struct est_core {
    /* the modified RLS (eqs. 34-38): identified mu (p), theta (r), their P, M = dtheta/dD
     * (r x 20), D(mu) (20) of the full mu */
    double mu[EST_NMU], P_mu[EST_NMU * EST_NMU];
    double theta[EST_NTH], P_th[EST_NTH * EST_NTH];
    double M[EST_NTH * EST_ND], D[EST_ND];
    /* Gram matrices of the weighted rows [A | b] (nl x nl), [phi | y | psi] (na x na) and
     * their counts */
    double S_lin[EST_NL * EST_NL], S_ang[EST_NA * EST_NA];
    double rows_lin, rows_ang, decay_lin, decay_ang, n1_lin, n2_lin, n1_ang, n2_ang;
    /* the drift tracker (est_tracker.h; clock = the sample count) */
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
    /* errors in variables (the paper solver with signal_sd > 0): the expected noise
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
    /* -- the thrust's consider term (est_consider.h; in use where the model's consider is
     * set) --
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
    /* the accelerometer bias's fit (has_bias once a sample came) */
    int has_bias;
    est_bias_fit bias;
    /* the model-fit test's relative residual (est_fit.h): this sample's sums of squares of
     * the a-posteriori residuals and of the right-hand sides (linear, angular rows; the
     * solver's step writes them) and their exponential window's sums */
    double fit_now[4], fit_win[4];
} est_core;

/* The identified flags' hold (est_hold.h): the reported estimates and standard deviations
 * at up to EST_HOLD_SNAPS sample times, ident.fit_window / EST_HOLD_STEPS apart, since the
 * information filter's replay (a ring: the next slot, the snapshots stored), and the last
 * committed sample's time [s]. */
#define EST_HOLD_STEPS 4
#define EST_HOLD_SNAPS (EST_HOLD_STEPS + 1)
typedef struct est_hold {
    int head, count;
    double t_last;
    double t[EST_HOLD_SNAPS];
    double vec[EST_HOLD_SNAPS * EST_NZ], sd[EST_HOLD_SNAPS * EST_NZ];
} est_hold;

/* The Data block's fixed head; the variable tail follows at the model's offsets. */
typedef struct est_data {
    unsigned magic;
    int samples, rejected, status;
    char msg[SR_EST_MSG_LEN];
    est_core core;
    est_hold hold;
} est_data;

#define EST_MAGIC 0x53524531u     /* "SRE1" */

/* What became of a sample in est_rows: its rows go to the solver, or it was only stored */
enum est_stored {
    EST_ROWS = 0,                 /* the rows E (and Ec, the noise rows) go to the solver */
    EST_STORED_HISTORY = 1,       /* the differencing history is still filling */
    EST_STORED_REFERENCE = 2,     /* the momentum method's first sample, its reference */
    EST_STORED_WINDOW = 3         /* the momentum window's first sample */
};

/* The rows of one sample (est_rows.c) and what its commit stores (est_rows_commit): the
 * equations E (3 x 42) and their consider columns Ec (3 x 16: the right-hand sides'
 * sensitivities to the thrust's errors); the expected noise rows as n_chunks chunks of
 * n_used blocks sigma_l C_l (3 x 42 each; the work space's tail), each chunk added to the
 * noise Gram matrices as one; the sample's own-point rows (, consider columns) and their
 * noise rows, stored with it in the differencing history; the thrust integrals and the
 * bias fit with this sample; the momentum window's samples this one makes obsolete. */
typedef struct est_rows {
    int stored;                   /* enum est_stored */
    int win_drop;
    int n_chunks;
    int win_chunks;               /* the window rows' noise rows instead (n_win blocks:
                                     the sample's and the reference's chunk, or none) */
    double E[EST_NB], Ec[3 * SR_N_CCOLS];
    double own[EST_NB + 3 * SR_N_CCOLS];
    double own_noise[EST_MAXCH * EST_NB];
    double Et[EST_NB], Er[EST_NB];          /* the window's sample's and reference's equations,
                                               a perturbed row (its noise rows') */
    double Ek[EST_NB], xk[SR_X_LEN(SR_MAX_JOINTS)];
    double thr[SR_THRUST_LEN];
    est_bias_fit bias;
    /* the sample as the equations take it: the window's centre with differenced
     * accelerations, or a_S less the accelerometer bias */
    double xc[SR_X_LEN(SR_MAX_JOINTS)], xb[SR_X_LEN(SR_MAX_JOINTS)];
} est_rows;

/* doubles of a solver's scratch for the noise blocks' identified rows (one chunk) */
#define EST_NOISE_SCRATCH (3 * EST_MAXCH * (EST_NL + EST_NA))

/* the modal stage's temporaries (est_modal.c): the search's Gram matrix, one sample's rows
 * with the modal columns, one frequency's columns at the sample and at its momentum window's
 * reference, then (with the window) the search's ring of the filters' states
 * (est_modal_work_size) */
typedef struct est_modal_work {
    double gram[EST_MODAL_SCAN_NMAX * EST_MODAL_SCAN_NMAX];
    double rows[EST_MAXK * (EST_MODAL_NMAX + 1 + SR_N_CONSIDER)];
    double cols[6 * EST_MODAL_COLS];
    double cols_ref[6 * EST_MODAL_COLS];
    double cov[EST_NZ * EST_NZ];
    double ring[];
} est_modal_work;

/* The work space of one update (sr_estimator_work_size bytes beside the Data block, never part
 * of the state): the sample's rows, the new state of its transaction and every temporary too
 * large for a small stack. Its contents between updates mean nothing. The noise rows follow
 * it (noise[], the model's work_noise doubles). */
typedef struct est_work {
    est_rows rows;
    est_core nw;                  /* the new state, committed when it came out finite */
    sr_info_data nwi;             /* the information filter's new state */
    sr_exd_work exd;              /* the information filter's and the excitation design's */
    double noise_rows[EST_NOISE_SCRATCH];
    double noise[];               /* the noise rows (est_rows.n_chunks chunks, or the modal
                                     window rows' win_chunks), then with
                                     ident.modes = 1 the modal columns' temporaries
                                     (est_modal_work, est_modal_work_of), then with the
                                     rigid band its (sr_band_work, est_band_work_of) */
} est_work;

/* the modal columns' temporaries in the work space w (after its noise rows) */
static inline est_modal_work *est_modal_work_of(const sr_estimator_model *m, est_work *w)
{
    return (est_modal_work *)(w->noise + m->work_noise);
}

/* a function kept out of its caller's frame (the compilers that can be told): the largest
 * temporaries of an update's stages are then never on the stack at once */
#if defined(__GNUC__)
#define EST_NOINLINE __attribute__((noinline))
#else
#define EST_NOINLINE
#endif

/* Python's max(a, b): b only where b > a (NaN in a is kept) */
static inline double est_pymax(double a, double b) { return b > a ? b : a; }

/* the information filter's state, its replay buffer and the excitation design's state in
 * the Data block (where the model has them) */
static inline sr_info_data *est_info_data(const sr_estimator_model *m, const void *data)
{
    return (sr_info_data *)((char *)data + m->off_info);
}
static inline double *est_info_buffer(const sr_estimator_model *m, const void *data)
{
    return (double *)((char *)data + m->off_info_buf);
}
static inline sr_exd_data *est_exd_data(const sr_estimator_model *m, const void *data)
{
    return (sr_exd_data *)((char *)data + m->off_exd);
}

#endif /* SR_EST_TYPES_H */
