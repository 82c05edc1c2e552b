/* The modal columns' stage of the estimator (est_modal.h): the modes' filters driven by the
 * measured base motion, their momentum columns beside the rigid rows, the square-root
 * information solve of both, the kept samples and the search of the modes' frequencies. */
#include "est_modal.h"

#include <limits.h>
#include <math.h>
#include <string.h>

#include "est_consider.h"
#include "est_corr.h"
#include "est_eiv.h"
#include "est_joint.h"
#include "est_rls.h"
#include "linalg.h"
#include "sr_math.h"
#include "standard_params.h"

/* the search: a geometric grid of EST_MODAL_GRID frequencies from EST_MODAL_F_LO to
 * EST_MODAL_F_HI [Hz] at damping EST_MODAL_ZETA0, Nelder-Mead evaluations per mode, the gain a
 * mode must bring (fraction of the residual), the relative residual below which the rigid model
 * fits (no search), the first search's time after the reference [s] (then at each doubling),
 * the samples the scan reads at most (every k-th kept sample) */
#define EST_MODAL_GRID 25
#define EST_MODAL_F_LO 0.1
#define EST_MODAL_F_HI 1.5
#define EST_MODAL_ZETA0 0.02
/* the bounds of a mode (the refinement's): frequency from EST_MODAL_F_MIN to
 * SR_EST_MAX_MODE_F [Hz] (below, a mode's columns mimic the rigid body's), damping */
#define EST_MODAL_F_MIN SR_EST_MIN_MODE_F
#define EST_MODAL_ZETA_MIN 1e-4
#define EST_MODAL_ZETA_MAX 0.5
/* the modes are kept (no replay) where a search moved none by more than this (relative; the
 * damping 100 times this) */
#define EST_MODAL_KEEP 1e-3
#define EST_MODAL_NM_EVALS 30
#define EST_MODAL_MIN_GAIN 0.3
#define EST_MODAL_FIT_FLOOR 1e-6
#define EST_MODAL_FIRST_SEARCH 60.0
#define EST_MODAL_SCAN_SAMPLES 300
/* the prior information of a modal unknown (weak: the data decide), SI units */
#define EST_MODAL_PRIOR_INFO 1e-12
#define TWO_PI 6.283185307179586

static size_t align8(size_t x) { return (x + 7) & ~(size_t)7; }

static int n_max(const sr_estimator_model *m) { return EST_MODAL_MAX_F * EST_MODAL_COLS + m->q; }

/* the right-hand sides of a row: yy, then with the thrust's consider term its consider
 * right-hand sides (SR_N_CONSIDER: the row's derivatives in the thrust's errors c) */
static int n_rhs(const sr_estimator_model *m) { return 1 + (m->consider ? SR_N_CONSIDER : 0); }

int est_modal_slot(const sr_estimator_model *m)
{
    return EST_MODAL_SIG + (m->k1 + m->k2) * (m->q + n_rhs(m)) + 1;
}

/* the filters' states of one sample (eta, eta' per drive channel, per frequency) */
#define EST_MODAL_STATES (2 * EST_MODAL_U * EST_MODAL_MAX_F)
/* a window ring's entry: the sample's index, its signals, the filters' states after it */
#define EST_MODAL_RING_SLOT (1 + EST_MODAL_SIG + EST_MODAL_STATES)

/* entries of the search's ring of filter states (the window's reach within the kept
 * samples and the reference) */
static int scan_ring_cap(const sr_estimator_model *m)
{
    return m->win_cap < EST_MODAL_MAX_SAMPLES + 1 ? m->win_cap : EST_MODAL_MAX_SAMPLES + 1;
}

size_t est_modal_size(const sr_estimator_model *m)
{
    if (!m->modes)
        return 0;
    size_t nm = (size_t)n_max(m);
    return align8(sizeof(est_modal_data))
           + sizeof(double) * (nm * nm + nm * (size_t)n_rhs(m)
                               + (size_t)EST_MODAL_MAX_SAMPLES * est_modal_slot(m)
                               + (m->window ? (size_t)m->win_cap * EST_MODAL_RING_SLOT : 0));
}

size_t est_modal_work_size(const sr_estimator_model *m)
{
    if (!m->modes)
        return 0;
    return sizeof(est_modal_work)
           + (m->window ? sizeof(double) * (size_t)scan_ring_cap(m) * EST_MODAL_STATES : 0);
}

static est_modal_data *state(const sr_estimator_model *m, void *data)
{
    return (est_modal_data *)((char *)data + m->off_modal);
}
static double *R_of(const sr_estimator_model *m, void *data)
{
    return (double *)((char *)data + m->off_modal + align8(sizeof(est_modal_data)));
}
static double *d_of(const sr_estimator_model *m, void *data)
{
    size_t nm = (size_t)n_max(m);
    return R_of(m, data) + nm * nm;
}
/* with the consider term: D_c (n_max x SR_N_CONSIDER), the consider right-hand sides rotated
 * as d is (dz/dc = R^-1 D_c) */
static double *dc_of(const sr_estimator_model *m, void *data)
{
    return d_of(m, data) + n_max(m);
}
static double *kept_of(const sr_estimator_model *m, void *data)
{
    return d_of(m, data) + (size_t)n_max(m) * (size_t)n_rhs(m);
}
/* the window ring's entry of sample index i (slot i mod win_cap) */
static double *ring_of(const sr_estimator_model *m, void *data, int i)
{
    return kept_of(m, data) + (size_t)EST_MODAL_MAX_SAMPLES * est_modal_slot(m)
           + (size_t)(i % m->win_cap) * EST_MODAL_RING_SLOT;
}

/* -- the filter ----------------------------------------------------------------------------- */

