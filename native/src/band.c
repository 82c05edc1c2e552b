/* The rigid band (band.h): the information filter's rows through a causal Butterworth low-pass
 * below the modes, with the quasi-static compliance columns or the found modes' own, solved
 * every SR_BAND_SOLVE_EVERY rows. */
#include <math.h>
#include <string.h>

#include "band.h"
#include "info_internal.h"
#include "linalg.h"
#include "sr_math.h"
#include "standard_params.h"

#define TWO_PI 6.283185307179586
#define PI 3.141592653589793

/* the compliance's filters [Hz, damping]: quasi-static below about a quarter of their
   frequency; the second, with the first, separates their damping's term (2 zeta u' / w^3) */
static const double QS[SR_BAND_NQS][2] = {{2.0, 0.7}, {1.0, 0.7}};

static size_t align8(size_t x) { return (x + 7) & ~(size_t)7; }

/* -- the layout ----------------------------------------------------------------------------- */

/* after the head: all filters' columns' [R] (nc x nc, compact; not kept with one filter in
   use), the low-pass's (nl x nl), the first filter's columns' alone (n1 x n1), the
   errors-in-variables sums N_HH (nu x nu) and N_Hy (nu), the first sample's rows (nr x nc),
   the low-pass's states (2 per section and row entry) */
static double *Rc_of(void *data) { return (double *)((char *)data + align8(sizeof(sr_band_data))); }
static double *Rl_of(const sr_band_model *b, void *data)
{
    return Rc_of(data) + (size_t)b->nc * (size_t)b->nc;
}
static double *R1_of(const sr_band_model *b, void *data)
{
    return Rl_of(b, data) + (size_t)b->nl * (size_t)b->nl;
}
static double *NHH_of(const sr_band_model *b, void *data)
{
    return R1_of(b, data) + (size_t)b->n1 * (size_t)b->n1;
}
static double *NHy_of(const sr_band_model *b, const sr_info_model *im, void *data)
{
    return NHH_of(b, data) + (size_t)im->nu * (size_t)im->nu;
}
static double *Z0_of(const sr_band_model *b, const sr_info_model *im, void *data)
{
    return NHy_of(b, im, data) + im->nu;
}
static double *states_of(const sr_band_model *b, const sr_info_model *im, void *data)
{
    return Z0_of(b, im, data) + (size_t)im->nr * (size_t)b->nc;
}

size_t sr_band_data_size(const sr_band_model *b, const sr_info_model *im)
{
    if (!b || !im)
        return 0;
    size_t nu = (size_t)im->nu, row = (size_t)im->nr * (size_t)b->nc;
    return align8(sizeof(sr_band_data))
           + sizeof(double) * ((size_t)b->nc * b->nc + (size_t)b->nl * b->nl
                               + (size_t)b->n1 * b->n1 + nu * nu + nu
                               + row * (1 + 2 * SR_BAND_NSOS));
}

size_t sr_band_model_size(void) { return sizeof(sr_band_model); }
size_t sr_band_work_size(void) { return sizeof(sr_band_work); }

/* -- the model: the low-pass --------------------------------------------------------------- */

/* y = the cascade's output for x, its states s (2 per section, for nx entries; entry i's at
   s[2 (k nx + i)]) advanced (transposed direct form II) */
static void low_pass(const sr_band_model *b, int nx, const double *x, double *s, double *y)
{
    for (int i = 0; i < nx; i++)
        y[i] = x[i];
    for (int k = 0; k < SR_BAND_NSOS; k++) {
        const double *c = b->sos[k];
        double *sk = s + 2 * (size_t)k * nx;
        for (int i = 0; i < nx; i++) {
            double in = y[i], out = c[0] * in + sk[2 * i];
            sk[2 * i] = c[1] * in - c[3] * out + sk[2 * i + 1];
            sk[2 * i + 1] = c[2] * in - c[4] * out;
            y[i] = out;
        }
    }
}

