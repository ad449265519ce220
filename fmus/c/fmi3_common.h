/*
 * satfmu: what the FMI 3.0 interfaces of a model (fmi3.c, co-simulation; fmi3_me.c, model exchange)
 * have in common: the host's logger, variable access (arrays, FMI 3.0's types), the sample clock's
 * functions, instantiation's checks, initialization, reset, and the functions neither provides. A
 * model-exchange FMU's model.h defines NZ, and this file then includes satfmu_me.h: its variables
 * beyond the co-simulation FMU's, value references NA + 1 + g (the derivatives of the state group g
 * of STATE_GROUPS, an array), NA + 1 + NG + g (the states of group g) and NA + 1 + 2 NG (the event
 * indicators), are read too, and a change of the inputs, parameters or state invalidates the
 * derivatives. Each wrapper defines
 * STEP_STATE_NAME before including it. Written for this project.
 */
#include <stdbool.h>

#include "fmi3Functions.h"

#define SATFMU_FMI3 1
#define HOST_FIELDS                  \
    fmi3LogMessageCallback logger;   \
    fmi3InstanceEnvironment env;     \
    int event_mode_used;             \
    int early_return_allowed;

#include "satfmu_core.h"
#if defined(NZ)
#include "satfmu_me.h"
#endif

#define VR_TIME 0
#define CLOCK_VR (NA + 1)
#define INITIALIZED (ST_EVENT | ST_STEP_COMPLETE)

static void host_log(const Instance *inst, int status, const char *category, const char *message) {
    if (inst->logger) inst->logger(inst->env, (fmi3Status)status, category, message);
}

/* A change of the inputs, parameters, state or time: outputs (and derivatives) to be recomputed. */
static void fmi3_changed(Instance *inst) {
#if defined(NZ)
    me_changed(inst);
#else
    inst->d.outputs_valid = 0;
#endif
}

/* ------------------------------------------------------------------ variable access */
/* A variable of the description beside time: value references 1 .. NA the model's (ARRAYS; `first`
 * its first element's row of VARIABLES), then a model-exchange FMU's derivatives and states
 * (satfmu_me.h's variables: `first` the index of the first one's state). */
typedef struct {
    int first, size;
    int me; /* 0 a model variable, 1 derivatives, 2 states, 3 event indicators: me_variable((me - 1) NX + first + j) */
} View;

/* A model-exchange variable: a state group's derivatives (value reference NA + 1 + g) or states
 * (NA + 1 + NG + g), the event indicators (NA + 1 + 2 NG); 0 if vr is none. */
static int me_view(fmi3ValueReference vr, View *out) {
#if defined(NZ)
    const fmi3ValueReference base = (fmi3ValueReference)NA + 1;
#if NG > 0
    if (vr >= base && vr < base + 2 * (fmi3ValueReference)NG) {
        const int g = (int)((vr - base) % (fmi3ValueReference)NG);
        out->first = STATE_GROUPS[g].first;
        out->size = STATE_GROUPS[g].size;
        out->me = vr < base + (fmi3ValueReference)NG ? 1 : 2;
        return 1;
    }
#endif
    if (NZ > 0 && vr == base + 2 * (fmi3ValueReference)NG) {
        out->first = 0;
        out->size = NZ;
        out->me = 3;
        return 1;
    }
#endif
    (void)vr;
    (void)out;
    return 0;
}

/* The variable of value reference vr and FMI type `type` (a model-exchange variable only when read);
 * 0 and a message if none. */
