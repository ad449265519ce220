/* satfmu: the multiplicative extended Kalman filter of attitude and gyro bias, one sample instant.
 *
 * The C form of controllers/mekf.py's step(), operation for operation in the same order (plain
 * loops, the same libm calls), so that the native and pythonfmu estimator FMUs hold the same bits.
 * mekf_step(v, held, message, size) reads the arguments of controllers/mekf.py ARGUMENTS, then the
 * previous instant's held values (HELD), and writes this instant's held values; it returns 0 and a
 * message when a value is not finite or an innovation covariance is not positive definite.
 * No allocation.
 */
#ifndef SATFMU_MEKF_H
#define SATFMU_MEKF_H

#include <math.h>
#include <stdio.h>
#include <string.h>

#define MEKF_N_ARGS 32
#define MEKF_N_HELD 38
/* offsets of the held values (controllers/mekf.py HELD) */
#define MEKF_Q 0
#define MEKF_BIAS 4
#define MEKF_P 7
#define MEKF_W 28
#define MEKF_T 31
#define MEKF_INIT 32
#define MEKF_WEST 33
#define MEKF_NIS 36
#define MEKF_UPDATES 37
#define MEKF_TIME_TOLERANCE 1e-9

static void mekf_cross(const double *a, const double *b, double *c) {
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

static void mekf_product(const double *a, const double *b, double *out) {
    double c[3], r[4];
    mekf_cross(a, b, c);
    r[0] = a[3] * b[0] + b[3] * a[0] - c[0];
    r[1] = a[3] * b[1] + b[3] * a[1] - c[1];
    r[2] = a[3] * b[2] + b[3] * a[2] - c[2];
    r[3] = a[3] * b[3] - (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]);
    memcpy(out, r, sizeof r);
}

static void mekf_rotation(const double *v, double *q) {
    const double angle = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    const double half = angle == 0.0 ? 0.5 : sin(0.5 * angle) / angle;
    q[0] = half * v[0];
    q[1] = half * v[1];
    q[2] = half * v[2];
    q[3] = cos(0.5 * angle);
}

static void mekf_normalize(double *q) {
    double norm = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    int i;
    if (q[3] < 0.0) norm = -norm;
    for (i = 0; i < 4; i++) q[i] = q[i] / norm;
}

static void mekf_dcm(const double *q, double c[3][3]) {
    const double x = q[0], y = q[1], z = q[2], w = q[3];
    c[0][0] = w * w + x * x - y * y - z * z;
    c[0][1] = 2.0 * (x * y + w * z);
    c[0][2] = 2.0 * (x * z - w * y);
    c[1][0] = 2.0 * (x * y - w * z);
    c[1][1] = w * w - x * x + y * y - z * z;
    c[1][2] = 2.0 * (y * z + w * x);
    c[2][0] = 2.0 * (x * z + w * y);
    c[2][1] = 2.0 * (y * z - w * x);
    c[2][2] = w * w - x * x - y * y + z * z;
}

/* out (n x p) = a (n x m) b (m x p), row-major; out may not alias a or b */
static void mekf_matmul(const double *a, const double *b, double *out, int n, int m, int p) {
    int i, j, k;
    for (i = 0; i < n; i++)
        for (j = 0; j < p; j++) {
            double s = 0.0;
            for (k = 0; k < m; k++) s += a[i * m + k] * b[k * p + j];
            out[i * p + j] = s;
        }
}

static void mekf_transpose(const double *a, double *out, int n, int m) {
    int i, j;
    for (i = 0; i < n; i++)
        for (j = 0; j < m; j++) out[j * n + i] = a[i * m + j];
}

static int mekf_inverse3(const double s[9], double out[9], char *message, size_t size) {
    const double c00 = s[4] * s[8] - s[5] * s[7];
    const double c01 = s[5] * s[6] - s[3] * s[8];
    const double c02 = s[3] * s[7] - s[4] * s[6];
    const double det = s[0] * c00 + s[1] * c01 + s[2] * c02;
    double adj[9];
    int i;
    if (!(isfinite(det) && det > 0.0)) {
        snprintf(message, size, "innovation covariance not positive definite (determinant %.3g)", det);
        return 0;
    }
    adj[0] = c00;
    adj[1] = s[2] * s[7] - s[1] * s[8];
    adj[2] = s[1] * s[5] - s[2] * s[4];
    adj[3] = c01;
    adj[4] = s[0] * s[8] - s[2] * s[6];
    adj[5] = s[2] * s[3] - s[0] * s[5];
    adj[6] = c02;
    adj[7] = s[1] * s[6] - s[0] * s[7];
    adj[8] = s[0] * s[4] - s[1] * s[3];
    for (i = 0; i < 9; i++) out[i] = adj[i] / det;
    return 1;
}

static void mekf_skew(const double *v, double *out) {
    out[0] = 0.0; out[1] = -v[2]; out[2] = v[1];
    out[3] = v[2]; out[4] = 0.0; out[5] = -v[0];
    out[6] = -v[1]; out[7] = v[0]; out[8] = 0.0;
}

