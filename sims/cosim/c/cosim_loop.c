/* The fixed-step loop of satfmu's co-simulation master (sims/cosim/master.py), in C.
 *
 * The master loads the FMUs through fmpy, instantiates and initializes them, and prepares
 * the step plan: the FMUs' fmi2DoStep/fmi2GetReal/fmi2SetReal function pointers and
 * instances, the connection transfers in propagation order, the communication times and
 * profile values of the points the steps reach (the whole grid, or one block's: k0 is the
 * first point they hold) and the recorded variables. satfmu_cosim_steps then runs the steps
 * k_begin..k_end-1 exactly as the master's Python loop does, call for call and value for
 * value, so both give the same results bit for bit:
 *
 *   for each step k: fmi2DoStep(t_k, h) on every FMU in order; then, at t_{k+1},
 *     feedthrough order: profiles set, then each transfer read and set in level order;
 *     Jacobi order: every transfer read, then profiles set, then every transfer set;
 *   then, if k + 1 is a recorded step, every recorded variable read into its column.
 *
 * The first call that returns a status above fmi2Warning stops the loop: the step, the
 * FMU, the function and the status are returned in the plan, and the Python side raises
 * the error the master raises for it. Nothing here allocates: every buffer is the caller's.
 * Only standard C and the FMI 2.0 function signatures are used.
 */
#include <stddef.h>

typedef int (*DoStepFn)(void *, double, double, int);
typedef int (*GetRealFn)(void *, const unsigned int *, size_t, double *);
typedef int (*SetRealFn)(void *, const unsigned int *, size_t, const double *);

enum { CALL_DO_STEP = 1, CALL_GET_REAL = 2, CALL_SET_REAL = 3 };
enum { STATUS_WARNING = 1 };

typedef struct {
    void *instance;       /* fmi2Component */
    DoStepFn do_step;
    GetRealFn get_real;
    SetRealFn set_real;
} Fmu;

typedef struct {          /* outputs of one FMU -> inputs of another, one level of propagation */
    int src, dst;         /* FMU indices */
    size_t n;
    const unsigned int *src_vr, *dst_vr;
    double *buf;          /* n values */
} Transfer;

typedef struct {          /* the profile inputs of one FMU */
    int fmu;
    size_t n;
    const unsigned int *vr;
    const double *values; /* the block's points x n, row k - k0 = the values at t_k */
    double *buf;          /* n values */
} ProfileSet;

typedef struct {          /* the recorded variables of one FMU */
    int fmu;
    size_t n;
    const unsigned int *vr;
    const long *cols;     /* column of each variable in data */
    double *buf;          /* n values */
} RecordSet;

typedef struct {
    int n_fmus;
    const Fmu *fmus;
    int n_transfers;
    const Transfer *transfers;
    int n_profiles;
    const ProfileSet *profiles;
    int n_records;
    const RecordSet *records;
    const double *times;  /* t_k0 .. t_k1 of the block of steps run (k0 .. k1 - 1), s */
    double step_size;     /* s */
    long n_steps;
    int jacobi;           /* 1: Jacobi exchange order, 0: feedthrough order */
    long record_every;    /* record t_k when k % record_every == 0, and t_{n_steps} */
    double *data;         /* recorded rows row0, row0 + 1, ... x n_cols, row-major */
    long n_cols;
    long row0;            /* the recorded row data's first row holds (0, or a streamed block's first) */
    long k0;              /* the point times[0] and each profile's values' first row are at */
    /* set when a call fails */
    long failed_step;
    int failed_fmu;
    int failed_call;
    int status;
} Plan;

static int fail(Plan *p, long k, int fmu, int call, int status) {
    p->failed_step = k;
    p->failed_fmu = fmu;
    p->failed_call = call;
    p->status = status;
    return status;
}

static int set_profiles(Plan *p, long k) {
    for (int i = 0; i < p->n_profiles; i++) {
        const ProfileSet *s = &p->profiles[i];
        const Fmu *f = &p->fmus[s->fmu];
        const double *row = s->values + (size_t)(k - p->k0) * s->n;
        for (size_t j = 0; j < s->n; j++) s->buf[j] = row[j];
        int st = f->set_real(f->instance, s->vr, s->n, s->buf);
        if (st > STATUS_WARNING) return fail(p, k, s->fmu, CALL_SET_REAL, st);
    }
    return 0;
}

static int get_transfer(Plan *p, long k, const Transfer *t) {
    const Fmu *f = &p->fmus[t->src];
    int st = f->get_real(f->instance, t->src_vr, t->n, t->buf);
    return st > STATUS_WARNING ? fail(p, k, t->src, CALL_GET_REAL, st) : 0;
}

static int set_transfer(Plan *p, long k, const Transfer *t) {
    const Fmu *f = &p->fmus[t->dst];
    int st = f->set_real(f->instance, t->dst_vr, t->n, t->buf);
    return st > STATUS_WARNING ? fail(p, k, t->dst, CALL_SET_REAL, st) : 0;
}

/* Profiles and connections at t_k (the master's exchange()). */
static int exchange(Plan *p, long k) {
    if (!p->jacobi) {
        if (set_profiles(p, k)) return p->status;
        for (int i = 0; i < p->n_transfers; i++) {
            if (get_transfer(p, k, &p->transfers[i]) || set_transfer(p, k, &p->transfers[i])) return p->status;
        }
        return 0;
    }
    for (int i = 0; i < p->n_transfers; i++)
        if (get_transfer(p, k, &p->transfers[i])) return p->status;
    if (set_profiles(p, k)) return p->status;
    for (int i = 0; i < p->n_transfers; i++)
        if (set_transfer(p, k, &p->transfers[i])) return p->status;
    return 0;
}

/* The recorded variables at t_k into their row (the master's sample()). */
static int record(Plan *p, long k, long row) {
    double *out = p->data + (size_t)(row - p->row0) * (size_t)p->n_cols;
    for (int i = 0; i < p->n_records; i++) {
        const RecordSet *r = &p->records[i];
        const Fmu *f = &p->fmus[r->fmu];
        int st = f->get_real(f->instance, r->vr, r->n, r->buf);
        if (st > STATUS_WARNING) return fail(p, k, r->fmu, CALL_GET_REAL, st);
        for (size_t j = 0; j < r->n; j++) out[r->cols[j]] = r->buf[j];
    }
    return 0;
}

/* Steps k = k_begin .. k_end - 1 (each from t_k to t_{k+1}); returns 0, or the status of the
 * call that failed (above fmi2Warning), described in the plan's failed_* fields. */
int satfmu_cosim_steps(Plan *p, long k_begin, long k_end) {
    for (long k = k_begin; k < k_end; k++) {
        for (int i = 0; i < p->n_fmus; i++) {
            const Fmu *f = &p->fmus[i];
            int st = f->do_step(f->instance, p->times[k - p->k0], p->step_size, 1);
            if (st > STATUS_WARNING) return fail(p, k, i, CALL_DO_STEP, st);
        }
        if (exchange(p, k + 1)) return p->status;
        if ((k + 1) % p->record_every == 0 || k + 1 == p->n_steps) {
            long row = (k + 1 + p->record_every - 1) / p->record_every;
            if (record(p, k + 1, row)) return p->status;
        }
    }
    return 0;
}
