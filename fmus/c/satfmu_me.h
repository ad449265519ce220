/*
 * satfmu: the model-exchange part of a plant's FMU, shared by its FMI 2.0 and FMI 3.0 interfaces
 * (fmi2_me.c, fmi3_me.c), which include it after satfmu_core.h. The importer's solver integrates
 * the continuous states; this part gives it the state, its derivatives and the event indicators
 * (model_event_indicators, from fmus/events.py) and handles the events. The model's C (model.h)
 * and satfmu_core.h's variable checks are those of the co-simulation FMU; its step functions (fixed
 * RK4 substeps, the exact flow) are not used here. Written for this project.
 *
 * Modes. The right-hand side may read the state at the start of an integration substep (a friction
 * mode frozen over it; satfmu.fmus.model.Model.previous): here that is the state at the last event,
 * held in `mode`. Each indicator's relations are read from its side (model_derivatives_sided,
 * model_outputs_sided: satfmu.fmus.events.sided), held from one event to the next, so the field is
 * smooth between events. At each event the post-step map is applied to the state with that mode
 * (the MRP set switched to its shadow, a wheel stopped in stiction, a momentum clamped at its
 * bound), the mode is taken anew from the result, and each indicator's side anew from its sign.
 *
 * Sliding (Filippov). Where an indicator g_k crosses zero and the fields of both its sides point
 * back at the surface g_k = 0 (a wheel at its speed limit: the command that spins it up is cut, its
 * friction pulls it back under the limit, the command acts again), the co-simulation FMU chatters
 * across the surface substep by substep, and a solver would meet an endless train of events. Here
 * the state slides on the surface instead: with S the sliding indicators, f0 the field with each of
 * them on its - side and f_m the field with m on its + side, the field is f0 + sum_m alpha_m (f_m - f0)
 * with the alphas that keep every g_k of S constant (dg_k/dt = 0: a linear system in the rates of the
 * indicators along the fields, each a central difference over RATE_STEP of the state's scale). The
 * outputs blend alike (a wheel's motor torque is the one that holds it at its limit). A sliding
 * indicator is seen by the solver as min(alpha_k, 1 - alpha_k) - HYSTERESIS: the slide ends at the
 * event where alpha_k leaves (0, 1), the state going to the side whose field then points away.
 *
 * Hysteresis. A solver stops where an indicator g is zero to its own precision, often exactly 0,
 * where the relation g > 0 of the post-step map has not changed yet (an MRP set at |sigma| = 1 is
 * not switched). So the indicator the solver sees is g + side * eps, with side the indicator's side
 * and eps = HYSTERESIS (1 + |g| at the event): it reaches zero only once g has crossed by eps,
 * where the relation has changed (|sigma|^2 - 1 = 1e-12: switched).
 *
 * Errors: a non-finite state, derivative or event indicator puts the instance in the error state
 * (never returned with OK); a call with a wrong count or a NULL array changes nothing.
 */
#if !defined(NZ)
#error "satfmu_me.h needs a model.h generated with its event indicators (NZ)"
#endif

#define HYSTERESIS 1e-12
#define RATE_STEP 1e-7 /* the central difference's step along a field, relative to the state's scale */

/* The continuous state, inputs or time changed: derivatives and outputs to be recomputed. */
static void me_changed(Instance *inst) {
    inst->dx_valid = 0;
    inst->d.outputs_valid = 0;
}

/* The indicators g at state x (the mode read as the state), without their offsets. */
static void me_raw_indicators(Instance *inst, const double *x, double *g) {
#if NZ > 0
    model_event_indicators(inst->d.time, x, x, inst->d.u, inst->d.p, g);
#else
    (void)inst;
    (void)x;
    (void)g;
#endif
}

/* The rate of change of every indicator along the field v at the instance's state: a central
 * difference. */
static void me_rates(Instance *inst, const double *v, double *r) {
    double xa[DIM(NX)], xb[DIM(NX)], ga[DIM(NZ)], gb[DIM(NZ)], scale = 0.0, size = 0.0, h;
    int i;
    for (i = 0; i < NX; i++) {
        scale = fmax(scale, fabs(inst->d.x[i]));
        size = fmax(size, fabs(v[i]));
    }
    if (!(size > 0.0)) {
        for (i = 0; i < NZ; i++) r[i] = 0.0;
        return;
    }
    h = RATE_STEP * (1.0 + scale) / size;
    for (i = 0; i < NX; i++) {
        xa[i] = inst->d.x[i] + h * v[i];
        xb[i] = inst->d.x[i] - h * v[i];
    }
    me_raw_indicators(inst, xa, ga);
    me_raw_indicators(inst, xb, gb);
    for (i = 0; i < NZ; i++) r[i] = (ga[i] - gb[i]) / (2.0 * h);
}

