/* The standard parameters and the reported estimates, each from the other (standard_params.h). */
#include "standard_params.h"

#include <string.h>

const int SR_SHARP_TO_PROJECT[6] = {0, 3, 5, 1, 2, 4};
const int SR_SHARP_I[6] = {0, 0, 0, 1, 1, 2}, SR_SHARP_J[6] = {0, 1, 2, 1, 2, 2};

void sr_standard_of_reported(const double *x, double *z)
{
    for (int k = 0; k < 2; k++) {
        const double *g = x + 10 * k;
        double mk = g[0], bb = g[1] * g[1] + g[2] * g[2] + g[3] * g[3];
        double Ic[9] = {g[4], g[7], g[8], g[7], g[5], g[9], g[8], g[9], g[6]};
        z[10 * k] = mk;
        for (int i = 0; i < 3; i++)
            z[10 * k + 1 + i] = mk * g[1 + i];
        for (int q = 0; q < 6; q++) {
            int i = SR_SHARP_I[q], j = SR_SHARP_J[q];
            double par = (i == j ? bb * 1.0 : bb * 0.0) - g[1 + i] * g[1 + j];
            z[10 * k + 4 + q] = Ic[3 * i + j] + mk * par;       /* I_O = I_c + m S(b) */
        }
    }
}

void sr_reported_of_standard(const double *z, double *out)
{
    for (int k = 0; k < 2; k++) {
        int e = 10 * k;
        double m = z[e], b[3], bb = 0.0;
        out[e] = m;
        for (int i = 0; i < 3; i++) {
            b[i] = z[e + 1 + i] / m;                         /* b = c / m */
            out[e + 1 + i] = b[i];
        }
        for (int i = 0; i < 3; i++)
            bb += b[i] * b[i];
        for (int jp = 0; jp < 6; jp++) {
            int p = SR_SHARP_TO_PROJECT[jp], i = SR_SHARP_I[p], j = SR_SHARP_J[p];
            double eye = i == j ? 1.0 : 0.0;
            out[e + 4 + jp] = z[e + 4 + p] - m * (bb * eye - b[i] * b[j]);   /* I_c */
        }
    }
}

void sr_reported_jacobian(const double *z, double *J)
{
    memset(J, 0, sizeof(double) * 20 * 20);
    for (int k = 0; k < 2; k++) {
        int e = 10 * k;
        double m = z[e], cc = 0.0;
        J[e * 20 + e] = 1.0;
        for (int i = 0; i < 3; i++) {
            J[(e + 1 + i) * 20 + e + 1 + i] = 1.0 / m;
            J[(e + 1 + i) * 20 + e] = -z[e + 1 + i] / (m * m);
        }
        for (int i = 0; i < 3; i++)
            cc += z[e + 1 + i] * z[e + 1 + i];
        for (int jp = 0; jp < 6; jp++) {
            int p = SR_SHARP_TO_PROJECT[jp], row = e + 4 + jp, i = SR_SHARP_I[p],
                j = SR_SHARP_J[p];
            double ci = z[e + 1 + i], cj = z[e + 1 + j];
            double S_ij = (i == j ? cc : 0.0) - ci * cj;
            J[row * 20 + e + 4 + p] = 1.0;
            J[row * 20 + e] = S_ij / (m * m);
            for (int kk = 0; kk < 3; kk++) {
                double dS = (i == j ? 2.0 * z[e + 1 + kk] : 0.0) - (kk == i ? cj : 0.0)
                            - (kk == j ? ci : 0.0);
                J[row * 20 + e + 1 + kk] = -dS / m;
            }
        }
    }
}
