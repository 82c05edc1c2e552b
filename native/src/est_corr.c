/* The residual autocorrelation of the equations (est_corr.h): its sums and ring in the Data
 * block, the inflation of the residual variance they give. */
#include "est_corr.h"

static double *corr_sums(const sr_estimator_model *m, const void *data, int eq)
{
    return (double *)((char *)data + (eq == 0 ? m->off_corr_lin : m->off_corr_ang));
}

/* c_j after adding e: lam c_j + e . e_(t-j) (write: into the sums and the ring) and the
 * inflation max(1, 1 + 2 sum_j (1 - j/(L+1)) c_j / c_0) */
static double corr_add(const sr_estimator_model *m, const void *data, const est_core *c, int eq,
                       const double *e, int k, int write)
{
    int L = m->lags;
    double lam = m->opt.lambda;
    double *cs = corr_sums(m, data, eq), *ring = cs + (L + 1);
    int head = c->corr_head[eq], count = c->corr_count[eq];
    double s = 0.0;
    for (int a = 0; a < k; a++)
        s += e[a] * e[a];
    double c0 = (lam != 1.0 ? cs[0] * lam : cs[0]) + s;
    double acc = 0.0;
    int row = head;
    for (int j = 1; j <= L; j++) {
        double cj = lam != 1.0 ? cs[j] * lam : cs[j];
        if (j <= count) {                                    /* lag j: the row j back */
            row = row > 0 ? row - 1 : L - 1;
            double d = 0.0;
            for (int a = 0; a < k; a++)
                d += e[a] * ring[row * k + a];
            cj += d;
        }
        acc += (1.0 - j / (L + 1.0)) * cj;
        if (write)
            cs[j] = cj;
    }
    if (write) {
        cs[0] = c0;
        for (int a = 0; a < k; a++)
            ring[head * k + a] = e[a];
    }
    if (!(c0 > 0.0))
        return 1.0;
    double f = 1.0 + 2.0 * (acc / c0);
    return f > 1.0 ? f : 1.0;
}

double est_corr_current(const sr_estimator_model *m, const void *data, int eq)
{
    int L = m->lags;
    if (L == 0)
        return 1.0;
    const double *cs = corr_sums(m, data, eq);
    double acc = 0.0;
    for (int j = 1; j <= L; j++)
        acc += (1.0 - j / (L + 1.0)) * cs[j];
    if (!(cs[0] > 0.0))
        return 1.0;
    double f = 1.0 + 2.0 * (acc / cs[0]);
    return f > 1.0 ? f : 1.0;
}

double est_corr_inflation(const sr_estimator_model *m, const void *data, const est_core *c,
                          int eq, const double *e, int k)
{
    return corr_add(m, data, c, eq, e, k, 0);
}

void est_corr_commit(const sr_estimator_model *m, void *data, est_core *c, int eq,
                     const double *e, int k)
{
    corr_add(m, data, c, eq, e, k, 1);
    c->corr_head[eq] = (c->corr_head[eq] + 1) % m->lags;
    if (c->corr_count[eq] < m->lags)
        c->corr_count[eq]++;
}
