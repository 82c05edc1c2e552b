/* The estimator's options (estimator.h, est_options.h): ONE table of every option, by the name of
 * the estimator FMU's parameter that sets it, from which come the defaults, the setting by
 * name, the accepted ranges and the checks with their messages; and the rules between options. */
#include "est_options.h"

#include <float.h>
#include <limits.h>
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "body.h"
#include "differencing.h"
#include "excite_design.h"
#include "sample.h"
#include "sr_text.h"

/* the closed bounds of "> 0", "< 1" and "finite" */
#define POSITIVE 0x1p-1074                 /* the smallest positive double */
#define BELOW_ONE 0x1.fffffffffffffp-1     /* the largest double below 1 */
#define FINITE DBL_MAX

/* what a value's message says (rule: the text, {n} the option's name, {a} {b} its bounds as
 * %g, {A} {B} the same without the exponent's sign and zeros, "1e6"):
 *   CODE   "<name> = <v> is not one of <rule>"
 *   RULE   "<rule>, got <v>" (an Integer option's v as an integer)
 *   REPR   "<rule>, got <v>" (v as a Real's, "2.0")
 *   COVAR  "<name> must be a finite covariance > 0, got <v>" when v is not, else the RULE */
enum { CODE, RULE, REPR, COVAR };
/* how a value is checked: its range always (the other method's row weights too); a profile
 * magnitude also scaled by noise.scale with ident.noise_profile = 1; a guess as a body
 * (sr_body_check of the guess it belongs to) */
enum { ALWAYS, PROFILE, BODY };

/* The options: X(name, field, index, integer, min, max, default, not_one, parameter, when,
 * style, rule). not_one: 1 also refuses the value 1 inside the range; parameter: 1 an
 * estimator FMU parameter sets it. The order is the checks' and the FMU parameters'. */
