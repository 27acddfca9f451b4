"""The FMUs under test and what each test needs to know about them.

Every generic test in test_fmus.py runs once per entry of CASES. To add an FMU (cable_fmu,
stewart_fmu), append an FmuCase: its file in dist/, a time-varying input, a reference for the
simulate test, and the String parameter that names its resource file.
"""

from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional

import numpy as np

import oscillator_reference as osc


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
]
