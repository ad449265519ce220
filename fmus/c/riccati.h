/*
 * satfmu: checked solution of the continuous-time algebraic Riccati equation, the sample routine
 * of the native online SDRE controller FMUs. Written for this project; the C twin of
 * controllers/riccati.py (riccati_gain and sampled_gain), with the same data, checks,
 * tolerances and messages.
 *
 * Included by model.h after it defines SAMPLER_N (state dimension n) and SAMPLER_M (input
 * dimension m); every function is static, so this header is no translation unit of its own.
 *
 * riccati_sampled_gain(v, held, message, size) reads A (n x n, row-major), B (n x m), the
 * diagonals of Q (n) and R (m) and the shift eps (1/s) from v, solves
 *     As' P + P As + Q - P B R^-1 B' P = 0,   As = A - eps I,
 * for the stabilizing P and writes K = R^-1 B' P (m x n, row-major), the relative residual and
 * the largest real part of the eigenvalues of A - B K (1/s) to held. It returns 0 and a message
 * when the data are not finite, the solve fails, or a check fails:
 *   - relative residual |As'P + P As + Q - P B K|_F / max(1, |Q|_F, |P|_F) <= 1e-8;
 *   - P positive semidefinite: smallest eigenvalue of (P + P')/2 > -1e-8 max(1, |P|_F);
 *   - As - B K stable (every real part < 0);
 *   - A - B K: largest real part <= 1e-6 1/s (an uncontrollable mode of A at 0 stays at 0);
 *   - largest gain entry <= 1e6.
 *
 * Method: the matrix sign function of the Hamiltonian H = [[As, -G], [-Q, -As']], G = B R^-1 B',
 * by Newton's iteration Z <- (Z / g + g Z^-1) / 2 with determinant scaling g = |det Z|^(1/2n)
 * (dropped once the iteration is in its quadratic phase); the stable invariant subspace
 * [I; P] is the null space of sign(H) + I, so P solves the least-squares system
 * [W12; W22 + I] P = -[W11 + I; W21] (Householder QR). Newton-Kleinman steps then refine P
 * (Acl' D + D Acl = -Res(P), Acl = As - B K, solved as an n^2 linear system) while the residual
 * falls; the P of smallest residual is kept. Eigenvalues (for the checks) come from a Householder
 * reduction to Hessenberg form and Francis double-shift QR steps. No allocation: every array has
 * a size fixed by SAMPLER_N and SAMPLER_M.
 */
#ifndef SATFMU_RICCATI_H
#define SATFMU_RICCATI_H

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#define RIC_N SAMPLER_N
#define RIC_M SAMPLER_M
#define RIC_2N (2 * RIC_N)
#define RIC_NN (RIC_N * RIC_N)
#define RIC_RESIDUAL_TOL 1e-8 /* controllers/riccati.py riccati_gain: residual_tol */
#define RIC_MAX_RE_TOL 1e-6   /* max_re_tol, 1/s */
#define RIC_GAIN_LIMIT 1e6    /* gain_limit */
#define RIC_SIGN_ITERATIONS 100
#define RIC_NEWTON_STEPS 8
#define RIC_QR_SWEEPS 40      /* Francis steps per eigenvalue, at most */
/* the Lyapunov step's n^2 x n^2 system lives on the stack: at most 80 KiB */
typedef char ric_dimension_check[(RIC_N >= 1 && RIC_N <= 10 && RIC_M >= 1) ? 1 : -1];

/* LU factorization with partial pivoting of the k x k matrix a (row-major, in place); the log of
 * |det a| in *logdet. 0 when a pivot is zero or not finite (a singular matrix). */