#define EST_OPTIONS(X)                                                                         \
    X("method", method, 0, 1, 1, 2, 1, 0, 1, ALWAYS, CODE, "1 (momentum), 2 (force)")           \
    X("solver", solver, 0, 1, 1, 2, 1, 0, 1, ALWAYS, CODE, "1 (paper), 2 (joint)")              \
    X("accel_source", accel_source, 0, 1, 1, 2, 1, 0, 1, ALWAYS, CODE,                          \
      "1 (measured), 2 (differenced)")                                                          \
    X("lambda", lambda, 0, 0, POSITIVE, 1.0, 1.0, 0, 1, ALWAYS, RULE,                           \
      "forgetting factor lambda must satisfy 0 < lambda <= 1")                                  \
    X("P0_mu", P0_mu, 0, 0, SR_EST_P0_MIN, SR_EST_P0_MAX, 1e6, 0, 1, ALWAYS, COVAR,              \
      "{n} must be a covariance within [{a}, {b}] (SI units)")                      \
    X("P0_theta", P0_theta, 0, 0, SR_EST_P0_MIN, SR_EST_P0_MAX, 1e6, 0, 1, ALWAYS, COVAR,        \
      "{n} must be a covariance within [{a}, {b}] (SI units)")                      \
    BODY_OPTIONS(X, "guess.base.", guess_base, 600.0, 0.0, 0.0, 0.0, 100.0, 100.0, 100.0)       \
    BODY_OPTIONS(X, "guess.target.", guess_target, 100.0, 0.1, 0.1, 0.1, 10.0, 10.0, 10.0)      \
    X("ident.sd_rel", sd_rel, 0, 0, POSITIVE, BELOW_ONE, 1e-3, 0, 1, ALWAYS, RULE,              \
      "relative standard deviation threshold ident.sd_rel must satisfy 0 < sd_rel < 1")         \
    X("ident.flag_confidence", flag_confidence, 0, 0, SR_EST_FLAG_CONFIDENCE_MIN,               \
      SR_EST_FLAG_CONFIDENCE_MAX, 0.99, 0, 1, ALWAYS, RULE,                                      \
      "{n} must be a probability from {a} to {b}")                                              \
    X("ident.excite_mode", excite_mode, 0, 1, 0, 2, 1, 0, 1, ALWAYS, CODE,                      \
      "0 (off), 1 (until_identified), 2 (always)")                                              \
    X("ident.excite_level", excite_level, 0, 0, 0.0, 1.0, 1.0, 0, 1, ALWAYS, RULE,              \
      "{n} must be in [{a}, {b}]")                                                              \
    X("ident.sd_row.momentum_lin", row_sd, 0, 0, 0.0, FINITE, 0.0, 0, 1, ALWAYS, RULE,          \
      "{n} must be a finite number >= 0 (0 = unit weight)")                                     \
    X("ident.sd_row.momentum_ang", row_sd, 1, 0, 0.0, FINITE, 0.0, 0, 1, ALWAYS, RULE,          \
      "{n} must be a finite number >= 0 (0 = unit weight)")                                     \
    X("ident.sd_row.force_lin", row_sd, 2, 0, 0.0, FINITE, 0.0, 0, 1, ALWAYS, RULE,             \
      "{n} must be a finite number >= 0 (0 = unit weight)")                                     \
    X("ident.sd_row.force_ang", row_sd, 3, 0, 0.0, FINITE, 0.0, 0, 1, ALWAYS, RULE,             \
      "{n} must be a finite number >= 0 (0 = unit weight)")                                     \
    X("ident.diff_half_window", diff_half_window, 0, 1, 1, SR_EST_MAX_HALF_WINDOW, 1, 0, 1,     \
      ALWAYS, RULE, "{n} must be an integer from {a} to {b}")                                   \
    X("ident.diff_momentum", diff_momentum, 0, 1, 0, 2, 0, 0, 1, ALWAYS, CODE,                  \
      "0 (automatic), 1 (on), 2 (off)")                                                         \
    X("ident.corr_lags", corr_lags, 0, 1, 0, SR_EST_MAX_CORR_LAGS, 0, 0, 1, ALWAYS, RULE,       \
      "{n} must be an integer from {a} to {b}")                                                 \
    X("ident.momentum_window", momentum_window, 0, 0, 0.0, SR_EST_MAX_WINDOW, 0.0, 0, 1,        \
      ALWAYS, RULE, "{n} must be a number of seconds from {a} to {b}")                          \
    X("ident.momentum_point", momentum_point, 0, 1, 0, 1, 0, 0, 1, ALWAYS, RULE,                \
      "{n} must be 0 or 1")                                                                     \
    X("ident.accel_bias", accel_bias, 0, 1, 0, 1, 0, 0, 1, ALWAYS, RULE, "{n} must be 0 or 1")  \
    X("ident.sd_thrust.scale", sd_thrust_scale, 0, 0, 0.0, SR_EST_MAX_THRUST_SD, 0.0, 0, 1,     \
      ALWAYS, RULE, "{n} must be a number from {a} to {b}")                                     \
    X("ident.sd_thrust.misalign", sd_thrust_misalign, 0, 0, 0.0, SR_EST_MAX_THRUST_SD, 0.0, 0,  \
      1, ALWAYS, RULE, "{n} must be a number from {a} to {b}")                                  \
    X("ident.noise.base.a", signal_sd, 0, 0, 0.0, FINITE, 0.0, 0, 1, ALWAYS, RULE,              \
      "{n} (signal_sd['a_S']) must be a finite number >= 0")                                    \
    X("ident.noise.base.alpha", signal_sd, 1, 0, 0.0, FINITE, 0.0, 0, 1, ALWAYS, RULE,          \
      "{n} (signal_sd['alpha_B']) must be a finite number >= 0")                                \
    X("ident.noise.arm.qdd", signal_sd, 2, 0, 0.0, FINITE, 0.0, 0, 1, ALWAYS, RULE,             \
      "{n} (signal_sd['qdd']) must be a finite number >= 0")                                    \
    X("ident.noise.base.v", signal_sd, 3, 0, 0.0, FINITE, 0.0, 0, 1, ALWAYS, RULE,              \
      "{n} (signal_sd['v_S']) must be a finite number >= 0")                                    \
    X("ident.noise.base.omega", signal_sd, 4, 0, 0.0, FINITE, 0.0, 0, 1, ALWAYS, RULE,          \
      "{n} (signal_sd['omega_B']) must be a finite number >= 0")                                \
    X("ident.noise.arm.qd", signal_sd, 5, 0, 0.0, FINITE, 0.0, 0, 1, ALWAYS, RULE,              \
      "{n} (signal_sd['qd']) must be a finite number >= 0")                                     \
    X("ident.noise_profile", noise_profile, 0, 1, 0, 1, 0, 0, 1, ALWAYS, REPR,                  \
      "{n} must be 0 (none) or 1 (sensors)")                                                   \
    X("ident.information", information, 0, 1, 0, 2, 0, 0, 1, ALWAYS, CODE,                      \
      "0 (automatic), 1 (on), 2 (off)")                                                         \
    X("ident.excite_adapt", excite_adapt, 0, 1, 0, 2, 0, 0, 1, ALWAYS, CODE,                    \
      "0 (automatic), 1 (on), 2 (off)")                                                         \
    X("ident.excite_rate_try", excite_rate_try, 0, 0, SR_EXD_RATE_MIN, SR_EXD_RATE_MAX, 4.0, 1, \
      1, ALWAYS, RULE, "{n} must be in [{a}, {b}] and not 1")                                   \
    X("ident.excite_window", excite_window, 0, 0, POSITIVE, SR_EXD_TIME_MAX, 30.0, 0, 1,        \
      ALWAYS, RULE, "{n} must be > 0 s and <= {B} s")                                           \
    X("ident.excite_settle", excite_settle, 0, 0, 0.0, SR_EXD_TIME_MAX, 20.0, 0, 1, ALWAYS,     \
      RULE, "{n} must be >= 0 s and <= {B} s")                                                  \
    X("ident.excite_horizon", excite_horizon, 0, 0, POSITIVE, SR_EXD_TIME_MAX, 300.0, 0, 1,     \
      ALWAYS, RULE, "{n} must be > 0 s and <= {B} s")                                           \
    X("ident.modes", modes, 0, 1, 1, 2, 2, 0, 1, ALWAYS, CODE, "1 (on), 2 (off)")               \
    MODE_F(X, "ident.mode_f[1]", 0) MODE_F(X, "ident.mode_f[2]", 1)                            \
    MODE_F(X, "ident.mode_f[3]", 2) MODE_F(X, "ident.mode_f[4]", 3)                            \
    X("ident.band", band, 0, 1, 0, 2, 0, 0, 1, ALWAYS, CODE,                                    \
      "0 (automatic), 1 (on), 2 (off)")                                                         \
    X("ident.fit_window", fit_window, 0, 0, POSITIVE, SR_EXD_TIME_MAX, 60.0, 0, 1, ALWAYS,      \
      RULE, "{n} must be > 0 s and <= {B} s")                                                   \
    X("ident.fit_lags", fit_lags, 0, 1, 1, SR_INFO_MAX_LAGS, 50, 0, 1, ALWAYS, RULE,            \
      "{n} must be an integer from {a} to {b}")                                                 \
    X("ident.fit_rho_max", fit_rho_max, 0, 0, POSITIVE, 1.0, 1e-2, 0, 1, ALWAYS, RULE,          \
      "{n} must be in (0, {b}]")                                                                \
    X("ident.fit_whiteness_max", fit_whiteness_max, 0, 0, 1.0, 1e6, 30.0, 0, 1, ALWAYS, RULE,   \
      "{n} must be in [{a}, {B}]")                                                              \
    X("ident.fit_chi2_max", fit_chi2_max, 0, 0, 1.0, 1e6, 2.0, 0, 1, ALWAYS, RULE,              \
      "{n} must be in [{a}, {B}]")                                                              \
    X("ident.fit_thrust_max", fit_thrust_max, 0, 0, 1.0, 1e6, 3.0, 0, 1, ALWAYS, RULE,          \
      "{n} must be in [{a}, {B}]")                                                              \
    X("ident.fit_bias_k", fit_bias_k, 0, 0, 0.0, 100.0, 0.5, 0, 1, ALWAYS, RULE,                \
      "{n} must be in [{a}, {b}]")                                                              \
    X("ident.fit_bias_k_info", fit_bias_k_info, 0, 0, 0.0, 100.0, 0.25, 0, 1, ALWAYS, RULE,     \
      "{n} must be in [{a}, {b}]")                                                              \
    X("ident.eiv_uncertainty", eiv_uncertainty, 0, 0, 0.0, 1.0, 0.05, 0, 1, ALWAYS, RULE,       \
      "{n} must be in [{a}, {b}]")                                                              \
    X("noise.scale", noise_scale, 0, 0, 0.0, SR_NOISE_PROFILE_MAX, 1.0, 0, 1, PROFILE, RULE,    \
      "{n} must be a finite number in [{a}, {B}]")                                              \
    PROFILE_MAGNITUDE(X, SR_NOISE_GYRO_ARW)                                                     \
    PROFILE_MAGNITUDE(X, SR_NOISE_NAV_V)                                                        \
    PROFILE_MAGNITUDE(X, SR_NOISE_ACCEL_VRW)                                                    \
    PROFILE_MAGNITUDE(X, SR_NOISE_ALPHA)                                                        \
    PROFILE_MAGNITUDE(X, SR_NOISE_ENC_QD)                                                       \
    PROFILE_MAGNITUDE(X, SR_NOISE_ENC_QDD)                                                      \
    PROFILE_MAGNITUDE(X, SR_NOISE_THRUST_SCALE)                                                 \
    PROFILE_MAGNITUDE(X, SR_NOISE_THRUST_MISALIGN)                                              \
    PROFILE_MAGNITUDE(X, SR_NOISE_NAV_R)                                                        \
    PROFILE_MAGNITUDE(X, SR_NOISE_STAR_CROSS)                                                   \
    PROFILE_MAGNITUDE(X, SR_NOISE_STAR_ROLL)                                                    \
    PROFILE_MAGNITUDE(X, SR_NOISE_ENC_Q)                                                        \
    PROFILE_MAGNITUDE(X, SR_NOISE_ENC_RESOLUTION)                                               \
    PROFILE_MAGNITUDE(X, SR_NOISE_GYRO_BIAS)                                                    \
    X("noise_dt", noise_dt, 0, 0, POSITIVE, SR_NOISE_PROFILE_MAX, 0.1, 0, 0, PROFILE, RULE,     \
      "the sample time (noise_dt) must be a finite number in (0, {B}] s")                      \
    X("momentum_window_samples", momentum_window_samples, 0, 1, 0, SR_EST_MAX_WINDOW_SAMPLES,   \
      0, 1, 0, ALWAYS, RULE,                                                                    \
      "{n} (the momentum window's ring) must be 0 (automatic) or an integer from 2 to {b}")

