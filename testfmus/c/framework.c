/* The FMI 3.0 Co-Simulation and Model Exchange functions of a test FMU over the model of
 * model.h: every function the standard declares is defined; those of an interface the model
 * does not offer, of Scheduled Execution, of Co-Simulation's event mode, clocks and derivatives
 * return fmi3Error with a message. Written for this workspace's tests of its importer,
 * independently of its Rust export layer. */

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "model.h"

#define EXPORT __attribute__((visibility("default")))

/* STEP: Co-Simulation's step mode; EVENT and CONTINUOUS: Model Exchange's event mode and
 * continuous-time mode. */
typedef enum { INSTANTIATED, INITIALIZATION, STEP, TERMINATED, BROKEN, EVENT, CONTINUOUS } Phase;

typedef struct {
    Phase phase;
    bool me; /* instantiated for Model Exchange */
    double time;
    bool ended; /* the model ended the simulation (terminateSimulation was reported) */
    bool early_return_allowed;
    bool log_on;
    fmi3LogMessageCallback log;
    fmi3InstanceEnvironment env;
    Model *model;
} Instance;

/* A saved FMU state: the instance's own fields, then the model's bytes. */
typedef struct {
    uint32_t magic;
    Phase phase;
    double time;
    bool ended;
} Header;

static const uint32_t MAGIC = 0x33465346u; /* "FSF3" */

static fmi3Status fail(Instance *inst, const char *function, const char *format, ...) {
    char text[512];
    int n = snprintf(text, sizeof text, "%s: ", function);
    va_list args;
    va_start(args, format);
    vsnprintf(text + n, sizeof text - (size_t)n, format, args);
    va_end(args);
    if (inst && inst->log) inst->log(inst->env, fmi3Error, "logError", text);
    if (inst) inst->phase = BROKEN;
    return fmi3Error;
}

static const Variable *find(fmi3ValueReference vr) {
    for (size_t i = 0; i < MODEL_VARIABLE_COUNT; i++)
        if (MODEL_VARIABLES[i].vr == vr) return &MODEL_VARIABLES[i];
    return NULL;
}

static size_t type_size(Type t) {
    switch (t) {
    case FLOAT64: return sizeof(double);
    case INT32: return sizeof(int32_t);
    case BOOLEAN: return sizeof(bool);
    default: return STRING_SIZE;
    }
}

static const char *TYPE_NAMES[] = {"Float64", "Int32", "Boolean", "String"};

/* --- what a model without Model Exchange (or without Co-Simulation) leaves out ----------- */

/* (weak functions, not constants: a compiler may fold a weak constant's default into this file) */
#define WEAK __attribute__((weak))
WEAK Interfaces model_interfaces(void) { return (Interfaces){.co_simulation = true}; }
WEAK int model_step(Model *m, double t, double h, double *end) {
    (void)m, (void)t, (void)h, (void)end;
    return 0;
}
WEAK void model_get_states(const Model *m, double x[]) { (void)m, (void)x; }
WEAK void model_set_states(Model *m, const double x[]) { (void)m, (void)x; }
WEAK void model_derivatives(Model *m, double t, double dx[]) { (void)m, (void)t, (void)dx; }
WEAK void model_indicators(Model *m, double t, double z[]) { (void)m, (void)t, (void)z; }
WEAK void model_update(Model *m, double t, Update *u) {
    (void)m, (void)t;
    *u = (Update){0};
}

/* --- common functions ------------------------------------------------------------------- */

EXPORT const char *fmi3GetVersion(void) { return "3.0"; }

EXPORT fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean on, size_t n, const fmi3String categories[]) {
    (void)n;
    (void)categories;
    if (!instance) return fmi3Error;
    ((Instance *)instance)->log_on = on;
    return fmi3OK;
}