static int ric_lu(double *a, int k, int *piv, double *logdet) {
    int i, j, c;
    *logdet = 0.0;
    for (c = 0; c < k; c++) {
        int r = c;
        for (i = c + 1; i < k; i++)
            if (fabs(a[i * k + c]) > fabs(a[r * k + c])) r = i;
        piv[c] = r;
        if (r != c)
            for (j = 0; j < k; j++) {
                const double t = a[c * k + j];
                a[c * k + j] = a[r * k + j];
                a[r * k + j] = t;
            }
        if (!(a[c * k + c] != 0.0) || !isfinite(a[c * k + c])) return 0;
        *logdet += log(fabs(a[c * k + c]));
        for (i = c + 1; i < k; i++) {
            const double f = a[i * k + c] / a[c * k + c];
            a[i * k + c] = f;
            for (j = c + 1; j < k; j++) a[i * k + j] -= f * a[c * k + j];
        }
    }
    return 1;
}

/* Solve (LU) x = b in place for the k x nrhs right-hand side b (row-major). */
static void ric_lu_solve(const double *lu, const int *piv, int k, double *b, int nrhs) {
    int i, j, c;
    for (c = 0; c < k; c++)
        if (piv[c] != c)
            for (j = 0; j < nrhs; j++) {
                const double t = b[c * nrhs + j];
                b[c * nrhs + j] = b[piv[c] * nrhs + j];
                b[piv[c] * nrhs + j] = t;
            }
    for (i = 1; i < k; i++)
        for (c = 0; c < i; c++)
            for (j = 0; j < nrhs; j++) b[i * nrhs + j] -= lu[i * k + c] * b[c * nrhs + j];
    for (i = k - 1; i >= 0; i--)
        for (j = 0; j < nrhs; j++) {
            double s = b[i * nrhs + j];
            for (c = i + 1; c < k; c++) s -= lu[i * k + c] * b[c * nrhs + j];
            b[i * nrhs + j] = s / lu[i * k + i];
        }
}

static double ric_frobenius(const double *a, int count) {
    double s = 0.0;
    int i;
    for (i = 0; i < count; i++) s += a[i] * a[i];
    return sqrt(s);
}

/* Householder reflector of the vector (x[0], ..., x[len-1]) onto a multiple of e1: v and
 * beta = 2 / v'v (beta = 0 when x = 0). */
static double ric_reflector(const double *x, int len, double *v) {
    double nrm = 0.0, vv;
    int i;
    for (i = 0; i < len; i++) nrm += x[i] * x[i];
    nrm = sqrt(nrm);
    if (nrm == 0.0) return 0.0;
    for (i = 0; i < len; i++) v[i] = x[i];
    v[0] += copysign(nrm, x[0]);
    vv = 0.0;
    for (i = 0; i < len; i++) vv += v[i] * v[i];
    return vv > 0.0 ? 2.0 / vv : 0.0;
}

/* h <- (I - beta v v') h on rows r0..r0+len-1, columns c0..c1 (k x k, row-major). */
static void ric_reflect_rows(double *h, int k, int r0, int len, int c0, int c1, const double *v, double beta) {
    int i, j;
    for (j = c0; j <= c1; j++) {
        double s = 0.0;
        for (i = 0; i < len; i++) s += v[i] * h[(r0 + i) * k + j];
        s *= beta;
        for (i = 0; i < len; i++) h[(r0 + i) * k + j] -= s * v[i];
    }
}

/* h <- h (I - beta v v') on columns c0..c0+len-1, rows r0..r1. */
static void ric_reflect_cols(double *h, int k, int c0, int len, int r0, int r1, const double *v, double beta) {
    int i, j;
    for (i = r0; i <= r1; i++) {
        double s = 0.0;
        for (j = 0; j < len; j++) s += h[i * k + c0 + j] * v[j];
        s *= beta;
        for (j = 0; j < len; j++) h[i * k + c0 + j] -= s * v[j];
    }
}

/* Eigenvalues (re[i], im[i]) of the k x k matrix h (destroyed), k <= RIC_N. 0 when the QR
 * steps do not converge. */
