/*
 * satfmu: the FMI 2.0 model-exchange interface of a plant generated from a symbolic definition
 * (fmus/model.py). The importer's solver integrates the continuous states; this file gives it the
 * state, its derivatives and the event indicators (fmus/events.py), and handles the events. The
 * model's C (model.h) and the interface-independent C (satfmu_core.h: variable checks, outputs,
 * logging) are those of the co-simulation FMU; its step functions (fixed RK4 substeps, the exact
 * flow) are not used here. Written for this project.
 *
 * Modes. The right-hand side may read the state at the start of an integration substep (a friction
 * mode frozen over it; satfmu.fmus.model.Model.previous): here that is the state at the last event,
 * held in `mode`. At each event (fmi2NewDiscreteStates) the post-step map is applied to the state
 * with that mode (the MRP set switched to its shadow, a wheel stopped in stiction, a momentum
 * clamped at its bound) and the mode is taken anew from the result. The event indicators change
 * sign where the right-hand side or the post-step map switches, so the solver stops there.
 *
 * Hysteresis. A solver stops where an indicator g is zero to its own precision, often exactly 0,
 * where the relation g > 0 of the post-step map has not changed yet (an MRP set at |sigma| = 1 is
 * not switched). So the indicator the solver sees is g + side * eps, with side the sign of g at
 * the last event and eps = HYSTERESIS (1 + |g| there): it reaches zero only once g has crossed
 * by eps, where the relation has changed (|sigma|^2 - 1 = 1e-12: switched).
 *
 * Variables beyond the co-simulation FMU's (value references NV.. in the description): NV + i is
 * the derivative of state i, NV + NX + i state i itself (listed for the states no output carries).
 *
 * Robustness: every call checks the instance pointer, the call order against the FMI 2.0
 * model-exchange state machine, value references, types, finiteness and declared ranges; a
 * violation returns fmi2Error with a message and changes nothing. A non-finite state, derivative,
 * event indicator or output puts the instance in the error state: never returned with fmi2OK.
 */
#include "fmi2Functions.h"

#define HOST_FIELDS                \
    fmi2CallbackLogger logger;     \
    fmi2ComponentEnvironment env;  \
    double mode[DIM(NX)];          \
    double dx[DIM(NX)];            \
    int dx_valid;                  \
    double side[DIM(NZ)];

#define STEP_STATE_NAME "ContinuousTimeMode"

/* the co-simulation step functions of satfmu_core.h (integration, sampling, FMU state records)
 * are not used by model exchange */
#if defined(__GNUC__)
#pragma GCC diagnostic ignored "-Wunused-function"
#endif
#include "satfmu_core.h"

#define ST_CONTINUOUS ST_STEP_COMPLETE

/* The message is passed as the logger's format string with '%' doubled, so hosts that cannot
 * expand variadic arguments (ctypes-based ones such as fmpy) show it intact. */
static void host_log(const Instance *inst, int status, const char *category, const char *message) {
    char esc[2048];
    size_t i, j = 0;
    if (!inst->logger) return;
    for (i = 0; message[i] && j + 2 < sizeof esc; i++) {
        if (message[i] == '%') esc[j++] = '%';
        esc[j++] = message[i];
    }
    esc[j] = '\0';
    inst->logger(inst->env, inst->instance_name, (fmi2Status)status, category, esc);
}

/* ------------------------------------------------------------------ the model's continuous part */
/* The derivatives at the instance's time, state, inputs and mode; 0 (and the error state) when one
 * is not finite. */
static int derivatives(Instance *inst, const char *fn) {
    Data *d = &inst->d;
    int i;
    if (inst->dx_valid) return 1;
    if (NX > 0) model_derivatives(d->time, d->x, inst->mode, d->u, d->p, inst->dx);
    for (i = 0; i < NX; i++) {
        if (!isfinite(inst->dx[i])) {
            d->state = ST_ERROR;
            log_msg(inst, STATUS_ERROR, "logStatusError", "%s: the derivative of state %d is non-finite (%g) at "
                    "t = %.17g s", fn, i, inst->dx[i], d->time);
            return 0;
        }
    }
    inst->dx_valid = 1;
    return 1;
}

