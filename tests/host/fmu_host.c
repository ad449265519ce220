/*
 * satfmu's own FMI 2.0 co-simulation test host (tests/test_win64.py). Written for this project.
 *
 * It loads one FMU's unpacked binary, instantiates it for co-simulation, sets the parameters and
 * inputs a plan file gives, steps it with fmi2DoStep and prints every output at every
 * communication point. One source for both platforms: compiled natively it loads the linux64
 * library with dlopen; compiled with MinGW-w64 (_WIN32) it loads the win64 DLL with LoadLibrary
 * and runs under wine. The same plan on both must print the same numbers.
 *
 * Usage: fmu_host BINARY PLAN [--x87-53]
 *
 * --x87-53 (the win64 host only) sets the x87 control word to 0x27F, 53-bit precision, the Windows
 * x64 default an MSVC-built tool runs with; without it the host keeps what MinGW-w64's start-up
 * code sets, 0x37F (64-bit precision). The DLL's libm (MinGW-w64's) computes some functions with
 * x87 instructions, whose results can depend on that precision.
 *
 * PLAN is plain text: whitespace-separated tokens in this order (every number in C99
 * hexadecimal floating form, as Python's float.hex writes it, so that it is read exactly):
 *
 *   guid GUID
 *   resources URI                   the fmuResourceLocation (a file: URI)
 *   step H                          communication step size, s
 *   parameters M                    then M triples: real|integer|boolean VR VALUE
 *   inputs N                        then N value references of Real inputs
 *   outputs Q                       then Q value references of Real outputs
 *   steps K                         then K rows of N values: the inputs of step k
 *
 * The run: fmi2Instantiate, the parameters, fmi2SetupExperiment(0), initialization; then for
 * k = 0 .. K-1 the inputs of row k are set, the outputs are read and printed at t_k = k H, and
 * fmi2DoStep(t_k, H) is called; the outputs at t_K end the run. Output: K + 1 lines, each the time
 * and the Q outputs, every number printed with %.17g. Any call returning other than fmi2OK, or a
 * malformed plan, ends the host with exit code 1 and a message on stderr (with the FMU's log).
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2FunctionTypes.h"

#define HOST_NAME "fmu_host"
#include "host_plan.h"

#ifdef _WIN32
#include <windows.h>
typedef HMODULE Library;
static Library open_library(const char *path) { return LoadLibraryA(path); }
static void *find_symbol(Library lib, const char *name) { return (void *)GetProcAddress(lib, name); }
#else
#include <dlfcn.h>
typedef void *Library;
static Library open_library(const char *path) { return dlopen(path, RTLD_NOW | RTLD_LOCAL); }
static void *find_symbol(Library lib, const char *name) { return dlsym(lib, name); }
#endif

typedef struct {
    fmi2InstantiateTYPE *instantiate;
    fmi2FreeInstanceTYPE *free_instance;
    fmi2SetupExperimentTYPE *setup_experiment;
    fmi2EnterInitializationModeTYPE *enter_initialization;
    fmi2ExitInitializationModeTYPE *exit_initialization;
    fmi2TerminateTYPE *terminate;
    fmi2SetRealTYPE *set_real;
    fmi2SetIntegerTYPE *set_integer;
    fmi2SetBooleanTYPE *set_boolean;
    fmi2GetRealTYPE *get_real;
    fmi2DoStepTYPE *do_step;
} Api;

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    va_list args;
    (void)env;
    fprintf(stderr, "[%s %d %s] ", instance ? instance : "", (int)status, category ? category : "");
    va_start(args, message);
    vfprintf(stderr, message, args);
    va_end(args);
    fputc('\n', stderr);
}

static void *symbol(Library lib, const char *name) {
    void *f = find_symbol(lib, name);
    if (f == NULL) fail("the binary does not export %s", name);
    return f;
}

static void check(fmi2Status status, const char *call) {
    if (status != fmi2OK) fail("%s returned status %d", call, (int)status);
}

static size_t count(FILE *plan, const char *name) {
    keyword(plan, name);
    return count_of(plan, name);
}

static void set_parameters(FILE *plan, const Api *api, fmi2Component c) {
    size_t i, m = count(plan, "parameters");
    char kind[TOKEN_SIZE];
    for (i = 0; i < m; i++) {
        fmi2ValueReference vr;
        double value;
        token(plan, kind, "parameter type");
        vr = reference(plan);
        value = number(plan, "parameter value");
        if (strcmp(kind, "real") == 0) {
            check(api->set_real(c, &vr, 1, &value), "fmi2SetReal (parameter)");
        } else if (strcmp(kind, "integer") == 0) {
            fmi2Integer v = (fmi2Integer)value;
            check(api->set_integer(c, &vr, 1, &v), "fmi2SetInteger (parameter)");
        } else if (strcmp(kind, "boolean") == 0) {
            fmi2Boolean v = value != 0.0 ? fmi2True : fmi2False;
            check(api->set_boolean(c, &vr, 1, &v), "fmi2SetBoolean (parameter)");
        } else {
            fail("plan: parameter type '%s' (real, integer or boolean)", kind);
        }
    }
}

int main(int argc, char **argv) {
    char guid[TOKEN_SIZE], uri[TOKEN_SIZE];
    fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
    fmi2ValueReference *in_vr, *out_vr;
    double h, *u, *y;
    size_t i, k, n, q, steps;
    fmi2Component c;
    Library lib;
    FILE *plan;
    Api api;

    if (!(argc == 3 || (argc == 4 && strcmp(argv[3], "--x87-53") == 0)))
        fail("usage: fmu_host BINARY PLAN [--x87-53]");
    lib = open_library(argv[1]);
    if (lib == NULL) fail("cannot load %s", argv[1]);
    if (argc == 4) { /* after the DLL's start-up code, which could reset the control word */
