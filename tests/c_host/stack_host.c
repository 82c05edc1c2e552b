/*
 * stack_host.c -- an FMI 2.0 co-simulation host that runs an FMU binary in a thread with a small
 * stack (Linux: dlopen, pthread_attr_setstacksize), used by tests/test_stack_*.py. Hosts that
 * step FMUs on worker threads give them such stacks (musl's default is 128 KiB); a frame deeper
 * than the stack ends the process with a signal.
 *
 * In the thread: instantiate, set Real variables (VR=VALUE, before initialisation), set up at
 * t = 0, initialise, NSTEPS steps of H seconds (each from the end of the last), read the Real
 * variables READ_VRS, free. Prints "heap <bytes>", the heap an instance takes (glibc's
 * mallinfo2 around fmi2Instantiate; -1 elsewhere), then the values read, one per line as
 * %.17g, and exits 0; exits 1 if a call did not return fmi2OK (the FMU's messages go to
 * stderr), 2 on a usage or loading error.
 *
 * usage: stack_host BINARY GUID RESOURCE_URI STACK_BYTES NSTEPS H READ_VRS [VR=VALUE ...]
 *        (READ_VRS: comma-separated value references)
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <malloc.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2_host.h"

#define MAXV 4096

typedef fmi2Component (*instantiate_fn)(fmi2String, fmi2Type, fmi2String, fmi2String,
                                        const fmi2CallbackFunctions *, fmi2Boolean, fmi2Boolean);
typedef fmi2Status (*setup_fn)(fmi2Component, fmi2Boolean, fmi2Real, fmi2Real, fmi2Boolean,
                               fmi2Real);
typedef fmi2Status (*phase_fn)(fmi2Component);
typedef fmi2Status (*real_fn)(fmi2Component, const fmi2ValueReference[], size_t, fmi2Real[]);
typedef fmi2Status (*set_real_fn)(fmi2Component, const fmi2ValueReference[], size_t,
                                  const fmi2Real[]);
typedef fmi2Status (*step_fn)(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean);
typedef void (*free_fn)(fmi2Component);

static struct {
    void *lib;
    const char *guid, *uri;
    int nsteps;
    double h;
    fmi2ValueReference read[MAXV], set[MAXV];
    double set_value[MAXV], out[MAXV];
    size_t nread, nset;
    long long heap;
    int failed;
} run;

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    va_list ap;
    (void)env;
    fprintf(stderr, "[%s] %d %s: ", name ? name : "?", (int)status, category ? category : "");
    va_start(ap, message);
    vfprintf(stderr, message, ap);
    va_end(ap);
    fputc('\n', stderr);
}

static void *sym(const char *name) {
    void *p = dlsym(run.lib, name);
    if (!p) {
        fprintf(stderr, "stack_host: %s is not exported\n", name);
        exit(2);
    }
    return p;
}

#define CHECK(call, what)                                                                    \
    do {                                                                                     \
        if ((call) != fmi2OK) {                                                              \
            fprintf(stderr, "stack_host: %s did not return fmi2OK\n", what);                 \
            run.failed = 1;                                                                  \
            return NULL;                                                                     \
        }                                                                                    \
    } while (0)

/* bytes allocated on the heap now (-1: unknown) */
static long long heap_in_use(void) {
#if defined(__GLIBC__) && (__GLIBC__ > 2 || __GLIBC_MINOR__ >= 33)
    struct mallinfo2 m = mallinfo2();
    return (long long)(m.uordblks + m.hblkhd);
#else
    return -1;
#endif
}

/* the whole life of one instance, on the thread's stack */
static void *simulate(void *arg) {
    static fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Component c;
    double t = 0.0;
    int k;
    long long before;
    (void)arg;
    before = heap_in_use();
    c = ((instantiate_fn)sym("fmi2Instantiate"))("stack", fmi2CoSimulation, run.guid, run.uri, &cb,
                                                  fmi2False, fmi2False);
    run.heap = before < 0 ? -1 : heap_in_use() - before;
    if (!c) {
        fprintf(stderr, "stack_host: fmi2Instantiate returned NULL\n");
        run.failed = 1;
        return NULL;
    }
    if (run.nset)
        CHECK(((set_real_fn)sym("fmi2SetReal"))(c, run.set, run.nset, run.set_value),
              "fmi2SetReal");
    CHECK(((setup_fn)sym("fmi2SetupExperiment"))(c, fmi2False, 0.0, 0.0, fmi2False, 0.0),
          "fmi2SetupExperiment");
    CHECK(((phase_fn)sym("fmi2EnterInitializationMode"))(c), "fmi2EnterInitializationMode");
    CHECK(((phase_fn)sym("fmi2ExitInitializationMode"))(c), "fmi2ExitInitializationMode");
    for (k = 0; k < run.nsteps; ++k) {
        CHECK(((step_fn)sym("fmi2DoStep"))(c, t, run.h, fmi2True), "fmi2DoStep");
        t += run.h;
    }
    CHECK(((real_fn)sym("fmi2GetReal"))(c, run.read, run.nread, run.out), "fmi2GetReal");
    CHECK(((phase_fn)sym("fmi2Terminate"))(c), "fmi2Terminate");
    ((free_fn)sym("fmi2FreeInstance"))(c);
    return NULL;
}

static size_t parse_vrs(const char *s, fmi2ValueReference *out) {
    size_t n = 0;
    while (*s && n < MAXV) {
        char *end;
        out[n++] = (fmi2ValueReference)strtoul(s, &end, 10);
        s = *end == ',' ? end + 1 : end;
        if (end == s && *s) break;
    }
    return n;
}

int main(int argc, char **argv) {
    pthread_attr_t attr;
    pthread_t thread;
    size_t i, stack;
    int a;
    if (argc < 8) {
        fprintf(stderr, "usage: stack_host BINARY GUID RESOURCE_URI STACK_BYTES NSTEPS H "
                        "READ_VRS [VR=VALUE ...]\n");
        return 2;
    }
    run.lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!run.lib) {
        fprintf(stderr, "stack_host: %s\n", dlerror());
        return 2;
    }
    run.guid = argv[2];
    run.uri = argv[3];
    stack = (size_t)strtoul(argv[4], NULL, 10);
    run.nsteps = atoi(argv[5]);
    run.h = strtod(argv[6], NULL);
    run.nread = parse_vrs(argv[7], run.read);
    for (a = 8; a < argc && run.nset < MAXV; ++a) {
        const char *eq = strchr(argv[a], '=');
        if (!eq) {
            fprintf(stderr, "stack_host: %s is not VR=VALUE\n", argv[a]);
            return 2;
        }
        run.set[run.nset] = (fmi2ValueReference)strtoul(argv[a], NULL, 10);
        run.set_value[run.nset++] = strtod(eq + 1, NULL);
    }
    if (pthread_attr_init(&attr) != 0 || pthread_attr_setstacksize(&attr, stack) != 0) {
        fprintf(stderr, "stack_host: a stack of %lu bytes cannot be set\n", (unsigned long)stack);
        return 2;
    }
    if (pthread_create(&thread, &attr, simulate, NULL) != 0 || pthread_join(thread, NULL) != 0) {
        fprintf(stderr, "stack_host: the thread could not run\n");
        return 2;
    }
    if (run.failed) return 1;
    printf("heap %lld\n", run.heap);
    for (i = 0; i < run.nread; ++i) printf("%.17g\n", run.out[i]);
    return 0;
}