/* a body's ten guesses (body.h's ranges; an inertia entry lies within the principal moments'
 * range, a product of inertia within +- the largest principal moment) */
#define BODY_OPTIONS(X, prefix, field, m, bx, by, bz, ixx, iyy, izz)                             \
    X(prefix "m", field, 0, 0, SR_BODY_MASS_MIN, SR_BODY_MASS_MAX, m, 0, 1, BODY, RULE, NULL)  \
    X(prefix "b[1]", field, 1, 0, -SR_BODY_COM_MAX, SR_BODY_COM_MAX, bx, 0, 1, BODY, RULE,     \
      NULL)                                                                                     \
    X(prefix "b[2]", field, 2, 0, -SR_BODY_COM_MAX, SR_BODY_COM_MAX, by, 0, 1, BODY, RULE,     \
      NULL)                                                                                     \
    X(prefix "b[3]", field, 3, 0, -SR_BODY_COM_MAX, SR_BODY_COM_MAX, bz, 0, 1, BODY, RULE,     \
      NULL)                                                                                     \
    X(prefix "Ixx", field, 4, 0, SR_BODY_INERTIA_MIN, SR_BODY_INERTIA_MAX, ixx, 0, 1, BODY,     \
      RULE, NULL)                                                                               \
    X(prefix "Iyy", field, 5, 0, SR_BODY_INERTIA_MIN, SR_BODY_INERTIA_MAX, iyy, 0, 1, BODY,     \
      RULE, NULL)                                                                               \
    X(prefix "Izz", field, 6, 0, SR_BODY_INERTIA_MIN, SR_BODY_INERTIA_MAX, izz, 0, 1, BODY,     \
      RULE, NULL)                                                                               \
    X(prefix "Ixy", field, 7, 0, -SR_BODY_INERTIA_MAX, SR_BODY_INERTIA_MAX, 0.0, 0, 1, BODY,    \
      RULE, NULL)                                                                               \
    X(prefix "Ixz", field, 8, 0, -SR_BODY_INERTIA_MAX, SR_BODY_INERTIA_MAX, 0.0, 0, 1, BODY,    \
      RULE, NULL)                                                                               \
    X(prefix "Iyz", field, 9, 0, -SR_BODY_INERTIA_MAX, SR_BODY_INERTIA_MAX, 0.0, 0, 1, BODY,    \
      RULE, NULL)

