/* Physical consistency of an estimated rigid body and the projection onto real bodies (the
 * estimator's report; spacerobot.estimator.physical binds them).
 *
 * A body is (m [kg], b[3] [m] the centre-of-mass offset, I6[6] [kg.m2] the inertia about the
 * centre of mass, I6 = Ixx Iyy Izz Ixy Ixz Iyz). It is real iff m > 0 and
 * Sigma_c = tr(I_c)/2 * 1 - I_c (the second moment of the mass about the CoM) is positive
 * definite (the pseudo-inertia matrix is positive definite; Wensing et al., RA-L 2017).
 *
 * The estimate vector (20) is the base then the target, each m, b(3), I6(6) (positions of
 * spacerobot.interface.ParameterLayout: a body's entries start at 0 and 10).
 * Booleans in arrays are int (0 false, 1 true).
 */
#ifndef SR_PHYSICAL_H
#define SR_PHYSICAL_H

#include "sr_api.h"

/* smallest eigenvalue of Sigma_c kept by the projection, relative to the largest
 * |eigenvalue| (physical.REL_SIGMA_MIN) */
#define SR_REL_SIGMA_MIN 1e-6
/* smallest mass kept by the projection, relative to the caller's mass scale (the initial
 * guess of the body's mass): m_min = SR_REL_MASS_MIN * |m_scale| (physical.REL_MASS_MIN) */
#define SR_REL_MASS_MIN 1e-6
/* smallest scale of a centre-of-mass component's relative error [m]
 * (spacerobot.interface.COM_SCALE_MIN) */
#define SR_COM_SCALE_MIN 0.05
/* position of a body's mass in the estimate vector (20): base 0, target 10 */
#define SR_EST_BASE 0
#define SR_EST_TARGET 10

#ifdef __cplusplus
extern "C" {
#endif

/* Sigma_c = tr(I_c)/2 * 1 - I_c (S 3 x 3, row-major) from I6 (6) [kg.m2]. */
SR_API void sr_second_moment(const double *I6, double *S);

/* 1 iff (m, b (3), I6 (6)) is a real rigid body: every entry finite, m > 0, Sigma_c positive
 * definite (a Cholesky factorisation meeting no pivot <= 0; no tolerance: a body on the
 * boundary, e.g. a rod, is not accepted); else 0. */
SR_API int sr_is_physical(double m, const double *b, const double *I6);

/* physical (2): sr_is_physical of the base and of the target of the estimates ls (20). */
SR_API void sr_both_physical(const double *ls, int *physical);

/* scale (20): the scale of the relative error of each entry of vec (20)
 * (ParameterLayout.error_scale; NaN propagates as there): per body |m| (1 if 0),
 * max(|b_i|, com_min), |I_ii| (the body's largest |I_ii| if 0), and for the products of
 * inertia the largest |I_ii| (1 if that is not > 0). com_min [m], normally SR_COM_SCALE_MIN.
 * scale must not alias vec. */
SR_API void sr_error_scale(const double *vec, double com_min, double *scale);

/* ok_body (2): per body, every entry i it identifies (identified (20)) has sd[i] <= tol and
 * |out[i] - ls[i]| <= tol, tol = sd_rel * scale[i] (report_kernels.identified_bodies).
 * sd, out, ls, scale (20). */
SR_API void sr_identified_bodies(const double *sd, const double *out, const double *ls,
                                 const double *scale, double sd_rel, const int *identified,
                                 int *ok_body);

/* The flags of Identifier.report in one call where both bodies of the estimates ls (20) are
 * physical: flags (4) = sr_both_physical (flags[0..1]), then sr_identified_bodies of ls as it
 * is (out = ls, scale = sr_error_scale(ls, com_min); flags[2..3]). Returns 1 when done; 0 with
 * only flags[0..1] written where a body needs its projection (the caller then projects and
 * calls sr_error_scale / sr_identified_bodies itself). sd (20), identified (20). */
SR_API int sr_report_flags(const double *ls, const double *sd, double com_min, double sd_rel,
                           const int *identified, int *flags);

/* The nearest real body to (m, b (3), I6 (6)) in the (m, b, Sigma_c) coordinates
 * (physical.project_body): the mass clipped at m_min [kg] (SR_REL_MASS_MIN * |m_scale|), b kept,
 * the eigenvalues of Sigma_c clipped at rel_sigma_min (SR_REL_SIGMA_MIN) times the largest
 * |eigenvalue| (at least the smallest normal double), I_c = tr(S) 1 - S of the symmetrised
 * result. Writes *m_out, I6_out (6; may alias I6), *projected (0: the body is physical and is
 * returned unchanged, exactly; 1: projected).
 * Returns 0 ok, 1 the eigen-decomposition did not converge (non-finite I6: the outputs are
 * then written but not to be used; the caller decides). A non-finite m or b alone is not an
 * error (as in Python: a NaN m gives m_min, b is not used). */
SR_API int sr_project_body(double m, const double *b, const double *I6, double m_min,
                           double rel_sigma_min, double *m_out, double *I6_out, int *projected);

/* A real body with the identified entries of a planar estimate kept
 * (physical.project_planar_body): m (unless below m_min), b and Izz kept; the in-plane block
 * of Sigma_c gets its eigenvalues clipped at s_min with their sum (Izz) kept, Sigma_xz =
 * Sigma_yz = 0, Sigma_zz clipped at s_min (s_min as sr_project_body's). An Izz <= 2 s_min that
 * no real body keeps: sr_project_body. Arguments, outputs and status as sr_project_body. */
SR_API int sr_project_planar_body(double m, const double *b, const double *I6, double m_min,
                                  double rel_sigma_min, double *m_out, double *I6_out,
                                  int *projected);

#ifdef __cplusplus
}
#endif

#endif /* SR_PHYSICAL_H */
