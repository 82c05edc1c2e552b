/* One sample through the estimator (sr_estimator_update, estimator.h), in one direction:
 * validation (the sample's values and rotation, its time after the newest the state needs),
 * the information filter's sample, the sample's rows (est_rows.h), the solver's step into the
 * work space (est_paper.h or est_joint.h), and the commit of the new state only where every
 * number came out finite (a rejected sample changes the counters, the status and the message
 * only); then the excitation design's step on the committed state. */
#include <math.h>
#include <string.h>

#include "est_band.h"
#include "est_corr.h"
#include "est_fit.h"
#include "est_hold.h"
#include "est_joint.h"
#include "est_modal.h"
#include "est_types.h"
#include "est_paper.h"
#include "est_report.h"
#include "est_rows.h"
#include "sample.h"
#include "sr_text.h"

/* -- validation ----------------------------------------------------------------------------- */

/* the status and message of a sample that sr_sample_check refused: the first signal (the
 * sample's table, sample.h) with a value that is not finite or out of range, else base.A */
static int explain_rejection(const sr_estimator_model *m, const double *x, char *msg, size_t n)
{
    for (int k = 0; k < SR_SIG_COUNT; k++) {
        int o = sr_sample_signal_offset(k, m->n), size = sr_sample_signal_size(k, m->n);
        int finite = 1, inrange = 1;
        for (int i = 0; i < size; i++) {
            if (!isfinite(x[o + i]))
                finite = 0;
            else if (!(fabs(x[o + i]) <= SR_EST_INPUT_LIMIT))
                inrange = 0;
        }
        if (!finite) {
            sr_text_set(msg, n, "non-finite input ");
            sr_text_cat(msg, n, sr_sample_signal_key(k));
            sr_text_cat(msg, n, " = ");
            sr_text_vec(msg, n, x + o, size);
            return SR_EST_REJECT_NONFINITE;
        }
        if (!inrange) {
            sr_text_set(msg, n, "input ");
            sr_text_cat(msg, n, sr_sample_signal_key(k));
            sr_text_cat(msg, n, " = ");
            sr_text_vec(msg, n, x + o, size);
            sr_text_cat(msg, n, " is beyond the physical range |x| <= ");
            sr_text_num(msg, n, SR_EST_INPUT_LIMIT, 6);
            sr_text_cat(msg, n, " (SI units?)");
            return SR_EST_REJECT_NONFINITE;
        }
    }
    double err, det;
    sr_rotation_error(x + SR_X_A_B, &err, &det);
    sr_text_set(msg, n, "base.A is not a rotation matrix (|A^T A - I| = ");
    sr_text_num(msg, n, err, 3);
    sr_text_cat(msg, n, " > ");
    sr_text_num(msg, n, SR_EST_ROTATION_TOL, 6);
    sr_text_cat(msg, n, " or det = ");
    sr_text_num(msg, n, det, 6);
    sr_text_cat(msg, n, " <= 0)");
    return SR_EST_REJECT_INCONSISTENT;
}

/* n + 1, saturated at INT_MAX (the counters of a long run, or of a restored block, never
 * overflow) */
static int count_up(int n) { return n < 2147483647 ? n + 1 : n; }

/* a rejection after validation: counters, status, message */
static int reject(est_data *d, int status, const char *why, char *msg, size_t msglen)
{
    d->rejected = count_up(d->rejected);
    d->status = status;
    sr_text_set(d->msg, sizeof d->msg, why);
    if (msg && msglen)
        sr_text_set(msg, msglen, d->msg);
    return status;
}

/* The sample's validation: its values (finite, within SR_EST_INPUT_LIMIT), base.A a rotation,
 * its time finite and after the newest the state needs (the differencing history, the
 * momentum window and the thrust integrals need increasing sample times). SR_EST_ESTIMATING
 * when valid, else the rejection's status with its reason in why. */