/* exp(M) of a 4 x 4 matrix (scaling and squaring of an order-16 Taylor series) */
static void expm4(const double *M, double *E)
{
    double nrm = 0.0;
    for (int i = 0; i < 16; i++)
        nrm = fmax(nrm, fabs(M[i]));
    int s = 0;
    while (nrm * 4.0 > 0.5 && s < 60) {
        nrm *= 0.5;
        s++;
    }
    double A[16], T[16], X[16];
    for (int i = 0; i < 16; i++)
        A[i] = ldexp(M[i], -s);
    memset(E, 0, sizeof(double) * 16);
    memset(T, 0, sizeof T);
    for (int i = 0; i < 4; i++)
        E[5 * i] = T[5 * i] = 1.0;
    for (int k = 1; k <= 16; k++) {                          /* T = T A / k */
        sr_matmul(T, A, 4, 4, 4, X);
        for (int i = 0; i < 16; i++) {
            T[i] = X[i] / k;
            E[i] += T[i];
        }
    }
    for (int j = 0; j < s; j++) {
        sr_matmul(E, E, 4, 4, 4, X);
        memcpy(E, X, sizeof X);
    }
}

/* One step of a frequency's filters over dt for the drive u0 -> u1 (linear in between):
 * x' = [[0, 1], [-w^2, -2 zeta w]] x + [0, -1] u, exactly:
 * x1 = Phi x0 + Gam0 u0 + Gam1 (u1 - u0) (the exponential of the filter with the input as a
 * chain of two integrators) */
void est_modal_filter_step(est_modal_filter *f, double dt, const double *u0, const double *u1)
{
    double *E = f->step;
    if (!(f->key[0] == f->w && f->key[1] == f->zeta && f->key[2] == dt)) {
        double M[16] = {0.0}, X[16];
        M[1] = dt;                                        /* row 0: eta' */
        M[4] = -f->w * f->w * dt;                         /* row 1: eta'' */
        M[5] = -2.0 * f->zeta * f->w * dt;
        M[6] = -dt;
        M[11] = 1.0;                                      /* row 2: the input's slope */
        expm4(M, X);
        memcpy(E, X, sizeof(double) * 8);                 /* rows 0 and 1 */
        f->key[0] = f->w;
        f->key[1] = f->zeta;
        f->key[2] = dt;
    }
    for (int j = 0; j < EST_MODAL_U; j++) {
        double du = u1[j] - u0[j], a = f->eta[j], b = f->etad[j];
        f->eta[j] = E[0] * a + E[1] * b + E[2] * u0[j] + E[3] * du;
        f->etad[j] = E[4] * a + E[5] * b + E[6] * u0[j] + E[7] * du;
    }
}

/* the signals a kept sample holds: t, u = [A^T a_S, alpha_B, omega2], omega_B, v_B = A^T v_S,
 * A, r_S (EST_MODAL_SIG) */
void est_modal_signals(double t, const double *x, double *sig)
{
    const double *A = x + SR_X_A_B, *w = x + SR_X_OMEGA_B;
    sig[0] = t;
    double *u = sig + 1;
    for (int i = 0; i < 3; i++) {
        u[i] = A[i] * x[SR_X_A_S] + A[3 + i] * x[SR_X_A_S + 1] + A[6 + i] * x[SR_X_A_S + 2];
        u[3 + i] = x[SR_X_ALPHA_B + i];
    }
    u[6] = w[0] * w[0];
    u[7] = w[1] * w[1];
    u[8] = w[2] * w[2];
    u[9] = w[0] * w[1];
    u[10] = w[0] * w[2];
    u[11] = w[1] * w[2];
    memcpy(sig + 13, w, sizeof(double) * 3);
    for (int i = 0; i < 3; i++)
        sig[16 + i] = A[i] * x[SR_X_V_S] + A[3 + i] * x[SR_X_V_S + 1] + A[6 + i] * x[SR_X_V_S + 2];
    memcpy(sig + 19, A, sizeof(double) * 9);
    memcpy(sig + 28, x + SR_X_R_S, sizeof(double) * 3);
}

/* -- the columns ---------------------------------------------------------------------------- */

static void cross(const double *a, const double *b, double *c)
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

/* The momentum columns of one frequency (6 x nc, row-major; nc = EST_MODAL_COLS, or the scan's
 * EST_MODAL_SCAN_COLS: G and C only) at a sample's signals sig with the filter's eta and eta'
 * (etad) there, in the rows' axes: inertial, the angular rows about the point p_I (the origin,
 * or the newer sample's base position with ident.momentum_point). In base axes about S first
 * (est_modal.h's terms, d = e_i eta_j, Omega(w) e_i eta_j):
 *   G (i <= j): h_i += eta'_j, h_j += eta'_i      C (6 i + j): h_i = eta'_{6 + j}
 *   D (12 i + j): lin [w]x e_i eta_j, ang -[v_B]x e_i eta_j
 *   T (12 i + j): ang Omega(w)[:, i] eta_j */
void est_modal_columns(const double *eta, const double *etad, const double *sig,
                       const double *p_I, int nc, double *out)
{
    const double *w = sig + 13, *vB = sig + 16, *A = sig + 19, *r = sig + 28;
    memset(out, 0, sizeof(double) * 6 * (size_t)nc);
    int c = 0;
    for (int i = 0; i < 6; i++)
        for (int j = i; j < 6; j++, c++) {
            out[i * nc + c] += etad[j];
            if (j != i)
                out[j * nc + c] += etad[i];
        }
    for (int i = 0; i < 6; i++)
        for (int j = 0; j < 6; j++, c++)
            out[i * nc + c] = etad[6 + j];
    if (nc == EST_MODAL_COLS) {
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < EST_MODAL_U; j++, c++) {
                double dv[3] = {0.0, 0.0, 0.0}, a[3], b[3];
                dv[i] = eta[j];
                cross(w, dv, a);
                cross(vB, dv, b);
                for (int k = 0; k < 3; k++) {
                    out[k * nc + c] = a[k];
                    out[(3 + k) * nc + c] = -b[k];
                }
            }
        /* Omega(w) [Ixx Iyy Izz Ixy Ixz Iyz]: columns of I w */
        static const int om[6][3] = {{0, -1, -1}, {-1, 1, -1}, {-1, -1, 2},
                                     {1, 0, -1}, {2, -1, 0}, {-1, 2, 1}};
        for (int i = 0; i < 6; i++)
            for (int j = 0; j < EST_MODAL_U; j++, c++)
                for (int k = 0; k < 3; k++)
                    out[(3 + k) * nc + c] = om[i][k] >= 0 ? w[om[i][k]] * eta[j] : 0.0;
    }
    /* to the rows' axes: lin_I = A lin, ang_I = A ang + (r_S - p_I) x lin_I */
    double rp[3] = {r[0] - p_I[0], r[1] - p_I[1], r[2] - p_I[2]};
    for (int col = 0; col < nc; col++) {
        double lb[3], ab[3], li[3], ai[3], rx[3];
        for (int k = 0; k < 3; k++) {
            lb[k] = out[k * nc + col];
            ab[k] = out[(3 + k) * nc + col];
        }
        for (int k = 0; k < 3; k++) {
            li[k] = A[3 * k] * lb[0] + A[3 * k + 1] * lb[1] + A[3 * k + 2] * lb[2];
            ai[k] = A[3 * k] * ab[0] + A[3 * k + 1] * ab[1] + A[3 * k + 2] * ab[2];
        }
        cross(rp, li, rx);
        for (int k = 0; k < 3; k++)
            ai[k] += rx[k];
        for (int k = 0; k < 3; k++) {
            out[k * nc + col] = li[k];
            out[(3 + k) * nc + col] = ai[k];
        }
    }
}

