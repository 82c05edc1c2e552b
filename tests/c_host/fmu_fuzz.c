/*
 * fmu_fuzz.c -- a randomised FMI 2.0 call test of a co-simulation FMU binary, used by
 * tests/test_native_fmu_fuzz.py. One source for Linux (gcc, dlopen) and Windows
 * (x86_64-w64-mingw32-gcc, LoadLibrary); no FMI header needed (the types are declared below).
 *
 * With a seeded generator it calls every fmi2 function in random order on several instances at
 * once: NaN, Inf, huge, negative and denormal values; out-of-range and wrong-type value
 * references; NULL arrays and NULL instances; every lifecycle call in every phase; states
 * got, set (also into another instance: refused), overwritten, serialised, deserialised (also
 * in another instance, from random bytes, from a damaged copy of a real state and from an
 * instance of another model of the same binary), freed, or left to fmi2FreeInstance. It never
 * does what the standard leaves undefined for the host (a state used after it was freed, a
 * freed instance, arrays shorter than nvr).
 *
 * Alongside it keeps a model of each instance (phase, time, whether its parameters are the
 * start values, its states) and checks every status against what FMI 2.0 and the project's
 * layer promise: a refused call (fmi2Error) leaves the instance as it was; a call in the wrong
 * phase is refused; doStep outside the stepping phase or with a non-finite point or a step
 * <= 0 is discarded, one from another point than the instance's time refused (fmi2Error,
 * also where a NaN input would have discarded it: the point is checked first);
 * never fmi2Fatal. After every refusal of an instance in the stepping
 * phase it probes that the instance still works: a valid doStep returns fmi2OK and, for an
 * instance initialised with its start parameters, every Real output is finite (an instance
 * running from a damaged state or with random parameters the FMU accepted is only asked not to
 * crash). Log messages are checked (instance name, category, text present).
 *
 * What a model may legally do differently is told by options, so that the same checks serve
 * the estimator, the sensors and the plant:
 *   -T          direct feedthrough (the sensors): the outputs measure the inputs set now, so a
 *               non-finite or huge input (|x| > 1e6) may give non-finite outputs; the outputs
 *               are required finite only while every input holds a moderate value.
 *   -N VRS      inputs whose NaN value makes doStep discard the step (the plant's
 *               excitation inputs: no level or rate to apply); a step while one of them is
 *               NaN must be discarded.
 *   -H MAXSTEP  doStep discards a communication step longer than MAXSTEP seconds (the plant).
 *   -F          a valid step may be discarded by an instance whose parameters are not the start
 *               values or that runs from a damaged state (the plant's integration may fail for
 *               accepted but extreme parameters); with the start parameters it must succeed.
 *   -w SECONDS  a wild step drawn longer than SECONDS but not longer than -H is shortened to
 *               SECONDS (the plant's step costs grow with its length: quick under valgrind).
 *
 * usage: fmu_fuzz [-n CALLS] [-S SEED] [-k INSTANCES] [-L LOGLINES] [-D STEPS [-p VR=INT ...]]
 *                 [-T] [-N VRS] [-H MAXSTEP] [-F] [-w SECONDS]
 *                 -R VRS -P VRS -I VRS -O VRS -Z VRS [-g GUID2 -u URI2 -m NVARS2]
 *                 BINARY GUID RESOURCE_URI NVARS
 *   -R Real inputs, -P Real parameters (fixed), -I Integer parameters (fixed), -O Real outputs,
 *   -Z Integer outputs (comma-separated value references; any list may be empty, "");
 *   NVARS: the number of variables
 *   (value references 0..NVARS-1); -g/-u/-m: a model of another robot served by the same
 *   binary, whose states the first model must refuse. -L: print at most this many log lines.
 *   -D STEPS: then the damage sweep: an instance (Integer parameters -p VR=INT) stepped STEPS
 *   times, its state serialised, and every 4-byte word past the first 64 bytes set to
 *   0x7FFFFFFF, 0xFFFFFFFF (-1) or 0x00010000 (a word holding a small count or index: to each
 *   in turn; any other word: to one of them, in rotation); each such state deserialised,
 *   restored and stepped twice: the FMU may refuse it, or step or discard, but never crash.
 *
 * Prints a summary (calls and statuses per function, log lines per status) on stdout and
 * exits 0 when every status matched, 1 on a mismatch (each one printed), 2 on a usage or
 * loading error.
 */
#if defined(_WIN32)
#  ifndef __USE_MINGW_ANSI_STDIO
#    define __USE_MINGW_ANSI_STDIO 1
#  endif
#  include <windows.h>
#  include <getopt.h>
#else
#  ifndef _POSIX_C_SOURCE
#    define _POSIX_C_SOURCE 200809L
#  endif
#  include <dlfcn.h>
#  include <unistd.h>
#endif
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2_host.h"   /* the FMI 2.0 types (FMI 2.0.4, sections 2.1.2-2.1.9) */

typedef const fmi2ValueReference *VRS;
static struct {
    const char *(*GetTypesPlatform)(void);
    const char *(*GetVersion)(void);
    fmi2Status (*SetDebugLogging)(fmi2Component, fmi2Boolean, size_t, const fmi2String *);
    fmi2Component (*Instantiate)(fmi2String, fmi2Type, fmi2String, fmi2String,
                                 const fmi2CallbackFunctions *, fmi2Boolean, fmi2Boolean);
    void (*FreeInstance)(fmi2Component);
    fmi2Status (*SetupExperiment)(fmi2Component, fmi2Boolean, fmi2Real, fmi2Real, fmi2Boolean, fmi2Real);
    fmi2Status (*EnterInitializationMode)(fmi2Component);
    fmi2Status (*ExitInitializationMode)(fmi2Component);
    fmi2Status (*Terminate)(fmi2Component);
    fmi2Status (*Reset)(fmi2Component);
    fmi2Status (*GetReal)(fmi2Component, VRS, size_t, fmi2Real *);
    fmi2Status (*GetInteger)(fmi2Component, VRS, size_t, fmi2Integer *);
    fmi2Status (*GetBoolean)(fmi2Component, VRS, size_t, fmi2Boolean *);
    fmi2Status (*GetString)(fmi2Component, VRS, size_t, fmi2String *);
    fmi2Status (*SetReal)(fmi2Component, VRS, size_t, const fmi2Real *);
    fmi2Status (*SetInteger)(fmi2Component, VRS, size_t, const fmi2Integer *);
    fmi2Status (*SetBoolean)(fmi2Component, VRS, size_t, const fmi2Boolean *);
    fmi2Status (*SetString)(fmi2Component, VRS, size_t, const fmi2String *);
    fmi2Status (*GetFMUstate)(fmi2Component, fmi2FMUstate *);
    fmi2Status (*SetFMUstate)(fmi2Component, fmi2FMUstate);
    fmi2Status (*FreeFMUstate)(fmi2Component, fmi2FMUstate *);
    fmi2Status (*SerializedFMUstateSize)(fmi2Component, fmi2FMUstate, size_t *);
    fmi2Status (*SerializeFMUstate)(fmi2Component, fmi2FMUstate, fmi2Byte *, size_t);
    fmi2Status (*DeSerializeFMUstate)(fmi2Component, const fmi2Byte *, size_t, fmi2FMUstate *);
    fmi2Status (*GetDirectionalDerivative)(fmi2Component, VRS, size_t, VRS, size_t, const fmi2Real *,
                                           fmi2Real *);
    fmi2Status (*SetRealInputDerivatives)(fmi2Component, VRS, size_t, const fmi2Integer *,
                                          const fmi2Real *);
    fmi2Status (*GetRealOutputDerivatives)(fmi2Component, VRS, size_t, const fmi2Integer *, fmi2Real *);
    fmi2Status (*DoStep)(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean);
    fmi2Status (*CancelStep)(fmi2Component);
    fmi2Status (*GetStatus)(fmi2Component, fmi2StatusKind, fmi2Status *);
    fmi2Status (*GetRealStatus)(fmi2Component, fmi2StatusKind, fmi2Real *);
    fmi2Status (*GetIntegerStatus)(fmi2Component, fmi2StatusKind, fmi2Integer *);
    fmi2Status (*GetBooleanStatus)(fmi2Component, fmi2StatusKind, fmi2Boolean *);
    fmi2Status (*GetStringStatus)(fmi2Component, fmi2StatusKind, fmi2String *);
} F;

