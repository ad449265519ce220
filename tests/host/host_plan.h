/*
 * satfmu's test hosts (fmu_host.c, FMI 2.0; fmu_host3.c, FMI 3.0): reading a plan file and printing
 * rows. Each host defines HOST_NAME (its messages' prefix) before including this file. Written for
 * this project.
 */
#ifndef SATFMU_HOST_PLAN_H
#define SATFMU_HOST_PLAN_H

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define TOKEN_SIZE 4096

/* A message on stderr, then exit code 1. */
static void fail(const char *format, ...) {
    va_list args;
    va_start(args, format);
    fputs(HOST_NAME ": ", stderr);
    vfprintf(stderr, format, args);
    fputc('\n', stderr);
    va_end(args);
    exit(1);
}

/* The next token of the plan into buf (TOKEN_SIZE bytes); a missing one ends the host. */
static void token(FILE *plan, char *buf, const char *what) {
    if (fscanf(plan, "%4095s", buf) != 1) fail("plan: %s missing", what);
}

static void keyword(FILE *plan, const char *expected) {
    char buf[TOKEN_SIZE];
    token(plan, buf, expected);
    if (strcmp(buf, expected) != 0) fail("plan: '%s' expected, '%s' found", expected, buf);
}

static double number(FILE *plan, const char *what) {
    char buf[TOKEN_SIZE], *end;
    double value;
    token(plan, buf, what);
    value = strtod(buf, &end);
    if (end == buf || *end != '\0') fail("plan: %s: '%s' is not a number", what, buf);
    return value;
}

/* A count (0 .. 1e6) of `what`. */
static size_t count_of(FILE *plan, const char *what) {
    double n = number(plan, what);
    if (!(n >= 0.0 && n <= 1e6) || n != (double)(size_t)n) fail("plan: bad count of %s", what);
    return (size_t)n;
}

/* A value reference (an unsigned 32-bit integer, as fmi2ValueReference and fmi3ValueReference). */
static unsigned int reference(FILE *plan) {
    double vr = number(plan, "value reference");
    if (!(vr >= 0.0 && vr <= 4294967295.0) || vr != (double)(unsigned int)vr) fail("plan: bad value reference");
    return (unsigned int)vr;
}

static void *allocate(size_t n, size_t size) {
    void *p = calloc(n > 0 ? n : 1, size);
    if (p == NULL) fail("out of memory");
    return p;
}

/* One output line: the time and q values, each with %.17g. */
static void print_row(double t, const double *y, size_t q) {
    size_t j;
    printf("%.17g", t);
    for (j = 0; j < q; j++) printf(" %.17g", y[j]);
    putchar('\n');
}

#endif
