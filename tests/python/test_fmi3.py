"""FMI 3.0: the workspace's FMUs exported as FMI 3.0 (dist/fmi3/) and small FMI 3.0 FMUs
written in C (testfmus/c/, built here), checked by fmpy and run by the master.

* fmpy validates every FMI 3.0 FMU (its schema and rules);
* fmpy drives each FMU of fmus.CASES in both versions under the same inputs: every output
  equal to 1e-12 (they run the same model through two export layers);
* fmpy runs the C FMUs against their exact answers (Dahlquist's closed form, the
  feedthrough's arrays, the stair's end);
* the master runs the zoo's systems with FMI 3.0 FMUs (the C ones, and the workspace's FMI 3.0
  zoo) with every scheme against the answers each scheme must give (zoo.py)."""

import math
import shutil

import fmpy
import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu

import c_fmus
from conftest import DIST
from fmus import CASES
from test_fmus import drive_table
from zoo import (
    TIGHT,
    ITERATING,
    SCHEMES,
    ball_exact,
    chain_expected,
    check_oscillators,
    loop_expected,
    pack,
    run,
)

FMI3 = DIST / "fmi3"
EXPORTED = ["cable_fmu", "stewart_fmu", "oscillator", "dahlquist", "van_der_pol", "bouncing_ball", "feedthrough",
            "stair", "resource"]


@pytest.fixture(scope="module")
def c_built(tmp_path_factory):
    return c_fmus.build(tmp_path_factory.mktemp("c-fmus"))


def fmi3_file(name):
    path = FMI3 / f"{name}.fmu"
    assert path.is_file(), f"{path} is missing: run `target/release/master package --out {DIST}` first"
    return path


@pytest.mark.parametrize("name", EXPORTED)
def test_fmpy_validates_the_exported_fmi3_fmu(name):
    assert validate_fmu(str(fmi3_file(name))) == []
    md = read_model_description(str(fmi3_file(name)))
    assert md.fmiVersion == "3.0" and md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate


def test_fmpy_validates_the_c_fmus(c_built):
    assert {name: validate_fmu(str(path)) for name, path in c_built.items()} == {n: [] for n in c_built}


class Driven:
    """One FMU (either version) instantiated by fmpy and driven step by step, variables by the
    names of the FMI 2.0 view (`name[k]` is element k of the FMI 3.0 array `name`)."""

    def __init__(self, path, directory):
        fmpy.extract(str(path), directory)
        self.md = md = read_model_description(directory)
        self.v3 = md.fmiVersion.startswith("3")
        self.var = {v.name: v for v in md.modelVariables}
        if self.v3:
            self.fmu = FMU3Slave(guid=md.instantiationToken, unzipDirectory=directory,
                                 modelIdentifier=md.coSimulation.modelIdentifier, instanceName="x")
        else:
            self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=directory,
                                 modelIdentifier=md.coSimulation.modelIdentifier, instanceName="x")
        self.fmu.instantiate()

    def where(self, name):
        """(variable, element index or None)."""
        if name in self.var:
            return self.var[name], None
        base, k = name[:-1].split("[")
        return self.var[base], int(k) - 1

    def initialize(self, start_values):
        if self.v3:
            self.fmu.enterInitializationMode(startTime=0.0)
        else:
            self.fmu.setupExperiment(startTime=0.0)
            self.fmu.enterInitializationMode()
        for name, value in start_values.items():
            v, _ = self.where(name)
            setter = {"Real": "setReal", "Float64": "setFloat64", "Integer": "setInteger", "Int32": "setInt32",
                      "Boolean": "setBoolean", "String": "setString"}[v.type]
            getattr(self.fmu, setter)([v.valueReference], [value])
        self.fmu.exitInitializationMode()

    def set_reals(self, names, values):
        if not self.v3:
            self.fmu.setReal([self.var[n].valueReference for n in names], list(values))
            return
        arrays = {}
        for name, x in zip(names, values):
            v, k = self.where(name)
            arrays.setdefault(v.valueReference, {})[k or 0] = x
        for vr, elements in arrays.items():
            assert sorted(elements) == list(range(len(elements))), "every element set"
            self.fmu.setFloat64([vr], [elements[k] for k in range(len(elements))])

    def get_reals(self, names):
        if not self.v3:
            return self.fmu.getReal([self.var[n].valueReference for n in names])
        out = []
        for name in names:
            v, k = self.where(name)
            values = self.fmu.getFloat64([v.valueReference], nValues=int(v.dimensions[0].start) if v.dimensions else 1)
            out.append(values[k or 0])
        return out

    def step(self, t, h):
        self.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_fmi3_twin_follows_the_fmi2_fmu_under_the_same_inputs(case, tmp_path):
    """fmpy drives both versions of each FMU with the case's time-varying inputs: the same model
    behind two export layers, so the outputs agree to 1e-12 (in fact bit for bit)."""
    runs = []
    for version, path in (("2", DIST / f"{case.name}.fmu"), ("3", fmi3_file(case.name))):
        d = Driven(path, str(tmp_path / version))
        d.initialize(case.start_values)
        rows = [d.get_reals(case.outputs)]
        for n in range(40):
            t = n * case.step_size
            d.set_reals(case.inputs, case.drive(t))
            d.step(t, case.step_size)
            rows.append(d.get_reals(case.outputs))
        d.fmu.terminate()
        d.fmu.freeInstance()
        runs.append(np.array(rows))
    two, three = runs
    scale = np.maximum(np.abs(two).max(axis=0), 1e-300)
    assert (np.abs(three - two).max(axis=0) / scale <= 1e-12).all()
    assert np.array_equal(two, three), "the same arithmetic: bit for bit"


