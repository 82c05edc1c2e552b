/* Errors in variables (est_eiv.h): the expected noise part of the Gram matrices and the
 * covariance of a bias-compensated answer. */
#include "est_eiv.h"

#include "linalg.h"

void est_noise_begin(double lam, int has, const double *N_old, int n, double *N)
{
    for (int i = 0; i < n * n; i++)          /* lam N (as the Gram matrices: lam S + R^T R) */
        N[i] = !has ? 0.0 : lam == 1.0 ? N_old[i] : lam * N_old[i];
}

void est_compensate(const double *S, const double *N, int n, int q, const double *x,
                    double *xc)
{
    double G[20 * 20] = {0.0}, rhs[20], dx[20], lam[20], *V = G, d[20];     /* (V in place) */
    int un[20], u[20];
    for (int i = 0; i < q; i++) {
        double s = 0.0;
        for (int j = 0; j < q; j++) {
            G[i * q + j] = S[i * n + j] - N[i * n + j];
            s += N[i * n + j] * x[j];
        }
        rhs[i] = s - N[i * n + q];                     /* N_HH x_r - N_Hy */
    }
    sr_scaled_eigh(G, q, lam, V, d, un);
    sr_eig_solve(lam, V, d, un, rhs, q, dx, u);
    for (int i = 0; i < q; i++)
        xc[i] = x[i] + dx[i];
}

void est_compensated_covariance(const double *S, const double *N, int n, int q,
                                const double *P, double *out)
{
    /* G: S - N, then in place its scaled eigenvectors V, then K P */
    double G[20 * 20] = {0.0}, K[20 * 20], *V = G, *KP = G;
    double col[20], x[20], lam[20], d[20];
    int un[20], u[20];
    for (int i = 0; i < q; i++)
        for (int j = 0; j < q; j++)
            G[i * q + j] = S[i * n + j] - N[i * n + j];
    sr_scaled_eigh(G, q, lam, V, d, un);
    for (int j = 0; j < q; j++) {                        /* column j of (S - N)^-1 N */
        for (int i = 0; i < q; i++)
            col[i] = N[i * n + j];
        sr_eig_solve(lam, V, d, un, col, q, x, u);
        for (int i = 0; i < q; i++)
            K[i * q + j] = (i == j ? 1.0 : 0.0) + x[i];
    }
    sr_matmul(K, P, q, q, q, KP);
    for (int i = 0; i < q; i++)                          /* (K P) K^T */
        for (int j = 0; j < q; j++) {
            double s = 0.0;
            for (int l = 0; l < q; l++)
                s += KP[i * q + l] * K[j * q + l];
            out[i * q + j] = s;
        }
}