/* the functions in the order of F, for resolving and counting */
enum {
    K_GetTypesPlatform, K_GetVersion, K_SetDebugLogging, K_Instantiate, K_FreeInstance, K_SetupExperiment,
    K_EnterInitializationMode, K_ExitInitializationMode, K_Terminate, K_Reset, K_GetReal, K_GetInteger,
    K_GetBoolean, K_GetString, K_SetReal, K_SetInteger, K_SetBoolean, K_SetString, K_GetFMUstate, K_SetFMUstate,
    K_FreeFMUstate, K_SerializedFMUstateSize, K_SerializeFMUstate, K_DeSerializeFMUstate,
    K_GetDirectionalDerivative, K_SetRealInputDerivatives, K_GetRealOutputDerivatives, K_DoStep,
    K_CancelStep, K_GetStatus, K_GetRealStatus, K_GetIntegerStatus, K_GetBooleanStatus, K_GetStringStatus,
    NFUNC
};
static const char *const NAME[NFUNC] = {
    "GetTypesPlatform", "GetVersion", "SetDebugLogging", "Instantiate", "FreeInstance",
    "SetupExperiment", "EnterInitializationMode", "ExitInitializationMode", "Terminate", "Reset",
    "GetReal", "GetInteger", "GetBoolean", "GetString", "SetReal", "SetInteger", "SetBoolean",
    "SetString", "GetFMUstate", "SetFMUstate", "FreeFMUstate", "SerializedFMUstateSize",
    "SerializeFMUstate", "DeSerializeFMUstate", "GetDirectionalDerivative",
    "SetRealInputDerivatives", "GetRealOutputDerivatives", "DoStep", "CancelStep", "GetStatus",
    "GetRealStatus", "GetIntegerStatus", "GetBooleanStatus", "GetStringStatus"};

/* ---- the platform -------------------------------------------------------------------------- */
typedef void (*any_fn)(void);
#if defined(_WIN32)
static void *lib_open(const char *path) { return (void *)LoadLibraryA(path); }
static any_fn lib_sym(void *lib, const char *name) {
    return (any_fn)GetProcAddress((HMODULE)lib, name);
}
#else
static void *lib_open(const char *path) { return dlopen(path, RTLD_NOW | RTLD_LOCAL); }
static any_fn lib_sym(void *lib, const char *name) {
    void *p = dlsym(lib, name);
    any_fn f;
    memcpy(&f, &p, sizeof f);
    return f;
}
#endif

/* ---- the generator (splitmix64: seeded, the same sequence on every platform) ---------------- */
static uint64_t rng_state;
static uint64_t rnd(void) {
    uint64_t z = (rng_state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}
static int below(int n) { return (int)(rnd() % (uint64_t)n); }
static int chance(int percent) { return below(100) < percent; }
static double uniform(double a, double b) { return a + (b - a) * (double)(rnd() >> 11) * 0x1p-53; }

static double any_real(void) {
    switch (below(16)) {
    case 0: return NAN;
    case 1: return INFINITY;
    case 2: return -INFINITY;
    case 3: return 1e308;
    case 4: return -1e308;
    case 5: return 1e16;
    case 6: return -5e15;
    case 7: return 0.0;
    case 8: return -0.0;
    case 9: return 4.9406564584124654e-324;         /* the smallest denormal */
    case 10: return -1.0;
    case 11: return uniform(-1e6, 1e6);
    default: return uniform(-10.0, 10.0);
    }
}
static int any_int(void) {
    static const int POOL[] = {INT_MIN, INT_MAX, -1, 0, 1, 2, 3, 50, 51, 10000, 10001, -100000};
    return chance(70) ? POOL[below((int)(sizeof POOL / sizeof POOL[0]))] : (int)(rnd() & 0xFFFFFFFFu);
}

/* ---- the model of the FMU and of each instance ---------------------------------------------- */
#define MAXV 1024
#define MAX_SLOTS 8
#define MAX_STATES 48
typedef struct { size_t n; fmi2ValueReference vr[MAXV]; } List;
static List in_real, par_real, par_int, out_real, out_int, nan_discard;
static int feedthrough, may_fail;              /* -T, -F */
static double max_step = INFINITY;             /* -H */
static double wild_max = INFINITY;             /* -w */
static unsigned nvars, nvars2;
static const char *guid, *uri, *guid2, *uri2;
static double start_real[MAXV];
static int start_int[MAXV];
static double start_in[MAXV];
static int have_starts;

enum { NONE = -1, INSTANTIATED, INITIALIZATION, STEPPING, TERMINATED };
static const char *const PHASE[] = {"instantiated", "initialisation", "stepping", "terminated"};

typedef struct {
    fmi2Component c;
    int model;                /* 0: the FMU under test, 1: the other robot (-g, -u) */
    int phase;
    int starts;               /* parameters at their start values: initialisation must succeed */
    int damaged;              /* runs from a damaged state: only "no crash" is checked */
    int wild_inputs;          /* -T: an input holds a non-finite or huge value */
    unsigned nan_inputs;      /* -N: bit i set while input nan_discard.vr[i] is NaN */
    double time;
    char name[32];
    fmi2CallbackFunctions cb;
} Slot;
static Slot slot[MAX_SLOTS];
static int nslots;

typedef struct {
    fmi2FMUstate s;
    int owner, model, phase, starts, damaged, wild_inputs;
    unsigned nan_inputs;
    double time;
} State;
static State states[MAX_STATES];
static int nstates;

/* ---- counting and checking ------------------------------------------------------------------ */
static long calls[NFUNC], status_count[NFUNC][6], null_instances, total, violations;
static long log_lines[6], log_bad, log_printed, log_max = 20;
static long damaged_restored, damaged_steps, foreign_refused;

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    char text[2048];
    va_list ap;
    int ok = name && category && message && (int)status >= 0 && (int)status <= 5;
    if (ok) {
        va_start(ap, message);
        vsnprintf(text, sizeof text, message, ap);
        va_end(ap);
        ok = text[0] != '\0';
    }
    if (env) {                                 /* the environment handed over at instantiation */
        int k, known = 0;
        for (k = 0; k < MAX_SLOTS; ++k) known |= env == (void *)&slot[k];
        ok = ok && known;
    }
    if (!ok) {
        ++log_bad;
        printf("BAD LOG LINE: name %s category %s status %d\n", name ? name : "(null)",
               category ? category : "(null)", (int)status);
        return;
    }
    log_lines[(int)status]++;
    if (log_printed++ < log_max) fprintf(stderr, "[%s][status %d][%s] %s\n", name, (int)status,
                                         category, text);
}

static fmi2Status count(int f, fmi2Status s) {
    calls[f]++;
    total++;
    if ((int)s >= 0 && (int)s <= 5) status_count[f][(int)s]++;
    return s;
}

#define M_OK (1u << fmi2OK)
#define M_WARN (1u << fmi2Warning)
#define M_DISCARD (1u << fmi2Discard)
#define M_ERROR (1u << fmi2Error)

static void expect(int f, fmi2Status s, unsigned mask, int k, const char *why) {
    if ((int)s < 0 || (int)s > 5 || !(mask & (1u << (int)s))) {
        ++violations;
        printf("VIOLATION at call %ld: fmi2%s on instance %d (%s%s%s) returned %d; expected mask "
               "0x%x (%s)\n", total, NAME[f], k, k >= 0 && slot[k].c ? PHASE[slot[k].phase] : "-",
               k >= 0 && slot[k].c && !slot[k].starts ? ", parameters changed" : "",
               k >= 0 && slot[k].c && slot[k].damaged ? ", from a damaged state" : "", (int)s, mask,
               why);
    }
}

#define CALL(f, expr) count(f, (expr))

/* ---- value-reference lists ------------------------------------------------------------------ */
/* kinds of entries: 0 real input, 1 real parameter, 2 integer parameter, 3 real output,
   4 integer output, 5 out of range */
