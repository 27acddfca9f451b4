"""The FMUs under test and what each test needs to know about them.

Every generic test in test_fmus.py runs once per entry of CASES. To add an FMU (cable_fmu,
stewart_fmu), append an FmuCase: its file in dist/, a time-varying input, a reference for the
simulate test, and the String parameter that names its resource file.
"""

from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional

import os
import pathlib
import subprocess
import tempfile

import numpy as np

import oscillator_reference as osc

REPO = pathlib.Path(__file__).resolve().parents[2]
# cargo's build directory: CARGO_TARGET_DIR where it is set (relative to the repository, where
# the test command runs cargo), else target/
TARGET = REPO / os.environ.get("CARGO_TARGET_DIR", "target")
MASTER = TARGET / "release" / "master"


@dataclass
class FmuCase:
    name: str  # the .fmu file name without extension (= modelIdentifier)
    inputs: List[str]
    outputs: List[str]
    step_size: float
    stop_time: float
    # Input values at time t, one per input (the time-varying drive of the tests).
    drive: Callable[[float], np.ndarray]
    # Expected outputs of fmpy.simulate_fmu (structured array with time, inputs and outputs):
    # returns an array (rows = result rows, columns = outputs), and the relative tolerance.
    reference: Callable[[np.ndarray, Dict], np.ndarray]
    reference_rtol: float
    # The String parameter naming a resource file (relative to resources/), for the missing-file test.
    resource_parameter: str
    # Perturbation of each input for the central differences, and the agreement required.
    fd_delta: List[float]
    fd_rtol: float
    start_values: Dict = field(default_factory=dict)
    # Steps taken before the rollback / derivative checks.
    warmup_steps: int = 20


def _oscillator_reference(result, start_values):
    p = osc.Parameters.from_start_values(start_values)
    forces = osc.held_force(result["time"], OSCILLATOR_DRIVE)
    x, v, a = osc.trapezoid(p, result["time"], forces)
    return np.column_stack([x, v, a])


def OSCILLATOR_DRIVE(t):
    return np.array([3.0 * np.sin(2.0 * t) + 0.5])


def rust_replay(model, scene, inputs, outputs, result, newton_tol=None):
    """The model's Rust library run in-process (`master replay`) on the inputs fmpy applied
    (recorded in `result` at every communication point); returns the outputs at the same times."""
    with tempfile.TemporaryDirectory() as d:
        table = pathlib.Path(d) / "inputs.csv"
        out = pathlib.Path(d) / "outputs.csv"
        columns = ["time"] + inputs
        data = np.column_stack([result[c] for c in columns])
        np.savetxt(table, data, delimiter=",", header=",".join(columns), comments="", fmt="%.17e")
        cmd = [str(MASTER), "replay", "--model", model, "--scene", str(scene), "--inputs", str(table), "--out", str(out)]
        if newton_tol is not None:
            cmd += ["--newton-tol", repr(newton_tol)]
        subprocess.run(cmd, check=True)
        ref = np.genfromtxt(out, delimiter=",", names=True, deletechars="")
    assert np.array_equal(ref["time"], result["time"]), "the replay must report the same times"
    return np.column_stack([ref[name] for name in outputs])


CABLE_INPUTS = ["wrench.f[1]", "wrench.f[2]", "wrench.f[3]", "wrench.m[1]", "wrench.m[2]", "wrench.m[3]"]
CABLE_OUTPUTS = (
    [f"cabin.r[{k}]" for k in (1, 2, 3)]
    + [f"cabin.q[{k}]" for k in (1, 2, 3, 4)]
    + [f"cabin.{p}[{k}]" for p in ("v", "w", "a", "alpha") for k in (1, 2, 3)]
    + [f"cable.tension_{e}[{i}]" for e in ("anchor", "cabin") for i in range(1, 7)]
)
# The static wrench of the Stewart platform at its starting pose in scene C (the input start).
CABLE_STATIC = np.array([0.0, 0.0, -1812.888, 0.0, 96.7256, 0.0])


