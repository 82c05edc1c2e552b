/*
 * front_library.c -- the FMI 2.0 binary (binaries/linux64/<model identifier>.so) of the
 * spacerobot FMUs: a thin front over pythonfmu 0.7.0's export library, which the FMU ships beside
 * it as binaries/linux64/pythonfmu_export.so. Compiled by spacerobot/fmi/front_library.py at
 * FMU build time with the system C compiler against the headers of the building Python; it does
 * not link libpython (it loads it), so any host can dlopen it.
 *
 * Why (pythonfmu 0.7.0, Linux; docs/fmus.md "The front library"):
 *   - pythonfmu's library is built for Python's stable ABI and does not link libpython; a host
 *     that is not Python cannot even load it unless libpython is already loaded RTLD_GLOBAL
 *     (numpy's extension modules need Python's symbols in the global scope too);
 *   - it starts the interpreter with a plain Py_Initialize(): paths guessed from the host's
 *     executable, PYTHONHOME/PYTHONPATH needed, Python's SIGINT handler installed in the host;
 *   - it keeps its interpreter guard in a static std::shared_ptr and also resets it from a library
 *     destructor (finalizePythonInterpreter): at exit() the control block is freed twice and
 *     glibc aborts ("free(): corrupted unsorted chunks", exit status 134);
 *   - it maps every Python exception to fmi2Fatal; it cannot return fmi2Error.
 *
 * What this front does:
 *   1. fmi2Instantiate reads <resources>/python_runtime.txt, the record of the Python installation
 *      the FMU was built with (home, shared library, module search path). If the host process
 *      already runs an initialised Python (fmpy, any Python host), that one is used. Otherwise
 *      the recorded libpython is loaded RTLD_GLOBAL and the interpreter initialised from an
 *      isolated PyConfig with the recorded home and search path (environment variables ignored,
 *      no signal handlers installed), and the GIL released. Anything missing: NULL, and the
 *      host's logger says what is missing.
 *   2. pythonfmu_export.so is loaded and every fmi2 call is forwarded to it (the front's
 *      component holds pythonfmu's and a copy of the host's callbacks). The Python side calls
 *      spacerobot_flag_error() before raising an exception that means "this call is refused,
 *      state unchanged": the front then returns fmi2Error where pythonfmu says fmi2Fatal, and
 *      logs pythonfmu's report of that exception as an error too.
 *   3. The front pins itself in memory and registers an exit handler after pythonfmu's static
 *      guard exists; exit handlers run in reverse order, so at exit() it releases pythonfmu's
 *      guard once (finalizePythonInterpreter) before the C++ runtime destroys it, then finalises
 *      the interpreter it started. Nothing is unloaded earlier, so a host may free instances,
 *      dlclose the library, both or neither.
 *
 * Record format (one "key=value" per line, '#' starts a comment; path may repeat):
 *   version=3.11          home=<sys.base_prefix>      library=<libpython3.x.so>      path=<dir>
 */
#define _GNU_SOURCE
#include <Python.h>

#include <dlfcn.h>
#include <errno.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "fmi2Functions.h"

#define RECORD_NAME "python_runtime.txt"
#define PYTHONFMU_NAME "pythonfmu_export.so"
#define MAX_PATHS 64
#define MSG 2048

/* ---- the Python C API, resolved from the loaded libpython (this library does not link it) -- */
static struct {
    __typeof__(&Py_IsInitialized) IsInitialized;
    __typeof__(&Py_GetVersion) GetVersion;
    __typeof__(&PyConfig_InitIsolatedConfig) ConfigInitIsolated;
    __typeof__(&PyConfig_SetBytesString) ConfigSetBytesString;
    __typeof__(&PyConfig_Clear) ConfigClear;
    __typeof__(&PyWideStringList_Append) WideStringListAppend;
    __typeof__(&Py_DecodeLocale) DecodeLocale;
    __typeof__(&PyMem_RawFree) RawFree;
    __typeof__(&Py_InitializeFromConfig) InitializeFromConfig;
    __typeof__(&PyStatus_Exception) StatusException;
    __typeof__(&PyEval_SaveThread) SaveThread;
    __typeof__(&PyEval_RestoreThread) RestoreThread;
    __typeof__(&Py_FinalizeEx) FinalizeEx;
} py;

