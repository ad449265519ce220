/*
 * satfmu: generic FMI 2.0 co-simulation wrapper for models generated from a symbolic
 * definition (fmus/model.py). The model-specific part (sizes, variable table and the
 * functions model_derivatives, model_outputs, model_post_step) is generated into
 * model.c, which this file includes. Written for this project.
 *
 * Integration: classical RK4 over each communication step, inputs held constant
 * (zero-order hold), n = max(n_substeps, ceil(h / h_max)) substeps, post_step map
 * (projection / switching) after every substep.
 *
 * Exact integration (EXACT 1, a model affine in the state with its piecewise law frozen at
 * the substep start): x(tau) = Phi x + Gamma b with Phi = e^{A tau}, Gamma = integral_0^tau
 * e^{A s} ds, A = model_jacobian, b = the derivatives at x = 0. Phi and Gamma come from a
 * Taylor series of Gamma at tau / 2^s (|A| tau / 2^s <= 1/2, 18 terms, truncation below
 * 1e-22) and s doublings Gamma <- (I + Phi) Gamma, Phi <- Phi^2; they are cached for the
 * last (A, tau). A substep ends early at model_switch_time (the frozen law's validity).
 *
 * Sampling (NH > 0, an expression sampler of fmus/model.py): NH values are computed by
 * model_sample_arguments at the start and at the instants k * period - phase (start +
 * k * period without a phase parameter) and held in p[NP..NP+NH-1] in between; a step is
 * integrated in segments between instants. The values of an instant at a communication
 * point are computed from the inputs set there, when first needed (an output read or the
 * next step), and again if an input changes there (as fmus/pyslave.py does). The held
 * values the expressions read are always those of the previous instant (held_prev), so a
 * repeated sample at one instant gives the same result as a single one.
 *
 * Robustness: every call checks the instance pointer, the call order against the
 * FMI 2.0 co-simulation state machine, value references, types, finiteness and
 * declared ranges; a violation returns fmi2Error with a message naming the
 * variable and never changes the stored values. A step whose state becomes
 * non-finite puts the instance in the error state (fmi2SetFMUstate or fmi2Reset
 * recover it).
 */
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

typedef struct {
    const char *name;
    int kind;   /* 0 parameter, 1 input, 2 output */
    int type;   /* 0 Real, 1 Integer, 2 Boolean */
    int index;  /* position in p[], u[] or y[] */
    double start, min, max;
} VariableInfo;

enum { KIND_PARAMETER = 0, KIND_INPUT = 1, KIND_OUTPUT = 2 };
enum { TYPE_REAL = 0, TYPE_INTEGER = 1, TYPE_BOOLEAN = 2 };

#include "model.c"

#define DIM(n) ((n) > 0 ? (n) : 1)
#define MAX_SUBSTEPS 10000000.0
#define STATE_MAGIC 0x5a7f3d02u

typedef enum {
    ST_INSTANTIATED = 1 << 0,
    ST_INITIALIZATION = 1 << 1,
    ST_STEP_COMPLETE = 1 << 2,
    ST_TERMINATED = 1 << 3,
    ST_ERROR = 1 << 4
} ModelState;

static const char *state_name(int s) {
    switch (s) {
    case ST_INSTANTIATED: return "Instantiated";
    case ST_INITIALIZATION: return "InitializationMode";
    case ST_STEP_COMPLETE: return "StepComplete";
    case ST_TERMINATED: return "Terminated";
    default: return "Error";
    }
}

/* Everything that an FMU state snapshot must restore. Plain data: serializable by memcpy. */
typedef struct {
    unsigned magic;
    int state;
    double time;
    double x[DIM(NX)];
    double u[DIM(NU)];
    double p[DIM(NP + NH)]; /* parameters, then the held values */
    double y[DIM(NY)];
    int outputs_valid;
    double start_time;
    double next_instant; /* the first sample instant after the FMU time */
    double held_prev[DIM(NH)]; /* the held values of the previous instant */
    int at_instant;      /* the FMU time is a sample instant */
    int sample_due;      /* the held values of that instant are stale */
} Data;