static int view_of(Instance *inst, fmi3ValueReference vr, int type, int set, const char *fn, View *out) {
    if (vr == VR_TIME) {
        log_msg(inst, STATUS_ERROR, "logStatusError", "%s: value reference 0 is the independent variable 'time' "
                "(fmi3GetFloat64 reads it; it cannot be set)", fn);
        return 0;
    }
    if (me_view(vr, out)) {
        if (type == TYPE_REAL && !set) return 1;
        log_msg(inst, STATUS_ERROR, "logStatusError", "%s: value reference %u is a state or its derivative: "
                "%s", fn, (unsigned)vr, set ? "fmi3SetContinuousStates sets the states" : "a Float64");
        return 0;
    }
    if (vr < 1 || vr > (fmi3ValueReference)NA) {
        if (NH > 0 && vr == (fmi3ValueReference)CLOCK_VR)
            log_msg(inst, STATUS_ERROR, "logStatusError", "%s: value reference %u is the sample clock "
                    "(fmi3GetClock, fmi3SetClock)", fn, (unsigned)vr);
        else
            log_msg(inst, STATUS_ERROR, "logStatusError", "%s: unknown value reference %u", fn, (unsigned)vr);
        return 0;
    }
    if (VARIABLES[ARRAYS[vr - 1].first].type != type) {
        log_msg(inst, STATUS_ERROR, "logStatusError", "%s: variable '%s' (value reference %u) has another type", fn,
                ARRAYS[vr - 1].name, (unsigned)vr);
        return 0;
    }
    out->first = ARRAYS[vr - 1].first;
    out->size = ARRAYS[vr - 1].size;
    out->me = 0;
    return 1;
}

/* The number of values of the variables vr[] (time, when read, counts one); 0 and a message on a
 * bad one. *extra tells whether one is a model-exchange variable. */
static int count_values(Instance *inst, const fmi3ValueReference vr[], size_t nvr, int type, int set,
                        size_t nValues, int *extra, const char *fn) {
    size_t i, count = 0;
    View view;
    *extra = 0;
    for (i = 0; i < nvr; i++) {
        if (!set && type == TYPE_REAL && vr[i] == VR_TIME) {
            count += 1;
            continue;
        }
        if (!view_of(inst, vr[i], type, set, fn, &view)) return 0;
        count += (size_t)view.size;
        *extra |= view.me != 0;
    }
    if (count != nValues) {
        log_msg(inst, STATUS_ERROR, "logStatusError", "%s: nValues = %zu, but the %zu variables hold %zu values", fn,
                nValues, nvr, count);
        return 0;
    }
    return 1;
}

/* Element j of a variable (its view checked). */
static double element(Instance *inst, const View *view, int j) {
#if defined(NZ)
    if (view->me) return me_variable(inst, (view->me - 1) * NX + view->first + j);
#endif
    return *slot(&inst->d, &VARIABLES[view->first + j]);
}

static fmi3Status get_values(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, int type, const char *fn,
                             size_t nValues, fmi3Float64 *r, fmi3Int32 *n, fmi3Boolean *b) {
    size_t i, k = 0;
    int j, ok, extra;
    View view;
    CHECK(c, fn, ST_INITIALIZATION | INITIALIZED | ST_TERMINATED | ST_ERROR);
    if (nvr > 0 && (!vr || (!r && !n && !b))) return ERROR(inst, "%s: NULL array argument", fn);
    if (!count_values(inst, vr, nvr, type, 0, nValues, &extra, fn)) return fmi3Error;
#if defined(NZ)
    if (inst->d.state == ST_INITIALIZATION) me_initial(inst); /* outputs and derivatives at the start */
#endif
    ok = update_outputs(inst, fn);
#if defined(NZ)
    if (ok && extra) ok = me_derivatives(inst, fn);
#endif
    for (i = 0; i < nvr; i++) { /* written even on an error: values for diagnosis */
        if (type == TYPE_REAL && vr[i] == VR_TIME) {
            r[k++] = inst->d.time;
            continue;
        }
        view_of(inst, vr[i], type, 0, fn, &view);
        for (j = 0; j < view.size; j++, k++) {
            double v = element(inst, &view, j);
            if (r) r[k] = v;
            else if (n) n[k] = isfinite(v) ? (fmi3Int32)v : 0;
            else b[k] = v != 0.0;
        }
    }
    return ok ? fmi3OK : fmi3Error;
}

