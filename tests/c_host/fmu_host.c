/*
 * fmu_host.c -- a minimal FMI 2.0 co-simulation master written in C, used by
 * tests/test_native_fmu_hosts.py and tests/test_native_closed_loop_host.py to show that the
 * spacerobot FMUs work in a host that is not Python (the situation of fmuCheck, OMSimulator or Simulink).
 *
 * ONE source for Linux and Windows: it compiles with gcc (dlopen) and with x86_64-w64-mingw32-gcc
 * (LoadLibrary / GetProcAddress under _WIN32; the .exe then runs a win64 FMU binary, e.g. under
 * Wine). It needs no FMI header: the few FMI 2.0 types it uses are declared below, from the
 * standard (FMI 2.0.4, section 2.1), and it reaches the FMU through function pointers only.
 *
 * It loads an FMU binary, resolves the fmi2* functions, instantiates the FMU, optionally sets
 * Real and Integer parameters in initialisation mode, steps it with a fixed communication step
 * and prints the requested variables as CSV (time first, Reals with %.17g so that values
 * round-trip exactly, then Integers).
 *
 * Options:
 *   -c N        before the run, N cycles of instantiate, initialise, one step, terminate, free
 *               of the first FMU (instances must come and go without leaking or crashing).
 *   -x MODE     how the host ends: "free" (default: fmi2Terminate + fmi2FreeInstance),
 *               "dlclose" (also unload every FMU library: dlclose / FreeLibrary) or "none"
 *               (return from main with the instances alive and the libraries loaded).
 *   -s K        after step K take the FMU state, serialise it to bytes and free it; at the end
 *               deserialise, restore, re-run the steps after K (with the same inputs) and exit 5
 *               unless every printed variable ends bit-identical.
 *   -i FILE     inputs of the first FMU, one row per step: the first line lists the Real value
 *               references (comma-separated), each further line their values for one step
 *               (row k is set before the step from t_k = k DT; a value is a decimal number or
 *               the IEEE-754 bits as 0x followed by 16 hex digits, exact and locale-free).
 *   -j VRS      also print these Integer variables (comma-separated value references) of the
 *               first FMU after its Reals.
 *   -p VR=INT   set this Integer parameter of the first FMU in initialisation mode (repeatable).
 *   -e EST.so -g EST_GUID -r EST_RESOURCE_URI -w P1:E1,P2:E2,... -o E_OUT1,E_OUT2,...
 *               also load a second FMU (the estimator) and wire it: before every step its
 *               inputs E_i are set to the first FMU's outputs P_i; its outputs E_OUT are
 *               printed after the first FMU's.
 *   -b E1:P1,E2:P2,...
 *               with -e: feedback wires, the second FMU's outputs E_i to the first FMU's inputs
 *               P_i, set before every step (after the -i row): a closed loop, as the SSP wires
 *               estimator ident.excite, ident.excite_rate -> plant inputs of the same names.
 *               Neither FMU has direct feedthrough, so every input gets its source's value at
 *               the communication point
 *               (a Jacobi exchange, as spacerobot.system.master does), then the first FMU
 *               steps, then the second.
 *
 * usage: fmu_host [options] BINARY GUID RESOURCE_URI DT NSTEPS VR1,VR2,... [VR=VALUE ...]
 * (VR=VALUE: a Real parameter set in initialisation mode.)
 *
 * It needs no set-up and calls nothing but the FMI 2.0 C API. Exit status: 0 ok, 1 usage,
 * 2 the binary cannot be loaded, 3 a missing fmi2 symbol or another FMI version, 4 a call
 * returned fmi2Discard or worse (fmi2Instantiate returned NULL: after the FMU's logged
 * messages), 5 a state round trip that did not reproduce the run, 6 unloading failed, 7 an
 * unreadable input file. The last line on stderr gives the time taken.
 */
#if defined(_WIN32)
#  ifndef __USE_MINGW_ANSI_STDIO
#    define __USE_MINGW_ANSI_STDIO 1   /* C99 printf (%.17g round-trips) whatever the msvcrt */
#  endif
#  include <windows.h>
#  include <getopt.h>
#else
#  ifndef _POSIX_C_SOURCE
#    define _POSIX_C_SOURCE 200809L   /* getopt, clock_gettime */
#  endif
#  include <dlfcn.h>
#  include <time.h>
#  include <unistd.h>
#endif
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2_host.h"   /* the FMI 2.0 types (FMI 2.0.4, sections 2.1.2-2.1.9) */

