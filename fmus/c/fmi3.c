/*
 * satfmu: the FMI 3.0 co-simulation interface of a model generated from a symbolic definition
 * (fmus/model.py); fmi2_cosim.c is its FMI 2.0 interface. Everything that does not depend on the
 * interface (time, sampling, integration, variable checks, FMU state records) is in
 * satfmu_core.h, which includes the generated model.h; this file is the FMU's only translation
 * unit (sources/buildDescription.xml lists it). Written for this project.
 *
 * Variables: value reference 0 is the independent variable time; 1 .. NA the model's variables,
 * its vectors as arrays (ARRAYS in model.h: the first element's row of VARIABLES and the size;
 * satfmu.fmus.arrays groups them), whose values fmi3Get/SetFloat64, Int32 and Boolean read and
 * write in element order, nValues counting every element; CLOCK_VR (NA + 1), for a sampled model
 * (NH > 0), its sample clock.
 *
 * Sample clock: an input, periodic Clock with intervalVariability "fixed" (its period and shift
 * depend on the fixed parameters, so the importer reads them with fmi3GetIntervalDecimal and
 * fmi3GetShiftDecimal in Initialization Mode: the period, and the first instant after the start
 * time minus the start time). An instance instantiated with eventModeUsed is clocked (see
 * satfmu_core.h): the importer ends a step at each instant, enters Event Mode, sets the inputs,
 * activates the clock with fmi3SetClock and calls fmi3UpdateDiscreteStates, which takes the
 * sample and returns the next instant as nextEventTime. Without event mode (eventModeUsed false,
 * which the standard asks of an importer of a clocked FMU but many co-simulation importers
 * cannot do), the instance samples inside its steps as the FMI 2.0 FMU does, with its results.
 *
 * Robustness: as fmi2_cosim.c (call order against the FMI 3.0 co-simulation state machine, value
 * references, types, nValues, finiteness, ranges; a refused call changes nothing; no non-finite
 * output with fmi3OK). Model exchange and scheduled execution are not provided (their
 * instantiation returns NULL with a message).
 */
#include <stdbool.h>

#include "fmi3Functions.h"

#define SATFMU_FMI3 1
#define STEP_STATE_NAME "StepMode"
#define HOST_FIELDS                  \
    fmi3LogMessageCallback logger;   \
    fmi3InstanceEnvironment env;     \
    int event_mode_used;             \
    int early_return_allowed;

#include "satfmu_core.h"

#define VR_TIME 0
#define CLOCK_VR (NA + 1)
#define INITIALIZED (ST_EVENT | ST_STEP_COMPLETE)

static void host_log(const Instance *inst, int status, const char *category, const char *message) {
    if (inst->logger) inst->logger(inst->env, (fmi3Status)status, category, message);
}

/* ------------------------------------------------------------------ variable access */
/* The array (or scalar) of value reference vr and FMI type `type`; NULL and a message if none. */
static const ArrayInfo *array_of(Instance *inst, fmi3ValueReference vr, int type, const char *fn) {
    if (vr == VR_TIME) {
        log_msg(inst, STATUS_ERROR, "logStatusError", "%s: value reference 0 is the independent variable 'time' "
                "(fmi3GetFloat64 reads it; it cannot be set)", fn);
        return NULL;
    }
    if (vr < 1 || vr > (fmi3ValueReference)NA) {
        if (NH > 0 && vr == (fmi3ValueReference)CLOCK_VR)
            log_msg(inst, STATUS_ERROR, "logStatusError", "%s: value reference %u is the sample clock "
                    "(fmi3GetClock, fmi3SetClock)", fn, (unsigned)vr);
        else
            log_msg(inst, STATUS_ERROR, "logStatusError", "%s: unknown value reference %u", fn, (unsigned)vr);
        return NULL;
    }
    if (VARIABLES[ARRAYS[vr - 1].first].type != type) {
        log_msg(inst, STATUS_ERROR, "logStatusError", "%s: variable '%s' (value reference %u) has another type", fn,
                ARRAYS[vr - 1].name, (unsigned)vr);
        return NULL;
    }
    return &ARRAYS[vr - 1];
}

