/*
 * satfmu: the FMI 2.0 co-simulation interface of a model generated from a symbolic definition
 * (fmus/model.py). Everything that does not depend on the interface (time, sampling, integration,
 * variable checks, FMU state records; described in satfmu_core.h) is in satfmu_core.h, which
 * includes the generated model.h; this file is the FMU's only translation unit, so a tool may
 * compile every .c file under sources/ or the one <SourceFiles> lists. fmi3.c is the FMI 3.0
 * interface of the same model. Written for this project.
 *
 * Robustness: every call checks the instance pointer, the call order against the
 * FMI 2.0 co-simulation state machine, value references, types, finiteness and
 * declared ranges; a violation returns fmi2Error with a message naming the
 * variable and never changes the stored values. A step whose state becomes
 * non-finite, a sample with a non-finite value and a non-finite output put the instance in
 * the error state (fmi2SetFMUstate or fmi2Reset recover it): no output is ever non-finite
 * with fmi2OK.
 */
#include "fmi2Functions.h"

#define HOST_FIELDS          \
    fmi2CallbackLogger logger; \
    fmi2ComponentEnvironment env;

#include "satfmu_core.h"

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

static fmi2Status get_values(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, int type,
                             const char *fn, fmi2Real *r, fmi2Integer *n, fmi2Boolean *b) {
    size_t i;
    int ok;
    CHECK(c, fn, ST_INITIALIZATION | ST_STEP_COMPLETE | ST_TERMINATED | ST_ERROR);
    if (nvr > 0 && (!vr || (!r && !n && !b))) return ERROR(inst, "%s: NULL array argument", fn);
    for (i = 0; i < nvr; i++)
        if (!lookup(inst, vr[i], type, fn)) return fmi2Error;
    ok = update_outputs(inst, fn);
    for (i = 0; i < nvr; i++) { /* written even on an error: values for diagnosis */
        double v = *slot(&inst->d, &VARIABLES[vr[i]]);
        if (r) r[i] = v;
        else if (n) n[i] = isfinite(v) ? (fmi2Integer)v : 0;
        else b[i] = v != 0.0 ? fmi2True : fmi2False;
    }
    return ok ? fmi2OK : fmi2Error;
}

static fmi2Status set_values(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, int type,
                             const char *fn, const fmi2Real *r, const fmi2Integer *n, const fmi2Boolean *b) {
    size_t i;
    CHECK(c, fn, ST_INSTANTIATED | ST_INITIALIZATION | ST_STEP_COMPLETE | ST_TERMINATED | ST_ERROR);
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
    return fmi2OK;
}

/* ------------------------------------------------------------------ FMI API */
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
    if (fmuType != fmi2CoSimulation) {
        log_msg(&tmp, fmi2Error, "logStatusError", "fmi2Instantiate: this FMU supports co-simulation only");
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
    inst->d.outputs_valid = 0;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    CHECK(c, "fmi2ExitInitializationMode", ST_INITIALIZATION);
    if (exit_initialization(inst, "fmi2ExitInitializationMode") != STATUS_OK) return fmi2Error;
    inst->d.state = ST_STEP_COMPLETE;
    return fmi2OK;
}

/* FMI 2.0: fmi2Terminate only from stepComplete (or stepFailed, which this FMU never enters):
 * an instance in the error state is reset or freed, not terminated. */
fmi2Status fmi2Terminate(fmi2Component c) {
    CHECK(c, "fmi2Terminate", ST_STEP_COMPLETE);
    inst->d.state = ST_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    CHECK(c, "fmi2Reset", ~0);
    set_defaults(&inst->d);
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
    CHECK(c, "fmi2GetString", ST_INITIALIZATION | ST_STEP_COMPLETE | ST_TERMINATED | ST_ERROR);
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
    CHECK(c, "fmi2SetString", ST_INSTANTIATED | ST_INITIALIZATION | ST_STEP_COMPLETE);
    (void)vr;
    (void)value;
    if (nvr > 0) return ERROR(inst, "fmi2SetString: this FMU has no String variables");
    return fmi2OK;
}