#define HYSTERESIS 1e-12

/* The model's indicators g at the instance's time, state and inputs (the mode read as the state). */
static void indicators(Instance *inst, double *g) {
#if NZ > 0
    model_event_indicators(inst->d.time, inst->d.x, inst->d.x, inst->d.u, inst->d.p, g);
#else
    (void)inst;
    (void)g;
#endif
}

/* At an event: each indicator's side (its sign, 0 exactly on it) and offset, for the hysteresis. */
static void take_sides(Instance *inst) {
    double g[DIM(NZ)];
    int i;
    indicators(inst, g);
    for (i = 0; i < NZ; i++)
        inst->side[i] = (g[i] > 0.0 ? 1.0 : g[i] < 0.0 ? -1.0 : 0.0) * HYSTERESIS * (1.0 + fabs(g[i]));
}

/* The continuous state, inputs or time changed: derivatives and outputs to be recomputed. */
static void changed(Instance *inst) {
    inst->dx_valid = 0;
    inst->d.outputs_valid = 0;
}

/* ------------------------------------------------------------------ variable access */
static const VariableInfo *lookup(Instance *inst, fmi2ValueReference vr, int type, const char *fn) {
    if (vr >= (fmi2ValueReference)NV) {
        log_msg(inst, STATUS_ERROR, "logStatusError", "%s: unknown value reference %u", fn, (unsigned)vr);
        return NULL;
    }
    if (VARIABLES[vr].type != type) {
        log_msg(inst, STATUS_ERROR, "logStatusError", "%s: variable '%s' (value reference %u) has another type",
                fn, VARIABLES[vr].name, (unsigned)vr);
        return NULL;
    }
    return &VARIABLES[vr];
}

#define GET_MASK (ST_INITIALIZATION | ST_EVENT | ST_CONTINUOUS | ST_TERMINATED | ST_ERROR)

static fmi2Status get_values(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, int type,
                             const char *fn, fmi2Real *r, fmi2Integer *n, fmi2Boolean *b) {
    size_t i;
    int ok = 1, extra = 0;
    CHECK(c, fn, GET_MASK);
    if (nvr > 0 && (!vr || (!r && !n && !b))) return ERROR(inst, "%s: NULL array argument", fn);
    for (i = 0; i < nvr; i++) {
#if NX > 0
        if (r && vr[i] >= (fmi2ValueReference)NV && vr[i] < (fmi2ValueReference)(NV + 2 * NX)) {
            extra = 1; /* a derivative or a state */
            continue;
        }
#endif
        if (!lookup(inst, vr[i], type, fn)) return fmi2Error;
    }
    ok = update_outputs(inst, fn); /* in Initialization Mode from the initial state */
    if (inst->d.state == ST_INITIALIZATION) memcpy(inst->mode, inst->d.x, sizeof inst->mode);
    if (ok && extra) ok = derivatives(inst, fn);
    for (i = 0; i < nvr; i++) { /* written even on an error: values for diagnosis */
        double v;
#if NX > 0
        if (r && vr[i] >= (fmi2ValueReference)NV) {
            const size_t k = vr[i] - (fmi2ValueReference)NV;
            v = k < (size_t)NX ? inst->dx[k] : inst->d.x[k - (size_t)NX];
        } else
#endif
        {
            v = *slot(&inst->d, &VARIABLES[vr[i]]);
        }
        if (r) r[i] = v;
        else if (n) n[i] = isfinite(v) ? (fmi2Integer)v : 0;
        else b[i] = v != 0.0 ? fmi2True : fmi2False;
    }
    return ok ? fmi2OK : fmi2Error;
}