#if EXACT
/* Phi and Gamma of the last (A, tau): derived data, not part of an FMU state. */
typedef struct {
    int valid;
    double tau;
    double A[NX * NX], Phi[NX * NX], Gamma[NX * NX];
} FlowCache;
#endif

typedef struct {
    Data d;
#if EXACT
    FlowCache flow;
#endif
    char *instance_name;
    fmi2CallbackLogger logger;
    fmi2ComponentEnvironment env;
    int log_on;
} Instance;

/* The formatted message is passed as the logger's format string with '%' doubled, so hosts
 * that cannot expand variadic arguments (ctypes-based ones such as fmpy) show it intact. */
static void log_msg(Instance *inst, fmi2Status status, const char *category, const char *fmt, ...) {
    char buf[1024], esc[2048];
    size_t i, j = 0;
    va_list ap;
    if (!inst || !inst->logger) return;
    if (status == fmi2OK && !inst->log_on) return;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    for (i = 0; buf[i] && j + 2 < sizeof esc; i++) {
        if (buf[i] == '%') esc[j++] = '%';
        esc[j++] = buf[i];
    }
    esc[j] = '\0';
    inst->logger(inst->env, inst->instance_name, status, category, esc);
}

#define ERROR(inst, ...) (log_msg((inst), fmi2Error, "logStatusError", __VA_ARGS__), fmi2Error)

static int allowed(Instance *inst, const char *fn, int mask) {
    if (inst->d.state & mask) return 1;
    log_msg(inst, fmi2Error, "logStatusError", "%s must not be called in state %s", fn,
            state_name(inst->d.state));
    return 0;
}

#define CHECK(c, fn, mask)                                   \
    Instance *inst = (Instance *)(c);                        \
    if (!inst) return fmi2Error;                             \
    if (!allowed(inst, fn, (mask))) return fmi2Error

static void set_defaults(Data *d) {
    int i;
    memset(d, 0, sizeof *d);
    d->magic = STATE_MAGIC;
    d->state = ST_INSTANTIATED;
    d->at_instant = 1;
    d->sample_due = NH > 0;
    for (i = 0; i < NV; i++) {
        const VariableInfo *v = &VARIABLES[i];
        if (v->kind == KIND_PARAMETER) d->p[v->index] = v->start;
        else if (v->kind == KIND_INPUT) d->u[v->index] = v->start;
    }
}

static void initial_state(Data *d) {
    int i;
    for (i = 0; i < NX; i++) d->x[i] = d->p[STATE_INITIAL[i]];
}

static int all_finite(const double *v, int n) {
    int i;
    for (i = 0; i < n; i++) if (!isfinite(v[i])) return 0;
    return 1;
}

/* ------------------------------------------------------------------ sampling */
static double instant_after(const Data *d, double t) {
    const double period = d->p[P_PERIOD > 0 ? P_PERIOD : 0];
    const double phase = P_PHASE >= 0 ? d->p[P_PHASE > 0 ? P_PHASE : 0] : -d->start_time;
    double k = floor((t + phase) / period) + 1.0;
    if (k * period - phase <= t + TIME_TOL * fmax(1.0, fabs(t))) k += 1.0;
    return k * period - phase;
}

/* Held values of the current instant; 0 (and the error state) when one is not finite. */
static int sample(Instance *inst) {
    double held[DIM(NH)], pp[DIM(NP + NH)];
    int i;
    Data *d = &inst->d;
    if (NH == 0) return 1;
    for (i = 0; i < NP; i++) pp[i] = d->p[i];
    for (i = 0; i < NH; i++) pp[NP + i] = d->held_prev[i];
    model_sample_arguments(d->time, d->x, d->u, pp, held);
    for (i = 0; i < NH; i++) {
        if (!isfinite(held[i])) {
            d->state = ST_ERROR;
            log_msg(inst, fmi2Error, "logStatusError", "sample at t = %g s: held value %d is %g", d->time, i,
                    held[i]);
            return 0;
        }
    }
    for (i = 0; i < NH; i++) d->p[NP + i] = held[i];
    d->sample_due = 0;
    d->outputs_valid = 0;
    return 1;
}