/* a mode's frequency given to the modal columns (est_modal.h): 0 or in range [Hz] */
#define MODE_F(X, name, k)                                                                      \
    X(name, mode_f, k, 0, 0.0, SR_EST_MAX_MODE_F, 0.0, 0, 1, ALWAYS, RULE,                      \
      "{n} must be a frequency from {a} to {b} Hz (0 = not given)")

/* a sensors' magnitude the noise profile reads (noise.<name>, sensor_noise.h): finite >= 0 */
#define PROFILE_MAGNITUDE(X, k)                                                                 \
    X(NULL, noise, k, 0, 0.0, FINITE, 0.0, 0, 1, PROFILE, RULE, "{n} must be a finite number >= 0")

typedef struct {
    const char *name, *field;              /* NULL name: the magnitude's sr_noise_name(index) */
    int index, integer;
    size_t offset;
    double min, max, start;
    int not_one, parameter, when, style;
    const char *rule;
} option;

#define FIELD_OFFSET(field, index)                                                              \
    (offsetof(sr_estimator_options, field)                                                     \
     + (size_t)(index) * sizeof(((sr_estimator_options *)0)->field[0]))
/* the field's own type: int or double (an array's element) */
#define IS_INT(field) (sizeof(((sr_estimator_options *)0)->field) % sizeof(double) != 0)