/* the fmi2 functions called, as pointer types */
typedef const char *(*GetVersion_t)(void);
typedef fmi2Component (*Instantiate_t)(fmi2String, fmi2Type, fmi2String, fmi2String,
                                       const fmi2CallbackFunctions *, fmi2Boolean, fmi2Boolean);
typedef fmi2Status (*SetupExperiment_t)(fmi2Component, fmi2Boolean, fmi2Real, fmi2Real,
                                        fmi2Boolean, fmi2Real);
typedef fmi2Status (*Phase_t)(fmi2Component);          /* Enter/ExitInitializationMode, Terminate */
typedef fmi2Status (*SetReal_t)(fmi2Component, const fmi2ValueReference *, size_t,
                                const fmi2Real *);
typedef fmi2Status (*GetReal_t)(fmi2Component, const fmi2ValueReference *, size_t, fmi2Real *);
typedef fmi2Status (*SetInteger_t)(fmi2Component, const fmi2ValueReference *, size_t,
                                   const fmi2Integer *);
typedef fmi2Status (*GetInteger_t)(fmi2Component, const fmi2ValueReference *, size_t,
                                   fmi2Integer *);
typedef fmi2Status (*DoStep_t)(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean);
typedef void (*FreeInstance_t)(fmi2Component);
typedef fmi2Status (*GetFMUstate_t)(fmi2Component, fmi2FMUstate *);
typedef fmi2Status (*SetFMUstate_t)(fmi2Component, fmi2FMUstate);
typedef fmi2Status (*FreeFMUstate_t)(fmi2Component, fmi2FMUstate *);
typedef fmi2Status (*SerializedFMUstateSize_t)(fmi2Component, fmi2FMUstate, size_t *);
typedef fmi2Status (*SerializeFMUstate_t)(fmi2Component, fmi2FMUstate, fmi2Byte *, size_t);
typedef fmi2Status (*DeSerializeFMUstate_t)(fmi2Component, const fmi2Byte *, size_t,
                                            fmi2FMUstate *);

/* ---- the platform: loading a library, a clock ------------------------------------------------ */
typedef void (*any_fn)(void);
#if defined(_WIN32)
typedef HMODULE lib_t;
static lib_t lib_open(const char *path) { return LoadLibraryA(path); }
static int lib_close(lib_t lib) { return FreeLibrary(lib) ? 0 : 1; }
static any_fn lib_sym(lib_t lib, const char *name) { return (any_fn)GetProcAddress(lib, name); }
static const char *lib_error(void) {
    static char text[64];
    snprintf(text, sizeof text, "Windows error %lu", (unsigned long)GetLastError());
    return text;
}
static double now(void) {
    LARGE_INTEGER f, c;
    QueryPerformanceFrequency(&f);
    QueryPerformanceCounter(&c);
    return (double)c.QuadPart / (double)f.QuadPart;
}
#else
typedef void *lib_t;
static lib_t lib_open(const char *path) { return dlopen(path, RTLD_NOW | RTLD_LOCAL); }
static int lib_close(lib_t lib) { return dlclose(lib); }
static any_fn lib_sym(lib_t lib, const char *name) {
    void *p = dlsym(lib, name);
    any_fn f;
    memcpy(&f, &p, sizeof f);                   /* POSIX: a data pointer holds a function's */
    return f;
}
static const char *lib_error(void) {
    const char *e = dlerror();
    return e ? e : "unknown error";
}
static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}
#endif

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    va_list args;
    (void)env;
    fprintf(stderr, "[%s][status %d][%s] ", name ? name : "?", (int)status,
            category ? category : "");
    va_start(args, message);
    vfprintf(stderr, message, args);
    va_end(args);
    fputc('\n', stderr);
}

typedef struct {
    lib_t lib;
    fmi2Component c;
    GetVersion_t GetVersion;
    Instantiate_t Instantiate;
    SetupExperiment_t SetupExperiment;
    Phase_t EnterInitializationMode, ExitInitializationMode, Terminate;
    SetReal_t SetReal;
    GetReal_t GetReal;
    SetInteger_t SetInteger;
    GetInteger_t GetInteger;
    DoStep_t DoStep;
    FreeInstance_t FreeInstance;
    GetFMUstate_t GetFMUstate;
    SetFMUstate_t SetFMUstate;
    FreeFMUstate_t FreeFMUstate;
    SerializedFMUstateSize_t SerializedFMUstateSize;
    SerializeFMUstate_t SerializeFMUstate;
    DeSerializeFMUstate_t DeSerializeFMUstate;
} Fmu;