/* The FMU time reached a new instant: what is held now becomes the previous instant's values. */
static void new_instant(Data *d) {
    int i;
    for (i = 0; i < NH; i++) d->held_prev[i] = d->p[NP + i];
}

static int update_outputs(Instance *inst) {
    Data *d = &inst->d;
    if (d->outputs_valid) return 1;
    if (d->state & (ST_INSTANTIATED | ST_INITIALIZATION)) initial_state(d);
    if (d->sample_due && !sample(inst)) return 0;
    if (NY > 0) model_outputs(d->time, d->x, d->u, d->p, d->y);
    d->outputs_valid = 1;
    return 1;
}

/* ------------------------------------------------------------------ integration */
#if !EXACT
static void rk4(Data *d, double h) {
    double k1[DIM(NX)], k2[DIM(NX)], k3[DIM(NX)], k4[DIM(NX)], xt[DIM(NX)], xp[DIM(NX)];
    int i;
    double t = d->time;
    model_derivatives(t, d->x, d->x, d->u, d->p, k1);
    for (i = 0; i < NX; i++) xt[i] = d->x[i] + 0.5 * h * k1[i];
    model_derivatives(t + 0.5 * h, xt, d->x, d->u, d->p, k2);
    for (i = 0; i < NX; i++) xt[i] = d->x[i] + 0.5 * h * k2[i];
    model_derivatives(t + 0.5 * h, xt, d->x, d->u, d->p, k3);
    for (i = 0; i < NX; i++) xt[i] = d->x[i] + h * k3[i];
    model_derivatives(t + h, xt, d->x, d->u, d->p, k4);
    for (i = 0; i < NX; i++) {
        xp[i] = d->x[i];
        xt[i] = d->x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    model_post_step(t + h, xt, xp, d->u, d->p, d->x);
}
#endif

#if EXACT
#define TAYLOR_TERMS 18
#define MAX_SWITCHES 64 /* per substep; beyond that the law of the last switch is kept */

static void matmul(const double *a, const double *b, double *c) {
    int i, j, k;
    for (i = 0; i < NX; i++)
        for (j = 0; j < NX; j++) {
            double s = 0.0;
            for (k = 0; k < NX; k++) s += a[i * NX + k] * b[k * NX + j];
            c[i * NX + j] = s;
        }
}

/* Phi = e^{A tau}, Gamma = integral_0^tau e^{A s} ds (see the header comment). */
static void affine_flow(const double *A, double tau, double *Phi, double *Gamma) {
    double T[NX * NX], W[NX * NX], norm = 0.0, dt;
    int i, j, k, s = 0;
    for (i = 0; i < NX; i++) {
        double row = 0.0;
        for (j = 0; j < NX; j++) row += fabs(A[i * NX + j]);
        norm = fmax(norm, row);
    }
    norm *= tau;
    while (norm > 0.5 && s < 1000) { norm *= 0.5; s++; }
    dt = ldexp(tau, -s);
    for (i = 0; i < NX * NX; i++) T[i] = (i % (NX + 1) == 0) ? 1.0 : 0.0;
    for (k = TAYLOR_TERMS; k >= 1; k--) { /* T <- I + (A dt / (k + 1)) T */
        matmul(A, T, W);
        for (i = 0; i < NX * NX; i++) T[i] = W[i] * dt / (double)(k + 1) + ((i % (NX + 1) == 0) ? 1.0 : 0.0);
    }
    for (i = 0; i < NX * NX; i++) Gamma[i] = dt * T[i];
    matmul(A, Gamma, Phi);
    for (i = 0; i < NX; i++) Phi[i * NX + i] += 1.0;
    for (k = 0; k < s; k++) {
        matmul(Phi, Gamma, W);
        for (i = 0; i < NX * NX; i++) Gamma[i] += W[i];
        matmul(Phi, Phi, W);
        memcpy(Phi, W, sizeof W);
    }
}

/* Exact flow over tau seconds with the law frozen at the current state, then post_step. */
static void exact_segment(Instance *inst, double tau) {
    Data *d = &inst->d;
    FlowCache *fc = &inst->flow;
    double A[NX * NX], zero[NX], b[NX], xt[NX];
    int i, j;
    memset(zero, 0, sizeof zero);
    model_jacobian(d->time, d->x, d->x, d->u, d->p, A);
    model_derivatives(d->time, zero, d->x, d->u, d->p, b);
    if (!fc->valid || fc->tau != tau || memcmp(fc->A, A, sizeof A) != 0) {
        affine_flow(A, tau, fc->Phi, fc->Gamma);
        memcpy(fc->A, A, sizeof A);
        fc->tau = tau;
        fc->valid = 1;
    }
    for (i = 0; i < NX; i++) {
        double s = 0.0;
        for (j = 0; j < NX; j++) s += fc->Phi[i * NX + j] * d->x[j] + fc->Gamma[i * NX + j] * b[j];
        xt[i] = s;
    }
    model_post_step(d->time + tau, xt, d->x, d->u, d->p, d->x);
}

/* Exact substep of h seconds ending at t_end, cut at the switch instants of the piecewise law
 * (an uncut substep uses h itself, so a constant step size reuses the cached flow). */
static void exact_substep(Instance *inst, double h, double t_end) {
    int n, cut = 0;
    for (n = 0; n < MAX_SWITCHES; n++) {
        double ts, remaining = t_end - inst->d.time;
        model_switch_time(inst->d.time, inst->d.x, inst->d.u, inst->d.p, &ts);
        if (!(ts > TIME_TOL * fmax(1.0, fabs(t_end))) || ts >= remaining) break;
        exact_segment(inst, ts);
        inst->d.time += ts;
        cut = 1;
    }
    exact_segment(inst, cut ? t_end - inst->d.time : h);
    inst->d.time = t_end;
}
#endif

/* ------------------------------------------------------------------ variable access */
static const VariableInfo *lookup(Instance *inst, fmi2ValueReference vr, int type, const char *fn) {
    if (vr >= (fmi2ValueReference)NV) {
        log_msg(inst, fmi2Error, "logStatusError", "%s: unknown value reference %u", fn, (unsigned)vr);
        return NULL;
    }
    if (VARIABLES[vr].type != type) {
        log_msg(inst, fmi2Error, "logStatusError", "%s: variable '%s' (value reference %u) has another type",
                fn, VARIABLES[vr].name, (unsigned)vr);
        return NULL;
    }
    return &VARIABLES[vr];
}

static double *slot(Data *d, const VariableInfo *v) {
    if (v->kind == KIND_PARAMETER) return &d->p[v->index];
    if (v->kind == KIND_INPUT) return &d->u[v->index];
    return &d->y[v->index];
}

static fmi2Status get_values(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, int type,
                             const char *fn, fmi2Real *r, fmi2Integer *n, fmi2Boolean *b) {
    size_t i;
    CHECK(c, fn, ST_INITIALIZATION | ST_STEP_COMPLETE | ST_TERMINATED | ST_ERROR);
    if (nvr > 0 && (!vr || (!r && !n && !b))) return ERROR(inst, "%s: NULL array argument", fn);
    for (i = 0; i < nvr; i++)
        if (!lookup(inst, vr[i], type, fn)) return fmi2Error;
    if (!update_outputs(inst)) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        double v = *slot(&inst->d, &VARIABLES[vr[i]]);
        if (r) r[i] = v;
        else if (n) n[i] = (fmi2Integer)v;
        else b[i] = v != 0.0 ? fmi2True : fmi2False;
    }
    return fmi2OK;
}

