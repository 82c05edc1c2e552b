/* The identification equations of one sample.
 *
 * One sample gives, for the base (body 1) and the target held at the end-effector frame E
 * (body n), three rows of
 *   momentum form (eqs. 11/16):  B mu = J - P_arm,    Phi theta = H - L_arm - Psi D(mu);
 *   force form (eqs. 28/31, moments about the base sensor point S):
 *                                G mu = F - F_arm,    Q theta = M - M_arm,S - S D(mu),
 * with mu = [m1, m1 b1, mn, mn bn] (8), theta = [I1#, In#] (12, eq. 21) and D(mu) (20, eq. 23).
 * They are written into one row-major (3 x SR_N_COLS) array
 *   E = [A (8) | b | phi (12) | y | psi (20)],   A mu = b,   phi theta = y + psi D(mu),
 * with psi = -Psi (momentum) or -S (force); for the momentum form the identifier subtracts the
 * reference sample's E.
 *
 * Frames (DESIGN.md section 2): A is the base DCM body -> inertial (x_I = A x_B), omega_B and
 * alpha_B the base angular velocity and acceleration in the base frame, every other vector
 * inertial.
 */
#ifndef SR_EQUATIONS_H
#define SR_EQUATIONS_H

#include "arm.h"
#include "sample.h"
#include "sr_api.h"

#ifdef __cplusplus
extern "C" {
#endif

/* columns of the equation array E (3 x SR_N_COLS, row-major) */
#define SR_COL_A 0        /* A: 8 columns, mu = [m1, m1 b1, mn, mn bn] */
#define SR_COL_B 8        /* b */
#define SR_COL_PHI 9      /* phi: 12 columns, theta = [I1#, In#] */
#define SR_COL_Y 21       /* y */
#define SR_COL_PSI 22     /* psi: 20 columns, multiplies D(mu) */
#define SR_N_COLS 42

/* the flat sample x: sample.h (SR_X_*) */

/** The equations of one sample into E (3 x SR_N_COLS, row-major), see the top of this file.
 *  force: 1 force form (eqs. 28/31), 0 momentum form (eqs. 11/16); x: the flat sample
 *  (SR_X_LEN(robot->n)). Returns 0, or 1 (E untouched) for a NULL pointer or robot->n out of
 *  1..SR_MAX_JOINTS. No allocation; the inputs' finiteness is the caller's (sr_sample_check). */
SR_API int sr_equations(const sr_robot *robot, int force, const double *x, double *E);

/** D(mu) = [m1 J(b1); mn J(bn)] (20) from mu = [m1, m1 b1, mn, mn bn] (8), with
 *  J(b) = [1, b, bx^2, bx by, bx bz, by^2, by bz, bz^2] (eq. 23). */
SR_API void sr_D_of_mu(const double mu[8], double D[20]);

/** err = max |A^T A - 1| and det = det A of the DCM A (9, row-major). */
SR_API void sr_rotation_error(const double *A, double *err, double *det);

/** Check a flat sample x (len values): 0 if every entry is within [-limit, limit] (NaN is not)
 *  and its base DCM (x[SR_X_A_B..+9]) is a rotation (sr_rotation_error err <= tol, det > 0);
 *  1 for a value out of range or non-finite, 2 for a non-rotation, 3 for x NULL or
 *  len < SR_X_A_B + 9. */
SR_API int sr_sample_check(const double *x, int len, double limit, double tol);

/* -- the thrust's consider terms (est_consider.h, docs/identification.md section 6): a scale
 * factor error s and a misalignment phi (a small rotation), constant over a run, turn every
 * measured force and moment x into x + (s + [phi]x) x to first order. The
 * consider parameters c = [s_F, phi_F (3), s_M, phi_M (3)]; their sensitivities extend E by
 * SR_N_CCOLS right-hand-side columns per row, [d b / d c (8) | d y / d c (8)], which every
 * linear step on E (differencing, moving point, weights, planar selection) treats as the
 * right-hand sides b and y they perturb. */
#define SR_N_CONSIDER 8
#define SR_N_CCOLS (2 * SR_N_CONSIDER)
/* the thrust integrals K of the momentum form (consider.ThrustIntegrals): t [s], r_S (3) [m],
 * F (3) [N], M (3) [N.m] of the last sample (held until the next), then the integrals
 * k_s = int r_S x F dt (3) [N.m.s], k_phi = -int [r_S]x [F]x dt (3 x 3, row-major; column i
 * the angular impulse of e_i x F) [N.m.s], k_M = int M dt (3) [N.m.s] */
#define SR_THRUST_T 0
#define SR_THRUST_K 10          /* the 15 integrals k_s, k_phi, k_M start here */
#define SR_THRUST_NK 15
#define SR_THRUST_LEN 25

/** The thrust integrals K (SR_THRUST_LEN) with the sample of time t [s] (base position r_S
 *  (3), force F (3), moment M (3)): the previous sample's thrust integrated over t - t_prev
 *  (held: a rectangle rule, as the sensors model integrates its error), this sample's held
 *  from now on. first = 1 for the first sample (nothing integrated; K's integrals are kept,
 *  0 for a fresh K). In place. */
SR_API void sr_thrust_integrals_add(double *K, int first, double t, const double *r_S,
                                    const double *F, const double *M);

/** The right-hand sides' sensitivities to the consider parameters of one sample, out
 *  (3 x SR_N_CCOLS, row-major): columns 0..7 d b / d c, 8..15 d y / d c.
 *  force form (moments about S, where the thrust acts): db/ds_F = F, db/dphi_F = -[F]x,
 *  dy/ds_M = M, dy/dphi_M = -[M]x; momentum form (J = int F dt, H = int (M + r_S x F) dt):
 *  db/ds_F = J, db/dphi_F = -[J]x, dy/ds_F = k_s, dy/dphi_F = k_phi, dy/ds_M = k_M,
 *  dy/dphi_M = -[k_M]x. x: the flat sample (n joints: F, M, J from it); k: the 15 thrust
 *  integrals up to this sample (K + SR_THRUST_K; momentum form only, may be NULL for the
 *  force form). */
SR_API void sr_thrust_sensitivity(int force, const double *x, int n, const double *k,
                                  double *out);

#ifdef __cplusplus
}
#endif

#endif /* SR_EQUATIONS_H */