static fmi3Status set_values(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, int type, const char *fn,
                             size_t nValues, const fmi3Float64 *r, const fmi3Int32 *n, const fmi3Boolean *b) {
    size_t i, k = 0;
    int j, extra;
    View view;
    CHECK(c, fn, ST_INSTANTIATED | ST_INITIALIZATION | INITIALIZED | ST_TERMINATED | ST_ERROR);
    if (nvr > 0 && (!vr || (!r && !n && !b))) return ERROR(inst, "%s: NULL array argument", fn);
    if (!count_values(inst, vr, nvr, type, 1, nValues, &extra, fn)) return fmi3Error;
    /* validate all first: a rejected call leaves every value unchanged */
    for (i = 0; i < nvr; i++) {
        view_of(inst, vr[i], type, 1, fn, &view);
        for (j = 0; j < view.size; j++, k++) {
            double value = r ? r[k] : (n ? (double)n[k] : (b[k] ? 1.0 : 0.0));
            if (check_value(inst, &VARIABLES[view.first + j], value, fn) != STATUS_OK) return fmi3Error;
        }
    }
    for (i = 0, k = 0; i < nvr; i++) {
        view_of(inst, vr[i], type, 1, fn, &view);
        for (j = 0; j < view.size; j++, k++)
            *slot(&inst->d, &VARIABLES[view.first + j]) = r ? r[k] : (n ? (double)n[k] : (b[k] ? 1.0 : 0.0));
    }
    values_set(inst);
    fmi3_changed(inst);
    return fmi3OK;
}

/* A variable type this FMU has none of: no value reference is valid for it. */
static fmi3Status no_variables(fmi3Instance c, size_t nvr, const char *fn, const char *type) {
    CHECK(c, fn, ~0);
    if (nvr > 0) return ERROR(inst, "%s: this FMU has no %s variables", fn, type);
    return fmi3OK;
}

/* ------------------------------------------------------------------ the sample clock */
static int is_clock(Instance *inst, const fmi3ValueReference vr[], size_t nvr, const void *values, const char *fn) {
    size_t i;
    if (nvr > 0 && (!vr || !values)) {
        log_msg(inst, STATUS_ERROR, "logStatusError", "%s: NULL array argument", fn);
        return 0;
    }
    for (i = 0; i < nvr; i++) {
        if (NH == 0 || vr[i] != (fmi3ValueReference)CLOCK_VR) {
            log_msg(inst, STATUS_ERROR, "logStatusError", "%s: value reference %u is no clock (%s)", fn,
                    (unsigned)vr[i], NH > 0 ? "the sample clock's is NA + 1" : "this FMU has none");
            return 0;
        }
    }
    return 1;
}

/* fmi3SetClock of the sample clock: the FMU time must be one of its instants (or the start). */
static int activate_clock(Instance *inst, const char *fn) {
    Data *d = &inst->d;
    if (!d->at_instant)
        return ERROR(inst, "%s: the sample clock is activated at its instants only (every %g s); t = %.17g s is "
                     "none (the next: %.17g s)", fn, sample_period(d), d->time, instant_time(d, d->next_k));
    d->clock_active = 1;
    d->clock_due = 0;
    d->sample_due = 1;
    d->outputs_valid = 0;
    return STATUS_OK;
}

/* ------------------------------------------------------------------ FMI API */
const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    CHECK(c, "fmi3SetDebugLogging", ~0);
    return (fmi3Status)set_logging(inst, loggingOn, nCategories, categories, "fmi3SetDebugLogging");
}

/* An instance that only carries the host's logger: the messages of a refused instantiation. */
static Instance logging_only(fmi3String name, fmi3LogMessageCallback logger, fmi3InstanceEnvironment env) {
    Instance tmp;
    memset(&tmp, 0, sizeof tmp);
    tmp.instance_name = (char *)(name ? name : "?");
    tmp.logger = logger;
    tmp.env = env;
    return tmp;
}
/* A new instance after instantiation's checks (fn: the instantiation function): a name, the
 * description's instantiationToken; NULL and a message otherwise. */
