/*
 * satfmu's own FMI 3.0 co-simulation test host (tests/test_fmi3_host.py), the FMI 3.0 counterpart of
 * fmu_host.c. Written for this project.
 *
 * It loads one FMU's unpacked binary (dlopen), instantiates it for co-simulation, sets the
 * parameters and inputs a plan file gives, steps it with fmi3DoStep and prints every output at
 * every communication point. With a clock in the plan it uses event mode and drives the clock:
 * it reads the clock's interval and shift in Initialization Mode, ends a step at each activation
 * time t_j = start + shift + j interval that falls inside a communication step (splitting that step
 * there), and at each t_j enters Event Mode, sets the step's inputs, activates the clock with
 * fmi3SetClock and calls fmi3UpdateDiscreteStates and fmi3EnterStepMode; at the start it leaves the
 * initial Event Mode the same way, without activating the clock (the start's sample belongs to
 * initialization).
 *
 * Usage: fmu_host3 BINARY PLAN
 *
 * PLAN is plain text: whitespace-separated tokens in this order (every number in C99 hexadecimal
 * floating form, as Python's float.hex writes it, so that it is read exactly):
 *
 *   token TOKEN                     the instantiationToken
 *   resources PATH                  the resourcePath (a native path ending in a separator)
 *   step H                          communication step size, s
 *   clock VR                        the sample clock's value reference, or -1 (no clock: no event mode)
 *   parameters M                    then M groups: real|integer|boolean VR COUNT VALUE..COUNT
 *   inputs N                        then N pairs VR COUNT of Float64 inputs (arrays by their size)
 *   outputs Q                       then Q pairs VR COUNT of Float64 outputs
 *   steps K                         then K rows of the input values of step k (the counts' sum each)
 *
 * Output: K + 1 lines, each the time and every output value, printed with %.17g. Any call returning
 * other than fmi3OK, an early return, or a malformed plan ends the host with exit code 1 and a message
 * on stderr (with the FMU's log).
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <dlfcn.h>

#include "fmi3FunctionTypes.h"

#define HOST_NAME "fmu_host3"
#include "host_plan.h"

typedef struct {
    fmi3InstantiateCoSimulationTYPE *instantiate;
    fmi3FreeInstanceTYPE *free_instance;
    fmi3EnterInitializationModeTYPE *enter_initialization;
    fmi3ExitInitializationModeTYPE *exit_initialization;
    fmi3EnterEventModeTYPE *enter_event_mode;
    fmi3UpdateDiscreteStatesTYPE *update_discrete_states;
    fmi3EnterStepModeTYPE *enter_step_mode;
    fmi3TerminateTYPE *terminate;
    fmi3SetFloat64TYPE *set_float64;
    fmi3SetInt32TYPE *set_int32;
    fmi3SetBooleanTYPE *set_boolean;
    fmi3GetFloat64TYPE *get_float64;
    fmi3SetClockTYPE *set_clock;
    fmi3GetIntervalDecimalTYPE *get_interval;
    fmi3GetShiftDecimalTYPE *get_shift;
    fmi3DoStepTYPE *do_step;
} Api;

typedef struct {
    size_t n;               /* variables */
    fmi3ValueReference *vr; /* their value references */
    size_t values;          /* their values, every element */
} Variables;

static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    (void)env;
    fprintf(stderr, "[%d %s] %s\n", (int)status, category ? category : "", message ? message : "");
}

static void *symbol(void *lib, const char *name) {
    void *f = dlsym(lib, name);
    if (f == NULL) fail("the binary does not export %s", name);
    return f;
}

static void check(fmi3Status status, const char *call) {
    if (status != fmi3OK) fail("%s returned status %d", call, (int)status);
}