static const option OPTIONS[] = {
#define ROW_(name, field, index, integer, min, max, start, not_one, parameter, when, style, rule) \
    {name, #field, index, integer, offsetof(sr_estimator_options, field)                       \
         + (size_t)(index) * (integer ? sizeof(int) : sizeof(double)),                          \
     min, max, start, not_one, parameter, when, style, rule},
    EST_OPTIONS(ROW_)
#undef ROW_
};
#define N_OPTIONS ((int)(sizeof OPTIONS / sizeof OPTIONS[0]))

/* an Integer option's field is an int, a Real one's a double or an array of doubles (no option
 * is an array of ints): checked at compile time for every row */
#define TYPE_OK_(name, field, index, integer, min, max, start, not_one, parameter, when, style,  \
                 rule)                                                                          \
    ((integer) == (sizeof(((sr_estimator_options *)0)->field) % sizeof(double) != 0)) &&
typedef char check_option_types_[(EST_OPTIONS(TYPE_OK_) 1) ? 1 : -1];
#undef TYPE_OK_

static const char *name_of(const option *p) { return p->name ? p->name : sr_noise_name(p->index); }

static const option *find(const char *name)
{
    if (!name)
        return NULL;
    for (int i = 0; i < N_OPTIONS; i++)
        if (strcmp(name_of(&OPTIONS[i]), name) == 0)
            return &OPTIONS[i];
    return NULL;
}