static void mekf_unpack(const double *p, double *out) {
    int i, j, k = 0;
    for (i = 0; i < 6; i++)
        for (j = i; j < 6; j++) {
            out[i * 6 + j] = p[k];
            out[j * 6 + i] = p[k];
            k++;
        }
}

static void mekf_pack(const double *m, double *p) {
    int i, j, k = 0;
    for (i = 0; i < 6; i++)
        for (j = i; j < 6; j++) p[k++] = 0.5 * (m[i * 6 + j] + m[j * 6 + i]);
}

static void mekf_propagate(double *q, double *P, const double *w, double dt, double arw, double rrw) {
    double v[3], r[4], W[9], W2[9], phi[36], tmp[36], phit[36], a, b, c, v2, u2;
    const double rate = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    int i, j;
    v[0] = w[0] * dt; v[1] = w[1] * dt; v[2] = w[2] * dt;
    mekf_rotation(v, r);
    mekf_product(r, q, q);
    mekf_normalize(q);
    mekf_skew(w, W);
    mekf_matmul(W, W, W2, 3, 3, 3);
    if (rate * dt > 1e-4) {
        a = sin(rate * dt) / rate;
        b = (1.0 - cos(rate * dt)) / (rate * rate);
        c = (rate * dt - sin(rate * dt)) / (rate * rate * rate);
    } else {
        const double t2 = dt * dt, r2 = rate * rate;
        a = dt * (1.0 - r2 * t2 / 6.0);
        b = t2 * (0.5 - r2 * t2 / 24.0);
        c = t2 * dt * (1.0 / 6.0 - r2 * t2 / 120.0);
    }
    for (i = 0; i < 36; i++) phi[i] = 0.0;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            const double eye = i == j ? 1.0 : 0.0;
            phi[i * 6 + j] = eye - a * W[i * 3 + j] + b * W2[i * 3 + j];
            phi[i * 6 + j + 3] = b * W[i * 3 + j] - eye * dt - c * W2[i * 3 + j];
            phi[(i + 3) * 6 + j + 3] = eye;
        }
    mekf_matmul(phi, P, tmp, 6, 6, 6);
    mekf_transpose(phi, phit, 6, 6);
    mekf_matmul(tmp, phit, P, 6, 6, 6);
    v2 = arw * arw;
    u2 = rrw * rrw;
    for (i = 0; i < 3; i++) {
        P[i * 6 + i] += v2 * dt + u2 * dt * dt * dt / 3.0;
        P[i * 6 + i + 3] -= 0.5 * u2 * dt * dt;
        P[(i + 3) * 6 + i] -= 0.5 * u2 * dt * dt;
        P[(i + 3) * 6 + i + 3] += u2 * dt;
    }
}

/* one three-component measurement (H 3 x 6, R 3 x 3): q, bias and P corrected, *nis written */
static int mekf_update(double *q, double *bias, double *P, const double *y, const double *H, const double *R,
                       double *nis, char *message, size_t size) {
    double Ht[18], PHt[18], S[9], Si[9], K[18], dx[6], r[4], KH[36], A[36], At[36], tmp[36], Kt[18], KR[18],
        KRK[36];
    int i, j;
    mekf_transpose(H, Ht, 3, 6);
    mekf_matmul(P, Ht, PHt, 6, 6, 3);
    mekf_matmul(H, PHt, S, 3, 6, 3);
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) S[i * 3 + j] += R[i * 3 + j];
    if (!mekf_inverse3(S, Si, message, size)) return 0;
    mekf_matmul(PHt, Si, K, 6, 3, 3);
    for (i = 0; i < 6; i++) dx[i] = K[i * 3] * y[0] + K[i * 3 + 1] * y[1] + K[i * 3 + 2] * y[2];
    *nis = 0.0;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) *nis += y[i] * Si[i * 3 + j] * y[j];
    mekf_rotation(dx, r);
    mekf_product(r, q, q);
    mekf_normalize(q);
    for (i = 0; i < 3; i++) bias[i] = bias[i] + dx[3 + i];
    mekf_matmul(K, H, KH, 6, 3, 6);
    for (i = 0; i < 6; i++)
        for (j = 0; j < 6; j++) A[i * 6 + j] = (i == j ? 1.0 : 0.0) - KH[i * 6 + j];
    mekf_matmul(A, P, tmp, 6, 6, 6);
    mekf_transpose(A, At, 6, 6);
    mekf_matmul(tmp, At, P, 6, 6, 6);
    mekf_matmul(K, R, KR, 6, 3, 3);
    mekf_transpose(K, Kt, 6, 3);
    mekf_matmul(KR, Kt, KRK, 6, 3, 6);
    for (i = 0; i < 36; i++) P[i] = P[i] + KRK[i];
    return 1;
}

