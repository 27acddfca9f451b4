"""The zoo's FMUs (testfmus/) through fmpy: valid, each against its exact answer or an
independent reference, rollback and serialized states bit for bit, FMI 2.0 directional
derivatives against finite differences of fmi2GetReal after fmi2SetReal, and the end signal of
the stair (fmi2Discard, fmi2Terminated, fmi2LastSuccessfulTime)."""

import math
from ctypes import byref

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    fmi2LastSuccessfulTime,
    fmi2Terminated,
)
from fmpy.logging import addLoggerProxy
from fmpy.validation import validate_fmu

import fmpy
from conftest import Slave
from zoo import REPO, ball_exact, fmu_file, read_table, rk4_van_der_pol

ZOO = ["dahlquist", "van_der_pol", "bouncing_ball", "feedthrough", "stair", "resource"]
RESOURCES = REPO / "testfmus" / "fmus" / "resources"


@pytest.fixture(scope="module")
def unpacked(tmp_path_factory):
    """Every zoo FMU extracted once, with its parsed model description."""
    out = {}
    for name in ZOO:
        d = tmp_path_factory.mktemp(name)
        fmpy.extract(str(fmu_file(name)), str(d))
        out[name] = (str(d), fmpy.read_model_description(str(d)))
    return out


@pytest.mark.parametrize("name", ZOO)
def test_validate_fmu_reports_no_problem(name):
    assert validate_fmu(str(fmu_file(name))) == []


@pytest.mark.parametrize("name", ZOO)
def test_the_zoo_knows_nothing_of_the_extension(name, unpacked):
    """Third-party FMUs as far as a master can tell: no step-map annotation."""
    text = open(unpacked[name][0] + "/modelDescription.xml").read()
    assert "StepMapDerivative" not in text and "VendorAnnotations" not in text


def test_dahlquist_is_exact_for_a_held_input():
    # x' = -k x + u with u constant: x = u/k + (x0 - u/k) e^{-kt}, whatever the step
    k, x0, u = 0.7, 2.0, 0.5
    r = simulate_fmu(str(fmu_file("dahlquist")), stop_time=5.0, output_interval=0.1,
                     start_values={"k": k, "x0": x0, "u": u}, output=["x", "der_x"])
    exact = u / k + (x0 - u / k) * np.exp(-k * r["time"])
    assert np.max(np.abs(r["x"] - exact)) < 1e-14
    assert np.max(np.abs(r["der_x"] - (-k * exact + u))) < 1e-14


def test_van_der_pol_matches_an_independent_rk4_reference():
    # fmpy's output rows are the communication points; the reference: RK4 in numpy at 1e-4 s
    r = simulate_fmu(str(fmu_file("van_der_pol")), stop_time=10.0, output_interval=0.01,
                     output=["x0", "x1", "der_x0", "der_x1"])
    ref = rk4_van_der_pol(10.0, 1e-4, 2.0, 0.0)[::100]
    assert len(ref) == len(r)
    err = max(np.max(np.abs(r["x0"] - ref[:, 0])), np.max(np.abs(r["x1"] - ref[:, 1])))
    assert err < 1e-9, err
    assert np.max(np.abs(r["der_x0"] - r["x1"])) == 0.0
    der_x1 = (1 - r["x0"] ** 2) * r["x1"] - r["x0"]
    assert np.max(np.abs(r["der_x1"] - der_x1)) < 1e-12


@pytest.mark.parametrize("step", [0.01, 0.13, 1.0])
def test_bouncing_ball_locates_impacts_inside_steps(step):
    """The exact arcs and impact times, whatever the step: impacts fall inside steps, even
    several in one step of 1 s."""
    r = simulate_fmu(str(fmu_file("bouncing_ball")), stop_time=3.0, output_interval=step,
                     output=["h", "v", "bounces", "resting"])
    h, v, bounces, resting = ball_exact(r["time"])
    assert np.max(np.abs(r["h"] - h)) < 1e-12
    assert np.max(np.abs(r["v"] - v)) < 1e-12
    assert np.array_equal(r["bounces"], bounces) and np.array_equal(r["resting"], resting)
    # at rest at the first rebound below v_min: impact speeds sqrt(2 g h0) e^k
    impacts = math.ceil(math.log(0.1 / math.sqrt(2 * 9.81)) / math.log(0.7))
    assert bounces[-1] == impacts == 11 and resting[-1], "at rest within 3 s"