static double value_of(const sr_estimator_options *o, const option *p)
{
    const char *at = (const char *)o + p->offset;
    return p->integer ? (double)*(const int *)at : *(const double *)at;
}

/* -- the table's API ------------------------------------------------------------------------ */

void sr_estimator_options_default(sr_estimator_options *o)
{
    if (!o)
        return;
    memset(o, 0, sizeof *o);
    for (int i = 0; i < N_OPTIONS; i++) {
        char *at = (char *)o + OPTIONS[i].offset;
        if (OPTIONS[i].integer)
            *(int *)at = (int)OPTIONS[i].start;
        else
            *(double *)at = OPTIONS[i].start;
    }
}

size_t sr_estimator_options_size(void) { return sizeof(sr_estimator_options); }

int sr_estimator_option_count(void) { return N_OPTIONS; }

const char *sr_estimator_option_name(int i)
{
    return i >= 0 && i < N_OPTIONS ? name_of(&OPTIONS[i]) : NULL;
}

const char *sr_estimator_option_field(int i)
{
    return i >= 0 && i < N_OPTIONS ? OPTIONS[i].field : NULL;
}

int sr_estimator_option_index(int i) { return i >= 0 && i < N_OPTIONS ? OPTIONS[i].index : -1; }

long sr_estimator_option_offset(int i)
{
    return i >= 0 && i < N_OPTIONS ? (long)OPTIONS[i].offset : -1;
}

int sr_estimator_option_integer(int i)
{
    return i >= 0 && i < N_OPTIONS ? OPTIONS[i].integer : -1;
}

int sr_estimator_option_parameter(int i)
{
    return i >= 0 && i < N_OPTIONS ? OPTIONS[i].parameter : -1;
}

/* 1 if name is an input of the estimator FMU: a sample signal's FMU name with an index,
 * "<name>[i]" or "<name>[i,j]" (sample.h) */
static int is_input(const char *name)
{
    const char *bracket = strchr(name, '[');
    if (!bracket)
        return 0;
    size_t len = (size_t)(bracket - name);
    for (int k = 0; k < sr_sample_signal_count(); k++) {
        const char *stem = sr_sample_signal_fmi_name(k);
        if (strlen(stem) == len && strncmp(stem, name, len) == 0)
            return 1;
    }
    return 0;
}

int sr_estimator_param_range(const char *fmi_name, double *min, double *max)
{
    const option *p = find(fmi_name);
    double lo, hi;
    if (p && p->parameter) {
        lo = p->min;
        hi = p->max;
    } else if (fmi_name && is_input(fmi_name)) {
        lo = -SR_EST_INPUT_LIMIT;
        hi = SR_EST_INPUT_LIMIT;
    } else {
        return 1;
    }
    if (min)
        *min = lo;
    if (max)
        *max = hi;
    return 0;
}

/* append the value v of option p: an integer as one, else as Python's repr of a float */
static void value_text(const option *p, double v, char *err, size_t errlen)
{
    if (p->integer && v == floor(v) && fabs(v) < 1e18)
        sr_text_int(err, errlen, (long long)v);
    else
        sr_text_repr(err, errlen, v);
}

/* append x as sr_text_num's %g (6 digits), compact: no sign or leading zeros in the exponent
 * ("1e6", "1e-12", "0.5") */