static int mekf_step(const double *v, double *held, char *message, size_t size) {
    const double *prev = v + MEKF_N_ARGS;
    const double dt = v[0], *omega_m = v + 1, *q_m = v + 4, *b_m = v + 10, *b_ref = v + 13;
    const int use_tracker = v[16] > 0.5, fresh = use_tracker && v[8] > 0.5;
    double q[4], bias[3], P[36], w[3], nis = prev[MEKF_NIS], updates = prev[MEKF_UPDATES], last;
    int i, j, tracked = 0;
    message[0] = '\0';
    for (i = 0; i < MEKF_N_ARGS + MEKF_N_HELD; i++)
        if (!isfinite(v[i])) {
            if (i < MEKF_N_ARGS) snprintf(message, size, "argument %d of the filter is not finite", i);
            else snprintf(message, size, "held value %d is not finite", i - MEKF_N_ARGS);
            return 0;
        }
    if (prev[MEKF_INIT] < 0.5) {
        for (i = 0; i < MEKF_N_HELD; i++) held[i] = 0.0;
        if (fresh || !use_tracker) {
            for (i = 0; i < 4; i++) q[i] = fresh ? q_m[i] : v[28 + i];
            mekf_normalize(q);
            for (i = 0; i < 36; i++) P[i] = 0.0;
            for (i = 0; i < 3; i++) {
                P[i * 6 + i] = v[26] * v[26];
                P[(i + 3) * 6 + i + 3] = v[27] * v[27];
            }
            memcpy(held + MEKF_Q, q, sizeof q);
            mekf_pack(P, held + MEKF_P);
            for (i = 0; i < 3; i++) {
                held[MEKF_W + i] = omega_m[i];
                held[MEKF_WEST + i] = omega_m[i];
            }
            held[MEKF_T] = fresh ? v[9] : 0.0;
            held[MEKF_INIT] = 1.0;
        } else {
            held[MEKF_Q + 3] = 1.0; /* no estimate yet: the identity, everything else 0 */
        }
        return 1;
    }
    memcpy(q, prev + MEKF_Q, sizeof q);
    memcpy(bias, prev + MEKF_BIAS, sizeof bias);
    mekf_unpack(prev + MEKF_P, P);
    for (i = 0; i < 3; i++) w[i] = 0.5 * (prev[MEKF_W + i] + omega_m[i]) - bias[i];
    mekf_propagate(q, P, w, dt, v[24], v[25]);
    last = prev[MEKF_T];
    if (fresh && v[9] > last + MEKF_TIME_TOLERANCE) {
        double dq[4], conj[4], y[3], e[3], norm, sc2, sb2, R[9], H[18], sign;
        conj[0] = -q[0]; conj[1] = -q[1]; conj[2] = -q[2]; conj[3] = q[3];
        mekf_product(q_m, conj, dq);
        sign = dq[3] < 0.0 ? -2.0 : 2.0;
        for (i = 0; i < 3; i++) y[i] = sign * dq[i];
        for (i = 0; i < 3; i++) e[i] = v[20 + i];
        norm = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
        for (i = 0; i < 3; i++) e[i] = e[i] / norm;
        sc2 = v[18] * v[18];
        sb2 = v[19] * v[19];
        for (i = 0; i < 3; i++)
            for (j = 0; j < 3; j++) R[i * 3 + j] = sc2 * (i == j ? 1.0 : 0.0) + (sb2 - sc2) * e[i] * e[j];
        for (i = 0; i < 3; i++)
            for (j = 0; j < 6; j++) H[i * 6 + j] = i == j ? 1.0 : 0.0;
        if (!mekf_update(q, bias, P, y, H, R, &nis, message, size)) return 0;
        last = v[9];
        updates += 1.0;
        tracked = 1;
    }
    if (v[17] > 0.5 && !(b_ref[0] == 0.0 && b_ref[1] == 0.0 && b_ref[2] == 0.0)) {
        double C[3][3], predicted[3], y[3], S[9], H[18], R[9], m2, nis_m;
        mekf_dcm(q, C);
        for (i = 0; i < 3; i++) predicted[i] = C[i][0] * b_ref[0] + C[i][1] * b_ref[1] + C[i][2] * b_ref[2];
        for (i = 0; i < 3; i++) y[i] = b_m[i] - predicted[i];
        mekf_skew(predicted, S);
        for (i = 0; i < 3; i++)
            for (j = 0; j < 6; j++) H[i * 6 + j] = j < 3 ? S[i * 3 + j] : 0.0;
        m2 = v[23] * v[23];
        for (i = 0; i < 9; i++) R[i] = i % 4 == 0 ? m2 : 0.0;
        if (!mekf_update(q, bias, P, y, H, R, &nis_m, message, size)) return 0;
        updates += 1.0;
        if (!tracked) nis = nis_m;
    }
    memcpy(held + MEKF_Q, q, sizeof q);
    memcpy(held + MEKF_BIAS, bias, sizeof bias);
    mekf_pack(P, held + MEKF_P);
    for (i = 0; i < 3; i++) {
        held[MEKF_W + i] = omega_m[i];
        held[MEKF_WEST + i] = omega_m[i] - bias[i];
    }
    held[MEKF_T] = last;
    held[MEKF_INIT] = 1.0;
    held[MEKF_NIS] = nis;
    held[MEKF_UPDATES] = updates;
    return 1;
}

#endif /* SATFMU_MEKF_H */
