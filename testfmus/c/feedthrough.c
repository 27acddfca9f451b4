/* Every input passed at once to its output: Float64 (continuous, discrete, and an array of 3),
 * Int32, Boolean, String; Co-Simulation, or Model Exchange without states (its discrete inputs
 * set in event mode). */
#include <string.h>

#include "model.h"

struct Model {
    double real_continuous_in, real_continuous_out, real_discrete_in, real_discrete_out;
    double array_in[3], array_out[3];
    int32_t int_in, int_out;
    bool bool_in, bool_out;
    char string_in[STRING_SIZE], string_out[STRING_SIZE];
};

#define AT(field) offsetof(struct Model, field)

const char MODEL_TOKEN[] = "{c3a1d5e2-0003-4d61-8a3b-666565647468}";
const size_t MODEL_SIZE = sizeof(struct Model);
const Variable MODEL_VARIABLES[] = {
    {1, FLOAT64, INPUT, 1, AT(real_continuous_in)}, {2, FLOAT64, OUTPUT, 1, AT(real_continuous_out)},
    {3, FLOAT64, DISCRETE_INPUT, 1, AT(real_discrete_in)}, {4, FLOAT64, OUTPUT, 1, AT(real_discrete_out)},
    {5, FLOAT64, INPUT, 3, AT(array_in)},           {6, FLOAT64, OUTPUT, 3, AT(array_out)},
    {7, INT32, INPUT, 1, AT(int_in)},               {8, INT32, OUTPUT, 1, AT(int_out)},
    {9, BOOLEAN, INPUT, 1, AT(bool_in)},            {10, BOOLEAN, OUTPUT, 1, AT(bool_out)},
    {11, STRING, INPUT, 1, AT(string_in)},          {12, STRING, OUTPUT, 1, AT(string_out)},
};
const size_t MODEL_VARIABLE_COUNT = sizeof MODEL_VARIABLES / sizeof MODEL_VARIABLES[0];

void model_start(Model *m) { memset(m, 0, sizeof *m); }

const char *model_check(const Model *m) {
    (void)m;
    return NULL;
}

void model_initialize(Model *m, double t0) { (void)m, (void)t0; }

void model_evaluate(Model *m) {
    m->real_continuous_out = m->real_continuous_in;
    m->real_discrete_out = m->real_discrete_in;
    memcpy(m->array_out, m->array_in, sizeof m->array_in);
    m->int_out = m->int_in;
    m->bool_out = m->bool_in;
    memcpy(m->string_out, m->string_in, STRING_SIZE);
}

Interfaces model_interfaces(void) { return (Interfaces){.co_simulation = true, .model_exchange = true}; }

int model_step(Model *m, double t, double h, double *end) {
    (void)t, (void)h, (void)end;
    model_evaluate(m);
    return 0;
}
