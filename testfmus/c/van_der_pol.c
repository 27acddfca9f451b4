/* The van der Pol oscillator with a forcing input, x0'' = mu (1 - x0^2) x0' - x0 + u, as
 * x0' = x1, x1' = mu (1 - x0^2) x1 - x0 + u; classic Runge-Kutta over equal substeps of at most
 * max_substep (Co-Simulation), or integrated by the importer (Model Exchange: the states x0, x1). */
#include <math.h>
#include <stddef.h>

#include "model.h"

struct Model {
    double u, x0, x1, der_x0, der_x1, mu, x0_start, x1_start, max_substep;
    bool initialized;
};

const char MODEL_TOKEN[] = "{c3a1d5e2-0002-4d61-8a3b-766470c30102}";
const size_t MODEL_SIZE = sizeof(struct Model);
const Variable MODEL_VARIABLES[] = {
    {1, FLOAT64, INPUT, 1, offsetof(struct Model, u)},
    {2, FLOAT64, OUTPUT, 1, offsetof(struct Model, x0)},
    {3, FLOAT64, OUTPUT, 1, offsetof(struct Model, x1)},
    {4, FLOAT64, OUTPUT, 1, offsetof(struct Model, der_x0)},
    {5, FLOAT64, OUTPUT, 1, offsetof(struct Model, der_x1)},
    {6, FLOAT64, TUNABLE, 1, offsetof(struct Model, mu)},
    {7, FLOAT64, PARAMETER, 1, offsetof(struct Model, x0_start)},
    {8, FLOAT64, PARAMETER, 1, offsetof(struct Model, x1_start)},
    {9, FLOAT64, PARAMETER, 1, offsetof(struct Model, max_substep)},
};
const size_t MODEL_VARIABLE_COUNT = sizeof MODEL_VARIABLES / sizeof MODEL_VARIABLES[0];

void model_start(Model *m) {
    *m = (Model){.mu = 1.0, .x0_start = 2.0, .x1_start = 0.0, .max_substep = 1e-3, .x0 = 2.0, .x1 = 0.0};
}

const char *model_check(const Model *m) { return m->max_substep > 0.0 ? NULL : "max_substep must be positive"; }

void model_initialize(Model *m, double t0) {
    (void)t0;
    m->x0 = m->x0_start;
    m->x1 = m->x1_start;
    m->initialized = true;
}

static void rate(const Model *m, const double x[2], double out[2]) {
    out[0] = x[1];
    out[1] = m->mu * (1.0 - x[0] * x[0]) * x[1] - x[0] + m->u;
}

void model_evaluate(Model *m) {
    if (!m->initialized) {
        m->x0 = m->x0_start;
        m->x1 = m->x1_start;
    }
    double x[2] = {m->x0, m->x1}, r[2];
    rate(m, x, r);
    m->der_x0 = r[0];
    m->der_x1 = r[1];
}

int model_step(Model *m, double t, double h, double *end) {
    (void)t, (void)end;
    double n = fmax(ceil(h / m->max_substep), 1.0), dt = h / n;
    double x[2] = {m->x0, m->x1};
    for (long s = 0; s < (long)n; s++) {
        double k1[2], k2[2], k3[2], k4[2], y[2];
        rate(m, x, k1);
        for (int i = 0; i < 2; i++) y[i] = x[i] + 0.5 * dt * k1[i];
        rate(m, y, k2);
        for (int i = 0; i < 2; i++) y[i] = x[i] + 0.5 * dt * k2[i];
        rate(m, y, k3);
        for (int i = 0; i < 2; i++) y[i] = x[i] + dt * k3[i];
        rate(m, y, k4);
        for (int i = 0; i < 2; i++) x[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    m->x0 = x[0];
    m->x1 = x[1];
    return 0;
}

Interfaces model_interfaces(void) {
    return (Interfaces){.co_simulation = true, .model_exchange = true, .states = 2};
}

void model_get_states(const Model *m, double x[]) {
    x[0] = m->x0;
    x[1] = m->x1;
}

void model_set_states(Model *m, const double x[]) {
    m->x0 = x[0];
    m->x1 = x[1];
}

void model_derivatives(Model *m, double t, double dx[]) {
    (void)t;
    double x[2] = {m->x0, m->x1};
    rate(m, x, dx);
}
