/* The sample: what the sensors measure of the free-floating robot at one instant, and what the
 * estimator takes. ONE table (SR_SAMPLE_SIGNALS) gives the signals, their order and sizes; the
 * flat sample's offsets (SR_X_*), the plant's output vector (whose first entries are a sample),
 * the FMUs' variable bindings and the Python bindings (through sr_sample_signal_*) all follow
 * from it.
 *
 * Frames (DESIGN.md section 2): A is the base DCM body -> inertial (x_I = A x_B, row-major),
 * omega_B and alpha_B are in the base frame, every other vector is inertial; S is the base's
 * sensor point (its frame origin).
 */
#ifndef SR_SAMPLE_H
#define SR_SAMPLE_H

#include "sr_api.h"

#ifdef __cplusplus
extern "C" {
#endif

/* X(ID, key, fmi, fixed, per_joint, unit, description): the signal has fixed + per_joint n values
 * (n joints); fmi: the FMU variables' name, indexed 1-based ("base.r[1]", "base.A[1,2]",
 * "arm.q[3]"; spacerobot.interface.measurement_vars). The order is the flat sample's. */
#define SR_SAMPLE_SIGNALS(X)                                                                    \
    X(R_S, "r_S", "base.r", 3, 0, "m", "position of the base point S, inertial")                  \
    X(V_S, "v_S", "base.v", 3, 0, "m/s", "velocity of S, inertial")                               \
    X(A_B, "A", "base.A", 9, 0, "1", "DCM base -> inertial, row-major")                           \
    X(OMEGA_B, "omega_B", "base.omega", 3, 0, "rad/s", "base angular velocity, base frame")       \
    X(A_S, "a_S", "base.a", 3, 0, "m/s2", "acceleration of S, inertial")                          \
    X(ALPHA_B, "alpha_B", "base.alpha", 3, 0, "rad/s2", "base angular acceleration, base frame")  \
    X(Q, "q", "arm.q", 0, 1, "rad", "joint angles")                                               \
    X(QD, "qd", "arm.qd", 0, 1, "rad/s", "joint rates")                                           \
    X(QDD, "qdd", "arm.qdd", 0, 1, "rad/s2", "joint accelerations")                               \
    X(F, "F", "thrust.F", 3, 0, "N", "thrust force applied at S, inertial")                       \
    X(M, "M", "thrust.M", 3, 0, "N.m", "thrust moment about S, inertial")                         \
    X(J, "J", "thrust.J", 3, 0, "N.s", "impulse of F since t = 0, inertial")                      \
    X(H, "H", "thrust.H", 3, 0, "N.m.s",                                                          \
      "angular impulse of the thrust about the inertial origin since t = 0")

/* the signals' indices: SR_SIG_R_S = 0, ... */
enum sr_sample_signal {
#define SR_SAMPLE_ENUM_(id, key, fmi, fixed, per_joint, unit, what) SR_SIG_##id,
    SR_SAMPLE_SIGNALS(SR_SAMPLE_ENUM_)
#undef SR_SAMPLE_ENUM_
    SR_SIG_COUNT
};

/* offsets in the flat sample of a robot with n joints (the table's order; sample.c checks them
 * against the table at compile time) */
#define SR_X_R_S 0
#define SR_X_V_S 3
#define SR_X_A_B 6
#define SR_X_OMEGA_B 15
#define SR_X_A_S 18
#define SR_X_ALPHA_B 21
#define SR_X_Q 24
#define SR_X_QD(n) (SR_X_Q + (n))
#define SR_X_QDD(n) (SR_X_Q + 2 * (n))
#define SR_X_F(n) (SR_X_Q + 3 * (n))
#define SR_X_M(n) (SR_X_Q + 3 * (n) + 3)
#define SR_X_J(n) (SR_X_Q + 3 * (n) + 6)
#define SR_X_H(n) (SR_X_Q + 3 * (n) + 9)
#define SR_X_LEN(n) (SR_X_Q + 3 * (n) + 12)

/* The physical range of every value of a sample in SI units: |x| <= SR_SAMPLE_LIMIT (beyond it
 * no quantity of a space robot lies, and products of two such values stay finite). */
#define SR_SAMPLE_LIMIT 1e15

/** Number of signals (SR_SIG_COUNT). */
SR_API int sr_sample_signal_count(void);
/** Signal i's key ("r_S", ...), its FMU variables' name ("base.r", ...), unit and description;
 *  NULL for i out of range. */
SR_API const char *sr_sample_signal_key(int i);
SR_API const char *sr_sample_signal_fmi_name(int i);
SR_API const char *sr_sample_signal_unit(int i);
SR_API const char *sr_sample_signal_description(int i);
/** Signal i's number of values for a robot of n joints (3, 9 or n); -1 for i out of range. */
SR_API int sr_sample_signal_size(int i, int n);
/** Signal i's offset in the flat sample of a robot of n joints; -1 for i out of range. */
SR_API int sr_sample_signal_offset(int i, int n);
/** Length of the flat sample of a robot with n joints: 24 + 3 n + 12. */
SR_API int sr_sample_length(int n);

#ifdef __cplusplus
}
#endif

#endif /* SR_SAMPLE_H */