/* One sample's rows (k x width, row-major) [modal columns of the n_f frequencies (nc each) |
 * the identified rigid rows H (q) | yy | the first extra of its consider right-hand sides]:
 * the identified rows (rows_lin, rows_ang) weighted as the rigid ones (w_lin, w_ang); Hy the
 * kept rigid rows (k x (q + n_rhs)). Against a momentum
 * window's reference (ref_sig its signals, ref_x its filters' states in the
 * EST_MODAL_STATES layout; NULL: the filters at rest there, no columns) the columns are the
 * difference of the sample's and the reference's, both about the sample's point, as the
 * rigid rows are (est_rows.c) */
static void sample_rows(const sr_estimator_model *m, const est_modal_filter *f, int n_f, int nc,
                        const double *sig, const double *ref_sig, const double *ref_x,
                        const double *Hy, int extra, est_modal_work *w, double *rows)
{
    int k1 = m->k1, k = k1 + m->k2, q = m->q, width = n_f * nc + q + 1 + extra;
    int hw = q + n_rhs(m);
    static const double origin[3] = {0.0, 0.0, 0.0};
    const double *p_I = m->opt.momentum_point ? sig + 28 : origin;
    double *cols = w->cols, *cref = w->cols_ref;
    for (int a = 0; a < k; a++)
        memcpy(rows + a * width + n_f * nc, Hy + a * hw, sizeof(double) * (q + 1 + extra));
    for (int g = 0; g < n_f; g++) {
        est_modal_columns(f[g].eta, f[g].etad, sig, p_I, nc, cols);
        if (ref_x) {                    /* h(t) - h(t_r): the window's difference */
            const double *x = ref_x + 2 * EST_MODAL_U * g;
            est_modal_columns(x, x + EST_MODAL_U, ref_sig, p_I, nc, cref);
            for (int i = 0; i < 6 * nc; i++)
                cols[i] -= cref[i];
        }
        for (int a = 0; a < k; a++) {
            int src = a < k1 ? m->rows_lin[a] : 3 + m->rows_ang[a - k1];
            double wt = a < k1 ? m->w_lin : m->w_ang;
            for (int c = 0; c < nc; c++)
                rows[a * width + g * nc + c] = wt * cols[src * nc + c];
        }
    }
}

/* the filters' states (EST_MODAL_STATES: eta, eta' of each frequency) into x */
static void states_of(const est_modal_filter *f, int n_f, double *x)
{
    memset(x, 0, sizeof(double) * EST_MODAL_STATES);
    for (int g = 0; g < n_f; g++) {
        memcpy(x + 2 * EST_MODAL_U * g, f[g].eta, sizeof f[g].eta);
        memcpy(x + 2 * EST_MODAL_U * g + EST_MODAL_U, f[g].etad, sizeof f[g].etad);
    }
}

/* -- the square-root information solve ------------------------------------------------------ */

/* [R d] at the prior: the rigid unknowns (last q) at their guesses with information 1 / P0,
 * the modal ones at 0 with EST_MODAL_PRIOR_INFO */
static void solve_reset(const sr_estimator_model *m, void *data)
{
    est_modal_data *s = state(m, data);
    int q = m->q, nm = s->n_f * EST_MODAL_COLS, n = nm + q;
    double *R = R_of(m, data), *d = d_of(m, data);
    memset(R, 0, sizeof(double) * (size_t)n * (size_t)n);
    memset(d, 0, sizeof(double) * (size_t)n);
    if (m->consider)
        memset(dc_of(m, data), 0, sizeof(double) * (size_t)n * SR_N_CONSIDER);
    for (int i = 0; i < nm; i++)
        R[i * n + i] = sqrt(EST_MODAL_PRIOR_INFO);
    for (int i = 0; i < q; i++) {
        double info = sqrt(1.0 / m->prior[m->std_active[i]]);
        R[(nm + i) * n + nm + i] = info;
        d[nm + i] = info * m->pi0_full[m->std_active[i]];
    }
    s->rss = s->rows = s->y2 = 0.0;
}

/* the rows (k x (n + n_rhs)) into [R d D_c] by Givens rotations (in place; the rows are
 * destroyed), pivot by pivot with every row at each (one pass over R per sample: R is
 * megabytes) */
static void solve_add(const sr_estimator_model *m, void *data, double *rows, int k)
{
    est_modal_data *s = state(m, data);
    int n = s->n_f * EST_MODAL_COLS + m->q, nr = n_rhs(m), w = n + nr;
    double *R = R_of(m, data), *d = d_of(m, data), *Dc = dc_of(m, data);
    for (int a = 0; a < k; a++)
        s->y2 += rows[(size_t)a * w + n] * rows[(size_t)a * w + n];
    for (int i = 0; i < n; i++) {
        double *restrict Ri = R + (size_t)i * n;
        for (int a = 0; a < k; a++) {
            double *restrict x = rows + (size_t)a * w;
            if (x[i] == 0.0)
                continue;
            double r = sr_hypot(Ri[i], x[i]), c = Ri[i] / r, sn = x[i] / r;
            Ri[i] = r;
            x[i] = 0.0;
            for (int j = i + 1; j < n; j++) {
                double p = Ri[j], v = x[j];
                Ri[j] = c * p + sn * v;
                x[j] = c * v - sn * p;
            }
            double p = d[i], v = x[n];
            d[i] = c * p + sn * v;
            x[n] = c * v - sn * p;
            for (int j = 1; j < nr; j++) {
                double *dc = Dc + (size_t)i * SR_N_CONSIDER + j - 1;
                p = *dc;
                v = x[n + j];
                *dc = c * p + sn * v;
                x[n + j] = c * v - sn * p;
            }
        }
    }
    for (int a = 0; a < k; a++) {
        s->rss += rows[(size_t)a * w + n] * rows[(size_t)a * w + n];
        s->rows += 1.0;
    }
}

