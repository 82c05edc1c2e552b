/* Rigid-body dynamics of the free-floating robot: forward dynamics (articulated-body
 * algorithm), joint-space inertia (composite-rigid-body algorithm), non-linear effects
 * (recursive Newton-Euler) and the system momentum, for the robot of an sr_robot record (any
 * serial chain of 1..SR_MAX_JOINTS revolute joints on a free or planar base) carrying a
 * captured target rigidly attached at the end-effector frame E, and up to SR_DYN_MAX_LEAVES
 * leaves: bodies on one-degree-of-freedom joints of the base (revolute or prismatic; the
 * plant's flexible panels and slosh masses, their springs and dampers being generalised
 * forces the caller applies).
 *
 * Pinocchio's organisation: a constant model (sr_dyn_model, built once by sr_dyn_model_init),
 * a separate work space (sr_dyn_data, any contents; one per thread), free functions over both.
 * Both are plain structs of fixed size (no pointers, no allocation): copy them freely.
 *
 * Two views of the state.
 *
 * 1. Generalised coordinates, Pinocchio's (the plant's RK4 state):
 *    spatial (free-flyer root): q = [r_S (3), quaternion x y z w (4), q_arm (n), q_leaf (nl)],
 *                               v = [v_l (3), omega_B (3), qd (n), qd_leaf (nl)],
 *                               nq = 7 + n + nl, nv = 6 + n + nl;
 *    planar (planar root):      q = [x, y, cos th, sin th, q_arm, q_leaf],
 *                               v = [v_l,x, v_l,y, omega_z, qd, qd_leaf],
 *                               nq = 4 + n + nl, nv = 3 + n + nl;
 *    v_l = A^T v_S is the velocity of the base origin S in base axes, omega_B the base's angular
 *    velocity in base axes. The base's generalised force is [A^T F; A^T M_S] (planar: its
 *    x, y and z rows), F the total thrust applied at S and M_S its moment about S, both
 *    inertial. The acceleration ddq = dv/dt is the time derivative of these components
 *    (Pinocchio's spatial acceleration in the base frame: dv_l/dt = A^T a_S - omega_B x v_l),
 *    not the classical acceleration.
 *
 * 2. The physical state (the sensors' and the identification equations' quantities, equations.h):
 *    r_S (inertial), A (DCM base -> inertial, x_I = A x_B, row-major 3 x 3), v_S (inertial),
 *    omega_B (base frame), q_arm, qd; forces F, M_S (inertial, M_S about S), tau; accelerations
 *    a_S (inertial, classical: d v_S / dt), alpha_B (base frame, d omega_B / dt), qdd.
 *    A planar robot moves in the base x-y plane: only the rotation of A about z (c = A11,
 *    s = A21, normalised), v_S x, y, omega_B z, F x, y and M_S z act; a_S z = alpha_B x, y = 0.
 *
 * Momentum: P (linear) and L (angular, about the inertial origin) of the whole system,
 * inertial frame; hg = [P, L_c] with L_c about the system centre of mass (Pinocchio's data.hg).
 *
 * Matrices are row-major. Status codes: 0 ok; SR_DYN_EARG for a NULL pointer or a model not
 * initialised (n out of range); SR_DYN_EPD when the base's articulated inertia (or M) is not
 * positive definite (a NaN passes through, so that NaN propagates instead).
 */
#ifndef SR_DYNAMICS_H
#define SR_DYNAMICS_H

#include <stddef.h>

#include "arm.h"
#include "sr_api.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Most leaves (bodies on a one-degree-of-freedom joint of the base) a model may have. */
#define SR_DYN_MAX_LEAVES 8
/** Bodies of the model: the base (0), the links (1..n), the leaves (n + 1 .. n + nl). */
#define SR_DYN_MAX_BODIES (SR_MAX_JOINTS + 1 + SR_DYN_MAX_LEAVES)
/** Most coordinates after the base's (the arm's, then the leaves'). */
#define SR_DYN_MAX_COORDS (SR_MAX_JOINTS + SR_DYN_MAX_LEAVES)
/** Largest generalised velocity (6 + SR_DYN_MAX_COORDS). */
#define SR_DYN_MAX_NV (6 + SR_DYN_MAX_COORDS)

