/*
 * satfmu: generic FMI 2.0 co-simulation wrapper for models generated from a symbolic
 * definition (fmus/model.py). The model-specific part (sizes, variable table, identity and the
 * functions model_derivatives, model_outputs, model_post_step) is generated into the header
 * model.h, which this file includes: this file is the FMU's only translation unit, so a tool may
 * compile every .c file under sources/ or the one <SourceFiles> lists. Written for this project.
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
 * last (A, tau), a tau within FLOW_TAU_RTOL of it reusing them. A substep ends early at
 * model_switch_time (the frozen law's validity),
 * measured as a duration from the substep start, so the result does not depend on the
 * absolute time.
 *
 * Sampling (NH > 0, a sampler of fmus/model.py): NH values are computed by model_sample (the
 * sampler's expressions, or its C routine on them, e.g. riccati.h's checked Riccati gain; a
 * refusal is an error with the routine's message) at the start and at the instants t_k = k * period - phase
 * (t_k = start + k * period without a phase parameter), k an integer count kept exactly in
 * a double (|k| < 2^52), and held in p[NP..NP+NH-1] in between; a step is integrated in
 * segments between instants. Every sample is taken from the inputs set for the step being
 * taken (FMI 2.0: the inputs set before fmi2DoStep(t, h) hold over [t, t + h)):
 *  - an instant inside a step, or at its start, is sampled from that step's inputs;
 *  - an instant at which a step ends (a communication point t_k) belongs to the next step: its
 *    values are computed from the inputs set at t_k, when first needed after one is set (an
 *    output read, as a feedthrough-order importer does) or else by the next fmi2DoStep, and
 *    again if an input changes there. Until an input is set at t_k (inputs_stale), an output
 *    read shows the values held from the previous instant: a Jacobi-order importer (every
 *    output read before any input is set, as libcosim and ecos) thus sees the feedthrough-order
 *    outputs one communication step later, never a sample of the previous step's inputs (which
 *    made a finite difference of two samples, B-dot's, exactly 0). A model without inputs, and
 *    the start time (inputs set in initialization mode), have no stale inputs.
 * The held values the expressions read are always those of the previous instant (held_prev),
 * so a repeated sample at one instant gives the same result as a single one. fmus/pyslave.py
 * does the same.
 *
 * Time: two times closer than time_tolerance(t) (model.h, satfmu.fmus.model.time_tolerance: 1e-9 |t|,
 * at most 1 us, at least 8 ulp of |t|) are one instant (a sample instant and a step end, a
 * breakpoint). fmi2DoStep refuses a currentCommunicationPoint farther than point_tol (8 ulp of
 * the larger of 1 s, |t| and |start|: what double precision forces when a master computes
 * t0 + k h and the FMU t_{k-1} + h) from the FMU time, a step that does not advance the time,
 * and (stopTime defined) a step past stopTime.
 *
 * Bounded work: one fmi2DoStep spans at most MAX_STEP_INSTANTS sample instants and takes at
 * most MAX_STEP_SUBSTEPS integration substeps (counted before anything changes); a longer step
 * is refused with fmi2Error, whatever h (up to DBL_MAX) and the sample period.
 *
 * FMU states: a snapshot is a Saved record: a magic number, the format version, the size,
 * the FMU identity (the 16 bytes of its GUID, MODEL_ID), a CRC-32 over
 * the whole record, then the instance data. fmi2SetFMUstate, fmi2SerializeFMUstate and
 * fmi2DeSerializeFMUstate check all of it, then the ranges (model state, finite time within
 * [start, stop], finite state outside the error state, parameters and inputs within their
 * declared ranges, the sample count consistent with the time); a failed check names what
 * failed, returns fmi2Error and leaves the instance as it was.
 *
 * Robustness: every call checks the instance pointer, the call order against the
 * FMI 2.0 co-simulation state machine, value references, types, finiteness and
 * declared ranges; a violation returns fmi2Error with a message naming the
 * variable and never changes the stored values. A step whose state becomes
 * non-finite, a sample with a non-finite value and a non-finite output put the instance in
 * the error state (fmi2SetFMUstate or fmi2Reset recover it): no output is ever non-finite
 * with fmi2OK.
 */
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