def test_fmpy_runs_the_c_fmus_to_their_exact_answers(c_built, tmp_path):
    r = simulate_fmu(str(c_built["dahlquist"]), stop_time=2.0, output_interval=0.1, start_values={"k": 1.5, "x0": 2.0})
    assert np.max(np.abs(r["x"] - 2.0 * np.exp(-1.5 * r["time"]))) < 1e-14
    assert np.max(np.abs(r["der_x"] + 1.5 * r["x"])) < 1e-14
    # the stair ends the simulation at its final count (terminateSimulation)
    r = simulate_fmu(str(c_built["stair"]), stop_time=20.0, output_interval=0.4)
    assert r["counter"][-1] == 10 and r["time"][-1] < 10.0
    assert np.array_equal(r["counter"], np.minimum(1 + np.floor(r["time"] + 1e-9), 10))
    # the feedthrough passes its array through
    d = Driven(c_built["feedthrough"], str(tmp_path / "f"))
    d.initialize({})
    d.fmu.setFloat64([5], [1.5, -2.0, 3.25])
    d.step(0.0, 0.1)
    assert d.fmu.getFloat64([6], nValues=3) == [1.5, -2.0, 3.25]
    assert d.get_reals(["array_out[2]"]) == [-2.0]
    d.fmu.freeInstance()


# --- the master with FMI 3.0 FMUs --------------------------------------------------------------

KINDS = ["c", "exported"]


@pytest.fixture(scope="module", params=KINDS)
def fmi3_systems(request, tmp_path_factory, c_built):
    """The zoo's systems whose FMUs have FMI 3.0 versions, packed with them: the C FMUs, or the
    workspace's FMI 3.0 zoo."""
    d = tmp_path_factory.mktemp(f"fmi3-systems-{request.param}")
    names = ["dahlquist", "van_der_pol", "feedthrough", "stair"]
    fmus = c_built if request.param == "c" else {n: fmi3_file(n) for n in names}
    return {name: pack(name, d, fmus=fmus) for name in ["chain", "loop", "oscillators", "stair"]}


@pytest.mark.parametrize("scheme", SCHEMES)
def test_fmi3_chain_gives_each_schemes_exact_answer(fmi3_systems, scheme):
    cols, js, _ = run(fmi3_systems["chain"], scheme, 0.1, *TIGHT)
    x1, f_out, x2 = chain_expected(cols["time"], scheme)
    assert np.max(np.abs(cols["d1.x"] - x1)) < 1e-14
    assert np.max(np.abs(cols["f.real_continuous_out"] - f_out)) < 1e-12
    assert np.max(np.abs(cols["d2.x"] - x2)) < 1e-12