static Instance *create(bool logging_on, bool early_return_allowed, bool me, fmi3InstanceEnvironment env,
                        fmi3LogMessageCallback log) {
    Instance *inst = calloc(1, sizeof *inst);
    Model *m = calloc(1, MODEL_SIZE);
    if (!inst || !m) {
        free(inst);
        free(m);
        return NULL;
    }
    *inst = (Instance){.phase = INSTANTIATED, .me = me, .early_return_allowed = early_return_allowed,
                       .log_on = logging_on, .log = log, .env = env, .model = m};
    model_start(m);
    return inst;
}

EXPORT fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String resources,
                                                fmi3Boolean visible, fmi3Boolean logging_on,
                                                fmi3Boolean event_mode_used, fmi3Boolean early_return_allowed,
                                                const fmi3ValueReference required[], size_t n_required,
                                                fmi3InstanceEnvironment env, fmi3LogMessageCallback log,
                                                fmi3IntermediateUpdateCallback intermediate) {
    (void)resources;
    (void)visible;
    (void)required;
    (void)n_required;
    (void)intermediate;
    Instance probe = {.log = log, .env = env};
    if (!name || !token || strcmp(token, MODEL_TOKEN) != 0) {
        fail(&probe, "fmi3InstantiateCoSimulation", "instantiationToken `%s` is not this FMU's `%s`",
             token ? token : "(null)", MODEL_TOKEN);
        return NULL;
    }
    if (!model_interfaces().co_simulation) {
        fail(&probe, "fmi3InstantiateCoSimulation", "this FMU implements Model Exchange only");
        return NULL;
    }
    if (event_mode_used) {
        fail(&probe, "fmi3InstantiateCoSimulation", "this FMU has no event mode (hasEventMode = false)");
        return NULL;
    }
    return create(logging_on, early_return_allowed, false, env, log);
}

EXPORT fmi3Instance fmi3InstantiateModelExchange(fmi3String name, fmi3String token, fmi3String resources,
                                                 fmi3Boolean visible, fmi3Boolean logging_on,
                                                 fmi3InstanceEnvironment env, fmi3LogMessageCallback log) {
    (void)resources, (void)visible;
    Instance probe = {.log = log, .env = env};
    if (!name || !token || strcmp(token, MODEL_TOKEN) != 0) {
        fail(&probe, "fmi3InstantiateModelExchange", "instantiationToken `%s` is not this FMU's `%s`",
             token ? token : "(null)", MODEL_TOKEN);
        return NULL;
    }
    if (!model_interfaces().model_exchange) {
        fail(&probe, "fmi3InstantiateModelExchange", "this FMU implements Co-Simulation only");
        return NULL;
    }
    return create(logging_on, false, true, env, log);
}

EXPORT fmi3Instance fmi3InstantiateScheduledExecution(fmi3String name, fmi3String token, fmi3String resources,
                                                      fmi3Boolean visible, fmi3Boolean logging_on,
                                                      fmi3InstanceEnvironment env, fmi3LogMessageCallback log,
                                                      fmi3ClockUpdateCallback clock_update,
                                                      fmi3LockPreemptionCallback lock,
                                                      fmi3UnlockPreemptionCallback unlock) {
    (void)name, (void)token, (void)resources, (void)visible, (void)logging_on, (void)clock_update, (void)lock,
        (void)unlock;
    Instance probe = {.log = log, .env = env};
    fail(&probe, "fmi3InstantiateScheduledExecution", "this FMU implements Co-Simulation only");
    return NULL;
}

EXPORT void fmi3FreeInstance(fmi3Instance instance) {
    Instance *inst = instance;
    if (!inst) return;
    free(inst->model);
    free(inst);
}

EXPORT fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean tolerance_defined,
                                              fmi3Float64 tolerance, fmi3Float64 start, fmi3Boolean stop_defined,
                                              fmi3Float64 stop) {
    (void)tolerance_defined, (void)tolerance, (void)stop_defined, (void)stop;
    Instance *inst = instance;
    if (!inst) return fmi3Error;
    if (inst->phase != INSTANTIATED) return fail(inst, "fmi3EnterInitializationMode", "not after instantiation");
    inst->time = start;
    inst->phase = INITIALIZATION;
    return fmi3OK;
}