/* ---- pythonfmu's export library ----------------------------------------------------------- */
static struct {
    fmi2InstantiateTYPE *Instantiate;
    fmi2FreeInstanceTYPE *FreeInstance;
    fmi2SetDebugLoggingTYPE *SetDebugLogging;
    fmi2SetupExperimentTYPE *SetupExperiment;
    fmi2EnterInitializationModeTYPE *EnterInitializationMode;
    fmi2ExitInitializationModeTYPE *ExitInitializationMode;
    fmi2TerminateTYPE *Terminate;
    fmi2ResetTYPE *Reset;
    fmi2GetRealTYPE *GetReal;
    fmi2GetIntegerTYPE *GetInteger;
    fmi2GetBooleanTYPE *GetBoolean;
    fmi2GetStringTYPE *GetString;
    fmi2SetRealTYPE *SetReal;
    fmi2SetIntegerTYPE *SetInteger;
    fmi2SetBooleanTYPE *SetBoolean;
    fmi2SetStringTYPE *SetString;
    fmi2GetFMUstateTYPE *GetFMUstate;
    fmi2SetFMUstateTYPE *SetFMUstate;
    fmi2FreeFMUstateTYPE *FreeFMUstate;
    fmi2SerializedFMUstateSizeTYPE *SerializedFMUstateSize;
    fmi2SerializeFMUstateTYPE *SerializeFMUstate;
    fmi2DeSerializeFMUstateTYPE *DeSerializeFMUstate;
    fmi2GetDirectionalDerivativeTYPE *GetDirectionalDerivative;
    fmi2SetRealInputDerivativesTYPE *SetRealInputDerivatives;
    fmi2GetRealOutputDerivativesTYPE *GetRealOutputDerivatives;
    fmi2DoStepTYPE *DoStep;
    fmi2CancelStepTYPE *CancelStep;
    fmi2GetStatusTYPE *GetStatus;
    fmi2GetRealStatusTYPE *GetRealStatus;
    fmi2GetIntegerStatusTYPE *GetIntegerStatus;
    fmi2GetBooleanStatusTYPE *GetBooleanStatus;
    fmi2GetStringStatusTYPE *GetStringStatus;
    void (*finalize)(void); /* finalizePythonInterpreter: releases pythonfmu's static guard */
} pf;

static pthread_mutex_t load_lock = PTHREAD_MUTEX_INITIALIZER;
static int loaded;                     /* pythonfmu's library loaded and Python running */
static int started_python;             /* this front initialised the interpreter */
static PyThreadState *main_thread;     /* its thread state while the GIL is released */
static pthread_t init_thread;
static __thread int error_flagged;     /* set by the Python side: the failing call is an fmi2Error */

/* Called (through ctypes) by the FMU's Python code right before it raises an exception for a
   call it refuses with the state unchanged (spacerobot/fmi/pythonfmu_compat.py). */
__attribute__((visibility("default"))) void spacerobot_flag_error(void) { error_flagged = 1; }

/* ---- helpers ---------------------------------------------------------------------------- */
/* The FMI logger's message is a printf format. Hosts that format it (fmpy, fmuCheck) and hosts
   that print it as it is both get readable text when it has no arguments and every '%' is
   doubled, which is what pythonfmu and the FMU's Python code do: the front does the same. */
static void escape_percent(const char *text, char *out, size_t n) {
    size_t k = 0;
    for (; *text && k + 2 < n; text++) {
        if (*text == '%') out[k++] = '%';
        out[k++] = *text;
    }
    out[k] = 0;
}

