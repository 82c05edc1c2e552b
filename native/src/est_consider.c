/* The thrust's consider term (est_consider.h): the consider sums of the identified rows and the
 * consider variance added to the standard deviations. */
#include "est_consider.h"

#include <math.h>

void est_consider_rows(const sr_estimator_model *m, const double *Ec, double *bc, double *yc)
{
    const int nc = SR_N_CONSIDER;
    for (int a = 0; a < m->k1; a++)
        for (int c = 0; c < nc; c++) {
            double v = Ec[m->rows_lin[a] * SR_N_CCOLS + c];
            bc[a * nc + c] = m->w_lin != 1.0 ? v * m->w_lin : v;
        }
    for (int a = 0; a < m->k2; a++)
        for (int c = 0; c < nc; c++) {
            double v = Ec[m->rows_ang[a] * SR_N_CCOLS + nc + c];
            yc[a * nc + c] = m->w_ang != 1.0 ? v * m->w_ang : v;
        }
}

void est_consider_sums(const sr_estimator_model *m, const est_core *old, est_core *nw,
                       const double *Ec, const double *A, const double *phi, const double *H)
{
    const int nc = SR_N_CONSIDER, k1 = m->k1, k2 = m->k2;
    double lam = m->opt.lambda;
    /* the consider right-hand sides of the identified rows, weighted as their rows */
    double bc[3 * SR_N_CONSIDER], yc[3 * SR_N_CONSIDER];
    est_consider_rows(m, Ec, bc, yc);
    if (m->opt.solver == 1) {                /* lam C + A^T b_c, lam C + phi^T y_c */
        for (int i = 0; i < m->p; i++)
            for (int c = 0; c < nc; c++) {
                double s = 0.0;
                for (int a = 0; a < k1; a++)
                    s += A[a * m->p + i] * bc[a * nc + c];
                nw->cons_lin[i * nc + c] = lam * old->cons_lin[i * nc + c] + s;
            }
        for (int i = 0; i < m->r; i++)
            for (int c = 0; c < nc; c++) {
                double s = 0.0;
                for (int a = 0; a < k2; a++)
                    s += phi[a * m->r + i] * yc[a * nc + c];
                nw->cons_ang[i * nc + c] = lam * old->cons_ang[i * nc + c] + s;
            }
        return;
    }
    for (int i = 0; i < m->q; i++)           /* lam C + Y^T [b_c; y_c] */
        for (int c = 0; c < nc; c++) {
            double s = 0.0;
            for (int a = 0; a < k1; a++)
                s += H[a * m->q + i] * bc[a * nc + c];
            for (int a = 0; a < k2; a++)
                s += H[(k1 + a) * m->q + i] * yc[a * nc + c];
            nw->cons_lin[i * nc + c] = lam * old->cons_lin[i * nc + c] + s;
        }
}

void est_consider_add(const sr_estimator_model *m, est_core *nw, const double *J,
                         double *shift)
{
    const int nc = SR_N_CONSIDER;
    for (int k = 0; k < EST_NZ; k++)                         /* each parameter at 1 sigma */
        for (int c = 0; c < nc; c++)
            shift[k * nc + c] *= m->sd_c[c];
    for (int i = 0; i < EST_NZ; i++) {
        double v = 0.0;
        for (int c = 0; c < nc; c++) {
            double dx = 0.0;
            for (int k = 0; k < EST_NZ; k++)
                dx += J[i * EST_NZ + k] * shift[k * nc + c];
            v += dx * dx;
        }
        double sdc = sqrt(v), sd = nw->sd[i];
        nw->sd[i] = sqrt(sd * sd + sdc * sdc);
    }
}
