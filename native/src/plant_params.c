/* The plant's tables (plant.h): the outputs' keys and sizes, the parameter structs' fields with
 * their FMI names, units and ranges, the check of a parameter against its range, and the
 * ranges of every parameter and input of the plant FMU. */
#include <stddef.h>
#include <string.h>

#include "body.h"
#include "plant_internal.h"
#include "sr_text.h"

/* -- the outputs ----------------------------------------------------------------------------- */

static const struct {
    const char *key, *unit, *what;
    int fixed, per_joint;
} OUTPUTS[SR_PLANT_Y_COUNT] = {
#define ROW_(id, key, fixed, per_joint, unit, what) {key, unit, what, fixed, per_joint},
#define ROW_S_(id, key, fmi, fixed, per_joint, unit, what) {key, unit, what, fixed, per_joint},
    SR_SAMPLE_SIGNALS(ROW_S_)
    SR_PLANT_OUTPUTS(ROW_)
#undef ROW_
#undef ROW_S_
};

void plant_output_offsets(int n, int *at)
{
    int k;
    at[0] = 0;
    for (k = 0; k < SR_PLANT_Y_COUNT; k++)
        at[k + 1] = at[k] + OUTPUTS[k].fixed + OUTPUTS[k].per_joint * n;
}

SR_API int sr_plant_output_count(void) { return SR_PLANT_Y_COUNT; }

SR_API const char *sr_plant_output_name(int k)
{
    return k >= 0 && k < SR_PLANT_Y_COUNT ? OUTPUTS[k].key : NULL;
}

SR_API const char *sr_plant_output_unit(int k)
{
    return k >= 0 && k < SR_PLANT_Y_COUNT ? OUTPUTS[k].unit : NULL;
}

SR_API const char *sr_plant_output_description(int k)
{
    return k >= 0 && k < SR_PLANT_Y_COUNT ? OUTPUTS[k].what : NULL;
}

/* -- the parameter structs ------------------------------------------------------------------- */

typedef struct field {
    const char *name, *fmi, *unit, *what;
    int size;                  /* doubles */
    size_t offset;             /* in the struct [bytes] */
    double lo, hi;             /* the range */
} field;

#define FIELD_(type, f, dims, fmi, unit, lo, hi, what)                                          \
    {#f, fmi, unit, what, (int)(sizeof(((type *)0)->f) / sizeof(double)), offsetof(type, f), lo, \
     hi},
#define CTRL_(f, dims, fmi, unit, lo, hi, what)                                                 \
    FIELD_(sr_plant_controller, f, dims, fmi, unit, lo, hi, what)
#define EX_(f, dims, fmi, unit, lo, hi, what)                                                   \
    FIELD_(sr_plant_excitation, f, dims, fmi, unit, lo, hi, what)
#define PROP_(f, dims, fmi, unit, lo, hi, what)                                                 \
    FIELD_(sr_plant_propellant, f, dims, fmi, unit, lo, hi, what)
static const field CONTROLLER[] = {SR_PLANT_CONTROLLER_FIELDS(CTRL_)};
static const field EXCITATION[] = {SR_PLANT_EXCITATION_FIELDS(EX_)};
static const field PROPELLANT[] = {SR_PLANT_PROPELLANT_FIELDS(PROP_)};
#undef CTRL_
#undef EX_
#undef PROP_
#undef FIELD_

static const struct {
    const field *fields;
    int count;
} TABLES[SR_PLANT_TABLE_COUNT] = {
    {CONTROLLER, (int)(sizeof CONTROLLER / sizeof CONTROLLER[0])},
    {EXCITATION, (int)(sizeof EXCITATION / sizeof EXCITATION[0])},
    {PROPELLANT, (int)(sizeof PROPELLANT / sizeof PROPELLANT[0])},
};

/* every field a double or 3 (what the FMU's variables and the bindings assume) */
#define SIZE_OK_(type, f) (sizeof(((type *)0)->f) == sizeof(double)                             \
                           || sizeof(((type *)0)->f) == 3 * sizeof(double))