static fmi2Status set_values(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, int type,
                             const char *fn, const fmi2Real *r, const fmi2Integer *n, const fmi2Boolean *b) {
    size_t i;
    CHECK(c, fn, ST_INSTANTIATED | ST_INITIALIZATION | ST_EVENT | ST_CONTINUOUS | ST_TERMINATED | ST_ERROR);
    if (nvr > 0 && (!vr || (!r && !n && !b))) return ERROR(inst, "%s: NULL array argument", fn);
    /* validate all first: a rejected call leaves every value unchanged */
    for (i = 0; i < nvr; i++) {
        const VariableInfo *v = lookup(inst, vr[i], type, fn);
        double value = r ? r[i] : (n ? (double)n[i] : (b[i] ? 1.0 : 0.0));
        if (!v || check_value(inst, v, value, fn) != STATUS_OK) return fmi2Error;
    }
    for (i = 0; i < nvr; i++)
        *slot(&inst->d, &VARIABLES[vr[i]]) = r ? r[i] : (n ? (double)n[i] : (b[i] ? 1.0 : 0.0));
    values_set(inst);
    changed(inst);
    return fmi2OK;
}

/* ------------------------------------------------------------------ FMI API: common */
const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    CHECK(c, "fmi2SetDebugLogging", ~0);
    return (fmi2Status)set_logging(inst, loggingOn, nCategories, categories, "fmi2SetDebugLogging");
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    Instance tmp, *inst;
    (void)fmuResourceLocation;
    (void)visible;
    memset(&tmp, 0, sizeof tmp);
    tmp.instance_name = (char *)(instanceName ? instanceName : "?");
    tmp.logger = functions ? functions->logger : NULL;
    tmp.env = functions ? functions->componentEnvironment : NULL;
    if (!instanceName || !*instanceName) {
        log_msg(&tmp, fmi2Error, "logStatusError", "fmi2Instantiate: missing instance name");
        return NULL;
    }
    if (fmuType != fmi2ModelExchange) {
        log_msg(&tmp, fmi2Error, "logStatusError", "fmi2Instantiate: this FMU supports model exchange only (the "
                "co-simulation FMU of this model is a file of its own)");
        return NULL;
    }
    if (!fmuGUID || strcmp(fmuGUID, MODEL_GUID) != 0) {
        log_msg(&tmp, fmi2Error, "logStatusError", "fmi2Instantiate: GUID '%s' does not match '%s'",
                fmuGUID ? fmuGUID : "(null)", MODEL_GUID);
        return NULL;
    }
    inst = new_instance(instanceName, 0);
    if (!inst) return NULL;
    inst->logger = tmp.logger;
    inst->env = tmp.env;
    inst->log_on = loggingOn ? 1 : 0;
    return inst;
}

void fmi2FreeInstance(fmi2Component c) { free_instance((Instance *)c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    CHECK(c, "fmi2SetupExperiment", ST_INSTANTIATED);
    (void)toleranceDefined;
    (void)tolerance;
    return (fmi2Status)setup_experiment(inst, startTime, stopTimeDefined, stopTime, "fmi2SetupExperiment");
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    CHECK(c, "fmi2EnterInitializationMode", ST_INSTANTIATED);
    inst->d.state = ST_INITIALIZATION;
    changed(inst);
    return fmi2OK;
}

/* The initial state from the parameters; the mode is the initial state. Event Mode follows. */
fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    CHECK(c, "fmi2ExitInitializationMode", ST_INITIALIZATION);
    if (exit_initialization(inst, "fmi2ExitInitializationMode") != STATUS_OK) return fmi2Error;
    memcpy(inst->mode, inst->d.x, sizeof inst->mode);
    changed(inst);
    take_sides(inst);
    inst->d.state = ST_EVENT;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    CHECK(c, "fmi2Terminate", ST_EVENT | ST_CONTINUOUS);
    inst->d.state = ST_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    CHECK(c, "fmi2Reset", ~0);
    set_defaults(&inst->d);
    changed(inst);
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    return get_values(c, vr, nvr, TYPE_REAL, "fmi2GetReal", value, NULL, NULL);
}
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    return get_values(c, vr, nvr, TYPE_INTEGER, "fmi2GetInteger", NULL, value, NULL);
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    return get_values(c, vr, nvr, TYPE_BOOLEAN, "fmi2GetBoolean", NULL, NULL, value);
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    CHECK(c, "fmi2GetString", GET_MASK);
    (void)vr;
    (void)value;
    if (nvr > 0) return ERROR(inst, "fmi2GetString: this FMU has no String variables");
    return fmi2OK;
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    return set_values(c, vr, nvr, TYPE_REAL, "fmi2SetReal", value, NULL, NULL);
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    return set_values(c, vr, nvr, TYPE_INTEGER, "fmi2SetInteger", NULL, value, NULL);
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    return set_values(c, vr, nvr, TYPE_BOOLEAN, "fmi2SetBoolean", NULL, NULL, value);
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    CHECK(c, "fmi2SetString", ST_INSTANTIATED | ST_INITIALIZATION | ST_EVENT | ST_CONTINUOUS);
    (void)vr;
    (void)value;
    if (nvr > 0) return ERROR(inst, "fmi2SetString: this FMU has no String variables");
    return fmi2OK;
}

