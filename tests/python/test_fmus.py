"""fmpy cross-checks of every packaged FMU (one parametrisation per entry of fmus.CASES)."""

import math
import resource

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu

from conftest import Slave, expect_error, fmu_path


def drive_table(case):
    """The drive sampled on the communication grid, as an fmpy input table."""
    times = np.arange(0.0, case.stop_time + case.step_size / 2, case.step_size)
    dtype = [("time", np.float64)] + [(name, np.float64) for name in case.inputs]
    rows = [(t, *case.drive(t)) for t in times]
    return np.array(rows, dtype=dtype)


def step_with_drive(slave, case, t0, n):
    """n communication steps from t0 under the drive; returns the outputs after each step."""
    h = case.step_size
    input_vrs = [slave.vr[i] for i in case.inputs]
    out = []
    for k in range(n):
        t = t0 + k * h
        slave.fmu.setReal(input_vrs, list(case.drive(t)))
        slave.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        out.append(slave.get_real(case.outputs))
    return out


def same_bits(a, b):
    return [[float(x).hex() for x in row] for row in a] == [[float(x).hex() for x in row] for row in b]


def test_validate_fmu_reports_no_problem(case):
    assert validate_fmu(str(fmu_path(case))) == []


def test_simulate_fmu_matches_the_reference(case):
    result = simulate_fmu(
        str(fmu_path(case)),
        stop_time=case.stop_time,
        output_interval=case.step_size,
        input=drive_table(case),
        start_values=case.start_values,
        output=case.inputs + case.outputs,
    )
    expected = case.reference(result, case.start_values)
    got = np.column_stack([result[name] for name in case.outputs])
    assert got.shape == expected.shape
    scale = np.maximum(np.abs(expected).max(axis=0), 1e-300)
    err = np.abs(got - expected).max(axis=0) / scale
    assert (err <= case.reference_rtol).all(), f"relative errors {dict(zip(case.outputs, err))}"


def test_rollback_reproduces_every_output_bit_for_bit(case, unpacked):
    s = Slave(*unpacked).initialize(case.start_values)
    step_with_drive(s, case, 0.0, case.warmup_steps)
    t0 = case.warmup_steps * case.step_size
    state = s.fmu.getFMUstate()
    first = step_with_drive(s, case, t0, 30)
    s.fmu.setFMUstate(state)
    again = step_with_drive(s, case, t0, 30)
    assert same_bits(first, again)
    s.fmu.freeFMUstate(state)
    s.free()


def test_serialized_state_round_trips(case, unpacked):
    a = Slave(*unpacked, name="a").initialize(case.start_values)
    step_with_drive(a, case, 0.0, case.warmup_steps)
    t0 = case.warmup_steps * case.step_size
    blob = a.fmu.serializeFMUstate(a.fmu.getFMUstate())
    b = Slave(*unpacked, name="b")
    state = b.fmu.deSerializeFMUstate(blob)
    b.fmu.setFMUstate(state)
    assert b.fmu.serializeFMUstate(state) == blob
    assert same_bits(step_with_drive(a, case, t0, 30), step_with_drive(b, case, t0, 30))
    # Damaged bytes are refused with a reason.
    with pytest.raises(FMICallException) as e:
        b.fmu.deSerializeFMUstate(b"X" + blob[1:])
    assert e.value.status == 3
    assert any("not a state of this FMU" in m for m in b.errors()), b.messages
    a.free()
    b.free()


def test_serializing_an_older_state_leaves_the_instance_as_it_was(case, unpacked):
    """A state kept in memory (the cable FMU shares its factorization between states) is written
    out through its instance: serializing a state saved earlier must leave the instance's own
    state bit for bit, and give the bytes of that earlier state."""
    a = Slave(*unpacked, name="a").initialize(case.start_values)
    twin = Slave(*unpacked, name="twin").initialize(case.start_values)
    step_with_drive(a, case, 0.0, case.warmup_steps)
    step_with_drive(twin, case, 0.0, case.warmup_steps)
    t0 = case.warmup_steps * case.step_size
    early = a.fmu.getFMUstate()
    from_early = step_with_drive(a, case, t0, 10)
    step_with_drive(twin, case, t0, 10)
    blob = a.fmu.serializeFMUstate(early)
    t1 = t0 + 10 * case.step_size
    assert same_bits(step_with_drive(a, case, t1, 20), step_with_drive(twin, case, t1, 20))
    b = Slave(*unpacked, name="b")
    b.fmu.setFMUstate(b.fmu.deSerializeFMUstate(blob))
    assert same_bits(step_with_drive(b, case, t0, 10), from_early)
    a.fmu.freeFMUstate(early)
    for s in (a, twin, b):
        s.free()