#define CHECK_CTRL_(f, dims, fmi, unit, lo, hi, what) && SIZE_OK_(sr_plant_controller, f)
#define CHECK_EX_(f, dims, fmi, unit, lo, hi, what) && SIZE_OK_(sr_plant_excitation, f)
#define CHECK_PROP_(f, dims, fmi, unit, lo, hi, what) && SIZE_OK_(sr_plant_propellant, f)
typedef char check_field_sizes_[(1 SR_PLANT_CONTROLLER_FIELDS(CHECK_CTRL_)
                                 SR_PLANT_EXCITATION_FIELDS(CHECK_EX_)
                                 SR_PLANT_PROPELLANT_FIELDS(CHECK_PROP_)) ? 1 : -1];

static const field *field_at(int table, int i)
{
    if (table < 0 || table >= SR_PLANT_TABLE_COUNT || i < 0 || i >= TABLES[table].count)
        return NULL;
    return &TABLES[table].fields[i];
}

SR_API int sr_plant_field_count(int table)
{
    return table >= 0 && table < SR_PLANT_TABLE_COUNT ? TABLES[table].count : -1;
}

SR_API const char *sr_plant_field_name(int table, int i)
{
    const field *f = field_at(table, i);
    return f != NULL ? f->name : NULL;
}

SR_API const char *sr_plant_field_fmi_name(int table, int i)
{
    const field *f = field_at(table, i);
    return f != NULL ? f->fmi : NULL;
}

SR_API const char *sr_plant_field_unit(int table, int i)
{
    const field *f = field_at(table, i);
    return f != NULL ? f->unit : NULL;
}

SR_API const char *sr_plant_field_description(int table, int i)
{
    const field *f = field_at(table, i);
    return f != NULL ? f->what : NULL;
}

SR_API int sr_plant_field_size(int table, int i)
{
    const field *f = field_at(table, i);
    return f != NULL ? f->size : -1;
}

SR_API long sr_plant_field_offset(int table, int i)
{
    const field *f = field_at(table, i);
    return f != NULL ? (long)f->offset : -1;
}

SR_API int sr_plant_field_range(int table, int i, double *min, double *max)
{
    const field *f = field_at(table, i);
    if (f == NULL)
        return 1;
    if (min != NULL)
        *min = f->lo;
    if (max != NULL)
        *max = f->hi;
    return 0;
}

/* err = "<name>[<k + 1>] must be within [lo, hi] <unit>, got <value>" (no index for size 1) */
static void range_message(const char *name, int size, int k, double lo, double hi,
                          const char *unit, double value, char *err, size_t errlen)
{
    sr_text_set(err, errlen, name);
    if (size > 1) {
        sr_text_cat(err, errlen, "[");
        sr_text_int(err, errlen, k + 1);
        sr_text_cat(err, errlen, "]");
    }
    sr_text_cat(err, errlen, " must be within [");
    sr_text_num(err, errlen, lo, 6);
    sr_text_cat(err, errlen, ", ");
    sr_text_num(err, errlen, hi, 6);
    sr_text_cat(err, errlen, "] ");
    sr_text_cat(err, errlen, unit);
    sr_text_cat(err, errlen, ", got ");
    sr_text_repr(err, errlen, value);
}

int plant_check_range(const char *name, const double *v, int size, double lo, double hi,
                      const char *unit, char *err, size_t errlen)
{
    int k;
    for (k = 0; k < size; k++)
        if (!(v[k] >= lo && v[k] <= hi)) {
            range_message(name, size, k, lo, hi, unit, v[k], err, errlen);
            return 1;
        }
    return 0;
}

int plant_check_fields(int table, const void *s, char *err, size_t errlen)
{
    int i;
    for (i = 0; i < TABLES[table].count; i++) {
        const field *f = &TABLES[table].fields[i];
        const double *v = (const double *)((const char *)s + f->offset);
        if (plant_check_range(f->fmi, v, f->size, f->lo, f->hi, f->unit, err, errlen))
            return 1;
    }
    return 0;
}

/* -- every parameter and input of the plant FMU ---------------------------------------------- */

/* the bound |a product of inertia| <= (max - min) / 2 that principal moments within
 * [min, max] imply (an off-diagonal element of a symmetric matrix is at most half the spread
 * of its eigenvalues) */
#define PRODUCT_MAX_ (0.5 * (SR_BODY_INERTIA_MAX - SR_BODY_INERTIA_MIN))

/* the plant's parameters and inputs that are not fields of the structs, in the FMU's order
 * around them: before the controller, and between it and the excitation */
typedef struct param {
    const char *fmi;
    int size;
    double lo, hi;
} param;