static fmi2ValueReference pick_vr(int kind) {
    const List *l = kind == 0 ? &in_real : kind == 1 ? &par_real : kind == 2 ? &par_int
                  : kind == 3 ? &out_real : &out_int;
    if (kind == 5 || l->n == 0) {
        static const fmi2ValueReference FAR_OFF[] = {0, 1, 2, 1000, 0x7FFFFFFFu, 0xFFFFFFFFu};
        int j = below(6);
        return j < 3 ? nvars + (unsigned)j : FAR_OFF[j];
    }
    return l->vr[below((int)l->n)];
}

typedef struct { size_t n; fmi2ValueReference vr[16]; int kind[16]; } Pick;

/* a random list for a call on type (0 Real, 1 Integer); kinds restricted to `kinds` (bitmask) */
static void pick_list(Pick *p, unsigned kinds) {
    size_t i;
    p->n = (size_t)below(chance(20) ? 1 : 9);
    for (i = 0; i < p->n; ++i) {
        int kind;
        do kind = below(6); while (!(kinds & (1u << kind)));
        p->vr[i] = pick_vr(kind);
        {   /* a kind whose list is empty picked an out-of-range reference */
            const List *l = kind == 0 ? &in_real : kind == 1 ? &par_real : kind == 2 ? &par_int
                          : kind == 3 ? &out_real : kind == 4 ? &out_int : NULL;
            if (l && l->n == 0) kind = 5;
        }
        p->kind[i] = kind;
    }
}

/* ---- helpers on instances and states -------------------------------------------------------- */
static int find_slot(int want_model, int need_live) {
    int k, tries;
    for (tries = 0; tries < 4 * MAX_SLOTS; ++tries) {
        k = below(nslots);
        if (want_model >= 0 && slot[k].model != want_model) continue;
        if (need_live && !slot[k].c) continue;
        return k;
    }
    return -1;
}

static void drop_state(int i) {
    states[i] = states[--nstates];
}

static void free_state(int i) {
    int k = states[i].owner;
    fmi2Status s = CALL(K_FreeFMUstate, F.FreeFMUstate(slot[k].c, &states[i].s));
    expect(K_FreeFMUstate, s, M_OK, k, "freeing a state of this instance");
    if (states[i].s != NULL) {
        ++violations;
        printf("VIOLATION: fmi2FreeFMUstate left the state pointer set\n");
    }
    drop_state(i);
}

static void free_slot(int k) {
    int i, keep = chance(50);
    /* the states still held: freed here, or (half the time) left to fmi2FreeInstance */
    for (i = nstates - 1; i >= 0; --i)
        if (states[i].owner == k) {
            if (keep) drop_state(i);
            else free_state(i);
        }
    calls[K_FreeInstance]++;
    total++;
    F.FreeInstance(slot[k].c);
    slot[k].c = NULL;
    slot[k].phase = NONE;
}

static void instantiate(int k, int model) {
    Slot *s = &slot[k];
    int visible, logging;
    s->cb.logger = logger;
    s->cb.allocateMemory = calloc;
    s->cb.freeMemory = free;
    s->cb.stepFinished = NULL;
    s->cb.componentEnvironment = s;
    visible = chance(50);
    logging = chance(30);
    snprintf(s->name, sizeof s->name, "fuzz%d", k);
    s->c = F.Instantiate(s->name, fmi2CoSimulation, model ? guid2 : guid, model ? uri2 : uri,
                         &s->cb, visible, logging);
    calls[K_Instantiate]++;
    total++;
    if (!s->c) {
        ++violations;
        printf("VIOLATION: fmi2Instantiate of a valid instance %d returned NULL\n", k);
        return;
    }
    status_count[K_Instantiate][fmi2OK]++;
    s->model = model;
    s->phase = INSTANTIATED;
    s->starts = 1;
    s->damaged = 0;
    s->wild_inputs = 0;
    s->nan_inputs = 0;
    s->time = 0.0;
}

/* the start values of parameters and inputs, read once from a fresh instance */
static void read_starts(int k) {
    fmi2Status st;
    st = CALL(K_GetReal, F.GetReal(slot[k].c, par_real.vr, par_real.n, start_real));
    expect(K_GetReal, st, M_OK, k, "start values");
    st = CALL(K_GetInteger, F.GetInteger(slot[k].c, par_int.vr, par_int.n, start_int));
    expect(K_GetInteger, st, M_OK, k, "start values");
    st = CALL(K_GetReal, F.GetReal(slot[k].c, in_real.vr, in_real.n, start_in));
    expect(K_GetReal, st, M_OK, k, "start values");
    have_starts = 1;
}

/* on a violation: the instance's parameters that are not at their start values */
static void print_changed_parameters(int k) {
    static double r[MAXV];
    static int z[MAXV];
    size_t i;
    if (!have_starts || F.GetReal(slot[k].c, par_real.vr, par_real.n, r) != fmi2OK ||
        F.GetInteger(slot[k].c, par_int.vr, par_int.n, z) != fmi2OK)
        return;
    for (i = 0; i < par_real.n; ++i)
        if (memcmp(&r[i], &start_real[i], sizeof r[i]) != 0)
            printf("    parameter vr %u = %.17g (start %.17g)\n", par_real.vr[i], r[i], start_real[i]);
    for (i = 0; i < par_int.n; ++i)
        if (z[i] != start_int[i])
            printf("    parameter vr %u = %d (start %d)\n", par_int.vr[i], z[i], start_int[i]);
}

/* Is t the instance's time as the FMU judges it (a millionth of the step h, plus the round-off of
 * the time)? 1 yes, 0 no, -1 too close to the limit to tell. */
static int at_time(double t, double time, double h) {
    double off = fabs(t - time), tol = 1e-6 * h + 8.0 * DBL_EPSILON * fmax(fabs(t), fabs(time));
    return off <= 0.5 * tol ? 1 : off > 2.0 * tol ? 0 : -1;
}

/* may a valid step of instance k be discarded (-F), or must it be (-N)? */
static unsigned valid_step_mask(int k) {
    const Slot *s = &slot[k];
    if (s->nan_inputs) return M_DISCARD;
    return may_fail && (s->damaged || !s->starts) ? M_OK | M_DISCARD : M_OK;
}

/* a valid doStep from the instance's time must work and give finite outputs */
static void probe(int k, const char *after) {
    static double out[MAXV];
    fmi2Status st;
    size_t i;
    Slot *s = &slot[k];
    if (s->phase != STEPPING || !isfinite(s->time) || !isfinite(s->time + 0.1) || s->model) return;
    st = CALL(K_SetReal, F.SetReal(s->c, in_real.vr, in_real.n, start_in));
    expect(K_SetReal, st, M_OK, k, "probe: the start inputs");
    if (st == fmi2OK) {
        s->wild_inputs = 0;
        s->nan_inputs = 0;
    }
    st = CALL(K_DoStep, F.DoStep(s->c, s->time, 0.1, fmi2True));
    expect(K_DoStep, st, valid_step_mask(k), k, after);
    if (st == fmi2OK) s->time += 0.1;
    st = CALL(K_GetReal, F.GetReal(s->c, out_real.vr, out_real.n, out));
    expect(K_GetReal, st, M_OK, k, "probe: the outputs");
    if (st == fmi2OK && !s->damaged && s->starts && !(feedthrough && s->wild_inputs))
        for (i = 0; i < out_real.n; ++i)
            if (!isfinite(out[i])) {
                ++violations;
                printf("VIOLATION at call %ld: output vr %u of instance %d is %g after a valid "
                       "step (%s)\n", total, out_real.vr[i], k, out[i], after);
                print_changed_parameters(k);
                break;
            }
}

/* after a call on instance k: probe if it was refused in the stepping phase */
static void after(int k, fmi2Status st, const char *what) {
    if (k >= 0 && slot[k].c && st >= fmi2Discard && chance(60)) probe(k, what);
}