static void say(const fmi2CallbackFunctions *cb, fmi2String instance, fmi2Status status,
                const char *text) {
    static const char *category[] = {"logStatusOK", "logStatusWarning", "logStatusDiscard",
                                     "logStatusError", "logStatusFatal", "logStatusPending"};
    char escaped[2 * MSG];
    escape_percent(text, escaped, sizeof escaped);
    if (cb && cb->logger)
        cb->logger(cb->componentEnvironment, instance ? instance : "", status,
                   category[(int)status], escaped);
    else
        fprintf(stderr, "%s: %s\n", instance ? instance : "FMU", text);
}

static int is_dir(const char *p) {
    struct stat st;
    return stat(p, &st) == 0 && S_ISDIR(st.st_mode);
}

/* file:///a/b, file:/a/b or file://localhost/a/b, %XX decoded -> /a/b */
static int uri_to_path(const char *uri, char *out, size_t n) {
    const char *p = uri;
    size_t k = 0;
    if (!uri) return 0;
    if (strncmp(p, "file://localhost/", 17) == 0) p += 16;
    else if (strncmp(p, "file:///", 8) == 0) p += 7;
    else if (strncmp(p, "file:/", 6) == 0) p += 5;
    else if (strncmp(p, "file:", 5) == 0) return 0;
    for (; *p && k + 1 < n; p++) {
        if (p[0] == '%' && p[1] && p[2]) {
            char hex[3] = {p[1], p[2], 0};
            out[k++] = (char)strtol(hex, NULL, 16);
            p += 2;
        } else {
            out[k++] = *p;
        }
    }
    out[k] = 0;
    while (k > 1 && out[k - 1] == '/') out[--k] = 0;
    return k > 0;
}

typedef struct {
    char file[PATH_MAX + 32];
    char version[32], home[PATH_MAX], library[PATH_MAX];
    char *paths[MAX_PATHS];
    int npaths;
} Record;

static void free_record(Record *r) {
    for (int i = 0; i < r->npaths; i++) free(r->paths[i]);
    r->npaths = 0;
}

static int read_record(const char *resources, Record *r, char *err, size_t n) {
    char line[PATH_MAX + 32];
    FILE *f;
    memset(r, 0, sizeof *r);
    snprintf(r->file, sizeof r->file, "%s/" RECORD_NAME, resources);
    f = fopen(r->file, "r");
    if (!f) {
        snprintf(err, n, "the record of the Python installation this FMU runs in, %s, cannot be "
                 "read (%s); rebuild the FMU with spacerobot build", r->file, strerror(errno));
        return 0;
    }
    while (fgets(line, sizeof line, f)) {
        char *eq = strchr(line, '='), *end = line + strcspn(line, "\r\n");
        *end = 0;
        if (line[0] == '#' || !eq) continue;
        *eq = 0;
        if (!strcmp(line, "version")) snprintf(r->version, sizeof r->version, "%s", eq + 1);
        else if (!strcmp(line, "home")) snprintf(r->home, sizeof r->home, "%s", eq + 1);
        else if (!strcmp(line, "library")) snprintf(r->library, sizeof r->library, "%s", eq + 1);
        else if (!strcmp(line, "path") && r->npaths < MAX_PATHS) r->paths[r->npaths++] = strdup(eq + 1);
    }
    fclose(f);
    if (!r->version[0] || !r->home[0] || !r->library[0] || r->npaths == 0) {
        snprintf(err, n, "%s is incomplete: it needs version=, home=, library= and path= lines; "
                 "rebuild the FMU with spacerobot build", r->file);
        free_record(r);
        return 0;
    }
    return 1;
}

#define RESOLVE(lib, field, name)                                                          \
    do {                                                                                   \
        *(void **)(&(field)) = dlsym((lib), (name));                                        \
        if (!(field)) {                                                                     \
            snprintf(err, n, "%s has no symbol %s", what, (name));                          \
            return 0;                                                               \
        }                                                                                  \
    } while (0)