/* the model with nq filters of cols columns each (modes: their frequencies per Data block) */
static int model_init(sr_band_model *b, const sr_info_model *im, double dt, int nq, int cols,
                      int modes)
{
    if (!b || !im || !(dt >= SR_BAND_DT_MIN && dt <= SR_BAND_DT_MAX))
        return 1;
    memset(b, 0, sizeof *b);
    /* Butterworth (scipy.signal.butter(order, fc, fs=1 / dt)): the analog prototype's poles
       s_k = exp(i pi (2 k + N + 1) / (2 N)) at the prewarped cut-off wc = 2 fs tan(pi fc / fs),
       mapped by the bilinear transform z = (2 fs + p) / (2 fs - p); one section per conjugate
       pair, its two zeros at z = -1 and its gain 1 at DC */
    double fs = 1.0 / dt, arg = PI * SR_BAND_FC * dt;
    double wc = 2.0 * fs * sr_sin(arg) / sr_cos(arg);
    for (int k = 0; k < SR_BAND_NSOS; k++) {
        double th = PI * (2.0 * k + SR_BAND_ORDER + 1.0) / (2.0 * SR_BAND_ORDER);
        double pr = wc * sr_cos(th), pim = wc * sr_sin(th);       /* p = pr + i pim */
        double nr = 2.0 * fs + pr, dr = 2.0 * fs - pr, den = dr * dr + pim * pim;
        double zr = (nr * dr - pim * pim) / den, zi = (nr * pim + pim * dr) / den;
        double a1 = -2.0 * zr, a2 = zr * zr + zi * zi, g = (1.0 + a1 + a2) / 4.0;
        double *c = b->sos[k];
        c[0] = g;
        c[1] = 2.0 * g;
        c[2] = g;
        c[3] = a1;
        c[4] = a2;
    }
    /* the white-noise gain: its impulse response's squares over 40 / fc s (it has decayed
       by more than 1e-9 of its peak there) */
    double st[2 * SR_BAND_NSOS] = {0.0}, x = 1.0, y, g = 0.0;
    long n = lround(40.0 / SR_BAND_FC / dt);
    for (long k = 0; k < n; k++, x = 0.0) {
        low_pass(b, 1, &x, st, &y);
        g += y * y;
    }
    b->gain = g;
    b->settle = (int)lround(SR_BAND_SETTLE / SR_BAND_FC / dt);
    b->dt = dt;
    b->nq = nq;
    b->cols = cols;
    b->modes = modes;
    b->nm = nq * cols;
    b->nl = im->nu + 1;
    b->nc = b->nm + b->nl;
    b->n1 = cols + b->nl;
    return 0;
}

int sr_band_model_init(sr_band_model *b, const sr_info_model *im, double dt)
{
    return model_init(b, im, dt, SR_BAND_NQS, EST_MODAL_GC_COLS, 0);
}

int sr_band_model_init_modes(sr_band_model *b, const sr_info_model *im, double dt)
{
    return model_init(b, im, dt, SR_BAND_MAX_MODES, EST_MODAL_COLS, 1);
}

/* the filters in use (the state's count, clamped to the model's: sr_band_add does not check
   the state) */
static int in_use(const sr_band_model *b, const sr_band_data *s)
{
    return s->nf < 0 ? 0 : s->nf > b->nq ? b->nq : s->nf;
}

/* the unknowns in use of the rows [M | H | y] (all: the filters in use's columns and the
   filter's) and [M1 | H | y] (first: the first filter's alone, where it is in use) */
static int unknowns(const sr_band_model *b, const sr_info_model *im, const sr_band_data *s,
                    int first)
{
    int nf = in_use(b, s);
    return (first ? (nf > 0) : nf) * b->cols + im->nu;
}

/* -- the state ------------------------------------------------------------------------------ */