static void save_state(int k) {
    fmi2Status st;
    State *t;
    if (nstates == MAX_STATES) free_state(below(nstates));
    t = &states[nstates];
    t->s = NULL;
    st = CALL(K_GetFMUstate, F.GetFMUstate(slot[k].c, &t->s));
    expect(K_GetFMUstate, st, M_OK, k, "a new state");
    if (st != fmi2OK || !t->s) return;
    t->owner = k;
    t->model = slot[k].model;
    t->phase = slot[k].phase;
    t->starts = slot[k].starts;
    t->damaged = slot[k].damaged;
    t->wild_inputs = slot[k].wild_inputs;
    t->nan_inputs = slot[k].nan_inputs;
    t->time = slot[k].time;
    nstates++;
}

/* serialise state i into a fresh buffer (by its owner); NULL if refused */
static fmi2Byte *serialise(int i, size_t *size) {
    int k = states[i].owner;
    fmi2Byte *bytes;
    fmi2Status st = CALL(K_SerializedFMUstateSize, F.SerializedFMUstateSize(slot[k].c, states[i].s, size));
    expect(K_SerializedFMUstateSize, st, M_OK, k, "size of a state of this instance");
    if (st != fmi2OK || *size == 0 || *size > (1u << 28)) return NULL;
    bytes = (fmi2Byte *)malloc(*size);
    if (!bytes) return NULL;
    st = CALL(K_SerializeFMUstate, F.SerializeFMUstate(slot[k].c, states[i].s, bytes, *size));
    expect(K_SerializeFMUstate, st, M_OK, k, "serialising a state of this instance");
    if (st != fmi2OK) {
        free(bytes);
        return NULL;
    }
    return bytes;
}

/* deserialise bytes into instance k; the state joins the pool with the given attributes */
static void deserialise(int k, const fmi2Byte *bytes, size_t size, unsigned mask, const State *like,
                        int damaged, const char *why) {
    fmi2FMUstate s = NULL;
    fmi2Status st;
    if (nstates == MAX_STATES) free_state(below(nstates));
    st = CALL(K_DeSerializeFMUstate, F.DeSerializeFMUstate(slot[k].c, bytes, size, &s));
    expect(K_DeSerializeFMUstate, st, mask, k, why);
    if (st == fmi2OK && s) {
        State *t = &states[nstates++];
        *t = *like;
        t->s = s;
        t->owner = k;
        t->damaged = damaged;
        if (damaged) t->starts = 0;
    }
    after(k, st, why);
}

/* ---- the operations ------------------------------------------------------------------------- */
static void op_instantiate(void) {
    int k, model = 0;
    for (k = 0; k < nslots; ++k)
        if (!slot[k].c) break;
    if (k == nslots) {
        k = below(nslots);
        free_slot(k);
    }
    if (guid2 && k == nslots - 1) model = 1;    /* the last slot holds the other robot */
    instantiate(k, model);
    if (slot[k].c && !model && !have_starts) read_starts(k);
}

static void op_bad_instantiate(void) {
    static fmi2CallbackFunctions no_logger = {NULL, calloc, free, NULL, NULL};
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Component c;
    const char *name = "bad", *g = guid, *u = uri;
    const fmi2CallbackFunctions *fn = &cb;
    fmi2Type type = fmi2CoSimulation;
    switch (below(8)) {
    case 0: name = NULL; break;
    case 1: name = ""; break;
    case 2: type = fmi2ModelExchange; break;
    case 3: g = chance(50) ? "{00000000-0000-0000-0000-000000000000}" : guid2 ? guid2 : "x"; break;
    case 4: u = chance(50) ? "file:///nonexistent/fmu/resources" : "http://example.org/"; break;
    case 5: u = NULL; break;
    case 6: fn = chance(50) ? NULL : &no_logger; break;
    default: type = (fmi2Type)7; break;
    }
    c = F.Instantiate(name, type, g, u, fn, fmi2False, chance(50));
    calls[K_Instantiate]++;
    total++;
    if (c) {
        ++violations;
        printf("VIOLATION at call %ld: fmi2Instantiate with bad arguments returned an instance\n", total);
        F.FreeInstance(c);
    } else {
        null_instances++;
    }
}

static void op_set(int k, int integer);

static void op_lifecycle(int k) {
    Slot *s = &slot[k];
    fmi2Status st;
    int which = below(6);
    if (chance(60)) {                            /* mostly the call that leads on to stepping */
        switch (s->phase) {
        case INSTANTIATED: which = chance(50) ? 0 : 1; break;
        case INITIALIZATION:
            if (!s->starts && chance(70)) {
                op_set(k, 0);
                return;
            }
            which = 2;
            break;
        case TERMINATED: which = 5; break;
        default: break;
        }
    }
    if (which == 0) {
        double t0 = chance(70) ? 0.0 : any_real(), tol = any_real(), stop = any_real();
        int tol_defined = chance(50), stop_defined = chance(50);
        st = CALL(K_SetupExperiment, F.SetupExperiment(s->c, tol_defined, tol, t0, stop_defined, stop));
        expect(K_SetupExperiment, st, s->phase == INSTANTIATED && isfinite(t0) ? M_OK : M_ERROR, k,
               "allowed once after instantiation, with a finite start time");
        if (st == fmi2OK) s->time = t0;
    } else if (which == 1) {
        st = CALL(K_EnterInitializationMode, F.EnterInitializationMode(s->c));
        expect(K_EnterInitializationMode, st, s->phase == INSTANTIATED ? M_OK : M_ERROR, k,
               "allowed after instantiation");
        if (st == fmi2OK) s->phase = INITIALIZATION;
    } else if (which == 2 || which == 3) {
        unsigned mask = s->phase != INITIALIZATION ? M_ERROR : s->starts ? M_OK : M_OK | M_ERROR;
        st = CALL(K_ExitInitializationMode, F.ExitInitializationMode(s->c));
        expect(K_ExitInitializationMode, st, mask, k, "allowed in initialisation; the start values are valid");
        if (st == fmi2OK) s->phase = STEPPING;
    } else if (which == 4) {
        st = CALL(K_Terminate, F.Terminate(s->c));
        expect(K_Terminate, st, s->phase == STEPPING ? M_OK : M_ERROR, k, "allowed while stepping");
        if (st == fmi2OK) s->phase = TERMINATED;
    } else {
        if (s->phase != TERMINATED && chance(70)) return;    /* a reset now and then */
        st = CALL(K_Reset, F.Reset(s->c));
        expect(K_Reset, st, M_OK, k, "always allowed");
        s->phase = INSTANTIATED;
        s->starts = 1;
        s->damaged = 0;
        s->wild_inputs = 0;
        s->nan_inputs = 0;
        s->time = 0.0;
    }
    after(k, st, "a lifecycle call");
}

/* may variable kind be set in phase? */
static int settable(int kind, int phase) {
    if (kind == 5 || kind == 3 || kind == 4 || phase == TERMINATED) return 0;
    if ((kind == 1 || kind == 2) && phase == STEPPING) return 0;
    return 1;
}

/* after a successful fmi2SetReal on instance k: what the inputs now hold (-T, -N) */
static void inputs_set(int k, const fmi2ValueReference *vr, size_t n, const double *v) {
    size_t i, j;
    for (i = 0; i < n; ++i) {
        for (j = 0; j < in_real.n && in_real.vr[j] != vr[i]; ++j) {}
        if (j == in_real.n) continue;                    /* not an input */
        if (!isfinite(v[i]) || fabs(v[i]) > 1e6) slot[k].wild_inputs = 1;
        for (j = 0; j < nan_discard.n && j < 32; ++j)
            if (nan_discard.vr[j] == vr[i]) {
                if (isnan(v[i])) slot[k].nan_inputs |= 1u << j;
                else slot[k].nan_inputs &= ~(1u << j);
            }
    }
}