static int validate(const sr_estimator_model *m, const void *data, double t,
                    const double *sample, char *why, size_t whylen)
{
    int status = SR_EST_ESTIMATING;
    if (!sample) {
        status = SR_EST_REJECT_INCONSISTENT;
        sr_text_set(why, whylen, "no sample given");
    } else if (sr_sample_check(sample, m->nflat, SR_EST_INPUT_LIMIT, SR_EST_ROTATION_TOL) != 0) {
        status = explain_rejection(m, sample, why, whylen);
    }
    if (!isfinite(t)) {
        sr_text_set(why, whylen, "non-finite sample time ");
        sr_text_num(why, whylen, t, 6);
        return status != SR_EST_ESTIMATING ? status : SR_EST_REJECT_NONFINITE;
    }
    if (status != SR_EST_ESTIMATING)
        return status;
    double last;
    if (est_rows_last_time(m, data, &last) && !(t > last)) {
        sr_text_set(why, whylen, "differenced accelerations, the moving reference and the "
                                 "thrust integrals need increasing sample times: t = ");
        sr_text_num(why, whylen, t, 6);
        sr_text_cat(why, whylen, " s after ");
        sr_text_num(why, whylen, last, 6);
        sr_text_cat(why, whylen, " s");
        return SR_EST_REJECT_INCONSISTENT;
    }
    return SR_EST_ESTIMATING;
}

/* -- the information filter and the excitation design --------------------------------------- */

/* The information filter's sample (information.h) into *nwi, a copy of the Data's filter,
 * linearised at this estimator's estimates so far (its own can run away while it is poorly
 * informed: the physical projection of the least squares', the guesses where a mass is not
 * positive). 0 ok, 1 failed (non-finite numbers: the sample is rejected). */
static int info_step(const sr_estimator_model *m, void *data, double t, const double *sample,
                     sr_info_data *nwi, sr_info_work *w)
{
    double ls[EST_NZ], sd[EST_NZ], z[EST_NZ];
    int flags[4];
    est_least_squares(m, data, ls, sd);
    est_physical_vector(m, ls, sd, z, flags);
    if (!(z[0] > 0.0 && z[10] > 0.0)) {
        memcpy(z, m->opt.guess_base, sizeof(double) * 10);
        memcpy(z + 10, m->opt.guess_target, sizeof(double) * 10);
    }
    /* the replay buffer: written at the filter's next slot only, which counts at the commit */
    return sr_info_step(&m->info_m, est_info_data(m, data), nwi, est_info_buffer(m, data), t,
                        sample, z, w);
}

/* The excitation's rate (excite_design.h) after a committed sample at t; where a window ends
 * the choice reads whether the estimator still asks for excitation (the report's
 * ident.excite of the committed state) */
static void design_step(const sr_estimator_model *m, void *data, double t, sr_exd_work *w)
{
    if (!m->adapt)
        return;
    sr_exd_data *x = est_exd_data(m, data);
    int wanted = 1;
    if (sr_exd_reads_wanted(&m->exd, x, t)) {
        sr_estimator_report r;
        sr_estimator_report_get(m, data, &r);
        /* no faster rate under any misfit: toward the modes it may be, and the rate's
           prediction weighs by the noise values and the thrust prior it calls in doubt */
        wanted = r.excite > 0.0 && !r.misfit;
    }
    /* a failed prediction leaves the rate at 1 (the plant's own): nothing to reject */
    (void)sr_exd_step(&m->exd, x, &m->info_m, est_info_data(m, data), t, wanted, w);
}

/* -- the commit ----------------------------------------------------------------------------- */

/* 1 if everything the report reads after the step nw is finite */
static int outputs_finite(const est_core *nw)
{
    int ok = isfinite(nw->residual_lin + nw->residual_ang) && isfinite(nw->rcond_mu)
             && isfinite(nw->rcond_theta);
    for (int i = 0; i < EST_NZ; i++)
        ok &= isfinite(nw->vec[i]) && isfinite(nw->sd[i]);
    return ok;
}

/* Commit the new state src into dst: the parts of its arrays in use (the rest of dst, e.g. a
 * planar robot's unused entries, keeps its bytes), its scalars and the autocorrelation
 * rings' heads; not the rings, the momentum reference and the history (est_rows_commit). */