void sr_band_data_init(const sr_band_model *b, const sr_info_model *im, void *data)
{
    if (!b || !im || !data)
        return;
    sr_band_data *s = (sr_band_data *)data;
    memset(s, 0, sizeof *s);
    if (!b->modes) {
        s->nf = SR_BAND_NQS;
        for (int g = 0; g < SR_BAND_NQS; g++) {
            s->f[g].w = TWO_PI * QS[g][0];
            s->f[g].zeta = QS[g][1];
        }
    }
    /* the square-root informations at the prior: the filter's unknowns at its prior
       (information prior_sqrt^2 about u0), the columns' at 0 with SR_BAND_PRIOR_INFO */
    int nu = im->nu, nm = b->nm, nc = b->nc, nl = b->nl, n1 = b->n1, m1 = n1 - nl;
    double *Rc = Rc_of(data), *Rl = Rl_of(b, data), *R1 = R1_of(b, data);
    memset(Rc, 0, sizeof(double) * (size_t)nc * nc);
    memset(Rl, 0, sizeof(double) * (size_t)nl * nl);
    memset(R1, 0, sizeof(double) * (size_t)n1 * n1);
    for (int i = 0; i < nm; i++)
        Rc[i * nc + i] = sqrt(SR_BAND_PRIOR_INFO);
    for (int i = 0; i < m1; i++)
        R1[i * n1 + i] = sqrt(SR_BAND_PRIOR_INFO);
    for (int j = 0; j < nu; j++) {
        Rc[(nm + j) * nc + nm + j] = Rl[j * nl + j] = R1[(m1 + j) * n1 + m1 + j]
            = im->prior_sqrt[j];
        Rc[(nm + j) * nc + nc - 1] = Rl[j * nl + nl - 1] = R1[(m1 + j) * n1 + n1 - 1]
            = im->prior_sqrt[j] * im->u0[j];
    }
    memset(NHH_of(b, data), 0, sizeof(double) * ((size_t)nu * nu + nu
                                                  + (size_t)im->nr * nc * (1 + 2 * SR_BAND_NSOS)));
}

int sr_band_data_init_modes(const sr_band_model *b, const sr_info_model *im, void *data,
                            int nf, const double *f_hz, const double *zeta)
{
    if (!b || !im || !data || !f_hz || !zeta || !b->modes || nf < 1 || nf > b->nq)
        return 1;
    for (int g = 0; g < nf; g++)
        if (!(f_hz[g] > 0.0 && isfinite(f_hz[g]) && zeta[g] > 0.0 && zeta[g] <= 1.0)
            || (g > 0 && !(f_hz[g] >= f_hz[g - 1])))
            return 1;
    sr_band_data_init(b, im, data);
    sr_band_data *s = (sr_band_data *)data;
    s->nf = nf;
    for (int g = 0; g < nf; g++) {
        s->f[g].w = TWO_PI * f_hz[g];
        s->f[g].zeta = zeta[g];
    }
    return 0;
}

/* 1 where the filters in use are the model's: the compliance's fixed ones, or modes in range
   (ascending) and the rest unused (zero) */
static int filters_valid(const sr_band_model *b, const sr_band_data *s)
{
    if (!b->modes) {
        if (s->nf != SR_BAND_NQS)
            return 0;
        for (int g = 0; g < SR_BAND_NQS; g++)
            if (s->f[g].w != TWO_PI * QS[g][0] || s->f[g].zeta != QS[g][1])
                return 0;
        return 1;
    }
    if (s->nf < 0 || s->nf > b->nq)
        return 0;
    for (int g = 0; g < SR_BAND_MAX_F; g++) {
        const est_modal_filter *f = &s->f[g];
        if (g < s->nf ? !(f->w > 0.0 && f->zeta > 0.0 && f->zeta <= 1.0
                          && (g == 0 || f->w >= s->f[g - 1].w))
                      : f->w != 0.0 || f->zeta != 0.0)
            return 0;
    }
    return 1;
}

