/* A minimal C importer for valgrind: dlopen an unpacked FMU's library and run N
 * instantiate / setup / init / set / doStep / get / get+free FMU state / free cycles.
 * Build and run: scripts/valgrind.sh (it unpacks target/fmu/MagSwarm.fmu). */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef void *C;
typedef struct {
    void (*logger)(void *, const char *, int, const char *, const char *, ...);
    void *alloc, *free_, *step_finished, *env;
} Callbacks;

static int errors = 0;
static void logger(void *env, const char *name, int status, const char *cat, const char *msg, ...) {
    (void)env; (void)name; (void)cat;
    if (status >= 3) { errors++; fprintf(stderr, "FMU error: %s\n", msg); }
}

#define SYM(R, n, ...) R (*n)(__VA_ARGS__) = (R (*)(__VA_ARGS__))dlsym(lib, #n); \
    if (!n) { fprintf(stderr, "missing %s\n", #n); return 2; }

int main(int argc, char **argv) {
    if (argc < 5) { fprintf(stderr, "usage: %s LIB GUID RESOURCE_URI N [z_vr]\n", argv[0]); return 2; }
    void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) { fprintf(stderr, "%s\n", dlerror()); return 2; }
    long n = atol(argv[4]);
    unsigned z_vr = argc > 5 ? (unsigned)atoi(argv[5]) : 1, r1_vr = argc > 6 ? (unsigned)atoi(argv[6]) : 10;
    SYM(C, fmi2Instantiate, const char *, int, const char *, const char *, const Callbacks *, int, int);
    SYM(void, fmi2FreeInstance, C);
    SYM(int, fmi2SetupExperiment, C, int, double, double, int, double);
    SYM(int, fmi2EnterInitializationMode, C);
    SYM(int, fmi2ExitInitializationMode, C);
    SYM(int, fmi2SetReal, C, const unsigned *, size_t, const double *);
    SYM(int, fmi2GetReal, C, const unsigned *, size_t, double *);
    SYM(int, fmi2DoStep, C, double, double, int);
    SYM(int, fmi2GetFMUstate, C, void **);
    SYM(int, fmi2FreeFMUstate, C, void **);
    Callbacks cb = {logger, 0, 0, 0, 0};
    double sum = 0;
    for (long i = 0; i < n; i++) {
        C c = fmi2Instantiate("v", 1, argv[2], argv[3], &cb, 0, 0);
        if (!c) { fprintf(stderr, "instantiate failed at cycle %ld\n", i); return 1; }
        fmi2SetupExperiment(c, 0, 0, 0, 0, 0);
        fmi2EnterInitializationMode(c);
        fmi2ExitInitializationMode(c);
        double z = 0.006 + 0.01 * (double)(i % 10) / 10.0, r1 = 0;
        fmi2SetReal(c, &z_vr, 1, &z);
        fmi2DoStep(c, 0.0, 0.05, 1);
        fmi2GetReal(c, &r1_vr, 1, &r1);
        sum += r1;
        void *s = NULL, *kept = NULL;
        fmi2GetFMUstate(c, &s);
        fmi2FreeFMUstate(c, &s);
        if (i % 2) fmi2GetFMUstate(c, &kept); /* not freed: fmi2FreeInstance must free it */
        fmi2FreeInstance(c);
    }
    if (!getenv("NO_DLCLOSE")) dlclose(lib);
    printf("%ld cycles, sum r1 = %.9g, %d errors\n", n, sum, errors);
    return errors != 0;
}
