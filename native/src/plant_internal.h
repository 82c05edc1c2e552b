/* Internals of the plant core shared by its files: plant.c (the model, the outputs, the state),
 * plant_step.c (RK4), plant_control.c (the controllers), plant_excitation.c,
 * plant_propellant.c and plant_leaves.c (the flexible parts). Not part of the library's API. */
#ifndef SR_PLANT_INTERNAL_H
#define SR_PLANT_INTERNAL_H

#include "plant.h"

/* a model sr_plant_model_init built (its sizes consistent: no access out of bounds) */
static inline int plant_model_ok(const sr_plant_model *md)
{
    if (md == NULL || (md->planar != 0 && md->planar != 1) || md->n < 1
        || md->n > SR_MAX_JOINTS)
        return 0;
    if (md->n_flex < 0 || md->n_flex > SR_PLANT_MAX_FLEX || md->n_slosh < 0
        || md->n_slosh > SR_PLANT_MAX_SLOSH || md->nl != md->n_flex + md->n_slosh
        || md->dyn.nl != md->nl)
        return 0;
    return md->nb == (md->planar ? 3 : 6) && md->nq0 == (md->planar ? 4 : 7)
           && md->nq == md->nq0 + md->n + md->nl
           && md->nv == md->nb + md->n + md->nl && md->nx == 6 + md->nq + md->nv + 7
           && md->ny == SR_PLANT_NY(md->n) && md->n_att == (md->planar ? 1 : 3)
           && md->n_ch == md->n_att + md->n && md->h > 0.0 && md->h <= 1.0
           && md->ex.ramp > 0.0;
}

/* -- the tables (plant_params.c) ------------------------------------------------------------ */
/* at (SR_PLANT_Y_COUNT + 1): where each output starts in the output vector of n joints */
void plant_output_offsets(int n, int *at);
/* 0 when the size numbers v are within [lo, hi], else 1 with "<name>[k] must be within
 * [lo, hi] <unit>, got <value>" in err */
int plant_check_range(const char *name, const double *v, int size, double lo, double hi,
                      const char *unit, char *err, size_t errlen);
/* plant_check_range of every field of the struct s of table (enum sr_plant_table) */
int plant_check_fields(int table, const void *s, char *err, size_t errlen);
/* the same for record rec (0-based) of a table of several records (names <name>[rec + 1],
 * <name>[rec + 1,k]) */
int plant_check_record(int table, int rec, const void *s, char *err, size_t errlen);
/* the FMI name of field field_name of table, record rec (0-based; ignored for a table of one
 * record), element k (0-based; -1: the field as a whole) into err */
void plant_field_name(int table, const char *field_name, int rec, int k, char *err,
                      size_t errlen);

/* -- the excitation (plant_excitation.c) ------------------------------------------------- */
void plant_ramp_level(double t, const double *ramp, double *s);
void plant_fill_trig(const sr_plant_model *md, const sr_plant_data *d, double t,
                     double (*trig)[4]);
void plant_rotate_trig(const sr_plant_model *md, sr_plant_data *d);
void plant_channel(const double *row, const double *trig, double *f);
void plant_level_times(const double *s, const double *f, double *out);
void plant_excitation_table(const sr_plant_model *md, double rate, sr_plant_data *d);
void plant_excitation_update(const sr_plant_model *md, sr_plant_data *d);

/* -- the controllers (plant_control.c) --------------------------------------------------- */
int plant_thrust_control(const sr_plant_model *md, sr_plant_data *d, double t,
                         const double *ramp, double m_p, double dt);

/* -- the propellant (plant_propellant.c) ------------------------------------------------- */
double plant_mass_flow(const double *FM, const double *pp);
void plant_base_spatial(const sr_plant_model *md, double m_p, double *m, double *hB,
                        double *IS);
int plant_base_inertia(const sr_plant_model *md, sr_plant_data *d, double m_p);
void plant_propellant_rates(const sr_plant_model *md, const double *xa, const double *A,
                            double flow, double *row);
void plant_base_now(const sr_plant_model *md, double m_p, double *out);

/* -- the flexible parts (plant_leaves.c) ------------------------------------------------- */
/* the leaves' spring and damper forces -k q - c qd of the configuration d->qn, d->vs into
 * their generalised forces d->gen[nb + n ..] */
void plant_leaf_forces(const sr_plant_model *md, sr_plant_data *d);
/* the composite rigid base [m, b (3), Ixx Iyy Izz Ixy Ixz Iyz] with m_p of propellant */
void plant_composite_now(const sr_plant_model *md, double m_p, double *out);

/* -- the integration (plant_step.c) ------------------------------------------------------ */
void plant_load(const sr_plant_model *md, const double *x, sr_plant_data *d);
int plant_control_here(const sr_plant_model *md, sr_plant_data *d, const double *x, double t,
                       const double *ramp, double dt, int anchor);

#endif /* SR_PLANT_INTERNAL_H */