static int ric_eigenvalues(double *h, int k, double *re, double *im) {
    double x[RIC_N + 3], v[RIC_N + 3], norm = 0.0;
    int c, i, hi, sweeps = 0;
    for (c = 0; c + 2 < k; c++) { /* Hessenberg form */
        double beta;
        for (i = c + 1; i < k; i++) x[i - c - 1] = h[i * k + c];
        beta = ric_reflector(x, k - c - 1, v);
        if (beta == 0.0) continue;
        ric_reflect_rows(h, k, c + 1, k - c - 1, 0, k - 1, v, beta);
        ric_reflect_cols(h, k, c + 1, k - c - 1, 0, k - 1, v, beta);
        for (i = c + 2; i < k; i++) h[i * k + c] = 0.0;
    }
    for (i = 0; i < k * k; i++) norm = fmax(norm, fabs(h[i]));
    if (!isfinite(norm)) return 0;
    hi = k - 1;
    while (hi >= 0) {
        int l = hi;
        double s, t;
        while (l > 0) { /* a negligible subdiagonal entry splits the active block */
            double scale = fabs(h[(l - 1) * k + l - 1]) + fabs(h[l * k + l]);
            if (scale == 0.0) scale = norm;
            if (fabs(h[l * k + l - 1]) <= DBL_EPSILON * scale) {
                h[l * k + l - 1] = 0.0;
                break;
            }
            l--;
        }
        if (l == hi) { /* a 1 x 1 block */
            re[hi] = h[hi * k + hi];
            im[hi] = 0.0;
            hi--;
            sweeps = 0;
            continue;
        }
        if (l == hi - 1) { /* a 2 x 2 block: mid +- sqrt(disc) */
            const double a = h[l * k + l], b = h[l * k + hi], cc = h[hi * k + l], d = h[hi * k + hi];
            const double mid = 0.5 * (a + d), half = 0.5 * (a - d), disc = half * half + b * cc;
            if (disc >= 0.0) {
                const double big = mid + copysign(sqrt(disc), mid);
                re[l] = big;
                re[hi] = big != 0.0 ? (a * d - b * cc) / big : 0.0;
                im[l] = im[hi] = 0.0;
            } else {
                re[l] = re[hi] = mid;
                im[l] = sqrt(-disc);
                im[hi] = -im[l];
            }
            hi -= 2;
            sweeps = 0;
            continue;
        }
        if (++sweeps > RIC_QR_SWEEPS) return 0;
        /* the double shift: the eigenvalues of the trailing 2 x 2 block (their sum s, product t);
         * every 10th step an exceptional shift breaks a cycle */
        if (sweeps % 10 == 0) {
            const double w = fabs(h[hi * k + hi - 1]) + fabs(h[(hi - 1) * k + hi - 2]), mu = h[hi * k + hi] + 0.75 * w;
            s = 2.0 * mu;
            t = mu * mu + 0.25 * w * w;
        } else {
            s = h[(hi - 1) * k + hi - 1] + h[hi * k + hi];
            t = h[(hi - 1) * k + hi - 1] * h[hi * k + hi] - h[(hi - 1) * k + hi] * h[hi * k + hi - 1];
        }
        x[0] = h[l * k + l] * h[l * k + l] + h[l * k + l + 1] * h[(l + 1) * k + l] - s * h[l * k + l] + t;
        x[1] = h[(l + 1) * k + l] * (h[l * k + l] + h[(l + 1) * k + l + 1] - s);
        x[2] = h[(l + 1) * k + l] * h[(l + 2) * k + l + 1];
        for (c = l; c <= hi - 2; c++) { /* chase the bulge down the active block */
            const double beta = ric_reflector(x, 3, v);
            const int r1 = c + 3 < hi ? c + 3 : hi;
            if (beta != 0.0) {
                ric_reflect_rows(h, k, c, 3, c > l ? c - 1 : l, hi, v, beta);
                ric_reflect_cols(h, k, c, 3, l, r1, v, beta);
                if (c > l) h[(c + 1) * k + c - 1] = h[(c + 2) * k + c - 1] = 0.0;
            }
            x[0] = h[(c + 1) * k + c];
            x[1] = h[(c + 2) * k + c];
            if (c + 3 <= hi) x[2] = h[(c + 3) * k + c];
        }
        {
            const double beta = ric_reflector(x, 2, v);
            if (beta != 0.0) {
                ric_reflect_rows(h, k, hi - 1, 2, hi - 2, hi, v, beta);
                ric_reflect_cols(h, k, hi - 1, 2, l, hi, v, beta);
                h[hi * k + hi - 2] = 0.0;
            }
        }
    }
    return 1;
}

