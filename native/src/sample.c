/* The sample's table (sample.h): its signals' keys, units, sizes and offsets. */
#include "sample.h"

#include <stddef.h>

static const struct {
    const char *key, *fmi, *unit, *what;
    int fixed, per_joint;
} SIGNALS[SR_SIG_COUNT] = {
#define SR_SAMPLE_ROW_(id, key, fmi, fixed, per_joint, unit, what)                              \
    {key, fmi, unit, what, fixed, per_joint},
    SR_SAMPLE_SIGNALS(SR_SAMPLE_ROW_)
#undef SR_SAMPLE_ROW_
};

int sr_sample_signal_count(void) { return SR_SIG_COUNT; }

const char *sr_sample_signal_key(int i) { return i >= 0 && i < SR_SIG_COUNT ? SIGNALS[i].key : NULL; }

const char *sr_sample_signal_fmi_name(int i)
{
    return i >= 0 && i < SR_SIG_COUNT ? SIGNALS[i].fmi : NULL;
}

const char *sr_sample_signal_unit(int i) { return i >= 0 && i < SR_SIG_COUNT ? SIGNALS[i].unit : NULL; }

const char *sr_sample_signal_description(int i)
{
    return i >= 0 && i < SR_SIG_COUNT ? SIGNALS[i].what : NULL;
}

int sr_sample_signal_size(int i, int n)
{
    if (i < 0 || i >= SR_SIG_COUNT)
        return -1;
    return SIGNALS[i].fixed + SIGNALS[i].per_joint * n;
}

int sr_sample_signal_offset(int i, int n)
{
    if (i < 0 || i >= SR_SIG_COUNT)
        return -1;
    int off = 0;
    for (int k = 0; k < i; k++)
        off += sr_sample_signal_size(k, n);
    return off;
}

int sr_sample_length(int n) { return SR_X_LEN(n); }

/* The SR_X_* offsets follow the table, checked at compile time: a struct with one member per
 * signal of (fixed + 1) doubles, and one of (per_joint + 1), give each signal's offset as
 * offsetof / sizeof(double) minus the signal's index (the + 1 of the members before it). */
struct fixed_ {
#define SR_SAMPLE_FIXED_(id, key, fmi, fixed, per_joint, unit, what) double id[(fixed) + 1];
    SR_SAMPLE_SIGNALS(SR_SAMPLE_FIXED_)
#undef SR_SAMPLE_FIXED_
};
struct per_joint_ {
#define SR_SAMPLE_PER_JOINT_(id, key, fmi, fixed, per_joint, unit, what)                       \
    double id[(per_joint) + 1];
    SR_SAMPLE_SIGNALS(SR_SAMPLE_PER_JOINT_)
#undef SR_SAMPLE_PER_JOINT_
};
#define OFF_(id, n) ((long)(offsetof(struct fixed_, id) / sizeof(double)) - SR_SIG_##id          \
                     + ((long)(offsetof(struct per_joint_, id) / sizeof(double)) - SR_SIG_##id) * (n))
#define CHECK_(name, expr) typedef char check_##name##_[(expr) ? 1 : -1]
#define CHECK_AT_(n, tag)                                                                       \
    CHECK_(tag, OFF_(R_S, n) == SR_X_R_S && OFF_(V_S, n) == SR_X_V_S && OFF_(A_B, n) == SR_X_A_B \
                && OFF_(OMEGA_B, n) == SR_X_OMEGA_B && OFF_(A_S, n) == SR_X_A_S                 \
                && OFF_(ALPHA_B, n) == SR_X_ALPHA_B && OFF_(Q, n) == SR_X_Q                     \
                && OFF_(QD, n) == SR_X_QD(n) && OFF_(QDD, n) == SR_X_QDD(n)                     \
                && OFF_(F, n) == SR_X_F(n) && OFF_(M, n) == SR_X_M(n) && OFF_(J, n) == SR_X_J(n) \
                && OFF_(H, n) == SR_X_H(n) && SR_X_H(n) + 3 == SR_X_LEN(n))
CHECK_AT_(0, zero_joints);
CHECK_AT_(1, one_joint);
CHECK_AT_(7, seven_joints);
