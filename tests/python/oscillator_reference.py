"""Independent references for the fmi test oscillator (m x'' + c x' + k x = F - m g [gravity]).

* trapezoid(): the exact discrete solution of the integrator the FMU uses (trapezoidal rule,
  `substeps` steps per communication step, input held over the step), written in matrix form.
* analytic_step_response(): the closed-form solution for a constant force.
"""

from dataclasses import dataclass

import numpy as np

G = 9.80665
MASS = 2.0  # resources/oscillator.txt


@dataclass
class Parameters:
    m: float = MASS
    k: float = 40.0
    c: float = 0.8
    x0: float = 0.1
    v0: float = 0.0
    substeps: int = 1
    gravity: bool = False

    @staticmethod
    def from_start_values(values):
        p = Parameters()
        for key, value in values.items():
            setattr(p, key, value)
        return p

    def weight(self):
        return -self.m * G if self.gravity else 0.0


def held_force(times, drive):
    """The input fmpy applies over [t_n, t_n+1): the drive sampled at t_n."""
    return np.array([drive(t)[0] for t in times[:-1]])


def trapezoid(p, times, forces, force_rates=None):
    """States (x, v) and acceleration at every time; forces[n] is applied from times[n] on."""
    A = np.array([[0.0, 1.0], [-p.k / p.m, -p.c / p.m]])
    b = np.array([0.0, 1.0 / p.m])
    I = np.eye(2)
    y = np.array([p.x0, p.v0])
    xs, vs = [y[0]], [y[1]]
    for n, f in enumerate(forces):
        h = (times[n + 1] - times[n]) / p.substeps
        rate = 0.0 if force_rates is None else force_rates[n]
        L = I - 0.5 * h * A
        R = I + 0.5 * h * A
        for j in range(p.substeps):
            fa = f + p.weight() + rate * h * j
            fb = f + p.weight() + rate * h * (j + 1)
            y = np.linalg.solve(L, R @ y + 0.5 * h * b * (fa + fb))
        xs.append(y[0])
        vs.append(y[1])
    xs, vs = np.array(xs), np.array(vs)
    # The output a uses the input currently set: the one applied over the step just taken
    # (fmpy sets the next input only before the next step).
    f_now = np.concatenate([[forces[0]], forces])
    acc = (f_now + p.weight() - p.c * vs - p.k * xs) / p.m
    return xs, vs, acc


def analytic_step_response(p, force, t):
    """x(t) for constant force from (x0, v0), underdamped."""
    wn = np.sqrt(p.k / p.m)
    zeta = p.c / (2.0 * np.sqrt(p.k * p.m))
    wd = wn * np.sqrt(1.0 - zeta**2)
    xs = (force + p.weight()) / p.k
    a = p.x0 - xs
    b = (p.v0 + zeta * wn * a) / wd
    return xs + np.exp(-zeta * wn * t) * (a * np.cos(wd * t) + b * np.sin(wd * t))