/* the errors in variables (est_modal.h): S (q x (q + 1)) = R_qq^T [R_qq d_q], the reduced
 * (modal unknowns eliminated) Gram matrix of [H | yy] from R's last q x q block, and the
 * rigid answer x (q) compensated in place for the rows' noise N (est_eiv.h, eq. 2); returns
 * dx^T S_qq dx, what the residual sum of squares grows by from the least-squares answer to
 * the compensated one (dx their difference; the modal unknowns at their best for each) */
static double compensate_rigid(const sr_estimator_model *m, const est_modal_data *s,
                               const double *R, const double *d, int nm, double *x, double *S)
{
    int q = m->q, nj = q + 1, n = nm + q;
    for (int i = 0; i < q; i++)
        for (int j = 0; j < nj; j++) {
            double acc = 0.0;
            for (int l = 0; l <= i && l <= j; l++)
                acc += R[(size_t)(nm + l) * n + nm + i]
                       * (j < q ? R[(size_t)(nm + l) * n + nm + j] : d[nm + l]);
            S[i * nj + j] = acc;
        }
    double xc[EST_NZ], dx[EST_NZ], grow = 0.0;
    est_compensate(S, s->N, nj, q, x, xc);
    for (int i = 0; i < q; i++)
        dx[i] = xc[i] - x[i];
    for (int i = 0; i < q; i++)
        for (int j = 0; j < q; j++)
            grow += dx[i] * S[i * nj + j] * dx[j];
    memcpy(x, xc, sizeof(double) * q);
    return grow > 0.0 ? grow : 0.0;
}

/* the rigid unknowns' answer z (20; the unidentified at their guesses) and covariance C (20 x
 * 20: the prior's where unidentified) from R's last q x q block: R_qq z_q = d_q,
 * C_qq = s2 R_qq^-1 R_qq^-T, s2 = rss / (rows - n); with the window rows' noise N
 * (est_modal.h) z_q compensated, C_qq = K C K^T (est_eiv.h) and s2 the residual's at the
 * compensated answer (as the joint solver's); with the consider term their shift in the
 * thrust's errors, shift (20 x 8) = dz/dc = R_qq^-1 D_c,q (0 where unidentified; not
 * compensated, as the joint solver's); w's gram the scratch */
static void solve_rigid(const sr_estimator_model *m, void *data, double *z, double *C,
                        double *Rinv, double *shift, est_modal_work *w)
{
    est_modal_data *s = state(m, data);
    int q = m->q, nm = s->n_f * EST_MODAL_COLS, n = nm + q;
    const double *R = R_of(m, data), *d = d_of(m, data);
    double x[EST_NZ];
    for (int i = q - 1; i >= 0; i--) {
        double acc = d[nm + i];
        for (int j = i + 1; j < q; j++)
            acc -= R[(size_t)(nm + i) * n + nm + j] * x[j];
        x[i] = acc / R[(size_t)(nm + i) * n + nm + i];
    }
    /* the errors in variables: the answer compensated for the rows' noise (est_modal.h) */
    int nj = q + 1, eiv = m->n_win > 0 && s->rows > 0.0;
    double *S = w->gram, grow = eiv ? compensate_rigid(m, s, R, d, nm, x, S) : 0.0;
    memcpy(z, m->pi0_full, sizeof(double) * EST_NZ);
    for (int i = 0; i < q; i++)
        z[m->std_active[i]] = x[i];
    /* R_qq^-1 (upper triangular), column by column */
    memset(Rinv, 0, sizeof(double) * q * q);
    for (int j = 0; j < q; j++)
        for (int i = j; i >= 0; i--) {
            double acc = i == j ? 1.0 : 0.0;
            for (int l = i + 1; l <= j; l++)
                acc -= R[(size_t)(nm + i) * n + nm + l] * Rinv[l * q + j];
            Rinv[i * q + j] = acc / R[(size_t)(nm + i) * n + nm + i];
        }
    if (m->consider) {
        const double *Dc = dc_of(m, data);
        memset(shift, 0, sizeof(double) * EST_NZ * SR_N_CONSIDER);
        for (int i = 0; i < q; i++)
            for (int c = 0; c < SR_N_CONSIDER; c++) {
                double acc = 0.0;
                for (int l = i; l < q; l++)
                    acc += Rinv[i * q + l] * Dc[(size_t)(nm + l) * SR_N_CONSIDER + c];
                shift[m->std_active[i] * SR_N_CONSIDER + c] = acc;
            }
    }
    double dof = s->rows - n, s2 = dof > 0.0 ? (s->rss + grow) / dof : 1.0;   /* at z */
    double *P = S + q * nj;                      /* s2 R_qq^-1 R_qq^-T, then with eiv K P K^T */
    for (int i = 0; i < q; i++)
        for (int j = 0; j < q; j++) {
            double acc = 0.0;
            for (int l = (i > j ? i : j); l < q; l++)
                acc += Rinv[i * q + l] * Rinv[j * q + l];
            P[i * q + j] = s2 * acc;
        }
    if (eiv) {
        double *KPK = P + q * q;
        est_compensated_covariance(S, s->N, nj, q, P, KPK);
        memcpy(P, KPK, sizeof(double) * q * q);
    }
    memset(C, 0, sizeof(double) * EST_NZ * EST_NZ);
    for (int i = 0; i < EST_NZ; i++)
        C[i * EST_NZ + i] = m->prior[i];
    for (int i = 0; i < q; i++)
        for (int j = 0; j < q; j++)
            C[m->std_active[i] * EST_NZ + m->std_active[j]] = P[i * q + j];
}