/* The number of values of the variables vr[] (time counts one); 0 and a message on a bad one. */
static int count_values(Instance *inst, const fmi3ValueReference vr[], size_t nvr, int type, int with_time,
                        size_t nValues, const char *fn) {
    size_t i, count = 0;
    for (i = 0; i < nvr; i++) {
        const ArrayInfo *a;
        if (with_time && vr[i] == VR_TIME) {
            count += 1;
            continue;
        }
        if (!(a = array_of(inst, vr[i], type, fn))) return 0;
        count += (size_t)a->size;
    }
    if (count != nValues) {
        log_msg(inst, STATUS_ERROR, "logStatusError", "%s: nValues = %zu, but the %zu variables hold %zu values", fn,
                nValues, nvr, count);
        return 0;
    }
    return 1;
}

static fmi3Status get_values(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, int type, const char *fn,
                             size_t nValues, fmi3Float64 *r, fmi3Int32 *n, fmi3Boolean *b) {
    size_t i, k = 0;
    int j, ok;
    CHECK(c, fn, ST_INITIALIZATION | INITIALIZED | ST_TERMINATED | ST_ERROR);
    if (nvr > 0 && (!vr || (!r && !n && !b))) return ERROR(inst, "%s: NULL array argument", fn);
    if (!count_values(inst, vr, nvr, type, type == TYPE_REAL, nValues, fn)) return fmi3Error;
    ok = update_outputs(inst, fn);
    for (i = 0; i < nvr; i++) { /* written even on an error: values for diagnosis */
        if (type == TYPE_REAL && vr[i] == VR_TIME) {
            r[k++] = inst->d.time;
            continue;
        }
        for (j = 0; j < ARRAYS[vr[i] - 1].size; j++, k++) {
            double v = *slot(&inst->d, &VARIABLES[ARRAYS[vr[i] - 1].first + j]);
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
    int j;
    CHECK(c, fn, ST_INSTANTIATED | ST_INITIALIZATION | INITIALIZED | ST_TERMINATED | ST_ERROR);
    if (nvr > 0 && (!vr || (!r && !n && !b))) return ERROR(inst, "%s: NULL array argument", fn);
    if (!count_values(inst, vr, nvr, type, 0, nValues, fn)) return fmi3Error;
    /* validate all first: a rejected call leaves every value unchanged */
    for (i = 0; i < nvr; i++)
        for (j = 0; j < ARRAYS[vr[i] - 1].size; j++, k++) {
            double value = r ? r[k] : (n ? (double)n[k] : (b[k] ? 1.0 : 0.0));
            if (check_value(inst, &VARIABLES[ARRAYS[vr[i] - 1].first + j], value, fn) != STATUS_OK)
                return fmi3Error;
        }
    for (i = 0, k = 0; i < nvr; i++)
        for (j = 0; j < ARRAYS[vr[i] - 1].size; j++, k++)
            *slot(&inst->d, &VARIABLES[ARRAYS[vr[i] - 1].first + j]) =
                r ? r[k] : (n ? (double)n[k] : (b[k] ? 1.0 : 0.0));
    values_set(inst);
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

/* The event's discrete update (fmi3UpdateDiscreteStates, fmi3EnterStepMode): a due sample is
 * taken from the inputs set so far; the clock is deactivated. */
static int update_discrete(Instance *inst) {
    Data *d = &inst->d;
    if (d->sample_due && !sample(inst)) return STATUS_ERROR;
    d->clock_active = 0;
    d->inputs_stale = 0;
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

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
    Instance tmp = logging_only(instanceName, logMessage, instanceEnvironment), *inst;
    (void)resourcePath;
    (void)visible;
    (void)requiredIntermediateVariables;
    (void)intermediateUpdate;
    if (!instanceName || !*instanceName) {
        log_msg(&tmp, STATUS_ERROR, "logStatusError", "fmi3InstantiateCoSimulation: missing instance name");
        return NULL;
    }
    if (!instantiationToken || strcmp(instantiationToken, MODEL_GUID) != 0) {
        log_msg(&tmp, STATUS_ERROR, "logStatusError", "fmi3InstantiateCoSimulation: instantiationToken '%s' does "
                "not match '%s'", instantiationToken ? instantiationToken : "(null)", MODEL_GUID);
        return NULL;
    }
    if (nRequiredIntermediateVariables > 0) {
        log_msg(&tmp, STATUS_ERROR, "logStatusError", "fmi3InstantiateCoSimulation: this FMU provides no "
                "intermediate update (providesIntermediateUpdate=false), so no intermediate variables");
        return NULL;
    }
    inst = new_instance(instanceName, eventModeUsed && NH > 0);
    if (!inst) return NULL;
    inst->logger = logMessage;
    inst->env = instanceEnvironment;
    inst->log_on = loggingOn ? 1 : 0;
    inst->event_mode_used = eventModeUsed ? 1 : 0;
    inst->early_return_allowed = earlyReturnAllowed ? 1 : 0;
    return inst;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    Instance tmp = logging_only(instanceName, logMessage, instanceEnvironment);
    (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    log_msg(&tmp, STATUS_ERROR, "logStatusError", "fmi3InstantiateModelExchange: this FMU supports co-simulation "
            "only");
    return NULL;
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
    log_msg(&tmp, STATUS_ERROR, "logStatusError", "fmi3InstantiateScheduledExecution: this FMU supports "
            "co-simulation only");
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
    inst->d.outputs_valid = 0;
    return fmi3OK;
}

/* Event Mode when the importer uses it (eventModeUsed), else Step Mode. */
fmi3Status fmi3ExitInitializationMode(fmi3Instance c) {
    CHECK(c, "fmi3ExitInitializationMode", ST_INITIALIZATION);
    if (exit_initialization(inst, "fmi3ExitInitializationMode") != STATUS_OK) return fmi3Error;
    inst->d.state = inst->event_mode_used ? ST_EVENT : ST_STEP_COMPLETE;
    return fmi3OK;
}

fmi3Status fmi3EnterEventMode(fmi3Instance c) {
    CHECK(c, "fmi3EnterEventMode", ST_STEP_COMPLETE);
    if (!inst->event_mode_used)
        return ERROR(inst, "fmi3EnterEventMode: the instance was instantiated with eventModeUsed = false");
    inst->d.state = ST_EVENT;
    return fmi3OK;
}

fmi3Status fmi3EnterStepMode(fmi3Instance c) {
    CHECK(c, "fmi3EnterStepMode", ST_EVENT);
    if (update_discrete(inst) != STATUS_OK) return fmi3Error;
    inst->d.state = ST_STEP_COMPLETE;
    return fmi3OK;
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    CHECK(c, "fmi3UpdateDiscreteStates", ST_EVENT);
    if (!discreteStatesNeedUpdate || !terminateSimulation || !nominalsOfContinuousStatesChanged ||
        !valuesOfContinuousStatesChanged || !nextEventTimeDefined || !nextEventTime)
        return ERROR(inst, "fmi3UpdateDiscreteStates: NULL result pointer");
    if (update_discrete(inst) != STATUS_OK) return fmi3Error;
    *discreteStatesNeedUpdate = false;
    *terminateSimulation = false;
    *nominalsOfContinuousStatesChanged = false;
    *valuesOfContinuousStatesChanged = false;
    *nextEventTimeDefined = inst->d.clocked != 0;
    *nextEventTime = inst->d.clocked ? instant_time(&inst->d, inst->d.next_k) : 0.0;
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

#define NOT_PROVIDED(NAME, WHY)                                                                                \
    CHECK(c, #NAME, ~0);                                                                                       \
    return ERROR(inst, #NAME ": not provided (" WHY ")")

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

/* ------------------------------------------------------------------ FMU state */
fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState *FMUState) {
    CHECK(c, "fmi3GetFMUState", STATE_MASK);
    return (fmi3Status)state_get(inst, FMUState, "fmi3GetFMUState");
}
fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState FMUState) {
    CHECK(c, "fmi3SetFMUState", STATE_MASK);
    return (fmi3Status)state_set(inst, FMUState, "fmi3SetFMUState");
}
fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState *FMUState) {
    CHECK(c, "fmi3FreeFMUState", STATE_MASK);
    state_free(FMUState);
    return fmi3OK;
}
fmi3Status fmi3SerializedFMUStateSize(fmi3Instance c, fmi3FMUState FMUState, size_t *size) {
    CHECK(c, "fmi3SerializedFMUStateSize", STATE_MASK);
    return (fmi3Status)state_size(inst, FMUState, size, "fmi3SerializedFMUStateSize");
}
fmi3Status fmi3SerializeFMUState(fmi3Instance c, fmi3FMUState FMUState, fmi3Byte serializedState[], size_t size) {
    CHECK(c, "fmi3SerializeFMUState", STATE_MASK);
    return (fmi3Status)state_serialize(inst, FMUState, serializedState, size, "fmi3SerializeFMUState");
}
fmi3Status fmi3DeserializeFMUState(fmi3Instance c, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState) {
    CHECK(c, "fmi3DeserializeFMUState", STATE_MASK);
    return (fmi3Status)state_deserialize(inst, serializedState, size, FMUState, "fmi3DeserializeFMUState");
}

/* ------------------------------------------------------------------ co-simulation */
fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean *eventHandlingNeeded,
                      fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    int early = 0;
    fmi3Status status;
    CHECK(c, "fmi3DoStep", ST_STEP_COMPLETE);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!eventHandlingNeeded || !terminateSimulation || !earlyReturn || !lastSuccessfulTime)
        return ERROR(inst, "fmi3DoStep: NULL result pointer");
    status = (fmi3Status)do_step(inst, currentCommunicationPoint, communicationStepSize,
                                 inst->early_return_allowed, &early, "fmi3DoStep");
    *eventHandlingNeeded = early != 0;
    *terminateSimulation = false;
    *earlyReturn = early != 0;
    *lastSuccessfulTime = inst->d.time;
    return status;
}

/* ------------------------------------------------------------------ not this FMU's interfaces */
fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance c) {
    NOT_PROVIDED(fmi3EnterContinuousTimeMode, "co-simulation only");
}
fmi3Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation) {
    (void)noSetFMUStatePriorToCurrentPoint; (void)enterEventMode; (void)terminateSimulation;
    NOT_PROVIDED(fmi3CompletedIntegratorStep, "co-simulation only");
}
fmi3Status fmi3SetTime(fmi3Instance c, fmi3Float64 time) {
    (void)time;
    NOT_PROVIDED(fmi3SetTime, "co-simulation only");
}
fmi3Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64 continuousStates[], size_t nContinuousStates) {
    (void)continuousStates; (void)nContinuousStates;
    NOT_PROVIDED(fmi3SetContinuousStates, "co-simulation only");
}
fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64 derivatives[], size_t nContinuousStates) {
    (void)derivatives; (void)nContinuousStates;
    NOT_PROVIDED(fmi3GetContinuousStateDerivatives, "co-simulation only");
}
fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64 eventIndicators[], size_t nEventIndicators) {
    (void)eventIndicators; (void)nEventIndicators;
    NOT_PROVIDED(fmi3GetEventIndicators, "co-simulation only");
}
fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64 continuousStates[], size_t nContinuousStates) {
    (void)continuousStates; (void)nContinuousStates;
    NOT_PROVIDED(fmi3GetContinuousStates, "co-simulation only");
}
fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64 nominals[], size_t nContinuousStates) {
    (void)nominals; (void)nContinuousStates;
    NOT_PROVIDED(fmi3GetNominalsOfContinuousStates, "co-simulation only");
}
fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *nEventIndicators) {
    (void)nEventIndicators;
    NOT_PROVIDED(fmi3GetNumberOfEventIndicators, "co-simulation only");
}
fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *nContinuousStates) {
    (void)nContinuousStates;
    NOT_PROVIDED(fmi3GetNumberOfContinuousStates, "co-simulation only");
}
fmi3Status fmi3ActivateModelPartition(fmi3Instance c, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
    (void)clockReference; (void)activationTime;
    NOT_PROVIDED(fmi3ActivateModelPartition, "co-simulation only");
}
