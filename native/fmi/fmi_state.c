/*
 * fmi_state.c -- the FMI layer's FMU states (fmi_layer.h): get, set, free, serialise and
 * deserialise, for both FMI versions. A state holds the variables' values and the model's own
 * block (model.h); a state that does not fit the instance is refused with a logged reason and
 * leaves it as it was.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "fmi_layer.h"

#define STATE_MAGIC 0x53524653u   /* "SRFS" */
#define STATE_VERSION 1u
#define refuse sr_fmi_refuse
#if FMI_VERSION == 3
#  define SIZE_CALL "fmi3SerializedFMUStateSize"
#else
#  define SIZE_CALL "fmi2SerializedFMUstateSize"
#endif

/* one saved FMU state: this header, then real[nvars], integer[nvars], the model's block */
typedef struct {
    uint32_t magic, version;
    uint64_t nvars, model_size, has_model;
    int32_t phase, pad;
    double time;
} state_header;

typedef struct {
    state_header h;
    unsigned char bytes[];           /* values and the model's block */
} saved_state;

/* ---- FMU state -------------------------------------------------------------------------------- */
static int has_core(const sr_instance *inst) {
    return inst->phase == PHASE_STEP || inst->phase == PHASE_TERMINATED;
}

/* bytes of the values in a state: reals, then integers padded to 8 bytes (the model's block
   that follows stays aligned for its doubles) */
static size_t values_size(const sr_instance *inst) {
    return (size_t)inst->nvars * sizeof(double) + ((size_t)inst->nvars * sizeof(int) + 7u) / 8u * 8u;
}

/* bytes of a state of this instance as it is now */
static size_t current_size(sr_instance *inst) {
    return sizeof(saved_state) + values_size(inst) +
           (has_core(inst) ? sr_model_state_size(inst->model) : 0);
}

/* bytes of the saved state s (header checked by state_mismatch) */
static size_t stored_size(const sr_instance *inst, const saved_state *s) {
    return sizeof(saved_state) + values_size(inst) +
           (size_t)s->h.model_size;
}

static const char *state_mismatch(sr_instance *inst, const saved_state *s, size_t size);

/* The states this instance handed out are kept in a list and recognised by their address, so
   that a pointer that is not one of them is never dereferenced: not a garbage or freed pointer,
   and not the state itself passed where its address is expected. fmusim 0.0.39 does the latter
   (FMISaveFMUStateToFile and FMIRestoreFMUStateFromFile call fmi2FreeFMUstate(c, state) instead
   of fmi2FreeFMUstate(c, &state)); the free function frees such a state all the same. */
static int state_index(const sr_instance *inst, const void *s) {
    for (int i = 0; s && i < inst->nstates; ++i)
        if (inst->states[i] == s) return i;
    return -1;
}

static int remember_state(sr_instance *inst, void *s) {
    if (inst->nstates == inst->cap_states) {
        int cap = inst->cap_states ? 2 * inst->cap_states : 8;
        void **more = realloc(inst->states, (size_t)cap * sizeof *more);
        if (!more) return 1;
        inst->states = more;
        inst->cap_states = cap;
    }
    inst->states[inst->nstates++] = s;
    return 0;
}

static void forget_state(sr_instance *inst, int i) {
    free(inst->states[i]);
    inst->states[i] = inst->states[--inst->nstates];
}

static void save_into(sr_instance *inst, saved_state *s) {
    unsigned char *p = s->bytes;
    int with_model = has_core(inst);
    memset(&s->h, 0, sizeof s->h);
    s->h.magic = STATE_MAGIC;
    s->h.version = STATE_VERSION;
    s->h.nvars = (uint64_t)inst->nvars;
    s->h.has_model = (uint64_t)with_model;
    s->h.model_size = with_model ? (uint64_t)sr_model_state_size(inst->model) : 0u;
    s->h.phase = (int32_t)inst->phase;
    s->h.time = inst->time;
    memcpy(p, inst->real, (size_t)inst->nvars * sizeof(double));
    p += (size_t)inst->nvars * sizeof(double);
    memcpy(p, inst->integer, (size_t)inst->nvars * sizeof(int));
    p = s->bytes + values_size(inst);
    if (with_model) sr_model_state_save(inst->model, p);
}

int sr_fmi_get_state(sr_instance *inst, const char *call, void **state) {
    saved_state *s;
    if (!state) return refuse(inst, "%s: state is NULL", call);
    /* a state of ours given back is overwritten (reallocated to the size needed); anything
       else in *state is not read: a new state */
    s = state_index(inst, *state) >= 0 ? *state : NULL;
    if (s && stored_size(inst, s) != current_size(inst)) {
        saved_state *bigger = realloc(s, current_size(inst));
        if (!bigger) return refuse(inst, "%s: out of memory", call);
        inst->states[state_index(inst, s)] = bigger;
        s = bigger;
    } else if (!s) {
        s = calloc(1, current_size(inst));
        if (!s) return refuse(inst, "%s: out of memory", call);
        if (remember_state(inst, s)) {
            free(s);
            return refuse(inst, "%s: out of memory", call);
        }
    }
    save_into(inst, s);
    *state = s;
    return SR_OK;
}

