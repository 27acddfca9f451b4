/* A careless Model Exchange FMU for the importer's tests: x' = -x with a time event at t_bad;
 * from that event on, misbehaviour 1 returns NaN derivatives and misbehaviour 2 a NaN event
 * indicator — with the status fmi3OK, as if nothing were wrong. */
#include <math.h>
#include <stddef.h>

#include "model.h"

struct Model {
    double x, der_x, z, x0, t_bad;
    int32_t misbehaviour;
    bool bad, initialized;
};

const char MODEL_TOKEN[] = "{c3a1d5e2-0006-4d61-8a3b-686f7374696c}";
const size_t MODEL_SIZE = sizeof(struct Model);
const Variable MODEL_VARIABLES[] = {
    {1, FLOAT64, OUTPUT, 1, offsetof(struct Model, x)},
    {2, FLOAT64, OUTPUT, 1, offsetof(struct Model, der_x)},
    {3, FLOAT64, OUTPUT, 1, offsetof(struct Model, z)},
    {4, FLOAT64, PARAMETER, 1, offsetof(struct Model, x0)},
    {5, FLOAT64, PARAMETER, 1, offsetof(struct Model, t_bad)},
    {6, INT32, PARAMETER, 1, offsetof(struct Model, misbehaviour)},
};
const size_t MODEL_VARIABLE_COUNT = sizeof MODEL_VARIABLES / sizeof MODEL_VARIABLES[0];

Interfaces model_interfaces(void) {
    return (Interfaces){.model_exchange = true, .states = 1, .indicators = 1};
}

void model_start(Model *m) { *m = (Model){.x = 1.0, .x0 = 1.0, .t_bad = 0.5}; }

const char *model_check(const Model *m) {
    return m->misbehaviour >= 0 && m->misbehaviour <= 2 ? NULL : "misbehaviour: 0, 1 or 2";
}

void model_initialize(Model *m, double t0) {
    (void)t0;
    m->x = m->x0;
    m->initialized = true;
}

void model_derivatives(Model *m, double t, double dx[]) {
    (void)t;
    dx[0] = m->bad && m->misbehaviour == 1 ? NAN : -m->x;
}

void model_indicators(Model *m, double t, double z[]) {
    (void)t;
    z[0] = m->bad && m->misbehaviour == 2 ? NAN : 1.0;
}

void model_evaluate(Model *m) {
    if (!m->initialized) m->x = m->x0;
    model_derivatives(m, 0.0, &m->der_x);
    model_indicators(m, 0.0, &m->z);
}

void model_get_states(const Model *m, double x[]) { x[0] = m->x; }

void model_set_states(Model *m, const double x[]) { m->x = x[0]; }

void model_update(Model *m, double t, Update *u) {
    m->bad = t >= m->t_bad;
    *u = (Update){.next_defined = !m->bad, .next = m->t_bad};
}