/* Load the recorded libpython RTLD_GLOBAL and start the interpreter from the record. */
static int start_python(const Record *r, char *err, size_t n) {
    const char *what = r->library;
    void *lib;
    PyConfig config;
    PyStatus status;
    if (!is_dir(r->home)) {
        snprintf(err, n, "the Python installation recorded in %s is missing: home %s does not "
                 "exist (the FMU runs in the Python %s it was built with, at the same path)",
                 r->file, r->home, r->version);
        return 0;
    }
    for (int i = 0; i < r->npaths; i++) {
        if (!is_dir(r->paths[i])) {
            snprintf(err, n, "the Python module search path recorded in %s is incomplete: %s "
                     "does not exist (numpy must stay installed "
                     "where it was when the FMU was built)", r->file, r->paths[i]);
            return 0;
        }
    }
    lib = dlopen(r->library, RTLD_NOW | RTLD_GLOBAL);
    if (!lib) {
        snprintf(err, n, "the Python library recorded in %s cannot be loaded: %s", r->file,
                 dlerror());
        return 0;
    }
    RESOLVE(lib, py.IsInitialized, "Py_IsInitialized");
    RESOLVE(lib, py.GetVersion, "Py_GetVersion");
    RESOLVE(lib, py.ConfigInitIsolated, "PyConfig_InitIsolatedConfig");
    RESOLVE(lib, py.ConfigSetBytesString, "PyConfig_SetBytesString");
    RESOLVE(lib, py.ConfigClear, "PyConfig_Clear");
    RESOLVE(lib, py.WideStringListAppend, "PyWideStringList_Append");
    RESOLVE(lib, py.DecodeLocale, "Py_DecodeLocale");
    RESOLVE(lib, py.RawFree, "PyMem_RawFree");
    RESOLVE(lib, py.InitializeFromConfig, "Py_InitializeFromConfig");
    RESOLVE(lib, py.StatusException, "PyStatus_Exception");
    RESOLVE(lib, py.SaveThread, "PyEval_SaveThread");
    RESOLVE(lib, py.RestoreThread, "PyEval_RestoreThread");
    RESOLVE(lib, py.FinalizeEx, "Py_FinalizeEx");
    if (strncmp(py.GetVersion(), r->version, strlen(r->version)) != 0 ||
        py.GetVersion()[strlen(r->version)] != '.') {
        snprintf(err, n, "%s is Python %.20s, but %s records Python %s", r->library,
                 py.GetVersion(), r->file, r->version);
        return 0;
    }
    if (py.IsInitialized()) return 1;        /* another front library started it */

    py.ConfigInitIsolated(&config);          /* ignores PYTHONHOME, PYTHONPATH, user site */
    config.install_signal_handlers = 0;      /* SIGINT stays the host's */
    config.site_import = 0;                  /* the recorded path already holds what .pth adds */
    config.parse_argv = 0;
    status = py.ConfigSetBytesString(&config, &config.home, r->home);
    config.module_search_paths_set = 1;
    for (int i = 0; i < r->npaths && !py.StatusException(status); i++) {
        wchar_t *w = py.DecodeLocale(r->paths[i], NULL);
        if (!w) break;
        status = py.WideStringListAppend(&config.module_search_paths, w);
        py.RawFree(w);
    }
    if (!py.StatusException(status)) status = py.InitializeFromConfig(&config);
    py.ConfigClear(&config);
    if (py.StatusException(status)) {
        snprintf(err, n, "the Python interpreter recorded in %s did not start: %s%s%s", r->file,
                 status.func ? status.func : "", status.func ? ": " : "",
                 status.err_msg ? status.err_msg : "unknown error");
        return 0;
    }
    started_python = 1;
    init_thread = pthread_self();
    main_thread = py.SaveThread();           /* release the GIL; pythonfmu takes it per call */
    return 1;
}

/* Runs at exit(), before the C++ runtime destroys pythonfmu's static guard (registered after
   pythonfmu's library was loaded, and exit handlers run in reverse order). */
static void at_exit(void) {
    if (pf.finalize) pf.finalize();          /* pythonfmu's guard released once, while alive */
    if (started_python && pthread_equal(init_thread, pthread_self())) {
        py.RestoreThread(main_thread);
        py.FinalizeEx();
        started_python = 0;
    }
}

