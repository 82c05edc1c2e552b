/*
 * fmu_host.c -- a minimal FMI 2.0 co-simulation master written in C, used by
 * tests/test_conformance_c_host.py to show that the spacerobot FMUs work in a host that is not
 * Python (the situation of fmuCheck, OMSimulator or Simulink).
 *
 * It dlopen()s an FMU binary, resolves the fmi2* functions, instantiates the FMU, optionally
 * sets Real parameters in initialisation mode, steps it with a fixed communication step and
 * prints the requested Real variables as CSV (time first, %.17g, so values round-trip exactly).
 *
 * Options:
 *   -c N        before the run, N cycles of instantiate, initialise, one step, terminate, free
 *               of the first FMU (instances must come and go without leaking or crashing).
 *   -x MODE     how the host ends: "free" (default: fmi2Terminate + fmi2FreeInstance),
 *               "dlclose" (also dlclose every FMU library) or "none" (return from main with the
 *               instances alive and the libraries loaded).
 *   -s K        after step K take the FMU state, serialise it to bytes and free it; at the end
 *               deserialise, restore, re-run the steps after K and exit 5 unless every printed
 *               variable ends bit-identical.
 *   -e EST.so -g EST_GUID -r EST_RESOURCE_URI -w P1:E1,P2:E2,... -o E_OUT1,E_OUT2,...
 *               also load a second FMU (the estimator) and wire it: before every step its
 *               inputs E_i are set to the first FMU's outputs P_i; its outputs E_OUT are
 *               printed after the first FMU's.
 *
 * usage: fmu_host [options] BINARY.so GUID RESOURCE_URI DT NSTEPS VR1,VR2,... [VR=VALUE ...]
 *
 * It needs no set-up and calls nothing but the FMI 2.0 C API: the FMU's own binary finds its
 * Python (docs/fmus.md, "Non-Python hosts"). If fmi2Instantiate returns NULL, the host exits 4
 * after the FMU's logged messages.
 */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "fmi2Functions.h"

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
    void *lib;
    fmi2Component c;
    fmi2GetVersionTYPE *GetVersion;
    fmi2InstantiateTYPE *Instantiate;
    fmi2SetupExperimentTYPE *SetupExperiment;
    fmi2EnterInitializationModeTYPE *EnterInitializationMode;
    fmi2ExitInitializationModeTYPE *ExitInitializationMode;
    fmi2SetRealTYPE *SetReal;
    fmi2GetRealTYPE *GetReal;
    fmi2DoStepTYPE *DoStep;
    fmi2TerminateTYPE *Terminate;
    fmi2FreeInstanceTYPE *FreeInstance;
    fmi2GetFMUstateTYPE *GetFMUstate;
    fmi2SetFMUstateTYPE *SetFMUstate;
    fmi2FreeFMUstateTYPE *FreeFMUstate;
    fmi2SerializedFMUstateSizeTYPE *SerializedFMUstateSize;
    fmi2SerializeFMUstateTYPE *SerializeFMUstate;
    fmi2DeSerializeFMUstateTYPE *DeSerializeFMUstate;
} Fmu;

static void *sym(void *lib, const char *name) {
    void *f = dlsym(lib, name);
    if (!f) {
        fprintf(stderr, "fmu_host: symbol %s not found: %s\n", name, dlerror());
        exit(3);
    }
    return f;
}

#define LOAD(f, name) *(void **)(&(f)->name) = sym((f)->lib, "fmi2" #name)

static fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};