static void set_parameters(FILE *plan, const Api *api, fmi3Instance c) {
    size_t i, j, m;
    char kind[TOKEN_SIZE];
    keyword(plan, "parameters");
    m = count_of(plan, "parameters");
    for (i = 0; i < m; i++) {
        fmi3ValueReference vr;
        size_t n;
        double *value;
        token(plan, kind, "parameter type");
        vr = reference(plan);
        n = count_of(plan, "parameter values");
        value = allocate(n, sizeof *value);
        for (j = 0; j < n; j++) value[j] = number(plan, "parameter value");
        if (strcmp(kind, "real") == 0) {
            check(api->set_float64(c, &vr, 1, value, n), "fmi3SetFloat64 (parameter)");
        } else if (strcmp(kind, "integer") == 0) {
            fmi3Int32 *v = allocate(n, sizeof *v);
            for (j = 0; j < n; j++) v[j] = (fmi3Int32)value[j];
            check(api->set_int32(c, &vr, 1, v, n), "fmi3SetInt32 (parameter)");
            free(v);
        } else if (strcmp(kind, "boolean") == 0) {
            fmi3Boolean *v = allocate(n, sizeof *v);
            for (j = 0; j < n; j++) v[j] = value[j] != 0.0;
            check(api->set_boolean(c, &vr, 1, v, n), "fmi3SetBoolean (parameter)");
            free(v);
        } else {
            fail("plan: parameter type '%s' (real, integer or boolean)", kind);
        }
        free(value);
    }
}

static Variables variables(FILE *plan, const char *name) {
    Variables v;
    size_t i;
    keyword(plan, name);
    v.n = count_of(plan, name);
    v.vr = allocate(v.n, sizeof *v.vr);
    v.values = 0;
    for (i = 0; i < v.n; i++) {
        v.vr[i] = reference(plan);
        v.values += count_of(plan, "values");
    }
    return v;
}

/* Event Mode at the FMU time: the inputs u, the clock activated (activate), the discrete update. */
static void event(const Api *api, fmi3Instance c, const Variables *in, const double *u, fmi3ValueReference clock,
                  int activate, int enter) {
    fmi3Boolean need, terminate, nominals, values, defined;
    fmi3Float64 next;
    fmi3Clock on = fmi3ClockActive;
    if (enter) check(api->enter_event_mode(c), "fmi3EnterEventMode");
    if (in->n > 0) check(api->set_float64(c, in->vr, in->n, u, in->values), "fmi3SetFloat64 (inputs, Event Mode)");
    if (activate) check(api->set_clock(c, &clock, 1, &on), "fmi3SetClock");
    check(api->update_discrete_states(c, &need, &terminate, &nominals, &values, &defined, &next),
          "fmi3UpdateDiscreteStates");
    if (need || terminate) fail("fmi3UpdateDiscreteStates asks for another update or to terminate");
    check(api->enter_step_mode(c), "fmi3EnterStepMode");
}

/* fmi3DoStep from t for h seconds; it must complete. */
static void step(const Api *api, fmi3Instance c, double t, double h) {
    fmi3Boolean event_needed, terminate, early;
    fmi3Float64 reached;
    check(api->do_step(c, t, h, fmi3True, &event_needed, &terminate, &early, &reached), "fmi3DoStep");
    if (early || terminate || event_needed) fail("fmi3DoStep from t = %.17g s returned early at %.17g s", t, reached);
}