static fmi2Status check_value(Instance *inst, const VariableInfo *v, double value, const char *fn) {
    if (v->kind == KIND_OUTPUT)
        return ERROR(inst, "%s: variable '%s' is an output and cannot be set", fn, v->name);
    if (v->kind == KIND_PARAMETER && !(inst->d.state & (ST_INSTANTIATED | ST_INITIALIZATION)))
        return ERROR(inst, "%s: parameter '%s' has variability fixed and cannot be set in state %s", fn,
                     v->name, state_name(inst->d.state));
    if (!(inst->d.state & (ST_INSTANTIATED | ST_INITIALIZATION | ST_STEP_COMPLETE)))
        return ERROR(inst, "%s: '%s' cannot be set in state %s", fn, v->name, state_name(inst->d.state));
    if (!isfinite(value))
        return ERROR(inst, "%s: variable '%s' set to non-finite value %g", fn, v->name, value);
    if (value < v->min || value > v->max)
        return ERROR(inst, "%s: variable '%s' = %g is outside its range [%g, %g]", fn, v->name, value,
                     v->min, v->max);
    return fmi2OK;
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
        if (!v || check_value(inst, v, value, fn) != fmi2OK) return fmi2Error;
    }
    for (i = 0; i < nvr; i++)
        *slot(&inst->d, &VARIABLES[vr[i]]) = r ? r[i] : (n ? (double)n[i] : (b[i] ? 1.0 : 0.0));
    inst->d.outputs_valid = 0;
    inst->d.sample_due = NH > 0 && inst->d.at_instant;
    return fmi2OK;
}