/** The joint of a leaf: a rotation about an axis fixed in the base, or a translation along
 *  one. */
#define SR_DYN_REVOLUTE 0
#define SR_DYN_PRISMATIC 1

#define SR_DYN_OK 0
#define SR_DYN_EARG 1       /* NULL pointer, model not initialised, invalid robot/target */
#define SR_DYN_EPD 2        /* not positive definite */

/** The constant model. Each link is described in its joint frame (the link frame turned so
 *  that the joint axis is z: its rotation is then Rz(q)); the base keeps its frame B. A leaf
 *  k = n + 1 + j is a body of its own whose parent is the base: revolute, in its joint frame
 *  (R[k] its axes in B, z the axis; p[k] a point of the axis); prismatic, in base axes at its
 *  centre of mass at rest p[k] (R[k] = Q[k] = identity), moving along axis[j]. */
typedef struct sr_dyn_model {
    int planar;                          /* 1: planar root (v_x, v_y, omega_z) */
    int n;                               /* joints, 1..SR_MAX_JOINTS */
    int nq, nv;                          /* generalised coordinates / velocities */
    int nl;                              /* leaves, 0..SR_DYN_MAX_LEAVES */
    int kind[SR_DYN_MAX_LEAVES];         /* SR_DYN_REVOLUTE or SR_DYN_PRISMATIC */
    double axis[SR_DYN_MAX_LEAVES][3];   /* unit joint axis of each leaf, base frame */
    double R[SR_DYN_MAX_BODIES][9];      /* joint k in its parent's joint frame at q = 0 (3 x 3):
                                            x_parent = R[k] Rz(q_k) x_k + p[k]; k = 0 identity */
    double p[SR_DYN_MAX_BODIES][3];      /* [m] */
    double m[SR_DYN_MAX_BODIES];         /* body masses [kg] (link n includes the target) */
    double h[SR_DYN_MAX_BODIES][3];      /* first moments m c about the joint origin [kg.m] */
    double J[SR_DYN_MAX_BODIES][6];      /* inertia about the joint origin [kg.m2], upper
                                            triangle xx xy xz yy yz zz, joint frame */
    double Q[SR_DYN_MAX_BODIES][9];      /* joint frame in the link's record frame (3 x 3):
                                            x_link = Q[k] x_joint; Q[0] identity */
} sr_dyn_model;

/** Work space of the algorithms (contents are scratch between calls); a leaf's entries are
 *  at the base origin S (bp = its joint origin). */
typedef struct sr_dyn_data {
    double bp[SR_DYN_MAX_BODIES][3];     /* joint origins in base axes [m] */
    double S[SR_DYN_MAX_BODIES][6];      /* joint motions [linear; angular], base axes */
    double cb[SR_DYN_MAX_BODIES][6];     /* velocity-product accelerations (ABA) */
    double g[SR_DYN_MAX_BODIES][3];      /* body first moments in base axes */
    double J[SR_DYN_MAX_BODIES][6];      /* body inertias in base axes (upper triangles) */
    double pA[SR_DYN_MAX_BODIES][6];     /* bias forces (ABA) / RNEA forces (terms) */
    double U[SR_DYN_MAX_BODIES][6];      /* IA S (ABA) / Ic S (CRBA) */
    double Du[SR_DYN_MAX_BODIES][2];     /* [1 / S^T IA S, tau - S^T pA] (ABA) */
} sr_dyn_data;

/** Build the model of robot (a record read by sr_robot_parse / sr_robot_read, or filled by the
 *  caller) carrying target: a body rigidly attached at the end-effector frame E (mass [kg],
 *  com [m] and inertia about it [kg.m2] in E's frame; NULL or mass 0: no target). Its inertia
 *  is added to the last link's, as Pinocchio's appendBodyToJoint does. Returns 0, or
 *  SR_DYN_EARG (model zeroed) for a NULL pointer, n out of 1..SR_MAX_JOINTS, planar not 0/1, a
 *  non-finite value, a mass <= 0 (target: < 0) or a zero joint axis. */
