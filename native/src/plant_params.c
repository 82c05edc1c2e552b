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
#define FLEX_(f, dims, fmi, unit, lo, hi, what)                                                 \
    FIELD_(sr_plant_panel, f, dims, fmi, unit, lo, hi, what)
#define SLOSH_(f, dims, fmi, unit, lo, hi, what)                                                \
    FIELD_(sr_plant_slosh, f, dims, fmi, unit, lo, hi, what)
static const field CONTROLLER[] = {SR_PLANT_CONTROLLER_FIELDS(CTRL_)};
static const field EXCITATION[] = {SR_PLANT_EXCITATION_FIELDS(EX_)};
static const field PROPELLANT[] = {SR_PLANT_PROPELLANT_FIELDS(PROP_)};
static const field FLEX[] = {SR_PLANT_FLEX_FIELDS(FLEX_)};
static const field SLOSH[] = {SR_PLANT_SLOSH_FIELDS(SLOSH_)};
#undef CTRL_
#undef EX_
#undef PROP_
#undef FLEX_
#undef SLOSH_
#undef FIELD_

static const struct {
    const field *fields;
    int count;
    int records;               /* records of the struct the FMU has */
} TABLES[SR_PLANT_TABLE_COUNT] = {
    {CONTROLLER, (int)(sizeof CONTROLLER / sizeof CONTROLLER[0]), 1},
    {EXCITATION, (int)(sizeof EXCITATION / sizeof EXCITATION[0]), 1},
    {PROPELLANT, (int)(sizeof PROPELLANT / sizeof PROPELLANT[0]), 1},
    {FLEX, (int)(sizeof FLEX / sizeof FLEX[0]), SR_PLANT_MAX_FLEX},
    {SLOSH, (int)(sizeof SLOSH / sizeof SLOSH[0]), SR_PLANT_MAX_SLOSH},
};

/* every field a double or 3 (what the FMU's variables and the bindings assume) */
#define SIZE_OK_(type, f) (sizeof(((type *)0)->f) == sizeof(double)                             \
                           || sizeof(((type *)0)->f) == 3 * sizeof(double))
#define CHECK_CTRL_(f, dims, fmi, unit, lo, hi, what) && SIZE_OK_(sr_plant_controller, f)
#define CHECK_EX_(f, dims, fmi, unit, lo, hi, what) && SIZE_OK_(sr_plant_excitation, f)
#define CHECK_PROP_(f, dims, fmi, unit, lo, hi, what) && SIZE_OK_(sr_plant_propellant, f)
#define CHECK_FLEX_(f, dims, fmi, unit, lo, hi, what) && SIZE_OK_(sr_plant_panel, f)
#define CHECK_SLOSH_(f, dims, fmi, unit, lo, hi, what) && SIZE_OK_(sr_plant_slosh, f)
typedef char check_field_sizes_[(1 SR_PLANT_CONTROLLER_FIELDS(CHECK_CTRL_)
                                 SR_PLANT_EXCITATION_FIELDS(CHECK_EX_)
                                 SR_PLANT_PROPELLANT_FIELDS(CHECK_PROP_)
                                 SR_PLANT_FLEX_FIELDS(CHECK_FLEX_)
                                 SR_PLANT_SLOSH_FIELDS(CHECK_SLOSH_)) ? 1 : -1];
/* the record indices of the FMI names are single digits (sr_plant_param_range) */
typedef char check_records_[(SR_PLANT_MAX_FLEX <= 9 && SR_PLANT_MAX_SLOSH <= 9
                             && SR_PLANT_MAX_LEAVES <= SR_DYN_MAX_LEAVES) ? 1 : -1];

static const field *field_at(int table, int i)
{
    if (table < 0 || table >= SR_PLANT_TABLE_COUNT || i < 0 || i >= TABLES[table].count)
        return NULL;
    return &TABLES[table].fields[i];
}

