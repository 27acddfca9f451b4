/* What each test model defines for framework.c, which implements the FMI 3.0 Co-Simulation
 * and Model Exchange functions over it: a plain data struct (copied as a whole for FMU states),
 * its variables as a table of offsets into that struct, and its equations. The model knows
 * nothing of FMI beyond the types. Value reference 0 is the independent variable `time`, kept
 * by the framework. */
#ifndef FEEDSIM_MODEL_H
#define FEEDSIM_MODEL_H

#include "fmi3.h"

/* The characters a String variable holds, its terminating NUL included. */
#define STRING_SIZE 256

typedef enum { FLOAT64, INT32, BOOLEAN, STRING } Type;
/* Who may set a variable, and when: a parameter before initialization ends, a tunable one also
 * between steps, an input at any time (a discrete one, as every Int32, Boolean and String input,
 * not in Model Exchange's continuous-time mode); outputs are computed. */
typedef enum { PARAMETER, TUNABLE, INPUT, OUTPUT, DISCRETE_INPUT } Role;

typedef struct {
    fmi3ValueReference vr;
    Type type;
    Role role;
    size_t count;  /* elements: 1 for a scalar */
    size_t offset; /* of the first element in the model's struct */
} Variable;

typedef struct Model Model;

extern const char MODEL_TOKEN[];
extern const Variable MODEL_VARIABLES[];
extern const size_t MODEL_VARIABLE_COUNT;
extern const size_t MODEL_SIZE;

/* Start values. */
void model_start(Model *m);
/* NULL, or why the parameters set cannot be used (checked when initialization ends). */
const char *model_check(const Model *m);
/* Leaving initialization mode at t0: the state from the parameters. */
void model_initialize(Model *m, double t0);
/* The outputs from the state and the inputs (called before values are read). */
void model_evaluate(Model *m);
/* Advance from t by h: 0 when t + h is reached, 1 when the model ends at *end (t ≤ *end ≤ t + h). */
int model_step(Model *m, double t, double h, double *end);

/* Model Exchange, for a model that offers it: the importer integrates the continuous states.
 * framework.c defines weak defaults of these functions for a model without it (Co-Simulation
 * only, no states, no events); a model without Co-Simulation need not define model_step. */
typedef struct {
    bool co_simulation, model_exchange;
    size_t states, indicators; /* continuous states and event indicators */
} Interfaces;
Interfaces model_interfaces(void);
/* The continuous states into x, or from x. */
void model_get_states(const Model *m, double x[]);
void model_set_states(Model *m, const double x[]);
/* Their derivatives, and the event indicators, at time t (states and inputs as set). */
void model_derivatives(Model *m, double t, double dx[]);
void model_indicators(Model *m, double t, double z[]);

/* What an update of the discrete states at an event says. */
typedef struct {
    bool again;          /* another update is needed at this instant */
    bool terminate;      /* the model ends the simulation */
    bool states_changed; /* the continuous states jumped */
    bool next_defined;   /* a time event is due at `next` */
    double next;
} Update;
/* An event at t (after initialization, a time event or a state event): the discrete states
 * updated. */
void model_update(Model *m, double t, Update *u);

#endif
