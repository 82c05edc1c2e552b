/* Accelerations differenced from measured velocities:
 * the weights of a derivative at the centre of a window of 2m + 1 samples (a Savitzky-Golay
 * derivative for arbitrary sample times: the slope at the centre of the least-squares
 * quadratic through the samples; the 3-point central difference for uneven steps when m = 1),
 * the weights of the displacements integrated from velocities, and the centre sample with its
 * accelerations replaced by those derivatives.
 *
 * Times are in seconds, ascending (oldest first), distinct. No allocation: windows are bounded
 * by SR_DIFF_MAX_SAMPLES. Status: 0 ok; 1 bad arguments (k, centre or an index out of range,
 * nothing written); 2 the weights are not finite (times not distinct or not finite).
 */
#ifndef SR_DIFFERENCING_H
#define SR_DIFFERENCING_H

#include "sr_api.h"

/* largest half window m (samples each side of the centre) of the derivative weights */
#define SR_DIFF_MAX_HALF_WINDOW 50
/* largest window, 2 SR_DIFF_MAX_HALF_WINDOW + 1 samples */
#define SR_DIFF_MAX_SAMPLES (2 * SR_DIFF_MAX_HALF_WINDOW + 1)
/* largest half window of the displacement weights. They solve a Vandermonde system of the
 * window's 2 m + 1 nodes, whose condition grows tenfold per sample: against exact rational
 * arithmetic (even and jittered steps) the computed weights were off by 1e-15 relative at
 * m <= 4, 7e-9 at m = 10, 3e-7 at 12, 3e-4 at 15 and O(1) from 20 on; the exact weights
 * themselves grow (max |u| 0.67 at m = 1, 32 at m = 10, 3e3 at m = 14: velocity noise
 * amplified as much). Windows past m = 10 are refused: their digits run out within a few
 * samples more. */
#define SR_DIFF_MAX_DISPLACEMENT_HALF_WINDOW 10
#define SR_DIFF_MAX_DISPLACEMENT_SAMPLES (2 * SR_DIFF_MAX_DISPLACEMENT_HALF_WINDOW + 1)

#ifdef __cplusplus
extern "C" {
#endif

/* Weights w (k) [1/s] with sum_i w_i x(t_i) = the slope at t[centre] of the least-squares
 * quadratic through the samples (t_i, x(t_i)) (exact for quadratics;
 * differencing.derivative_weights). t (k) [s], 3 <= k <= SR_DIFF_MAX_SAMPLES,
 * 0 <= centre < k. k = 3, centre = 1: the central difference for uneven steps
 * h1 = t1 - t0, h2 = t2 - t1: w = (-h2 / (h1 (h1 + h2)), (h2 - h1) / (h1 h2), h1 / (h2 (h1 + h2))).
 * Otherwise, with tau = t - t[centre], s = max |tau|, the columns 1, tau/s, (tau/s)^2 of V:
 * w = row 1 of (V^T V)^-1 V^T, / s (the normal equations solved by sr_lu_solve). */
SR_API int sr_derivative_weights(const double *t, int k, int centre, double *w);

/* Weights u (k) [1] with sum_j u_j v(t_j) = sum_i w_i (x(t_i) - x(t[centre])) for v = dx/dt a
 * polynomial of degree k - 1 (differencing.displacement_weights): u = V^-T W^T w with
 * V[j][p] = (tau_j / s)^p, W[i][p] = s (tau_i / s)^(p+1) / (p + 1) (tau, s as above).
 * t (k) [s], w (k) [1/s], 3 <= k <= SR_DIFF_MAX_DISPLACEMENT_SAMPLES (status 1 beyond),
 * 0 <= centre < k; u must not alias w. Solved by LU with partial pivoting (sr_lu_solve, as
 * NumPy's np.linalg.solve; the k x k system on the stack, 3.5 kB at k = 21): the same numbers
 * to round-off times the condition number of the Vandermonde system (~1e4 at m = 5, ~1e9 at
 * m = 10; SR_DIFF_MAX_DISPLACEMENT_HALF_WINDOW). On a singular system u is all NaN
 * (status 2). */
SR_API int sr_displacement_weights(const double *t, int k, int centre, const double *w,
                                   double *u);

/* The centre sample of a window with its accelerations replaced by the derivatives of their
 * velocities at the centre's time:
 * t (k) [s] and X (k x n) the window's k = 2m + 1 flattened samples, oldest first;
 * out (n) = X[m] with out[acc[p]] = sum_i w_i X[i][vel[p]] for p < npairs (w from
 * sr_derivative_weights(t, k, m)); *t_c = t[m]. acc, vel (npairs) indices into a sample
 * (0 <= index < n). k odd, 3 <= k <= SR_DIFF_MAX_SAMPLES. out must not alias X. */
SR_API int sr_centre_derivative(const double *t, const double *X, int k, int n, const int *acc,
                                const int *vel, int npairs, double *out, double *t_c);

/* sr_centre_derivative with the window's samples given by their k row pointers X[i] (n values
 * each; e.g. the slots of a ring), and the weights w (k) out (may be NULL). */
SR_API int sr_centre_derivative_rows(const double *t, const double *const *X, int k, int n,
                                     const int *acc, const int *vel, int npairs, double *out,
                                     double *t_c, double *w);

#ifdef __cplusplus
}
#endif

#endif /* SR_DIFFERENCING_H */
