/* The modal columns (ident.modes = 1): the momentum of flexible parts on the base (panels,
 * slosh), to first order in their deformation, as extra unknowns of the momentum rows, so that
 * the reported rigid parameters are the composite body's despite the modes.
 *
 * A mode eta of a part on the base, at the (cantilevered) frequency w and damping zeta, obeys
 *   eta'' + 2 zeta w eta' + w^2 eta = -(l^T a_B + s^T omega2),   u = [a_B (6); omega2 (6)]
 * (a_B = [A^T a_S; alpha_B] the base's measured motion, omega2 the rate's products), and adds
 * to the momentum in base axes about S (four blocks of unknowns per frequency):
 *   G  l l^T eta'_a          21 (symmetric)      C  l s^T eta'_w       36
 *   D  [w]x d eta, -[v_B]x d eta    36            T  Omega(w) dI(eta)   72
 * eta, eta' the filter's response to each drive channel u_j (exact for an input linear between
 * samples), at rest at the momentum reference; over a momentum window each sample's columns
 * minus those of its window's reference (a ring of the filters' states). The unknowns [modal (165 per frequency) | rigid standard parameters (q)] are solved
 * by a square-root information filter (Givens rotations of each sample's rows into [R d]); the
 * rigid block is last, so its answer and covariance need only R's last q x q block.
 *
 * The frequencies: given (ident.mode_f, Hz) or found from the kept samples by variable
 * projection, at EST_MODAL_FIRST_SEARCH s after the reference and at each doubling of that
 * time, where the rows' relative residual exceeds EST_MODAL_FIT_FLOOR: the modes so far refined
 * (Nelder-Mead over (log w, log zeta), each with the others held), the found ones that lower
 * the residual by less than EST_MODAL_MIN_GAIN dropped (the given ones kept), then a scan of
 * EST_MODAL_GRID frequencies adding the best new mode (refined) while it lowers the residual by
 * EST_MODAL_MIN_GAIN (the search with the G and C blocks only, on at most
 * EST_MODAL_SCAN_SAMPLES kept samples); where the modes changed, every kept sample is solved
 * again with the new columns (est_modal.c has the constants).
 *
 * Errors in variables: with the sensors' noise profile the rows' position and velocities
 * (r_S, v_S, omega_B, qd) are noisy in both of a window row's samples, and that noise in the
 * regressors shrinks the least-squares answer (the wings at 0.3 Hz through the sensors: every
 * mass and inertia 0.9-6.8 % low on seeds 0-7). The rows' expected noise Gram matrix N_HH, N_Hy
 * (est_eiv.h, eq. 1, from est_rows' window noise rows) is summed beside [R d], and the rigid
 * answer compensated in the reduced (modal unknowns eliminated) normal equations,
 * (R_qq^T R_qq - N_HH) x_c = R_qq^T d_q - N_Hy (eq. 2), with its covariance K P K^T and the
 * residual variance at x_c. Left out: the noise the modal columns carry (the filters'
 * low-passed drive, and the sample's rates and position in the D and T blocks, correlated
 * with the rows' own), and the bilinear r x v terms' noise products, counted in both
 * channels' rows (second order). */
#ifndef SR_EST_MODAL_H
#define SR_EST_MODAL_H

#include "est_types.h"
#include "modal_filter.h"

/* the modal stage's state in the Data block (followed by R, d, the kept samples and, with the
 * momentum window, the window's ring: each entry a sample's index, signals and the filters'
 * states after it, from which the columns at a row's reference are formed again) */
typedef struct est_modal_data {
    int started;               /* the reference sample came: the filters start at rest */
    int n_f;                   /* frequencies in use */
    int kept;                  /* samples kept (at most EST_MODAL_MAX_SAMPLES) */
    int searches;              /* searches done */
    double t0, t_prev;         /* the reference's and the previous sample's times [s] */
    double u0[EST_MODAL_U];     /* the reference's drive (the filters start there) */
    double u_prev[EST_MODAL_U];
    int n_samp;                /* the newest sample's index (0: the reference) */
    int ring_count;            /* the momentum window's ring: entries (sample indices
                                  n_samp - ring_count + 1 .. n_samp), as the rows' ring */
    double sig0[EST_MODAL_SIG]; /* the reference's signals */
    double rss, rows;          /* the residual sum of squares and rows of the [R d] solve */
    double y2;                 /* sum of the squared right-hand sides (the relative residual) */
    double N[(EST_NZ + 1) * (EST_NZ + 1)];  /* the rows' expected noise Gram matrix of
                                                [H | yy] ((q + 1) x (q + 1), est_eiv.h) */
    est_modal_filter f[EST_MODAL_MAX_F];
} est_modal_data;

/* the doubles of a kept sample (its signals, identified rows [H | yy (| consider)], its momentum
 * window's reference's sample index, -1 without the window) */
int est_modal_slot(const sr_estimator_model *m);

/* bytes of the modal stage's state in the Data block (0 where ident.modes is off) */
size_t est_modal_size(const sr_estimator_model *m);

/* bytes of the modal stage's temporaries in the work space (0 where ident.modes is off) */
size_t est_modal_work_size(const sr_estimator_model *m);

/* the state at rest with the given frequencies (none: found later) */
void est_modal_init(const sr_estimator_model *m, void *data);

/* 0, or 1 where a count or number of the state is out of range (a corrupt block) */
int est_modal_check(const sr_estimator_model *m, const void *data);

/* The reference sample (its time t, flat sample x; the momentum window's first): the filters
 * start at rest there. */
void est_modal_reference(const sr_estimator_model *m, void *data, double t, const double *x);

/* The sample x at t with its rows rw (est_rows: the rigid rows E, 3 x 42; with the thrust's
 * consider term their consider columns Ec, 3 x 16; formed against the momentum window's entry
 * win_drop, its oldest samples the window drops, ignored without the window; the window
 * rows' noise rows, win_chunks chunks in noise) after the solver's step into nw: the filters'
 * step, the rows with the modal columns (differenced against the window's reference) into
 * [R d], their noise into N, the sample kept, the mode search where it is due; then nw's
 * estimates and sd from the modal solve (where they are finite). Writes the Data block
 * (after the solver's step succeeded). */
void est_modal_step(const sr_estimator_model *m, void *data, double t, const double *x,
                    const est_rows *rw, const double *noise, est_core *nw,
                    est_modal_work *w);

/* the frequency [Hz] and damping of mode k (0 .. n_f - 1) now: 1, or 0 if there is none */
int est_modal_mode(const sr_estimator_model *m, const void *data, int k, double *f,
                   double *zeta);

#endif /* SR_EST_MODAL_H */