/* glibc floor of the Linux x86-64 binary: GLIBC_2.14 (memcpy), so that it loads on RHEL 8
 * (glibc 2.28) and older. glibc 2.29 gave pow, exp, log, exp2 and log2 a new default symbol
 * version (GLIBC_2.29) that drops the SVID error-handling wrapper; a binary linked against a newer
 * glibc asks for pow@GLIBC_2.29 (e.g. for the integer powers sympy prints as pow(x, 3)) and does
 * not load on glibc <= 2.28. Binding each to its original version GLIBC_2.2.5, which every x86-64
 * glibc keeps, removes that requirement for every exponent and every model, whatever the code
 * generator prints (it prints integer powers up to 8 as products, in C and Python alike, but
 * other exponents, exp and log still call the C library). On a newer glibc
 * the old version runs the same pow (only errno handling on overflow or a pole differs, and a
 * non-finite result is refused here anyway), so results are unchanged bit for bit. Only for glibc
 * on x86-64 Linux, where GLIBC_2.2.5 is the base version (not the win64 DLL, MinGW-w64's, whose
 * C library is msvcrt, nor GNU/Hurd); a directive for a function the model does not call adds
 * nothing. tests/test_glibc_floor.py checks every native FMU's binary. Only in satfmu's own build
 * (SATFMU_GLIBC_FLOOR, with libm on the link line): a binary rebuilt from sources/ by an importer
 * (fmpy compile, whose CMake links no libm) is for the glibc it is built on, and a versioned
 * reference without libm fails to link ("no symbol version section for versioned symbol"). */
#if defined(SATFMU_GLIBC_FLOOR) && defined(__linux__) && defined(__GLIBC__) && defined(__x86_64__)
__asm__(".symver pow,pow@GLIBC_2.2.5");
__asm__(".symver exp,exp@GLIBC_2.2.5");
__asm__(".symver log,log@GLIBC_2.2.5");
__asm__(".symver exp2,exp2@GLIBC_2.2.5");
__asm__(".symver log2,log2@GLIBC_2.2.5");
#endif

typedef struct {
    const char *name;
    int kind;   /* 0 parameter, 1 input, 2 output */
    int type;   /* 0 Real, 1 Integer, 2 Boolean */
    int index;  /* position in p[], u[] or y[] */
    double start, min, max;
} VariableInfo;

enum { KIND_PARAMETER = 0, KIND_INPUT = 1, KIND_OUTPUT = 2 };
enum { TYPE_REAL = 0, TYPE_INTEGER = 1, TYPE_BOOLEAN = 2 };

#include "model.h"

#define DIM(n) ((n) > 0 ? (n) : 1)

/* Work bounds of one fmi2DoStep. Measured (x86-64, gcc -O2, a step of 999,999 instants or
 * substeps): a sample instant of an expression sampler costs 12 ns (cubesat_bdot) to 22 ns
 * (cubesat_periodic_satfmu, its gain schedule), an RK4 substep 0.16 us (mrp_satellite) to 0.65 us
 * (magnetorquer_cubesat with its field model), so a step at either bound takes at most ~25 ms and
 * ~0.7 s. A routine sampler's instant costs far more (the online SDRE's Riccati solve: 0.12 ms):
 * model.h then bounds the instants at 1e4 (~1.2 s), as fmus/pyslave.py bounds a Python sampler's.
 * The far steps of the robustness suite (1e4 default steps: 1e4 instants, <= 8e5 substeps) stay
 * within them. */
#ifndef MAX_STEP_INSTANTS
#define MAX_STEP_INSTANTS 1000000.0
#endif
#define MAX_STEP_SUBSTEPS 1000000.0
#define INDEX_LIMIT 4503599627370496.0 /* 2^52: sample counts stay exact integers in a double */

#define STATE_MAGIC 0x73746655u /* "Ufts": a satfmu FMU state */
#define STATE_FORMAT 3u         /* layout of Saved; 2 had no inputs_stale, 1 was the unchecked Data */

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
    double time;
    double start_time;
    double stop_time;    /* +inf when the experiment defines none */
    double x[DIM(NX)];
    double u[DIM(NU)];
    double p[DIM(NP + NH)]; /* parameters, then the held values */
    double y[DIM(NY)];
    double held_prev[DIM(NH)]; /* the held values of the previous instant */
    double next_k;       /* index of the first sample instant after the FMU time (an integer) */
    int32_t state;
    int32_t outputs_valid;
    int32_t at_instant;  /* the FMU time is a sample instant */
    int32_t sample_due;  /* the held values of that instant are stale */
    int32_t inputs_stale; /* a step ended at that instant and no input has been set since */
} Data;

