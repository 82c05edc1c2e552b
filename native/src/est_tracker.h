/* The drift tracker (docs/identification.md section 7): how far the estimates lag behind
 * parameters that move (a mass changing as propellant is spent), added to their standard
 * deviations. After each sample (clock t = the sample count): the data's weight s0 and mean
 * age a_bar under the forgetting factor, a weighted forgetting line through each data-only
 * estimate (weights 1 / sd^2) whose slope is the estimate's rate, the age-weighted Gram
 * matrices (every old row one step older), and the lag: of one least-squares problem
 * A r = G^-1 M r with r = (1 - growth A)^-1 rate (eq. 2, where every line has a spread; the
 * solvers map it to the estimates), else rate a_bar / max(1 - da_bar/dt, 0.1) (eq. 1). The
 * total sd: sqrt(sd^2 + max(0, lag^2 - (g sd)^2)), the part of the lag beyond the estimate's
 * own scatter (g = max(a_bar / spread, 1)). A solver's step calls est_tracker_begin, its own
 * lag with the rates, then est_tracker_end. */
#ifndef SR_EST_TRACKER_H
#define SR_EST_TRACKER_H

#include "est_types.h"
#include "est_uncertainty.h"

/* the excitation diagnostics (of both blocks) above which est_block_lag_two_solves serves for
 * est_block_lag: measured on recorded runs (planar and spatial, both methods, the noise
 * options), no standard deviation moves by more than 1e-9 relative down to 1e-4; at 1e-6 the
 * first samples' (meaningless, ~1e20) ones do */
#ifndef EST_LAG_RCOND
#define EST_LAG_RCOND 1e-3
#endif

/* One sample's tracker, between est_tracker_begin and est_tracker_end. */
typedef struct est_tracker_step {
    double rate[EST_NZ];          /* the estimates' rates (the lines' slopes) [1 / sample] */
    double gain[EST_NZ];          /* max(a_bar / spread, 1) per line */
    int all_positive;             /* every line has a spread: the matrix lag (eq. 2) */
    double growth;                /* da_bar/dt / a_bar (0 unless all_positive) */
    double factor;                /* a_bar / max(1 - da_bar/dt, 0.1) (eq. 1) */
    double s0, s1, t_ref, t, a_bar;   /* the tracker's scalars after the sample */
} est_tracker_step;

/* The tracker with the sample of clock t: the lines through the data-only estimates x (20)
 * with weights 1 / sd^2 (sd (20), floored at the round-off of the step's estimates nw->vec,
 * which the step wrote before) into nw, the age-weighted Gram matrices stepped with old's
 * Gram matrices (the rows the lag reads), the rates and gains into *ts. */
void est_tracker_begin(const sr_estimator_model *m, const est_core *old, est_core *nw,
                       double t, const double *x, const double *sd, est_tracker_step *ts);

/* The total standard deviations into nw->sd from sd (20) and the solver's lag (20; NULL:
 * eq. 1's), and the tracker's scalars. */
void est_tracker_end(est_core *nw, const double *sd, const double *lag,
                     const est_tracker_step *ts);

/* (A r, r) of one least-squares problem (eq. 2): A = G^-1 M (information-weighted mean age),
 * r = (1 - growth A)^-1 rate; G, M (q x q) read from the leading blocks of n x n matrices,
 * rate (q). NaN where a matrix is singular. extra (q, may be NULL): replaced by G^-1 extra
 * (one more column of the same solve). */
void est_block_lag(const double *G_full, const double *M_full, int n, int q,
                   const double *rate, double growth, double *Ar, double *r_out, double *extra);

/* est_block_lag by two one-column solves, (G - growth M) r = G rate and A r = G^-1 (M r)
 * (G^-1 from eg where its Cholesky path holds it): the same numbers to round-off where both
 * information blocks are well conditioned (EST_LAG_RCOND), a third of the work. */
void est_block_lag_two_solves(const double *G_full, const double *M_full, int n, int q,
                              const double *rate, double growth, double *Ar, double *r_out,
                              double *extra, const est_eigs *eg);

/* x = A^-1 b for A (n x n, n <= EST_NZ; overwritten) and b (n; overwritten by x): LU with
 * partial pivoting that skips the operations with an exact zero (a sparse Jacobian's). All
 * NaN where a pivot column is 0. */
void est_sparse_lu_solve(double *A, int n, double *b);

#endif /* SR_EST_TRACKER_H */
