/* A ball dropped onto the ground, as Model Exchange only: the states h and v, the height as
 * event indicator; at an impact the ball rebounds with e times its speed, or rests for good
 * when the rebound is slower than v_min. */
#include <math.h>
#include <stddef.h>

#include "model.h"

struct Model {
    double h, v, g, e, v_min, h0, v0, der_h, der_v;
    int32_t bounces;
    bool resting, initialized;
};

const char MODEL_TOKEN[] = "{c3a1d5e2-0005-4d61-8a3b-62616c6c3335}";
const size_t MODEL_SIZE = sizeof(struct Model);
const Variable MODEL_VARIABLES[] = {
    {1, FLOAT64, OUTPUT, 1, offsetof(struct Model, h)},
    {2, FLOAT64, OUTPUT, 1, offsetof(struct Model, v)},
    {3, INT32, OUTPUT, 1, offsetof(struct Model, bounces)},
    {4, BOOLEAN, OUTPUT, 1, offsetof(struct Model, resting)},
    {5, FLOAT64, TUNABLE, 1, offsetof(struct Model, g)},
    {6, FLOAT64, TUNABLE, 1, offsetof(struct Model, e)},
    {7, FLOAT64, TUNABLE, 1, offsetof(struct Model, v_min)},
    {8, FLOAT64, PARAMETER, 1, offsetof(struct Model, h0)},
    {9, FLOAT64, PARAMETER, 1, offsetof(struct Model, v0)},
    {10, FLOAT64, OUTPUT, 1, offsetof(struct Model, der_h)},
    {11, FLOAT64, OUTPUT, 1, offsetof(struct Model, der_v)},
};
const size_t MODEL_VARIABLE_COUNT = sizeof MODEL_VARIABLES / sizeof MODEL_VARIABLES[0];

Interfaces model_interfaces(void) {
    return (Interfaces){.model_exchange = true, .states = 2, .indicators = 1};
}

void model_start(Model *m) { *m = (Model){.h = 1.0, .g = 9.81, .e = 0.7, .v_min = 0.1, .h0 = 1.0}; }

const char *model_check(const Model *m) {
    if (!(m->g >= 0.0 && m->v_min >= 0.0 && m->h0 >= 0.0)) return "g, v_min and h0 must not be negative";
    return m->e >= 0.0 && m->e <= 1.0 ? NULL : "e must be in [0, 1]";
}

void model_initialize(Model *m, double t0) {
    (void)t0;
    m->h = m->h0;
    m->v = m->v0;
    m->initialized = true;
}

void model_derivatives(Model *m, double t, double dx[]) {
    (void)t;
    dx[0] = m->v;
    dx[1] = m->resting ? 0.0 : -m->g;
}

void model_evaluate(Model *m) {
    if (!m->initialized) {
        m->h = m->h0;
        m->v = m->v0;
    }
    double dx[2];
    model_derivatives(m, 0.0, dx);
    m->der_h = dx[0];
    m->der_v = dx[1];
}

void model_get_states(const Model *m, double x[]) {
    x[0] = m->h;
    x[1] = m->v;
}

void model_set_states(Model *m, const double x[]) {
    m->h = x[0];
    m->v = x[1];
}

void model_indicators(Model *m, double t, double z[]) {
    (void)t;
    z[0] = m->h;
}

void model_update(Model *m, double t, Update *u) {
    (void)t;
    bool impact = !m->resting && m->h <= 0.0 && m->v < 0.0;
    if (impact) {
        m->h = 0.0;
        m->v = -m->e * m->v;
        m->bounces += 1;
        if (m->v <= m->v_min) {
            m->v = 0.0;
            m->resting = true;
        }
    }
    *u = (Update){.states_changed = impact};
}
