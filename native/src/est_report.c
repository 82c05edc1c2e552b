/* What the estimator reports (estimator.h): the estimates projected onto real bodies where
 * they are not, their standard deviations (the information filter's where it runs), the
 * identified flags, the diagnostics and the excitation request; read from the Data block
 * only. */
#include "est_report.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "est_corr.h"
#include "est_fit.h"
#include "est_hold.h"
#include "est_joint.h"
#include "est_band.h"
#include "est_modal.h"
#include "est_paper.h"
#include "physical.h"
#include "sr_text.h"

void est_physical_vector(const sr_estimator_model *m, const double *ls, const double *sd,
                         double *out, int *flags)
{
    /* the information filter's sds are calibrated: its flag asks every sd flag_z times below
       the threshold, so that every estimate of a flagged body is within it with probability
       ident.flag_confidence */
    double sd_rel = m->info ? m->opt.sd_rel / m->flag_z : m->opt.sd_rel;
    memcpy(out, ls, sizeof(double) * EST_NZ);
    if (sr_report_flags(ls, sd, SR_COM_SCALE_MIN, sd_rel, m->identified, flags))
        return;
    const double *g[2] = {m->opt.guess_base, m->opt.guess_target};
    for (int k = 0; k < 2; k++) {
        if (flags[k])
            continue;
        double *body = out + 10 * k, m_out;
        int projected;
        double m_min = SR_REL_MASS_MIN * fabs(g[k][0]);
        if (m->robot.planar)
            sr_project_planar_body(body[0], body + 1, body + 4, m_min, SR_REL_SIGMA_MIN,
                                   &m_out, body + 4, &projected);
        else
            sr_project_body(body[0], body + 1, body + 4, m_min, SR_REL_SIGMA_MIN, &m_out,
                            body + 4, &projected);
        body[0] = m_out;
    }
    double scale[EST_NZ];
    sr_error_scale(out, SR_COM_SCALE_MIN, scale);
    sr_identified_bodies(sd, out, ls, scale, sd_rel, m->identified, flags + 2);
}

void est_least_squares(const sr_estimator_model *m, const void *data, double *vec, double *sd)
{
    const est_data *d = (const est_data *)data;
    if (d->samples > 0) {
        memcpy(vec, d->core.vec, sizeof(double) * EST_NZ);
        memcpy(sd, d->core.sd, sizeof(double) * EST_NZ);
        return;
    }
    double data_only[EST_NZ], J[EST_NZ * EST_NZ], rcond[2];
    if (m->opt.solver == 1)
        est_paper_std_parts(m, &d->core, 1.0, 1.0, sd, data_only, J, vec, rcond);
    else
        est_joint_std_parts(m, &d->core, 1.0, sd, data_only, J, vec);
}

/* the filter's estimates (held: the thrust errors at their priors), compensated (2) or not (0)
   for the noise in the equations' coefficients */
static int filter_estimate(const sr_estimator_model *m, const sr_info_data *fd, int held,
                           int compensated, double *vec, double *bound, double *chi2,
                           double *rss)
{
    return held ? sr_info_estimate_held(&m->info_m, fd, compensated, vec, bound, chi2, rss)
                : sr_info_estimate(&m->info_m, fd, compensated, vec, bound, chi2);
}

/* the information filter's estimates and standard deviations (its bound times
 * sqrt(max(1, chi2)): the misfit the noise model did not foresee widens them) and the
 * errors-in-variables correction's own uncertainty (ident.eiv_uncertainty: a fraction of the
 * correction, which scales with the noise values' variances: where chi2 alone says they are
 * too small (noise), to within chi2 - 1 of itself); where a thrust scale is beyond its
 * prior with white residuals (scale: a miscalibration or a model error the scale absorbs),
 * the difference to the estimate with the thrust errors held, the other answer; where the
 * rigid model does not fit (held), with the thrust errors held at their priors (a consider
 * term) and the model-error term over the residual beyond the noise's. 0, or 1 (a singular
 * information) */