/* a state's header is consistent with this instance (and its bytes with `size`, if given) */
static const char *state_mismatch(sr_instance *inst, const saved_state *s, size_t size) {
    if (!s || (!size && state_index(inst, s) < 0)) return "not a state of this instance (freed?)";
    if (s->h.magic != STATE_MAGIC) return "not a state of this FMU";
    if (s->h.version != STATE_VERSION) return "a state of another version of this FMU";
    if (s->h.nvars != (uint64_t)inst->nvars) return "a state of an FMU with other variables";
    if (s->h.phase < PHASE_INSTANTIATED || s->h.phase > PHASE_TERMINATED) return "a damaged state";
    if (s->h.has_model > 1 || s->h.model_size > (1u << 30) || (!s->h.has_model && s->h.model_size))
        return "a damaged state";
    /* save_into stores the model exactly in the phases that have one (has_core): a state that
       says otherwise would leave a stepping instance without its core */
    if (s->h.has_model != (uint64_t)(s->h.phase == PHASE_STEP || s->h.phase == PHASE_TERMINATED))
        return "a damaged state";
    if (size && size != stored_size(inst, s)) return "a state of the wrong size";
    return NULL;
}

int sr_fmi_set_state(sr_instance *inst, const char *call, const void *state) {
    const saved_state *s = state;
    const char *why;
    double *real_before;
    int *int_before;
    const unsigned char *p;
    if (!inst) return SR_ERROR;
    if ((why = state_mismatch(inst, s, 0)) != NULL) return refuse(inst, "%s: %s", call, why);
    p = s->bytes;
    real_before = malloc((size_t)inst->nvars * sizeof(double));
    int_before = malloc((size_t)inst->nvars * sizeof(int));
    if (!real_before || !int_before) {
        free(real_before); free(int_before);
        return refuse(inst, "%s: out of memory", call);
    }
    memcpy(real_before, inst->real, (size_t)inst->nvars * sizeof(double));
    memcpy(int_before, inst->integer, (size_t)inst->nvars * sizeof(int));
    memcpy(inst->real, p, (size_t)inst->nvars * sizeof(double));
    p += (size_t)inst->nvars * sizeof(double);
    memcpy(inst->integer, p, (size_t)inst->nvars * sizeof(int));
    p = s->bytes + values_size(inst);
    if (s->h.has_model) {
        /* the core is rebuilt from the state's parameters, then takes its block */
        if (sr_model_state_load(inst->model, inst, p, (size_t)s->h.model_size) != 0) {
            memcpy(inst->real, real_before, (size_t)inst->nvars * sizeof(double));
            memcpy(inst->integer, int_before, (size_t)inst->nvars * sizeof(int));
            free(real_before); free(int_before);
            return SR_ERROR;
        }
    } else {
        sr_model_reset(inst->model);
    }
    free(real_before); free(int_before);
    inst->phase = (sr_phase)s->h.phase;
    inst->time = s->h.time;
    inst->preview_dirty = 1;
    inst->outputs_dirty = 1;
    return SR_OK;
}

int sr_fmi_free_state(sr_instance *inst, const char *call, void **state) {
    int i;
    if (!state) return SR_OK;
    if ((i = state_index(inst, state)) >= 0) {      /* the state itself (fmusim 0.0.39) */
        forget_state(inst, i);
        return SR_OK;
    }
    if (!*state) return SR_OK;
    if ((i = state_index(inst, *state)) < 0)
        return refuse(inst, "%s: not a state of this instance (freed already?)", call);
    forget_state(inst, i);
    *state = NULL;
    return SR_OK;
}

int sr_fmi_serialized_size(sr_instance *inst, const char *call, const void *state, size_t *size) {
    const saved_state *s = state;
    const char *why;
    if (!size) return refuse(inst, "%s: size is NULL", call);
    if ((why = state_mismatch(inst, s, 0)) != NULL)
        return refuse(inst, "%s: %s", call, why);
    *size = stored_size(inst, s);
    return SR_OK;
}

int sr_fmi_serialize(sr_instance *inst, const char *call, const void *state, void *bytes,
                     size_t size) {
    size_t need = 0;
    if (sr_fmi_serialized_size(inst, SIZE_CALL, state, &need) != SR_OK) return SR_ERROR;
    if (!bytes || size < need)
        return refuse(inst, "%s: the buffer holds %lu bytes, %lu needed",
                      call, (unsigned long)size, (unsigned long)need);   /* msvcrt knows no %zu */
    memcpy(bytes, state, need);
    return SR_OK;
}

int sr_fmi_deserialize(sr_instance *inst, const char *call, const void *bytes, size_t size,
                       void **state) {
    saved_state *s;
    const char *why;
    if (!bytes || !state || size < sizeof(saved_state))
        return refuse(inst, "%s: not a serialised state of this FMU", call);
    s = malloc(size);
    if (!s) return refuse(inst, "%s: out of memory", call);
    memcpy(s, bytes, size);
    if ((why = state_mismatch(inst, s, size)) != NULL || remember_state(inst, s)) {
        free(s);
        return refuse(inst, "%s: %s", call, why ? why : "out of memory");
    }
    *state = s;                      /* a new state: *state on entry is not read */
    return SR_OK;
}
