/* The model-fit test, its gate on the flags and the model-error term (est_fit.h). */
#include "est_fit.h"

#include <math.h>
#include <string.h>

/* the window's length in samples (at least 1) */
static double window_samples(const sr_estimator_model *m)
{
    double n = m->opt.fit_window / m->opt.noise_dt;
    return n > 1.0 ? n : 1.0;
}

void est_fit_window(const sr_estimator_model *m, const est_core *old, int first, est_core *nw)
{
    double a = first ? 0.0 : 1.0 - 1.0 / window_samples(m);
    for (int i = 0; i < 4; i++)
        nw->fit_win[i] = a * old->fit_win[i] + nw->fit_now[i];
}

/* the estimator declares no noise: rows unweighted, no errors in variables, no profile */
static int noise_free(const sr_estimator_model *m)
{
    return !m->eiv && m->w_lin == 1.0 && m->w_ang == 1.0 && !m->opt.noise_profile;
}

void est_fit_test(const sr_estimator_model *m, const void *data, double *model_fit,
                  int *cause)
{
    const est_data *d = (const est_data *)data;
    *model_fit = 0.0;
    *cause = 0;
    if (m->info) {
        sr_info_fit f;
        sr_info_fit_of(&m->info_m, est_info_data(m, data), &f);
        *model_fit = f.whiteness;
        *cause = f.model ? SR_EST_MISFIT_MODEL : f.scale ? SR_EST_MISFIT_THRUST
                 : f.noise ? SR_EST_MISFIT_NOISE : 0;
        return;
    }
    if (d->samples <= 0)
        return;
    const double *w = d->core.fit_win;
    double rho = 0.0;
    for (int g = 0; g < 2; g++)                 /* linear, angular rows */
        if (w[2 * g + 1] > 0.0) {
            double r = sqrt(w[2 * g] / w[2 * g + 1]);
            rho = r > rho ? r : rho;
        }
    *model_fit = rho;
    /* decided once the window holds its length of samples (the first seconds' residuals are
       the estimates settling) */
    *cause = noise_free(m) && d->samples >= window_samples(m) && rho > m->opt.fit_rho_max
                 ? SR_EST_MISFIT_MODEL : 0;
}

void est_fit_gate_flags(int misfit, int *identified)
{
    if (misfit)
        identified[0] = identified[1] = 0;
}

void est_fit_model_error_var(double k, const double *unit_var, double excess, double *var)
{
    double e = excess > 0.0 ? excess : 0.0;
    for (int i = 0; i < EST_NZ; i++)
        var[i] = k * k * unit_var[i] * e;
}