/* An FMU state (fmi2FMUstate points to one; serialized, it is these bytes). */
typedef struct {
    uint32_t magic;      /* STATE_MAGIC */
    uint32_t format;     /* STATE_FORMAT */
    uint32_t size;       /* sizeof(Saved) */
    uint32_t crc;        /* CRC-32 (IEEE 802.3, as zlib.crc32) of the record with this field 0 */
    unsigned char model_id[16]; /* MODEL_ID */
    Data d;
} Saved;

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
    d->state = ST_INSTANTIATED;
    d->stop_time = INFINITY;
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

/* The largest difference of a currentCommunicationPoint from the FMU time t, s (see the header). */
static double point_tol(const Data *d, double t) {
    return TIME_ULPS * DBL_EPSILON * fmax(1.0, fmax(fabs(t), fabs(d->start_time)));
}

/* ------------------------------------------------------------------ sampling */
static double sample_period(const Data *d) { return d->p[P_PERIOD > 0 ? P_PERIOD : 0]; }

/* t_k - k * period: -phase, or the start time without a phase parameter, s. */
static double instant_origin(const Data *d) {
    return P_PHASE >= 0 ? -d->p[P_PHASE > 0 ? P_PHASE : 0] : d->start_time;
}

/* The sample instant of index k, s: k * period - phase (start + k * period without a phase). */
static double instant_time(const Data *d, double k) {
    return P_PHASE >= 0 ? k * sample_period(d) - d->p[P_PHASE > 0 ? P_PHASE : 0]
                        : d->start_time + k * sample_period(d);
}

/* The index of the first instant later than t (by more than time_tolerance); -1 when the index is not
 * an exact integer (|(t - origin) / period| >= INDEX_LIMIT) or the period is not > 0. */
static double first_instant_after(const Data *d, double t) {
    const double period = sample_period(d), tol = time_tolerance(t);
    double k = floor((t - instant_origin(d)) / period) + 1.0;
    int i;
    if (!(period > 0.0) || !(fabs(k) < INDEX_LIMIT)) return -1.0;
    for (i = 0; i < 4 && instant_time(d, k - 1.0) > t + tol; i++) k -= 1.0; /* rounding of the quotient */
    for (i = 0; i < 4 && instant_time(d, k) <= t + tol; i++) k += 1.0;
    return k;
}

/* Held values of the current instant; 0 (and the error state) when the sample routine refuses
 * (its message is logged) or a value is not finite. */