EXPORT fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    Instance *inst = instance;
    if (!inst) return fmi3Error;
    if (inst->phase != INITIALIZATION) return fail(inst, "fmi3ExitInitializationMode", "not in initialization mode");
    const char *why = model_check(inst->model);
    if (why) return fail(inst, "fmi3ExitInitializationMode", "%s", why);
    model_initialize(inst->model, inst->time);
    inst->phase = inst->me ? EVENT : STEP; /* Model Exchange: event mode, for the initial event */
    return fmi3OK;
}

EXPORT fmi3Status fmi3Terminate(fmi3Instance instance) {
    Instance *inst = instance;
    if (!inst) return fmi3Error;
    if (inst->phase != STEP && inst->phase != EVENT && inst->phase != CONTINUOUS)
        return fail(inst, "fmi3Terminate", "not in step, event or continuous-time mode");
    inst->phase = TERMINATED;
    return fmi3OK;
}

EXPORT fmi3Status fmi3Reset(fmi3Instance instance) {
    Instance *inst = instance;
    if (!inst) return fmi3Error;
    memset(inst->model, 0, MODEL_SIZE);
    model_start(inst->model);
    inst->phase = INSTANTIATED;
    inst->time = 0.0;
    inst->ended = false;
    return fmi3OK;
}

/* --- values ----------------------------------------------------------------------------- */

static fmi3Status get(Instance *inst, const char *function, Type type, const fmi3ValueReference vrs[], size_t nvr,
                      void *values, size_t n_values) {
    if (!inst) return fmi3Error;
    if (inst->phase == INSTANTIATED || inst->phase == BROKEN)
        return fail(inst, function, "not allowed before initialization mode or after an error");
    model_evaluate(inst->model);
    size_t k = 0;
    for (size_t i = 0; i < nvr; i++) {
        if (vrs[i] == 0 && type == FLOAT64) {
            if (k + 1 > n_values) return fail(inst, function, "nValues = %zu is too small", n_values);
            ((double *)values)[k++] = inst->time;
            continue;
        }
        const Variable *v = find(vrs[i]);
        if (!v || v->type != type)
            return fail(inst, function, "unknown value reference %u (no %s variable has it)", vrs[i], TYPE_NAMES[type]);
        if (k + v->count > n_values) return fail(inst, function, "nValues = %zu is too small", n_values);
        const char *from = (const char *)inst->model + v->offset;
        if (type == STRING) {
            for (size_t j = 0; j < v->count; j++) ((fmi3String *)values)[k + j] = from + j * STRING_SIZE;
        } else {
            memcpy((char *)values + k * type_size(type), from, v->count * type_size(type));
        }
        k += v->count;
    }
    if (k != n_values) return fail(inst, function, "nValues = %zu, but the variables hold %zu values", n_values, k);
    return fmi3OK;
}

static fmi3Status set(Instance *inst, const char *function, Type type, const fmi3ValueReference vrs[], size_t nvr,
                      const void *values, size_t n_values) {
    if (!inst) return fmi3Error;
    size_t k = 0;
    for (size_t i = 0; i < nvr; i++) {
        const Variable *v = find(vrs[i]);
        if (!v || v->type != type)
            return fail(inst, function, "unknown value reference %u (no settable %s variable has it)", vrs[i],
                        TYPE_NAMES[type]);
        bool discrete = v->role == DISCRETE_INPUT || (v->role == INPUT && type != FLOAT64);
        bool allowed = (v->role == INPUT && !discrete) || (discrete && inst->phase != CONTINUOUS) ||
                       (v->role == TUNABLE && (inst->phase == STEP || inst->phase == EVENT)) ||
                       ((v->role == PARAMETER || v->role == TUNABLE) &&
                        (inst->phase == INSTANTIATED || inst->phase == INITIALIZATION));
        if (discrete && inst->phase == CONTINUOUS)
            return fail(inst, function, "value reference %u: a discrete input, set in event mode only", vrs[i]);
        if (!allowed || inst->phase == TERMINATED || inst->phase == BROKEN)
            return fail(inst, function, "value reference %u cannot be set now", vrs[i]);
        if (k + v->count > n_values) return fail(inst, function, "nValues = %zu is too small", n_values);
        char *to = (char *)inst->model + v->offset;
        if (type == STRING) {
            for (size_t j = 0; j < v->count; j++) {
                fmi3String s = ((const fmi3String *)values)[k + j];
                if (!s || strlen(s) >= STRING_SIZE)
                    return fail(inst, function, "value reference %u: a null string or one of %d bytes or more",
                                vrs[i], STRING_SIZE);
                strcpy(to + j * STRING_SIZE, s);
            }
        } else {
            memcpy(to, (const char *)values + k * type_size(type), v->count * type_size(type));
        }
        k += v->count;
    }
    if (k != n_values) return fail(inst, function, "nValues = %zu, but the variables hold %zu values", n_values, k);
    return fmi3OK;
}

