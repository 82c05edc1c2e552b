/* What the information filter's files share (information.c: the filter; info_rows.c: its rows
 * and their noise; info_fit.c: the model-fit test and the estimate with the thrust held) and
 * the rigid band (band.c) calls: internal to the core, not part of information.h's
 * interface. */
#ifndef SR_INFO_INTERNAL_H
#define SR_INFO_INTERNAL_H

#include "information.h"

#define MU SR_INFO_MAX_U             /* row stride of R, N_HH */
/* a function kept out of its caller's frame: two of the large temporaries never share one */
#if defined(__GNUC__)
#define INFO_NOINLINE __attribute__((noinline))
#else
#define INFO_NOINLINE
#endif
#define HS (MU + 1)                  /* row stride of a block of rows [H | y] */

/* information.c */
void info_reported_of_u(const sr_info_model *m, const double *u, double *x);
int info_bound_with(const sr_info_model *m, int nu, const double *Ri,
                    const double *G, const double *u, double *bound);
void info_solve_square_root(int nu, const double *R, const double *dv,
                            const double *N_HH, const double *N_Hy,
                            int compensated, double *u, double *Ri);
void info_solve_unknowns(const sr_info_model *m, const sr_info_data *d, int compensated,
                         double *u, double *Ri);
/* the sample's rows and weight, its errors-in-variables products (sr_info_add's parts; the
   rigid band, band.c, forms its rows with them too) */
void info_sample_rows(const sr_info_model *m, const double *x, const double *K,
                      const double *z, double *Hy);
int info_sample_weight(const sr_info_model *m, const double *x, const double *K,
                       const double *z, const double *me_var, const double *Hy, double *W,
                       double *xs, sr_info_work *w);
void info_eiv_sample(const sr_info_model *m, const double *x, const double *K,
                     const double *Hy, const double *W, double *xs, sr_info_work *w,
                     double *N_HH, double *N_Hy);
/* info_rows.c */
void info_white_sds(const sr_info_noise *n, double *w);
void info_rows_full(const sr_info_model *m, const double *x, double full[6][20], double *y);
void info_rows_at(const sr_info_model *m, const double *x, const double *zO, double *r);
void info_linear_rows(const sr_info_model *m, const double *x, const double *k, double *H,
                      double *y);
int info_channels(const sr_info_model *m, int *idx, double *sd);
double info_nav_product_var(const sr_info_model *m);
void info_nav_mixed(const sr_info_model *m, const double *x, const double *k, const double *Hy,
                    double *xs, double (*V)[6 * HS], double (*G)[6 * HS]);
int info_noise_weight(const sr_info_model *m, const double *x, const double *z,
                      const double (*G)[6 * HS], const double *me_var, double *W);
void info_weigh(const double *W, int nr, const double *in, int ld, int ncol, double *out);
/* info_fit.c */
/* 1 where d's residuals are coloured beyond the model-fit test's threshold and its thrust
   ratio is finite: the fit test's model-error decision (info_fit.c) */
int info_coloured(const sr_info_model *m, const sr_info_data *d);
void info_model_error_of(const sr_info_model *m, const double *buffer, const double *z,
                         double *me_var);

#endif