static int estimates_filter(const sr_estimator_model *m, const est_data *d, int held,
                            int noise, int scale, double *vec, double *sd, double *bound,
                            double *chi2)
{
    const sr_info_data *fd = est_info_data(m, d);
    double rss = 0.0, raw[EST_NZ], raw_bound[EST_NZ], raw_chi2;
    if (filter_estimate(m, fd, held, 2, vec, bound, chi2, &rss) != 0)
        return 1;
    double k = sqrt(*chi2 > 1.0 ? *chi2 : 1.0), frac = m->opt.eiv_uncertainty;
    if (noise && *chi2 - 1.0 > frac)
        frac = *chi2 - 1.0;
    /* (where the uncompensated estimates are not finite, the sds go without this term) */
    int eiv = frac > 0.0
              && filter_estimate(m, fd, held, 0, raw, raw_bound, &raw_chi2, NULL) == 0;
    for (int i = 0; i < EST_NZ; i++) {
        double c = eiv ? frac * (vec[i] - raw[i]) : 0.0;
        sd[i] = sqrt(k * bound[i] * k * bound[i] + c * c);
    }
    if (scale) {           /* (where the held estimate is not finite, without this term) */
        double alt[EST_NZ], alt_bound[EST_NZ];
        if (filter_estimate(m, fd, 1, 2, alt, alt_bound, NULL, NULL) == 0)
            for (int i = 0; i < EST_NZ; i++)
                sd[i] = sqrt(sd[i] * sd[i] + (vec[i] - alt[i]) * (vec[i] - alt[i]));
    }
    if (held) {            /* the residual beyond the noise's: rss - dof; all of it where
                              the model error is in the rows' noise model (me_var) */
        double unit[EST_NZ], var[EST_NZ];
        double dof = fd->rows - (m->info_m.nu - SR_N_CONSIDER);
        double excess = fd->me_var[0] > 0.0 || fd->me_var[1] > 0.0 ? rss : rss - dof;
        for (int i = 0; i < EST_NZ; i++)
            unit[i] = bound[i] * bound[i];
        est_fit_model_error_var(m->opt.fit_bias_k_info, unit, excess, var);
        for (int i = 0; i < EST_NZ; i++)
            sd[i] = sqrt(sd[i] * sd[i] + var[i]);
    }
    return 0;
}

/* the reported least-squares estimates and standard deviations: the information filter's
 * where it runs, else the equations' own (where the model does not fit, with the model-error
 * term: the scatter sd^2 = s^2 [(A^T A)^-1]_ii, s^2 = ||r||^2 / dof, so the bias bound's
 * [(A^T A)^-1]_ii ||r||^2 = sd^2 dof: unit variance sd^2, excess the rows' count); crb (20) and
 * chi2 (may be NULL) the filter's bound and misfit, 0 without it; cause the model-fit
 * test's (est_fit_test: SR_EST_MISFIT_*, 0 without a misfit); band (may be NULL) the rigid
 * band's answer reported (est_band_answer's: SR_BAND_* or EST_BAND_MODES) */
