"""Physics of the fmi test oscillator through fmpy, against closed-form and discrete references."""

import shutil
import tempfile

import fmpy
import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException

import oscillator_reference as osc
from conftest import Slave, fmu_path
from fmus import CASES

CASE = next(c for c in CASES if c.name == "oscillator")


def step_response(h, start_values):
    """x(t) under a constant force F = 2 N, simulated by fmpy with communication step h."""
    table = np.array([(0.0, 2.0), (10.0, 2.0)], dtype=[("time", np.float64), ("F", np.float64)])
    r = simulate_fmu(str(fmu_path(CASE)), stop_time=3.0, output_interval=h, input=table,
                     start_values=start_values, output=["x"])
    return r["time"], r["x"]


def test_constant_force_converges_to_the_analytic_solution_at_second_order():
    sv = {"gravity": True, "c": 2.0}
    p = osc.Parameters.from_start_values(sv)
    errors = []
    for h in (0.02, 0.01, 0.005):
        t, x = step_response(h, sv)
        errors.append(np.abs(x - osc.analytic_step_response(p, 2.0, t)).max())
    # Trapezoidal rule: global error ~ h^2 (phase error ω³h²t/12 times the amplitude).
    wn = np.sqrt(p.k / p.m)
    bound = 1.2 * abs(p.x0 - (2.0 + p.weight()) / p.k) * wn**3 * 0.02**2 * 3.0 / 12
    assert errors[0] < bound, (errors, bound)
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    assert all(3.6 < r < 4.4 for r in ratios), ratios


@pytest.fixture(scope="module")
def oscillator():
    d = tempfile.mkdtemp(prefix="fmi-osc-")
    fmpy.extract(str(fmu_path(CASE)), d)
    yield d, read_model_description(d)
    shutil.rmtree(d, ignore_errors=True)


def test_linear_input_interpolation(oscillator):
    """fmi2SetRealInputDerivatives with the slope of each input segment: the FMU integrates the
    piecewise-linear input exactly as the trapezoidal rule sees it. (fmpy's own
    set_input_derivatives=True fails for a single input in fmpy 0.3.32, so FMU2Slave is driven
    directly.)"""
    h = 0.01
    times = np.arange(0.0, 2.0 + h / 2, h)
    values = np.sin(3.0 * times)
    rates = np.diff(values) / np.diff(times)
    s = Slave(*oscillator).initialize()
    f = [s.vr["F"]]
    x = [s.get_real(["x"])[0]]
    for n in range(len(times) - 1):
        s.fmu.setReal(f, [values[n]])
        s.fmu.setRealInputDerivatives(f, [1], [rates[n]])
        s.fmu.doStep(times[n], h)
        x.append(s.get_real(["x"])[0])
    expected, _, _ = osc.trapezoid(osc.Parameters(), times, values[:-1], force_rates=rates)
    assert np.abs(np.array(x) - expected).max() <= 1e-12 * np.abs(expected).max()
    with pytest.raises(FMICallException):
        s.fmu.setRealInputDerivatives(f, [2], [0.0])
    assert any("only first-order input derivatives" in m for m in s.errors()), s.messages
    s.free()


def test_parameters_of_every_type_reach_the_model(oscillator):
    s = Slave(*oscillator)
    s.initialize({"substeps": 4, "gravity": True, "k": 25.0, "x0": 0.0})
    assert s.fmu.getInteger([s.vr["substeps"]]) == [4]
    assert s.fmu.getBoolean([s.vr["gravity"]]) == [True]
    assert s.fmu.getString([s.vr["config"]]) == [b"oscillator.txt"]
    assert s.get_real(["a"])[0] == -osc.G
    s.free()