static Instance *instantiate(const char *fn, fmi3String instanceName, fmi3String instantiationToken,
                             fmi3Boolean loggingOn, int clocked, fmi3InstanceEnvironment instanceEnvironment,
                             fmi3LogMessageCallback logMessage) {
    Instance tmp = logging_only(instanceName, logMessage, instanceEnvironment), *inst;
    if (!instanceName || !*instanceName) {
        log_msg(&tmp, STATUS_ERROR, "logStatusError", "%s: missing instance name", fn);
        return NULL;
    }
    if (!instantiationToken || strcmp(instantiationToken, MODEL_GUID) != 0) {
        log_msg(&tmp, STATUS_ERROR, "logStatusError", "%s: instantiationToken '%s' does not match '%s'", fn,
                instantiationToken ? instantiationToken : "(null)", MODEL_GUID);
        return NULL;
    }
    inst = new_instance(instanceName, clocked);
    if (!inst) return NULL;
    inst->logger = logMessage;
    inst->env = instanceEnvironment;
    inst->log_on = loggingOn ? 1 : 0;
    return inst;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption) {
    Instance tmp = logging_only(instanceName, logMessage, instanceEnvironment);
    (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption;
    log_msg(&tmp, STATUS_ERROR, "logStatusError", "fmi3InstantiateScheduledExecution: scheduled execution "
            "is not provided");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance c) { free_instance((Instance *)c); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    CHECK(c, "fmi3EnterInitializationMode", ST_INSTANTIATED);
    (void)toleranceDefined;
    (void)tolerance;
    if (setup_experiment(inst, startTime, stopTimeDefined, stopTime, "fmi3EnterInitializationMode") != STATUS_OK)
        return fmi3Error;
    inst->d.state = ST_INITIALIZATION;
    fmi3_changed(inst);
    return fmi3OK;
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance c) {
    CHECK(c, "fmi3EvaluateDiscreteStates", ~0);
    return ERROR(inst, "fmi3EvaluateDiscreteStates: not provided (providesEvaluateDiscreteStates=false)");
}

fmi3Status fmi3Terminate(fmi3Instance c) {
    CHECK(c, "fmi3Terminate", INITIALIZED);
    inst->d.state = ST_TERMINATED;
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance c) {
    CHECK(c, "fmi3Reset", ~0);
    set_defaults(&inst->d);
    fmi3_changed(inst);
    return fmi3OK;
}


/* ------------------------------------------------------------------ getters and setters */
fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 values[],
                          size_t nValues) {
    return get_values(c, vr, nvr, TYPE_REAL, "fmi3GetFloat64", nValues, values, NULL, NULL);
}
fmi3Status fmi3GetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Int32 values[],
                        size_t nValues) {
    return get_values(c, vr, nvr, TYPE_INTEGER, "fmi3GetInt32", nValues, NULL, values, NULL);
}
fmi3Status fmi3GetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Boolean values[],
                          size_t nValues) {
    return get_values(c, vr, nvr, TYPE_BOOLEAN, "fmi3GetBoolean", nValues, NULL, NULL, values);
}
fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Float64 values[],
                          size_t nValues) {
    return set_values(c, vr, nvr, TYPE_REAL, "fmi3SetFloat64", nValues, values, NULL, NULL);
}
fmi3Status fmi3SetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Int32 values[],
                        size_t nValues) {
    return set_values(c, vr, nvr, TYPE_INTEGER, "fmi3SetInt32", nValues, NULL, values, NULL);
}
fmi3Status fmi3SetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Boolean values[],
                          size_t nValues) {
    return set_values(c, vr, nvr, TYPE_BOOLEAN, "fmi3SetBoolean", nValues, NULL, NULL, values);
}