static void estimates_info(const sr_estimator_model *m, const est_data *d, int cause,
                           double *vec, double *sd, double *crb, double *chi2, int *band)
{
    double bound[EST_NZ], x2 = 0.0;
    int held = cause == SR_EST_MISFIT_MODEL;
    if (!m->info || estimates_filter(m, d, held, cause == SR_EST_MISFIT_NOISE,
                                     cause == SR_EST_MISFIT_THRUST, vec, sd, bound, &x2) != 0) {
        est_least_squares(m, d, vec, sd);     /* (a singular information: the equations') */
        memset(bound, 0, sizeof bound);
        x2 = 0.0;
        if (held && d->samples > 0) {     /* a model misfit (not the noise values': these
                                             rows' own scatter measures the noise) */
            double var[EST_NZ], unit[EST_NZ];
            for (int i = 0; i < EST_NZ; i++)
                unit[i] = sd[i] * sd[i];
            est_fit_model_error_var(m->opt.fit_bias_k, unit, d->core.rows_lin, var);
            for (int i = 0; i < EST_NZ; i++)
                sd[i] = sqrt(sd[i] * sd[i] + var[i]);
        }
    }
    /* a misfit of the rigid model where the modal columns (ident.modes = 1) run beside the
       filter and have found a mode: their joint solver's answer, the modes in its model (the
       issue's wings through the sensors 2.26 % off against the held filter's 56.5 %); the
       filter's solve above still gives crb.* and diag.info_chi2 */
    double f, zeta;
    if (held && m->info && d->samples > 0 && est_modal_mode(m, d, 0, &f, &zeta))
        est_least_squares(m, d, vec, sd);
    /* a misfit of the rigid model (coloured residuals) where the rigid band runs and has an
       answer: the band's (the wings through the sensors 1.5-2.7 % off against the
       held filter's 56 %, est_band.h; with the modal columns the band over their found modes
       where the compliance does not fit: the wings at 0.3 Hz 0.753-2.47 % against the
       columns' 2.29-12.4 %, seeds 0-7); not for a thrust scale beyond its prior with white
       residuals: the filter's answer with the thrust estimated is the better one there (the
       issue's slosh on the spatial robot 2.3-3.1 % against the band's 2.7-3.9 %) */
    int kind = SR_BAND_NONE;
    if (held && m->info && d->samples > 0)
        kind = est_band_answer(m, d, vec, sd);
    if (band)
        *band = kind;
    if (crb)
        memcpy(crb, bound, sizeof bound);
    if (chi2)
        *chi2 = x2;
}

static void estimates(const sr_estimator_model *m, const est_data *d, double *vec, double *sd)
{
    double fit;
    int cause;
    est_fit_test(m, d, &fit, &cause);
    estimates_info(m, d, cause, vec, sd, NULL, NULL, NULL);
}

void sr_estimator_estimates(const sr_estimator_model *m, const void *data, double *vec,
                            double *sd)
{
    if (!m || !data || !vec || !sd)
        return;
    if (sr_estimator_data_check(m, data, NULL, 0) != 0) {
        for (int i = 0; i < EST_NZ; i++)
            vec[i] = sd[i] = NAN;
        return;
    }
    estimates(m, (const est_data *)data, vec, sd);
}

void sr_estimator_sd_without_lag(const sr_estimator_model *m, const void *data, double *sd)
{
    if (!m || !data || !sd)
        return;
    const est_data *d = (const est_data *)data;
    if (sr_estimator_data_check(m, d, NULL, 0) != 0) {
        for (int i = 0; i < EST_NZ; i++)
            sd[i] = NAN;
        return;
    }
    double vec[EST_NZ], data_only[EST_NZ], J[EST_NZ * EST_NZ], rcond[2];
    if (m->opt.solver == 1)
        est_paper_std_parts(m, &d->core, est_corr_current(m, data, 0),
                            est_corr_current(m, data, 1), sd, data_only, J, vec, rcond);
    else if (m->modes && d->samples > 0)     /* the modal solve's (it adds no lag) */
        memcpy(sd, d->core.sd, sizeof(double) * EST_NZ);
    else
        est_joint_std_parts(m, &d->core, est_corr_current(m, data, 0), sd, data_only, J, vec);
}

void sr_estimator_message(const sr_estimator_model *m, const void *data, char *msg,
                          size_t msglen)
{
    if (!m || !data || !msg || !msglen)
        return;
    const est_data *d = (const est_data *)data;
    char buf[SR_EST_MSG_LEN];
    memcpy(buf, d->msg, sizeof buf);         /* NUL-terminated even in a corrupt block */
    buf[SR_EST_MSG_LEN - 1] = '\0';
    sr_text_set(msg, msglen, buf);
}