/* The sides with every indicator of `set` on its - side, and that of m (>= 0) on its + side. */
static void me_forced(const Instance *inst, const int *set, int m, double *s) {
    int k;
    for (k = 0; k < NZ; k++) s[k] = set[k] ? -1.0 : inst->sides[k];
    if (m >= 0) s[m] = 1.0;
}

/* Solves a x = b (n x n, row-major, destroyed) by Gaussian elimination with partial pivoting;
 * 0 when a is singular to working precision. */
static int me_solve(double *a, double *b, int n) {
    int i, j, k, pivot;
    double scale = 0.0;
    for (i = 0; i < n * n; i++) scale = fmax(scale, fabs(a[i]));
    for (k = 0; k < n; k++) {
        pivot = k;
        for (i = k + 1; i < n; i++)
            if (fabs(a[i * n + k]) > fabs(a[pivot * n + k])) pivot = i;
        if (!(fabs(a[pivot * n + k]) > 1e-12 * scale)) return 0;
        if (pivot != k) {
            double t;
            for (j = 0; j < n; j++) {
                t = a[k * n + j];
                a[k * n + j] = a[pivot * n + j];
                a[pivot * n + j] = t;
            }
            t = b[k];
            b[k] = b[pivot];
            b[pivot] = t;
        }
        for (i = k + 1; i < n; i++) {
            const double factor = a[i * n + k] / a[k * n + k];
            for (j = k; j < n; j++) a[i * n + j] -= factor * a[k * n + j];
            b[i] -= factor * b[k];
        }
    }
    for (k = n - 1; k >= 0; k--) {
        for (j = k + 1; j < n; j++) b[k] -= a[k * n + j] * b[j];
        b[k] /= a[k * n + k];
    }
    return 1;
}

/* The sliding blend of the indicators of `set` at the instance's state: alpha[k] for each k of the
 * set, and (f not NULL) the field. 0 when the blend is undetermined (the fields' rates singular). */
static int me_slide(Instance *inst, const int *set, double *alpha, double *f) {
    const Data *d = &inst->d;
    double s[DIM(NZ)], f0[DIM(NX)], diff[DIM(NZ)][DIM(NX)], r[DIM(NZ)], a[DIM(NZ) * DIM(NZ)], b[DIM(NZ)];
    int members[DIM(NZ)], n = 0, i, j, k;
    memset(b, 0, sizeof b);
    for (k = 0; k < NZ; k++)
        if (set[k]) members[n++] = k;
    me_forced(inst, set, -1, s);
    model_derivatives_sided(d->time, d->x, inst->mode, d->u, d->p, s, f0);
    me_rates(inst, f0, r);
    for (i = 0; i < n; i++) b[i] = -r[members[i]];
    for (j = 0; j < n; j++) {
        me_forced(inst, set, members[j], s);
        model_derivatives_sided(d->time, d->x, inst->mode, d->u, d->p, s, diff[j]);
        for (k = 0; k < NX; k++) diff[j][k] -= f0[k];
        me_rates(inst, diff[j], r);
        for (i = 0; i < n; i++) a[i * n + j] = r[members[i]];
    }
    if (!me_solve(a, b, n)) return 0;
    for (i = 0; i < n; i++) alpha[members[i]] = b[i];
    if (f) {
        for (k = 0; k < NX; k++) {
            f[k] = f0[k];
            for (j = 0; j < n; j++) f[k] += b[j] * diff[j][k];
        }
    }
    return 1;
}

/* The derivatives at the instance's time, state, inputs, mode and sides (the sliding blend when the
 * state slides); 0 (and the error state) when one is not finite or a blend is undetermined. */
