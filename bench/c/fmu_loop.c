/* A bare C co-simulation loop over FMI 2.0 co-simulation FMUs: the peer of bench/cosim_speed.py.
 *
 * It makes the same calls as satfmu's master for a fixed-step run (the same FMUs, parameters,
 * transfers in the same order, profiles, recorded variables) with nothing else around them:
 * no Python, no checks beyond the status codes, the recording a plain array. It reads the
 * plan that bench/cosim_speed.py writes (whitespace-separated numbers and strings):
 *
 *   n_fmus
 *   per FMU: library_path guid resource_uri instance_name n_params, then per parameter:
 *            kind(r|i|b) value_reference value
 *   n_transfers, per transfer: src dst n, n source value references, n target value references
 *   n_records, per record set: fmu n, n value references
 *   n_profiles, per profile set: fmu n, n value references
 *   values_file step_size n_steps jacobi(0|1) repetitions
 *
 * values_file is binary float64: the communication times t_0 .. t_n (s), then the profile values,
 * (n_steps + 1) rows of every profile set's values in order.
 *
 * Each repetition instantiates, initializes, steps and frees the FMUs; the CPU time of the
 * step loop alone is printed (one line per repetition: "cpu_s <seconds>"), then the last
 * recorded row ("last <v1> <v2> ...", %.17g) so the bench checks that the loop computed what
 * the master computes.
 *
 * Build: gcc -O2 -o fmu_loop fmu_loop.c -ldl
 */
#define _POSIX_C_SOURCE 199309L
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef void (*Logger)(void *, const char *, int, const char *, const char *, ...);
typedef struct {
    Logger logger;
    void *(*allocate)(size_t, size_t);
    void (*free)(void *);
    void *step_finished;
    void *env;
} Callbacks;

typedef void *(*InstantiateFn)(const char *, int, const char *, const char *, const Callbacks *, int, int);
typedef void (*FreeFn)(void *);
typedef int (*SetupFn)(void *, int, double, double, int, double);
typedef int (*ModeFn)(void *);
typedef int (*DoStepFn)(void *, double, double, int);
typedef int (*GetRealFn)(void *, const unsigned *, size_t, double *);
typedef int (*SetRealFn)(void *, const unsigned *, size_t, const double *);
typedef int (*SetIntFn)(void *, const unsigned *, size_t, const int *);

typedef struct {
    char lib[4096], guid[256], uri[4096], name[256];
    void *dll, *c;
    InstantiateFn instantiate;
    FreeFn free_instance;
    SetupFn setup;
    ModeFn enter_init, exit_init, terminate;
    DoStepFn do_step;
    GetRealFn get_real;
    SetRealFn set_real;
    SetIntFn set_integer, set_boolean;
    int n_params;
    char *kinds;
    unsigned *pvr;
    double *pval;
} Fmu;

typedef struct { int src, dst; size_t n; unsigned *svr, *dvr; double *buf; } Transfer;
typedef struct { int fmu; size_t n; unsigned *vr; double *buf; } Set;

static void logger(void *env, const char *instance, int status, const char *category, const char *message, ...) {
    (void)env; (void)category;
    if (status > 1) {
        va_list ap;
        va_start(ap, message);
        fprintf(stderr, "[%s] ", instance);
        vfprintf(stderr, message, ap);
        fprintf(stderr, "\n");
        va_end(ap);
    }
}

static void die(const char *what) { fprintf(stderr, "fmu_loop: %s\n", what); exit(2); }

static void *sym(void *dll, const char *name) {
    void *f = dlsym(dll, name);
    if (!f) die(name);
    return f;
}

static void check(int status, const char *what) { if (status > 1) die(what); }

static void read_vrs(FILE *in, size_t n, unsigned *out) {
    for (size_t i = 0; i < n; i++) if (fscanf(in, "%u", &out[i]) != 1) die("plan: value reference");
}

