/*
 * fmu_host3.c -- a minimal FMI 3.0 co-simulation master in C (tests/test_fmi3.py): one source
 * for Linux (gcc, dlopen) and Windows (x86_64-w64-mingw32-gcc, LoadLibrary; run under Wine), so
 * that the win64 FMI 3.0 binaries are compared with the linux64 ones.
 *
 * It compiles against fmpy's copy of the standard's headers (fmpy/c-code/fmi3FunctionTypes.h:
 * -I that folder), not the FMUs' own fmi3.h, so that the FMUs' functions are called with the
 * standard's types. It loads the first FMU (and optionally a second one, wired to it), steps them
 * with a fixed communication step (a Jacobi exchange at every communication point: every input
 * gets its source's value, then the first FMU steps, then the second) and prints time and the
 * requested Float64 variables as CSV with %.17g.
 *
 * usage: fmu_host3 [-e BIN2 -g TOKEN2 -r RESOURCES2 -w P:E,... -b E:P,... -o VRS2]
 *                  BIN TOKEN RESOURCES DT NSTEPS VRS
 *   RESOURCES: the FMU's resources folder (a native path ending in a separator, as FMI 3.0
 *   passes it); VRS: comma-separated Float64 value references printed (first FMU);
 *   -w: wires first-FMU output P -> second-FMU input E; -b: feedback E -> P; -o: the second
 *   FMU's Float64 outputs printed after the first's.
 * Exit status: 0 ok, 1 usage, 2 a binary cannot be loaded, 3 a missing fmi3 symbol, 4 a call
 * returned fmi3Discard or worse (or an instance could not be created).
 */
#if defined(_WIN32)
#  ifndef __USE_MINGW_ANSI_STDIO
#    define __USE_MINGW_ANSI_STDIO 1   /* C99 printf: %.17g round-trips */
#  endif
#  include <windows.h>
#else
#  ifndef _POSIX_C_SOURCE
#    define _POSIX_C_SOURCE 200809L
#  endif
#  include <dlfcn.h>
#endif
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3FunctionTypes.h"

#define MAXV 512

#if defined(_WIN32)
typedef HMODULE lib_t;
static lib_t lib_open(const char *p) { return LoadLibraryA(p); }
static void *lib_sym(lib_t l, const char *n) { return (void *)(size_t)GetProcAddress(l, n); }
#else
typedef void *lib_t;
static lib_t lib_open(const char *p) { return dlopen(p, RTLD_NOW | RTLD_LOCAL); }
static void *lib_sym(lib_t l, const char *n) { return dlsym(l, n); }
#endif

typedef struct {
    fmi3InstantiateCoSimulationTYPE *instantiate;
    fmi3EnterInitializationModeTYPE *enter_init;
    fmi3ExitInitializationModeTYPE *exit_init;
    fmi3GetFloat64TYPE *get;
    fmi3SetFloat64TYPE *set;
    fmi3DoStepTYPE *step;
    fmi3TerminateTYPE *terminate;
    fmi3FreeInstanceTYPE *free_instance;
    fmi3Instance inst;
} fmu_t;

static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category,
                   fmi3String message) {
    (void)env;
    fprintf(stderr, "[%d][%s] %s\n", (int)status, category ? category : "", message ? message : "");
}

/* resolve one symbol into a function pointer (through an object pointer: POSIX dlsym) */
#define RESOLVE(f, field, name)                                                               \
    do {                                                                                      \
        void *s_ = lib_sym(l, name);                                                          \
        if (!s_) { fprintf(stderr, "missing %s\n", name); return 3; }                          \
        memcpy(&(f)->field, &s_, sizeof s_);                                                  \
    } while (0)

static int load(fmu_t *f, const char *path, const char *name, const char *token,
                const char *resources) {
    lib_t l = lib_open(path);
    if (!l) { fprintf(stderr, "cannot load %s\n", path); return 2; }
    RESOLVE(f, instantiate, "fmi3InstantiateCoSimulation");
    RESOLVE(f, enter_init, "fmi3EnterInitializationMode");
    RESOLVE(f, exit_init, "fmi3ExitInitializationMode");
    RESOLVE(f, get, "fmi3GetFloat64");
    RESOLVE(f, set, "fmi3SetFloat64");
    RESOLVE(f, step, "fmi3DoStep");
    RESOLVE(f, terminate, "fmi3Terminate");
    RESOLVE(f, free_instance, "fmi3FreeInstance");
    f->inst = f->instantiate(name, token, resources, fmi3False, fmi3False, fmi3False, fmi3False,
                             NULL, 0, NULL, logger, NULL);
    if (!f->inst) { fprintf(stderr, "fmi3InstantiateCoSimulation of %s returned NULL\n", path); return 4; }
    return 0;
}