static any_fn sym(lib_t lib, const char *name) {
    any_fn f = lib_sym(lib, name);
    if (!f) {
        fprintf(stderr, "fmu_host: symbol %s not found: %s\n", name, lib_error());
        exit(3);
    }
    return f;
}

#define LOAD(f, name, type) (f)->name = (type)sym((f)->lib, "fmi2" #name)

static fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};

static void load(Fmu *f, const char *so, const char *instance, const char *guid,
                 const char *resources) {
    f->lib = lib_open(so);
    if (!f->lib) {
        fprintf(stderr, "fmu_host: cannot load %s: %s\n", so, lib_error());
        exit(2);
    }
    LOAD(f, GetVersion, GetVersion_t);
    LOAD(f, Instantiate, Instantiate_t);
    LOAD(f, SetupExperiment, SetupExperiment_t);
    LOAD(f, EnterInitializationMode, Phase_t);
    LOAD(f, ExitInitializationMode, Phase_t);
    LOAD(f, Terminate, Phase_t);
    LOAD(f, SetReal, SetReal_t);
    LOAD(f, GetReal, GetReal_t);
    LOAD(f, SetInteger, SetInteger_t);
    LOAD(f, GetInteger, GetInteger_t);
    LOAD(f, DoStep, DoStep_t);
    LOAD(f, FreeInstance, FreeInstance_t);
    LOAD(f, GetFMUstate, GetFMUstate_t);
    LOAD(f, SetFMUstate, SetFMUstate_t);
    LOAD(f, FreeFMUstate, FreeFMUstate_t);
    LOAD(f, SerializedFMUstateSize, SerializedFMUstateSize_t);
    LOAD(f, SerializeFMUstate, SerializeFMUstate_t);
    LOAD(f, DeSerializeFMUstate, DeSerializeFMUstate_t);
    if (strcmp(f->GetVersion(), "2.0") != 0) {
        fprintf(stderr, "fmu_host: unexpected FMI version %s\n", f->GetVersion());
        exit(3);
    }
    f->c = f->Instantiate(instance, fmi2CoSimulation, guid, resources, &callbacks, fmi2False,
                          fmi2False);
    if (!f->c) {
        fprintf(stderr, "fmu_host: fmi2Instantiate of %s returned NULL\n", so);
        exit(4);
    }
}

static void check(fmi2Status s, const char *what) {
    if (s > fmi2Warning) {
        fprintf(stderr, "fmu_host: %s returned status %d\n", what, (int)s);
        exit(4);
    }
}

#define CHECK(call) check((call), #call)

static size_t parse_list(const char *text, unsigned long *out, size_t max) {
    size_t k = 0;
    char *end;
    const char *p = text;
    while (*p && k < max) {
        unsigned long v = strtoul(p, &end, 10);
        if (end == p) break;
        out[k++] = v;
        p = (*end == ',' || *end == ':') ? end + 1 : end;
    }
    return k;
}

#define MAXV 1024

/* ---- the input file (-i) -------------------------------------------------------------------- */
typedef struct {
    size_t nvr, nrows;
    fmi2ValueReference vr[MAXV];
    double *values;                  /* nrows x nvr */
} Inputs;

/* one value: "0x" + 16 hex digits (IEEE-754 bits) or a decimal number; 0 ok */
static int parse_value(const char *s, const char **end, double *out) {
    if (s[0] == '0' && (s[1] == 'x' || s[1] == 'X')) {
        unsigned long long bits = 0;
        int digits = 0;
        for (s += 2; digits < 16; ++s, ++digits) {
            int d = (*s >= '0' && *s <= '9') ? *s - '0'
                  : (*s >= 'a' && *s <= 'f') ? *s - 'a' + 10
                  : (*s >= 'A' && *s <= 'F') ? *s - 'A' + 10 : -1;
            if (d < 0) break;
            bits = (bits << 4) | (unsigned long long)d;
        }
        if (digits != 16) return 1;
        memcpy(out, &bits, sizeof *out);
        *end = s;
        return 0;
    } else {
        char *e;
        *out = strtod(s, &e);
        *end = e;
        return e == s;
    }
}