static void op_set(int k, int integer) {
    Slot *s = &slot[k];
    Pick p;
    double rv[16];
    int iv[16];
    size_t i;
    int valid = 1, params = 0, null_vr = 0, null_val = 0;
    fmi2Status st;
    if (chance(40) && have_starts) {             /* every parameter back to its start value */
        if (integer)
            st = CALL(K_SetInteger, F.SetInteger(s->c, par_int.vr, par_int.n, start_int));
        else
            st = CALL(K_SetReal, F.SetReal(s->c, par_real.vr, par_real.n, start_real));
        expect(integer ? K_SetInteger : K_SetReal, st,
               s->phase == INSTANTIATED || s->phase == INITIALIZATION ||
               (integer ? par_int.n : par_real.n) == 0 ? M_OK : M_ERROR, k,
               "parameters may be set before the stepping phase (no parameters: always)");
        if (st == fmi2OK && !integer) {
            /* both types must be at their start values: set the other type too */
            st = CALL(K_SetInteger, F.SetInteger(s->c, par_int.vr, par_int.n, start_int));
            expect(K_SetInteger, st, M_OK, k, "parameters may be set before the stepping phase");
            if (st == fmi2OK && (s->phase == INSTANTIATED || s->phase == INITIALIZATION) &&
                !s->damaged) s->starts = 1;
        }
        after(k, st, "setting the start values");
        return;
    }
    pick_list(&p, integer ? (chance(80) ? (1u << 2) : 0x3Fu) : (chance(80) ? 0x3u : 0x3Fu));
    for (i = 0; i < p.n; ++i) {
        int type_ok = integer ? (p.kind[i] == 2 || p.kind[i] == 4) : (p.kind[i] <= 1 || p.kind[i] == 3);
        valid &= type_ok && settable(p.kind[i], s->phase);
        params |= p.kind[i] == 1 || p.kind[i] == 2;
        rv[i] = any_real();
        iv[i] = any_int();
    }
    if (p.n && chance(5)) null_vr = 1;
    else if (p.n && chance(5)) null_val = 1;
    if (integer)
        st = CALL(K_SetInteger, F.SetInteger(s->c, null_vr ? NULL : p.vr, p.n, null_val ? NULL : iv));
    else
        st = CALL(K_SetReal, F.SetReal(s->c, null_vr ? NULL : p.vr, p.n, null_val ? NULL : rv));
    valid = p.n == 0 || (valid && !null_vr && !null_val);
    expect(integer ? K_SetInteger : K_SetReal, st, valid ? M_OK : M_ERROR, k,
           "valid references of the type, settable in this phase, non-NULL arrays");
    if (st == fmi2OK && params && p.n) s->starts = 0;   /* parameters changed: validity unknown */
    if (st == fmi2OK && !integer) inputs_set(k, p.vr, p.n, rv);
    after(k, st, "a set call");
}

static void op_get(int k, int integer) {
    Slot *s = &slot[k];
    Pick p;
    double rv[16];
    int iv[16];
    size_t i;
    int valid = 1, null_vr = 0, null_val = 0;
    fmi2Status st;
    pick_list(&p, chance(80) ? (integer ? 0x14u : 0x0Bu) : 0x3Fu);
    for (i = 0; i < p.n; ++i)
        valid &= integer ? (p.kind[i] == 2 || p.kind[i] == 4) : (p.kind[i] <= 1 || p.kind[i] == 3);
    if (p.n && chance(5)) null_vr = 1;
    else if (p.n && chance(5)) null_val = 1;
    if (integer)
        st = CALL(K_GetInteger, F.GetInteger(s->c, null_vr ? NULL : p.vr, p.n, null_val ? NULL : iv));
    else
        st = CALL(K_GetReal, F.GetReal(s->c, null_vr ? NULL : p.vr, p.n, null_val ? NULL : rv));
    valid = p.n == 0 || (valid && !null_vr && !null_val);
    expect(integer ? K_GetInteger : K_GetReal, st, valid ? M_OK : M_ERROR, k,
           "valid references of the type, non-NULL arrays");
    after(k, st, "a get call");
}

static void op_other_types(int k) {
    Slot *s = &slot[k];
    fmi2ValueReference vr[2];
    fmi2Boolean b[2] = {1, 0};
    fmi2String str[2] = {"a", NULL};
    size_t n = (size_t)below(3);
    fmi2Status st;
    int f;
    vr[0] = pick_vr(below(6));
    vr[1] = pick_vr(below(6));
    switch (below(4)) {
    case 0: f = K_GetBoolean; st = CALL(K_GetBoolean, F.GetBoolean(s->c, vr, n, b)); break;
    case 1: f = K_SetBoolean; st = CALL(K_SetBoolean, F.SetBoolean(s->c, vr, n, b)); break;
    case 2: f = K_GetString; st = CALL(K_GetString, F.GetString(s->c, vr, n, str)); break;
    default: f = K_SetString; st = CALL(K_SetString, F.SetString(s->c, vr, n, str)); break;
    }
    expect(f, st, n ? M_ERROR : M_OK, k, "the model has no Boolean or String variables");
    after(k, st, "a Boolean/String call");
}

static void op_inputs(int k) {
    static double v[MAXV];
    size_t i;
    fmi2Status st;
    for (i = 0; i < in_real.n; ++i)
        v[i] = chance(90) ? start_in[i] + (chance(50) ? uniform(-1, 1) : 0.0) : any_real();
    st = CALL(K_SetReal, F.SetReal(slot[k].c, in_real.vr, in_real.n, v));
    if (st == fmi2OK) {                          /* every input set: the flags start afresh */
        slot[k].wild_inputs = 0;
        inputs_set(k, in_real.vr, in_real.n, v);
    }
    expect(K_SetReal, st, slot[k].phase == TERMINATED ? M_ERROR : M_OK, k, "inputs may be set until terminated");
    after(k, st, "setting the inputs");
}

static void op_step(int k, int wild) {
    static double out[MAXV];
    Slot *s = &slot[k];
    double t = s->time, h = 0.1;
    fmi2Status st;
    unsigned mask;
    size_t i;
    if (wild) {
        if (chance(50)) t = any_real();
        if (chance(70)) h = any_real();
        if (h > wild_max && h <= max_step) h = wild_max;
    }
    st = CALL(K_DoStep, F.DoStep(s->c, t, h, chance(50)));
    int well_formed = s->phase == STEPPING && isfinite(t) && isfinite(h) && h > 0.0
                      && h <= max_step;
    mask = well_formed ? valid_step_mask(k) : M_DISCARD;
    if (well_formed) {                           /* a step from another time: refused, before
                                                    the model sees its inputs (NaN or not) */
        int at = at_time(t, s->time, h);
        if (s->damaged || at < 0) mask |= M_ERROR;
        else if (at == 0) mask = M_ERROR;
    }
    expect(K_DoStep, st, mask, k, "a step while stepping, finite t at the instance's time, "
           "finite h > 0 (<= -H), no NaN in a -N input");
    if (st == fmi2OK) {
        s->time = t + h;
        if (s->damaged) damaged_steps++;
        if (!s->model && !s->damaged && s->starts && !(feedthrough && s->wild_inputs)) {
            st = CALL(K_GetReal, F.GetReal(s->c, out_real.vr, out_real.n, out));
            expect(K_GetReal, st, M_OK, k, "every output");
            for (i = 0; i < out_real.n; ++i)
                if (!isfinite(out[i])) {
                    ++violations;
                    printf("VIOLATION at call %ld: output vr %u of instance %d is %g after a step\n",
                           total, out_real.vr[i], k, out[i]);
                    print_changed_parameters(k);
                    break;
                }
        }
    }
    after(k, st, "a step");
}

