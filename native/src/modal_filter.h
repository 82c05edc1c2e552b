/* One flexible mode's filter, driven by the base's measured motion, and the momentum columns
 * it gives (docs/identification.md section 8): what the modal columns (est_modal.h) and the
 * rigid band's compliance (band.h) share. est_modal.c implements them. */
#ifndef SR_MODAL_FILTER_H
#define SR_MODAL_FILTER_H

#define EST_MODAL_GC_COLS 57       /* the G (21) and C (36) blocks' columns of one frequency */
#define EST_MODAL_COLS 165         /* and with the D (36) and T (72) blocks */

/* a sample's drive (12) and the doubles a kept sample needs beside its rows */
#define EST_MODAL_U 12
#define EST_MODAL_SIG (1 + 12 + 3 + 3 + 9 + 3)   /* t, u, omega_B, v_B, A, r_S */

/* one frequency's filter: eta and eta' per drive channel */
typedef struct est_modal_filter {
    double w, zeta;
    double eta[EST_MODAL_U], etad[EST_MODAL_U];
    double key[3], step[8];    /* the step's coefficients for (w, zeta, dt) = key */
    double given;              /* 1: from ident.mode_f (refined, never dropped), 0: found */
} est_modal_filter;

/* One step of a filter over dt for the drive u0 -> u1 (linear in between; exact) */
void est_modal_filter_step(est_modal_filter *f, double dt, const double *u0, const double *u1);

/* the signals of the sample x at t (EST_MODAL_SIG: t, the drive u, omega_B, v_B, A, r_S) */
void est_modal_signals(double t, const double *x, double *sig);

/* The momentum columns of one frequency (6 x nc, row-major; nc = 165: the G, C, D and T
 * blocks, or EST_MODAL_GC_COLS: the G and C blocks only) at the signals sig with the filter's eta,
 * eta' there, in inertial axes, the angular rows about the point p_I */
void est_modal_columns(const double *eta, const double *etad, const double *sig,
                       const double *p_I, int nc, double *out);

#endif /* SR_MODAL_FILTER_H */
