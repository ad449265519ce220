/*
 * satfmu: what the FMI 2.0 interfaces of a model (fmi2_cosim.c, co-simulation; fmi2_me.c, model
 * exchange) have in common: the host's logger, variable access, instantiation, the experiment,
 * initialization, reset and the getters and setters. Each wrapper defines before including it
 *   FMU_TYPE        its fmi2Type (fmi2CoSimulation, fmi2ModelExchange),
 *   FMU_TYPE_ONLY   the message refusing the other one,
 *   GET_MASK        the states in which variables are read,
 *   SET_MASK        the states in which variables are set;
 * a model-exchange FMU's model.h defines NZ, and this file then includes satfmu_me.h: the variables
 * beyond the co-simulation FMU's (value references NV + i, the derivative of state i, and NV + NX + i,
 * state i) are read too, and a change of the inputs, parameters or state invalidates the
 * derivatives. Written for this project.
 */
#include "fmi2Functions.h"

#define HOST_FIELDS          \
    fmi2CallbackLogger logger; \
    fmi2ComponentEnvironment env;

#include "satfmu_core.h"
#if defined(NZ)
#include "satfmu_me.h"
#endif

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

/* A change of the inputs, parameters, state or time: outputs (and derivatives) to be recomputed. */
static void fmi2_changed(Instance *inst) {
#if defined(NZ)
    me_changed(inst);
#else
    inst->d.outputs_valid = 0;
#endif
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

/* Whether vr is a model-exchange variable (a derivative or a state), read as a Real. */
static int me_reference(fmi2ValueReference vr, int type) {
#if defined(NZ) && NX > 0
    return type == TYPE_REAL && vr >= (fmi2ValueReference)NV && vr < (fmi2ValueReference)(NV + 2 * NX);
#else
    (void)vr;
    (void)type;
    return 0;
#endif
}

static fmi2Status get_values(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, int type,
                             const char *fn, fmi2Real *r, fmi2Integer *n, fmi2Boolean *b) {
    size_t i;
    int ok, extra = 0;
    CHECK(c, fn, GET_MASK);
    if (nvr > 0 && (!vr || (!r && !n && !b))) return ERROR(inst, "%s: NULL array argument", fn);
    for (i = 0; i < nvr; i++) {
        if (me_reference(vr[i], type)) extra = 1;
        else if (!lookup(inst, vr[i], type, fn)) return fmi2Error;
    }
#if defined(NZ)
    if (inst->d.state == ST_INITIALIZATION) me_initial(inst); /* outputs and derivatives at the start */
#endif
    ok = update_outputs(inst, fn);
#if defined(NZ)
    if (ok && extra) ok = me_derivatives(inst, fn);
#endif
    for (i = 0; i < nvr; i++) { /* written even on an error: values for diagnosis */
        double v;
#if defined(NZ)
        if (me_reference(vr[i], type)) v = me_variable(inst, (int)(vr[i] - (fmi2ValueReference)NV));
        else
#endif
            v = *slot(&inst->d, &VARIABLES[vr[i]]);
        if (r) r[i] = v;
        else if (n) n[i] = isfinite(v) ? (fmi2Integer)v : 0;
        else b[i] = v != 0.0 ? fmi2True : fmi2False;
    }
    (void)extra;
    return ok ? fmi2OK : fmi2Error;
}

static fmi2Status set_values(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, int type,
                             const char *fn, const fmi2Real *r, const fmi2Integer *n, const fmi2Boolean *b) {
    size_t i;
    CHECK(c, fn, SET_MASK);
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
    fmi2_changed(inst);
    return fmi2OK;
}

/* ------------------------------------------------------------------ FMI API: common functions */
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
    if (fmuType != FMU_TYPE) {
        log_msg(&tmp, fmi2Error, "logStatusError", "fmi2Instantiate: %s", FMU_TYPE_ONLY);
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
    fmi2_changed(inst);
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    CHECK(c, "fmi2Reset", ~0);
    set_defaults(&inst->d);
    fmi2_changed(inst);
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
    CHECK(c, "fmi2SetString", SET_MASK & ~(ST_TERMINATED | ST_ERROR));
    (void)vr;
    (void)value;
    if (nvr > 0) return ERROR(inst, "fmi2SetString: this FMU has no String variables");
    return fmi2OK;
}