static void num_compact(char *err, size_t errlen, double x)
{
    char t[40], u[40];
    size_t k = 0;
    sr_text_set(t, sizeof t, "");
    sr_text_num(t, sizeof t, x, 6);
    for (const char *c = t; *c && k + 1 < sizeof u; c++) {
        u[k++] = *c;
        if (*c == 'e') {
            if (c[1] == '+')
                c++;
            else if (c[1] == '-')
                u[k++] = *++c;
            while (c[1] == '0' && c[2])
                c++;
        }
    }
    u[k] = '\0';
    sr_text_cat(err, errlen, u);
}

/* the message of option p's value v: "<name> = <v> is not one of <rule>" (CODE), or the rule
 * with {n} (the name), {a}, {b}, {A}, {B} (the bounds) filled in and ", got <v>" (RULE, REPR,
 * COVAR) */
static void message(const option *p, double v, char *err, size_t errlen)
{
    sr_text_set(err, errlen, "");
    if (p->style == COVAR && !(v > 0.0 && isfinite(v))) {
        sr_text_cat(err, errlen, name_of(p));
        sr_text_cat(err, errlen, " must be a finite covariance > 0, got ");
        sr_text_repr(err, errlen, v);
        return;
    }
    if (p->style == CODE) {
        sr_text_cat(err, errlen, name_of(p));
        sr_text_cat(err, errlen, " = ");
        value_text(p, v, err, errlen);
        sr_text_cat(err, errlen, " is not one of ");
        sr_text_cat(err, errlen, p->rule);
        return;
    }
    for (const char *c = p->rule; *c; c++) {
        if (c[0] == '{' && c[1] && c[2] == '}') {
            if (c[1] == 'n')
                sr_text_cat(err, errlen, name_of(p));
            else if (c[1] == 'a' || c[1] == 'b')
                sr_text_num(err, errlen, c[1] == 'a' ? p->min : p->max, 6);
            else
                num_compact(err, errlen, c[1] == 'A' ? p->min : p->max);
            c += 2;
        } else {
            char one[2] = {*c, '\0'};
            sr_text_cat(err, errlen, one);
        }
    }
    sr_text_cat(err, errlen, ", got ");
    if (p->style == REPR)
        sr_text_repr(err, errlen, v);
    else
        value_text(p, v, err, errlen);
}

int sr_estimator_options_set(sr_estimator_options *o, const char *name, double value,
                             char *err, size_t errlen)
{
    if (err && errlen)
        err[0] = '\0';
    const option *p = find(name);
    if (!o || !p)
        return 2;
    char *at = (char *)o + p->offset;
    if (!p->integer) {
        *(double *)at = value;
        return 0;
    }
    if (!(value >= (double)INT_MIN && value <= (double)INT_MAX && value == floor(value))) {
        message(p, value, err, errlen);       /* no int holds it: out of its range too */
        return 1;
    }
    *(int *)at = (int)value;
    return 0;
}

int sr_estimator_options_get(const sr_estimator_options *o, const char *name, double *value)
{
    const option *p = find(name);
    if (!o || !p)
        return 2;
    if (value)
        *value = value_of(o, p);
    return 0;
}

/* -- the checks ----------------------------------------------------------------------------- */

/* 0 when option p's value in o is in its range (and not 1 where that is refused) */
static int in_range(const sr_estimator_options *o, const option *p)
{
    double v = value_of(o, p);
    return v >= p->min && v <= p->max && !(p->not_one && v == 1.0);
}