/* ------------------------------------------------------------------ not provided */
#define NOT_PROVIDED(fn, why)                                   \
    CHECK(c, #fn, ~0);                                          \
    return ERROR(inst, #fn ": not provided (" why ")")

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    (void)FMUstate;
    NOT_PROVIDED(fmi2GetFMUstate, "canGetAndSetFMUstate=false");
}
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    (void)FMUstate;
    NOT_PROVIDED(fmi2SetFMUstate, "canGetAndSetFMUstate=false");
}
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    (void)FMUstate;
    NOT_PROVIDED(fmi2FreeFMUstate, "canGetAndSetFMUstate=false");
}
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    (void)FMUstate; (void)size;
    NOT_PROVIDED(fmi2SerializedFMUstateSize, "canSerializeFMUstate=false");
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size) {
    (void)FMUstate; (void)serializedState; (void)size;
    NOT_PROVIDED(fmi2SerializeFMUstate, "canSerializeFMUstate=false");
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    (void)serializedState; (void)size; (void)FMUstate;
    NOT_PROVIDED(fmi2DeSerializeFMUstate, "canSerializeFMUstate=false");
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown; (void)dvUnknown;
    NOT_PROVIDED(fmi2GetDirectionalDerivative, "providesDirectionalDerivative=false");
}

/* ------------------------------------------------------------------ FMI API: model exchange */
fmi2Status fmi2EnterEventMode(fmi2Component c) {
    CHECK(c, "fmi2EnterEventMode", ST_EVENT | ST_CONTINUOUS);
    inst->d.state = ST_EVENT;
    return fmi2OK;
}

/* The event: the post-step map with the mode of the last event, then the mode anew. One pass: the
 * map's result is a state the map keeps (no further iteration is asked for). */
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo) {
    Data *d;
    double x[DIM(NX)];
    int i, moved = 0;
    CHECK(c, "fmi2NewDiscreteStates", ST_EVENT);
    if (!eventInfo) return ERROR(inst, "fmi2NewDiscreteStates: NULL eventInfo");
    d = &inst->d;
    if (NX > 0) model_post_step(d->time, d->x, inst->mode, d->u, d->p, x);
    for (i = 0; i < NX; i++) {
        if (!isfinite(x[i])) {
            d->state = ST_ERROR;
            return ERROR(inst, "fmi2NewDiscreteStates: state %d became non-finite (%g) at t = %.17g s", i, x[i],
                         d->time);
        }
        moved |= x[i] != d->x[i];
    }
    if (NX > 0) {
        memcpy(d->x, x, sizeof x);
        memcpy(inst->mode, x, sizeof x);
    }
    changed(inst);
    take_sides(inst);
    eventInfo->newDiscreteStatesNeeded = fmi2False;
    eventInfo->terminateSimulation = fmi2False;
    eventInfo->nominalsOfContinuousStatesChanged = fmi2False;
    eventInfo->valuesOfContinuousStatesChanged = moved ? fmi2True : fmi2False;
    eventInfo->nextEventTimeDefined = fmi2False;
    eventInfo->nextEventTime = 0.0;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    CHECK(c, "fmi2EnterContinuousTimeMode", ST_EVENT);
    inst->d.state = ST_CONTINUOUS;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation) {
    CHECK(c, "fmi2CompletedIntegratorStep", ST_CONTINUOUS);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!enterEventMode || !terminateSimulation) return ERROR(inst, "fmi2CompletedIntegratorStep: NULL argument");
    *enterEventMode = fmi2False;
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    CHECK(c, "fmi2SetTime", ST_EVENT | ST_CONTINUOUS);
    if (!isfinite(time)) return ERROR(inst, "fmi2SetTime: non-finite time %g", time);
    inst->d.time = time;
    changed(inst);
    return fmi2OK;
}