static void load(Fmu *f, const char *so, const char *instance, const char *guid,
                 const char *resources) {
    f->lib = dlopen(so, RTLD_NOW | RTLD_LOCAL);
    if (!f->lib) {
        fprintf(stderr, "fmu_host: dlopen failed: %s\n", dlerror());
        exit(2);
    }
    LOAD(f, GetVersion); LOAD(f, Instantiate); LOAD(f, SetupExperiment);
    LOAD(f, EnterInitializationMode); LOAD(f, ExitInitializationMode);
    LOAD(f, SetReal); LOAD(f, GetReal); LOAD(f, DoStep); LOAD(f, Terminate);
    LOAD(f, FreeInstance); LOAD(f, GetFMUstate); LOAD(f, SetFMUstate); LOAD(f, FreeFMUstate);
    LOAD(f, SerializedFMUstateSize); LOAD(f, SerializeFMUstate); LOAD(f, DeSerializeFMUstate);
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
        out[k++] = strtoul(p, &end, 10);
        if (end == p) break;
        p = (*end == ',' || *end == ':') ? end + 1 : end;
    }
    return k;
}

#define MAXV 1024

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

int main(int argc, char **argv) {
    int opt, state_step = -1, cycles = 0, i, k;
    const char *est_so = NULL, *est_guid = NULL, *est_res = NULL, *wires = NULL, *est_out = NULL;
    const char *exit_mode = "free";
    while ((opt = getopt(argc, argv, "c:x:s:e:g:r:w:o:")) != -1) {
        switch (opt) {
        case 'c': cycles = atoi(optarg); break;
        case 'x': exit_mode = optarg; break;
        case 's': state_step = atoi(optarg); break;
        case 'e': est_so = optarg; break;
        case 'g': est_guid = optarg; break;
        case 'r': est_res = optarg; break;
        case 'w': wires = optarg; break;
        case 'o': est_out = optarg; break;
        default: return 1;
        }
    }
    if (argc - optind < 6 || (est_so && !(est_guid && est_res && wires && est_out))) {
        fprintf(stderr, "usage: %s [-c N] [-x free|dlclose|none] [-s K] [-e EST.so -g GUID -r URI -w P:E,... -o E,...] "
                        "BINARY.so GUID RESOURCE_URI DT NSTEPS VRS [VR=VALUE ...]\n", argv[0]);
        return 1;
    }
    const char *so = argv[optind], *guid = argv[optind + 1], *resources = argv[optind + 2];
    double dt = atof(argv[optind + 3]);
    int nsteps = atoi(argv[optind + 4]);

    static unsigned long tmp[2 * MAXV];
    static fmi2ValueReference out_vr[MAXV], wire_p[MAXV], wire_e[MAXV], eout_vr[MAXV];
    static double row[2 * MAXV], wire_v[MAXV], saved[2 * MAXV];
    size_t nout = parse_list(argv[optind + 5], tmp, MAXV), nwire = 0, neout = 0, n;
    for (n = 0; n < nout; n++) out_vr[n] = (fmi2ValueReference)tmp[n];

    Fmu plant, est;
    memset(&plant, 0, sizeof plant);
    memset(&est, 0, sizeof est);
    load(&plant, so, "c_host_plant", guid, resources);
    for (i = 0; i < cycles; i++) cycle(&plant, guid, resources, dt);
    if (cycles) fprintf(stderr, "fmu_host: %d instantiate/free cycles done\n", cycles);
    if (est_so) {
        size_t m = parse_list(wires, tmp, 2 * MAXV);
        nwire = m / 2;
        for (n = 0; n < nwire; n++) {
            wire_p[n] = (fmi2ValueReference)tmp[2 * n];
            wire_e[n] = (fmi2ValueReference)tmp[2 * n + 1];
        }
        neout = parse_list(est_out, tmp, MAXV);
        for (n = 0; n < neout; n++) eout_vr[n] = (fmi2ValueReference)tmp[n];
        load(&est, est_so, "c_host_estimator", est_guid, est_res);
    }

    CHECK(plant.SetupExperiment(plant.c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
    CHECK(plant.EnterInitializationMode(plant.c));
    for (i = optind + 6; i < argc; i++) {
        char *eq = strchr(argv[i], '=');
        if (!eq) return 1;
        fmi2ValueReference vr = (fmi2ValueReference)strtoul(argv[i], NULL, 10);
        fmi2Real val = atof(eq + 1);
        CHECK(plant.SetReal(plant.c, &vr, 1, &val));
    }
    CHECK(plant.ExitInitializationMode(plant.c));
    if (est_so) {
        CHECK(est.SetupExperiment(est.c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
        CHECK(est.EnterInitializationMode(est.c));
        CHECK(est.ExitInitializationMode(est.c));
    }

    double t = 0.0;
    fmi2FMUstate state = NULL;
    fmi2Byte *bytes = NULL;
    size_t nbytes = 0;
    double t_state = 0.0;

#define PRINT_ROW()                                                                        \
    do {                                                                                   \
        CHECK(plant.GetReal(plant.c, out_vr, nout, row));                                  \
        if (est_so) CHECK(est.GetReal(est.c, eout_vr, neout, row + nout));                 \
        printf("%.17g", t);                                                                \
        for (n = 0; n < nout + neout; n++) printf(",%.17g", row[n]);                       \
        printf("\n");                                                                      \
    } while (0)

#define STEP(tk)                                                                           \
    do {                                                                                   \
        if (est_so) {                                                                      \
            CHECK(plant.GetReal(plant.c, wire_p, nwire, wire_v));                          \
            CHECK(est.SetReal(est.c, wire_e, nwire, wire_v));                              \
        }                                                                                  \
        CHECK(plant.DoStep(plant.c, (tk), dt, fmi2True));                                  \
        if (est_so) CHECK(est.DoStep(est.c, (tk), dt, fmi2True));                          \
    } while (0)

    PRINT_ROW();
    for (k = 1; k <= nsteps; k++) {
        STEP(t);
        t = k * dt; /* communication points k*dt, as fmpy's simulate_fmu computes them */
        PRINT_ROW();
        if (k == state_step) {
            CHECK(plant.GetFMUstate(plant.c, &state));
            CHECK(plant.SerializedFMUstateSize(plant.c, state, &nbytes));
            bytes = (fmi2Byte *)malloc(nbytes);
            CHECK(plant.SerializeFMUstate(plant.c, state, bytes, nbytes));
            CHECK(plant.FreeFMUstate(plant.c, &state));
            t_state = t;
        }
    }

    if (state_step > 0 && state_step < nsteps && !est_so) {
        memcpy(saved, row, nout * sizeof(double));    /* the uninterrupted run's final values */
        state = NULL;
        CHECK(plant.DeSerializeFMUstate(plant.c, bytes, nbytes, &state));
        CHECK(plant.SetFMUstate(plant.c, state));
        CHECK(plant.FreeFMUstate(plant.c, &state));
        t = t_state;
        for (k = state_step + 1; k <= nsteps; k++) {
            CHECK(plant.DoStep(plant.c, t, dt, fmi2True));
            t = k * dt;
        }
        CHECK(plant.GetReal(plant.c, out_vr, nout, row));
        for (n = 0; n < nout; n++) {
            if (memcmp(&row[n], &saved[n], sizeof(double)) != 0) {
                fprintf(stderr, "fmu_host: state restore mismatch at vr %u: %.17g != %.17g\n",
                        out_vr[n], row[n], saved[n]);
                return 5;
            }
        }
        fprintf(stderr, "fmu_host: state round trip after step %d: %zu bytes, identical\n",
                state_step, nbytes);
    }

    free(bytes);
    if (strcmp(exit_mode, "none") == 0) return 0;     /* instances alive, libraries loaded */
    CHECK(plant.Terminate(plant.c));
    plant.FreeInstance(plant.c);
    if (est_so) {
        CHECK(est.Terminate(est.c));
        est.FreeInstance(est.c);
    }
    if (strcmp(exit_mode, "dlclose") == 0) {
        if (est_so && dlclose(est.lib) != 0) return 6;
        if (dlclose(plant.lib) != 0) return 6;
    }
    return 0;
}