/* -- the kept samples and the replay -------------------------------------------------------- */

static double *kept_sample(const sr_estimator_model *m, void *data, int i)
{
    return kept_of(m, data) + (size_t)i * est_modal_slot(m);
}

/* the filters at rest at the reference */
static void filters_rest(est_modal_data *s)
{
    for (int g = 0; g < EST_MODAL_MAX_F; g++) {
        memset(s->f[g].eta, 0, sizeof s->f[g].eta);
        memset(s->f[g].etad, 0, sizeof s->f[g].etad);
    }
}

/* the kept sample's momentum window's reference (its sample index; -1 without the window) */
static double *ref_of_kept(const sr_estimator_model *m, double *ks)
{
    return ks + EST_MODAL_SIG + (m->k1 + m->k2) * (m->q + n_rhs(m));
}

/* the window's ring holds the reference (index 0, signals sig, the filters at rest) alone */
static void ring_start(const sr_estimator_model *m, void *data, const double *sig)
{
    est_modal_data *s = state(m, data);
    s->n_samp = 0;
    if (!m->window)
        return;
    double *e = ring_of(m, data, 0);
    memset(e, 0, sizeof(double) * EST_MODAL_RING_SLOT);
    memcpy(e + 1, sig, sizeof(double) * EST_MODAL_SIG);
    s->ring_count = 1;
}

/* One sample (sig, Hy) through the filters and into [R d], its columns against the window's
 * reference r (a sample index in the ring; -1 without the window); the sample into the ring
 * after the entries older than r (as the rows' ring drops them) */
static void solve_sample(const sr_estimator_model *m, void *data, const double *sig,
                         const double *Hy, int r, est_modal_work *w)
{
    est_modal_data *s = state(m, data);
    double dt = sig[0] - s->t_prev;
    for (int g = 0; g < s->n_f; g++)
        est_modal_filter_step(&s->f[g], dt, s->u_prev, sig + 1);
    memcpy(s->u_prev, sig + 1, sizeof s->u_prev);
    s->t_prev = sig[0];
    const double *ref = r >= 0 ? ring_of(m, data, r) : NULL;
    sample_rows(m, s->f, s->n_f, EST_MODAL_COLS, sig, ref ? ref + 1 : NULL,
                ref ? ref + 1 + EST_MODAL_SIG : NULL, Hy, n_rhs(m) - 1, w, w->rows);
    solve_add(m, data, w->rows, m->k1 + m->k2);
    s->n_samp++;
    if (r >= 0) {
        double *e = ring_of(m, data, s->n_samp);
        e[0] = s->n_samp;
        memcpy(e + 1, sig, sizeof(double) * EST_MODAL_SIG);
        states_of(s->f, s->n_f, e + 1 + EST_MODAL_SIG);
        s->ring_count = s->n_samp - r + 1;
    }
}

/* every kept sample solved again (the modes changed), the window's ring formed again */
static void replay(const sr_estimator_model *m, void *data, const double *u0,
                   est_modal_work *w)
{
    est_modal_data *s = state(m, data);
    solve_reset(m, data);
    filters_rest(s);
    memcpy(s->u_prev, u0, sizeof s->u_prev);
    s->t_prev = s->t0;
    ring_start(m, data, s->sig0);
    for (int i = 0; i < s->kept; i++) {
        double *ks = kept_sample(m, data, i);
        solve_sample(m, data, ks, ks + EST_MODAL_SIG, (int)*ref_of_kept(m, ks), w);
    }
}

/* -- the mode search ------------------------------------------------------------------------ */

/* The variable-projection objective: the residual sum of squares of the kept samples' rows
 * (every stride-th) with the scan's columns (G, C) of the n_f frequencies f, over the rigid
 * rows' right-hand sides' (relative); the Gram matrix of [columns | H | yy] in w->gram. */
static double objective(const sr_estimator_model *m, void *data, const est_modal_filter *f_in,
                        int n_f, const double *u0, int stride, est_modal_work *w)
{
    est_modal_data *s = state(m, data);
    est_modal_filter f[EST_MODAL_MAX_F];
    int k = m->k1 + m->k2, nc = EST_MODAL_SCAN_COLS, width = n_f * nc + m->q + 1;
    for (int g = 0; g < n_f; g++) {
        f[g] = f_in[g];
        if (!(f[g].w >= TWO_PI * EST_MODAL_F_MIN && f[g].w <= TWO_PI * SR_EST_MAX_MODE_F
              && f[g].zeta >= EST_MODAL_ZETA_MIN && f[g].zeta <= EST_MODAL_ZETA_MAX))
            return HUGE_VAL;
        memset(f[g].eta, 0, sizeof f[g].eta);
        memset(f[g].etad, 0, sizeof f[g].etad);
    }
    double *G = w->gram, t_prev = s->t0, u_prev[EST_MODAL_U];
    /* with the window: the filters' states of each sample (index i + 1 of kept sample i; 0
     * the reference, at rest) in a ring as long as the window reaches */
    int cw = m->window ? scan_ring_cap(m) : 1;
    if (m->window)
        memset(w->ring, 0, sizeof(double) * EST_MODAL_STATES);
    memcpy(u_prev, u0, sizeof u_prev);
    memset(G, 0, sizeof(double) * (size_t)width * width);
    for (int i = 0; i < s->kept; i++) {
        double *ks = kept_sample(m, data, i);
        for (int g = 0; g < n_f; g++)
            est_modal_filter_step(&f[g], ks[0] - t_prev, u_prev, ks + 1);
        memcpy(u_prev, ks + 1, sizeof u_prev);
        t_prev = ks[0];
        if (m->window)
            states_of(f, n_f, w->ring + (size_t)((i + 1) % cw) * EST_MODAL_STATES);
        if (i % stride)
            continue;
        int ref = (int)*ref_of_kept(m, ks);       /* its window's reference's index */
        const double *ref_sig = ref > 0 ? kept_sample(m, data, ref - 1) : s->sig0;
        const double *ref_x = ref >= 0 ? w->ring + (size_t)(ref % cw) * EST_MODAL_STATES : NULL;
        sample_rows(m, f, n_f, nc, ks, ref_sig, ref_x, ks + EST_MODAL_SIG, 0, w, w->rows);
        for (int a = 0; a < k; a++) {                      /* the upper triangle */
            const double *x = w->rows + a * width;
            for (int r = 0; r < width; r++) {
                if (x[r] == 0.0)
                    continue;
                double xr = x[r], *Gr = G + (size_t)r * width;
                for (int c = r; c < width; c++)
                    Gr[c] += xr * x[c];
            }
        }
    }
    /* scaled: G_s = D G D, D = 1 / sqrt(diag), then the residual y'y - b' G_xx^-1 b */
    int n = width - 1;
    double yy = G[(size_t)n * width + n];
    if (!(yy > 0.0))
        return 0.0;
    double *sc = w->cols;                                   /* (width <= 6 * 165) */
    for (int r = 0; r < width; r++)
        sc[r] = G[(size_t)r * width + r] > 0.0 ? 1.0 / sqrt(G[(size_t)r * width + r]) : 0.0;
    for (int r = 0; r < width; r++)
        for (int c = r; c < width; c++) {
            double v = G[(size_t)r * width + c] * sc[r] * sc[c];
            G[(size_t)r * width + c] = G[(size_t)c * width + r] = v;
        }
    for (int r = 0; r < n; r++)
        G[(size_t)r * width + r] += 1e-10;                  /* (a column the run leaves at 0) */
    /* Cholesky of the whole [Gxx b; b' yy]: its last pivot^2 is the residual */
    for (int r = 0; r < width; r++) {
        double *Gr = G + (size_t)r * width;
        for (int c = 0; c <= r; c++) {
            double acc = Gr[c];
            const double *Gc = G + (size_t)c * width;
            for (int l = 0; l < c; l++)
                acc -= Gr[l] * Gc[l];
            if (c < r) {
                Gr[c] = acc / Gc[c];
            } else {
                if (r == n)
                    return acc > 0.0 ? acc : 0.0;           /* relative (yy scaled to 1) */
                if (!(acc > 0.0))
                    return HUGE_VAL;
                Gr[c] = sqrt(acc);
            }
        }
    }
    return HUGE_VAL;
}