int sr_band_data_valid(const sr_band_model *b, const sr_info_model *im, const void *data)
{
    if (!b || !im || !data)
        return 0;
    const sr_band_data *s = (const sr_band_data *)data;
    int most = s->added > b->settle ? s->added - b->settle : 0;    /* rows the samples give */
    if (s->added < 0 || s->used < 0 || s->used > most || s->pick < SR_BAND_NONE
        || s->pick > SR_BAND_COMPLIANCE || !filters_valid(b, s)
        || (s->pick != SR_BAND_NONE && (double)s->used * im->nr <= 2.0 * unknowns(b, im, s, 0)))
        return 0;
    double sum = s->t_prev;
    for (int i = 0; i < SR_THRUST_LEN; i++)
        sum += s->K[i];
    for (int i = 0; i < EST_MODAL_U; i++)
        sum += s->u_prev[i];
    for (int g = 0; g < SR_BAND_MAX_F; g++)
        for (int i = 0; i < EST_MODAL_U; i++)
            sum += s->f[g].eta[i] + s->f[g].etad[i];
    for (int v = 0; v < 3; v++) {
        sum += s->var[v].chi2 + s->var[v].dof;
        for (int i = 0; i < 20; i++)
            sum += s->var[v].vec[i] + s->var[v].bound[i];
    }
    return isfinite(sum);
}

/* -- one sample ----------------------------------------------------------------------------- */

/* The sample's rows [M | H | y] (nr x nc) into w->row at z (standard form; the columns of
   filters not in use zero), its thrust integrals into K, its drive into u and the filters in
   use stepped into f; where it
   is used (from the low-pass's start on) its weight into W and its errors-in-variables
   products into N_HH (MU stride), N_Hy (else zero). Nothing of the state written: 0, or 1
   where any of them is not finite. */
static int sample_rows(const sr_band_model *b, const sr_info_model *im, const void *data,
                       double t, const double *x, const double *z, double *K, double *u,
                       est_modal_filter *f, double *W, double *N_Hy, sr_band_work *w)
{
    const sr_band_data *s = (const sr_band_data *)data;
    int nr = im->nr, nu = im->nu, nm = b->nm, nc = b->nc;
    double sig[EST_MODAL_SIG], *N_HH = w->info.N_HH;
    static const double me_none[2] = {0.0, 0.0}, origin[3] = {0.0, 0.0, 0.0};
    memcpy(K, s->K, sizeof(double) * SR_THRUST_LEN);
    sr_thrust_integrals_add(K, s->added == 0, t, x + SR_X_R_S, x + SR_X_F(im->n),
                            x + SR_X_M(im->n));
    info_sample_rows(im, x, K, z, w->hy);
    memset(N_HH, 0, sizeof w->info.N_HH);
    memset(N_Hy, 0, sizeof(double) * SR_INFO_MAX_U);
    memset(W, 0, sizeof(double) * (size_t)(nr * nr));
    if (s->added >= b->settle) {
        if (info_sample_weight(im, x, K, z, me_none, w->hy, W, w->xs, &w->info) != 0)
            return 1;
        info_eiv_sample(im, x, K, w->hy, W, w->xs, &w->info, N_HH, N_Hy);
    }
    /* the filters, at rest at the first sample */
    int nf = in_use(b, s), cols = b->cols;
    memcpy(f, s->f, sizeof s->f);
    est_modal_signals(t, x, sig);
    if (s->added > 0)
        for (int g = 0; g < nf; g++)
            est_modal_filter_step(&f[g], t - s->t_prev, s->u_prev, sig + 1);
    for (int a = 0; a < nr; a++)
        memset(w->row + a * nc, 0, sizeof(double) * (size_t)nm);
    for (int g = 0; g < nf; g++) {
        est_modal_columns(f[g].eta, f[g].etad, sig, origin, cols, w->cols);
        for (int a = 0; a < nr; a++)            /* the filter's rows of the 6 */
            memcpy(w->row + a * nc + g * cols, w->cols + im->rows[a] * cols,
                   sizeof(double) * (size_t)cols);
    }
    for (int a = 0; a < nr; a++)
        memcpy(w->row + a * nc + nm, w->hy + a * HS, sizeof(double) * (size_t)(nu + 1));
    double sum = 0.0;
    for (int i = 0; i < nr * nc; i++)
        sum += w->row[i];
    for (int p = 0; p < nu; p++) {
        sum += N_Hy[p];
        for (int q = 0; q < nu; q++)
            sum += N_HH[p * SR_INFO_MAX_U + q];
    }
    for (int i = 0; i < nr * nr; i++)
        sum += W[i];
    for (int g = 0; g < nf; g++)
        for (int i = 0; i < EST_MODAL_U; i++)
            sum += f[g].eta[i] + f[g].etad[i];
    memcpy(u, sig + 1, sizeof(double) * EST_MODAL_U);
    for (int i = 0; i < EST_MODAL_U; i++)
        sum += u[i];
    for (int i = 0; i < SR_THRUST_LEN; i++)
        sum += K[i];
    return isfinite(sum) ? 0 : 1;
}