/* Smallest and largest real parts of the eigenvalues of the n x n matrix a (kept); NAN when QR
 * does not converge. */
static void ric_real_parts(const double *a, double *lo, double *hi) {
    double h[RIC_NN], re[RIC_N], im[RIC_N];
    int i;
    memcpy(h, a, sizeof h);
    *lo = INFINITY;
    *hi = -INFINITY;
    if (!ric_eigenvalues(h, RIC_N, re, im)) {
        *lo = *hi = NAN;
        return;
    }
    for (i = 0; i < RIC_N; i++) {
        *lo = fmin(*lo, re[i]);
        *hi = fmax(*hi, re[i]);
    }
}

/* The matrix sign function of the 2n x 2n matrix z, in place. 0 when an iterate is singular (an
 * eigenvalue on the imaginary axis) or the iteration does not converge. */
static int ric_sign(double *z) {
    enum { K = RIC_2N };
    static const double tol = 1e3 * DBL_EPSILON;
    double lu[K * K], inv[K * K], logdet, previous = INFINITY;
    int piv[K], it, i, scaled = 1;
    for (it = 0; it < RIC_SIGN_ITERATIONS; it++) {
        double g = 1.0, change = 0.0, size = 0.0;
        memcpy(lu, z, sizeof lu);
        if (!ric_lu(lu, K, piv, &logdet)) return 0;
        memset(inv, 0, sizeof inv);
        for (i = 0; i < K; i++) inv[i * K + i] = 1.0;
        ric_lu_solve(lu, piv, K, inv, K);
        if (scaled) g = exp(logdet / K);
        for (i = 0; i < K * K; i++) {
            const double next = 0.5 * (z[i] / g + g * inv[i]);
            change += fabs(next - z[i]);
            size += fabs(next);
            z[i] = next;
        }
        if (!isfinite(size)) return 0;
        change /= size;
        if (change < 1e-2) scaled = 0; /* quadratic phase: scaling would only perturb it */
        if (change <= tol || (change < 1e-6 && change >= previous)) return 1;
        previous = change;
    }
    return 0;
}

/* Least squares: the cols x nrhs solution of min |a x - b| (a rows x cols, b rows x nrhs, both
 * row-major, destroyed) into x, by Householder QR. 0 when a has deficient rank. */
static int ric_least_squares(double *a, int rows, int cols, double *b, int nrhs, double *x) {
    double col[RIC_2N], v[RIC_2N];
    int c, i, j;
    for (c = 0; c < cols; c++) {
        double beta;
        for (i = c; i < rows; i++) col[i - c] = a[i * cols + c];
        beta = ric_reflector(col, rows - c, v);
        if (beta == 0.0) return 0;
        ric_reflect_rows(a, cols, c, rows - c, c, cols - 1, v, beta); /* a is rows x cols: k = cols */
        for (j = 0; j < nrhs; j++) {
            double s = 0.0;
            for (i = c; i < rows; i++) s += v[i - c] * b[i * nrhs + j];
            s *= beta;
            for (i = c; i < rows; i++) b[i * nrhs + j] -= s * v[i - c];
        }
    }
    for (c = cols - 1; c >= 0; c--) {
        if (!(a[c * cols + c] != 0.0)) return 0;
        for (j = 0; j < nrhs; j++) {
            double s = b[c * nrhs + j];
            for (i = c + 1; i < cols; i++) s -= a[c * cols + i] * x[i * nrhs + j];
            x[c * nrhs + j] = s / a[c * cols + c];
        }
    }
    return 1;
}

