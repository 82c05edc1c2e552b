/* The estimator's choice of the excitation's rate (excite_design.h). */
#include "excite_design.h"

#include "physical.h"

#include <math.h>
#include <string.h>

#define MU SR_INFO_MAX_U

void sr_exd_init(sr_exd_data *x)
{
    if (!x)
        return;
    memset(x, 0, sizeof *x);
    x->phase = SR_EXD_WAIT;
    x->rate = 1.0;
    x->t_first = NAN;
}

/* the predicted largest scaled bound (bound / error scale at the filter's estimate, over the
 * estimates o identifies) of S(fd) + factor dS; NaN where the prediction fails */
static double predicted(const sr_exd_options *o, const sr_info_model *im,
                        const sr_info_data *fd, const double *dS, double factor,
                        sr_info_work *w)
{
    double vec[20], bound[20], scale[20], worst = 0.0;
    if (sr_info_estimate(im, fd, 2, vec, bound, NULL) != 0 ||
        sr_info_predict(im, fd, dS, factor, bound, w) != 0)
        return NAN;
    sr_error_scale(vec, SR_COM_SCALE_MIN, scale);
    /* (a planar robot's out-of-plane entries move with the identified ones through the
       parallel axes, bound > 0, but keep their guesses) */
    for (int i = 0; i < 20; i++)
        if (o->identified[i] && bound[i] > 0.0 && bound[i] / scale[i] > worst)
            worst = bound[i] / scale[i];
    return isfinite(worst) ? worst : NAN;
}

/* dS = S(fd) - S_mark (the information the window added) */
static void added(const sr_info_model *im, const sr_info_data *fd, const double *S_mark,
                  double *dS)
{
    int nu = im->nu;
    sr_info_information(im, fd, dS);
    for (int p = 0; p < nu; p++)
        for (int q = 0; q < nu; q++)
            dS[p * MU + q] -= S_mark[p * MU + q];
}

int sr_exd_reads_wanted(const sr_exd_options *o, const sr_exd_data *x, double t)
{
    return o && x && x->phase == SR_EXD_MEASURE && !(t - x->t_mark < o->window);
}

int sr_exd_step(const sr_exd_options *o, sr_exd_data *x, const sr_info_model *im,
                const sr_info_data *fd, double t, int wanted, sr_exd_work *w)
{
    if (!o || !x || !im || !fd || !w || !isfinite(t))
        return 1;
    switch (x->phase) {
    case SR_EXD_WAIT:
        if (isnan(x->t_first))                    /* no sample yet */
            x->t_first = t;
        if (fd->replayed) {
            if (t + 2.0 * o->window + o->settle >= x->t_first + o->horizon) {
                x->phase = SR_EXD_DONE;           /* the trial would not end in time */
                return 0;
            }
            sr_info_information(im, fd, x->S_mark);
            x->t_mark = t;
            x->phase = SR_EXD_MEASURE;
        }
        return 0;
    case SR_EXD_MEASURE:
        if (t - x->t_mark < o->window)
            return 0;
        added(im, fd, x->S_mark, x->dS);
        x->w_slow = t - x->t_mark;
        if (!wanted) {                            /* no excitation wanted: nothing to choose */
            x->phase = SR_EXD_DONE;
            return 0;
        }
        x->rate = o->rate;                        /* try the candidate */
        x->t_mark = t;
        x->phase = SR_EXD_SETTLE;
        return 0;
    case SR_EXD_SETTLE:
        if (t - x->t_mark < o->settle)
            return 0;
        sr_info_information(im, fd, x->S_mark);
        x->t_mark = t;
        x->phase = SR_EXD_MEASURE_FAST;
        return 0;
    case SR_EXD_MEASURE_FAST: {
        if (t - x->t_mark < o->window)
            return 0;
        double *dS_fast = w->dS_fast, left = x->t_first + o->horizon - t;
        added(im, fd, x->S_mark, dS_fast);
        if (left < 0.0)
            left = 0.0;
        /* each rate's bound at the horizon if the rest of the run added what its window did;
         * back at rate 1 after one more settle */
        double back = left - o->settle > 0.0 ? left - o->settle : 0.0;
        x->score[0] = predicted(o, im, fd, x->dS, back / x->w_slow, &w->info);
        x->score[1] = predicted(o, im, fd, dS_fast, left / (t - x->t_mark), &w->info);
        x->phase = SR_EXD_DONE;
        if (!isfinite(x->score[0]) || !isfinite(x->score[1])) {
            x->score[0] = x->score[1] = 0.0;     /* no prediction: the rate stays 1 */
            x->rate = 1.0;
            return 1;
        }
        x->rate = x->score[1] < SR_EXD_MARGIN * x->score[0] ? o->rate : 1.0;
        return 0;
    }
    default:
        return 0;
    }
}

int sr_exd_data_valid(const sr_exd_options *o, const sr_exd_data *x)
{
    if (!o || !x || x->phase < SR_EXD_WAIT || x->phase > SR_EXD_DONE)
        return 0;
    if (!(x->rate == 1.0 || x->rate == o->rate))
        return 0;
    if (isnan(x->t_first) && x->phase != SR_EXD_WAIT)   /* NaN only before a sample */
        return 0;
    double s = x->t_mark + x->w_slow + x->score[0] + x->score[1]
               + (isnan(x->t_first) ? 0.0 : x->t_first);
    for (int i = 0; i < MU * MU; i++)
        s += x->S_mark[i] + x->dS[i];
    return isfinite(s);
}