static int count_ok(Instance *inst, size_t n, size_t expected, const void *array, const char *fn) {
    if (n != expected) {
        log_msg(inst, STATUS_ERROR, "logStatusError", "%s: %zu values for %zu", fn, n, expected);
        return 0;
    }
    if (n > 0 && !array) {
        log_msg(inst, STATUS_ERROR, "logStatusError", "%s: NULL array", fn);
        return 0;
    }
    return 1;
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    size_t i;
    CHECK(c, "fmi2SetContinuousStates", ST_CONTINUOUS);
    if (!count_ok(inst, nx, (size_t)NX, x, "fmi2SetContinuousStates")) return fmi2Error;
    for (i = 0; i < nx; i++)
        if (!isfinite(x[i])) return ERROR(inst, "fmi2SetContinuousStates: state %zu is non-finite (%g)", i, x[i]);
    for (i = 0; i < nx; i++) inst->d.x[i] = x[i];
    changed(inst);
    return fmi2OK;
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives_out[], size_t nx) {
    size_t i;
    CHECK(c, "fmi2GetDerivatives", ST_EVENT | ST_CONTINUOUS | ST_TERMINATED | ST_ERROR);
    if (!count_ok(inst, nx, (size_t)NX, derivatives_out, "fmi2GetDerivatives")) return fmi2Error;
    if (!derivatives(inst, "fmi2GetDerivatives")) return fmi2Error;
    for (i = 0; i < nx; i++) derivatives_out[i] = inst->dx[i];
    return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    size_t i;
    Data *d;
    CHECK(c, "fmi2GetEventIndicators", ST_EVENT | ST_CONTINUOUS | ST_TERMINATED | ST_ERROR);
    if (!count_ok(inst, ni, (size_t)NZ, eventIndicators, "fmi2GetEventIndicators")) return fmi2Error;
    d = &inst->d;
    indicators(inst, eventIndicators);
    for (i = 0; i < ni; i++) {
        eventIndicators[i] += inst->side[i];
        if (!isfinite(eventIndicators[i])) {
            d->state = ST_ERROR;
            return ERROR(inst, "fmi2GetEventIndicators: indicator %zu is non-finite (%g) at t = %.17g s", i,
                         eventIndicators[i], d->time);
        }
    }
    return fmi2OK;
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    size_t i;
    CHECK(c, "fmi2GetContinuousStates", ST_INITIALIZATION | ST_EVENT | ST_CONTINUOUS | ST_TERMINATED | ST_ERROR);
    if (!count_ok(inst, nx, (size_t)NX, x, "fmi2GetContinuousStates")) return fmi2Error;
    if (inst->d.state == ST_INITIALIZATION) initial_state(&inst->d);
    for (i = 0; i < nx; i++) x[i] = inst->d.x[i];
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx) {
    size_t i;
    CHECK(c, "fmi2GetNominalsOfContinuousStates", ST_INSTANTIATED | ST_EVENT | ST_CONTINUOUS | ST_TERMINATED |
          ST_ERROR);
    if (!count_ok(inst, nx, (size_t)NX, x_nominal, "fmi2GetNominalsOfContinuousStates")) return fmi2Error;
    for (i = 0; i < nx; i++) x_nominal[i] = 1.0;
    return fmi2OK;
}
