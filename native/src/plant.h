/* The plant: the free-floating space robot after capture, integrated by classic RK4 at the
 * internal step h, with the paper's controllers held over each internal step (zero-order hold)
 * (Zhang, Yue, Yuan, IEEE Access 2020):
 *
 *   - thrusters: the bounded momentum laws, eq. 41 on the linear momentum P and eq. 40 on the
 *     angular momentum about the system centre of mass L_c, per inertial axis;
 *   - arm: the attitude law eq. 39 (e'' + K_D e' + K_P e = 0 through the base rows of the
 *     dynamics) by an inertia-weighted, selectively damped right pseudo-inverse, a null-space
 *     posture term towards q_home and a bound qdd_max on the joint accelerations;
 *   - the optional excitation: eq. 39 about a multi-sine attitude reference and the posture
 *     term about a multi-sine joint reference, scaled by a level that ramps (quintic) to the
 *     requested value in excitation.ramp seconds;
 *   - the optional propellant: a spherical tank in the base emptied by the thrusters
 *     (dm_p/dt = -(|F_x|+|F_y|+|F_z| + (|M_x|+|M_y|+|M_z|)/arm) / (Isp g0)); the base's inertia
 *     follows m_p at every RK4 stage; the expelled propellant carries away momentum P_x, L_x;
 *   - the optional flexible parts (sr_plant_model_set_leaves; none by default): hinged panels
 *     (a revolute joint with a torsional spring and damper each) and propellant slosh modes
 *     (a point mass on a prismatic joint with a spring and damper each), leaves of the base in
 *     the rigid-body algorithms (dynamics.h), exact at any amplitude. The controllers are
 *     designed on the composite rigid body (base + panels at rest + slosh masses at their
 *     equilibrium): the arm's attitude law uses its model, the thrusters act on the system's
 *     momentum (docs/models.md, "Flexible appendages and slosh").
 *
 * Pinocchio's organisation: a constant model (sr_plant_model, built by sr_plant_model_init)
 * and a data block (sr_plant_data: the state and the work space). Both are plain structs of
 * fixed size without pointers: FMI get/set/serialize FMU state may memcpy the data block; a
 * checkpoint is a copy of it. Several data blocks may share one model. A step's temporaries
 * live in the data block's work space, so a step needs little stack.
 *
 * The tables below are the one source of the plant's layouts: the output vector
 * (SR_PLANT_OUTPUTS, after the sample's signals of sample.h) and the parameter structs with
 * their FMI names, units and ranges (SR_PLANT_CONTROLLER_FIELDS, ...). The FMU glue and the
 * Python bindings read them through the functions at the end (sr_plant_output_*,
 * sr_plant_field_*, sr_plant_param_*).
 *
 * State vector x (nx = 6 + nq + nv + 7):
 *   x = [J (3), H (3), q (nq), v (nv), m_p, P_x (3), L_x (3)]
 *   J [N.s]   impulse of the thrust, inertial          (dJ/dt = F)
 *   H [N.m.s] its angular impulse about the inertial origin (dH/dt = M_S + r_S x F)
 *   q, v      Pinocchio's generalised coordinates (dynamics.h): spatial
 *             q = [r_S (3) [m], quaternion x y z w (4), q_arm (n) [rad], q_leaf (nl)],
 *             v = [v_l (3) [m/s] (velocity of S in base axes), omega_B (3) [rad/s], qd (n),
 *             qd_leaf (nl)]; planar q = [x, y, cos th, sin th, q_arm, q_leaf],
 *             v = [v_l,x, v_l,y, omega_z, qd, qd_leaf]; the leaves: the panels' deflections
 *             [rad], then the slosh modes' strokes [m] (nl = n_flex + n_slosh, 0 by default)
 *   m_p [kg]  propellant left (0 without propellant model; with slosh modes it includes their
 *             masses, which the thrusters never draw: m_p >= their total)
 *   P_x [N.s], L_x [N.m.s]: momentum carried away by the expelled propellant (inertial; L_x
 *             about the inertial origin): P + P_x - P(0) = J, L + L_x - L(0) = H.
 *
 * Status codes: 0 ok; SR_PLANT_EARG (bad argument: nothing changed); SR_PLANT_ENONFINITE (the
 * step reached a non-finite state); SR_PLANT_ESINGULAR_* (a singular matrix on the way). Every
 * failing call leaves the state of the data (t, x, ramp) as it was before the call
 * (transactional; only the work space may change).
 *
 * All angles of the excitation are computed with sr_math's sr_sincos (portable bits): afresh at
 * the first internal step of a call and every SR_PLANT_TRIG_ANCHOR steps, rotated by h at the
 * steps in between (a few units in the last place from a fresh evaluation; a run gives the same
 * bits for the same sequence of calls). The sines and cosines of the joint angles (the joint
 * placements of the rigid-body algorithms) likewise: sr_sincos at the first internal step of a
 * call and every SR_PLANT_JOINT_ANCHOR steps, at every other RK4 stage from those by the
 * angle-addition formulas (within about 1 ulp of sr_sincos). The only libm calls are sqrt,
 * fabs, fmod and floor (exact).
 */
#ifndef SR_PLANT_H
#define SR_PLANT_H

#include <stddef.h>

#include "arm.h"
#include "body.h"
#include "dynamics.h"
#include "sample.h"
#include "sr_api.h"

