/* A controller of the Stewart platform written by a user (docs/controllers.md), Co-Simulation:
 * the cabin's motion in, the platform's command out (control_fmu's interface). At the end of each
 * of its steps it reads the cabin's pose and commands the platform so that a feed fixed to it
 * stays where it was at the start: the centre back to its start position in the world, the
 * attitude back to its start attitude; `gain` scales the command (0: the platform held at home).
 * No filter, no prediction: the sample is a step old when the platform starts to follow. */
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "model.h"

struct Model {
    double r[3], q[4], v[3], w[3], a[3], alpha[3]; /* the cabin's motion (inputs, world frame) */
    double command_r[3], command_rot[3];           /* the command (outputs, cabin frame) */
    double gain, home[3];                          /* parameters */
    double r0[3], q0[4];                           /* the cabin's pose at the start */
};

#define AT(field) offsetof(struct Model, field)

const char MODEL_TOKEN[] = "{c3a1d5e2-0007-4d61-8a3b-636f6e74726c}";
const size_t MODEL_SIZE = sizeof(struct Model);
const Variable MODEL_VARIABLES[] = {
    {1, FLOAT64, INPUT, 3, AT(r)},         {2, FLOAT64, INPUT, 4, AT(q)},     {3, FLOAT64, INPUT, 3, AT(v)},
    {4, FLOAT64, INPUT, 3, AT(w)},         {5, FLOAT64, INPUT, 3, AT(a)},     {6, FLOAT64, INPUT, 3, AT(alpha)},
    {7, FLOAT64, OUTPUT, 3, AT(command_r)}, {8, FLOAT64, OUTPUT, 3, AT(command_rot)},
    {9, FLOAT64, PARAMETER, 1, AT(gain)},  {10, FLOAT64, PARAMETER, 3, AT(home)},
};
const size_t MODEL_VARIABLE_COUNT = sizeof MODEL_VARIABLES / sizeof MODEL_VARIABLES[0];

void model_start(Model *m) {
    memset(m, 0, sizeof *m);
    m->r[2] = 9.8, m->q[0] = 1.0, m->gain = 1.0;
    m->home[0] = 0.1, m->home[2] = -1.8;
}

const char *model_check(const Model *m) {
    return isfinite(m->gain) && isfinite(m->home[0]) && isfinite(m->home[1]) && isfinite(m->home[2])
               ? NULL
               : "gain and home must be finite";
}

/* The unit quaternion q (w, x, y, z) normalized into u. */
static void unit(const double q[4], double u[4]) {
    double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (int i = 0; i < 4; i++) u[i] = q[i] / n;
}

/* v rotated by q (body to world), or by its inverse (world to body) when `back`. */
static void rotate(const double q[4], const double v[3], int back, double out[3]) {
    double w = q[0], x = back ? -q[1] : q[1], y = back ? -q[2] : q[2], z = back ? -q[3] : q[3];
    /* t = 2 (x, y, z) × v; out = v + w t + (x, y, z) × t */
    double t[3] = {2.0 * (y * v[2] - z * v[1]), 2.0 * (z * v[0] - x * v[2]), 2.0 * (x * v[1] - y * v[0])};
    out[0] = v[0] + w * t[0] + (y * t[2] - z * t[1]);
    out[1] = v[1] + w * t[1] + (z * t[0] - x * t[2]);
    out[2] = v[2] + w * t[2] + (x * t[1] - y * t[0]);
}

void model_initialize(Model *m, double t0) {
    (void)t0;
    memcpy(m->r0, m->r, sizeof m->r);
    unit(m->q, m->q0);
}

void model_evaluate(Model *m) { (void)m; }

int model_step(Model *m, double t, double h, double *end) {
    (void)t, (void)h, (void)end;
    double q[4], world[3], at_home[3], centre[3];
    unit(m->q, q);
    /* the centre where it keeps its start position in the world, in the cabin frame now */
    rotate(m->q0, m->home, 0, at_home);
    for (int i = 0; i < 3; i++) world[i] = m->r0[i] + at_home[i] - m->r[i];
    rotate(q, world, 1, centre);
    /* the attitude that keeps the start one: q⁻¹ q0, as a rotation vector */
    double d[4] = {q[0] * m->q0[0] + q[1] * m->q0[1] + q[2] * m->q0[2] + q[3] * m->q0[3],
                   q[0] * m->q0[1] - q[1] * m->q0[0] - q[2] * m->q0[3] + q[3] * m->q0[2],
                   q[0] * m->q0[2] + q[1] * m->q0[3] - q[2] * m->q0[0] - q[3] * m->q0[1],
                   q[0] * m->q0[3] - q[1] * m->q0[2] + q[2] * m->q0[1] - q[3] * m->q0[0]};
    double s = sqrt(d[1] * d[1] + d[2] * d[2] + d[3] * d[3]);
    double angle = 2.0 * atan2(s, fabs(d[0])), sign = d[0] < 0.0 ? -1.0 : 1.0;
    for (int i = 0; i < 3; i++) {
        m->command_r[i] = m->gain * (centre[i] - m->home[i]);
        m->command_rot[i] = s > 0.0 ? m->gain * sign * angle * d[i + 1] / s : 0.0;
    }
    return 0;
}