static void op_state(int k) {
    int i, j;
    fmi2Status st;
    switch (below(10)) {
    case 0: case 1:
        save_state(k);
        break;
    case 2: {                                    /* overwrite a state of this instance */
        for (i = 0; i < nstates && states[i].owner != k; ++i) {}
        if (i == nstates) { save_state(k); break; }
        st = CALL(K_GetFMUstate, F.GetFMUstate(slot[k].c, &states[i].s));
        expect(K_GetFMUstate, st, M_OK, k, "overwriting a state of this instance");
        if (st == fmi2OK) {
            states[i].model = slot[k].model;
            states[i].phase = slot[k].phase;
            states[i].starts = slot[k].starts;
            states[i].damaged = slot[k].damaged;
            states[i].wild_inputs = slot[k].wild_inputs;
            states[i].nan_inputs = slot[k].nan_inputs;
            states[i].time = slot[k].time;
        }
        break;
    }
    case 3: case 4: case 5: {                    /* restore any state, also of another instance */
        State *t;
        unsigned mask;
        if (!nstates) { save_state(k); break; }
        t = &states[below(nstates)];
        if (chance(70))                          /* mostly one of this instance's own */
            for (i = 0, j = below(nstates); i < nstates; ++i)
                if (states[(i + j) % nstates].owner == k) {
                    t = &states[(i + j) % nstates];
                    break;
                }
        /* a state is this instance's (FMI 2.0: fmi2SetFMUstate takes a state the instance got
           itself; another instance's travels as serialised bytes) */
        if (t->model != slot[k].model || t->owner != k) mask = M_ERROR;
        else if (t->damaged || (!t->starts && (t->phase == STEPPING || t->phase == TERMINATED)))
            mask = M_OK | M_ERROR;                /* its parameters may be refused */
        else mask = M_OK;
        st = CALL(K_SetFMUstate, F.SetFMUstate(slot[k].c, t->s));
        expect(K_SetFMUstate, st, mask, k, "a state of this model");
        if (st == fmi2OK && t->damaged) damaged_restored++;
        if (st != fmi2OK && (t->model != slot[k].model || t->owner != k)) foreign_refused++;
        if (st == fmi2OK) {
            slot[k].phase = t->phase;
            slot[k].starts = t->starts;
            slot[k].damaged = t->damaged;
            slot[k].wild_inputs = t->wild_inputs;
            slot[k].nan_inputs = t->nan_inputs;
            slot[k].time = t->time;
        }
        after(k, st, "restoring a state");
        break;
    }
    case 6:
        for (i = 0; i < nstates && states[i].owner != k; ++i) {}
        if (i < nstates) free_state(i);
        else {
            fmi2FMUstate none = NULL;
            st = CALL(K_FreeFMUstate, F.FreeFMUstate(slot[k].c, chance(50) ? &none : NULL));
            expect(K_FreeFMUstate, st, M_OK, k, "freeing no state is a no-op");
        }
        break;
    case 7: {                                    /* serialise, deserialise anywhere */
        size_t size = 0;
        fmi2Byte *bytes;
        int to;
        if (!nstates) { save_state(k); break; }
        i = below(nstates);
        bytes = serialise(i, &size);
        if (!bytes) break;
        to = find_slot(-1, 1);
        if (to < 0) to = states[i].owner;
        if (chance(10)) {                        /* a buffer too small, or none */
            int owner = states[i].owner;
            st = CALL(K_SerializeFMUstate, F.SerializeFMUstate(slot[owner].c, states[i].s,
                                                             chance(50) ? bytes : NULL, size - 1));
            expect(K_SerializeFMUstate, st, M_ERROR, owner, "a buffer too small");
            st = CALL(K_SerializedFMUstateSize, F.SerializedFMUstateSize(slot[owner].c, states[i].s, NULL));
            expect(K_SerializedFMUstateSize, st, M_ERROR, owner, "size is NULL");
        }
        {
            State like = states[i];
            deserialise(to, bytes, size, like.model == slot[to].model ? M_OK : M_ERROR, &like, like.damaged,
                        "a serialised state of this model (also from another instance)");
            if (chance(20)) {                    /* truncated */
                deserialise(to, bytes, size / 2, M_ERROR, &like, 0, "a truncated serialised state");
            }
        }
        free(bytes);
        break;
    }
    case 8: {                                    /* random bytes */
        size_t size = (size_t)below(4) == 0 ? 0 : (size_t)below(1 << 14);
        fmi2Byte *bytes = (fmi2Byte *)malloc(size + 1);
        State like = {NULL, k, slot[k].model, INSTANTIATED, 0, 1, 0, 0u, 0.0};
        if (!bytes) break;
        for (j = 0; j < (int)size; ++j) bytes[j] = (fmi2Byte)(rnd() & 0xFF);
        deserialise(k, chance(10) ? NULL : bytes, size, M_ERROR, &like, 1, "random bytes");
        free(bytes);
        break;
    }
    default: {                                   /* a real state with damaged bytes past its header */
        size_t size = 0;
        fmi2Byte *bytes;
        if (!nstates) { save_state(k); break; }
        i = below(nstates);
        bytes = serialise(i, &size);
        if (!bytes) break;
        if (size > 64) {
            int flips = 1 + below(64);
            State like = states[i];
            for (j = 0; j < flips; ++j) {
                size_t at = 64 + (size_t)(rnd() % (uint64_t)(size - 64));
                bytes[at] = chance(50) ? (fmi2Byte)(rnd() & 0xFF) : (fmi2Byte)(bytes[at] ^ (1 << below(8)));
            }
            if (like.model == slot[k].model)
                deserialise(k, bytes, size, M_OK | M_ERROR, &like, 1, "a damaged serialised state");
        }
        free(bytes);
        break;
    }
    }
}

static void op_logging(int k) {
    static const char *const CATS[] = {"logEvents", "logStatusWarning", "logStatusDiscard",
                                       "logStatusError", "logAll"};
    fmi2String cats[3];
    size_t n = (size_t)below(4), i;
    int valid = 1, null_array = 0;
    fmi2Status st;
    for (i = 0; i < n; ++i) {
        int r = below(7);
        cats[i] = r < 5 ? CATS[r] : r == 5 ? "noSuchCategory" : NULL;
        valid &= r < 5;
    }
    if (n && chance(10)) null_array = 1;
    st = CALL(K_SetDebugLogging, F.SetDebugLogging(slot[k].c, chance(50), n, null_array ? NULL : cats));
    expect(K_SetDebugLogging, st, n == 0 || (valid && !null_array) ? M_OK : M_ERROR, k,
           "known categories");
    after(k, st, "fmi2SetDebugLogging");
}

static void op_status(int k) {
    Slot *s = &slot[k];
    fmi2StatusKind kind = (fmi2StatusKind)below(5);
    fmi2Status st, sv;
    fmi2Real r = 0;
    fmi2Integer i = 0;
    fmi2Boolean b = 1;
    fmi2String str = NULL;
    fmi2ValueReference vr[2];
    fmi2Integer order[2] = {1, 1};
    double dv[2] = {1.0, 2.0}, du[2];
    size_t n = (size_t)below(3);
    int null_value = chance(10);
    vr[0] = pick_vr(0);
    vr[1] = pick_vr(3);
    switch (below(9)) {
    case 0:
        st = CALL(K_GetStatus, F.GetStatus(s->c, kind, &sv));
        expect(K_GetStatus, st, M_ERROR, k, "no asynchronous steps");
        break;
    case 1:
        st = CALL(K_GetRealStatus, F.GetRealStatus(s->c, kind, null_value ? NULL : &r));
        if (st == fmi2OK && !(r == s->time || (isnan(r) && isnan(s->time)))) {
            ++violations;
            printf("VIOLATION at call %ld: fmi2LastSuccessfulTime of instance %d is %.17g, "
                   "expected %.17g\n", total, k, r, s->time);
        }
        expect(K_GetRealStatus, st, kind == fmi2LastSuccessfulTime && !null_value ? M_OK : M_ERROR, k,
               "only the last successful time");
        break;
    case 2:
        st = CALL(K_GetIntegerStatus, F.GetIntegerStatus(s->c, kind, &i));
        expect(K_GetIntegerStatus, st, M_ERROR, k, "no integer status");
        break;
    case 3:
        st = CALL(K_GetBooleanStatus, F.GetBooleanStatus(s->c, kind, &b));
        expect(K_GetBooleanStatus, st, kind == fmi2Terminated ? M_OK : M_ERROR, k, "fmi2Terminated only");
        if (st == fmi2OK && b != fmi2False) {
            ++violations;
            printf("VIOLATION: fmi2Terminated status is true\n");
        }
        break;
    case 4:
        st = CALL(K_GetStringStatus, F.GetStringStatus(s->c, kind, &str));
        expect(K_GetStringStatus, st, M_ERROR, k, "no string status");
        break;
    case 5:
        st = CALL(K_CancelStep, F.CancelStep(s->c));
        expect(K_CancelStep, st, M_ERROR, k, "synchronous steps");
        break;
    case 6:
        st = CALL(K_GetDirectionalDerivative, F.GetDirectionalDerivative(s->c, vr, n, vr, n, dv, du));
        expect(K_GetDirectionalDerivative, st, M_ERROR, k, "not provided");
        break;
    case 7:
        st = CALL(K_SetRealInputDerivatives, F.SetRealInputDerivatives(s->c, vr, n, order, dv));
        expect(K_SetRealInputDerivatives, st, n ? M_ERROR : M_OK, k, "cannot interpolate inputs");
        break;
    default:
        st = CALL(K_GetRealOutputDerivatives, F.GetRealOutputDerivatives(s->c, vr, n, order, du));
        expect(K_GetRealOutputDerivatives, st, n ? M_ERROR : M_OK, k, "no output derivatives");
        break;
    }
    after(k, st, "a status call");
}