/* Solve the Lyapunov equation a' d + d a + c = 0 (n x n) as an n^2 linear system. 0 when it
 * is singular (a has two eigenvalues summing to 0). */
static int ric_lyapunov(const double *a, const double *c, double *d) {
    double m[RIC_NN * RIC_NN]; /* 19 KiB for n = 7; RIC_N <= 10 keeps it below 80 KiB */
    int piv[RIC_NN], i, j, k;
    double logdet;
    memset(m, 0, sizeof m);
    for (i = 0; i < RIC_N; i++)
        for (j = 0; j < RIC_N; j++) {
            const int row = i * RIC_N + j;
            for (k = 0; k < RIC_N; k++) {
                m[row * RIC_NN + k * RIC_N + j] += a[k * RIC_N + i]; /* (a' d)_ij */
                m[row * RIC_NN + i * RIC_N + k] += a[k * RIC_N + j]; /* (d a)_ij */
            }
            d[row] = -c[row];
        }
    if (!ric_lu(m, RIC_NN, piv, &logdet)) return 0;
    ric_lu_solve(m, piv, RIC_NN, d, 1);
    return 1;
}

/* K = R^-1 B' P (m x n), the closed loop As - B K, and the relative residual of P (returned),
 * with res = As' P + P As + Q - P B K. */
static double ric_residual(const double *as, const double *b, const double *q, const double *r, const double *p,
                           double *k, double *acl, double *res) {
    int i, j, l;
    double pbk, qn = 0.0;
    for (i = 0; i < RIC_M; i++)
        for (j = 0; j < RIC_N; j++) {
            double s = 0.0;
            for (l = 0; l < RIC_N; l++) s += b[l * RIC_M + i] * p[l * RIC_N + j];
            k[i * RIC_N + j] = s / r[i];
        }
    for (i = 0; i < RIC_N; i++)
        for (j = 0; j < RIC_N; j++) {
            double s = 0.0;
            for (l = 0; l < RIC_M; l++) s += b[i * RIC_M + l] * k[l * RIC_N + j];
            acl[i * RIC_N + j] = as[i * RIC_N + j] - s;
        }
    for (i = 0; i < RIC_N; i++) {
        qn += q[i] * q[i];
        for (j = 0; j < RIC_N; j++) {
            double s = i == j ? q[i] : 0.0;
            for (l = 0; l < RIC_N; l++) s += as[l * RIC_N + i] * p[l * RIC_N + j] + p[i * RIC_N + l] * as[l * RIC_N + j];
            pbk = 0.0;
            for (l = 0; l < RIC_M; l++) {
                double pb = 0.0;
                int t;
                for (t = 0; t < RIC_N; t++) pb += p[i * RIC_N + t] * b[t * RIC_M + l];
                pbk += pb * k[l * RIC_N + j];
            }
            res[i * RIC_N + j] = s - pbk;
        }
    }
    return ric_frobenius(res, RIC_NN) / fmax(1.0, fmax(sqrt(qn), ric_frobenius(p, RIC_NN)));
}

static void ric_symmetrize(double *p) {
    int i, j;
    for (i = 0; i < RIC_N; i++)
        for (j = i + 1; j < RIC_N; j++) p[i * RIC_N + j] = p[j * RIC_N + i] = 0.5 * (p[i * RIC_N + j] + p[j * RIC_N + i]);
}

/* Append the failure text to message (bounded), "; "-separated after the first (*count of them). */
static void ric_append(char *message, size_t size, int *count, const char *text) {
    const size_t used = strlen(message);
    if (used + 1 < size) snprintf(message + used, size - used, "%s%s", *count ? "; " : "", text);
    (*count)++;
}