SR_API int sr_dyn_model_init(sr_dyn_model *model, const sr_robot *robot, const sr_body *target);

/** Add a leaf to the model: body (mass [kg] > 0, centre of mass [m] and inertia about it
 *  [kg.m2], in base axes at the leaf's coordinate 0) on a joint of the base of kind
 *  SR_DYN_REVOLUTE (a rotation by the leaf's coordinate [rad] about the unit vector along
 *  axis (3) through point (3) [m], base frame) or SR_DYN_PRISMATIC (a translation by it [m]
 *  along axis; point not read). Its coordinate and velocity follow the arm's and those of the
 *  leaves added before (nq, nv grow by one). Returns 0, or SR_DYN_EARG (model unchanged) for a
 *  NULL pointer, a model not initialised or with SR_DYN_MAX_LEAVES leaves, an unknown kind, a
 *  non-finite value, a mass <= 0 or a zero axis. */
SR_API int sr_dyn_add_leaf(sr_dyn_model *model, int kind, const double point[3],
                           const double axis[3], const sr_body *body);

/** Replace the base body (body 0) by the spatial inertia given at the base origin S in base
 *  axes: mass m [kg], first moment h_B = m b (3) [kg.m], inertia about S I_S (3 x 3, only the
 *  upper triangle read) [kg.m2] (e.g. the dry base plus its propellant: spatial inertias add).
 *  Returns 0, or SR_DYN_EARG (model unchanged) for a NULL pointer or a non-finite value or
 *  m <= 0. */
SR_API int sr_dyn_set_base_spatial(sr_dyn_model *model, double m, const double h_B[3],
                                   const double I_S[9]);

/** Replace the base body by base (mass, com and inertia about the com in frame B). */
SR_API int sr_dyn_set_base(sr_dyn_model *model, const sr_body *base);

/** sizeof(sr_dyn_model) and sizeof(sr_dyn_data), for bindings that allocate them. */
SR_API size_t sr_dyn_model_size(void);
SR_API size_t sr_dyn_data_size(void);

/* -- generalised coordinates (Pinocchio's) ------------------------------------------------ */

/** Forward dynamics ddq = M^-1 (tau - nle) by the articulated-body algorithm.
 *  q (nq), v (nv), tau (nv: base generalised force, then joint torques [N.m]), ddq (nv, out).
 *  Returns 0, SR_DYN_EARG, or SR_DYN_EPD (ddq then partly written). */
SR_API int sr_dyn_aba(const sr_dyn_model *model, sr_dyn_data *data, const double *q,
                      const double *v, const double *tau, double *ddq);

/** Joint-space inertia (CRBA), non-linear effects (RNEA at zero acceleration) and centroidal
 *  momentum, as Pinocchio's computeAllTerms: M (nv x nv, both triangles), nle (nv),
 *  hg (6) = [P, L_c] (inertial; L_c about the system centre of mass), com (3) the system centre
 *  of mass (inertial) [m]. Any output may be NULL (not computed). Returns 0 or SR_DYN_EARG. */
SR_API int sr_dyn_terms(const sr_dyn_model *model, sr_dyn_data *data, const double *q,
                        const double *v, double *M, double *nle, double *hg, double *com);

/* -- the same with the joint placements' sines and cosines supplied ------------------------ */

/** The sines and cosines of the coordinates after the base, q_arm (n + nl: the arm's joint
 *  angles [rad], then the leaves' coordinates): sc ((n + nl) x 2, row k = (sin q_k,
 *  cos q_k)), by sr_sincos (what sr_dyn_aba and sr_dyn_terms compute inside; a prismatic
 *  leaf's row is not used). Returns 0 or SR_DYN_EARG. */
SR_API int sr_dyn_arm_sincos(const sr_dyn_model *model, const double *q_arm, double *sc);