/* Nelder-Mead over (log w, log zeta) of mode j of f (the others held): f[j] at the best
 * point; its objective returned */
static double refine(const sr_estimator_model *m, void *data, est_modal_filter *f, int n_f,
                     int j, const double *u0, int stride, double r0, est_modal_work *w)
{
    double P[3][2], F[3];
    P[0][0] = sr_ln(f[j].w);
    P[0][1] = sr_ln(f[j].zeta);
    P[1][0] = P[0][0] + 0.03;
    P[1][1] = P[0][1];
    P[2][0] = P[0][0];
    P[2][1] = P[0][1] + 0.5;
    for (int v = 0; v < 3; v++) {
        if (v == 0) {
            F[v] = r0;
            continue;
        }
        f[j].w = sr_exp(P[v][0]);
        f[j].zeta = sr_exp(P[v][1]);
        F[v] = objective(m, data, f, n_f, u0, stride, w);
    }
    int evals = 2;
    while (evals < EST_MODAL_NM_EVALS) {
        int hi = 0, lo = 0;
        for (int v = 1; v < 3; v++) {
            if (F[v] > F[hi])
                hi = v;
            if (F[v] < F[lo])
                lo = v;
        }
        int mid = 3 - hi - lo;
        if (hi == lo)
            break;
        double c[2], xr[2], fr;
        for (int a = 0; a < 2; a++)
            c[a] = 0.5 * (P[lo][a] + P[mid][a]);
        for (int a = 0; a < 2; a++)
            xr[a] = 2.0 * c[a] - P[hi][a];
        f[j].w = sr_exp(xr[0]);
        f[j].zeta = sr_exp(xr[1]);
        fr = objective(m, data, f, n_f, u0, stride, w);
        evals++;
        if (fr < F[lo]) {                                  /* expand */
            double xe[2], fe;
            for (int a = 0; a < 2; a++)
                xe[a] = 3.0 * c[a] - 2.0 * P[hi][a];
            f[j].w = sr_exp(xe[0]);
            f[j].zeta = sr_exp(xe[1]);
            fe = objective(m, data, f, n_f, u0, stride, w);
            evals++;
            if (fe < fr) {
                memcpy(P[hi], xe, sizeof xe);
                F[hi] = fe;
            } else {
                memcpy(P[hi], xr, sizeof xr);
                F[hi] = fr;
            }
        } else if (fr < F[mid]) {
            memcpy(P[hi], xr, sizeof xr);
            F[hi] = fr;
        } else {                                           /* contract (or shrink) */
            double xc[2], fc;
            for (int a = 0; a < 2; a++)
                xc[a] = 0.5 * (c[a] + P[hi][a]);
            f[j].w = sr_exp(xc[0]);
            f[j].zeta = sr_exp(xc[1]);
            fc = objective(m, data, f, n_f, u0, stride, w);
            evals++;
            if (fc < F[hi]) {
                memcpy(P[hi], xc, sizeof xc);
                F[hi] = fc;
            } else {
                for (int v = 0; v < 3; v++)
                    if (v != lo) {
                        for (int a = 0; a < 2; a++)
                            P[v][a] = 0.5 * (P[v][a] + P[lo][a]);
                        f[j].w = sr_exp(P[v][0]);
                        f[j].zeta = sr_exp(P[v][1]);
                        F[v] = objective(m, data, f, n_f, u0, stride, w);
                        evals++;
                    }
            }
        }
        if (fabs(P[hi][0] - P[lo][0]) < 1e-5 && fabs(P[hi][1] - P[lo][1]) < 1e-3)
            break;
    }
    int lo = 0;
    for (int v = 1; v < 3; v++)
        if (F[v] < F[lo])
            lo = v;
    f[j].w = sr_exp(P[lo][0]);
    f[j].zeta = sr_exp(P[lo][1]);
    return F[lo];
}