#if defined(_WIN32) && defined(__x86_64__)
        const unsigned short windows_default = 0x27F;
        __asm__ volatile("fldcw %0" : : "m"(windows_default));
#else
        fail("--x87-53 is an option of the win64 host only");
#endif
    }
    api.instantiate = (fmi2InstantiateTYPE *)symbol(lib, "fmi2Instantiate");
    api.free_instance = (fmi2FreeInstanceTYPE *)symbol(lib, "fmi2FreeInstance");
    api.setup_experiment = (fmi2SetupExperimentTYPE *)symbol(lib, "fmi2SetupExperiment");
    api.enter_initialization = (fmi2EnterInitializationModeTYPE *)symbol(lib, "fmi2EnterInitializationMode");
    api.exit_initialization = (fmi2ExitInitializationModeTYPE *)symbol(lib, "fmi2ExitInitializationMode");
    api.terminate = (fmi2TerminateTYPE *)symbol(lib, "fmi2Terminate");
    api.set_real = (fmi2SetRealTYPE *)symbol(lib, "fmi2SetReal");
    api.set_integer = (fmi2SetIntegerTYPE *)symbol(lib, "fmi2SetInteger");
    api.set_boolean = (fmi2SetBooleanTYPE *)symbol(lib, "fmi2SetBoolean");
    api.get_real = (fmi2GetRealTYPE *)symbol(lib, "fmi2GetReal");
    api.do_step = (fmi2DoStepTYPE *)symbol(lib, "fmi2DoStep");

    plan = fopen(argv[2], "r");
    if (plan == NULL) fail("cannot open the plan %s", argv[2]);
    keyword(plan, "guid");
    token(plan, guid, "guid");
    keyword(plan, "resources");
    token(plan, uri, "resources");
    keyword(plan, "step");
    h = number(plan, "step");
    c = api.instantiate("host", fmi2CoSimulation, guid, uri, &callbacks, fmi2False, fmi2False);
    if (c == NULL) fail("fmi2Instantiate failed");
    set_parameters(plan, &api, c);
    n = count(plan, "inputs");
    in_vr = allocate(n, sizeof *in_vr);
    for (i = 0; i < n; i++) in_vr[i] = reference(plan);
    q = count(plan, "outputs");
    out_vr = allocate(q, sizeof *out_vr);
    for (i = 0; i < q; i++) out_vr[i] = reference(plan);
    steps = count(plan, "steps");
    u = allocate(n, sizeof *u);
    y = allocate(q, sizeof *y);

    check(api.setup_experiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0), "fmi2SetupExperiment");
    check(api.enter_initialization(c), "fmi2EnterInitializationMode");
    check(api.exit_initialization(c), "fmi2ExitInitializationMode");
    for (k = 0; k < steps; k++) {
        double t = (double)k * h;
        for (i = 0; i < n; i++) u[i] = number(plan, "input value");
        if (n > 0) check(api.set_real(c, in_vr, n, u), "fmi2SetReal (inputs)");
        check(api.get_real(c, out_vr, q, y), "fmi2GetReal");
        print_row(t, y, q);
        check(api.do_step(c, t, h, fmi2True), "fmi2DoStep");
    }
    check(api.get_real(c, out_vr, q, y), "fmi2GetReal");
    print_row((double)steps * h, y, q);
    check(api.terminate(c), "fmi2Terminate");
    api.free_instance(c);
    fclose(plan);
    free(in_vr);
    free(out_vr);
    free(u);
    free(y);
    return 0;
}