/* every function with a NULL instance: refused, never a crash */
static void op_null_instance(void) {
    fmi2FMUstate s = NULL;
    size_t size = 0;
    fmi2Real r[2];
    fmi2Integer i[2];
    fmi2Status sv, st;
    fmi2ValueReference vr[1] = {0};
    int f = below(14);
    switch (f) {
    case 0: st = CALL(K_SetupExperiment, F.SetupExperiment(NULL, 0, 0, 0, 0, 0)); f = K_SetupExperiment; break;
    case 1: st = CALL(K_EnterInitializationMode, F.EnterInitializationMode(NULL)); f = K_EnterInitializationMode; break;
    case 2: st = CALL(K_ExitInitializationMode, F.ExitInitializationMode(NULL)); f = K_ExitInitializationMode; break;
    case 3: st = CALL(K_Terminate, F.Terminate(NULL)); f = K_Terminate; break;
    case 4: st = CALL(K_Reset, F.Reset(NULL)); f = K_Reset; break;
    case 5: st = CALL(K_GetReal, F.GetReal(NULL, vr, 1, r)); f = K_GetReal; break;
    case 6: st = CALL(K_SetInteger, F.SetInteger(NULL, vr, 1, i)); f = K_SetInteger; break;
    case 7: st = CALL(K_DoStep, F.DoStep(NULL, 0.0, 0.1, fmi2True)); f = K_DoStep; break;
    case 8: st = CALL(K_GetFMUstate, F.GetFMUstate(NULL, &s)); f = K_GetFMUstate; break;
    case 9: st = CALL(K_SerializedFMUstateSize, F.SerializedFMUstateSize(NULL, NULL, &size)); f = K_SerializedFMUstateSize; break;
    case 10: st = CALL(K_GetStatus, F.GetStatus(NULL, fmi2DoStepStatus, &sv)); f = K_GetStatus; break;
    case 11: st = CALL(K_SetDebugLogging, F.SetDebugLogging(NULL, 1, 0, NULL)); f = K_SetDebugLogging; break;
    case 12: st = CALL(K_SetFMUstate, F.SetFMUstate(NULL, NULL)); f = K_SetFMUstate; break;
    default:
        calls[K_FreeInstance]++;
        total++;
        F.FreeInstance(NULL);
        return;
    }
    expect(f, st, M_ERROR, -1, "a NULL instance");
}

static void op_info(void) {
    const char *v = F.GetVersion(), *p = F.GetTypesPlatform();
    calls[K_GetVersion]++;
    calls[K_GetTypesPlatform]++;
    total += 2;
    if (!v || strcmp(v, "2.0") != 0 || !p || strcmp(p, "default") != 0) {
        ++violations;
        printf("VIOLATION: fmi2GetVersion %s, fmi2GetTypesPlatform %s\n", v ? v : "(null)", p ? p : "(null)");
    }
}

/* the other robot's instance: stepping with its start values, its states in the pool */
static void op_other_model(int k) {
    Slot *s = &slot[k];
    fmi2Status st;
    if (s->phase == INSTANTIATED) {
        st = CALL(K_EnterInitializationMode, F.EnterInitializationMode(s->c));
        expect(K_EnterInitializationMode, st, M_OK, k, "the other robot");
        if (st == fmi2OK) s->phase = INITIALIZATION;
    } else if (s->phase == INITIALIZATION && s->starts) {
        st = CALL(K_ExitInitializationMode, F.ExitInitializationMode(s->c));
        expect(K_ExitInitializationMode, st, M_OK, k, "the other robot at its start values");
        if (st == fmi2OK) s->phase = STEPPING;
    } else if (chance(50)) {
        op_step(k, 0);
    } else {
        op_state(k);
    }
}

/* ---- the damage sweep (-D): every 4-byte word of a real state past its header set to values
   that are dangerous as counts or indices, one at a time; each damaged state deserialised,
   restored and stepped (the FMU must refuse it or run it, never crash). ---------------------- */
static long sweep_runs, sweep_refused;

static void damage_sweep(int steps, const char *const *int_params, int n_int_params) {
    static const uint32_t WORDS[] = {0x7FFFFFFFu, 0xFFFFFFFFu, 0x00010000u};
    fmi2FMUstate clean = NULL, s;
    fmi2Byte *bytes, *work;
    size_t size = 0, at;
    fmi2Status st;
    int i, w;
    double t = 0.0;
    if (slot[0].c) free_slot(0);
    instantiate(0, 0);
    if (!slot[0].c) return;
    if (!have_starts) read_starts(0);
    st = CALL(K_SetupExperiment, F.SetupExperiment(slot[0].c, 0, 0.0, 0.0, 0, 0.0));
    expect(K_SetupExperiment, st, M_OK, 0, "sweep");
    st = CALL(K_EnterInitializationMode, F.EnterInitializationMode(slot[0].c));
    expect(K_EnterInitializationMode, st, M_OK, 0, "sweep");
    for (i = 0; i < n_int_params; ++i) {
        fmi2ValueReference vr = (fmi2ValueReference)strtoul(int_params[i], NULL, 10);
        const char *eq = strchr(int_params[i], '=');
        fmi2Integer v = eq ? (fmi2Integer)strtol(eq + 1, NULL, 10) : 0;
        st = CALL(K_SetInteger, F.SetInteger(slot[0].c, &vr, 1, &v));
        expect(K_SetInteger, st, M_OK, 0, "sweep: an Integer parameter");
    }
    st = CALL(K_ExitInitializationMode, F.ExitInitializationMode(slot[0].c));
    expect(K_ExitInitializationMode, st, M_OK, 0, "sweep: the parameters given");
    if (st != fmi2OK) return;
    slot[0].phase = STEPPING;
    st = CALL(K_SetReal, F.SetReal(slot[0].c, in_real.vr, in_real.n, start_in));
    expect(K_SetReal, st, M_OK, 0, "sweep: the start inputs (a valid sample at rest)");
    for (i = 0; i < steps; ++i, t += 0.1) {    /* fill histories and rings */
        st = CALL(K_DoStep, F.DoStep(slot[0].c, t, 0.1, fmi2True));
        expect(K_DoStep, st, M_OK, 0, "sweep: filling");
    }
    if (out_int.n) {                           /* the samples taken (diag.samples ...) */
        static int z[MAXV];
        size_t j;
        st = CALL(K_GetInteger, F.GetInteger(slot[0].c, out_int.vr, out_int.n, z));
        printf("damage-sweep integer outputs after filling:");
        for (j = 0; j < out_int.n; ++j) printf(" %d", z[j]);
        printf("\n");
    }
    st = CALL(K_GetFMUstate, F.GetFMUstate(slot[0].c, &clean));
    expect(K_GetFMUstate, st, M_OK, 0, "sweep");
    st = CALL(K_SerializedFMUstateSize, F.SerializedFMUstateSize(slot[0].c, clean, &size));
    if (st != fmi2OK || size < 128) return;
    bytes = (fmi2Byte *)malloc(size);
    work = (fmi2Byte *)malloc(size);
    if (!bytes || !work) { free(bytes); free(work); return; }
    st = CALL(K_SerializeFMUstate, F.SerializeFMUstate(slot[0].c, clean, bytes, size));
    expect(K_SerializeFMUstate, st, M_OK, 0, "sweep");
    for (at = 64; at + 4 <= size; at += 4) {
        uint32_t was;
        int nw = (int)(sizeof WORDS / sizeof WORDS[0]), all;
        memcpy(&was, bytes + at, 4);
        /* a word that holds a small count or index now gets every value; any other word one
           of them in turn (the halves of doubles, mostly) */
        all = was > 0u && was < 0x10000u;
        for (w = 0; w < nw; ++w) {
            uint32_t value = WORDS[all ? w : (int)((at / 4) % (size_t)nw)];
            if (!all && w > 0) break;
            memcpy(work, bytes, size);
            memcpy(work + at, &value, 4);
            s = NULL;
            sweep_runs++;
            st = CALL(K_DeSerializeFMUstate, F.DeSerializeFMUstate(slot[0].c, work, size, &s));
            expect(K_DeSerializeFMUstate, st, M_OK | M_ERROR, 0, "sweep: a damaged state");
            if (st != fmi2OK) { sweep_refused++; continue; }
            st = CALL(K_SetFMUstate, F.SetFMUstate(slot[0].c, s));
            expect(K_SetFMUstate, st, M_OK | M_ERROR, 0, "sweep: a damaged state");
            if (st == fmi2OK) {
                st = CALL(K_DoStep, F.DoStep(slot[0].c, t, 0.1, fmi2True));
                /* a damaged phase or time may turn the step down; it must not crash */
                expect(K_DoStep, st, M_OK | M_DISCARD | M_ERROR, 0,
                       "sweep: a step from a damaged state");
                st = CALL(K_DoStep, F.DoStep(slot[0].c, t + 0.1, 0.1, fmi2True));
                expect(K_DoStep, st, M_OK | M_DISCARD | M_ERROR, 0,
                       "sweep: a step from a damaged state");
                st = CALL(K_SetFMUstate, F.SetFMUstate(slot[0].c, clean));
                expect(K_SetFMUstate, st, M_OK, 0, "sweep: back to the clean state");
            } else {
                sweep_refused++;
            }
            st = CALL(K_FreeFMUstate, F.FreeFMUstate(slot[0].c, &s));
            expect(K_FreeFMUstate, st, M_OK, 0, "sweep");
        }
    }
    st = CALL(K_FreeFMUstate, F.FreeFMUstate(slot[0].c, &clean));
    free(bytes);
    free(work);
    free_slot(0);
}