/* The sample's low-passed rows Zf (nr x nc, in w->row), weighted by W, into the three
   informations (not where the weighted rows are not finite: an overflow). 1 where added. */
static int informations_add(const sr_band_model *b, const sr_info_model *im, void *data,
                             const double *W, sr_band_work *w)
{
    int nr = im->nr, nc = b->nc, nm = b->nm, nl = b->nl, n1 = b->n1, m1 = n1 - nl;
    double *Z = w->row, *WZ = w->wrow;
    info_weigh(W, nr, Z, nc, nc, WZ);
    double sum = 0.0;
    for (int i = 0; i < nr * nc; i++)
        sum += WZ[i];
    if (!isfinite(sum))
        return 0;
    /* the first filter's columns' rows [M1 | H | y] and the low-pass's [H | y] (in Z, no
       longer needed: nr (n1 + nl) <= nr nc) */
    double *Z1 = Z, *Zl = Z + nr * n1;
    for (int a = 0; a < nr; a++) {
        memcpy(Z1 + a * n1, WZ + a * nc, sizeof(double) * (size_t)m1);
        memcpy(Z1 + a * n1 + m1, WZ + a * nc + nm, sizeof(double) * (size_t)nl);
        memcpy(Zl + a * nl, WZ + a * nc + nm, sizeof(double) * (size_t)nl);
    }
    sr_band_data *s = (sr_band_data *)data;
    if (in_use(b, s) > 1)  /* (one filter in use: all filters' rows are the first's alone) */
        sr_qr_add_rows(Rc_of(data), nc, NULL, nc, WZ, nc, nr);  /* the rhs its last column */
    sr_qr_add_rows(R1_of(b, data), n1, NULL, n1, Z1, n1, nr);
    sr_qr_add_rows(Rl_of(b, data), nl, NULL, nl, Zl, nl, nr);
    if (s->used < s->added - b->settle)        /* (added saturates: so does it) */
        s->used++;
    return 1;
}