static void read_inputs(const char *path, Inputs *in) {
    FILE *f = fopen(path, "rb");
    static char line[1 << 16];
    size_t cap = 0;
    unsigned long tmp[MAXV];
    int lineno = 0;
    if (!f) {
        fprintf(stderr, "fmu_host: cannot open the input file %s\n", path);
        exit(7);
    }
    memset(in, 0, sizeof *in);
    while (fgets(line, sizeof line, f)) {
        const char *p = line;
        size_t k;
        ++lineno;
        if (strlen(line) == sizeof line - 1) {
            fprintf(stderr, "fmu_host: %s line %d is too long\n", path, lineno);
            exit(7);
        }
        if (lineno == 1) {
            in->nvr = parse_list(line, tmp, MAXV);
            for (k = 0; k < in->nvr; ++k) in->vr[k] = (fmi2ValueReference)tmp[k];
            if (in->nvr == 0) {
                fprintf(stderr, "fmu_host: %s: the first line lists no value references\n", path);
                exit(7);
            }
            continue;
        }
        if (line[0] == '\n' || line[0] == '\r' || line[0] == '\0') continue;
        if (in->nrows == cap) {
            double *more;
            cap = cap ? 2 * cap : 256;
            more = (double *)realloc(in->values, cap * in->nvr * sizeof(double));
            if (!more) {
                fprintf(stderr, "fmu_host: out of memory reading %s\n", path);
                exit(7);
            }
            in->values = more;
        }
        for (k = 0; k < in->nvr; ++k) {
            const char *end;
            while (*p == ' ') ++p;
            if (parse_value(p, &end, &in->values[in->nrows * in->nvr + k])) {
                fprintf(stderr, "fmu_host: %s line %d: value %lu is not a number\n", path, lineno,
                        (unsigned long)k + 1);
                exit(7);
            }
            p = end;
            while (*p == ' ') ++p;
            if (k + 1 < in->nvr && *p++ != ',') {
                fprintf(stderr, "fmu_host: %s line %d has %lu values, %lu expected\n", path,
                        lineno, (unsigned long)k + 1, (unsigned long)in->nvr);
                exit(7);
            }
        }
        in->nrows++;
    }
    fclose(f);
}