int main(int argc, char **argv) {
    if (argc != 2) die("usage: fmu_loop PLAN");
    FILE *in = fopen(argv[1], "r");
    if (!in) die("cannot open the plan");
    int n_fmus, n_tr, n_rec, n_prof;
    if (fscanf(in, "%d", &n_fmus) != 1) die("plan: n_fmus");
    Fmu *fmus = calloc((size_t)n_fmus, sizeof(Fmu));
    for (int i = 0; i < n_fmus; i++) {
        Fmu *f = &fmus[i];
        if (fscanf(in, "%4095s %255s %4095s %255s %d", f->lib, f->guid, f->uri, f->name, &f->n_params) != 5)
            die("plan: FMU line");
        f->kinds = calloc((size_t)f->n_params + 1, 1);
        f->pvr = calloc((size_t)f->n_params + 1, sizeof(unsigned));
        f->pval = calloc((size_t)f->n_params + 1, sizeof(double));
        for (int j = 0; j < f->n_params; j++)
            if (fscanf(in, " %c %u %lf", &f->kinds[j], &f->pvr[j], &f->pval[j]) != 3) die("plan: parameter");
        f->dll = dlopen(f->lib, RTLD_NOW | RTLD_LOCAL);
        if (!f->dll) die(dlerror());
        f->instantiate = (InstantiateFn)sym(f->dll, "fmi2Instantiate");
        f->free_instance = (FreeFn)sym(f->dll, "fmi2FreeInstance");
        f->setup = (SetupFn)sym(f->dll, "fmi2SetupExperiment");
        f->enter_init = (ModeFn)sym(f->dll, "fmi2EnterInitializationMode");
        f->exit_init = (ModeFn)sym(f->dll, "fmi2ExitInitializationMode");
        f->terminate = (ModeFn)sym(f->dll, "fmi2Terminate");
        f->do_step = (DoStepFn)sym(f->dll, "fmi2DoStep");
        f->get_real = (GetRealFn)sym(f->dll, "fmi2GetReal");
        f->set_real = (SetRealFn)sym(f->dll, "fmi2SetReal");
        f->set_integer = (SetIntFn)sym(f->dll, "fmi2SetInteger");
        f->set_boolean = (SetIntFn)sym(f->dll, "fmi2SetBoolean");
    }
    if (fscanf(in, "%d", &n_tr) != 1) die("plan: n_transfers");
    Transfer *tr = calloc((size_t)n_tr + 1, sizeof(Transfer));
    for (int i = 0; i < n_tr; i++) {
        if (fscanf(in, "%d %d %zu", &tr[i].src, &tr[i].dst, &tr[i].n) != 3) die("plan: transfer");
        tr[i].svr = calloc(tr[i].n, sizeof(unsigned));
        tr[i].dvr = calloc(tr[i].n, sizeof(unsigned));
        tr[i].buf = calloc(tr[i].n, sizeof(double));
        read_vrs(in, tr[i].n, tr[i].svr);
        read_vrs(in, tr[i].n, tr[i].dvr);
    }
    size_t n_cols = 0;
    if (fscanf(in, "%d", &n_rec) != 1) die("plan: n_records");
    Set *rec = calloc((size_t)n_rec + 1, sizeof(Set));
    for (int i = 0; i < n_rec; i++) {
        if (fscanf(in, "%d %zu", &rec[i].fmu, &rec[i].n) != 2) die("plan: record");
        rec[i].vr = calloc(rec[i].n, sizeof(unsigned));
        read_vrs(in, rec[i].n, rec[i].vr);
        rec[i].buf = calloc(rec[i].n, sizeof(double));
        n_cols += rec[i].n;
    }
    size_t n_prof_cols = 0;
    if (fscanf(in, "%d", &n_prof) != 1) die("plan: n_profiles");
    Set *prof = calloc((size_t)n_prof + 1, sizeof(Set));
    for (int i = 0; i < n_prof; i++) {
        if (fscanf(in, "%d %zu", &prof[i].fmu, &prof[i].n) != 2) die("plan: profile");
        prof[i].vr = calloc(prof[i].n, sizeof(unsigned));
        read_vrs(in, prof[i].n, prof[i].vr);
        n_prof_cols += prof[i].n;
    }
    char values_file[4096];
    double h;
    long n_steps;
    int jacobi, reps;
    if (fscanf(in, "%4095s %lf %ld %d %d", values_file, &h, &n_steps, &jacobi, &reps) != 5) die("plan: run");
    fclose(in);
    size_t n_rows = (size_t)n_steps + 1;
    double *times = malloc(n_rows * sizeof(double));
    double *pvalues = malloc(n_rows * (n_prof_cols ? n_prof_cols : 1) * sizeof(double));
    FILE *vf = fopen(values_file, "rb");
    if (!vf) die("cannot open the values file");
    if (fread(times, sizeof(double), n_rows, vf) != n_rows) die("values file: short (times)");
    if (fread(pvalues, sizeof(double), n_rows * n_prof_cols, vf) != n_rows * n_prof_cols) die("values file: short (profiles)");
    fclose(vf);
    double *data = malloc(n_rows * (n_cols ? n_cols : 1) * sizeof(double));
    Callbacks cb = {logger, calloc, free, NULL, NULL};

    for (int r = 0; r < reps; r++) {
        for (int i = 0; i < n_fmus; i++) {
            Fmu *f = &fmus[i];
            f->c = f->instantiate(f->name, 1, f->guid, f->uri, &cb, 0, 0);
            if (!f->c) die("fmi2Instantiate");
            for (int j = 0; j < f->n_params; j++) {
                if (f->kinds[j] == 'r') check(f->set_real(f->c, &f->pvr[j], 1, &f->pval[j]), "fmi2SetReal (parameter)");
                else {
                    int v = (int)f->pval[j];
                    check((f->kinds[j] == 'i' ? f->set_integer : f->set_boolean)(f->c, &f->pvr[j], 1, &v), "fmi2Set (parameter)");
                }
            }
            check(f->setup(f->c, 0, 0.0, times[0], 1, times[n_steps]), "fmi2SetupExperiment");
            check(f->enter_init(f->c), "fmi2EnterInitializationMode");
        }
        /* profiles and transfers at t0 in feedthrough order, then exit initialization */
        size_t off0 = 0;
        for (int i = 0; i < n_prof; i++) {
            check(fmus[prof[i].fmu].set_real(fmus[prof[i].fmu].c, prof[i].vr, prof[i].n, pvalues + off0), "profile");
            off0 += prof[i].n;
        }
        for (int i = 0; i < n_tr; i++) {
            check(fmus[tr[i].src].get_real(fmus[tr[i].src].c, tr[i].svr, tr[i].n, tr[i].buf), "get");
            check(fmus[tr[i].dst].set_real(fmus[tr[i].dst].c, tr[i].dvr, tr[i].n, tr[i].buf), "set");
        }
        for (int i = 0; i < n_fmus; i++) check(fmus[i].exit_init(fmus[i].c), "fmi2ExitInitializationMode");
        struct timespec a, b;
        clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &a);
        for (long k = 0; k < n_steps; k++) {
            for (int i = 0; i < n_fmus; i++) check(fmus[i].do_step(fmus[i].c, times[k], h, 1), "fmi2DoStep");
            const double *pv = pvalues + (size_t)(k + 1) * n_prof_cols;
            if (!jacobi) {
                size_t off = 0;
                for (int i = 0; i < n_prof; i++, off += prof[i - 1].n)
                    check(fmus[prof[i].fmu].set_real(fmus[prof[i].fmu].c, prof[i].vr, prof[i].n, pv + off), "profile");
                for (int i = 0; i < n_tr; i++) {
                    check(fmus[tr[i].src].get_real(fmus[tr[i].src].c, tr[i].svr, tr[i].n, tr[i].buf), "get");
                    check(fmus[tr[i].dst].set_real(fmus[tr[i].dst].c, tr[i].dvr, tr[i].n, tr[i].buf), "set");
                }
            } else {
                for (int i = 0; i < n_tr; i++)
                    check(fmus[tr[i].src].get_real(fmus[tr[i].src].c, tr[i].svr, tr[i].n, tr[i].buf), "get");
                size_t off = 0;
                for (int i = 0; i < n_prof; i++, off += prof[i - 1].n)
                    check(fmus[prof[i].fmu].set_real(fmus[prof[i].fmu].c, prof[i].vr, prof[i].n, pv + off), "profile");
                for (int i = 0; i < n_tr; i++)
                    check(fmus[tr[i].dst].set_real(fmus[tr[i].dst].c, tr[i].dvr, tr[i].n, tr[i].buf), "set");
            }
            double *row = data + (size_t)(k + 1) * n_cols;
            for (int i = 0; i < n_rec; i++) {
                check(fmus[rec[i].fmu].get_real(fmus[rec[i].fmu].c, rec[i].vr, rec[i].n, row), "get (record)");
                row += rec[i].n;
            }
        }
        clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &b);
        printf("cpu_s %.9f\n", (double)(b.tv_sec - a.tv_sec) + 1e-9 * (double)(b.tv_nsec - a.tv_nsec));
        for (int i = 0; i < n_fmus; i++) {
            check(fmus[i].terminate(fmus[i].c), "fmi2Terminate");
            fmus[i].free_instance(fmus[i].c);
        }
    }
    printf("last");
    for (size_t j = 0; j < n_cols; j++) printf(" %.17g", data[(size_t)n_steps * n_cols + j]);
    printf("\n");
    return 0;
}