#define NO_VARIABLES(TYPE, CTYPE)                                                                              \
    fmi3Status fmi3Get##TYPE(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, CTYPE values[],        \
                             size_t nValues) {                                                                 \
        (void)vr; (void)values; (void)nValues;                                                                 \
        return no_variables(c, nvr, "fmi3Get" #TYPE, #TYPE);                                                   \
    }                                                                                                          \
    fmi3Status fmi3Set##TYPE(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const CTYPE values[],  \
                             size_t nValues) {                                                                 \
        (void)vr; (void)values; (void)nValues;                                                                 \
        return no_variables(c, nvr, "fmi3Set" #TYPE, #TYPE);                                                   \
    }
NO_VARIABLES(Float32, fmi3Float32)
NO_VARIABLES(Int8, fmi3Int8)
NO_VARIABLES(UInt8, fmi3UInt8)
NO_VARIABLES(Int16, fmi3Int16)
NO_VARIABLES(UInt16, fmi3UInt16)
NO_VARIABLES(UInt32, fmi3UInt32)
NO_VARIABLES(Int64, fmi3Int64)
NO_VARIABLES(UInt64, fmi3UInt64)
NO_VARIABLES(String, fmi3String)

fmi3Status fmi3GetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, size_t valueSizes[],
                         fmi3Binary values[], size_t nValues) {
    (void)vr; (void)valueSizes; (void)values; (void)nValues;
    return no_variables(c, nvr, "fmi3GetBinary", "Binary");
}
fmi3Status fmi3SetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const size_t valueSizes[],
                         const fmi3Binary values[], size_t nValues) {
    (void)vr; (void)valueSizes; (void)values; (void)nValues;
    return no_variables(c, nvr, "fmi3SetBinary", "Binary");
}

/* The sample clock is active only in the Event Mode in which the importer activated it. */
fmi3Status fmi3GetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Clock values[]) {
    size_t i;
    CHECK(c, "fmi3GetClock", ST_EVENT);
    if (!is_clock(inst, vr, nvr, values, "fmi3GetClock")) return fmi3Error;
    for (i = 0; i < nvr; i++) values[i] = inst->d.clock_active != 0;
    return fmi3OK;
}

fmi3Status fmi3SetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Clock values[]) {
    size_t i;
    CHECK(c, "fmi3SetClock", ST_EVENT);
    if (!is_clock(inst, vr, nvr, values, "fmi3SetClock")) return fmi3Error;
    if (!inst->d.clocked) return ERROR(inst, "fmi3SetClock: the instance samples by itself (eventModeUsed = false)");
    for (i = 0; i < nvr; i++)
        if (values[i] && activate_clock(inst, "fmi3SetClock") != STATUS_OK) return fmi3Error;
    return fmi3OK;
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                                  fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[]) {
    size_t i;
    CHECK(c, "fmi3GetIntervalDecimal", ST_INITIALIZATION | INITIALIZED);
    if (!is_clock(inst, vr, nvr, intervals, "fmi3GetIntervalDecimal")) return fmi3Error;
    if (nvr > 0 && !qualifiers) return ERROR(inst, "fmi3GetIntervalDecimal: NULL array argument");
    for (i = 0; i < nvr; i++) {
        intervals[i] = sample_period(&inst->d);
        qualifiers[i] = inst->d.state == ST_INITIALIZATION ? fmi3IntervalChanged : fmi3IntervalUnchanged;
    }
    return fmi3OK;
}

/* The first instant after the start time, from the start time (the start itself is sampled in
 * initialization). */