/* "1,2,3" -> vr[]; returns the count */
static size_t parse_vrs(const char *s, fmi3ValueReference vr[]) {
    size_t n = 0;
    while (s && *s && n < MAXV) {
        vr[n++] = (fmi3ValueReference)strtoul(s, (char **)&s, 10);
        if (*s == ',') ++s;
    }
    return n;
}

/* "1:2,3:4" -> a[], b[]; returns the count */
static size_t parse_pairs(const char *s, fmi3ValueReference a[], fmi3ValueReference b[]) {
    size_t n = 0;
    while (s && *s && n < MAXV) {
        a[n] = (fmi3ValueReference)strtoul(s, (char **)&s, 10);
        if (*s == ':') ++s;
        b[n++] = (fmi3ValueReference)strtoul(s, (char **)&s, 10);
        if (*s == ',') ++s;
    }
    return n;
}

#define CHECK(call)                                                                           \
    do {                                                                                      \
        fmi3Status s_ = (call);                                                               \
        if (s_ > fmi3Warning) { fprintf(stderr, "%s returned %d\n", #call, (int)s_); return 4; } \
    } while (0)

int main(int argc, char *argv[]) {
    static fmi3ValueReference out1[MAXV], out2[MAXV], wp[MAXV], we[MAXV], be[MAXV], bp[MAXV];
    static fmi3Float64 val[MAXV];
    const char *bin2 = NULL, *tok2 = NULL, *res2 = NULL;
    size_t nout1, nout2 = 0, nw = 0, nb = 0, i;
    fmu_t a, b;
    int argi = 1, rc;
    long n, k;
    double h;
    memset(&a, 0, sizeof a);
    memset(&b, 0, sizeof b);
    while (argi + 1 < argc && argv[argi][0] == '-' && argv[argi][1] && !argv[argi][2]) {
        const char *v = argv[argi + 1];
        switch (argv[argi][1]) {
        case 'e': bin2 = v; break;
        case 'g': tok2 = v; break;
        case 'r': res2 = v; break;
        case 'w': nw = parse_pairs(v, wp, we); break;
        case 'b': nb = parse_pairs(v, be, bp); break;
        case 'o': nout2 = parse_vrs(v, out2); break;
        default: fprintf(stderr, "unknown option %s\n", argv[argi]); return 1;
        }
        argi += 2;
    }
    if (argc - argi != 6 || (bin2 && (!tok2 || !res2))) {
        fprintf(stderr, "usage: %s [-e BIN2 -g TOKEN2 -r RES2 -w P:E,... -b E:P,... -o VRS2] "
                "BIN TOKEN RESOURCES DT NSTEPS VRS\n", argv[0]);
        return 1;
    }
    h = strtod(argv[argi + 3], NULL);
    n = strtol(argv[argi + 4], NULL, 10);
    nout1 = parse_vrs(argv[argi + 5], out1);
    if ((rc = load(&a, argv[argi], "first", argv[argi + 1], argv[argi + 2])) != 0) return rc;
    if (bin2 && (rc = load(&b, bin2, "second", tok2, res2)) != 0) return rc;
    CHECK(a.enter_init(a.inst, fmi3False, 0.0, 0.0, fmi3True, n * h));
    CHECK(a.exit_init(a.inst));
    if (bin2) {
        CHECK(b.enter_init(b.inst, fmi3False, 0.0, 0.0, fmi3True, n * h));
        CHECK(b.exit_init(b.inst));
    }
    for (k = 0; k <= n; ++k) {
        double t = k * h;
        fmi3Boolean ev, term, early;
        fmi3Float64 last;
        if (bin2) {               /* Jacobi: read every source first, then set */
            static fmi3Float64 wv[MAXV], bv[MAXV];
            if (nw) CHECK(a.get(a.inst, wp, nw, wv, nw));
            if (nb) CHECK(b.get(b.inst, be, nb, bv, nb));
            if (nw) CHECK(b.set(b.inst, we, nw, wv, nw));
            if (nb) CHECK(a.set(a.inst, bp, nb, bv, nb));
        }
        CHECK(a.get(a.inst, out1, nout1, val, nout1));
        printf("%.17g", t);
        for (i = 0; i < nout1; ++i) printf(",%.17g", val[i]);
        if (bin2 && nout2) {
            CHECK(b.get(b.inst, out2, nout2, val, nout2));
            for (i = 0; i < nout2; ++i) printf(",%.17g", val[i]);
        }
        printf("\n");
        if (k == n) break;
        CHECK(a.step(a.inst, t, h, fmi3True, &ev, &term, &early, &last));
        if (last != t + h) { fprintf(stderr, "lastSuccessfulTime %.17g, not t + h\n", last); return 4; }
        if (bin2) CHECK(b.step(b.inst, t, h, fmi3True, &ev, &term, &early, &last));
    }
    CHECK(a.terminate(a.inst));
    a.free_instance(a.inst);
    if (bin2) {
        CHECK(b.terminate(b.inst));
        b.free_instance(b.inst);
    }
    return 0;
}