static void core_commit(const sr_estimator_model *m, est_core *dst, const est_core *src)
{
#define EST_COPY(f, count) memcpy(dst->f, src->f, sizeof(double) * (size_t)(count))
    int p = m->p, r = m->r, nl = m->nl, na = m->na, nj = m->q + 1;
    if (m->opt.solver == 1) {
        EST_COPY(mu, p);
        EST_COPY(P_mu, p * p);
        EST_COPY(theta, r);
        EST_COPY(P_th, r * r);
        EST_COPY(M, r * EST_ND);
        EST_COPY(D, EST_ND);
        EST_COPY(S_lin, nl * nl);
        EST_COPY(S_ang, na * na);
        EST_COPY(age_lin, p * nl);           /* (the rows age_step writes) */
        EST_COPY(age_ang, r * na);
        if (m->eiv) {
            EST_COPY(N_lin, nl * nl);
            EST_COPY(N_ang, na * na);
            EST_COPY(mu_c, p);
            EST_COPY(th_c, r);
            dst->has_eiv = src->has_eiv;
        }
    } else {
        EST_COPY(pi, EST_NZ);
        EST_COPY(P_pi, m->q * m->q);
        EST_COPY(S_pi, nj * nj);
        EST_COPY(age_pi, m->q * nj);
        EST_COPY(info_lin, m->n_lin_cols * m->n_lin_cols);
        EST_COPY(info_ang, m->n_ang_cols * m->n_ang_cols);
        if (m->eiv) {
            EST_COPY(N_pi, nj * nj);
            EST_COPY(pi_c, EST_NZ);
            dst->has_eiv = src->has_eiv;
        }
    }
    EST_COPY(tr_w, EST_NZ);
    EST_COPY(tr_mt, EST_NZ);
    EST_COPY(tr_mx, EST_NZ);
    EST_COPY(tr_ctt, EST_NZ);
    EST_COPY(tr_ctx, EST_NZ);
    EST_COPY(vec, EST_NZ);
    EST_COPY(sd, EST_NZ);
    if (m->consider) {
        EST_COPY(cons_lin, (m->opt.solver == 1 ? p : m->q) * SR_N_CONSIDER);
        if (m->opt.solver == 1)
            EST_COPY(cons_ang, r * SR_N_CONSIDER);
    }
#undef EST_COPY
    dst->rows_lin = src->rows_lin;
    dst->rows_ang = src->rows_ang;
    dst->decay_lin = src->decay_lin;
    dst->decay_ang = src->decay_ang;
    dst->n1_lin = src->n1_lin;
    dst->n2_lin = src->n2_lin;
    dst->n1_ang = src->n1_ang;
    dst->n2_ang = src->n2_ang;
    dst->tr_s0 = src->tr_s0;
    dst->tr_s1 = src->tr_s1;
    dst->tr_t_ref = src->tr_t_ref;
    dst->tr_t = src->tr_t;
    dst->tr_a_bar = src->tr_a_bar;
    for (int i = 0; i < 2; i++) {
        dst->corr_head[i] = src->corr_head[i];
        dst->corr_count[i] = src->corr_count[i];
    }
    dst->residual_lin = src->residual_lin;
    dst->residual_ang = src->residual_ang;
    dst->rcond_mu = src->rcond_mu;
    dst->rcond_theta = src->rcond_theta;
    memcpy(dst->fit_win, src->fit_win, sizeof dst->fit_win);
}

/* -- one sample ----------------------------------------------------------------------------- */

static const char *const info_fail_msg =
    "the information filter's update failed (non-finite numbers or a noise covariance that is "
    "not positive definite); are the inputs in SI units and of physical size, the noise.* "
    "magnitudes those of the sensors?";

/* the reasons of a step that failed (est_paper_step's status 1, 2, 3) */
static const char *step_failure(int st)
{
    return st == 1 ? "the update failed (LinAlgError: lam I + H P H^T is not positive "
                     "definite); are the inputs in SI units and of physical size?"
         : st == 3 ? "the update failed (LinAlgError: Eigenvalues did not converge); are the "
                     "inputs in SI units and of physical size?"
                   : "the update failed: it produced non-finite numbers; are the inputs in SI "
                     "units and of physical size?";
}

/* the flags' hold after a committed sample at t: the reported estimates kept where due */
static void hold_step(const sr_estimator_model *m, void *data, double t)
{
    double ls[EST_NZ], sd[EST_NZ];
    int due = est_hold_due(m, data, t);
    if (due)
        sr_estimator_estimates(m, data, ls, sd);
    est_hold_commit(m, data, t, due ? ls : NULL, due ? sd : NULL);
}

