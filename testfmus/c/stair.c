/* A counter from 1, up by one every period; at final_count the model ends the simulation
 * (terminateSimulation, at the time of the final count: an early return where the importer
 * allows one). As Model Exchange, each count is a time event. */
#include <math.h>
#include <stddef.h>

#include "model.h"

struct Model {
    int32_t counter, final_count;
    double period;
};

const char MODEL_TOKEN[] = "{c3a1d5e2-0004-4d61-8a3b-737461697233}";
const size_t MODEL_SIZE = sizeof(struct Model);
const Variable MODEL_VARIABLES[] = {
    {1, INT32, OUTPUT, 1, offsetof(struct Model, counter)},
    {2, FLOAT64, PARAMETER, 1, offsetof(struct Model, period)},
    {3, INT32, PARAMETER, 1, offsetof(struct Model, final_count)},
};
const size_t MODEL_VARIABLE_COUNT = sizeof MODEL_VARIABLES / sizeof MODEL_VARIABLES[0];

/* Events at communication points rounded within this fraction of a period count. */
static const double TOLERANCE = 1e-9;

static int32_t count_at(const Model *m, double t) {
    double n = 1.0 + floor(t / m->period + TOLERANCE);
    return (int32_t)fmin(n, (double)m->final_count);
}

void model_start(Model *m) { *m = (Model){.counter = 1, .final_count = 10, .period = 1.0}; }

const char *model_check(const Model *m) {
    if (!(m->period > 0.0)) return "period must be positive";
    return m->final_count >= 1 ? NULL : "final_count must be at least 1";
}

void model_initialize(Model *m, double t0) { m->counter = count_at(m, t0); }

void model_evaluate(Model *m) { (void)m; }

int model_step(Model *m, double t, double h, double *end) {
    double last = (m->final_count - 1) * m->period;
    if (last <= t + h + TOLERANCE * m->period) {
        m->counter = m->final_count;
        *end = fmax(last, t);
        return 1;
    }
    m->counter = count_at(m, t + h);
    return 0;
}

Interfaces model_interfaces(void) {
    return (Interfaces){.co_simulation = true, .model_exchange = true};
}

void model_update(Model *m, double t, Update *u) {
    m->counter = count_at(m, t);
    *u = (Update){.terminate = m->counter >= m->final_count};
    if (!u->terminate) {
        u->next_defined = true;
        u->next = m->counter * m->period;
    }
}