int sr_band_add(const sr_band_model *b, const sr_info_model *im, void *data, double t,
                const double *x, const double *z_lin, sr_band_work *w)
{
    if (!b || !im || !data || !x || !z_lin || !w || !(z_lin[0] > 0.0) || !(z_lin[10] > 0.0))
        return 1;
    sr_band_data *s = (sr_band_data *)data;
    if (!isfinite(t) || (s->added > 0 && !(t > s->t_prev)))
        return 1;
    int nr = im->nr, nu = im->nu, len = nr * b->nc;
    double z[20], W[36], K[SR_THRUST_LEN], N_Hy[SR_INFO_MAX_U], u[EST_MODAL_U];
    est_modal_filter f[SR_BAND_MAX_F];
    sr_standard_of_reported(z_lin, z);
    if (sample_rows(b, im, data, t, x, z, K, u, f, W, N_Hy, w) != 0)
        return 1;
    /* commit: the sums, the integrals, the filters, then the low-pass (from rest at the
       first sample's rows: it filters their difference to those) */
    double *NHH = NHH_of(b, data), *NHy = NHy_of(b, im, data), *Z0 = Z0_of(b, im, data);
    for (int p = 0; p < nu; p++) {
        NHy[p] += N_Hy[p];
        for (int q = 0; q < nu; q++)
            NHH[p * nu + q] += w->info.N_HH[p * SR_INFO_MAX_U + q];
    }
    memcpy(s->K, K, sizeof K);
    memcpy(s->f, f, sizeof f);
    memcpy(s->u_prev, u, sizeof s->u_prev);
    s->t_prev = t;
    if (s->added == 0)
        memcpy(Z0, w->row, sizeof(double) * (size_t)len);
    for (int i = 0; i < len; i++)
        w->low[i] = w->row[i] - Z0[i];
    low_pass(b, len, w->low, states_of(b, im, data), w->row);
    for (int i = 0; i < len; i++)
        w->row[i] += Z0[i];
    int used = s->added >= b->settle;
    if (s->added < 2147483647)
        s->added++;
    if (!used)
        return 0;
    if (informations_add(b, im, data, W, w) && s->used % SR_BAND_SOLVE_EVERY == 0)
        sr_band_solve(b, im, data, w);      /* (a skipped row solves nothing again) */
    return 0;
}

/* -- the solve ------------------------------------------------------------------------------ */

/* One variant's answer from its [R] (n x n compact; the filter's unknowns' block at columns
   off .. off + nu - 1, the columns' before it, the right-hand side last; k of its unknowns in
   use, the rest the zero columns of filters not in use): the unknowns u compensated by comp
   times the sums, the reported vec and bound (20), the data rows' chi2 at u (the prior rows'
   share taken off) and its degrees of freedom. 0, or 1 where not finite. */
static int solve_variant(const sr_band_model *b, const sr_info_model *im, void *data,
                         const double *R, int n, int off, int k, double comp, sr_band_work *w,
                         double *vec, double *bound, double *chi2, double *dof)
{
    int nu = im->nu, rhs = n - 1;
    const double *NHH = NHH_of(b, data), *NHy = NHy_of(b, im, data);
    double u[SR_INFO_MAX_U] = {0}, Ny[SR_INFO_MAX_U] = {0}, dv[SR_INFO_MAX_U] = {0};
    memset(w->R, 0, sizeof w->R);
    memset(w->N, 0, sizeof w->N);
    for (int i = 0; i < nu; i++) {
        for (int j = 0; j < nu; j++) {
            w->R[i * SR_INFO_MAX_U + j] = R[(off + i) * n + off + j];
            w->N[i * SR_INFO_MAX_U + j] = comp * NHH[i * nu + j];
        }
        dv[i] = R[(off + i) * n + rhs];
        Ny[i] = comp * NHy[i];
    }
    /* M eliminated: for any u its best M makes its own rows' residual 0, so u solves the last
       block's compensated normal equations (S - cN) u = s - c n_y */
    info_solve_square_root(nu, w->R, dv, w->N, Ny, 2, u, w->Ri);
    /* the residual at u: the last block's and the tail's, less the prior rows' (u about u0;
       M about 0, M = R11^-1 (d1 - R12 u) by back substitution) */
    double rss = R[rhs * n + rhs] * R[rhs * n + rhs];
    for (int i = 0; i < nu; i++) {
        double r = -dv[i];
        for (int j = i; j < nu; j++)
            r += w->R[i * SR_INFO_MAX_U + j] * u[j];
        double p = im->prior_sqrt[i] * (u[i] - im->u0[i]);
        rss += r * r - p * p;
    }
    for (int i = off - 1; i >= 0; i--) {
        double s = R[i * n + rhs];
        for (int j = 0; j < nu; j++)
            s -= R[i * n + off + j] * u[j];
        for (int j = i + 1; j < off; j++)
            s -= R[i * n + j] * w->mvec[j];
        w->mvec[i] = s / R[i * n + i];
        rss -= SR_BAND_PRIOR_INFO * w->mvec[i] * w->mvec[i];
    }
    *dof = (double)((const sr_band_data *)data)->used * im->nr - k;
    *chi2 = *dof > 0.0 ? rss / *dof : NAN;
    info_reported_of_u(im, u, vec);
    int ok = info_bound_with(im, nu, w->Ri, NULL, u, bound) == 0 && isfinite(*chi2);
    for (int i = 0; i < 20; i++)
        ok = ok && isfinite(vec[i]);
    return ok ? 0 : 1;
}