int main(int argc, char **argv) {
    char itoken[TOKEN_SIZE], resources[TOKEN_SIZE];
    double h, clock_vr, *u, *y, interval = 0.0, shift = 0.0, next = INFINITY;
    size_t k, i, steps, activation = 0; /* activations done; the next at shift + activation interval */
    fmi3ValueReference clock = 0;
    Variables in, out;
    fmi3Instance c;
    void *lib;
    FILE *plan;
    Api api;
    int clocked;

    if (argc != 3) fail("usage: fmu_host3 BINARY PLAN");
    lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (lib == NULL) fail("cannot load %s: %s", argv[1], dlerror());
    api.instantiate = (fmi3InstantiateCoSimulationTYPE *)symbol(lib, "fmi3InstantiateCoSimulation");
    api.free_instance = (fmi3FreeInstanceTYPE *)symbol(lib, "fmi3FreeInstance");
    api.enter_initialization = (fmi3EnterInitializationModeTYPE *)symbol(lib, "fmi3EnterInitializationMode");
    api.exit_initialization = (fmi3ExitInitializationModeTYPE *)symbol(lib, "fmi3ExitInitializationMode");
    api.enter_event_mode = (fmi3EnterEventModeTYPE *)symbol(lib, "fmi3EnterEventMode");
    api.update_discrete_states = (fmi3UpdateDiscreteStatesTYPE *)symbol(lib, "fmi3UpdateDiscreteStates");
    api.enter_step_mode = (fmi3EnterStepModeTYPE *)symbol(lib, "fmi3EnterStepMode");
    api.terminate = (fmi3TerminateTYPE *)symbol(lib, "fmi3Terminate");
    api.set_float64 = (fmi3SetFloat64TYPE *)symbol(lib, "fmi3SetFloat64");
    api.set_int32 = (fmi3SetInt32TYPE *)symbol(lib, "fmi3SetInt32");
    api.set_boolean = (fmi3SetBooleanTYPE *)symbol(lib, "fmi3SetBoolean");
    api.get_float64 = (fmi3GetFloat64TYPE *)symbol(lib, "fmi3GetFloat64");
    api.set_clock = (fmi3SetClockTYPE *)symbol(lib, "fmi3SetClock");
    api.get_interval = (fmi3GetIntervalDecimalTYPE *)symbol(lib, "fmi3GetIntervalDecimal");
    api.get_shift = (fmi3GetShiftDecimalTYPE *)symbol(lib, "fmi3GetShiftDecimal");
    api.do_step = (fmi3DoStepTYPE *)symbol(lib, "fmi3DoStep");

    plan = fopen(argv[2], "r");
    if (plan == NULL) fail("cannot open the plan %s", argv[2]);
    keyword(plan, "token");
    token(plan, itoken, "token");
    keyword(plan, "resources");
    token(plan, resources, "resources");
    keyword(plan, "step");
    h = number(plan, "step");
    keyword(plan, "clock");
    clock_vr = number(plan, "clock");
    clocked = clock_vr >= 0.0;
    if (clocked) clock = (fmi3ValueReference)clock_vr;
    c = api.instantiate("host3", itoken, resources, fmi3False, fmi3False, clocked ? fmi3True : fmi3False, fmi3False,
                        NULL, 0, NULL, logger, NULL);
    if (c == NULL) fail("fmi3InstantiateCoSimulation failed");
    set_parameters(plan, &api, c);
    in = variables(plan, "inputs");
    out = variables(plan, "outputs");
    keyword(plan, "steps");
    steps = count_of(plan, "steps");
    u = allocate(in.values, sizeof *u);
    y = allocate(out.values, sizeof *y);

    check(api.enter_initialization(c, fmi3False, 0.0, 0.0, fmi3False, 0.0), "fmi3EnterInitializationMode");
    if (clocked) {
        fmi3IntervalQualifier qualifier;
        check(api.get_interval(c, &clock, 1, &interval, &qualifier), "fmi3GetIntervalDecimal");
        check(api.get_shift(c, &clock, 1, &shift), "fmi3GetShiftDecimal");
        if (!(interval > 0.0) || qualifier != fmi3IntervalChanged) fail("the clock's interval is not a new one > 0");
        next = shift; /* the start is 0 */
    }
    check(api.exit_initialization(c), "fmi3ExitInitializationMode");
    for (k = 0; k < steps; k++) {
        const double t = (double)k * h, t_end = (double)(k + 1) * h;
        double now = t;
        for (i = 0; i < in.values; i++) u[i] = number(plan, "input value");
        if (clocked && k == 0) {
            event(&api, c, &in, u, clock, 0, 0); /* the initial Event Mode */
        } else if (clocked && fabs(next - t) <= 1e-9 * fmax(1.0, fabs(t))) {
            event(&api, c, &in, u, clock, 1, 1); /* an activation at this communication point */
            next = shift + (double)(++activation) * interval;
        } else if (in.n > 0) {
            check(api.set_float64(c, in.vr, in.n, u, in.values), "fmi3SetFloat64 (inputs)");
        }
        check(api.get_float64(c, out.vr, out.n, y, out.values), "fmi3GetFloat64");
        print_row(t, y, out.values);
        /* activations strictly inside the step: end a step at each and handle it */
        while (clocked && next < t_end - 1e-9 * fmax(1.0, fabs(t_end))) {
            step(&api, c, now, next - now);
            now = next;
            event(&api, c, &in, u, clock, 1, 1);
            next = shift + (double)(++activation) * interval;
        }
        step(&api, c, now, now == t ? h : t_end - now); /* h itself when not split, as a master steps */
    }
    check(api.get_float64(c, out.vr, out.n, y, out.values), "fmi3GetFloat64");
    print_row((double)steps * h, y, out.values);
    check(api.terminate(c), "fmi3Terminate");
    api.free_instance(c);
    fclose(plan);
    free(in.vr);
    free(out.vr);
    free(u);
    free(y);
    return 0;
}
