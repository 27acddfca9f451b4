/*
 * A minimal FMI 2.0 Co-Simulation FMU written in C, for testing the importer against a binary
 * that is not built by this workspace: an integrator y' = u that logs printf-style messages with
 * arguments, refuses negative inputs with fmi2Discard, and supports no optional capability.
 */
#include <stddef.h>
#include <string.h>

typedef void (*Logger)(void *, const char *, int, const char *, const char *, ...);
typedef struct {
    Logger logger;
    void *(*allocate)(size_t, size_t);
    void (*release)(void *);
    void (*step_finished)(void *, int);
    void *env;
} Callbacks;

typedef struct {
    Callbacks cb;
    char name[64];
    double u, y;
} Inst;

enum { OK = 0, DISCARD = 2, ERROR = 3 };
#define API __attribute__((visibility("default")))
#define LOG(i, status, ...) (i)->cb.logger((i)->cb.env, (i)->name, status, "log", __VA_ARGS__)

API const char *fmi2GetTypesPlatform(void) { return "default"; }
API const char *fmi2GetVersion(void) { return "2.0"; }
API int fmi2SetDebugLogging(void *c, int on, size_t n, const char *const *cats) { return OK; }

API void *fmi2Instantiate(const char *name, int type, const char *guid, const char *resources,
                          const Callbacks *cb, int visible, int logging_on) {
    Inst *i = cb->allocate(1, sizeof(Inst));
    if (i == NULL) return NULL;
    i->cb = *cb;
    strncpy(i->name, name, sizeof i->name - 1);
    i->u = 1.0;
    LOG(i, OK, "instantiated %s (type %d) with resources at %s, %d%% ready", guid, type, resources, 100);
    return i;
}

API void fmi2FreeInstance(void *c) {
    Inst *i = c;
    if (i != NULL) i->cb.release(i);
}

API int fmi2SetupExperiment(void *c, int td, double tol, double t0, int sd, double t1) { return OK; }
API int fmi2EnterInitializationMode(void *c) { return OK; }
API int fmi2ExitInitializationMode(void *c) { return OK; }
API int fmi2Terminate(void *c) { return OK; }
API int fmi2Reset(void *c) {
    Inst *i = c;
    i->u = 1.0;
    i->y = 0.0;
    return OK;
}

API int fmi2GetReal(void *c, const unsigned *vr, size_t n, double *v) {
    Inst *i = c;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] == 0) v[k] = i->u;
        else if (vr[k] == 1) v[k] = i->y;
        else {
            LOG(i, ERROR, "fmi2GetReal: no variable has value reference %u", vr[k]);
            return ERROR;
        }
    }
    return OK;
}

API int fmi2SetReal(void *c, const unsigned *vr, size_t n, const double *v) {
    Inst *i = c;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] != 0) {
            LOG(i, ERROR, "fmi2SetReal: cannot set value reference %u", vr[k]);
            return ERROR;
        }
        i->u = v[k];
    }
    return OK;
}

API int fmi2DoStep(void *c, double t, double h, int no_prior) {
    Inst *i = c;
    if (i->u < 0) {
        LOG(i, DISCARD, "step at t=%g refused: negative input u=%.3f", t, i->u);
        return DISCARD;
    }
    i->y += i->u * h;
    return OK;
}

/* Everything else is not supported. */
#define UNSUPPORTED(name, ...) \
    API int name(void *c, __VA_ARGS__) { return ERROR; }
UNSUPPORTED(fmi2GetInteger, const unsigned *vr, size_t n, int *v)
UNSUPPORTED(fmi2GetBoolean, const unsigned *vr, size_t n, int *v)
UNSUPPORTED(fmi2GetString, const unsigned *vr, size_t n, const char **v)
UNSUPPORTED(fmi2SetInteger, const unsigned *vr, size_t n, const int *v)
UNSUPPORTED(fmi2SetBoolean, const unsigned *vr, size_t n, const int *v)
UNSUPPORTED(fmi2SetString, const unsigned *vr, size_t n, const char *const *v)
UNSUPPORTED(fmi2GetFMUstate, void **s)
UNSUPPORTED(fmi2SetFMUstate, void *s)
UNSUPPORTED(fmi2FreeFMUstate, void **s)
UNSUPPORTED(fmi2SerializedFMUstateSize, void *s, size_t *size)
UNSUPPORTED(fmi2SerializeFMUstate, void *s, char *bytes, size_t size)
UNSUPPORTED(fmi2DeSerializeFMUstate, const char *bytes, size_t size, void **s)
UNSUPPORTED(fmi2GetDirectionalDerivative, const unsigned *u, size_t nu, const unsigned *k, size_t nk,
            const double *dk, double *du)
UNSUPPORTED(fmi2SetRealInputDerivatives, const unsigned *vr, size_t n, const int *o, const double *v)
UNSUPPORTED(fmi2GetRealOutputDerivatives, const unsigned *vr, size_t n, const int *o, double *v)
UNSUPPORTED(fmi2GetStatus, int kind, int *v)
UNSUPPORTED(fmi2GetRealStatus, int kind, double *v)
UNSUPPORTED(fmi2GetIntegerStatus, int kind, int *v)
UNSUPPORTED(fmi2GetBooleanStatus, int kind, int *v)
UNSUPPORTED(fmi2GetStringStatus, int kind, const char **v)
API int fmi2CancelStep(void *c) { return ERROR; }
