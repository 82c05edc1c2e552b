/* The model-fit test (docs/identification.md, "When the rigid model does not fit"): whether
 * the rigid model explains the data, the identified flags it gates, and the model-error term
 * of the standard deviations where it does not. */
#ifndef SR_EST_FIT_H
#define SR_EST_FIT_H

#include "est_types.h"

/* The exponential window of the relative residual with a sample: nw->fit_win =
 * (1 - 1 / N) old->fit_win + nw->fit_now (the step's sums), N = ident.fit_window / the sample
 * interval (noise_dt) samples: counted in samples, as the estimates (not the step sizes). */
void est_fit_window(const sr_estimator_model *m, const est_core *old, int first, est_core *nw);

/* What the test says of the committed state: the statistic (diag.model_fit) and the
 * misfit's cause (SR_EST_MISFIT_*; 0 without a misfit, diag.misfit = cause != 0;
 * est_report.c answers each). With the information filter: its whitened residuals' Ljung-Box Q/L, misfit where
 * that, its chi2 or a thrust scale is beyond its threshold, the cause (sr_info_fit_of) MODEL
 * where the residuals are coloured, NOISE where chi2 is (the noise values too small), else
 * THRUST where a thrust scale is beyond its prior (a thrust miscalibration or a model error
 * it absorbs). Without: the relative residual rho = max over the linear and angular rows of
 * sqrt(sum e^2 / sum y^2) over the window, misfit (MODEL) where rho > ident.fit_rho_max and
 * the estimator has no noise model (with noise, rho measures the noise: no decision) and the
 * window's N samples came. */
void est_fit_test(const sr_estimator_model *m, const void *data, double *model_fit,
                  int *cause);

/* The identified flags (2) as the model-fit test allows them: none while misfit. */
void est_fit_gate_flags(int misfit, int *identified);

/* The model-error variance (20) of the estimates where the model does not fit: the
 * least-squares bias bound. For the unmodelled part e of the weighted rows the estimate's bias
 * is c_i^T e with |c_i^T e| <= sqrt([(A^T W A)^-1]_ii) ||P_A e||; bounding the part the
 * estimate absorbed by what the residual shows, ||P_A e|| = k ||r_excess||, gives
 * var_i = k^2 [(A^T W A)^-1]_ii ||r_excess||^2 = k^2 unit_var_i excess, unit_var_i the
 * variance per unit of residual (the bound^2, or the scatter sd^2 over its degrees of
 * freedom), excess the residual's sum of squares beyond the noise's. (Where a second model
 * is at hand, the difference of the two estimates belongs here.) */
void est_fit_model_error_var(double k, const double *unit_var, double excess, double *var);

#endif /* SR_EST_FIT_H */
