/* The plant's excitation (plant.h): the multi-sine channels, the level's quintic ramp, the
 * change of rate through a dip of the level, and the references they make. */
#include <math.h>

#include "plant_internal.h"
#include "sr_math.h"

static const double PI = 3.141592653589793;          /* math.pi */

/* level s and its two derivatives at t of the ramp [s0, u, t0, T]: the quintic
 * s = s0 + (u - s0) p(x), p = 10 x^3 - 15 x^4 + 6 x^5, x = (t - t0) / T */
void plant_ramp_level(double t, const double *ramp, double *s)
{
    const double s0 = ramp[0], u = ramp[1], t0 = ramp[2], T = ramp[3];
    double x = (t - t0) / T, d, xm;
    if (x >= 1.0) {
        s[0] = u;
        s[1] = 0.0;
        s[2] = 0.0;
        return;
    }
    if (x <= 0.0)
        x = 0.0;
    d = u - s0;
    xm = 1.0 - x;
    s[0] = s0 + d * x * x * x * (10.0 + x * (6.0 * x - 15.0));
    s[1] = d * 30.0 * x * x * xm * xm / T;
    s[2] = d * 60.0 * x * xm * (1.0 - 2.0 * x) / (T * T);
}

/* the sines and cosines of both phases of every channel at t: trig[c] = [sin(w1 t + p1),
 * cos(w1 t + p1), sin(w2 t + p2), cos(w2 t + p2)] */
void plant_fill_trig(const sr_plant_model *md, const sr_plant_data *d, double t,
                      double (*trig)[4])
{
    int c;
    for (c = 0; c < md->n_ch; c++) {
        const double *row = d->ex_tab[c];
        sr_sincos(row[1] * t + row[2], &trig[c][0], &trig[c][1]);
        sr_sincos(row[3] * t + row[4], &trig[c][2], &trig[c][3]);
    }
}

/* d->trig advanced by h by the angle-addition formulas */
void plant_rotate_trig(const sr_plant_model *md, sr_plant_data *d)
{
    int c, j;
    for (c = 0; c < md->n_ch; c++)
        for (j = 0; j < 4; j += 2) {
            const double sn = d->trig[c][j], cs = d->trig[c][j + 1];
            const double ch = d->ex_rot[c][j], sh = d->ex_rot[c][j + 1];
            d->trig[c][j] = sn * ch + cs * sh;
            d->trig[c][j + 1] = cs * ch - sn * sh;
        }
}

/* channel c of the table, f = a/2 [sin(w1 t + p1) + sin(w2 t + p2)], f', f'', from its sines
 * trig (4) at t */
void plant_channel(const double *row, const double *trig, double *f)
{
    const double w1 = row[1], w2 = row[3], h = 0.5 * row[0];
    const double s1 = trig[0], c1 = trig[1], s2 = trig[2], c2 = trig[3];
    f[0] = h * (s1 + s2);
    f[1] = h * (w1 * c1 + w2 * c2);
    f[2] = -h * (w1 * w1 * s1 + w2 * w2 * s2);
}

/* s f and its first two time derivatives (product rule), s = (s, s', s''), f = (f, f', f'') */
void plant_level_times(const double *s, const double *f, double *out)
{
    out[0] = s[0] * f[0];
    out[1] = s[1] * f[0] + s[0] * f[1];
    out[2] = s[2] * f[0] + 2.0 * s[1] * f[1] + s[0] * f[2];
}

/* The excitation channels at `rate` times the excitation's frequencies into d->ex_tab,
 * d->ex_rot (spacerobot.robots.Excitation.channels of period / rate): two sines per channel
 * at frequencies in [w_f, 3 w_f), spread by the golden ratio and sqrt(2); the joint
 * amplitudes the largest keeping |q_ref - q_home| <= q_max, |qd_ref| <= qd_max,
 * |qdd_ref| <= qdd_max with the level's ramp included. */
