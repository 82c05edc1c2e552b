/* What the estimator reports (estimator.h): the estimates projected onto real bodies where
 * they are not, their standard deviations (the information filter's where it runs), the
 * identified flags, the diagnostics and the excitation request; read from the Data block
 * only. */
#include "est_report.h"

#include <math.h>
#include <string.h>

#include "est_corr.h"
#include "est_joint.h"
#include "est_paper.h"
#include "physical.h"
#include "sr_text.h"

void est_physical_vector(const sr_estimator_model *m, const double *ls, const double *sd,
                         double *out, int *flags)
{
    /* the information filter's sds are calibrated (an error beyond 2 sd in 1 of 20): its flag
       asks 2 sd below the threshold, so that a flagged estimate is within it at 95 % */
    double sd_rel = m->info ? 0.5 * m->opt.sd_rel : m->opt.sd_rel;
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

/* the reported least-squares estimates and standard deviations: the information filter's
 * (its bound times sqrt(max(1, chi2)): the misfit the noise model did not foresee widens them)
 * where it runs, else the equations' own; crb (20) and chi2 (may be NULL) the filter's bound
 * and misfit, 0 without it */
static void estimates_info(const sr_estimator_model *m, const est_data *d, double *vec,
                           double *sd, double *crb, double *chi2)
{
    double bound[EST_NZ], x2 = 0.0;
    if (!m->info) {
        est_least_squares(m, d, vec, sd);
        memset(bound, 0, sizeof bound);
    } else {
        if (sr_info_estimate(&m->info_m, est_info_data(m, d), 2, vec, bound, &x2) == 0) {
            double k = sqrt(x2 > 1.0 ? x2 : 1.0);
            for (int i = 0; i < EST_NZ; i++)
                sd[i] = k * bound[i];
        } else {                          /* a singular information: the equations' own */
            est_least_squares(m, d, vec, sd);
            memset(bound, 0, sizeof bound);
            x2 = 0.0;
        }
    }
    if (crb)
        memcpy(crb, bound, sizeof bound);
    if (chi2)
        *chi2 = x2;
}

static void estimates(const sr_estimator_model *m, const est_data *d, double *vec, double *sd)
{
    estimates_info(m, d, vec, sd, NULL, NULL);
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
    estimates_info(m, d, ls, r->sd, r->crb, &r->info_chi2);
    int flags[4];
    est_physical_vector(m, ls, r->sd, r->vector, flags);
    for (int k = 0; k < 2; k++) {
        r->physical[k] = flags[k];
        r->identified[k] = d->samples > 0 && flags[2 + k];
    }
    r->residual_lin = d->core.residual_lin;
    r->residual_ang = d->core.residual_ang;
    r->excitation_mu = d->samples > 0 ? d->core.rcond_mu : 0.0;
    r->excitation_theta = d->samples > 0 ? d->core.rcond_theta : 0.0;
    r->samples = d->samples;
    r->rejected = d->rejected;
    r->status = d->status;
    /* the excitation request */
    int mode = m->opt.excite_mode;
    r->excite = (mode == 2 || (mode == 1 && !(r->identified[0] && r->identified[1])))
                    ? m->opt.excite_level : 0.0;
    if (m->adapt) {
        const sr_exd_data *x = est_exd_data(m, data);
        r->excite_rate = x->rate;
        r->excite_score[0] = x->score[0];
        r->excite_score[1] = x->score[1];
    }
}

size_t sr_estimator_report_size(void) { return sizeof(sr_estimator_report); }
