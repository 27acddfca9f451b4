/* Dahlquist's test equation with a forcing input: der(x) = -k x + u, exact for a held u
 * (Co-Simulation), or integrated by the importer (Model Exchange: the state x). */
#include <math.h>
#include <stddef.h>

#include "model.h"

struct Model {
    double u, x, der_x, k, x0;
    bool initialized;
};

const char MODEL_TOKEN[] = "{c3a1d5e2-0001-4d61-8a3b-64616871c301}";
const size_t MODEL_SIZE = sizeof(struct Model);
const Variable MODEL_VARIABLES[] = {
    {1, FLOAT64, INPUT, 1, offsetof(struct Model, u)},
    {2, FLOAT64, OUTPUT, 1, offsetof(struct Model, x)},
    {3, FLOAT64, OUTPUT, 1, offsetof(struct Model, der_x)},
    {4, FLOAT64, TUNABLE, 1, offsetof(struct Model, k)},
    {5, FLOAT64, PARAMETER, 1, offsetof(struct Model, x0)},
};
const size_t MODEL_VARIABLE_COUNT = sizeof MODEL_VARIABLES / sizeof MODEL_VARIABLES[0];

void model_start(Model *m) { *m = (Model){.u = 0.0, .k = 1.0, .x0 = 1.0, .x = 1.0}; }

const char *model_check(const Model *m) { return isfinite(m->k) ? NULL : "k must be finite"; }

void model_initialize(Model *m, double t0) {
    (void)t0;
    m->x = m->x0;
    m->initialized = true;
}

void model_evaluate(Model *m) {
    if (!m->initialized) m->x = m->x0;
    m->der_x = -m->k * m->x + m->u;
}

int model_step(Model *m, double t, double h, double *end) {
    (void)t, (void)end;
    if (m->k == 0.0) {
        m->x += m->u * h;
    } else {
        double gain = -expm1(-m->k * h); /* 1 - e^{-kh} */
        m->x = m->x - gain * m->x + gain * m->u / m->k;
    }
    return 0;
}

Interfaces model_interfaces(void) {
    return (Interfaces){.co_simulation = true, .model_exchange = true, .states = 1};
}

void model_get_states(const Model *m, double x[]) { x[0] = m->x; }

void model_set_states(Model *m, const double x[]) { m->x = x[0]; }

void model_derivatives(Model *m, double t, double dx[]) {
    (void)t;
    dx[0] = -m->k * m->x + m->u;
}