double sr_estimator_excite_request(const sr_estimator_model *m, int identified_base,
                                   int identified_target)
{
    if (!m)
        return 0.0;
    int mode = m->opt.excite_mode;         /* never, until both are identified, always */
    return (mode == 2 || (mode == 1 && !(identified_base && identified_target)))
               ? m->opt.excite_level : 0.0;
}

void sr_estimator_report_get(const sr_estimator_model *m, const void *data,
                             sr_estimator_report *r)
{
    if (!m || !data || !r)
        return;
    const est_data *d = (const est_data *)data;
    double ls[EST_NZ];
    memset(r, 0, sizeof *r);
    r->excite_rate = 1.0;                    /* the plant's own rate unless chosen */
    if (sr_estimator_data_check(m, d, NULL, 0) != 0) {   /* a corrupt block: the status */
        r->status = SR_EST_REJECT_NONFINITE;
        return;
    }
    est_fit_test(m, d, &r->model_fit, &r->misfit_cause);
    r->misfit = r->misfit_cause != 0;
    estimates_info(m, d, r->misfit_cause, ls, r->sd, r->crb, &r->info_chi2, &r->band);
    int flags[4];
    est_physical_vector(m, ls, r->sd, r->vector, flags);
    for (int k = 0; k < 2; k++) {
        r->physical[k] = flags[k];
        r->identified[k] = d->samples > 0 && flags[2 + k];
    }
    est_fit_gate_flags(r->misfit, r->identified);
    est_hold_gate(m, d, ls, r->sd, r->identified);
    r->residual_lin = d->core.residual_lin;
    r->residual_ang = d->core.residual_ang;
    r->excitation_mu = d->samples > 0 ? d->core.rcond_mu : 0.0;
    r->excitation_theta = d->samples > 0 ? d->core.rcond_theta : 0.0;
    r->samples = d->samples;
    r->rejected = d->rejected;
    r->status = d->status;
    r->excite = sr_estimator_excite_request(m, r->identified[0], r->identified[1]);
    if (m->adapt) {
        const sr_exd_data *x = est_exd_data(m, data);
        r->excite_rate = x->rate;
        r->excite_score[0] = x->score[0];
        r->excite_score[1] = x->score[1];
    }
    for (int k = 0; k < SR_EST_MAX_MODES; k++)
        est_modal_mode(m, data, k, &r->mode_f[k], &r->mode_zeta[k]);
}

size_t sr_estimator_report_size(void) { return sizeof(sr_estimator_report); }

/* -- the outputs' and the status's tables ---------------------------------------------------- */

/* the 20 estimates' names (spacerobot.interface.ESTIMATE_NAMES) and their index */
#define ESTIMATES(Y, prefix, field)                                                              \
    BODY_ESTIMATES(Y, prefix, "base.", field, 0) BODY_ESTIMATES(Y, prefix, "target.", field, 10)
#define BODY_ESTIMATES(Y, prefix, body, field, o)                                               \
    Y(prefix body "m", field, o) Y(prefix body "b[1]", field, o + 1)                            \
    Y(prefix body "b[2]", field, o + 2) Y(prefix body "b[3]", field, o + 3)                     \
    Y(prefix body "Ixx", field, o + 4) Y(prefix body "Iyy", field, o + 5)                       \
    Y(prefix body "Izz", field, o + 6) Y(prefix body "Ixy", field, o + 7)                       \
    Y(prefix body "Ixz", field, o + 8) Y(prefix body "Iyz", field, o + 9)

/* the estimator FMU's outputs: name, Integer, the report's field and index */
typedef struct {
    const char *name;
    int integer;
    size_t offset;
} output;

#define REAL_(name, field, i)                                                                    \
    {name, 0, offsetof(sr_estimator_report, field) + (size_t)(i) * sizeof(double)},