static int load_pythonfmu(char *err, size_t n) {
    Dl_info self;
    char path[PATH_MAX + 32], *slash;
    const char *what = path;
    void *lib;
    if (!dladdr((void *)&spacerobot_flag_error, &self) || !self.dli_fname) {
        snprintf(err, n, "the FMU binary cannot locate itself (dladdr failed)");
        return 0;
    }
    snprintf(path, sizeof path, "%s", self.dli_fname);
    slash = strrchr(path, '/');
    snprintf(slash ? slash + 1 : path, sizeof path - (slash ? (size_t)(slash + 1 - path) : 0),
             "%s", PYTHONFMU_NAME);
    lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        snprintf(err, n, "pythonfmu's library cannot be loaded: %s", dlerror());
        return 0;
    }
    RESOLVE(lib, pf.Instantiate, "fmi2Instantiate");
    RESOLVE(lib, pf.FreeInstance, "fmi2FreeInstance");
    RESOLVE(lib, pf.SetDebugLogging, "fmi2SetDebugLogging");
    RESOLVE(lib, pf.SetupExperiment, "fmi2SetupExperiment");
    RESOLVE(lib, pf.EnterInitializationMode, "fmi2EnterInitializationMode");
    RESOLVE(lib, pf.ExitInitializationMode, "fmi2ExitInitializationMode");
    RESOLVE(lib, pf.Terminate, "fmi2Terminate");
    RESOLVE(lib, pf.Reset, "fmi2Reset");
    RESOLVE(lib, pf.GetReal, "fmi2GetReal");
    RESOLVE(lib, pf.GetInteger, "fmi2GetInteger");
    RESOLVE(lib, pf.GetBoolean, "fmi2GetBoolean");
    RESOLVE(lib, pf.GetString, "fmi2GetString");
    RESOLVE(lib, pf.SetReal, "fmi2SetReal");
    RESOLVE(lib, pf.SetInteger, "fmi2SetInteger");
    RESOLVE(lib, pf.SetBoolean, "fmi2SetBoolean");
    RESOLVE(lib, pf.SetString, "fmi2SetString");
    RESOLVE(lib, pf.GetFMUstate, "fmi2GetFMUstate");
    RESOLVE(lib, pf.SetFMUstate, "fmi2SetFMUstate");
    RESOLVE(lib, pf.FreeFMUstate, "fmi2FreeFMUstate");
    RESOLVE(lib, pf.SerializedFMUstateSize, "fmi2SerializedFMUstateSize");
    RESOLVE(lib, pf.SerializeFMUstate, "fmi2SerializeFMUstate");
    RESOLVE(lib, pf.DeSerializeFMUstate, "fmi2DeSerializeFMUstate");
    RESOLVE(lib, pf.GetDirectionalDerivative, "fmi2GetDirectionalDerivative");
    RESOLVE(lib, pf.SetRealInputDerivatives, "fmi2SetRealInputDerivatives");
    RESOLVE(lib, pf.GetRealOutputDerivatives, "fmi2GetRealOutputDerivatives");
    RESOLVE(lib, pf.DoStep, "fmi2DoStep");
    RESOLVE(lib, pf.CancelStep, "fmi2CancelStep");
    RESOLVE(lib, pf.GetStatus, "fmi2GetStatus");
    RESOLVE(lib, pf.GetRealStatus, "fmi2GetRealStatus");
    RESOLVE(lib, pf.GetIntegerStatus, "fmi2GetIntegerStatus");
    RESOLVE(lib, pf.GetBooleanStatus, "fmi2GetBooleanStatus");
    RESOLVE(lib, pf.GetStringStatus, "fmi2GetStringStatus");
    *(void **)(&pf.finalize) = dlsym(lib, "finalizePythonInterpreter");
    /* never unloaded: pythonfmu's library and Python's extension modules stay mapped */
    dlopen(self.dli_fname, RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);
    atexit(at_exit);
    return 1;
}