void plant_excitation_table(const sr_plant_model *md, double rate, sr_plant_data *d)
{
    const sr_plant_excitation *ex = &md->ex;
    const double phi = (sqrt(5.0) - 1.0) / 2.0, sq2 = sqrt(2.0);
    const double wf = 2.0 * PI * rate / ex->period;
    const double S1 = 15.0 / 8.0 / ex->ramp, S2 = 10.0 / sqrt(3.0) / (ex->ramp * ex->ramp);
    int c;
    for (c = 0; c < md->n_ch; c++) {
        const int k = 2 * c + 1;
        const double w1 = wf * (1.0 + 2.0 * fmod(phi * k, 1.0));
        const double w2 = wf * (1.0 + 2.0 * fmod(phi * (k + 1), 1.0));
        const double p1 = 2.0 * PI * fmod(sq2 * k, 1.0);
        const double p2 = 2.0 * PI * fmod(sq2 * (k + 1), 1.0);
        double a;
        if (c < md->n_att) {
            a = ex->att_max;
        } else {
            const double qd = S1 + 0.5 * (w1 + w2);
            const double qdd = S2 + S1 * (w1 + w2) + 0.5 * (w1 * w1 + w2 * w2);
            const double a2 = ex->qd_max / qd, a3 = ex->qdd_max / qdd;
            a = ex->q_max;
            if (a2 < a)
                a = a2;
            if (a3 < a)
                a = a3;
        }
        d->ex_tab[c][0] = a;
        d->ex_tab[c][1] = w1;
        d->ex_tab[c][2] = p1;
        d->ex_tab[c][3] = w2;
        d->ex_tab[c][4] = p2;
        sr_sincos(w1 * md->h, &d->ex_rot[c][1], &d->ex_rot[c][0]);
        sr_sincos(w2 * md->h, &d->ex_rot[c][3], &d->ex_rot[c][2]);
    }
    d->ex_rate[1] = rate;
    d->trig_t = NAN;                       /* the cached sines were of the old table */
}

/* The level targeted now: the one requested, or 0 while a change of rate is pending; where
 * the level has settled at 0 the new rate takes over (its table) and the requested level is
 * targeted. A new target starts a ramp from the level in effect at d->t. */
void plant_excitation_update(const sr_plant_model *md, sr_plant_data *d)
{
    double s[3], target;
    plant_ramp_level(d->t, d->ramp, s);
    if (d->ex_rate[2] != d->ex_rate[1] && s[0] == 0.0 && s[1] == 0.0 && s[2] == 0.0)
        plant_excitation_table(md, d->ex_rate[2], d);
    target = d->ex_rate[2] != d->ex_rate[1] ? 0.0 : d->ex_rate[0];
    if (target == d->ramp[1])
        return;
    d->ramp[0] = s[0];
    d->ramp[1] = target;
    d->ramp[2] = d->t;
    d->ramp[3] = md->ex.ramp;
}

SR_API int sr_plant_set_excitation(const sr_plant_model *model, sr_plant_data *data,
                                   double level)
{
    if (!plant_model_ok(model) || data == NULL || !(level >= 0.0 && level <= 1.0))
        return SR_PLANT_EARG;
    data->ex_rate[0] = level;
    plant_excitation_update(model, data);
    return SR_PLANT_OK;
}

SR_API int sr_plant_set_excitation_rate(const sr_plant_model *model, sr_plant_data *data,
                                        double rate)
{
    if (!plant_model_ok(model) || data == NULL
        || !(rate >= SR_PLANT_RATE_MIN && rate <= SR_PLANT_RATE_MAX))
        return SR_PLANT_EARG;
    data->ex_rate[2] = rate;
    plant_excitation_update(model, data);
    return SR_PLANT_OK;
}

SR_API int sr_plant_excitation_rate(const sr_plant_model *model, const sr_plant_data *data,
                                    double *rate)
{
    if (!plant_model_ok(model) || data == NULL || rate == NULL)
        return SR_PLANT_EARG;
    rate[0] = data->ex_rate[1];
    rate[1] = data->ex_rate[2];
    return SR_PLANT_OK;
}

SR_API int sr_plant_excitation_level(const sr_plant_model *model, const sr_plant_data *data,
                                     double *s)
{
    if (!plant_model_ok(model) || data == NULL || s == NULL)
        return SR_PLANT_EARG;
    plant_ramp_level(data->t, data->ramp, s);
    return SR_PLANT_OK;
}

SR_API int sr_plant_references(const sr_plant_model *model, const sr_plant_data *data,
                               double *ref)
{
    double lev[3], f[3], trig[SR_PLANT_MAX_CHANNELS][4];
    int c;
    if (!plant_model_ok(model) || data == NULL || ref == NULL)
        return SR_PLANT_EARG;
    plant_ramp_level(data->t, data->ramp, lev);
    plant_fill_trig(model, data, data->t, trig);
    for (c = 0; c < model->n_ch; c++) {
        plant_channel(data->ex_tab[c], trig[c], f);
        plant_level_times(lev, f, ref + 3 * c);
    }
    return SR_PLANT_OK;
}