#define GET_SET(Name, TYPE, CType)                                                                            \
    EXPORT fmi3Status fmi3Get##Name(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,          \
                                    CType values[], size_t n_values) {                                         \
        return get(instance, "fmi3Get" #Name, TYPE, vrs, nvr, values, n_values);                               \
    }                                                                                                          \
    EXPORT fmi3Status fmi3Set##Name(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,          \
                                    const CType values[], size_t n_values) {                                   \
        return set(instance, "fmi3Set" #Name, TYPE, vrs, nvr, values, n_values);                               \
    }

GET_SET(Float64, FLOAT64, fmi3Float64)
GET_SET(Int32, INT32, fmi3Int32)
GET_SET(Boolean, BOOLEAN, fmi3Boolean)
GET_SET(String, STRING, fmi3String)

/* Types these FMUs have no variables of. */
static fmi3Status none(fmi3Instance instance, const char *function, const fmi3ValueReference vrs[], size_t nvr) {
    if (nvr == 0) return fmi3OK;
    return fail(instance, function, "unknown value reference %u (this FMU has no variables of this type)", vrs[0]);
}

#define NO_VARIABLES(Name, CType)                                                                              \
    EXPORT fmi3Status fmi3Get##Name(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,          \
                                    CType values[], size_t n_values) {                                         \
        (void)values, (void)n_values;                                                                          \
        return none(instance, "fmi3Get" #Name, vrs, nvr);                                                      \
    }                                                                                                          \
    EXPORT fmi3Status fmi3Set##Name(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,          \
                                    const CType values[], size_t n_values) {                                   \
        (void)values, (void)n_values;                                                                          \
        return none(instance, "fmi3Set" #Name, vrs, nvr);                                                      \
    }

NO_VARIABLES(Float32, fmi3Float32)
NO_VARIABLES(Int8, fmi3Int8)
NO_VARIABLES(UInt8, fmi3UInt8)
NO_VARIABLES(Int16, fmi3Int16)
NO_VARIABLES(UInt16, fmi3UInt16)
NO_VARIABLES(UInt32, fmi3UInt32)
NO_VARIABLES(Int64, fmi3Int64)
NO_VARIABLES(UInt64, fmi3UInt64)

EXPORT fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr, size_t sizes[],
                                fmi3Binary values[], size_t n_values) {
    (void)sizes, (void)values, (void)n_values;
    return none(instance, "fmi3GetBinary", vrs, nvr);
}
EXPORT fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                                const size_t sizes[], const fmi3Binary values[], size_t n_values) {
    (void)sizes, (void)values, (void)n_values;
    return none(instance, "fmi3SetBinary", vrs, nvr);
}
EXPORT fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                               fmi3Clock values[]) {
    (void)values;
    return none(instance, "fmi3GetClock", vrs, nvr);
}
EXPORT fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference vrs[], size_t nvr,
                               const fmi3Clock values[]) {
    (void)values;
    return none(instance, "fmi3SetClock", vrs, nvr);
}

/* --- FMU states: the header and a copy of the model's struct ---------------------------- */

static size_t state_size(void) { return sizeof(Header) + MODEL_SIZE; }