def CABLE_DRIVE(t):
    """Platform-like disturbance on top of the static wrench: rotating force and moment."""
    return CABLE_STATIC + np.array(
        [40.0 * np.sin(0.9 * t), -25.0 * np.cos(0.6 * t), 15.0 * np.sin(2.1 * t), 8.0 * np.cos(1.3 * t), -12.0 * np.sin(0.7 * t), 3.0]
    )


STEWART_INPUTS = [f"cabin.{p}[{k}]" for p, n in (("r", 3), ("q", 4), ("v", 3), ("w", 3), ("a", 3), ("alpha", 3)) for k in range(1, n + 1)]
STEWART_OUTPUTS = (
    [f"wrench.{p}[{k}]" for p in ("f", "m") for k in (1, 2, 3)]
    + [f"actuator.force[{k}]" for k in range(1, 7)]
    + [f"platform.r[{k}]" for k in (1, 2, 3)]
    + [f"platform.q[{k}]" for k in (1, 2, 3, 4)]
)


def swaying_cabin(t, a, w, tilt, rate):
    """The cabin at scene C's pose (9.8 m above the origin), swaying by `a` (m) at `w` (rad/s) and
    turning by `tilt` (rad) at `rate` (rad/s) about the world x axis: its 19 inputs (position,
    quaternion, velocity, angular velocity, acceleration, angular acceleration), consistent
    kinematics."""
    x, v, acc = a * np.sin(w * t), a * w * np.cos(w * t), -a * w * w * np.sin(w * t)
    th = tilt * np.sin(rate * t)
    return np.array(
        [x, 0.5 * x, 9.8 - 0.2 * x, np.cos(th / 2), np.sin(th / 2), 0.0, 0.0,
         v, 0.5 * v, -0.2 * v, tilt * rate * np.cos(rate * t), 0.0, 0.0,
         acc, 0.5 * acc, -0.2 * acc, -tilt * rate * rate * np.sin(rate * t), 0.0, 0.0]
    )


def STEWART_DRIVE(t):
    """The cabin at scene C's pose, swaying and turning a little."""
    return swaying_cabin(t, 2e-3, 0.8, 1e-3, 0.5)


def _lt50m_case(name, inputs, outputs, drive, fd_delta, start_values=None):
    """An FMU of the LT50m models: 3 s of scene C in steps of 0.01 s, against its Rust library
    replayed in-process on the inputs fmpy applied."""
    def reference(result, start_values):
        scene = REPO / "scenes" / "lt50m_C.toml"
        return rust_replay(name, scene, inputs, outputs, result, start_values.get("newton_tol"))

    return FmuCase(name=name, inputs=inputs, outputs=outputs, step_size=0.01, stop_time=3.0, drive=drive,
                   reference=reference, reference_rtol=1e-9, resource_parameter="scene", fd_delta=fd_delta,
                   fd_rtol=1e-6, start_values=start_values or {})


CASES = [
    FmuCase(
        name="oscillator",
        inputs=["F"],
        outputs=["x", "v", "a"],
        step_size=0.01,
        stop_time=5.0,
        drive=OSCILLATOR_DRIVE,
        reference=_oscillator_reference,
        reference_rtol=1e-12,
        resource_parameter="config",
        fd_delta=[1e-3],
        fd_rtol=1e-8,
        start_values={"k": 50.0, "c": 1.0, "substeps": 3, "gravity": True, "x0": 0.05},
    ),
    # a tight Newton tolerance: the finite differences then measure the model, not the solver
    _lt50m_case("cable_fmu", CABLE_INPUTS, CABLE_OUTPUTS, CABLE_DRIVE, [20.0, 20.0, 20.0, 10.0, 10.0, 10.0],
                start_values={"newton_tol": 1e-13}),
    _lt50m_case("stewart_fmu", STEWART_INPUTS, STEWART_OUTPUTS, STEWART_DRIVE, [1e-5] * 19),
]