int sr_estimator_update(const sr_estimator_model *m, void *data, void *work, double t,
                        const double *sample, char *msg, size_t msglen)
{
    if (msg && msglen)
        msg[0] = '\0';
    if (!m || !data)
        return SR_EST_REJECT_NONFINITE;
    if (!work) {
        sr_text_set(msg, msglen, "sr_estimator_update: no work space given "
                                 "(sr_estimator_work_size bytes)");
        return SR_EST_REJECT_NONFINITE;
    }
    est_work *wk = (est_work *)work;
    est_data *d = (est_data *)data;
    est_core *c = &d->core;
    if (sr_estimator_data_check(m, d, msg, msglen) != 0)   /* never index with a corrupt
                                                             block's counts */
        return SR_EST_REJECT_NONFINITE;
    char why[SR_EST_MSG_LEN];
    why[0] = '\0';
    int st = validate(m, data, t, sample, why, sizeof why);
    if (st != SR_EST_ESTIMATING)
        return reject(d, st, why, msg, msglen);
    /* the information filter's sample, committed with the sample */
    if (m->info && info_step(m, data, t, sample, &wk->nwi, &wk->exd.info) != 0)
        return reject(d, SR_EST_REJECT_NONFINITE, info_fail_msg, msg, msglen);
    /* the sample's rows */
    est_rows *rows = &wk->rows;
    st = est_rows_of_sample(m, data, t, sample, rows, wk->noise, why, sizeof why);
    if (st != 0)
        return reject(d, st, why, msg, msglen);
    if (rows->stored != EST_ROWS) {                      /* stored, not solved */
        if (rows->stored == EST_STORED_REFERENCE || rows->stored == EST_STORED_WINDOW)
            est_modal_reference(m, data, t, sample);
        est_rows_commit(m, data, t, sample, rows);
        if (m->info)
            memcpy(est_info_data(m, data), &wk->nwi, sizeof wk->nwi);
        est_band_step(m, data, t, sample, est_band_work_of(m, wk));
        d->status = SR_EST_REFERENCE;
        d->msg[0] = '\0';
        design_step(m, data, t, &wk->exd);
        return d->status;
    }
    /* the solver's step: the new state in the work space; the tracker's clock is the sample
     * count (the estimates depend on the samples, not on the step sizes between them) */
    est_core *nw = &wk->nw;
    for (int i = 0; i < 2; i++) {
        nw->corr_head[i] = c->corr_head[i];
        nw->corr_count[i] = c->corr_count[i];
    }
    double e_lin[EST_MAXK], e_ang[3];
    st = m->opt.solver == 1
             ? est_paper_step(m, data, c, rows, wk->noise, wk->noise_rows, nw,
                              (double)d->samples, e_lin, e_ang)
             : est_joint_step(m, data, c, rows, wk->noise, wk->noise_rows, nw,
                              (double)d->samples, e_lin);
    if (st == 0 && !outputs_finite(nw))   /* e.g. a restored block's numbers: never report
                                              them non-finite */
        st = 2;
    if (st != 0)
        return reject(d, SR_EST_REJECT_NONFINITE, step_failure(st), msg, msglen);
    /* the modal columns' stage (est_modal.h): its own state, the estimates from it */
    if (m->modes)
        est_modal_step(m, data, t, sample, rows, wk->noise, nw, est_modal_work_of(m, wk));
    est_fit_window(m, c, d->samples == 0, nw);
    /* the commit; the rigid band's sample after the filter's (its replay starts the band) */
    if (m->info)
        memcpy(est_info_data(m, data), &wk->nwi, sizeof wk->nwi);
    est_band_step(m, data, t, sample, est_band_work_of(m, wk));
    if (m->lags > 0 && m->opt.solver == 1) {
        est_corr_commit(m, data, nw, 0, e_lin, m->k1);
        est_corr_commit(m, data, nw, 1, e_ang, m->k2);
    } else if (m->lags > 0) {
        est_corr_commit(m, data, nw, 0, e_lin, m->k1 + m->k2);
    }
    est_rows_commit(m, data, t, sample, rows);
    core_commit(m, c, nw);
    d->samples = count_up(d->samples);
    hold_step(m, data, t);
    d->status = SR_EST_ESTIMATING;
    d->msg[0] = '\0';
    design_step(m, data, t, &wk->exd);
    return d->status;
}