EXPORT fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *state) {
    Instance *inst = instance;
    if (!inst || !state) return fmi3Error;
    if (!*state) *state = malloc(state_size());
    if (!*state) return fail(inst, "fmi3GetFMUState", "out of memory");
    Header h = {.magic = MAGIC, .phase = inst->phase, .time = inst->time, .ended = inst->ended};
    memcpy(*state, &h, sizeof h);
    memcpy((char *)*state + sizeof h, inst->model, MODEL_SIZE);
    return fmi3OK;
}

EXPORT fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState state) {
    Instance *inst = instance;
    if (!inst || !state) return fmi3Error;
    Header h;
    memcpy(&h, state, sizeof h);
    if (h.magic != MAGIC) return fail(inst, "fmi3SetFMUState", "not a state of this FMU");
    memcpy(inst->model, (const char *)state + sizeof h, MODEL_SIZE);
    inst->phase = h.phase;
    inst->time = h.time;
    inst->ended = h.ended;
    return fmi3OK;
}

EXPORT fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *state) {
    (void)instance;
    if (state) {
        free(*state);
        *state = NULL;
    }
    return fmi3OK;
}

EXPORT fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState state, size_t *size) {
    (void)instance, (void)state;
    *size = state_size();
    return fmi3OK;
}

EXPORT fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState state, fmi3Byte bytes[], size_t size) {
    if (size < state_size()) return fail(instance, "fmi3SerializeFMUState", "a buffer of %zu bytes is too small", size);
    memcpy(bytes, state, state_size());
    return fmi3OK;
}

EXPORT fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte bytes[], size_t size,
                                          fmi3FMUState *state) {
    Header h;
    if (size != state_size()) return fail(instance, "fmi3DeserializeFMUState", "%zu bytes are no state of this FMU", size);
    memcpy(&h, bytes, sizeof h);
    if (h.magic != MAGIC) return fail(instance, "fmi3DeserializeFMUState", "not a state of this FMU");
    if (!*state) *state = malloc(state_size());
    if (!*state) return fail(instance, "fmi3DeserializeFMUState", "out of memory");
    memcpy(*state, bytes, size);
    return fmi3OK;
}

/* --- stepping --------------------------------------------------------------------------- */

EXPORT fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 t, fmi3Float64 h, fmi3Boolean no_prior,
                             fmi3Boolean *event_handling_needed, fmi3Boolean *terminate, fmi3Boolean *early_return,
                             fmi3Float64 *last_successful_time) {
    (void)no_prior;
    Instance *inst = instance;
    if (!inst) return fmi3Error;
    *event_handling_needed = false;
    *terminate = false;
    *early_return = false;
    *last_successful_time = inst->time;
    if (inst->phase != STEP || inst->ended || inst->me)
        return fail(inst, "fmi3DoStep", "not in step mode (or a Model Exchange instance), or ended");
    if (!(h > 0.0) || fabs(t - inst->time) > 1e-9 * fmax(1.0, fabs(t)))
        return fail(inst, "fmi3DoStep", "step from %g by %g, but the FMU is at %g", t, h, inst->time);
    double end = t + h;
    if (model_step(inst->model, t, h, &end) == 1) {
        inst->ended = true;
        *terminate = true;
        *early_return = inst->early_return_allowed && end < t + h;
        inst->time = end;
    } else {
        inst->time = t + h;
    }
    *last_successful_time = inst->time;
    return fmi3OK;
}

/* --- Model Exchange ------------------------------------------------------------------------ */

/* The instance, if it is of Model Exchange and in one of the phases given (a bit each). */
static Instance *me(fmi3Instance instance, const char *function, unsigned phases) {
    Instance *inst = instance;
    if (!inst) return NULL;
    if (!inst->me) {
        fail(inst, function, "not a Model Exchange instance");
        return NULL;
    }
    if (!(phases & (1u << inst->phase))) {
        fail(inst, function, "not allowed in this mode (%d)", (int)inst->phase);
        return NULL;
    }
    return inst;
}