/* The modes from the kept samples: those so far (given or found before) refined, each with
 * the others held; a found mode that lowers the residual by less than EST_MODAL_MIN_GAIN
 * dropped (a given one is kept);
 * then more by the greedy scan (est_modal.h). s->f and s->n_f updated; 1 where the modes
 * changed by more than EST_MODAL_KEEP (relative, frequency and damping) or in number. */
static int search(const sr_estimator_model *m, void *data, const double *u0, est_modal_work *w)
{
    est_modal_data *s = state(m, data);
    int stride = (s->kept + EST_MODAL_SCAN_SAMPLES - 1) / EST_MODAL_SCAN_SAMPLES;
    est_modal_filter f[EST_MODAL_MAX_F], g[EST_MODAL_MAX_F];
    memcpy(f, s->f, sizeof f);
    int n_f = s->n_f;
    double r0 = objective(m, data, f, n_f, u0, stride, w);
    for (int j = 0; j < n_f; j++)
        r0 = refine(m, data, f, n_f, j, u0, stride, r0, w);
    for (int j = n_f - 1; j >= 0 && n_f > 0; j--) {        /* pruning (of found modes) */
        if (f[j].given != 0.0)
            continue;
        int c = 0;
        for (int i = 0; i < n_f; i++)
            if (i != j)
                g[c++] = f[i];
        double r = objective(m, data, g, c, u0, stride, w);
        if (!(r0 < (1.0 - EST_MODAL_MIN_GAIN) * r)) {
            memcpy(f, g, sizeof(est_modal_filter) * (size_t)c);
            n_f = c;
            r0 = r;
        }
    }
    while (n_f < EST_MODAL_MAX_F) {                         /* the scan */
        int best = -1;
        double rb = HUGE_VAL;
        for (int i = 0; i < EST_MODAL_GRID; i++) {
            f[n_f].w = TWO_PI * EST_MODAL_F_LO
                       * sr_exp(i / (EST_MODAL_GRID - 1.0) * sr_ln(EST_MODAL_F_HI / EST_MODAL_F_LO));
            f[n_f].zeta = EST_MODAL_ZETA0;
            double r = objective(m, data, f, n_f + 1, u0, stride, w);
            if (r < rb) {
                rb = r;
                best = i;
            }
        }
        if (best < 0)
            break;
        f[n_f].w = TWO_PI * EST_MODAL_F_LO
                   * sr_exp(best / (EST_MODAL_GRID - 1.0) * sr_ln(EST_MODAL_F_HI / EST_MODAL_F_LO));
        f[n_f].zeta = EST_MODAL_ZETA0;
        double r1 = refine(m, data, f, n_f + 1, n_f, u0, stride, rb, w);
        if (!(r1 < (1.0 - EST_MODAL_MIN_GAIN) * r0))
            break;
        n_f++;
        r0 = r1;
    }
    int changed = n_f != s->n_f;
    for (int j = 0; j < n_f && !changed; j++)
        changed = fabs(f[j].w - s->f[j].w) > EST_MODAL_KEEP * s->f[j].w
                  || fabs(f[j].zeta - s->f[j].zeta) > 100.0 * EST_MODAL_KEEP * s->f[j].zeta;
    if (changed) {
        memset(s->f, 0, sizeof s->f);
        memcpy(s->f, f, sizeof(est_modal_filter) * (size_t)n_f);
        s->n_f = n_f;
    }
    return changed;
}

/* -- the stage ------------------------------------------------------------------------------ */

void est_modal_init(const sr_estimator_model *m, void *data)
{
    if (!m->modes)
        return;
    est_modal_data *s = state(m, data);
    memset(s, 0, sizeof *s);
    for (int g = 0; g < EST_MODAL_MAX_F; g++)
        if (m->opt.mode_f[g] > 0.0) {
            s->f[s->n_f].w = TWO_PI * m->opt.mode_f[g];
            s->f[s->n_f].zeta = 0.01;
            s->f[s->n_f].given = 1.0;
            s->n_f++;
        }
    solve_reset(m, data);
}

int est_modal_check(const sr_estimator_model *m, const void *data)
{
    if (!m->modes)
        return 0;
    void *dv = (void *)data;
    const est_modal_data *s = state(m, dv);
    /* n_samp below INT_MAX - 1: the next sample's increment stays an int */
    if (s->started < 0 || s->started > 1 || s->n_f < 0 || s->n_f > EST_MODAL_MAX_F
        || s->kept < 0 || s->kept > EST_MODAL_MAX_SAMPLES || s->searches < 0
        || s->n_samp < 0 || s->n_samp >= INT_MAX - 1 || s->kept > s->n_samp
        || !isfinite(s->rss + s->rows + s->y2 + s->t0 + s->t_prev))
        return 1;
    for (int i = 0; i < (m->q + 1) * (m->q + 1); i++)
        if (!isfinite(s->N[i]))
            return 1;
    for (int g = 0; g < s->n_f; g++)
        if (!(s->f[g].w > 0.0 && s->f[g].zeta > 0.0 && s->f[g].zeta < 1.0))
            return 1;
    /* the window's ring: as long as the rows' (est_core.win_count), its entries the samples
     * n_samp - ring_count + 1 .. n_samp; each kept sample's reference before it */
    if (m->window) {
        const est_core *c = &((const est_data *)data)->core;
        if (s->started && (s->ring_count != c->win_count || s->ring_count < 1
                           || s->ring_count > m->win_cap || s->ring_count > s->n_samp + 1))
            return 1;
        if (!s->started && s->ring_count != 0)
            return 1;
        for (int j = s->n_samp - s->ring_count + 1; j <= s->n_samp && s->started; j++)
            if (ring_of(m, dv, j)[0] != (double)j)
                return 1;
    }
    for (int i = 0; i < s->kept; i++) {
        double r = *ref_of_kept(m, kept_sample(m, dv, i));
        if (m->window ? !(r >= 0.0 && r <= i && r == floor(r)) : r != -1.0)
            return 1;
    }
    return 0;
}

void est_modal_reference(const sr_estimator_model *m, void *data, double t, const double *x)
{
    if (!m->modes)
        return;
    est_modal_data *s = state(m, data);
    double sig[EST_MODAL_SIG];
    est_modal_signals(t, x, sig);
    s->started = 1;
    s->t0 = s->t_prev = t;
    memset(s->N, 0, sizeof s->N);
    memcpy(s->sig0, sig, sizeof sig);
    memcpy(s->u0, sig + 1, sizeof s->u0);
    memcpy(s->u_prev, sig + 1, sizeof s->u_prev);
    ring_start(m, data, sig);
}