/** sr_dyn_aba with the sines and cosines of q's angles given by the caller, sc ((n + nl) x 2,
 *  as sr_dyn_arm_sincos; q's arm and revolute leaf angles are then not read; a prismatic
 *  leaf's coordinate is): for a caller that has them already
 *  (computed once for several algorithms at one configuration, or stepped from a nearby
 *  configuration's by the angle-addition formulas as the plant's RK4 stages do). With sc from
 *  sr_dyn_arm_sincos the result is sr_dyn_aba's, bit for bit. Returns as sr_dyn_aba. */
SR_API int sr_dyn_aba_sc(const sr_dyn_model *model, sr_dyn_data *data, const double *q,
                         const double *v, const double *tau, const double *sc, double *ddq);

/** sr_dyn_terms with the sines and cosines of q's angles given (sc ((n + nl) x 2), as
 *  sr_dyn_aba_sc). Returns as sr_dyn_terms. */
SR_API int sr_dyn_terms_sc(const sr_dyn_model *model, sr_dyn_data *data, const double *q,
                           const double *v, const double *sc, double *M, double *nle,
                           double *hg, double *com);

/* -- the physical state --------------------------------------------------------------------
 * For a model without leaves (one with leaves: SR_DYN_EARG). */

/** The generalised coordinates of a physical state: q (nq) and v (nv) from r_S (3), A (9),
 *  v_S (3), omega_B (3), q_arm (n), qd (n). The quaternion is A's (w >= 0, Shepperd's method);
 *  planar: (cos th, sin th) of A's z rotation, normalised. Returns 0 or SR_DYN_EARG. */
SR_API int sr_dyn_generalised(const sr_dyn_model *model, const double r_S[3], const double A[9],
                              const double v_S[3], const double omega_B[3],
                              const double *q_arm, const double *qd, double *q, double *v);

/** The generalised force gen (nv) = [A^T F; A^T M_S; tau] (planar: [(A^T F)_x, (A^T F)_y,
 *  M_S,z, tau]) of the thrust F (3) [N] at S and its moment M_S (3) [N.m] about S (both
 *  inertial) and the joint torques tau (n) [N.m]. Returns 0 or SR_DYN_EARG. */
SR_API int sr_dyn_generalised_force(const sr_dyn_model *model, const double A[9],
                                    const double F[3], const double M_S[3], const double *tau,
                                    double *gen);

/** Forward dynamics of the physical state: a_S (3, inertial) [m/s2], alpha_B (3, base frame)
 *  [rad/s2], qdd (n) [rad/s2] under the thrust F (3) at S, its moment M_S (3) about S (both
 *  inertial) and the joint torques tau (n). ABA as sr_dyn_aba; the base position does not
 *  enter (no gravity). Returns 0, SR_DYN_EARG or SR_DYN_EPD. */
SR_API int sr_dyn_forward(const sr_dyn_model *model, sr_dyn_data *data, const double A[9],
                          const double v_S[3], const double omega_B[3], const double *q_arm,
                          const double *qd, const double F[3], const double M_S[3],
                          const double *tau, double a_S[3], double alpha_B[3], double *qdd);

/** Joint-space inertia M (nv x nv) and bias forces h (nv) of the physical state, in the
 *  generalised velocity [A^T v_S, omega_B, qd] (planar: [(A^T v_S)_x, (A^T v_S)_y, omega_z,
 *  qd]): M dv/dt + h = sr_dyn_generalised_force(...). Either output may be NULL.
 *  Returns 0 or SR_DYN_EARG. */
SR_API int sr_dyn_mass_bias(const sr_dyn_model *model, sr_dyn_data *data, const double A[9],
                            const double v_S[3], const double omega_B[3], const double *q_arm,
                            const double *qd, double *M, double *h);

/** The system momentum of the physical state: P (3) [N.s] and L (3) about the inertial origin
 *  [N.m.s], inertial frame; com (3, may be NULL) the system centre of mass [m], inertial.
 *  Returns 0 or SR_DYN_EARG. */
SR_API int sr_dyn_momentum(const sr_dyn_model *model, sr_dyn_data *data, const double r_S[3],
                           const double A[9], const double v_S[3], const double omega_B[3],
                           const double *q_arm, const double *qd, double P[3], double L[3],
                           double *com);

#ifdef __cplusplus
}
#endif

#endif /* SR_DYNAMICS_H */