#define INT_(name, field, i)                                                                     \
    {name, 1, offsetof(sr_estimator_report, field) + (size_t)(i) * sizeof(int)},

static const output OUTPUTS[] = {
    ESTIMATES(REAL_, "", vector)             /* the estimates, physically consistent */
    ESTIMATES(REAL_, "sd.", sd)              /* their standard deviations */
    ESTIMATES(REAL_, "crb.", crb)            /* the information filter's bound */
    INT_("diag.samples", samples, 0)
    INT_("diag.rejected", rejected, 0)
    INT_("diag.status", status, 0)
    REAL_("diag.residual_lin", residual_lin, 0)
    REAL_("diag.residual_ang", residual_ang, 0)
    REAL_("diag.excitation_mu", excitation_mu, 0)
    REAL_("diag.excitation_theta", excitation_theta, 0)
    REAL_("ident.excite", excite, 0)
    INT_("diag.identified.base", identified, 0)
    INT_("diag.identified.target", identified, 1)
    INT_("diag.physical.base", physical, 0)
    INT_("diag.physical.target", physical, 1)
    REAL_("diag.info_chi2", info_chi2, 0)
    REAL_("ident.excite_rate", excite_rate, 0)
    REAL_("diag.excite_score.rate_1", excite_score, 0)
    REAL_("diag.excite_score.rate_try", excite_score, 1)
    REAL_("diag.mode_f[1]", mode_f, 0)
    REAL_("diag.mode_f[2]", mode_f, 1)
    REAL_("diag.mode_f[3]", mode_f, 2)
    REAL_("diag.mode_f[4]", mode_f, 3)
    REAL_("diag.mode_zeta[1]", mode_zeta, 0)
    REAL_("diag.mode_zeta[2]", mode_zeta, 1)
    REAL_("diag.mode_zeta[3]", mode_zeta, 2)
    REAL_("diag.mode_zeta[4]", mode_zeta, 3)
    REAL_("diag.model_fit", model_fit, 0)
    INT_("diag.misfit", misfit, 0)
    INT_("diag.misfit_cause", misfit_cause, 0)
    INT_("diag.band", band, 0)
};
#undef REAL_
#undef INT_
#define N_OUTPUTS ((int)(sizeof OUTPUTS / sizeof OUTPUTS[0]))

int sr_estimator_output_count(void) { return N_OUTPUTS; }

const char *sr_estimator_output_name(int i)
{
    return i >= 0 && i < N_OUTPUTS ? OUTPUTS[i].name : NULL;
}

int sr_estimator_output_integer(int i)
{
    return i >= 0 && i < N_OUTPUTS ? OUTPUTS[i].integer : -1;
}

void sr_estimator_outputs(const sr_estimator_report *r, double *out)
{
    if (!r || !out)
        return;
    for (int i = 0; i < N_OUTPUTS; i++) {
        const char *at = (const char *)r + OUTPUTS[i].offset;
        out[i] = OUTPUTS[i].integer ? (double)*(const int *)at : *(const double *)at;
    }
}

/* what diag.status says (the SR_EST_* codes) */
static const char *const STATUS_TEXT[] = {
    "no sample yet",
    "reference sample stored (momentum method) or waiting for differencing history",
    "estimating: last sample used",
    "last sample rejected: non-finite or out-of-range input, or an update that overflowed",
    "last sample rejected: inconsistent input (base.A not a rotation matrix, or a sample time "
    "not after the previous one with differenced accelerations or a reference window)"};

const char *sr_estimator_status_text(int s)
{
    return s >= SR_EST_NO_SAMPLE && s <= SR_EST_REJECT_INCONSISTENT ? STATUS_TEXT[s] : NULL;
}

double sr_estimator_input_limit(void) { return SR_EST_INPUT_LIMIT; }
double sr_estimator_rotation_tol(void) { return SR_EST_ROTATION_TOL; }
