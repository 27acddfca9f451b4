"""control_fmu, the second level as an FMU of its own, through fmpy: valid (both versions), run
alone, its FMI 3.0 twin equal to the FMI 2.0 FMU bit for bit, and its commands, handed to the
Stewart FMU's command input, moving the platform as the Stewart FMU's built-in controller does
under the same cabin motion (same sample instants, same noise)."""

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu

from conftest import DIST
from fmus import STEWART_INPUTS, swaying_cabin
from test_fmi3 import Driven, fmi3_file

H = 0.0025  # the plant's step (the scene's)
EVERY = 4  # the controller's period, 10 ms (its inertial unit's), in plant steps
COMMAND = [f"command.{p}[{k}]" for p in ("r", "rot") for k in (1, 2, 3)]
PLATFORM = [f"platform.r[{k}]" for k in (1, 2, 3)] + [f"platform.q[{k}]" for k in (1, 2, 3, 4)] + [
    f"feed.err[{k}]" for k in (1, 2, 3)]


def cabin(t):
    """lt50m_C_compensated's cabin at rest, swaying and turning a little."""
    return swaying_cabin(t, 4e-3, 2.1, 2e-3, 1.3)


@pytest.mark.parametrize("version", ["2", "3"])
def test_fmpy_validates_control_fmu(version):
    path = DIST / "control_fmu.fmu" if version == "2" else fmi3_file("control_fmu")
    assert validate_fmu(str(path)) == []
    md = read_model_description(str(path))
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate


def test_fmpy_runs_control_fmu_alone():
    """simulate_fmu at its period: a command every 10 ms that turns the platform back against the
    cabin's turn (the attitude held)."""
    times = np.arange(0.0, 2.0 + 1e-9, 0.01)
    table = np.array([(t, *cabin(t)) for t in times], dtype=[("time", np.float64)] + [(n, np.float64) for n in STEWART_INPUTS])
    r = simulate_fmu(str(DIST / "control_fmu.fmu"), stop_time=2.0, output_interval=0.01, input=table, output=COMMAND)
    rot = np.column_stack([r[f"command.rot[{k}]"] for k in (1, 2, 3)])
    assert np.all(np.isfinite(rot)) and len(r) == 201
    # the cabin turns about world x by th(t); the command turns back (the estimate filtered and
    # predicted: close, not equal)
    th = 2e-3 * np.sin(1.3 * r["time"])
    assert np.max(np.abs(rot[50:, 0] + th[50:])) < 0.2 * np.max(np.abs(th)), np.max(np.abs(rot[50:, 0] + th[50:]))


def drive_pair(path_control, path_stewart, tmp_path):
    """The Stewart FMU with its built-in controller, and the same FMU following control_fmu's
    commands (the controller stepped every 10 ms at the end of each of its periods, its command
    held): both under the same cabin motion, the platform's outputs at every plant step."""
    built_in = Driven(path_stewart, str(tmp_path / "built-in"))
    built_in.initialize({"scene": "lt50m_C_compensated.toml"})
    follower = Driven(path_stewart, str(tmp_path / "follower"))
    follower.initialize({"scene": "lt50m_C_compensated.toml", "command_input": True})
    control = Driven(path_control, str(tmp_path / "control"))
    control.initialize({})
    command = control.get_reals(COMMAND)
    rows = []
    for n in range(800):
        t = n * H
        u = cabin(t + H)  # what an iterating master converges to: the end-of-step values
        built_in.set_reals(STEWART_INPUTS, u)
        built_in.step(t, H)
        follower.set_reals(STEWART_INPUTS, u)
        follower.set_reals(COMMAND, command)
        follower.step(t, H)
        if (n + 1) % EVERY == 0:
            t0 = (n + 1 - EVERY) * H
            control.set_reals(STEWART_INPUTS, u)
            control.step(t0, EVERY * H)
            command = control.get_reals(COMMAND)
        rows.append((built_in.get_reals(PLATFORM), follower.get_reals(PLATFORM), list(command) + [0.0] * 4))
    for d in (built_in, follower, control):
        d.fmu.terminate()
        d.fmu.freeInstance()
    return np.array(rows)


def test_the_stewart_fmu_follows_control_fmu_as_its_built_in_controller(tmp_path):
    rows = drive_pair(DIST / "control_fmu.fmu", DIST / "stewart_fmu.fmu", tmp_path)
    a, b = rows[:, 0, :], rows[:, 1, :]
    assert np.max(np.abs(a[:, :3] - a[0, :3])) > 1e-3, "the platform moved"
    assert np.max(np.abs(a - b)) < 1e-12 * np.max(np.abs(a)), np.max(np.abs(a - b))


def test_the_fmi3_control_fmu_equals_the_fmi2_one(tmp_path):
    two = drive_pair(DIST / "control_fmu.fmu", DIST / "stewart_fmu.fmu", tmp_path / "2")
    three = drive_pair(fmi3_file("control_fmu"), fmi3_file("stewart_fmu"), tmp_path / "3")
    assert np.array_equal(two, three), "the same arithmetic behind two export layers: bit for bit"