def test_feedthrough_passes_every_type_at_once(unpacked):
    """Outputs follow inputs at once (no step in between) and keep them over a step."""
    s = Slave(*unpacked["feedthrough"]).initialize()
    vr = s.vr

    def outputs():
        return (s.fmu.getReal([vr["real_continuous_out"], vr["real_discrete_out"]]), s.fmu.getInteger([vr["int_out"]]),
                        s.fmu.getBoolean([vr["bool_out"]]), [x.decode() for x in s.fmu.getString([vr["string_out"]])])

    for n, (x, d, i, b, text) in enumerate([(1.5, -2.0, 7, True, "héllo, world"), (0.0, 3.25, -4, False, "")]):
        s.fmu.setReal([vr["real_continuous_in"], vr["real_discrete_in"]], [x, d])
        s.fmu.setInteger([vr["int_in"]], [i])
        s.fmu.setBoolean([vr["bool_in"]], [b])
        s.fmu.setString([vr["string_in"]], [text])
        expected = ([x, d], [i], [b], [text])
        assert outputs() == expected, "at once"
        s.fmu.doStep(currentCommunicationPoint=0.1 * n, communicationStepSize=0.1)
        assert outputs() == expected, "after the step"
    s.free()


def test_stair_ends_with_discard_terminated_and_its_last_successful_time(unpacked):
    s = Slave(*unpacked["stair"]).initialize()
    counter = s.vr["counter"]
    t, h, counts = 0.0, 0.4, []
    with pytest.raises(FMICallException) as e:
        for n in range(100):
            s.fmu.doStep(currentCommunicationPoint=n * h, communicationStepSize=h)
            counts.append(s.fmu.getInteger([counter])[0])
            t = (n + 1) * h
    assert e.value.status == 2, "fmi2Discard"
    assert s.fmu.getBooleanStatus(fmi2Terminated) is True
    assert s.fmu.getRealStatus(fmi2LastSuccessfulTime) == 9.0, "inside the step from 8.8 to 9.2"
    assert s.fmu.getInteger([counter]) == [10]
    assert abs(t - 8.8) < 1e-12
    expected = [1 + math.floor((k + 1) * h + 1e-9) for k in range(len(counts))]
    assert counts == expected
    s.fmu.terminate()
    s.free()
    # fmpy's own loop stops at the last successful time
    r = simulate_fmu(str(fmu_file("stair")), stop_time=12.0, output_interval=0.4)
    assert r["time"][-1] == 9.0 and r["counter"][-1] == 10


def test_resource_reads_its_file_from_the_unpacked_resources():
    for file in ("signal.txt", "ramp.txt"):
        title, ts, ys = read_table(RESOURCES / file)
        r = simulate_fmu(str(fmu_file("resource")), stop_time=4.0, output_interval=0.1,
                         start_values={"file": file}, output=["y", "points"])
        assert np.max(np.abs(r["y"] - np.interp(r["time"], ts, ys))) < 1e-14, file
        assert np.all(r["points"] == len(ts))


def test_resource_names_a_missing_file_and_needs_a_resource_location(unpacked):
    directory, md = unpacked["resource"]
    s = Slave(directory, md)
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    assert s.fmu.getString([s.vr["title"]]) == [b"triangle from resources/signal.txt"]
    with pytest.raises(FMICallException):
        s.set("file", "missing.txt")
    assert any("missing.txt" in m for m in s.errors()), s.messages
    assert s.fmu.getString([s.vr["file"]]) == [b"signal.txt"], "the parameter keeps its file"
    s.free()
    # without a resource location the FMU cannot read its file: fmi2Instantiate fails and says why
    lib = Slave(directory, md).fmu
    messages = []
    cb = fmi2CallbackFunctions()
    cb.logger = fmi2CallbackLoggerTYPE(lambda env, inst, status, cat, msg: messages.append(msg.decode()))
    cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(fmpy.calloc)
    cb.freeMemory = fmi2CallbackFreeMemoryTYPE(fmpy.free)
    addLoggerProxy(byref(cb))
    c = lib.fmi2Instantiate(b"nowhere", 1, md.guid.encode(), None, byref(cb), 0, 0)
    assert not c
    assert any("no resource location" in m for m in messages), messages


# --- the generic checks, per FMU: a drive of its inputs ------------------------------------------

