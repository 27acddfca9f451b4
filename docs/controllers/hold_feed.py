"""A controller of the Stewart platform written in Python with pythonfmu (docs/controllers.md):
the cabin's motion in, the platform's command out (control_fmu's interface). At the end of each
of its steps it reads the cabin's pose and commands the platform so that a feed fixed to it stays
where it was at the start: the centre back to its start position in the world, the attitude back
to its start attitude; `gain` scales the command (0: the platform held at home). The same law as
testfmus/c/controller.c. Build: `pythonfmu build -f hold_feed.py --handle-state`."""

import math

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real

CABIN = [("r", 3), ("q", 4), ("v", 3), ("w", 3), ("a", 3), ("alpha", 3)]


def rotate(q, v, back=False):
    """v rotated by the unit quaternion q (w, x, y, z), body to world (or back)."""
    w, x, y, z = q[0], *(-c if back else c for c in q[1:])
    t = (2 * (y * v[2] - z * v[1]), 2 * (z * v[0] - x * v[2]), 2 * (x * v[1] - y * v[0]))
    return (v[0] + w * t[0] + (y * t[2] - z * t[1]),
            v[1] + w * t[1] + (z * t[0] - x * t[2]),
            v[2] + w * t[2] + (x * t[1] - y * t[0]))


def unit(q):
    n = math.sqrt(sum(c * c for c in q))
    return [c / n for c in q]


class HoldFeed(Fmi2Slave):
    description = "Holds the feed's start pose from the cabin's pose at each step (docs/controllers.md)"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.cabin = {"r": [0.0, 0.0, 9.8], "q": [1.0, 0.0, 0.0, 0.0], **{n: [0.0] * 3 for n in "v w a alpha".split()}}
        self.command = {"r": [0.0] * 3, "rot": [0.0] * 3}
        self.gain = 1.0
        self.home = [0.1, 0.0, -1.8]  # the platform centre at home, cabin frame (m)
        self.start = None
        for name, n in CABIN:
            for k in range(n):
                self.register_variable(Real(f"cabin.{name}[{k + 1}]", causality=Fmi2Causality.input,
                                            getter=self._get(self.cabin[name], k), setter=self._set(self.cabin[name], k)))
        for name in ("r", "rot"):
            for k in range(3):
                self.register_variable(Real(f"command.{name}[{k + 1}]", causality=Fmi2Causality.output,
                                            getter=self._get(self.command[name], k), setter=self._set(self.command[name], k)))
        self.register_variable(Real("gain", causality=Fmi2Causality.parameter, variability=Fmi2Variability.tunable))

    @staticmethod
    def _get(values, k):
        return lambda: values[k]

    @staticmethod
    def _set(values, k):
        def set_(value):
            values[k] = value
        return set_

    def exit_initialization_mode(self):
        self.start = (list(self.cabin["r"]), unit(self.cabin["q"]))

    def do_step(self, current_time, step_size):
        r0, q0 = self.start
        q = unit(self.cabin["q"])
        at_home = rotate(q0, self.home)
        world = [r0[i] + at_home[i] - self.cabin["r"][i] for i in range(3)]
        centre = rotate(q, world, back=True)
        # q⁻¹ q0 as a rotation vector
        d = (q[0] * q0[0] + q[1] * q0[1] + q[2] * q0[2] + q[3] * q0[3],
             q[0] * q0[1] - q[1] * q0[0] - q[2] * q0[3] + q[3] * q0[2],
             q[0] * q0[2] + q[1] * q0[3] - q[2] * q0[0] - q[3] * q0[1],
             q[0] * q0[3] - q[1] * q0[2] + q[2] * q0[1] - q[3] * q0[0])
        s = math.sqrt(d[1] ** 2 + d[2] ** 2 + d[3] ** 2)
        angle, sign = 2.0 * math.atan2(s, abs(d[0])), (-1.0 if d[0] < 0 else 1.0)
        for i in range(3):
            self.command["r"][i] = self.gain * (centre[i] - self.home[i])
            self.command["rot"][i] = self.gain * sign * angle * d[i + 1] / s if s > 0 else 0.0
        return True