/* the rules between options (on top of each value's range) */
static int check_rules(const sr_estimator_options *o, char *err, size_t errlen)
{
    if (o->information == 1 && o->noise_profile != SR_NOISE_PROFILE_SENSORS) {
        sr_text_set(err, errlen, "ident.information = 1 needs the sensors' noise model: set "
                                 "ident.noise_profile = 1 (which turns it on) and the noise.* "
                                 "parameters");
        return 1;
    }
    if (o->modes == 1 && (o->method != 1 || o->solver != 2)) {
        sr_text_set(err, errlen, "ident.modes = 1 (the modal columns) needs the momentum method "
                                 "(method = 1) and the joint solver (solver = 2)");
        return 1;
    }
    for (int k = 0; k < SR_EST_MAX_MODES; k++)
        if (o->mode_f[k] != 0.0 && o->mode_f[k] < SR_EST_MIN_MODE_F) {
            sr_text_set(err, errlen, "ident.mode_f[");
            sr_text_int(err, errlen, k + 1);
            sr_text_cat(err, errlen, "] must be 0 (not given) or a frequency from ");
            sr_text_num(err, errlen, SR_EST_MIN_MODE_F, 6);
            sr_text_cat(err, errlen, " Hz (below, a mode's columns are a rigid body's), got ");
            sr_text_repr(err, errlen, o->mode_f[k]);
            return 1;
        }
    if (o->method == 2 && o->accel_source == 2 && o->diff_momentum == 1
        && o->diff_half_window > SR_DIFF_MAX_DISPLACEMENT_HALF_WINDOW) {
        sr_text_set(err, errlen, "ident.diff_half_window must be an integer from 1 to ");
        sr_text_int(err, errlen, SR_DIFF_MAX_DISPLACEMENT_HALF_WINDOW);
        sr_text_cat(err, errlen, " with ident.diff_momentum = 1 (the displacement weights "
                                 "lose their digits beyond), got ");
        sr_text_int(err, errlen, o->diff_half_window);
        return 1;
    }
    if (o->noise_profile != SR_NOISE_PROFILE_SENSORS)
        return 0;
    /* the profile's magnitudes scaled: within SR_NOISE_PROFILE_MAX, the thrust's within
     * SR_EST_MAX_THRUST_SD (they become ident.sd_thrust.*) */
    for (int i = 0; i < N_OPTIONS; i++) {
        const option *p = &OPTIONS[i];
        if (p->when != PROFILE || p->name)
            continue;
        int thrust = p->index == SR_NOISE_THRUST_SCALE || p->index == SR_NOISE_THRUST_MISALIGN;
        double x = o->noise[p->index], limit = thrust ? SR_EST_MAX_THRUST_SD
                                                      : SR_NOISE_PROFILE_MAX;
        if (!(o->noise_scale * x <= limit)) {
            sr_text_set(err, errlen, name_of(p));
            sr_text_cat(err, errlen, " must be at most ");
            num_compact(err, errlen, limit);
            sr_text_cat(err, errlen, " / noise.scale, got ");
            sr_text_repr(err, errlen, x);
            return 1;
        }
    }
    return 0;
}

int sr_estimator_options_check(const sr_estimator_options *o, char *err, size_t errlen)
{
    if (err && errlen)
        err[0] = '\0';
    if (!o) {
        sr_text_set(err, errlen, "no options given");
        return 1;
    }
    for (int i = 0; i < N_OPTIONS; i++) {
        const option *p = &OPTIONS[i];
        if (p->when == BODY) {                 /* each guess as a whole, at its first entry */
            if (p->index == 0) {
                const double *g = (const double *)((const char *)o + p->offset);
                char body[32];
                sr_text_set(body, sizeof body, p->name);
                body[strlen(body) - 2] = '\0';    /* "guess.base.m" -> "guess.base" */
                if (sr_body_check(body, g, err, errlen))
                    return 1;
            }
            continue;
        }
        if (!in_range(o, p)) {                 /* every value within its declared range */
            message(p, value_of(o, p), err, errlen);
            return 1;
        }
    }
    return check_rules(o, err, errlen);
}

sr_exd_options est_exd_options(const sr_estimator_options *o)
{
    sr_exd_options x;
    memset(&x, 0, sizeof x);
    x.rate = o->excite_rate_try;
    x.window = o->excite_window;
    x.settle = o->excite_settle;
    x.horizon = o->excite_horizon;
    return x;
}