/* The reported estimates and sd of the rigid unknowns into nw (where finite): the
 * least-squares variance inflated for the rows' correlated errors as the joint solver's
 * (est_corr.h: the overlapping windows share their samples' errors), with the thrust's
 * consider term from the solve's own shift in the thrust's errors (est_consider.h) */
static void report_into(const sr_estimator_model *m, void *data, est_core *nw,
                        est_modal_work *w)
{
    double z[EST_NZ], J[EST_NZ * EST_NZ], vec[EST_NZ], sd[EST_NZ], Rinv[EST_NZ * EST_NZ];
    double shift[EST_NZ * SR_N_CONSIDER];
    double *C = w->cov;
    solve_rigid(m, data, z, C, Rinv, shift, w);
    sr_reported_of_standard(z, vec);
    sr_reported_jacobian(z, J);
    double infl = m->lags > 0 ? est_corr_current(m, data, 0) : 1.0;
    int finite = isfinite(infl);
    for (int i = 0; i < EST_NZ; i++) {                    /* sd_i^2 = infl (J C J^T)_ii */
        double acc = 0.0;
        for (int a = 0; a < EST_NZ; a++) {
            if (J[i * EST_NZ + a] == 0.0)
                continue;
            for (int b = 0; b < EST_NZ; b++)
                acc += J[i * EST_NZ + a] * C[a * EST_NZ + b] * J[i * EST_NZ + b];
        }
        sd[i] = sqrt(fmax(acc, 0.0) * infl);
        finite &= isfinite(vec[i]) && isfinite(sd[i]);
    }
    for (int i = 0; i < EST_NZ * SR_N_CONSIDER && m->consider; i++)
        finite &= isfinite(shift[i]);
    if (!finite)
        return;
    memcpy(nw->vec, vec, sizeof vec);
    memcpy(nw->sd, sd, sizeof sd);
    if (m->consider)                         /* sd^2 += sum_c (J dz/dc sigma_c)^2 */
        est_consider_add(m, nw, J, shift);
}

/* the window rows' noise (rw's win_chunks chunks of n_win blocks in noise) into N: each
   block's identified rows [H | yy] (as the sample's, at nw's fixed parameters) */
static void noise_add(const sr_estimator_model *m, void *data, const est_rows *rw,
                      const double *noise, const est_core *nw, est_modal_work *w)
{
    est_modal_data *s = state(m, data);
    int nj = m->q + 1, k = m->k1 + m->k2;
    double *rows = w->cov;                                         /* (k x nj <= 6 x 21) */
    for (int c = 0; c < rw->win_chunks; c++)
        for (int b = 0; b < m->n_win; b++) {
            est_joint_rows_hy(m, nw, noise + ((size_t)c * m->n_win + b) * EST_NB, rows);
            est_gram_add(s->N, nj, rows, k, 1.0, s->N);
        }
}

void est_modal_step(const sr_estimator_model *m, void *data, double t, const double *x,
                    const est_rows *rw, const double *noise, est_core *nw,
                    est_modal_work *w)
{
    const double *E = rw->E, *Ec = rw->Ec;
    int win_drop = rw->win_drop;
    if (!m->modes)
        return;
    est_modal_data *s = state(m, data);
    if (!s->started)
        return;
    int k1 = m->k1, k = k1 + m->k2, q = m->q, hw = q + n_rhs(m), nc = SR_N_CONSIDER;
    double sig[EST_MODAL_SIG], Hy[EST_MAXK * (EST_NZ + 1 + SR_N_CONSIDER)];
    double H[EST_MAXK * EST_NZ], yy[EST_MAXK], bc[3 * SR_N_CONSIDER], yc[3 * SR_N_CONSIDER];
    est_modal_signals(t, x, sig);
    est_joint_rows(m, nw, E, H, yy);
    if (m->consider)
        est_consider_rows(m, Ec, bc, yc);
    for (int a = 0; a < k; a++) {                         /* [H | yy | the consider's] */
        memcpy(Hy + a * hw, H + a * q, sizeof(double) * q);
        Hy[a * hw + q] = yy[a];
        if (m->consider)
            memcpy(Hy + a * hw + q + 1, a < k1 ? bc + a * nc : yc + (a - k1) * nc,
                   sizeof(double) * nc);
    }
    /* the window's reference: the ring's entry win_drop from its oldest (as the rows') */
    int r = m->window ? s->n_samp - s->ring_count + 1 + win_drop : -1;
    solve_sample(m, data, sig, Hy, r, w);
    noise_add(m, data, rw, noise, nw, w);
    if (s->kept < EST_MODAL_MAX_SAMPLES) {
        double *ks = kept_sample(m, data, s->kept);
        memcpy(ks, sig, sizeof sig);
        memcpy(ks + EST_MODAL_SIG, Hy, sizeof(double) * k * hw);
        *ref_of_kept(m, ks) = r;
        s->kept++;
        /* the search where due (while every sample is kept), where the rows with the modes
         * so far do not fit or modes were given; then every kept sample again */
        if (s->kept < EST_MODAL_MAX_SAMPLES
            && t - s->t0 >= EST_MODAL_FIRST_SEARCH * ldexp(1.0, s->searches)) {
            s->searches++;
            double rel = s->y2 > 0.0 ? sqrt(s->rss / s->y2) : 0.0;
            if ((rel > EST_MODAL_FIT_FLOOR || s->n_f > 0) && search(m, data, s->u0, w))
                replay(m, data, s->u0, w);
        }
    }
    report_into(m, data, nw, w);
}

int est_modal_mode(const sr_estimator_model *m, const void *data, int k, double *f,
                   double *zeta)
{
    if (!m->modes)
        return 0;
    const est_modal_data *s = state(m, (void *)data);
    if (k < 0 || k >= s->n_f)
        return 0;
    *f = s->f[k].w / TWO_PI;
    *zeta = s->f[k].zeta;
    return 1;
}