static int sample(Instance *inst) {
    double held[DIM(NH)], pp[DIM(NP + NH)];
    char message[512];
    int i;
    Data *d = &inst->d;
    if (NH == 0) return 1;
    for (i = 0; i < NP; i++) pp[i] = d->p[i];
    for (i = 0; i < NH; i++) pp[NP + i] = d->held_prev[i];
    if (!model_sample(d->time, d->x, d->u, pp, held, message, sizeof message)) {
        d->state = ST_ERROR;
        log_msg(inst, fmi2Error, "logStatusError", "sample at t = %g s: %s", d->time, message);
        return 0;
    }
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

/* The outputs at the FMU time; 0 (and the error state, entered from any state) when a sample
 * or an output is not finite: no non-finite output is ever returned with fmi2OK. */
static int update_outputs(Instance *inst, const char *fn) {
    Data *d = &inst->d;
    int i;
    if (d->outputs_valid) return 1;
    if (d->state & (ST_INSTANTIATED | ST_INITIALIZATION)) initial_state(d);
    /* the instant that ended the last step waits for the inputs of the next one */
    if (d->sample_due && !d->inputs_stale && !sample(inst)) return 0;
    if (NY > 0) model_outputs(d->time, d->x, d->u, d->p, d->y);
    for (i = 0; i < NV; i++) {
        const VariableInfo *v = &VARIABLES[i];
        if (v->kind == KIND_OUTPUT && !isfinite(d->y[v->index])) {
            d->state = ST_ERROR;
            log_msg(inst, fmi2Error, "logStatusError", "%s: output '%s' is non-finite (%g) at t = %.17g s", fn,
                    v->name, d->y[v->index], d->time);
            return 0;
        }
    }
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

#define FLOW_TAU_RTOL 1e-9

/* Exact flow over tau seconds with the law frozen at the current state, then post_step. */
static void exact_segment(Instance *inst, double tau) {
    Data *d = &inst->d;
    FlowCache *fc = &inst->flow;
    double A[NX * NX], zero[NX], b[NX], xt[NX];
    int i, j;
    memset(zero, 0, sizeof zero);
    model_jacobian(d->time, d->x, d->x, d->u, d->p, A);
    model_derivatives(d->time, zero, d->x, d->u, d->p, b);
    /* a duration within FLOW_TAU_RTOL of the cached one reuses its flow: importers whose time
     * arithmetic makes each step differ in the last bits (t + h rounded, fmpy, fmusim) would
     * otherwise recompute it at every step (the state moves by its rate times the difference,
     * below 1e-12 s per step at 1 ms: the importer's own time error) */
    if (!fc->valid || fabs(fc->tau - tau) > FLOW_TAU_RTOL * fc->tau || memcmp(fc->A, A, sizeof A) != 0) {
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
 * (an uncut substep uses h itself, so a constant step size reuses the cached flow). The cuts
 * are durations from the substep start (a switch within 1e-9 max(1 s, h) of it is that
 * start's own), so the flow is the same at any absolute time. */
static void exact_substep(Instance *inst, double h, double t_end) {
    const double t0 = inst->d.time;
    double elapsed = 0.0;
    int n;
    for (n = 0; n < MAX_SWITCHES; n++) {
        double ts;
        model_switch_time(inst->d.time, inst->d.x, inst->d.u, inst->d.p, &ts);
        if (!(ts > TIME_TOL * fmax(1.0, h)) || ts >= h - elapsed) break;
        exact_segment(inst, ts);
        elapsed += ts;
        inst->d.time = t0 + elapsed;
    }
    exact_segment(inst, elapsed > 0.0 ? h - elapsed : h);
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
    inst->d.inputs_stale = 0;
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
    if (stopTimeDefined && !(isfinite(stopTime) && stopTime >= startTime))
        return ERROR(inst, "fmi2SetupExperiment: stopTime %g is not a finite time from startTime %g on", stopTime,
                     startTime);
    inst->d.time = startTime;
    inst->d.start_time = startTime;
    inst->d.stop_time = stopTimeDefined ? stopTime : INFINITY;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    CHECK(c, "fmi2EnterInitializationMode", ST_INSTANTIATED);
    inst->d.state = ST_INITIALIZATION;
    inst->d.outputs_valid = 0;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    double k = 0.0;
    CHECK(c, "fmi2ExitInitializationMode", ST_INITIALIZATION);
    if (NH > 0) {
        k = first_instant_after(&inst->d, inst->d.time);
        if (k < 0.0 || !(fabs(k) < INDEX_LIMIT))
            return ERROR(inst, "fmi2ExitInitializationMode: the sample instants k * %g s from the origin %g s "
                         "cannot be counted exactly at t = %g s", sample_period(&inst->d), instant_origin(&inst->d),
                         inst->d.time);
    }
    initial_state(&inst->d);
    inst->d.state = ST_STEP_COMPLETE;
    inst->d.outputs_valid = 0;
    inst->d.at_instant = 1;
    inst->d.sample_due = NH > 0;
    inst->d.inputs_stale = 0;
    inst->d.next_k = k;
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
#define STATE_MASK (ST_INSTANTIATED | ST_INITIALIZATION | ST_STEP_COMPLETE | ST_TERMINATED | ST_ERROR)

/* CRC-32 of IEEE 802.3 (reflected polynomial 0xEDB88320, as zlib.crc32), four bits at a time:
 * it detects every error burst of up to 32 bits, so every single-bit flip of a saved state. */
static uint32_t crc32_of(const unsigned char *bytes, size_t n) {
    static const uint32_t T[16] = {
        0x00000000u, 0x1db71064u, 0x3b6e20c8u, 0x26d930acu, 0x76dc4190u, 0x6b6b51f4u, 0x4db26158u, 0x5005713cu,
        0xedb88320u, 0xf00f9344u, 0xd6d6a3e8u, 0xcb61b38cu, 0x9b64c2b0u, 0x86d3d2d4u, 0xa00ae278u, 0xbdbdf21cu};
    uint32_t crc = 0xffffffffu;
    size_t i;
    for (i = 0; i < n; i++) {
        crc = (crc >> 4) ^ T[(crc ^ bytes[i]) & 15u];
        crc = (crc >> 4) ^ T[(crc ^ (bytes[i] >> 4)) & 15u];
    }
    return crc ^ 0xffffffffu;
}

/* CRC-32 of a record with its crc field taken as 0. */
static uint32_t saved_crc(const Saved *s) {
    Saved tmp;
    memcpy(&tmp, s, sizeof tmp);
    tmp.crc = 0;
    return crc32_of((const unsigned char *)&tmp, sizeof tmp);
}

static void save(const Data *d, Saved *s) {
    memset(s, 0, sizeof *s);
    s->magic = STATE_MAGIC;
    s->format = STATE_FORMAT;
    s->size = (uint32_t)sizeof(Saved);
    memcpy(s->model_id, MODEL_ID, sizeof s->model_id);
    memcpy(&s->d, d, sizeof *d);
    s->crc = saved_crc(s);
}

static int valid_flag(int32_t v) { return v == 0 || v == 1; }

/* The checks of a snapshot before it replaces the instance data: identity, integrity, ranges. */
static fmi2Status check_saved(Instance *inst, const Saved *s, const char *fn) {
    const Data *d = &s->d;
    double tol;
    int i;
    if (s->magic != STATE_MAGIC || s->format != STATE_FORMAT || s->size != sizeof(Saved))
        return ERROR(inst, "%s: not a state of this FMU (magic 0x%08x, format %u, size %u; expected 0x%08x, %u, %u)",
                     fn, (unsigned)s->magic, (unsigned)s->format, (unsigned)s->size, (unsigned)STATE_MAGIC,
                     (unsigned)STATE_FORMAT, (unsigned)sizeof(Saved));
    if (memcmp(s->model_id, MODEL_ID, sizeof s->model_id) != 0)
        return ERROR(inst, "%s: not a state of this FMU (the state of another model: its model identity differs "
                     "from this FMU's GUID %s)", fn, MODEL_GUID);
    if (s->crc != saved_crc(s))
        return ERROR(inst, "%s: corrupted state (checksum 0x%08x, computed 0x%08x)", fn, (unsigned)s->crc,
                     (unsigned)saved_crc(s));
    /* Below: a record with a valid checksum, so written by this FMU's code; the range checks
     * guard against a state saved by a faulty build of the same model. */
    if (d->state != ST_INSTANTIATED && d->state != ST_INITIALIZATION && d->state != ST_STEP_COMPLETE &&
        d->state != ST_TERMINATED && d->state != ST_ERROR)
        return ERROR(inst, "%s: corrupted state (invalid model state %d)", fn, (int)d->state);
    if (!valid_flag(d->outputs_valid) || !valid_flag(d->at_instant) || !valid_flag(d->sample_due) ||
        !valid_flag(d->inputs_stale) || (NH == 0 && (d->sample_due || d->inputs_stale)) ||
        (d->inputs_stale && !d->at_instant))
        return ERROR(inst, "%s: corrupted state (flags %d %d %d %d)", fn, (int)d->outputs_valid, (int)d->at_instant,
                     (int)d->sample_due, (int)d->inputs_stale);
    tol = time_tolerance(d->time);
    if (!isfinite(d->start_time) || !isfinite(d->time) || isnan(d->stop_time) || d->stop_time < d->start_time ||
        d->time < d->start_time - tol || d->time > d->stop_time + tol)
        return ERROR(inst, "%s: corrupted state (time %g s outside [start %g s, stop %g s])", fn, d->time,
                     d->start_time, d->stop_time);
    if (d->state != ST_ERROR && !all_finite(d->x, NX))
        return ERROR(inst, "%s: corrupted state (non-finite continuous state outside the error state)", fn);
    if (!all_finite(d->held_prev, NH) || !all_finite(d->p + NP, NH))
        return ERROR(inst, "%s: corrupted state (held values)", fn);
    if (NH > 0 && (d->state & (ST_STEP_COMPLETE | ST_TERMINATED)) && d->next_k != first_instant_after(d, d->time))
        return ERROR(inst, "%s: corrupted state (sample index %.17g, the time %.17g s gives %.17g)", fn, d->next_k,
                     d->time, first_instant_after(d, d->time));
    for (i = 0; i < NV; i++) {
        const VariableInfo *v = &VARIABLES[i];
        double value;
        if (v->kind == KIND_OUTPUT) {
            if (d->outputs_valid && d->state != ST_ERROR && !isfinite(d->y[v->index]))
                return ERROR(inst, "%s: corrupted state (output '%s' = %g)", fn, v->name, d->y[v->index]);
            continue;
        }
        value = v->kind == KIND_PARAMETER ? d->p[v->index] : d->u[v->index];
        if (!isfinite(value) || value < v->min || value > v->max)
            return ERROR(inst, "%s: corrupted state (variable '%s' = %g)", fn, v->name, value);
    }
    return fmi2OK;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    Saved *copy;
    CHECK(c, "fmi2GetFMUstate", STATE_MASK);
    if (!FMUstate) return ERROR(inst, "fmi2GetFMUstate: NULL state pointer");
    copy = *FMUstate ? (Saved *)*FMUstate : (Saved *)malloc(sizeof(Saved));
    if (!copy) return ERROR(inst, "fmi2GetFMUstate: out of memory");
    save(&inst->d, copy);
    *FMUstate = copy;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    CHECK(c, "fmi2SetFMUstate", STATE_MASK);
    if (!FMUstate) return ERROR(inst, "fmi2SetFMUstate: not a state of this FMU (NULL)");
    if (check_saved(inst, (const Saved *)FMUstate, "fmi2SetFMUstate") != fmi2OK) return fmi2Error;
    memcpy(&inst->d, &((const Saved *)FMUstate)->d, sizeof(Data));
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
    *size = sizeof(Saved);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size) {
    CHECK(c, "fmi2SerializeFMUstate", STATE_MASK);
    if (!FMUstate || !serializedState) return ERROR(inst, "fmi2SerializeFMUstate: NULL argument");
    if (size < sizeof(Saved)) return ERROR(inst, "fmi2SerializeFMUstate: buffer of %zu bytes is too small", size);
    if (check_saved(inst, (const Saved *)FMUstate, "fmi2SerializeFMUstate") != fmi2OK) return fmi2Error;
    memcpy(serializedState, FMUstate, sizeof(Saved));
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    Saved tmp;
    CHECK(c, "fmi2DeSerializeFMUstate", STATE_MASK);
    if (!serializedState || !FMUstate) return ERROR(inst, "fmi2DeSerializeFMUstate: NULL argument");
    if (size != sizeof(Saved))
        return ERROR(inst, "fmi2DeSerializeFMUstate: not a state of this FMU (%zu bytes, expected %zu)", size,
                     sizeof(Saved));
    memcpy(&tmp, serializedState, sizeof(Saved));
    if (check_saved(inst, &tmp, "fmi2DeSerializeFMUstate") != fmi2OK) return fmi2Error;
    if (!*FMUstate) *FMUstate = malloc(sizeof(Saved));
    if (!*FMUstate) return ERROR(inst, "fmi2DeSerializeFMUstate: out of memory");
    memcpy(*FMUstate, &tmp, sizeof(Saved));
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

/* Substeps of an integration over h seconds: max(n_substeps, ceil(h / h_max)); 1 for the exact
 * integrator (it has neither parameter), 0 without states. May exceed MAX_STEP_SUBSTEPS (or be
 * +inf): the caller checks before integrating. */
static double substeps(const Data *d, double h) {
    double n = P_N_SUBSTEPS >= 0 ? d->p[P_N_SUBSTEPS > 0 ? P_N_SUBSTEPS : 0] : 1.0;
    if (NX == 0) return 0.0;
    if (P_H_MAX >= 0) n = fmax(n, ceil(h / d->p[P_H_MAX > 0 ? P_H_MAX : 0]));
    return n;
}

/* Integrate h seconds from the FMU time in substeps (at most MAX_STEP_SUBSTEPS: checked by
 * fmi2DoStep); the instance time ends at t_end. */
static fmi2Status integrate(Instance *inst, double h, double t_end) {
    const double t0 = inst->d.time;
    long n, k;
    double hs;
    if (NX == 0) {
        inst->d.time = t_end;
        return fmi2OK;
    }
    n = (long)substeps(&inst->d, h);
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

/* The work of a step to t_end (h seconds) counted before anything changes: the index of the
 * last sample instant it reaches (k_end, NH > 0) and its substeps; fmi2Error past a bound. */
static fmi2Status plan_step(Instance *inst, double h, double t_end, double *k_end) {
    const Data *d = &inst->d;
    double n_sub;
    if (NH > 0) {
        const double period = sample_period(d), tol = time_tolerance(t_end);
        double count, k_after;
        if (!(period > 2.0 * tol))
            return ERROR(inst, "fmi2DoStep: the sample period %g s is below the time resolution at t = %.17g s "
                         "(instants closer than %g s are one)", period, t_end, tol);
        k_after = first_instant_after(d, t_end);
        if (k_after < 0.0)
            return ERROR(inst, "fmi2DoStep: h = %g s: the sample instants up to t = %g s cannot be counted exactly "
                         "(limit 2^52 periods)", h, t_end);
        *k_end = k_after - 1.0;
        count = *k_end - d->next_k + 1.0;
        if (count > MAX_STEP_INSTANTS)
            return ERROR(inst, "fmi2DoStep: h = %g s spans %.0f sample instants of %g s (limit %.0f); take shorter "
                         "communication steps", h, count, period, MAX_STEP_INSTANTS);
        /* every segment between instants lasts at most min(h, period) (one more substep for the
         * rounding of its length), and there are count + 1 segments */
        n_sub = (count + 1.0) * (substeps(d, fmin(h, period)) + (NX > 0 ? 1.0 : 0.0));
    } else {
        n_sub = substeps(d, h);
    }
    if (!(n_sub <= MAX_STEP_SUBSTEPS))
        return ERROR(inst, "fmi2DoStep: h = %g s would need %g integration substeps (limit %.0f); take shorter "
                     "communication steps or raise h_max", h, n_sub, MAX_STEP_SUBSTEPS);
    return fmi2OK;
}

/* Integrate to t_end in segments between the sample instants next_k .. k_end, sampling at each. */
static fmi2Status step_sampled(Instance *inst, double t_end, double k_end) {
    Data *d = &inst->d;
    const double tol = time_tolerance(t_end);
    if (d->sample_due && !sample(inst)) return fmi2Error;
    while (d->next_k <= k_end) {
        const double t_k = instant_time(d, d->next_k);
        if (t_k >= t_end - tol) break; /* the step ends at this instant */
        if (integrate(inst, t_k - d->time, t_k) != fmi2OK) return fmi2Error;
        d->next_k += 1.0;
        new_instant(d);
        if (!sample(inst)) return fmi2Error;
    }
    if (integrate(inst, t_end - d->time, t_end) != fmi2OK) return fmi2Error;
    d->at_instant = d->next_k <= k_end;
    if (d->at_instant) {
        d->next_k = k_end + 1.0;
        new_instant(d);
    }
    d->sample_due = d->at_instant;
    d->inputs_stale = d->at_instant && NU > 0; /* sampled from the inputs set for the next step */
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    const double h = communicationStepSize, t = currentCommunicationPoint;
    double t_end, tol, k_end = 0.0;
    fmi2Status status;
    CHECK(c, "fmi2DoStep", ST_STEP_COMPLETE);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!isfinite(h) || !(h > 0.0))
        return ERROR(inst, "fmi2DoStep: communicationStepSize must be finite and > 0, got %g", h);
    tol = isfinite(t) ? point_tol(&inst->d, fmax(fabs(t), fabs(inst->d.time))) : 0.0;
    if (!isfinite(t) || fabs(t - inst->d.time) > tol)
        return ERROR(inst, "fmi2DoStep: currentCommunicationPoint %.17g differs from the FMU time %.17g by %g s "
                     "(tolerance %g s)", t, inst->d.time, t - inst->d.time, tol);
    t_end = t + h;
    if (!isfinite(t_end) || !(t_end > t))
        return ERROR(inst, "fmi2DoStep: h = %g s from t = %.17g s does not reach a finite later time", h, t);
    if (t_end > inst->d.stop_time + time_tolerance(inst->d.stop_time))
        return ERROR(inst, "fmi2DoStep: the step to t = %.17g s passes stopTime %.17g s", t_end, inst->d.stop_time);
    if (plan_step(inst, h, t_end, &k_end) != fmi2OK) return fmi2Error;
    if (NH > 0) {
        status = step_sampled(inst, t_end, k_end);
    } else {
        status = integrate(inst, h, t_end);
    }
    inst->d.outputs_valid = 0;
    return status;
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