/* ------------------------------------------------------------------ FMI API */
const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    static const char *known[] = {"logStatusWarning", "logStatusDiscard", "logStatusError",
                                  "logStatusFatal", "logAll"};
    size_t i, k;
    CHECK(c, "fmi2SetDebugLogging", ~0);
    for (i = 0; i < nCategories; i++) {
        int found = 0;
        if (!categories || !categories[i]) return ERROR(inst, "fmi2SetDebugLogging: NULL category");
        for (k = 0; k < sizeof known / sizeof known[0]; k++) found |= strcmp(categories[i], known[k]) == 0;
        if (!found) return ERROR(inst, "fmi2SetDebugLogging: unknown log category '%s'", categories[i]);
    }
    inst->log_on = loggingOn ? 1 : 0;
    return fmi2OK;
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
    inst = (Instance *)calloc(1, sizeof *inst);
    if (!inst) return NULL;
    inst->instance_name = (char *)malloc(strlen(instanceName) + 1);
    if (!inst->instance_name) { free(inst); return NULL; }
    strcpy(inst->instance_name, instanceName);
    inst->logger = tmp.logger;
    inst->env = tmp.env;
    inst->log_on = loggingOn ? 1 : 0;
    set_defaults(&inst->d);
    return inst;
}

void fmi2FreeInstance(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (!inst) return;
    free(inst->instance_name);
    free(inst);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    CHECK(c, "fmi2SetupExperiment", ST_INSTANTIATED);
    (void)toleranceDefined;
    (void)tolerance;
    if (!isfinite(startTime)) return ERROR(inst, "fmi2SetupExperiment: non-finite startTime");
    if (stopTimeDefined && !(stopTime >= startTime))
        return ERROR(inst, "fmi2SetupExperiment: stopTime %g before startTime %g", stopTime, startTime);
    inst->d.time = startTime;
    inst->d.start_time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    CHECK(c, "fmi2EnterInitializationMode", ST_INSTANTIATED);
    inst->d.state = ST_INITIALIZATION;
    inst->d.outputs_valid = 0;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    CHECK(c, "fmi2ExitInitializationMode", ST_INITIALIZATION);
    initial_state(&inst->d);
    inst->d.state = ST_STEP_COMPLETE;
    inst->d.outputs_valid = 0;
    inst->d.at_instant = 1;
    inst->d.sample_due = NH > 0;
    if (NH > 0) inst->d.next_instant = instant_after(&inst->d, inst->d.time);
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    CHECK(c, "fmi2Terminate", ST_STEP_COMPLETE | ST_ERROR);
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
#define STATE_MASK (ST_INSTANTIATED | ST_INITIALIZATION | ST_STEP_COMPLETE | ST_TERMINATED | ST_ERROR)

/* A snapshot restores the call-order state too, so a corrupted one (e.g. state 0, which even
 * fmi2Reset refuses) is rejected; its parameters and inputs must pass fmi2SetReal's checks. */
static fmi2Status check_data(Instance *inst, const Data *d, const char *fn) {
    int i;
    if (d->magic != STATE_MAGIC) return ERROR(inst, "%s: not a state of this FMU", fn);
    if (d->state != ST_INSTANTIATED && d->state != ST_INITIALIZATION && d->state != ST_STEP_COMPLETE &&
        d->state != ST_TERMINATED && d->state != ST_ERROR)
        return ERROR(inst, "%s: corrupted state (invalid model state %d)", fn, d->state);
    if (!isfinite(d->time) || (d->outputs_valid != 0 && d->outputs_valid != 1))
        return ERROR(inst, "%s: corrupted state (time %g, flag %d)", fn, d->time, d->outputs_valid);
    if (!isfinite(d->start_time) || !isfinite(d->next_instant) || (d->at_instant != 0 && d->at_instant != 1) ||
        (d->sample_due != 0 && d->sample_due != 1))
        return ERROR(inst, "%s: corrupted state (sampling record)", fn);
    if (!all_finite(d->held_prev, NH) || !all_finite(d->p + NP, NH))
        return ERROR(inst, "%s: corrupted state (held values)", fn);
    for (i = 0; i < NV; i++) {
        const VariableInfo *v = &VARIABLES[i];
        double value;
        if (v->kind == KIND_OUTPUT) continue;
        value = v->kind == KIND_PARAMETER ? d->p[v->index] : d->u[v->index];
        if (!isfinite(value) || value < v->min || value > v->max)
            return ERROR(inst, "%s: corrupted state (variable '%s' = %g)", fn, v->name, value);
    }
    return fmi2OK;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    Data *copy;
    CHECK(c, "fmi2GetFMUstate", STATE_MASK);
    if (!FMUstate) return ERROR(inst, "fmi2GetFMUstate: NULL state pointer");
    copy = *FMUstate ? (Data *)*FMUstate : (Data *)malloc(sizeof(Data));
    if (!copy) return ERROR(inst, "fmi2GetFMUstate: out of memory");
    *copy = inst->d;
    *FMUstate = copy;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    CHECK(c, "fmi2SetFMUstate", STATE_MASK);
    if (!FMUstate) return ERROR(inst, "fmi2SetFMUstate: not a state of this FMU");
    if (check_data(inst, (const Data *)FMUstate, "fmi2SetFMUstate") != fmi2OK) return fmi2Error;
    inst->d = *(Data *)FMUstate;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    CHECK(c, "fmi2FreeFMUstate", STATE_MASK);
    if (FMUstate && *FMUstate) {
        free(*FMUstate);
        *FMUstate = NULL;
    }
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    CHECK(c, "fmi2SerializedFMUstateSize", STATE_MASK);
    if (!FMUstate || !size) return ERROR(inst, "fmi2SerializedFMUstateSize: NULL argument");
    *size = sizeof(Data);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size) {
    CHECK(c, "fmi2SerializeFMUstate", STATE_MASK);
    if (!FMUstate || !serializedState) return ERROR(inst, "fmi2SerializeFMUstate: NULL argument");
    if (size < sizeof(Data)) return ERROR(inst, "fmi2SerializeFMUstate: buffer of %zu bytes is too small", size);
    memcpy(serializedState, FMUstate, sizeof(Data));
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    Data tmp;
    CHECK(c, "fmi2DeSerializeFMUstate", STATE_MASK);
    if (!serializedState || !FMUstate) return ERROR(inst, "fmi2DeSerializeFMUstate: NULL argument");
    if (size != sizeof(Data)) return ERROR(inst, "fmi2DeSerializeFMUstate: %zu bytes, expected %zu", size, sizeof(Data));
    memcpy(&tmp, serializedState, sizeof(Data));
    if (check_data(inst, &tmp, "fmi2DeSerializeFMUstate") != fmi2OK) return fmi2Error;
    if (!*FMUstate) *FMUstate = malloc(sizeof(Data));
    if (!*FMUstate) return ERROR(inst, "fmi2DeSerializeFMUstate: out of memory");
    memcpy(*FMUstate, &tmp, sizeof(Data));
    return fmi2OK;
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

/* Integrate h seconds from the FMU time in RK4 substeps; the instance time ends at t_end. */
static fmi2Status integrate(Instance *inst, double h, double t_end) {
    const double t0 = inst->d.time;
    double n_sub, hs;
    long k, n;
    if (NX == 0) {
        inst->d.time = t_end;
        return fmi2OK;
    }
    n_sub = P_N_SUBSTEPS >= 0 ? inst->d.p[P_N_SUBSTEPS] : 1.0;
    if (P_H_MAX >= 0) n_sub = fmax(n_sub, ceil(h / inst->d.p[P_H_MAX]));
    if (n_sub > MAX_SUBSTEPS)
        return ERROR(inst, "fmi2DoStep: step %g s would need %g RK4 substeps (limit %g); raise h_max", h, n_sub,
                     MAX_SUBSTEPS);
    n = (long)n_sub;
    hs = h / (double)n;
    for (k = 0; k < n; k++) {
#if EXACT
        exact_substep(inst, hs, (k + 1 == n) ? t_end : t0 + (double)(k + 1) * hs);
#else
        rk4(&inst->d, hs);
        inst->d.time = (k + 1 == n) ? t_end : inst->d.time + hs;
#endif
    }
    if (!all_finite(inst->d.x, NX)) {
        inst->d.state = ST_ERROR;
        return ERROR(inst, "fmi2DoStep: the state became non-finite in the step from t = %g s with h = %g s "
                           "(%ld substeps); reduce the step or h_max, or restore an FMU state", t0, h, n);
    }
    return fmi2OK;
}

/* Integrate to t_end in segments between sample instants, sampling at each. */
static fmi2Status step_sampled(Instance *inst, double t_end) {
    const double tol = TIME_TOL * fmax(1.0, fabs(t_end));
    double t_next;
    if (inst->d.sample_due && !sample(inst)) return fmi2Error;
    for (;;) {
        t_next = inst->d.next_instant;
        if (t_next < t_end - tol) {
            if (integrate(inst, t_next - inst->d.time, t_next) != fmi2OK) return fmi2Error;
            inst->d.next_instant = instant_after(&inst->d, t_next);
            new_instant(&inst->d);
            if (!sample(inst)) return fmi2Error;
            continue;
        }
        if (integrate(inst, t_end - inst->d.time, t_end) != fmi2OK) return fmi2Error;
        inst->d.at_instant = fabs(t_next - t_end) <= tol;
        if (inst->d.at_instant) {
            inst->d.next_instant = instant_after(&inst->d, t_next);
            new_instant(&inst->d);
        }
        inst->d.sample_due = inst->d.at_instant;
        return fmi2OK;
    }
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    double h = communicationStepSize;
    fmi2Status status;
    CHECK(c, "fmi2DoStep", ST_STEP_COMPLETE);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!isfinite(h) || !(h > 0.0))
        return ERROR(inst, "fmi2DoStep: communicationStepSize must be finite and > 0, got %g", h);
    if (!isfinite(currentCommunicationPoint) ||
        fabs(currentCommunicationPoint - inst->d.time) > 1e-9 * fmax(1.0, fabs(inst->d.time)))
        return ERROR(inst, "fmi2DoStep: currentCommunicationPoint %.17g differs from the FMU time %.17g",
                     currentCommunicationPoint, inst->d.time);
    status = NH > 0 ? step_sampled(inst, currentCommunicationPoint + h)
                    : integrate(inst, h, currentCommunicationPoint + h);
    inst->d.outputs_valid = 0;
    return status;
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    CHECK(c, "fmi2CancelStep", STATE_MASK);
    return ERROR(inst, "fmi2CancelStep: fmi2DoStep is synchronous, there is nothing to cancel");
}

static fmi2Status no_status(fmi2Component c, const char *fn) {
    CHECK(c, fn, STATE_MASK);
    return ERROR(inst, "%s: fmi2DoStep is synchronous, no asynchronous status exists", fn);
}
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)s; (void)value;
    return no_status(c, "fmi2GetStatus");
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    Instance *inst = (Instance *)c;
    if (inst && s == fmi2LastSuccessfulTime && value) {
        *value = inst->d.time;
        return fmi2OK;
    }
    return no_status(c, "fmi2GetRealStatus");
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s; (void)value;
    return no_status(c, "fmi2GetIntegerStatus");
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    (void)s; (void)value;
    return no_status(c, "fmi2GetBooleanStatus");
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s; (void)value;
    return no_status(c, "fmi2GetStringStatus");
}