@pytest.mark.parametrize("scheme", SCHEMES)
def test_fmi3_loop_is_solved_by_iterating_schemes_and_refused_by_the_others(fmi3_systems, scheme):
    if scheme not in ITERATING:
        _, _, p = run(fmi3_systems["loop"], scheme, 0.1, expect_ok=False)
        assert p.returncode != 0 and f"scheme {scheme} cannot solve the system's algebraic loop" in p.stderr
        return
    cols, js, _ = run(fmi3_systems["loop"], scheme, 0.1, *TIGHT)
    assert np.max(np.abs(cols["d.x"] - loop_expected(cols["time"]))) < 1e-12
    assert js["max_interface_residual"] < 1e-13


@pytest.mark.parametrize("scheme", SCHEMES)
def test_fmi3_oscillators_follow_the_van_der_pol_reference(fmi3_systems, scheme):
    cols, _, _ = run(fmi3_systems["oscillators"], scheme, 0.05, *TIGHT)
    check_oscillators(cols, scheme)


@pytest.mark.parametrize("scheme", SCHEMES)
def test_fmi3_stair_ends_the_run_early_and_cleanly(fmi3_systems, scheme):
    """The stair reports its end with terminateSimulation at t = 9 s inside the step from 8.8 s:
    the run stops at 8.8 s, the last point every component reached."""
    cols, js, p = run(fmi3_systems["stair"], scheme, 0.4, *TIGHT)
    assert js["stopped_early"] is True
    assert js["stopped_at"] == pytest.approx(8.8, abs=1e-12)
    assert "terminateSimulation" in js["note"] and "last successful time 9 s" in js["note"], js["note"]
    t = cols["time"]
    assert len(t) == 23 and t[-1] == pytest.approx(8.8)
    counter = 1 + np.floor(t + 1e-9)
    assert np.array_equal(cols["stair.counter"], counter)
    assert np.array_equal(cols["f.int_out"], np.concatenate([[1], counter[:-1]]))


@pytest.mark.parametrize("scheme", SCHEMES)
def test_fmi3_ball_carries_int32_and_boolean_connections(tmp_path_factory, scheme):
    """The exported FMI 3.0 bouncing ball and feedthrough: the ball's closed form; Int32 and
    Boolean values passed a step late, as with FMI 2.0."""
    fmus = {n: fmi3_file(n) for n in ["bouncing_ball", "feedthrough"]}
    system = pack("ball", tmp_path_factory.mktemp(f"fmi3-ball-{scheme}"), fmus=fmus)
    cols, _, _ = run(system, scheme, 0.01, *TIGHT)
    h, v, bounces, resting = ball_exact(cols["time"])
    assert np.max(np.abs(cols["ball.h"] - h)) < 1e-12 and np.max(np.abs(cols["ball.v"] - v)) < 1e-12
    late = lambda x: np.concatenate([x[:1], x[:-1]])  # noqa: E731
    assert np.array_equal(cols["f.int_out"], late(bounces))
    assert np.array_equal(cols["f.bool_out"] == 1, late(resting))
    assert bounces[-1] == 11 and resting[-1]


def test_a_system_of_both_versions_runs_like_the_fmi2_system(tmp_path):
    """The chain with its feedthrough in FMI 3.0 and its Dahlquist units in FMI 2.0 gives the FMI
    2.0 chain's numbers exactly, with every scheme."""
    for scheme in SCHEMES:
        mixed = pack("chain", tmp_path / f"mixed-{scheme}", fmus={"feedthrough": fmi3_file("feedthrough")})
        plain = pack("chain", tmp_path / f"plain-{scheme}")
        a, _, _ = run(mixed, scheme, 0.1, *TIGHT)
        b, _, _ = run(plain, scheme, 0.1, *TIGHT)
        for name in ("d1.x", "f.real_continuous_out", "d2.x"):
            assert np.array_equal(a[name], b[name]), (scheme, name)