static int me_derivatives(Instance *inst, const char *fn) {
    Data *d = &inst->d;
    int i;
    if (inst->dx_valid) return 1;
    if (NX > 0 && inst->n_sliding == 0) {
        model_derivatives_sided(d->time, d->x, inst->mode, d->u, d->p, inst->sides, inst->dx);
    } else if (NX > 0 && !me_slide(inst, inst->sliding, inst->alpha, inst->dx)) {
        d->state = ST_ERROR;
        log_msg(inst, STATUS_ERROR, "logStatusError", "%s: the sliding mode is undetermined at t = %.17g s (the "
                "switching fields' rates are singular)", fn, d->time);
        return 0;
    }
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

/* The outputs at the instance's state with its sides, blended as the field while the state slides. */
static int me_outputs(Instance *inst, double *y, const char *fn) {
    const Data *d = &inst->d;
    double s[DIM(NZ)], ym[DIM(NY)];
    int i, k;
    if (inst->n_sliding == 0) {
        model_outputs_sided(d->time, d->x, d->u, d->p, inst->sides, y);
        return 1;
    }
    if (!me_derivatives(inst, fn)) return 0; /* the blend's alphas */
    me_forced(inst, inst->sliding, -1, s);
    model_outputs_sided(d->time, d->x, d->u, d->p, s, y);
    for (k = 0; k < NZ; k++) {
        if (!inst->sliding[k]) continue;
        me_forced(inst, inst->sliding, k, s);
        model_outputs_sided(d->time, d->x, d->u, d->p, s, ym);
        for (i = 0; i < NY; i++) ym[i] -= y[i];
        for (i = 0; i < NY; i++) y[i] += inst->alpha[k] * ym[i];
    }
    return 1;
}

/* Whether a sliding blend keeps its indicators inside (0, 1), by HYSTERESIS. */
static int me_inside(const int *set, const double *alpha) {
    int k;
    for (k = 0; k < NZ; k++)
        if (set[k] && !(alpha[k] > HYSTERESIS && alpha[k] < 1.0 - HYSTERESIS)) return 0;
    return 1;
}

/* The indicators' sides at an event (initial: at the start, where nothing slides): a sliding one
 * leaves its surface when its alpha left (0, 1), to the - side at 0, the + side at 1; another one
 * that crossed slides when the blend with it holds, else takes its new side. Then the offsets. */
static void me_settle(Instance *inst, int initial) {
    double g[DIM(NZ)], alpha[DIM(NZ)];
    int k, trial[DIM(NZ)];
    me_raw_indicators(inst, inst->d.x, g);
    if (inst->n_sliding > 0 && me_slide(inst, inst->sliding, alpha, NULL)) {
        for (k = 0; k < NZ; k++) {
            if (!inst->sliding[k] || (alpha[k] > HYSTERESIS && alpha[k] < 1.0 - HYSTERESIS)) continue;
            inst->sliding[k] = 0;
            inst->sides[k] = alpha[k] <= HYSTERESIS ? -1.0 : 1.0;
        }
    }
    for (k = 0; k < NZ; k++) {
        const double side = g[k] > 0.0 ? 1.0 : g[k] < 0.0 ? -1.0 : 0.0;
        if (inst->sliding[k]) continue;
        if (!initial && side != 0.0 && inst->sides[k] != 0.0 && side != inst->sides[k]) {
            memcpy(trial, inst->sliding, sizeof trial);
            trial[k] = 1;
            if (me_slide(inst, trial, alpha, NULL) && me_inside(trial, alpha)) {
                inst->sliding[k] = 1;
                continue;
            }
        }
        inst->sides[k] = side;
    }
    inst->n_sliding = 0;
    for (k = 0; k < NZ; k++) {
        inst->n_sliding += inst->sliding[k];
        inst->offset[k] = inst->sides[k] * HYSTERESIS * (1.0 + fabs(g[k]));
    }
    me_changed(inst);
}

/* The indicators as the solver sees them: g + offset, or for a sliding one min(alpha, 1 - alpha)
 * - HYSTERESIS (its blend computed first). */
static int me_indicators(Instance *inst, double *g, const char *fn) {
    int k;
    if (inst->n_sliding > 0 && !me_derivatives(inst, fn)) return 0;
    me_raw_indicators(inst, inst->d.x, g);
    for (k = 0; k < NZ; k++)
        g[k] = inst->sliding[k] ? fmin(inst->alpha[k], 1.0 - inst->alpha[k]) - HYSTERESIS : g[k] + inst->offset[k];
    return 1;
}

/* Initialization Mode: the state is the initial one, and so are the mode and the sides (for
 * outputs and derivatives read there). */
static void me_initial(Instance *inst) {
    initial_state(&inst->d);
    memcpy(inst->mode, inst->d.x, sizeof inst->mode);
    memset(inst->sliding, 0, sizeof inst->sliding);
    inst->n_sliding = 0;
    me_settle(inst, 1);
}

/* The end of initialization (exit_initialization done): the mode is the initial state, the
 * indicators' sides taken there. */
static void me_start(Instance *inst) {
    memcpy(inst->mode, inst->d.x, sizeof inst->mode);
    memset(inst->sliding, 0, sizeof inst->sliding);
    inst->n_sliding = 0;
    me_settle(inst, 1);
}

/* The event (fmi2NewDiscreteStates, fmi3UpdateDiscreteStates): the post-step map with the mode of
 * the last event, then the mode and the sides anew. One pass: the map's result is a state the map
 * keeps (no further iteration is asked for). *moved tells whether the continuous state changed. */
static int me_event(Instance *inst, int *moved, const char *fn) {
    Data *d = &inst->d;
    double x[DIM(NX)];
    int i;
    *moved = 0;
    if (NX > 0) model_post_step(d->time, d->x, inst->mode, d->u, d->p, x);
    for (i = 0; i < NX; i++) {
        if (!isfinite(x[i])) {
            d->state = ST_ERROR;
            return ERROR(inst, "%s: state %d became non-finite (%g) at t = %.17g s", fn, i, x[i], d->time);
        }
        *moved |= x[i] != d->x[i];
    }
    if (NX > 0) {
        memcpy(d->x, x, sizeof x);
        memcpy(inst->mode, x, sizeof x);
    }
    me_settle(inst, 0);
    return STATUS_OK;
}

/* The time of the instance (fmi2SetTime, fmi3SetTime). */
static int me_set_time(Instance *inst, double time, const char *fn) {
    if (!isfinite(time)) return ERROR(inst, "%s: non-finite time %g", fn, time);
    inst->d.time = time;
    me_changed(inst);
    return STATUS_OK;
}

/* Whether an array argument holds `expected` values; a message if not. */
static int me_count_ok(Instance *inst, size_t n, size_t expected, const void *array, const char *fn) {
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

/* fmi2SetContinuousStates, fmi3SetContinuousStates: all finite, else nothing changes. */
static int me_set_states(Instance *inst, const double x[], size_t nx, const char *fn) {
    size_t i;
    if (!me_count_ok(inst, nx, (size_t)NX, x, fn)) return STATUS_ERROR;
    for (i = 0; i < nx; i++)
        if (!isfinite(x[i])) return ERROR(inst, "%s: state %zu is non-finite (%g)", fn, i, x[i]);
    for (i = 0; i < nx; i++) inst->d.x[i] = x[i];
    me_changed(inst);
    return STATUS_OK;
}

/* fmi2GetDerivatives, fmi3GetContinuousStateDerivatives. */
static int me_get_derivatives(Instance *inst, double dx[], size_t nx, const char *fn) {
    size_t i;
    if (!me_count_ok(inst, nx, (size_t)NX, dx, fn)) return STATUS_ERROR;
    if (!me_derivatives(inst, fn)) return STATUS_ERROR;
    for (i = 0; i < nx; i++) dx[i] = inst->dx[i];
    return STATUS_OK;
}

/* fmi2GetEventIndicators, fmi3GetEventIndicators: the indicators as the solver sees them. */
static int me_get_indicators(Instance *inst, double g[], size_t ni, const char *fn) {
    size_t i;
    if (!me_count_ok(inst, ni, (size_t)NZ, g, fn)) return STATUS_ERROR;
    if (!me_indicators(inst, g, fn)) return STATUS_ERROR;
    for (i = 0; i < ni; i++) {
        if (!isfinite(g[i])) {
            inst->d.state = ST_ERROR;
            return ERROR(inst, "%s: indicator %zu is non-finite (%g) at t = %.17g s", fn, i, g[i], inst->d.time);
        }
    }
    return STATUS_OK;
}

/* fmi2GetContinuousStates, fmi3GetContinuousStates (in Initialization Mode the initial state). */
static int me_get_states(Instance *inst, double x[], size_t nx, const char *fn) {
    size_t i;
    if (!me_count_ok(inst, nx, (size_t)NX, x, fn)) return STATUS_ERROR;
    if (inst->d.state == ST_INITIALIZATION) me_initial(inst);
    for (i = 0; i < nx; i++) x[i] = inst->d.x[i];
    return STATUS_OK;
}

/* fmi2GetNominalsOfContinuousStates, fmi3GetNominalsOfContinuousStates: 1 for every state. */
static int me_get_nominals(Instance *inst, double nominals[], size_t nx, const char *fn) {
    size_t i;
    if (!me_count_ok(inst, nx, (size_t)NX, nominals, fn)) return STATUS_ERROR;
    for (i = 0; i < nx; i++) nominals[i] = 1.0;
    return STATUS_OK;
}

/* Model-exchange variable k: k < NX the derivative of state k (as me_derivatives left it), NX <= k
 * < 2 NX state k - NX, 2 NX <= k < 2 NX + NZ event indicator k - 2 NX (as the solver sees it). */
static double me_variable(Instance *inst, int k) {
    double g[DIM(NZ)];
#if NX > 0
    if (k >= 0 && k < NX) return inst->dx[k];
    if (k >= NX && k < 2 * NX) return inst->d.x[k - NX];
#endif
    k -= 2 * NX;
    if (k < 0 || k >= NZ || !me_indicators(inst, g, "fmi3GetFloat64")) return NAN; /* the callers' views exclude it */
    return g[k];
}
