/* The standard parameters of the two bodies and their map to the reported estimates.
 *
 * Per body (base, then target) the ten standard parameters z = [m, c = m b (3), I_O# (6)]
 * (Pinocchio's dynamic parameters: I_O the inertia about the body frame's origin, in the
 * paper's order I# = [I11, I12, I13, I22, I23, I33], eq. 21), in which both identification
 * equations are linear; the reported estimates x = [m, b (3), Ixx Iyy Izz Ixy Ixz Iyz] about
 * the centre of mass (spacerobot.interface.ESTIMATE_NAMES). The parallel-axis theorem links
 * them: I_O = I_c + m (|b|^2 1 - b b^T). Used by the joint solver and the information filter.
 */
#ifndef SR_STANDARD_PARAMS_H
#define SR_STANDARD_PARAMS_H

/* I = I#[SR_SHARP_TO_PROJECT] (ParameterLayout.sharp_to_project: the paper's order into the
 * reported Ixx Iyy Izz Ixy Ixz Iyz) */
extern const int SR_SHARP_TO_PROJECT[6];
/* index pairs (i, j) of the entries of I# (eq. 21) */
extern const int SR_SHARP_I[6], SR_SHARP_J[6];

/* z (20) of the reported x (20): m, c = m b, I_O = I_c + m (|b|^2 1 - b b^T) */
void sr_standard_of_reported(const double *x, double *z);

/* x (20) of z (20): b = c / m, I_c = I_O - m (|b|^2 1 - b b^T) */
void sr_reported_of_standard(const double *z, double *x);

/* d x / d z (20 x 20) at z: db/dc = 1 / m, db/dm = -c / m^2; with S(c) = |c|^2 1 - c c^T,
 * I_c = I_O - S(c) / m: dI_c/dI_O = 1, dI_c/dm = S / m^2,
 * dI_c,ij/dc_k = -(2 c_k d_ij - d_ik c_j - c_i d_jk) / m */
void sr_reported_jacobian(const double *z, double *J);

#endif /* SR_STANDARD_PARAMS_H */