fmi3Status fmi3GetShiftDecimal(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 shifts[]) {
    size_t i;
    double k;
    CHECK(c, "fmi3GetShiftDecimal", ST_INITIALIZATION | INITIALIZED);
    if (!is_clock(inst, vr, nvr, shifts, "fmi3GetShiftDecimal")) return fmi3Error;
    k = first_instant_after(&inst->d, inst->d.start_time);
    if (nvr > 0 && k < 0.0)
        return ERROR(inst, "fmi3GetShiftDecimal: the sample instants cannot be counted exactly from t = %g s",
                     inst->d.start_time);
    for (i = 0; i < nvr; i++) shifts[i] = instant_time(&inst->d, k) - inst->d.start_time;
    return fmi3OK;
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3UInt64 counters[],
                                   fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[]) {
    (void)vr; (void)nvr; (void)counters; (void)resolutions; (void)qualifiers;
    NOT_PROVIDED(fmi3GetIntervalFraction, "supportsFraction=false: use fmi3GetIntervalDecimal");
}
fmi3Status fmi3GetShiftFraction(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3UInt64 counters[],
                                fmi3UInt64 resolutions[]) {
    (void)vr; (void)nvr; (void)counters; (void)resolutions;
    NOT_PROVIDED(fmi3GetShiftFraction, "supportsFraction=false: use fmi3GetShiftDecimal");
}
fmi3Status fmi3SetIntervalDecimal(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                                  const fmi3Float64 intervals[]) {
    (void)vr; (void)nvr; (void)intervals;
    NOT_PROVIDED(fmi3SetIntervalDecimal, "the sample period is the FMU's parameter");
}
fmi3Status fmi3SetIntervalFraction(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                                   const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]) {
    (void)vr; (void)nvr; (void)counters; (void)resolutions;
    NOT_PROVIDED(fmi3SetIntervalFraction, "the sample period is the FMU's parameter");
}
fmi3Status fmi3SetShiftDecimal(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                               const fmi3Float64 shifts[]) {
    (void)vr; (void)nvr; (void)shifts;
    NOT_PROVIDED(fmi3SetShiftDecimal, "the sample instants follow the FMU's parameters");
}
fmi3Status fmi3SetShiftFraction(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                                const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]) {
    (void)vr; (void)nvr; (void)counters; (void)resolutions;
    NOT_PROVIDED(fmi3SetShiftFraction, "the sample instants follow the FMU's parameters");
}

/* ------------------------------------------------------------------ dependencies, derivatives */
fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance c, fmi3ValueReference valueReference,
                                               size_t *nDependencies) {
    (void)valueReference; (void)nDependencies;
    NOT_PROVIDED(fmi3GetNumberOfVariableDependencies, "providesPerElementDependencies=false: the description's "
                 "ModelStructure lists them");
}
fmi3Status fmi3GetVariableDependencies(fmi3Instance c, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies) {
    (void)dependent; (void)elementIndicesOfDependent; (void)independents; (void)elementIndicesOfIndependents;
    (void)dependencyKinds; (void)nDependencies;
    NOT_PROVIDED(fmi3GetVariableDependencies, "providesPerElementDependencies=false: the description's "
                 "ModelStructure lists them");
}
fmi3Status fmi3GetDirectionalDerivative(fmi3Instance c, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                        size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed; (void)sensitivity;
    (void)nSensitivity;
    NOT_PROVIDED(fmi3GetDirectionalDerivative, "providesDirectionalDerivatives=false");
}
fmi3Status fmi3GetAdjointDerivative(fmi3Instance c, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed; (void)sensitivity;
    (void)nSensitivity;
    NOT_PROVIDED(fmi3GetAdjointDerivative, "providesAdjointDerivatives=false");
}
fmi3Status fmi3GetOutputDerivatives(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                                    const fmi3Int32 orders[], fmi3Float64 values[], size_t nValues) {
    (void)vr; (void)nvr; (void)orders; (void)values; (void)nValues;
    NOT_PROVIDED(fmi3GetOutputDerivatives, "maxOutputDerivativeOrder=0");
}
fmi3Status fmi3EnterConfigurationMode(fmi3Instance c) {
    NOT_PROVIDED(fmi3EnterConfigurationMode, "this FMU has no structural parameters");
}
fmi3Status fmi3ExitConfigurationMode(fmi3Instance c) {
    NOT_PROVIDED(fmi3ExitConfigurationMode, "this FMU has no structural parameters");
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance c, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
    (void)clockReference; (void)activationTime;
    NOT_PROVIDED(fmi3ActivateModelPartition, "scheduled execution is not provided");
}