void sr_band_solve(const sr_band_model *b, const sr_info_model *im, void *data,
                   sr_band_work *w)
{
    if (!b || !im || !data || !w)
        return;
    sr_band_data *s = (sr_band_data *)data;
    int k = unknowns(b, im, s, 0), k1 = unknowns(b, im, s, 1);
    if ((double)s->used * im->nr <= 2.0 * k)            /* the unknowns in use twice */
        return;
    /* the sums are the used samples': the low-passed noise's products are the gain times
       theirs */
    double comp = b->gain;
    sr_band_variant_answer a[3];                /* the low-pass, all filters', the first's */
    if (solve_variant(b, im, data, Rl_of(b, data), b->nl, 0, im->nu, comp, w, a[0].vec,
                      a[0].bound, &a[0].chi2, &a[0].dof) != 0
        || solve_variant(b, im, data, R1_of(b, data), b->n1, b->n1 - b->nl, k1, comp, w,
                         a[2].vec, a[2].bound, &a[2].chi2, &a[2].dof) != 0)
        return;
    if (in_use(b, s) <= 1)                      /* (informations_add: [R] not kept) */
        a[1] = a[2];
    else if (solve_variant(b, im, data, Rc_of(data), b->nc, b->nm, k, comp, w, a[1].vec,
                           a[1].bound, &a[1].chi2, &a[1].dof) != 0)
        return;
    memcpy(s->var, a, sizeof a);
    s->pick = a[1].chi2 < SR_BAND_CHI2_DROP * a[0].chi2 ? SR_BAND_COMPLIANCE : SR_BAND_LOWPASS;
}

int sr_band_answer(const sr_band_model *b, const void *data, double *vec, double *bound,
                   double *alt, double *chi2, double *dof)
{
    if (!b || !data)
        return SR_BAND_NONE;
    const sr_band_data *s = (const sr_band_data *)data;
    if (s->pick != SR_BAND_LOWPASS && s->pick != SR_BAND_COMPLIANCE)
        return SR_BAND_NONE;                    /* (none yet, or a corrupt block) */
    /* the alternative: the columns of the first filter alone beside all filters' (what
       the compliance's second order changes; the lowest mode alone beside all found
       modes': what a spurious mode changes), all filters' columns beside the low-pass */
    int c = s->pick == SR_BAND_COMPLIANCE;
    const sr_band_variant_answer *p = &s->var[s->pick - 1], *q = &s->var[c ? 2 : 1];
    if (vec)
        memcpy(vec, p->vec, sizeof p->vec);
    if (bound)
        memcpy(bound, p->bound, sizeof p->bound);
    if (alt)
        memcpy(alt, q->vec, sizeof q->vec);
    if (chi2) {
        chi2[0] = s->var[0].chi2;
        chi2[1] = s->var[1].chi2;
    }
    if (dof)
        *dof = p->dof;
    return s->pick;
}

int sr_band_variant(const sr_band_model *b, const void *data, int which,
                    sr_band_variant_answer *a)
{
    if (!b || !data || !a || which < SR_BAND_LOWPASS || which > SR_BAND_FIRST)
        return 1;
    const sr_band_data *s = (const sr_band_data *)data;
    if (s->pick != SR_BAND_LOWPASS && s->pick != SR_BAND_COMPLIANCE)
        return 1;
    *a = s->var[which - 1];
    return 0;
}