#define IN(p) (1u << (p))
#define MODES (IN(EVENT) | IN(CONTINUOUS))
#define READABLE (IN(INITIALIZATION) | IN(EVENT) | IN(CONTINUOUS) | IN(TERMINATED))

EXPORT fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
    Instance *inst = me(instance, "fmi3EnterEventMode", MODES);
    if (!inst) return fmi3Error;
    inst->phase = EVENT;
    return fmi3OK;
}

EXPORT fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *again, fmi3Boolean *terminate,
                                           fmi3Boolean *nominals_changed, fmi3Boolean *states_changed,
                                           fmi3Boolean *next_defined, fmi3Float64 *next) {
    Instance *inst = me(instance, "fmi3UpdateDiscreteStates", IN(EVENT));
    if (!inst) return fmi3Error;
    Update u = {0};
    model_update(inst->model, inst->time, &u);
    if (u.terminate) inst->ended = true;
    *again = u.again;
    *terminate = u.terminate;
    *nominals_changed = false;
    *states_changed = u.states_changed;
    *next_defined = u.next_defined;
    *next = u.next_defined ? u.next : 0.0;
    return fmi3OK;
}

EXPORT fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) {
    Instance *inst = me(instance, "fmi3EnterContinuousTimeMode", IN(EVENT));
    if (!inst) return fmi3Error;
    inst->phase = CONTINUOUS;
    return fmi3OK;
}

EXPORT fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean no_prior, fmi3Boolean *event,
                                              fmi3Boolean *terminate) {
    (void)no_prior;
    Instance *inst = me(instance, "fmi3CompletedIntegratorStep", IN(CONTINUOUS));
    if (!inst) return fmi3Error;
    *event = false;
    *terminate = false;
    return fmi3OK;
}

EXPORT fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 t) {
    Instance *inst = me(instance, "fmi3SetTime", MODES);
    if (!inst) return fmi3Error;
    inst->time = t;
    return fmi3OK;
}

static size_t states(void) { return model_interfaces().states; }
static size_t indicators(void) { return model_interfaces().indicators; }

/* n must be the model's count of states (or indicators). */
static Instance *counted(fmi3Instance instance, const char *function, unsigned phases, size_t n, size_t count) {
    Instance *inst = me(instance, function, phases);
    if (inst && n != count) {
        fail(inst, function, "%zu values for %zu", n, count);
        return NULL;
    }
    return inst;
}

EXPORT fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 x[], size_t n) {
    Instance *inst = counted(instance, "fmi3SetContinuousStates", IN(CONTINUOUS), n, states());
    if (!inst) return fmi3Error;
    model_set_states(inst->model, x);
    return fmi3OK;
}

EXPORT fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 dx[], size_t n) {
    Instance *inst = counted(instance, "fmi3GetContinuousStateDerivatives", READABLE, n, states());
    if (!inst) return fmi3Error;
    model_derivatives(inst->model, inst->time, dx);
    return fmi3OK;
}

EXPORT fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 z[], size_t n) {
    Instance *inst = counted(instance, "fmi3GetEventIndicators", READABLE, n, indicators());
    if (!inst) return fmi3Error;
    model_indicators(inst->model, inst->time, z);
    return fmi3OK;
}

EXPORT fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 x[], size_t n) {
    Instance *inst = counted(instance, "fmi3GetContinuousStates", READABLE, n, states());
    if (!inst) return fmi3Error;
    model_get_states(inst->model, x);
    return fmi3OK;
}

EXPORT fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 x[], size_t n) {
    Instance *inst = counted(instance, "fmi3GetNominalsOfContinuousStates", READABLE, n, states());
    if (!inst) return fmi3Error;
    for (size_t i = 0; i < n; i++) x[i] = 1.0;
    return fmi3OK;
}

EXPORT fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *n) {
    if (!me(instance, "fmi3GetNumberOfEventIndicators", ~0u)) return fmi3Error;
    *n = indicators();
    return fmi3OK;
}