def step_map_derivative(slave, unknowns, knowns, seed):
    """The extension feedsimGetStepMapDerivative, called through ctypes (same signature as
    fmi2GetDirectionalDerivative)."""
    from ctypes import POINTER, c_double, c_int, c_size_t, c_uint, c_void_p

    f = slave.fmu.dll.feedsimGetStepMapDerivative
    f.argtypes = [c_void_p, POINTER(c_uint), c_size_t, POINTER(c_uint), c_size_t, POINTER(c_double), POINTER(c_double)]
    f.restype = c_int
    out = (c_double * len(unknowns))()
    status = f(slave.fmu.component, (c_uint * len(unknowns))(*unknowns), len(unknowns),
               (c_uint * len(knowns))(*knowns), len(knowns), (c_double * len(seed))(*seed), out)
    assert status == 0, slave.messages
    return np.array(out[:])


def test_the_step_map_extension_matches_central_differences_with_rollback(case, unpacked):
    """Outputs after a step with respect to the inputs held during it: the opt-in extension,
    announced in modelDescription.xml's VendorAnnotations (fmpy ignores it)."""
    s = Slave(*unpacked).initialize(case.start_values)
    assert 'name="feedsim"><StepMapDerivative/>' in open(unpacked[0] + "/modelDescription.xml").read()
    step_with_drive(s, case, 0.0, case.warmup_steps)
    t = case.warmup_steps * case.step_size
    h = case.step_size
    u0 = case.drive(t)
    in_vrs = [s.vr[i] for i in case.inputs]
    out_vrs = [s.vr[o] for o in case.outputs]
    state = s.fmu.getFMUstate()

    def outputs_after_step(u):
        s.fmu.setFMUstate(state)
        s.fmu.setReal(in_vrs, list(u))
        s.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        return np.array(s.fmu.getReal(out_vrs))

    for j, name in enumerate(case.inputs):
        du = np.zeros(len(in_vrs))
        du[j] = case.fd_delta[j]
        fd = (outputs_after_step(u0 + du) - outputs_after_step(u0 - du)) / (2 * case.fd_delta[j])
        outputs_after_step(u0)
        exact = step_map_derivative(s, out_vrs, [in_vrs[j]], [1.0])
        scale = max(np.abs(exact).max(), 1e-12)
        assert np.abs(fd - exact).max() <= case.fd_rtol * scale, f"d/d{name}: fd {fd} vs exact {exact}"
    s.free()


def test_do_step_before_initialization_is_an_error(case, unpacked):
    s = Slave(*unpacked)
    expect_error(s, lambda: s.fmu.doStep(0.0, case.step_size), "fmi2DoStep", "not allowed in state `instantiated`")
    s.free()


def test_unknown_value_reference_is_an_error(case, unpacked):
    s = Slave(*unpacked).initialize(case.start_values)
    unknown = max(s.vr.values()) + 1000
    expect_error(s, lambda: s.fmu.setReal([unknown], [0.0]), f"unknown value reference {unknown}")
    s.free()


def test_nan_input_is_an_error(case, unpacked):
    s = Slave(*unpacked).initialize(case.start_values)
    name = case.inputs[0]
    expect_error(s, lambda: s.fmu.setReal([s.vr[name]], [math.nan]), f"`{name}`", "NaN: not a finite number")
    s.free()


def test_missing_resource_file_is_an_error(case, unpacked):
    s = Slave(*unpacked)
    param = case.resource_parameter
    expect_error(s, lambda: s.set(param, "does_not_exist.file"), f"`{param}`", "does_not_exist.file")
    s.free()


def test_instantiate_free_cycles_do_not_grow_memory(case, unpacked):
    directory, md = unpacked
    s = Slave(directory, md)
    lib = s.fmu
    guid = md.guid.encode()
    uri = (lib.unzipDirectory + "/resources").encode()

    def cycles(n):
        for _ in range(n):
            c = lib.fmi2Instantiate(b"cycle", 1, guid, b"file://" + uri, s.callbacks, 0, 0)
            assert c
            lib.fmi2FreeInstance(c)

    cycles(200)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with open("/proc/self/statm") as f:
        rss0 = int(f.read().split()[1])
    cycles(1000)
    with open("/proc/self/statm") as f:
        rss1 = int(f.read().split()[1])
    assert (rss1 - rss0) * 4096 < 256 * 1024, f"RSS grew by {(rss1 - rss0) * 4} kB"
    assert before > 0
    s.free()