#ifdef __cplusplus
extern "C" {
#endif

/* -- the output vector ------------------------------------------------------------------------
 * X(ID, key, fixed, per_joint, unit, description), as SR_SAMPLE_SIGNALS: the outputs after the
 * sample's signals (the output vector begins with a sample, sample.h), each fixed + per_joint n
 * values. The accelerations, F, M and tau are those of the controls held from this instant over
 * the next internal step of h (so sum F = sum m a holds exactly at every output). */
#define SR_PLANT_OUTPUTS(X)                                                                     \
    X(P, "P", 3, 0, "N.s", "system linear momentum, inertial (truth)")                            \
    X(L, "L", 3, 0, "N.m.s", "system angular momentum about the inertial origin, inertial "       \
                             "(truth; L_c + c x P)")                                              \
    X(TAU, "tau", 0, 1, "N.m", "joint torques")                                                   \
    X(EXCITE, "excite_level", 1, 0, "1", "excitation level in effect, in [0, 1]")                 \
    X(ATT_REF, "att_ref", 3, 0, "rad", "attitude reference (rotation vector); planar: (0, 0, "    \
                                       "z); zero when no excitation was asked for")               \
    X(QD_REF, "qd_ref", 0, 1, "rad/s", "rate of the joint reference (zero likewise)")             \
    X(M_P, "m_p", 1, 0, "kg", "propellant left")                                                  \
    X(P_X, "P_x", 3, 0, "N.s", "linear momentum carried away by the propellant, inertial")        \
    X(L_X, "L_x", 3, 0, "N.m.s", "angular momentum carried away by the propellant, about the "    \
                                 "inertial origin, inertial")                                     \
    X(BASE_NOW, "base_now", 10, 0, "kg, m, kg.m2", "the base's truth now: m, b (3) (com, base "   \
                  "frame), Ixx Iyy Izz Ixy Ixz Iyz (about the com, base frame): the dry base "    \
                  "plus the propellant left, plus the panels at rest and the slosh masses at "    \
                  "their equilibrium (the composite rigid base)")                                 \
    X(EXCITE_RATE, "excite_rate", 1, 0, "1", "excitation rate in effect (frequency multiplier)")  \
    X(FLEX_P, "flex_P", 3, 0, "N.s", "linear momentum of the flexible parts: the system's minus "  \
                "that of the composite rigid body at the same base and arm motion, inertial")     \
    X(FLEX_L, "flex_L", 3, 0, "N.m.s", "angular momentum of the flexible parts (likewise), about " \
                "the inertial origin, inertial")                                                  \
    X(FLEX_Q, "flex_q", SR_PLANT_MAX_FLEX, 0, "rad", "panel deflections (0 past flex.n)")         \
    X(FLEX_QD, "flex_qd", SR_PLANT_MAX_FLEX, 0, "rad/s", "panel deflection rates")                \
    X(SLOSH_X, "slosh_x", SR_PLANT_MAX_SLOSH, 0, "m", "slosh strokes (0 past slosh.n)")           \
    X(SLOSH_V, "slosh_v", SR_PLANT_MAX_SLOSH, 0, "m/s", "slosh stroke rates")

/** The outputs in the order of the output vector: the sample's signals (SR_PLANT_Y_R_S ...
 *  SR_PLANT_Y_H, in sample.h's order), then SR_PLANT_OUTPUTS. */
enum sr_plant_output {
#define SR_PLANT_Y_ENUM_(id, key, fixed, per_joint, unit, what) SR_PLANT_Y_##id,
#define SR_PLANT_Y_ENUM_S_(id, key, fmi, fixed, per_joint, unit, what) SR_PLANT_Y_##id,
    SR_SAMPLE_SIGNALS(SR_PLANT_Y_ENUM_S_)
    SR_PLANT_OUTPUTS(SR_PLANT_Y_ENUM_)
#undef SR_PLANT_Y_ENUM_
#undef SR_PLANT_Y_ENUM_S_
    SR_PLANT_Y_COUNT                    /* number of outputs */
};

/* the output vector's length for n joints: the sums over both tables */
#define SR_PLANT_Y_FIXED_(id, key, fixed, per_joint, unit, what) + (fixed)
#define SR_PLANT_Y_PER_JOINT_(id, key, fixed, per_joint, unit, what) + (per_joint)
#define SR_PLANT_Y_FIXED_S_(id, key, fmi, fixed, per_joint, unit, what) + (fixed)
#define SR_PLANT_Y_PER_JOINT_S_(id, key, fmi, fixed, per_joint, unit, what) + (per_joint)
#define SR_PLANT_NY(n)                                                                          \
    ((0 SR_SAMPLE_SIGNALS(SR_PLANT_Y_FIXED_S_) SR_PLANT_OUTPUTS(SR_PLANT_Y_FIXED_))             \
     + (n) * (0 SR_SAMPLE_SIGNALS(SR_PLANT_Y_PER_JOINT_S_)                                      \
              SR_PLANT_OUTPUTS(SR_PLANT_Y_PER_JOINT_)))

/** Most panels and slosh modes (the leaves of the rigid-body model, dynamics.h). */
#define SR_PLANT_MAX_FLEX 4
#define SR_PLANT_MAX_SLOSH 4
#define SR_PLANT_MAX_LEAVES (SR_PLANT_MAX_FLEX + SR_PLANT_MAX_SLOSH)
/** Largest configuration, velocity, state and output sizes (spatial, SR_MAX_JOINTS joints,
 *  SR_PLANT_MAX_LEAVES leaves). */
#define SR_PLANT_MAX_NQ (7 + SR_MAX_JOINTS + SR_PLANT_MAX_LEAVES)
#define SR_PLANT_MAX_NV SR_DYN_MAX_NV
#define SR_PLANT_MAX_NX (6 + SR_PLANT_MAX_NQ + SR_PLANT_MAX_NV + 7)
#define SR_PLANT_MAX_NY SR_PLANT_NY(SR_MAX_JOINTS)
/** Excitation channels: up to 3 attitude axes, then the joints. */
#define SR_PLANT_MAX_CHANNELS (3 + SR_MAX_JOINTS)
/** Internal steps between fresh evaluations of the excitation sines. */
#define SR_PLANT_TRIG_ANCHOR 20
/** Internal steps between fresh evaluations (sr_sincos) of the joint angles' sines and cosines
 *  (the joint placements); in between they are stepped from the last fresh ones by the
 *  angle-addition formulas (within about 1 ulp of sr_sincos, no accumulation). */
#define SR_PLANT_JOINT_ANCHOR 20
/** Length of the message buffers the callers pass (a longer one is fine). */
#define SR_PLANT_MSG_LEN 256

#define SR_PLANT_OK 0
#define SR_PLANT_EARG 1                 /* bad argument (named in the message) */
#define SR_PLANT_ENONFINITE 2           /* the state became non-finite */
#define SR_PLANT_ESINGULAR_BASE 11      /* singular base inertia */
#define SR_PLANT_ESINGULAR_ARM 12       /* singular arm inertia */
#define SR_PLANT_ESINGULAR_COUPLING 13  /* singular attitude coupling */
#define SR_PLANT_ESINGULAR_ABA 14       /* singular articulated base inertia */

/* -- the parameters ---------------------------------------------------------------------------
 * The ranges the core enforces (sr_plant_model_init; sr_plant_param_range reports them). */
#define SR_PLANT_GAIN_MAX 1e9           /* |controller parameter|: beyond, products overflow
                                           within a step */
#define SR_PLANT_H_MIN 1e-6             /* internal step h [s] */
#define SR_PLANT_H_MAX 1.0
#define SR_PLANT_V0_MAX 1e6             /* |base.v0[i]| [m/s] */
#define SR_PLANT_OMEGA0_MAX 1e3         /* |base.omega0[i]| [rad/s] */
/* the excitation rate's range (input ident.excite_rate) and the level's (input ident.excite) */
#define SR_PLANT_RATE_MIN 0.1
#define SR_PLANT_RATE_MAX 10.0
#define SR_PLANT_LEVEL_MIN 0.0
#define SR_PLANT_LEVEL_MAX 1.0
/* the flexible parts: frequencies [Hz], and the largest 2 pi f h of a panel or slosh mode in
 * use (RK4's stability limit is 2.8; the modes of the free spacecraft lie above the
 * cantilevered ones) */
#define SR_PLANT_FREQ_MIN 1e-3
#define SR_PLANT_FREQ_MAX 100.0
#define SR_PLANT_STEP_PHASE_MAX 0.25

/* X(field, dims, FMI name, unit, min, max, description): the fields of a parameter struct, in
 * the order of the FMU's variables. dims is empty for a number, [3] for a 3-vector (FMI names
 * <name>[1..3]); every field is a double (or 3). The panels' and slosh modes' structs are
 * records of which the FMU has SR_PLANT_MAX_FLEX (SR_PLANT_MAX_SLOSH): FMI names
 * <name>[i] for a number of record i, <name>[i,k] for element k of a 3-vector (1-based). */

/** Controller gains and bounds (spacerobot.robots.Controller; FMU names as the fields): eq. 41
 *  F_i = K_F P_i within |P_i| < P_max, bounded by F_max; eq. 40 M_i = K_M L_c,i within
 *  |L_c,i| < L_max, bounded by M_max; eq. 39 gains K_D, K_P; posture gains K_Dn, K_Pn. */
#define SR_PLANT_CONTROLLER_FIELDS(X)                                                           \
    X(F_max, , "F_max", "N", 0.0, SR_PLANT_GAIN_MAX, "Thruster force bound per axis (eq. 41)")    \
    X(K_F, , "K_F", "1/s", -SR_PLANT_GAIN_MAX, SR_PLANT_GAIN_MAX,                                 \
      "Linear momentum feedback gain F = K_F P (eq. 41)")                                         \
    X(P_max, , "P_max", "N.s", 0.0, SR_PLANT_GAIN_MAX,                                            \
      "Linear momentum band of the bounded law (eq. 41)")                                         \
    X(M_max, , "M_max", "N.m", 0.0, SR_PLANT_GAIN_MAX, "Thruster torque bound per axis (eq. 40)") \
    X(K_M, , "K_M", "1/s", -SR_PLANT_GAIN_MAX, SR_PLANT_GAIN_MAX,                                 \
      "Angular momentum feedback gain M = K_M L (eq. 40)")                                        \
    X(L_max, , "L_max", "N.m.s", 0.0, SR_PLANT_GAIN_MAX,                                          \
      "Angular momentum band of the bounded law (eq. 40)")                                        \
    X(K_D, , "K_D", "1/s", -SR_PLANT_GAIN_MAX, SR_PLANT_GAIN_MAX,                                 \
      "Base attitude law damping gain (eq. 39)")                                                  \
    X(K_P, , "K_P", "1/s2", -SR_PLANT_GAIN_MAX, SR_PLANT_GAIN_MAX,                                \
      "Base attitude law stiffness gain (eq. 39)")                                                \
    X(K_Dn, , "K_Dn", "1/s", -SR_PLANT_GAIN_MAX, SR_PLANT_GAIN_MAX,                               \
      "Arm null-space posture damping gain")                                                      \
    X(K_Pn, , "K_Pn", "1/s2", -SR_PLANT_GAIN_MAX, SR_PLANT_GAIN_MAX,                              \
      "Arm null-space posture stiffness gain")                                                    \
    X(qdd_max, , "qdd_max", "rad/s2", 0.0, SR_PLANT_GAIN_MAX,                                     \
      "Bound on commanded joint accelerations")

/** Excitation (spacerobot.robots.Excitation; FMU names excite.<field>). */
#define SR_PLANT_EXCITATION_FIELDS(X)                                                           \
    X(att_max, , "excite.att_max", "rad", 0.0, 3.141592653589793,                                 \
      "Amplitude bound of the base attitude excitation reference, per axis")                      \
    X(q_max, , "excite.q_max", "rad", 0.0, 6.283185307179586,                                     \
      "Amplitude bound of each joint excitation reference about the home posture")                \
    X(qd_max, , "excite.qd_max", "rad/s", 0.0, 1e3,                                               \
      "Bound on each joint excitation reference rate")                                            \
    X(qdd_max, , "excite.qdd_max", "rad/s2", 0.0, 1e6,                                            \
      "Bound on each joint excitation reference acceleration")                                    \
    X(period, , "excite.period", "s", 1e-3, 1e9,                                                  \
      "Period of the slowest excitation component (components in [1, 3] x 2 pi/period)")          \
    X(ramp, , "excite.ramp", "s", 1e-3, 1e9,                                                      \
      "Duration of a change of the excitation level (quintic ramp, no jump)")

/** Propellant (spacerobot.robots.Propellant; FMU names prop.<field>). */
#define SR_PLANT_PROPELLANT_FIELDS(X)                                                           \
    X(m0, , "prop.m0", "kg", 0.0, 1e9,                                                            \
      "Initial propellant mass (0 = no propellant model: constant base, unmodelled supply)")      \
    X(Isp, , "prop.Isp", "s", 1e-3, 1e9,                                                          \
      "Specific impulse of the thrusters (mass flow = thrust / (Isp g0))")                        \
    X(R, , "prop.R", "m", 0.0, 1e3,                                                               \
      "Radius of the spherical tank (the propellant is a rigid sphere of liquid, inertia "        \
      "(2/5) m R^2 about its centre; 0 = point mass)")                                            \
    X(arm, , "prop.arm", "m", 1e-6, 1e6,                                                          \
      "Distance between the two thrusters of a torque couple (a torque M_i about an inertial "    \
      "axis costs the thrust abs(M_i) / arm)")                                                    \
    X(r, [3], "prop.r", "m", -1e3, 1e3, "Centre of the propellant tank, base frame B (origin S)")

/** A hinged panel (a flexible appendage; FMU names flex.<field>[i]): a rigid body on a
 *  revolute joint of the base with a torsional spring and damper, k = I_h (2 pi f)^2,
 *  c = 2 zeta (2 pi f) I_h, I_h its inertia about the hinge axis. Geometry at rest (deflection
 *  0), base frame. */
#define SR_PLANT_FLEX_FIELDS(X)                                                                 \
    X(m, , "flex.m", "kg", SR_BODY_MASS_MIN, SR_BODY_MASS_MAX, "Panel mass")                      \
    X(com, [3], "flex.com", "m", -SR_BODY_COM_MAX, SR_BODY_COM_MAX,                               \
      "Panel centre of mass at rest (deflection 0), base frame B (origin S)")                     \
    X(Ixx, , "flex.Ixx", "kg.m2", SR_BODY_INERTIA_MIN, SR_BODY_INERTIA_MAX,                       \
      "Panel inertia tensor element Ixx about its centre of mass, base axes at rest")             \
    X(Iyy, , "flex.Iyy", "kg.m2", SR_BODY_INERTIA_MIN, SR_BODY_INERTIA_MAX,                       \
      "Panel inertia tensor element Iyy about its centre of mass, base axes at rest")             \
    X(Izz, , "flex.Izz", "kg.m2", SR_BODY_INERTIA_MIN, SR_BODY_INERTIA_MAX,                       \
      "Panel inertia tensor element Izz about its centre of mass, base axes at rest")             \
    X(Ixy, , "flex.Ixy", "kg.m2", -SR_BODY_PRODUCT_MAX, SR_BODY_PRODUCT_MAX,                      \
      "Panel inertia tensor element Ixy (minus the product of inertia), base axes at rest")       \
    X(Ixz, , "flex.Ixz", "kg.m2", -SR_BODY_PRODUCT_MAX, SR_BODY_PRODUCT_MAX,                      \
      "Panel inertia tensor element Ixz (minus the product of inertia), base axes at rest")       \
    X(Iyz, , "flex.Iyz", "kg.m2", -SR_BODY_PRODUCT_MAX, SR_BODY_PRODUCT_MAX,                      \
      "Panel inertia tensor element Iyz (minus the product of inertia), base axes at rest")       \
    X(hinge, [3], "flex.hinge", "m", -SR_BODY_COM_MAX, SR_BODY_COM_MAX,                           \
      "A point of the panel's hinge axis, base frame B")                                          \
    X(axis, [3], "flex.axis", "1", -1.0, 1.0,                                                     \
      "Direction of the hinge axis, base frame B (normalised; not zero; the deflection turns "    \
      "the panel about it by the right-hand rule; planar robots: along z)")                       \
    X(f, , "flex.f", "Hz", SR_PLANT_FREQ_MIN, SR_PLANT_FREQ_MAX,                                  \
      "Cantilevered frequency (base held): stiffness k = I_h (2 pi f)^2, I_h the panel's "        \
      "inertia about the hinge axis")                                                             \
    X(zeta, , "flex.zeta", "1", 0.0, 1.0,                                                         \
      "Damping ratio of the cantilevered mode: damping c = 2 zeta (2 pi f) I_h")                  \
    X(q0, , "flex.q0", "rad", -3.141592653589793, 3.141592653589793, "Initial deflection")        \
    X(qd0, , "flex.qd0", "rad/s", -SR_PLANT_OMEGA0_MAX, SR_PLANT_OMEGA0_MAX,                      \
      "Initial deflection rate")

/** A propellant slosh mode (FMU names slosh.<field>[i]): the spring-mass equivalent of one
 *  lateral mode, a point mass on a prismatic joint of the base with a spring and damper,
 *  k = m (2 pi f)^2, c = 2 zeta (2 pi f) m. With a propellant model (prop.m0 > 0) the slosh
 *  masses are part of the propellant. */
#define SR_PLANT_SLOSH_FIELDS(X)                                                                \
    X(m, , "slosh.m", "kg", SR_BODY_MASS_MIN, SR_BODY_MASS_MAX,                                   \
      "Slosh mass (with prop.m0 > 0 a part of the propellant, not an addition)")                  \
    X(r, [3], "slosh.r", "m", -SR_BODY_COM_MAX, SR_BODY_COM_MAX,                                  \
      "Equilibrium point of the slosh mass, base frame B")                                        \
    X(axis, [3], "slosh.axis", "1", -1.0, 1.0,                                                    \
      "Direction of its motion, base frame B (normalised; not zero; planar robots: in the "       \
      "x-y plane)")                                                                               \
    X(f, , "slosh.f", "Hz", SR_PLANT_FREQ_MIN, SR_PLANT_FREQ_MAX,                                 \
      "Frequency of the mode with the base held: stiffness k = m (2 pi f)^2")                    \
    X(zeta, , "slosh.zeta", "1", 0.0, 1.0, "Damping ratio of the mode: damping c = 2 zeta "       \
      "(2 pi f) m")                                                                               \
    X(x0, , "slosh.x0", "m", -SR_BODY_COM_MAX, SR_BODY_COM_MAX,                                   \
      "Initial stroke from the equilibrium point along the axis")                                 \
    X(v0, , "slosh.v0", "m/s", -SR_PLANT_V0_MAX, SR_PLANT_V0_MAX, "Initial stroke rate")

#define SR_PLANT_FIELD_(field, dims, fmi, unit, lo, hi, what) double field dims;
typedef struct sr_plant_controller {
    SR_PLANT_CONTROLLER_FIELDS(SR_PLANT_FIELD_)
} sr_plant_controller;

typedef struct sr_plant_excitation {
    SR_PLANT_EXCITATION_FIELDS(SR_PLANT_FIELD_)
} sr_plant_excitation;

typedef struct sr_plant_propellant {
    SR_PLANT_PROPELLANT_FIELDS(SR_PLANT_FIELD_)
} sr_plant_propellant;

typedef struct sr_plant_panel {
    SR_PLANT_FLEX_FIELDS(SR_PLANT_FIELD_)
} sr_plant_panel;

typedef struct sr_plant_slosh {
    SR_PLANT_SLOSH_FIELDS(SR_PLANT_FIELD_)
} sr_plant_slosh;
#undef SR_PLANT_FIELD_

/** The parameter structs, for sr_plant_field_* (the tables above). */
enum sr_plant_table {
    SR_PLANT_TABLE_CONTROLLER = 0, SR_PLANT_TABLE_EXCITATION, SR_PLANT_TABLE_PROPELLANT,
    SR_PLANT_TABLE_FLEX, SR_PLANT_TABLE_SLOSH, SR_PLANT_TABLE_COUNT
};

/* -- model and data ---------------------------------------------------------------------------- */

/** The constant model (filled by sr_plant_model_init; read-only afterwards). */
typedef struct sr_plant_model {
    sr_dyn_model dyn;                    /* robot + target on the dry base, with the leaves */
    sr_dyn_model rigid;                  /* the composite rigid body the controllers know: the
                                            robot + target on the dry base + the leaves at rest
                                            (used when nl > 0) */
    int planar, n, nq, nv, nb, nx, ny;   /* nb = 3 planar / 6 spatial */
    int nq0;                             /* the base's coordinates: 4 planar / 7 spatial */
    int n_flex, n_slosh, nl;             /* panels, slosh modes, leaves (their sum) */
    int n_att;                           /* attitude channels: 1 planar (z), 3 spatial */
    int n_ch;                            /* excitation channels n_att + n */
    int y_at[SR_PLANT_Y_COUNT + 1];      /* output k occupies y[y_at[k] .. y_at[k + 1]) */
    sr_plant_controller ctrl;            /* the controller */
    double q_home[SR_MAX_JOINTS];        /* null-space posture, also the initial one [rad] */
    double h;                            /* internal RK4 step [s] */
    sr_plant_excitation ex;              /* the excitation's bounds, period, ramp */
    double pp[6];                        /* propellant: 1/(Isp g0) [s/m] (0: model off),
                                            1/arm [1/m], (2/5) R^2 [m2], tank centre r (3) */
    double m0;                           /* initial propellant mass [kg] */
    double dry[10];                      /* dry base: m, b (3), Ixx Iyy Izz Ixy Ixz Iyz */
    double dry_hB[3], dry_IS[9];         /* dry base first moment m b and inertia about S */
    double k_leaf[SR_PLANT_MAX_LEAVES];  /* springs [N.m/rad or N/m] of the leaves */
    double c_leaf[SR_PLANT_MAX_LEAVES];  /* dampers [N.m.s/rad or N.s/m] */
    double rest_m, rest_hB[3], rest_IS[9];   /* the leaves at rest: mass, first moment and
                                            inertia about S (base axes) */
    double m_slosh;                      /* slosh mass that is part of the propellant [kg]
                                            (0 without propellant model) */
    double x0[SR_PLANT_MAX_NX];          /* initial state (sr_plant_start) */
} sr_plant_model;

/** The data block: the state (t, x, ramp) and the work space (scratch between calls). */
typedef struct sr_plant_data {
    double t;                            /* time [s] */
    double x[SR_PLANT_MAX_NX];           /* state vector (first nx entries) */
    double ramp[4];                      /* excitation level ramp [s0, u, t0, T]: from s0 at t0
                                            to the targeted u in T seconds */
    double ex_rate[3];                   /* [level requested, rate in effect, rate requested]
                                            (while the rates differ the ramp targets 0) */
    double ex_tab[SR_PLANT_MAX_CHANNELS][5];  /* channels at the rate in effect (a, w1, p1,
                                            w2, p2): f = a/2 [sin(w1 t + p1) + sin(w2 t + p2)] */
    double ex_rot[SR_PLANT_MAX_CHANNELS][4];  /* cos(w1 h), sin(w1 h), cos(w2 h), sin(w2 h):
                                            the channels' sines stepped by h by rotation */
    /* -- work space ------------------------------------------------------------------- */
    sr_dyn_model dyn;                    /* the model's dyn with the base of the current
                                            stage's propellant mass */
    sr_dyn_model rigid;                  /* the model's rigid likewise */
    sr_dyn_data dd;
    double K[4][SR_PLANT_MAX_NX];        /* RK4 stage derivatives */
    double xa[SR_PLANT_MAX_NX], xs[SR_PLANT_MAX_NX], xn[SR_PLANT_MAX_NX];
    double qn[SR_PLANT_MAX_NQ], vs[SR_PLANT_MAX_NV];   /* normalised stage configuration */
    double gen[SR_PLANT_MAX_NV], acc[SR_PLANT_MAX_NV], ddq[SR_PLANT_MAX_NV];
    double FM[7];                        /* held thrust [F, M] (inertial), mass flow [kg/s] */
    double M[SR_PLANT_MAX_NV * SR_PLANT_MAX_NV], nle[SR_PLANT_MAX_NV], hg[6], com[3];
    /* the composite rigid body's terms at the same base and arm state (nl > 0): M (nb + n
     * square), nle, hg, com */
    double Mr[(6 + SR_MAX_JOINTS) * (6 + SR_MAX_JOINTS)], nle_r[6 + SR_MAX_JOINTS], hg_r[6];
    double com_r[3];
    /* the controllers' solves of the free rows: the factor of M_uu, [X, y0] */
    double Luu[(6 + SR_PLANT_MAX_LEAVES) * (6 + SR_PLANT_MAX_LEAVES)];
    double sol_u[(6 + SR_PLANT_MAX_LEAVES) * (SR_MAX_JOINTS + 1)];
    double trig[SR_PLANT_MAX_CHANNELS][4];   /* sin, cos of both phases of every channel at
                                            trig_t (NaN: none) */
    double trig_t;
    double q_anc[SR_DYN_MAX_COORDS];     /* arm (and leaf) angles of the last anchor [rad] */
    double sc_anc[2 * SR_DYN_MAX_COORDS];    /* their sines and cosines ((n + nl) x 2) */
    double sc[2 * SR_DYN_MAX_COORDS];    /* those of the current RK4 stage ((n + nl) x 2) */
    double A_s[9];                       /* DCM of the RK4 stage state xs (3 x 3) */
} sr_plant_data;

/** Build the model. robot: the robot record (its base body is replaced by base); base: the
 *  dry base (frame B, origin S); target: the grasped target in the end-effector frame E; both
 *  as sr_body (mass [kg], com [m], inertia about the com (3 x 3) [kg.m2]), checked by body.h's
 *  sr_body_check (inertia symmetric, checked here). ctrl, ex, prop: within the ranges of
 *  their tables; q_home (n) [rad]: the home posture (robot.q0; NULL: zeros), also the initial
 *  arm posture; v0 (3): initial velocity of S, inertial [m/s]; w0 (3): initial omega_B, base
 *  frame [rad/s] (planar: only v0 x, y and w0 z are used); h: internal RK4 step [s].
 *  Returns 0, or SR_PLANT_EARG (model zeroed) with a one-line message in err (errlen bytes,
 *  NUL-terminated when errlen > 0; err may be NULL) naming the bad parameter by its FMU name
 *  and its range (e.g. "target.m", "F_max", "excite.ramp", "prop.Isp", "base.v0[2]", "h"). */
SR_API int sr_plant_model_init(sr_plant_model *model, const sr_robot *robot, const sr_body *base,
                               const sr_body *target, const sr_plant_controller *ctrl,
                               const sr_plant_excitation *ex, const sr_plant_propellant *prop,
                               const double *q_home, const double v0[3], const double w0[3],
                               double h, char *err, size_t errlen);

/** Add the flexible parts to a model sr_plant_model_init built (once, before sr_plant_start):
 *  n_flex panels (0..SR_PLANT_MAX_FLEX) and n_slosh slosh modes (0..SR_PLANT_MAX_SLOSH).
 *  flex: SR_PLANT_MAX_FLEX records, slosh: SR_PLANT_MAX_SLOSH records (either may be NULL
 *  when its count is 0): every record is checked against its table's ranges (the FMU has
 *  them all); the first n_flex (n_slosh) are the parts. A part in use must also be real (a
 *  panel's inertia by body.h's rule, an axis not zero), slow enough for the step
 *  (2 pi f h <= SR_PLANT_STEP_PHASE_MAX) and, on a planar robot, move in the plane (hinge
 *  axis along z, slosh axis in x-y); with a propellant model the slosh masses in use must not
 *  exceed prop.m0 (they are part of the propellant; the thrusters draw only the rest).
 *  Initial state: the deflections and strokes q0, x0 at rates qd0, v0. With n_flex = n_slosh
 *  = 0 the model is left as it was. Returns 0, or SR_PLANT_EARG (model zeroed) with a one-line
 *  message in err naming the parameter by its FMU name (e.g. "flex.f[2]", "slosh.m"). */
SR_API int sr_plant_model_set_leaves(sr_plant_model *model, int n_flex,
                                     const sr_plant_panel *flex, int n_slosh,
                                     const sr_plant_slosh *slosh, char *err, size_t errlen);

/** sizeof(sr_plant_model), sizeof(sr_plant_data), sizeof(the parameter structs), for
 *  bindings that allocate them. */
SR_API size_t sr_plant_model_size(void);
SR_API size_t sr_plant_data_size(void);
SR_API size_t sr_plant_controller_size(void);
SR_API size_t sr_plant_excitation_size(void);
SR_API size_t sr_plant_propellant_size(void);
SR_API size_t sr_plant_flex_size(void);
SR_API size_t sr_plant_slosh_size(void);

/** Sizes of the model: nq, nv, nx (state vector), ny (output vector), n (joints); any pointer
 *  may be NULL. Returns 0 or SR_PLANT_EARG (model NULL or not initialised). */
SR_API int sr_plant_dims(const sr_plant_model *model, int *nq, int *nv, int *nx, int *ny,
                         int *n);

/** SR_PLANT_Y_COUNT, the number of outputs. */
SR_API int sr_plant_output_count(void);

/** Where each output starts in the output vector: offsets (SR_PLANT_Y_COUNT + 1), entry k
 *  (enum sr_plant_output) occupies [offsets[k], offsets[k + 1]); offsets[SR_PLANT_Y_COUNT] =
 *  ny. Returns 0 or SR_PLANT_EARG. */
SR_API int sr_plant_output_offsets(const sr_plant_model *model, int *offsets);

/** The key of output k (enum sr_plant_output) as NativePlant.outputs() names it ("r_S", "v_S",
 *  "A", ..., "base_now"), its unit and description; NULL for k out of range. Static storage. */
SR_API const char *sr_plant_output_name(int k);
SR_API const char *sr_plant_output_unit(int k);
SR_API const char *sr_plant_output_description(int k);

/** The fields of parameter struct `table` (enum sr_plant_table), in their tables' order:
 *  their number (-1 for a table out of range); field i's C name ("F_max", "r"), FMI name
 *  ("F_max", "excite.ramp", "prop.r": a 3-vector's variables are prop.r[1..3]), unit and
 *  description (NULL out of range); its number of doubles (1 or 3) and its offset in the
 *  struct in bytes (-1 out of range); its range in *min, *max (0, or 1 out of range).
 *  sr_plant_table_records: how many records of the struct the FMU has (1; the panels'
 *  SR_PLANT_MAX_FLEX, the slosh modes' SR_PLANT_MAX_SLOSH: FMI names <name>[i], <name>[i,k]);
 *  -1 for a table out of range. */
SR_API int sr_plant_table_records(int table);
SR_API int sr_plant_field_count(int table);
SR_API const char *sr_plant_field_name(int table, int i);
SR_API const char *sr_plant_field_fmi_name(int table, int i);
SR_API const char *sr_plant_field_unit(int table, int i);
SR_API const char *sr_plant_field_description(int table, int i);
SR_API int sr_plant_field_size(int table, int i);
SR_API long sr_plant_field_offset(int table, int i);
SR_API int sr_plant_field_range(int table, int i, double *min, double *max);

/** The FMI name of the plant FMU's parameter or input number i (0, 1, ...), in the FMU's
 *  order: the bodies (base.m, base.b[1] ... base.Iyz, target.*), base.v0[1..3],
 *  base.omega0[1..3], the controller, h, the inputs ident.excite and ident.excite_rate, the
 *  excitation, the propellant, the panels (flex.n, then flex.m[1..4], flex.com[1,1] ...) and
 *  the slosh modes (slosh.n, slosh.m[1..4], ...); into name (size bytes, NUL-terminated; 64
 *  suffice). All are Real but the counts flex.n and slosh.n (Integer).
 *  Returns 0, or 1 past the last (name untouched). */
SR_API int sr_plant_param_name(int i, char *name, size_t size);

/** The closed range [*min, *max] the core enforces for the plant FMU's Real parameter or
 *  input fmi_name (sr_plant_param_name's names): the parameters' tables and constants above,
 *  body.h's ranges for the bodies (an inertia element: the bound the principal moments'
 *  range implies: a diagonal element within it, |a product| within half its width), the
 *  inputs' ranges (values outside are clipped). Returns 0, or 1 for an unknown name (min, max
 *  untouched). */
SR_API int sr_plant_param_range(const char *fmi_name, double *min, double *max);

/** A one-line description of a status code (static storage; never NULL). */
SR_API const char *sr_plant_status_message(int status);

/** The initial state: t = 0, base at the inertial origin with identity attitude, arm at
 *  q_home at rest, base velocity from v0, w0; J = H = 0; m_p = prop.m0, P_x = L_x = 0;
 *  excitation level 0 (ramp [0, 0, 0, excitation.ramp]). Returns 0 or SR_PLANT_EARG. */
SR_API int sr_plant_start(const sr_plant_model *model, sr_plant_data *data);

/** Ask for the excitation level `level` in [0, 1] from now on: the level in effect moves there
 *  from its current value in excitation.ramp seconds along a quintic (to 0 first while a
 *  change of rate is pending); asking again for the level already requested changes nothing.
 *  Returns 0, or SR_PLANT_EARG (data unchanged) for a level outside [0, 1] or NaN. */
SR_API int sr_plant_set_excitation(const sr_plant_model *model, sr_plant_data *data,
                                   double level);

/* doubles of the excitation state (sr_plant_get_state / set_state): the ramp [s0, u, t0, T],
 * the level requested, the rate in effect, the rate requested */
#define SR_PLANT_EXCITE_STATE 7

/** Ask for the excitation rate `rate` in [SR_PLANT_RATE_MIN, SR_PLANT_RATE_MAX]: every
 *  component at rate times its frequency (as if excite.period were period / rate), the joint
 *  amplitudes re-bounded for those frequencies by the rule of sr_plant_model_init, the
 *  attitude amplitude kept (its reference's rate grows with the rate). A new rate takes over
 *  without breaking a bound when asked for at a settled level: the level ramps to 0, the
 *  table changes at the first step boundary where the level has settled at 0 (at once where
 *  it is 0 already), and the level then ramps to the one requested; asking for the rate in
 *  effect cancels a pending change. (A request during a ramp restarts it from the level in
 *  effect with zero slope, as sr_plant_set_excitation does: the references' rates jump.)
 *  Returns 0, or SR_PLANT_EARG (data unchanged) for a rate out of range or NaN. */
SR_API int sr_plant_set_excitation_rate(const sr_plant_model *model, sr_plant_data *data,
                                        double rate);

/** The rate in effect and the rate requested: rate (2). Returns 0 or SR_PLANT_EARG. */
SR_API int sr_plant_excitation_rate(const sr_plant_model *model, const sr_plant_data *data,
                                    double *rate);

/** The excitation level in effect now and its first two time derivatives: s (3) =
 *  (s, ds/dt [1/s], d2s/dt2 [1/s2]). Returns 0 or SR_PLANT_EARG. */
SR_API int sr_plant_excitation_level(const sr_plant_model *model, const sr_plant_data *data,
                                     double *s);

/** Integrate over dt [s]: k = floor(dt / h + 1e-9) RK4 steps of h, then one step of the rest
 *  dt - k h if that is >= 1e-9 h; the controls of each step are computed at its start and held
 *  over it. A pending change of rate whose level has settled at 0 takes effect first
 *  (sr_plant_set_excitation_rate; it stays on failure). Transactional otherwise: returns 0
 *  with (t, x) advanced, or a status (SR_PLANT_EARG for dt not finite and > 0;
 *  SR_PLANT_ESINGULAR_*; SR_PLANT_ENONFINITE when the state reached is not finite) with t, x
 *  as before the call. */
SR_API int sr_plant_advance(const sr_plant_model *model, sr_plant_data *data, double dt);

/** Every output at the current state, y (ny; the tables above), computed with the controls
 *  held from this instant over a step of h. Only the work space of data changes. Returns 0,
 *  SR_PLANT_EARG, SR_PLANT_ESINGULAR_* or SR_PLANT_ENONFINITE (an output is not finite; y
 *  then not to be used). */
SR_API int sr_plant_outputs(const sr_plant_model *model, sr_plant_data *data, double *y);

/** The controls for the step starting at the current state: F (3) [N] at S and M (3) [N.m]
 *  about S, inertial; tau (n) [N.m]; a (nv): the generalised acceleration dv/dt they produce
 *  (Pinocchio's convention); *flow: propellant mass flow [kg/s]. Any output may be NULL.
 *  Returns 0, SR_PLANT_EARG, SR_PLANT_ESINGULAR_* or SR_PLANT_ENONFINITE. */
SR_API int sr_plant_controls(const sr_plant_model *model, sr_plant_data *data, double *F,
                             double *M, double *tau, double *a, double *flow);

/** The base's truth now: out (10) = m [kg], b (3) [m], Ixx Iyy Izz Ixy Ixz Iyz [kg.m2] (about
 *  the com, base frame): the dry base plus the propellant left (parallel axes); the dry base
 *  without propellant model; with flexible parts the composite rigid base (plus the panels at
 *  rest and the slosh masses at their equilibrium). Returns 0 or SR_PLANT_EARG. */
SR_API int sr_plant_base_now(const sr_plant_model *model, const sr_plant_data *data,
                             double *out);

/** The excitation references now: ref ((n_att + n) x 3, row-major), row c: the scaled channel
 *  c and its first two time derivatives; rows 0..n_att-1 the attitude axes (rotation vector
 *  [rad]; planar: z only), then the joint offsets from q_home [rad]. Zero when the level and
 *  its derivatives are zero. Returns 0 or SR_PLANT_EARG. */
SR_API int sr_plant_references(const sr_plant_model *model, const sr_plant_data *data,
                               double *ref);

/** The state: *t [s], x (nx), ex (SR_PLANT_EXCITE_STATE: the ramp [s0, u, t0, T], the level
 *  requested, the rate in effect, the rate requested) (any may be NULL). Returns 0 or
 *  SR_PLANT_EARG. */
SR_API int sr_plant_get_state(const sr_plant_model *model, const sr_plant_data *data, double *t,
                              double *x, double *ex);

/** Set the state: t finite, x (nx) finite with a unit quaternion (planar: a unit (cos, sin)
 *  pair) within 1e-6 and m_slosh <= m_p <= m0 (1 + 1e-12) (m_slosh: the slosh masses that are
 *  part of the propellant, else 0), ex (as sr_plant_get_state's) finite with
 *  T > 0, the levels s0, u, requested in [0, 1] and both rates in [SR_PLANT_RATE_MIN,
 *  SR_PLANT_RATE_MAX] (NULL: [0, 0, 0, excitation.ramp, 0, 1, 1]). Returns 0, or SR_PLANT_EARG
 *  (data unchanged) with a message in err (errlen bytes; err may be NULL). */
SR_API int sr_plant_set_state(const sr_plant_model *model, sr_plant_data *data, double t,
                              const double *x, const double *ex, char *err, size_t errlen);

#ifdef __cplusplus
}
#endif

#endif /* SR_PLANT_H */