SR_API int sr_plant_table_records(int table)
{
    return table >= 0 && table < SR_PLANT_TABLE_COUNT ? TABLES[table].records : -1;
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

/* "<name>" for element k of a value of size numbers of record rec (-1: a struct of one
 * record): name, name[k + 1], name[rec + 1], name[rec + 1,k + 1] (FMI names, 1-based) */
static void element_name(const char *name, int rec, int size, int k, char *err, size_t errlen)
{
    sr_text_set(err, errlen, name);
    if (size > 1 || rec >= 0) {
        sr_text_cat(err, errlen, "[");
        if (rec >= 0) {
            sr_text_int(err, errlen, rec + 1);
            if (size > 1)
                sr_text_cat(err, errlen, ",");
        }
        if (size > 1)
            sr_text_int(err, errlen, k + 1);
        sr_text_cat(err, errlen, "]");
    }
}

/* err = "<element name> must be within [lo, hi] <unit>, got <value>" */
static void range_message(const char *name, int rec, int size, int k, double lo, double hi,
                          const char *unit, double value, char *err, size_t errlen)
{
    element_name(name, rec, size, k, err, errlen);
    sr_text_cat(err, errlen, " must be within [");
    sr_text_num(err, errlen, lo, 6);
    sr_text_cat(err, errlen, ", ");
    sr_text_num(err, errlen, hi, 6);
    sr_text_cat(err, errlen, "] ");
    sr_text_cat(err, errlen, unit);
    sr_text_cat(err, errlen, ", got ");
    sr_text_repr(err, errlen, value);
}

/* plant_check_range of the values of record rec (-1: a struct of one record) */
static int check_values(const char *name, int rec, const double *v, int size, double lo,
                        double hi, const char *unit, char *err, size_t errlen)
{
    int k;
    for (k = 0; k < size; k++)
        if (!(v[k] >= lo && v[k] <= hi)) {
            range_message(name, rec, size, k, lo, hi, unit, v[k], err, errlen);
            return 1;
        }
    return 0;
}

int plant_check_range(const char *name, const double *v, int size, double lo, double hi,
                      const char *unit, char *err, size_t errlen)
{
    return check_values(name, -1, v, size, lo, hi, unit, err, errlen);
}

int plant_check_record(int table, int rec, const void *s, char *err, size_t errlen)
{
    int i;
    for (i = 0; i < TABLES[table].count; i++) {
        const field *f = &TABLES[table].fields[i];
        const double *v = (const double *)((const char *)s + f->offset);
        if (check_values(f->fmi, rec, v, f->size, f->lo, f->hi, f->unit, err, errlen))
            return 1;
    }
    return 0;
}

int plant_check_fields(int table, const void *s, char *err, size_t errlen)
{
    return plant_check_record(table, -1, s, err, errlen);
}

void plant_field_name(int table, const char *field_name, int rec, int k, char *err,
                      size_t errlen)
{
    int i;
    for (i = 0; i < TABLES[table].count; i++) {
        const field *f = &TABLES[table].fields[i];
        if (strcmp(f->name, field_name) == 0) {
            element_name(f->fmi, TABLES[table].records > 1 ? rec : -1, k >= 0 ? f->size : 1,
                         k, err, errlen);
            return;
        }
    }
    sr_text_set(err, errlen, field_name);
}

/* -- every parameter and input of the plant FMU ---------------------------------------------- */

/* the plant's parameters and inputs that are not fields of the structs, in the FMU's order
 * around them: before the controller, between it and the excitation, and the counts of the
 * flexible parts before their tables */
typedef struct param {
    const char *fmi;
    int size;
    double lo, hi;
    int records;               /* 1, or the records of a table's struct (names [i] / [i,k]) */
} param;

#define BODY_(b)                                                                                \
    {b ".m", 1, SR_BODY_MASS_MIN, SR_BODY_MASS_MAX, 1},                                         \
    {b ".b", 3, -SR_BODY_COM_MAX, SR_BODY_COM_MAX, 1},                                          \
    {b ".Ixx", 1, SR_BODY_INERTIA_MIN, SR_BODY_INERTIA_MAX, 1},                                 \
    {b ".Iyy", 1, SR_BODY_INERTIA_MIN, SR_BODY_INERTIA_MAX, 1},                                 \
    {b ".Izz", 1, SR_BODY_INERTIA_MIN, SR_BODY_INERTIA_MAX, 1},                                 \
    {b ".Ixy", 1, -SR_BODY_PRODUCT_MAX, SR_BODY_PRODUCT_MAX, 1},                                \
    {b ".Ixz", 1, -SR_BODY_PRODUCT_MAX, SR_BODY_PRODUCT_MAX, 1},                                \
    {b ".Iyz", 1, -SR_BODY_PRODUCT_MAX, SR_BODY_PRODUCT_MAX, 1}
static const param BEFORE[] = {
    BODY_("base"), BODY_("target"),
    {"base.v0", 3, -SR_PLANT_V0_MAX, SR_PLANT_V0_MAX, 1},
    {"base.omega0", 3, -SR_PLANT_OMEGA0_MAX, SR_PLANT_OMEGA0_MAX, 1},
};
#undef BODY_
static const param BETWEEN[] = {
    {"h", 1, SR_PLANT_H_MIN, SR_PLANT_H_MAX, 1},
    {"ident.excite", 1, SR_PLANT_LEVEL_MIN, SR_PLANT_LEVEL_MAX, 1},
    {"ident.excite_rate", 1, SR_PLANT_RATE_MIN, SR_PLANT_RATE_MAX, 1},
};
static const param FLEX_N[] = {{"flex.n", 1, 0.0, SR_PLANT_MAX_FLEX, 1}};
static const param SLOSH_N[] = {{"slosh.n", 1, 0.0, SR_PLANT_MAX_SLOSH, 1}};

/* the parameters in order, as params: BEFORE, the controller, BETWEEN, the excitation, the
 * propellant, the panels' count and table, the slosh modes' count and table; *out = entry j
 * (0, or 1 past the last) */
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
        {FLEX_N, 1, -1},
        {NULL, 0, SR_PLANT_TABLE_FLEX},
        {SLOSH_N, 1, -1},
        {NULL, 0, SR_PLANT_TABLE_SLOSH},
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
                out->records = TABLES[PARTS[p].table].records;
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
        if (i < p.records * p.size) {
            element_name(p.fmi, p.records > 1 ? i / p.size : -1, p.size, i % p.size, name,
                         size);
            return 0;
        }
        i -= p.records * p.size;
    }
    return 1;
}