/* Python running (the host's or the recorded one) and pythonfmu's library loaded; once. */
static int ensure_loaded(const char *resource_uri, char *err, size_t n, char *warn, size_t nw) {
    char resources[PATH_MAX];
    Record r;
    int (*host_initialized)(void);
    int ok;
    if (loaded) return 1;
    if (!uri_to_path(resource_uri, resources, sizeof resources)) {
        snprintf(err, n, "fmuResourceLocation %s is not a file: URI", resource_uri ? resource_uri
                 : "(null)");
        return 0;
    }
    if (!read_record(resources, &r, err, n)) return 0;
    *(void **)(&host_initialized) = dlsym(RTLD_DEFAULT, "Py_IsInitialized");
    if (host_initialized && host_initialized()) {
        /* a Python host (fmpy, ...): its interpreter and sys.path are used */
        const char *(*version)(void);
        *(void **)(&version) = dlsym(RTLD_DEFAULT, "Py_GetVersion");
        if (version && (strncmp(version(), r.version, strlen(r.version)) != 0 ||
                        version()[strlen(r.version)] != '.'))
            snprintf(warn, nw, "the host runs Python %.20s but the FMU was built with Python %s "
                     "(%s); its Python code runs in the host's interpreter", version(), r.version,
                     r.file);
        ok = 1;
    } else {
        ok = start_python(&r, err, n);
    }
    free_record(&r);
    if (ok) ok = load_pythonfmu(err, n);
    loaded = ok;
    return ok;
}

/* ---- the FMI 2.0 functions -------------------------------------------------------------- */
const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

/* One instance: pythonfmu's component and the host's callbacks, which pythonfmu reaches through
   log_relay (so that a refusal it reports as Fatal is logged as the Error it is returned as). */
typedef struct {
    fmi2Component inner;
    fmi2CallbackFunctions host;     /* the host's callbacks, copied */
    fmi2CallbackFunctions relay;    /* given to pythonfmu: logger = log_relay, env = this */
} Instance;

static void log_relay(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                      fmi2String category, fmi2String message, ...) {
    const Instance *inst = (const Instance *)env;
    char text[MSG], escaped[2 * MSG];
    va_list args;
    if (!inst->host.logger) return;
    va_start(args, message);
    vsnprintf(text, sizeof text, message ? message : "", args);
    va_end(args);
    if (status == fmi2Fatal && error_flagged) {
        /* pythonfmu's report of the exception that carries a refusal: the reason was logged
           just before by the FMU's Python code */
        const char *where = strchr(text, '['), *end = where ? strchr(where, ']') : NULL;
        char call[128] = "the call";
        if (where && end && end - where < 100)
            snprintf(call, sizeof call, "%.*s", (int)(end - where + 1), where);
        snprintf(text, sizeof text, "%s refused with fmi2Error (reason logged above); the "
                 "instance's state is unchanged", call);
        status = fmi2Error;
        category = "logStatusError";
    }
    escape_percent(text, escaped, sizeof escaped);
    inst->host.logger(inst->host.componentEnvironment, name, status, category, escaped);
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
    char err[MSG] = "", warn[MSG] = "";
    Instance *inst;
    int ok;
    pthread_mutex_lock(&load_lock);
    ok = ensure_loaded(fmuResourceLocation, err, sizeof err, warn, sizeof warn);
    pthread_mutex_unlock(&load_lock);
    if (!ok) {
        say(functions, instanceName, fmi2Error, err);
        return NULL;
    }
    if (warn[0]) say(functions, instanceName, fmi2Warning, warn);
    if (!functions || !(inst = (Instance *)calloc(1, sizeof *inst))) {
        say(functions, instanceName, fmi2Error, functions ? "out of memory"
                                                          : "fmi2Instantiate: functions is NULL");
        return NULL;
    }
    inst->host = *functions;
    inst->relay = *functions;
    inst->relay.logger = log_relay;
    inst->relay.componentEnvironment = inst;
    error_flagged = 0;
    inst->inner = pf.Instantiate(instanceName, fmuType, fmuGUID, fmuResourceLocation,
                                 &inst->relay, visible, loggingOn);
    if (!inst->inner) {
        free(inst);
        return NULL;
    }
    return inst;
}