/* ------------------------------------------------------------------ FMU state */
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    CHECK(c, "fmi2GetFMUstate", STATE_MASK);
    return (fmi2Status)state_get(inst, FMUstate, "fmi2GetFMUstate");
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    CHECK(c, "fmi2SetFMUstate", STATE_MASK);
    return (fmi2Status)state_set(inst, FMUstate, "fmi2SetFMUstate");
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    CHECK(c, "fmi2FreeFMUstate", STATE_MASK);
    state_free(FMUstate);
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    CHECK(c, "fmi2SerializedFMUstateSize", STATE_MASK);
    return (fmi2Status)state_size(inst, FMUstate, size, "fmi2SerializedFMUstateSize");
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size) {
    CHECK(c, "fmi2SerializeFMUstate", STATE_MASK);
    return (fmi2Status)state_serialize(inst, FMUstate, (unsigned char *)serializedState, size,
                                       "fmi2SerializeFMUstate");
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    CHECK(c, "fmi2DeSerializeFMUstate", STATE_MASK);
    return (fmi2Status)state_deserialize(inst, (const unsigned char *)serializedState, size, FMUstate,
                                         "fmi2DeSerializeFMUstate");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    CHECK(c, "fmi2GetDirectionalDerivative", STATE_MASK);
    (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown; (void)dvUnknown;
    return ERROR(inst, "fmi2GetDirectionalDerivative: not provided (providesDirectionalDerivative=false)");
}

/* ------------------------------------------------------------------ co-simulation */
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    CHECK(c, "fmi2SetRealInputDerivatives", STATE_MASK);
    (void)vr; (void)nvr; (void)order; (void)value;
    return ERROR(inst, "fmi2SetRealInputDerivatives: inputs are held constant (canInterpolateInputs=false)");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    CHECK(c, "fmi2GetRealOutputDerivatives", STATE_MASK);
    (void)vr; (void)nvr; (void)order; (void)value;
    return ERROR(inst, "fmi2GetRealOutputDerivatives: not provided (maxOutputDerivativeOrder=0)");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    int early;
    CHECK(c, "fmi2DoStep", ST_STEP_COMPLETE);
    (void)noSetFMUStatePriorToCurrentPoint;
    return (fmi2Status)do_step(inst, currentCommunicationPoint, communicationStepSize, 0, &early, "fmi2DoStep");
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    CHECK(c, "fmi2CancelStep", STATE_MASK);
    return ERROR(inst, "fmi2CancelStep: fmi2DoStep is synchronous, there is nothing to cancel");
}

/* ------------------------------------------------------------------ status queries */
/* FMI 2.0 (section 4.2.3 and the co-simulation state table): the status functions may be called
 * in stepComplete, stepInProgress, stepFailed and terminated; elsewhere (Instantiated,
 * InitializationMode, Error) they return fmi2Error. This FMU provides
 *   fmi2GetRealStatus(fmi2LastSuccessfulTime): fmi2OK, the FMU time (the end of the last step),
 *   fmi2GetBooleanStatus(fmi2Terminated): fmi2OK, fmi2False (this FMU never asks to terminate),
 * and no other status: fmi2DoStepStatus and fmi2PendingStatus exist only after fmi2DoStep returned
 * fmi2Pending, which this synchronous FMU never does, so every other (function, kind) pair returns
 * fmi2Discard ("a status ... which cannot be retrieved by the slave") with a message; a kind that
 * is no fmi2StatusKind returns fmi2Error. */
#define STATUS_MASK (ST_STEP_COMPLETE | ST_TERMINATED)

static const char *status_kind_name(fmi2StatusKind s) {
    switch (s) {
    case fmi2DoStepStatus: return "fmi2DoStepStatus";
    case fmi2PendingStatus: return "fmi2PendingStatus";
    case fmi2LastSuccessfulTime: return "fmi2LastSuccessfulTime";
    case fmi2Terminated: return "fmi2Terminated";
    default: return NULL;
    }
}

/* The answer for a status this FMU does not provide: fmi2Discard, or fmi2Error for a NULL
 * value pointer or an unknown kind. */
static fmi2Status no_status(Instance *inst, const char *fn, fmi2StatusKind s, const void *value) {
    const char *kind = status_kind_name(s);
    if (!kind) return ERROR(inst, "%s: %d is no fmi2StatusKind", fn, (int)s);
    if (!value) return ERROR(inst, "%s: NULL value pointer", fn);
    log_msg(inst, fmi2Discard, "logStatusDiscard", "%s: %s is not provided (fmi2DoStep is synchronous; this FMU "
            "provides fmi2GetRealStatus(fmi2LastSuccessfulTime) and fmi2GetBooleanStatus(fmi2Terminated))", fn,
            kind);
    return fmi2Discard;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    CHECK(c, "fmi2GetStatus", STATUS_MASK);
    return no_status(inst, "fmi2GetStatus", s, value);
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    CHECK(c, "fmi2GetRealStatus", STATUS_MASK);
    if (s == fmi2LastSuccessfulTime && value) {
        *value = inst->d.time;
        return fmi2OK;
    }
    return no_status(inst, "fmi2GetRealStatus", s, value);
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    CHECK(c, "fmi2GetIntegerStatus", STATUS_MASK);
    return no_status(inst, "fmi2GetIntegerStatus", s, value);
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    CHECK(c, "fmi2GetBooleanStatus", STATUS_MASK);
    if (s == fmi2Terminated && value) {
        *value = fmi2False;
        return fmi2OK;
    }
    return no_status(inst, "fmi2GetBooleanStatus", s, value);
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    CHECK(c, "fmi2GetStringStatus", STATUS_MASK);
    return no_status(inst, "fmi2GetStringStatus", s, value);
}