/* one short life of an instance: instantiate, initialise, one step, terminate, free */
static void cycle(Fmu *f, const char *guid, const char *resources, double dt) {
    fmi2Component c = f->Instantiate("c_host_cycle", fmi2CoSimulation, guid, resources,
                                     &callbacks, fmi2False, fmi2False);
    if (!c) {
        fprintf(stderr, "fmu_host: fmi2Instantiate (cycle) returned NULL\n");
        exit(4);
    }
    CHECK(f->SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
    CHECK(f->EnterInitializationMode(c));
    CHECK(f->ExitInitializationMode(c));
    CHECK(f->DoStep(c, 0.0, dt, fmi2True));
    CHECK(f->Terminate(c));
    f->FreeInstance(c);
}

/* the run's state, shared by main and its helpers */
static Fmu plant, est;
static int wired;
static Inputs inputs;
static int have_inputs;
static size_t nout, nint, nwire, neout, nback;
static fmi2ValueReference out_vr[MAXV], int_vr[MAXV], wire_p[MAXV], wire_e[MAXV], eout_vr[MAXV];
static fmi2ValueReference back_e[MAXV], back_p[MAXV];
static double row[2 * MAXV], wire_v[MAXV], back_v[MAXV];
static fmi2Integer irow[MAXV];

static void print_row(double t) {
    size_t n;
    CHECK(plant.GetReal(plant.c, out_vr, nout, row));
    if (nint) CHECK(plant.GetInteger(plant.c, int_vr, nint, irow));
    if (wired) CHECK(est.GetReal(est.c, eout_vr, neout, row + nout));
    printf("%.17g", t);
    for (n = 0; n < nout; n++) printf(",%.17g", row[n]);
    for (n = 0; n < nint; n++) printf(",%d", irow[n]);
    for (n = nout; n < nout + neout; n++) printf(",%.17g", row[n]);
    printf("\n");
}

/* step k (1-based) from t = (k - 1) dt: the inputs of row k - 1 first */
static void step(int k, double t, double dt) {
    if (have_inputs) {
        if ((size_t)(k - 1) >= inputs.nrows) {
            fprintf(stderr, "fmu_host: the input file has %lu rows, step %d needs one more\n",
                    (unsigned long)inputs.nrows, k);
            exit(7);
        }
        CHECK(plant.SetReal(plant.c, inputs.vr, inputs.nvr,
                            inputs.values + (size_t)(k - 1) * inputs.nvr));
    }
    if (wired) {
        CHECK(plant.GetReal(plant.c, wire_p, nwire, wire_v));
        CHECK(est.SetReal(est.c, wire_e, nwire, wire_v));
    }
    if (nback) {                        /* the feedback: the second FMU's outputs at t */
        CHECK(est.GetReal(est.c, back_e, nback, back_v));
        CHECK(plant.SetReal(plant.c, back_p, nback, back_v));
    }
    CHECK(plant.DoStep(plant.c, t, dt, fmi2True));
    if (wired) CHECK(est.DoStep(est.c, t, dt, fmi2True));
}

int main(int argc, char **argv) {
    int opt, state_step = -1, cycles = 0, i, k;
    const char *est_so = NULL, *est_guid = NULL, *est_res = NULL, *wires = NULL, *est_out = NULL;
    const char *exit_mode = "free", *input_file = NULL, *int_out = NULL, *back = NULL;
    static const char *int_params[MAXV];
    int n_int_params = 0;
    double t0 = now();
    /* main may run more than once in a process (tests/test_conformance_c_host.py) */
    memset(&plant, 0, sizeof plant);
    memset(&est, 0, sizeof est);
    wired = have_inputs = 0;
    nout = nint = nwire = neout = nback = 0;
    while ((opt = getopt(argc, argv, "c:x:s:i:j:p:e:g:r:w:o:b:")) != -1) {
        switch (opt) {
        case 'c': cycles = atoi(optarg); break;
        case 'x': exit_mode = optarg; break;
        case 's': state_step = atoi(optarg); break;
        case 'i': input_file = optarg; break;
        case 'j': int_out = optarg; break;
        case 'p':
            if (n_int_params == MAXV) return 1;
            int_params[n_int_params++] = optarg;
            break;
        case 'e': est_so = optarg; break;
        case 'g': est_guid = optarg; break;
        case 'r': est_res = optarg; break;
        case 'w': wires = optarg; break;
        case 'o': est_out = optarg; break;
        case 'b': back = optarg; break;
        default: return 1;
        }
    }
    if (argc - optind < 6 || (est_so && !(est_guid && est_res && wires && est_out)) ||
        (back && !est_so)) {
        fprintf(stderr, "usage: %s [-c N] [-x free|dlclose|none] [-s K] [-i INPUTS.csv] [-j VRS] "
                        "[-p VR=INT ...] [-e EST -g GUID -r URI -w P:E,... -o E,... [-b E:P,...]] "
                        "BINARY GUID RESOURCE_URI DT NSTEPS VRS [VR=VALUE ...]\n", argv[0]);
        return 1;
    }
    const char *so = argv[optind], *guid = argv[optind + 1], *resources = argv[optind + 2];
    double dt = atof(argv[optind + 3]);
    int nsteps = atoi(argv[optind + 4]);

    static unsigned long tmp[2 * MAXV];
    static double saved[2 * MAXV];
    static fmi2Integer isaved[MAXV];
    size_t n;
    nout = parse_list(argv[optind + 5], tmp, MAXV);
    for (n = 0; n < nout; n++) out_vr[n] = (fmi2ValueReference)tmp[n];
    if (int_out) {
        nint = parse_list(int_out, tmp, MAXV);
        for (n = 0; n < nint; n++) int_vr[n] = (fmi2ValueReference)tmp[n];
    }
    if (input_file) {
        read_inputs(input_file, &inputs);
        have_inputs = 1;
    }

    load(&plant, so, "c_host_plant", guid, resources);
    for (i = 0; i < cycles; i++) cycle(&plant, guid, resources, dt);
    if (cycles) fprintf(stderr, "fmu_host: %d instantiate/free cycles done\n", cycles);
    if (est_so) {
        size_t m = parse_list(wires, tmp, 2 * MAXV);
        wired = 1;
        nwire = m / 2;
        for (n = 0; n < nwire; n++) {
            wire_p[n] = (fmi2ValueReference)tmp[2 * n];
            wire_e[n] = (fmi2ValueReference)tmp[2 * n + 1];
        }
        neout = parse_list(est_out, tmp, MAXV);
        for (n = 0; n < neout; n++) eout_vr[n] = (fmi2ValueReference)tmp[n];
        if (back) {
            m = parse_list(back, tmp, 2 * MAXV);
            nback = m / 2;
            for (n = 0; n < nback; n++) {
                back_e[n] = (fmi2ValueReference)tmp[2 * n];
                back_p[n] = (fmi2ValueReference)tmp[2 * n + 1];
            }
        }
        load(&est, est_so, "c_host_estimator", est_guid, est_res);
    }

    CHECK(plant.SetupExperiment(plant.c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
    CHECK(plant.EnterInitializationMode(plant.c));
    for (i = optind + 6; i < argc; i++) {
        const char *eq = strchr(argv[i], '='), *end;
        fmi2ValueReference vr = (fmi2ValueReference)strtoul(argv[i], NULL, 10);
        fmi2Real val;
        if (!eq || parse_value(eq + 1, &end, &val)) return 1;
        CHECK(plant.SetReal(plant.c, &vr, 1, &val));
    }
    for (i = 0; i < n_int_params; i++) {
        const char *eq = strchr(int_params[i], '=');
        fmi2ValueReference vr = (fmi2ValueReference)strtoul(int_params[i], NULL, 10);
        fmi2Integer val;
        if (!eq) return 1;
        val = (fmi2Integer)strtol(eq + 1, NULL, 10);
        CHECK(plant.SetInteger(plant.c, &vr, 1, &val));
    }
    CHECK(plant.ExitInitializationMode(plant.c));
    if (est_so) {
        CHECK(est.SetupExperiment(est.c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
        CHECK(est.EnterInitializationMode(est.c));
        CHECK(est.ExitInitializationMode(est.c));
    }

    double t = 0.0, t1 = now();
    fmi2FMUstate state = NULL;
    fmi2Byte *bytes = NULL;
    size_t nbytes = 0;
    double t_state = 0.0;

    print_row(t);
    for (k = 1; k <= nsteps; k++) {
        step(k, t, dt);
        t = k * dt; /* communication points k*dt, as fmpy's simulate_fmu computes them */
        print_row(t);
        if (k == state_step) {
            CHECK(plant.GetFMUstate(plant.c, &state));
            CHECK(plant.SerializedFMUstateSize(plant.c, state, &nbytes));
            bytes = (fmi2Byte *)malloc(nbytes);
            if (!bytes) return 4;
            CHECK(plant.SerializeFMUstate(plant.c, state, bytes, nbytes));
            CHECK(plant.FreeFMUstate(plant.c, &state));
            t_state = t;
        }
    }
    double t2 = now();

    if (state_step > 0 && state_step < nsteps && !wired) {
        memcpy(saved, row, nout * sizeof(double));    /* the uninterrupted run's final values */
        memcpy(isaved, irow, nint * sizeof(fmi2Integer));
        state = NULL;
        CHECK(plant.DeSerializeFMUstate(plant.c, bytes, nbytes, &state));
        CHECK(plant.SetFMUstate(plant.c, state));
        CHECK(plant.FreeFMUstate(plant.c, &state));
        t = t_state;
        for (k = state_step + 1; k <= nsteps; k++) {
            step(k, t, dt);
            t = k * dt;
        }
        CHECK(plant.GetReal(plant.c, out_vr, nout, row));
        if (nint) CHECK(plant.GetInteger(plant.c, int_vr, nint, irow));
        for (n = 0; n < nout; n++) {
            if (memcmp(&row[n], &saved[n], sizeof(double)) != 0) {
                fprintf(stderr, "fmu_host: state restore mismatch at vr %u: %.17g != %.17g\n",
                        out_vr[n], row[n], saved[n]);
                return 5;
            }
        }
        for (n = 0; n < nint; n++) {
            if (irow[n] != isaved[n]) {
                fprintf(stderr, "fmu_host: state restore mismatch at vr %u: %d != %d\n",
                        int_vr[n], irow[n], isaved[n]);
                return 5;
            }
        }
        fprintf(stderr, "fmu_host: state round trip after step %d: %lu bytes, identical\n",
                state_step, (unsigned long)nbytes);
    }

    free(bytes);
    free(inputs.values);
    fprintf(stderr, "fmu_host: load and initialise %.6f s, %d steps %.6f s\n", t1 - t0, nsteps,
            t2 - t1);
    if (strcmp(exit_mode, "none") == 0) return 0;     /* instances alive, libraries loaded */
    CHECK(plant.Terminate(plant.c));
    plant.FreeInstance(plant.c);
    if (wired) {
        CHECK(est.Terminate(est.c));
        est.FreeInstance(est.c);
    }
    if (strcmp(exit_mode, "dlclose") == 0) {
        if (wired && lib_close(est.lib) != 0) return 6;
        if (lib_close(plant.lib) != 0) return 6;
    }
    return 0;
}