DRIVES = {
    # name: (start values, {input: value at t}, outputs compared)
    "dahlquist": ({"k": 1.3, "x0": 0.4}, {"u": lambda t: math.sin(3 * t)}, ["x", "der_x"]),
    "van_der_pol": ({"mu": 2.0}, {"u": lambda t: 0.5 * math.cos(t)}, ["x0", "x1", "der_x0", "der_x1"]),
    "bouncing_ball": ({"e": 0.8}, {}, ["h", "v"]),
    "feedthrough": ({}, {"real_continuous_in": lambda t: t * t, "real_discrete_in": lambda t: -t},
                    ["real_continuous_out", "real_discrete_out"]),
    "stair": ({"period": 0.07, "final_count": 1000}, {}, []),
    "resource": ({}, {}, ["y"]),
}


def steps(s, drive, outputs, t0, n, h=0.05):
    rows = []
    for k in range(n):
        t = t0 + k * h
        for name, f in drive.items():
            s.fmu.setReal([s.vr[name]], [f(t)])
        s.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        rows.append([float(x).hex() for x in s.get_real(outputs)]
                    + [s.fmu.getInteger([v.valueReference])[0] for v in s.md.modelVariables
                       if v.type == "Integer" and v.causality == "output"])
    return rows


@pytest.mark.parametrize("name", ZOO)
def test_rollback_and_serialized_states_reproduce_every_output_bit_for_bit(name, unpacked):
    start, drive, outputs = DRIVES[name]
    a = Slave(*unpacked[name], name="a").initialize(start)
    steps(a, drive, outputs, 0.0, 10)
    state = a.fmu.getFMUstate()
    blob = a.fmu.serializeFMUstate(state)
    first = steps(a, drive, outputs, 0.5, 20)
    a.fmu.setFMUstate(state)
    assert steps(a, drive, outputs, 0.5, 20) == first
    b = Slave(*unpacked[name], name="b")
    b.fmu.setFMUstate(b.fmu.deSerializeFMUstate(blob))
    assert steps(b, drive, outputs, 0.5, 20) == first
    a.fmu.freeFMUstate(state)
    a.free()
    b.free()


def fd_check(s, unknowns, knowns, step_mode, delta=1e-6):
    """fmi2GetDirectionalDerivative against central differences of fmi2GetReal after
    fmi2SetReal (no step in between): every pair, declared or not; in step mode an output that
    <ModelStructure><Outputs> declares independent of an input has a zero derivative."""
    for k in knowns:
        x0 = s.fmu.getReal([s.vr[k]])[0]
        s.fmu.setReal([s.vr[k]], [x0 + delta])
        up = np.array(s.get_real(unknowns))
        s.fmu.setReal([s.vr[k]], [x0 - delta])
        down = np.array(s.get_real(unknowns))
        s.fmu.setReal([s.vr[k]], [x0])
        fd = (up - down) / (2 * delta)
        exact = np.array(s.fmu.getDirectionalDerivative([s.vr[u] for u in unknowns], [s.vr[k]], [1.0]))
        assert np.allclose(exact, fd, rtol=1e-7, atol=1e-8), f"d/d{k}: exact {exact}, differences {fd}"
        for u, d in zip(unknowns, exact):
            if not step_mode:
                continue
            declared = [dep.name for dep in (s.md_outputs.get(u) or [])]
            if k in s.inputs and k not in declared:
                assert d == 0.0, f"{u} is declared independent of {k} but its derivative is {d}"


DERIVATIVES = {
    # name: (outputs, knowns in initialization mode, knowns in step mode)
    "dahlquist": (["x", "der_x"], ["u", "k", "x0"], ["u", "k"]),
    "van_der_pol": (["x0", "x1", "der_x0", "der_x1"], ["u", "mu", "x0_start", "x1_start"], ["u", "mu"]),
    "feedthrough": (["real_continuous_out", "real_discrete_out"], ["real_continuous_in", "real_discrete_in"],
                    ["real_continuous_in", "real_discrete_in"]),
}


@pytest.mark.parametrize("name", sorted(DERIVATIVES))
def test_directional_derivatives_are_fmi2s_at_the_communication_point(name, unpacked):
    outputs, init_knowns, step_knowns = DERIVATIVES[name]
    start, drive, _ = DRIVES[name]
    directory, md = unpacked[name]
    assert md.coSimulation.providesDirectionalDerivative
    s = Slave(directory, md)
    s.md_outputs = {u.variable.name: u.dependencies for u in md.outputs}
    s.inputs = [v.name for v in md.modelVariables if v.causality == "input"]
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    for k, v in start.items():
        s.set(k, v)
    fd_check(s, outputs, init_knowns, step_mode=False)
    s.fmu.exitInitializationMode()
    steps(s, drive, [], 0.0, 7)
    fd_check(s, outputs, step_knowns, step_mode=True)
    s.free()