void fmi2FreeInstance(fmi2Component c) {
    if (!loaded || !c) return;
    pf.FreeInstance(((Instance *)c)->inner);
    free(c);
}

/* forward a call; a refusal flagged by the Python side is fmi2Error, not pythonfmu's Fatal */
#define FORWARD(name, params, args)                                                        \
    fmi2Status fmi2##name params {                                                         \
        fmi2Status status_;                                                                \
        if (!loaded) return fmi2Error;                                                     \
        if (!c) return fmi2Error;                                                          \
        error_flagged = 0;                                                                 \
        c = ((Instance *)c)->inner;                                                        \
        status_ = pf.name args;                                                            \
        return (status_ == fmi2Fatal && error_flagged) ? fmi2Error : status_;              \
    }

FORWARD(SetDebugLogging, (fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]),
        (c, on, n, cat))
FORWARD(SetupExperiment, (fmi2Component c, fmi2Boolean tolDefined, fmi2Real tol,
                          fmi2Real start, fmi2Boolean stopDefined, fmi2Real stop),
        (c, tolDefined, tol, start, stopDefined, stop))
FORWARD(EnterInitializationMode, (fmi2Component c), (c))
FORWARD(ExitInitializationMode, (fmi2Component c), (c))
FORWARD(Terminate, (fmi2Component c), (c))
FORWARD(Reset, (fmi2Component c), (c))
FORWARD(GetReal, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]),
        (c, vr, n, v))
FORWARD(GetInteger, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]),
        (c, vr, n, v))
FORWARD(GetBoolean, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]),
        (c, vr, n, v))
FORWARD(GetString, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]),
        (c, vr, n, v))
FORWARD(SetReal, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]),
        (c, vr, n, v))
FORWARD(SetInteger, (fmi2Component c, const fmi2ValueReference vr[], size_t n,
                     const fmi2Integer v[]), (c, vr, n, v))
FORWARD(SetBoolean, (fmi2Component c, const fmi2ValueReference vr[], size_t n,
                     const fmi2Boolean v[]), (c, vr, n, v))
FORWARD(SetString, (fmi2Component c, const fmi2ValueReference vr[], size_t n,
                    const fmi2String v[]), (c, vr, n, v))
FORWARD(GetFMUstate, (fmi2Component c, fmi2FMUstate *s), (c, s))
FORWARD(SetFMUstate, (fmi2Component c, fmi2FMUstate s), (c, s))
FORWARD(FreeFMUstate, (fmi2Component c, fmi2FMUstate *s), (c, s))
FORWARD(SerializedFMUstateSize, (fmi2Component c, fmi2FMUstate s, size_t *size), (c, s, size))
FORWARD(SerializeFMUstate, (fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t size),
        (c, s, b, size))
FORWARD(DeSerializeFMUstate, (fmi2Component c, const fmi2Byte b[], size_t size,
                              fmi2FMUstate *s), (c, b, size, s))
FORWARD(GetDirectionalDerivative, (fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                   const fmi2ValueReference z[], size_t nz,
                                   const fmi2Real dv[], fmi2Real dz[]),
        (c, u, nu, z, nz, dv, dz))
FORWARD(SetRealInputDerivatives, (fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                  const fmi2Integer order[], const fmi2Real v[]),
        (c, vr, n, order, v))
FORWARD(GetRealOutputDerivatives, (fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                   const fmi2Integer order[], fmi2Real v[]),
        (c, vr, n, order, v))
FORWARD(DoStep, (fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior), (c, t, h,
                                                                                     noSetPrior))
FORWARD(CancelStep, (fmi2Component c), (c))
FORWARD(GetStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Status *v), (c, k, v))
FORWARD(GetRealStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Real *v), (c, k, v))
FORWARD(GetIntegerStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Integer *v), (c, k, v))
FORWARD(GetBooleanStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Boolean *v), (c, k, v))
FORWARD(GetStringStatus, (fmi2Component c, const fmi2StatusKind k, fmi2String *v), (c, k, v))