/* The stabilizing P of (A - eps I, B, diag q, diag r) into p; 0 and a message when none is found. */
static int ric_solve(const double *as, const double *b, const double *q, const double *r, double eps, double *p,
                     char *message, size_t size) {
    double z[RIC_2N * RIC_2N], ls[RIC_2N * RIC_N], rhs[RIC_2N * RIC_N];
    double k[RIC_M * RIC_N], acl[RIC_NN], res[RIC_NN], d[RIC_NN], best[RIC_NN], best_res, rel;
    const int n2 = RIC_2N;
    int i, j, l, step;
    for (i = 0; i < RIC_N; i++)
        for (j = 0; j < RIC_N; j++) {
            double g = 0.0;
            for (l = 0; l < RIC_M; l++) g += b[i * RIC_M + l] * b[j * RIC_M + l] / r[l];
            z[i * n2 + j] = as[i * RIC_N + j];
            z[i * n2 + RIC_N + j] = -g;
            z[(RIC_N + i) * n2 + j] = i == j ? -q[i] : 0.0;
            z[(RIC_N + i) * n2 + RIC_N + j] = -as[j * RIC_N + i];
        }
    if (!ric_sign(z)) {
        snprintf(message, size, "no stabilizing Riccati solution for the pair shifted by eps = %g: the "
                 "Hamiltonian matrix has eigenvalues on or near the imaginary axis (its sign iteration failed)", eps);
        return 0;
    }
    for (i = 0; i < n2; i++)
        for (j = 0; j < RIC_N; j++) {
            ls[i * RIC_N + j] = z[i * n2 + RIC_N + j] + (i == RIC_N + j ? 1.0 : 0.0);
            rhs[i * RIC_N + j] = -(z[i * n2 + j] + (i == j ? 1.0 : 0.0));
        }
    if (!ric_least_squares(ls, n2, RIC_N, rhs, RIC_N, p)) {
        snprintf(message, size, "no stabilizing Riccati solution for the pair shifted by eps = %g: the stable "
                 "invariant subspace of the Hamiltonian matrix is not a graph [I; P]", eps);
        return 0;
    }
    ric_symmetrize(p);
    best_res = ric_residual(as, b, q, r, p, k, acl, res);
    memcpy(best, p, sizeof best);
    rel = best_res;
    for (step = 0; step < RIC_NEWTON_STEPS && isfinite(rel) && rel > 4.0 * DBL_EPSILON; step++) {
        if (!ric_lyapunov(acl, res, d)) break;
        for (i = 0; i < RIC_NN; i++) p[i] += d[i];
        ric_symmetrize(p);
        rel = ric_residual(as, b, q, r, p, k, acl, res);
        if (!(rel < best_res)) break;
        if (rel > 0.5 * best_res) { /* no longer converging fast: keep it and stop */
            best_res = rel;
            memcpy(best, p, sizeof best);
            break;
        }
        best_res = rel;
        memcpy(best, p, sizeof best);
    }
    memcpy(p, best, sizeof best);
    return 1;
}

/* The checked gain: the sample routine of the online SDRE FMU. v holds A (n x n), B (n x m), diag Q
 * (n), diag R (m) and eps; held receives K (m x n), the relative residual and max Re eig(A - B K). */