EXPORT fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *n) {
    if (!me(instance, "fmi3GetNumberOfContinuousStates", ~0u)) return fmi3Error;
    *n = states();
    return fmi3OK;
}

/* --- what these FMUs do not provide ------------------------------------------------------ */

#define UNSUPPORTED(Name, Why, ...)                                                                            \
    EXPORT fmi3Status Name(fmi3Instance instance, __VA_ARGS__) {                                               \
        return fail(instance, #Name, Why);                                                                     \
    }
#define UNSUPPORTED0(Name, Why)                                                                                \
    EXPORT fmi3Status Name(fmi3Instance instance) { return fail(instance, #Name, Why); }

#define NO_EVENTS "this FMU has no event mode in Co-Simulation (hasEventMode = false)"
#define NO_CLOCKS "this FMU has no clocks"

UNSUPPORTED0(fmi3EnterStepMode, NO_EVENTS)
UNSUPPORTED0(fmi3EvaluateDiscreteStates, "this FMU has no clocks")
UNSUPPORTED(fmi3GetNumberOfVariableDependencies, "no per-element dependencies", fmi3ValueReference vr, size_t *n)
UNSUPPORTED(fmi3GetVariableDependencies, "no per-element dependencies", fmi3ValueReference vr, size_t a[],
            fmi3ValueReference b[], size_t c[], fmi3DependencyKind d[], size_t n)
UNSUPPORTED(fmi3GetDirectionalDerivative, "no directional derivatives (providesDirectionalDerivatives = false)",
            const fmi3ValueReference u[], size_t nu, const fmi3ValueReference k[], size_t nk, const fmi3Float64 s[],
            size_t ns, fmi3Float64 o[], size_t no)
UNSUPPORTED(fmi3GetAdjointDerivative, "no adjoint derivatives", const fmi3ValueReference u[], size_t nu,
            const fmi3ValueReference k[], size_t nk, const fmi3Float64 s[], size_t ns, fmi3Float64 o[], size_t no)
UNSUPPORTED0(fmi3EnterConfigurationMode, "no structural parameters")
UNSUPPORTED0(fmi3ExitConfigurationMode, "no structural parameters")
UNSUPPORTED(fmi3GetIntervalDecimal, NO_CLOCKS, const fmi3ValueReference v[], size_t n, fmi3Float64 i[],
            fmi3IntervalQualifier q[])
UNSUPPORTED(fmi3GetIntervalFraction, NO_CLOCKS, const fmi3ValueReference v[], size_t n, fmi3UInt64 c[],
            fmi3UInt64 r[], fmi3IntervalQualifier q[])
UNSUPPORTED(fmi3GetShiftDecimal, NO_CLOCKS, const fmi3ValueReference v[], size_t n, fmi3Float64 s[])
UNSUPPORTED(fmi3GetShiftFraction, NO_CLOCKS, const fmi3ValueReference v[], size_t n, fmi3UInt64 c[], fmi3UInt64 r[])
UNSUPPORTED(fmi3SetIntervalDecimal, NO_CLOCKS, const fmi3ValueReference v[], size_t n, const fmi3Float64 i[])
UNSUPPORTED(fmi3SetIntervalFraction, NO_CLOCKS, const fmi3ValueReference v[], size_t n, const fmi3UInt64 c[],
            const fmi3UInt64 r[])
UNSUPPORTED(fmi3SetShiftDecimal, NO_CLOCKS, const fmi3ValueReference v[], size_t n, const fmi3Float64 s[])
UNSUPPORTED(fmi3SetShiftFraction, NO_CLOCKS, const fmi3ValueReference v[], size_t n, const fmi3UInt64 c[],
            const fmi3UInt64 r[])
UNSUPPORTED(fmi3GetOutputDerivatives, "no output derivatives (maxOutputDerivativeOrder = 0)",
            const fmi3ValueReference v[], size_t n, const fmi3Int32 o[], fmi3Float64 x[], size_t nx)
UNSUPPORTED(fmi3ActivateModelPartition, "this FMU has no Scheduled Execution", fmi3ValueReference c,
            fmi3Float64 t)