static size_t parse_list(const char *text, List *l) {
    const char *p = text;
    char *end;
    l->n = 0;
    while (*p && l->n < MAXV) {
        unsigned long v = strtoul(p, &end, 10);
        if (end == p) break;
        l->vr[l->n++] = (fmi2ValueReference)v;
        p = *end == ',' ? end + 1 : end;
    }
    return l->n;
}

int main(int argc, char **argv) {
    long ncalls = 20000;
    unsigned long long seed = 1;
    int opt, f, k, sweep_steps = -1, n_int_params = 0;
    static const char *int_params[64];
    void *lib;
    nslots = 4;
    while ((opt = getopt(argc, argv, "n:S:k:L:R:P:I:O:Z:g:u:m:D:p:TN:H:Fw:")) != -1) {
        switch (opt) {
        case 'n': ncalls = atol(optarg); break;
        case 'S': seed = strtoull(optarg, NULL, 10); break;
        case 'k': nslots = atoi(optarg); break;
        case 'L': log_max = atol(optarg); break;
        case 'R': parse_list(optarg, &in_real); break;
        case 'P': parse_list(optarg, &par_real); break;
        case 'I': parse_list(optarg, &par_int); break;
        case 'O': parse_list(optarg, &out_real); break;
        case 'Z': parse_list(optarg, &out_int); break;
        case 'g': guid2 = optarg; break;
        case 'u': uri2 = optarg; break;
        case 'm': nvars2 = (unsigned)atoi(optarg); break;
        case 'D': sweep_steps = atoi(optarg); break;
        case 'p':
            if (n_int_params < 64) int_params[n_int_params++] = optarg;
            break;
        case 'T': feedthrough = 1; break;
        case 'N': parse_list(optarg, &nan_discard); break;
        case 'H': max_step = strtod(optarg, NULL); break;
        case 'F': may_fail = 1; break;
        case 'w': wild_max = strtod(optarg, NULL); break;
        default: return 2;
        }
    }
    if (argc - optind != 4 || nslots < 2 || nslots > MAX_SLOTS || !in_real.n || !out_real.n ||
        (guid2 && !uri2)) {
        fprintf(stderr, "usage: %s [-n CALLS] [-S SEED] [-k 2..%d] [-L LOGLINES] -R VRS -P VRS -I VRS "
                "-O VRS -Z VRS [-g GUID2 -u URI2 -m NVARS2] BINARY GUID RESOURCE_URI NVARS\n",
                argv[0], MAX_SLOTS);
        return 2;
    }
    guid = argv[optind + 1];
    uri = argv[optind + 2];
    nvars = (unsigned)atoi(argv[optind + 3]);
    rng_state = seed;
    lib = lib_open(argv[optind]);
    if (!lib) {
        fprintf(stderr, "fmu_fuzz: cannot load %s\n", argv[optind]);
        return 2;
    }
    for (f = 0; f < NFUNC; ++f) {
        char name[64];
        any_fn fn;
        snprintf(name, sizeof name, "fmi2%s", NAME[f]);
        fn = lib_sym(lib, name);
        if (!fn) {
            fprintf(stderr, "fmu_fuzz: %s is not exported\n", name);
            return 2;
        }
        memcpy((char *)&F + (size_t)f * sizeof fn, &fn, sizeof fn);
    }
    for (k = 0; k < MAX_SLOTS; ++k) slot[k].phase = NONE;

    while (total < ncalls) {
        int r = below(100);
        k = find_slot(0, 1);
        if (k < 0 || (r < 2 && chance(50))) { op_instantiate(); continue; }
        if (r < 4) { op_bad_instantiate(); continue; }
        if (r < 6) {
            if (chance(80)) continue;
            int j = find_slot(-1, 1);
            if (j >= 0) free_slot(j);
            continue;
        }
        if (r < 7) { op_null_instance(); continue; }
        if (r < 8) { op_info(); continue; }
        if (guid2 && r < 12) {
            int o = nslots - 1;
            if (!slot[o].c) instantiate(o, 1);
            else op_other_model(o);
            continue;
        }
        if (r < 24) op_lifecycle(k);
        else if (r < 32) op_set(k, 0);
        else if (r < 38) op_set(k, 1);
        else if (r < 44) op_get(k, 0);
        else if (r < 48) op_get(k, 1);
        else if (r < 50) op_other_types(k);
        else if (r < 60) op_inputs(k);
        else if (r < 72) op_step(k, 0);
        else if (r < 78) op_step(k, 1);
        else if (r < 90) op_state(k);
        else if (r < 93) op_logging(k);
        else op_status(k);
    }
    for (k = 0; k < nslots; ++k)
        if (slot[k].c) free_slot(k);
    if (sweep_steps >= 0) damage_sweep(sweep_steps, int_params, n_int_params);

    printf("function calls ok warning discard error fatal\n");
    for (f = 0; f < NFUNC; ++f)
        printf("fmi2%s %ld %ld %ld %ld %ld %ld\n", NAME[f], calls[f], status_count[f][0],
               status_count[f][1], status_count[f][2], status_count[f][3], status_count[f][4]);
    printf("instantiate-null %ld\n", null_instances);
    if (sweep_steps >= 0)
        printf("damage-sweep states %ld refused %ld\n", sweep_runs, sweep_refused);
    printf("damaged-states-restored %ld steps-from-damaged-states %ld foreign-states-refused %ld\n",
           damaged_restored, damaged_steps, foreign_refused);
    printf("log-lines ok %ld warning %ld discard %ld error %ld fatal %ld bad %ld\n", log_lines[0],
           log_lines[1], log_lines[2], log_lines[3], log_lines[4], log_bad);
    printf("total %ld seed %llu instances %d violations %ld\n", total, seed, nslots, violations);
    return violations || log_bad ? 1 : 0;
}