/* the index suffix s of an FMI name: "" (count 0), "[a]" (1) or "[a,b]" (2) with single
 * digits a, b >= 1 into idx; -1 if malformed */
static int index_suffix(const char *s, int *idx)
{
    int count = 0;
    if (*s == '\0')
        return 0;
    if (*s++ != '[')
        return -1;
    for (;;) {
        if (!(*s >= '1' && *s <= '9') || count == 2)
            return -1;
        idx[count++] = *s++ - '0';
        if (*s == ']')
            return s[1] == '\0' ? count : -1;
        if (*s++ != ',')
            return -1;
    }
}

SR_API int sr_plant_param_range(const char *fmi_name, double *min, double *max)
{
    param p;
    int j;
    size_t len;
    if (fmi_name == NULL)
        return 1;
    for (j = 0; param_at(j, &p) == 0; j++) {
        int idx[2], count, want;
        len = strlen(p.fmi);
        if (strncmp(fmi_name, p.fmi, len) != 0)
            continue;
        count = index_suffix(fmi_name + len, idx);
        want = (p.records > 1) + (p.size > 1);
        if (count != want || (p.records > 1 && idx[0] > p.records)
            || (p.size > 1 && idx[count - 1] > p.size))
            continue;
        if (min != NULL)
            *min = p.lo;
        if (max != NULL)
            *max = p.hi;
        return 0;
    }
    return 1;
}