static int riccati_sampled_gain(const double *v, double *held, char *message, size_t size) {
    const double *a = v, *b = v + RIC_NN, *q = v + RIC_NN + RIC_N * RIC_M, *r = q + RIC_N, eps = r[RIC_M];
    double as[RIC_NN], p[RIC_NN], k[RIC_M * RIC_N], acl[RIC_NN], res[RIC_NN], sym[RIC_NN];
    double residual, min_eig, max_eig, min_re, max_re_shifted, max_re, gain_norm = 0.0, p_norm;
    char text[160];
    int i, j, failures = 0;
    static const char *const names[4] = {"A", "B", "Q", "R"};
    const int counts[4] = {RIC_NN, RIC_N * RIC_M, RIC_N, RIC_M};
    const double *parts[4];
    parts[0] = a;
    parts[1] = b;
    parts[2] = q;
    parts[3] = r;
    message[0] = '\0';
    for (i = 0; i < 4; i++)
        for (j = 0; j < counts[i]; j++)
            if (!isfinite(parts[i][j])) {
                snprintf(message, size, "%s has non-finite entries", names[i]);
                return 0;
            }
    if (!(isfinite(eps) && eps >= 0.0)) {
        snprintf(message, size, "eps must be finite and >= 0, got %g", eps);
        return 0;
    }
    for (i = 0; i < RIC_M; i++)
        if (!(r[i] > 0.0)) {
            snprintf(message, size, "R is not positive definite (diagonal entry %d is %g)", i + 1, r[i]);
            return 0;
        }
    for (i = 0; i < RIC_NN; i++) as[i] = a[i] - (i % (RIC_N + 1) == 0 ? eps : 0.0);
    if (!ric_solve(as, b, q, r, eps, p, message, size)) return 0;
    residual = ric_residual(as, b, q, r, p, k, acl, res);
    ric_real_parts(acl, &min_re, &max_re_shifted);
    for (i = 0; i < RIC_N; i++)
        for (j = 0; j < RIC_N; j++) {
            double s = 0.0;
            int l;
            for (l = 0; l < RIC_M; l++) s += b[i * RIC_M + l] * k[l * RIC_N + j];
            acl[i * RIC_N + j] = a[i * RIC_N + j] - s;
            sym[i * RIC_N + j] = 0.5 * (p[i * RIC_N + j] + p[j * RIC_N + i]);
        }
    ric_real_parts(acl, &min_re, &max_re);
    ric_real_parts(sym, &min_eig, &max_eig);
    for (i = 0; i < RIC_M * RIC_N; i++) gain_norm = fmax(gain_norm, fabs(k[i]));
    p_norm = ric_frobenius(p, RIC_NN);
    strcpy(message, "Riccati solution rejected: ");
    if (!isfinite(residual) || residual > RIC_RESIDUAL_TOL) {
        snprintf(text, sizeof text, "relative residual %.3g > %g", residual, RIC_RESIDUAL_TOL);
        ric_append(message, size, &failures, text);
    }
    if (!(min_eig > -RIC_RESIDUAL_TOL * fmax(1.0, p_norm))) {
        snprintf(text, sizeof text, "P is not positive semidefinite (min eigenvalue %.3g)", min_eig);
        ric_append(message, size, &failures, text);
    }
    if (!(max_re_shifted < 0.0)) {
        snprintf(text, sizeof text, "shifted closed loop not stable (max Re %.3g 1/s)", max_re_shifted);
        ric_append(message, size, &failures, text);
    }
    if (!(max_re <= RIC_MAX_RE_TOL)) {
        snprintf(text, sizeof text, "closed loop A - B K has an unstable mode (max Re %.3g 1/s > %g)", max_re,
                 RIC_MAX_RE_TOL);
        ric_append(message, size, &failures, text);
    }
    if (!(gain_norm <= RIC_GAIN_LIMIT)) {
        snprintf(text, sizeof text, "gain entry %.3g exceeds %g (mode barely controllable)", gain_norm,
                 RIC_GAIN_LIMIT);
        ric_append(message, size, &failures, text);
    }
    if (failures) return 0;
    message[0] = '\0';
    for (i = 0; i < RIC_M * RIC_N; i++) held[i] = k[i];
    held[RIC_M * RIC_N] = residual;
    held[RIC_M * RIC_N + 1] = max_re;
    return 1;
}

#endif /* SATFMU_RICCATI_H */