#define BODY_(b)                                                                                \
    {b ".m", 1, SR_BODY_MASS_MIN, SR_BODY_MASS_MAX},                                            \
    {b ".b", 3, -SR_BODY_COM_MAX, SR_BODY_COM_MAX},                                             \
    {b ".Ixx", 1, SR_BODY_INERTIA_MIN, SR_BODY_INERTIA_MAX},                                    \
    {b ".Iyy", 1, SR_BODY_INERTIA_MIN, SR_BODY_INERTIA_MAX},                                    \
    {b ".Izz", 1, SR_BODY_INERTIA_MIN, SR_BODY_INERTIA_MAX},                                    \
    {b ".Ixy", 1, -PRODUCT_MAX_, PRODUCT_MAX_},                                                 \
    {b ".Ixz", 1, -PRODUCT_MAX_, PRODUCT_MAX_},                                                 \
    {b ".Iyz", 1, -PRODUCT_MAX_, PRODUCT_MAX_}
static const param BEFORE[] = {
    BODY_("base"), BODY_("target"),
    {"base.v0", 3, -SR_PLANT_V0_MAX, SR_PLANT_V0_MAX},
    {"base.omega0", 3, -SR_PLANT_OMEGA0_MAX, SR_PLANT_OMEGA0_MAX},
};
#undef BODY_
static const param BETWEEN[] = {
    {"h", 1, SR_PLANT_H_MIN, SR_PLANT_H_MAX},
    {"ident.excite", 1, SR_PLANT_LEVEL_MIN, SR_PLANT_LEVEL_MAX},
    {"ident.excite_rate", 1, SR_PLANT_RATE_MIN, SR_PLANT_RATE_MAX},
};

/* the parameters in order, as params: BEFORE, the controller, BETWEEN, the excitation, the
 * propellant; *out = entry j (0, or 1 past the last) */
static int param_at(int j, param *out)
{
    static const struct {
        const param *list;
        int count, table;      /* a list, or a table (list NULL) */
    } PARTS[] = {
        {BEFORE, (int)(sizeof BEFORE / sizeof BEFORE[0]), -1},
        {NULL, 0, SR_PLANT_TABLE_CONTROLLER},
        {BETWEEN, (int)(sizeof BETWEEN / sizeof BETWEEN[0]), -1},
        {NULL, 0, SR_PLANT_TABLE_EXCITATION},
        {NULL, 0, SR_PLANT_TABLE_PROPELLANT},
    };
    int p;
    for (p = 0; p < (int)(sizeof PARTS / sizeof PARTS[0]); p++) {
        const int count = PARTS[p].list != NULL ? PARTS[p].count : TABLES[PARTS[p].table].count;
        if (j < count) {
            if (PARTS[p].list != NULL) {
                *out = PARTS[p].list[j];
            } else {
                const field *f = &TABLES[PARTS[p].table].fields[j];
                out->fmi = f->fmi;
                out->size = f->size;
                out->lo = f->lo;
                out->hi = f->hi;
            }
            return 0;
        }
        j -= count;
    }
    return 1;
}

SR_API int sr_plant_param_name(int i, char *name, size_t size)
{
    param p;
    int j;
    for (j = 0; i >= 0 && param_at(j, &p) == 0; j++) {
        if (i < p.size) {
            if (p.size == 1)
                sr_text_set(name, size, p.fmi);
            else
                sr_text_format(name, size, "%s[%d]", p.fmi, i + 1);
            return 0;
        }
        i -= p.size;
    }
    return 1;
}

SR_API int sr_plant_param_range(const char *fmi_name, double *min, double *max)
{
    param p;
    int j;
    size_t len;
    if (fmi_name == NULL)
        return 1;
    for (j = 0; param_at(j, &p) == 0; j++) {
        len = strlen(p.fmi);
        if (strncmp(fmi_name, p.fmi, len) != 0)
            continue;
        if (p.size == 1 ? fmi_name[len] != '\0'
                        : !(fmi_name[len] == '[' && fmi_name[len + 1] >= '1'
                            && fmi_name[len + 1] < '1' + p.size && fmi_name[len + 2] == ']'
                            && fmi_name[len + 3] == '\0'))
            continue;
        if (min != NULL)
            *min = p.lo;
        if (max != NULL)
            *max = p.hi;
        return 0;
    }
    return 1;
}
