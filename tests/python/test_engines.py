"""Co-simulation engines we did not write, from PyPI, on our SSP files: libcosim (`libcosimpy`,
the Open Simulation Platform's C++ engine) and ecos (`ecospy`; its native library needs Intel
TBB, taken from the `tbb` wheel). Both couple by fixed-step Jacobi, as `master run --scheme
jacobi` does, so on the same .ssp they must give the master's Jacobi answer; on LT50m they
diverge from the platform's added mass like it (the README), where the master's IJCSA does not.

Skipped only where the packages have no build for this platform; on linux x86_64 with CPython
3.11 (this project's machines) a missing package is a failure: tests/run_all.sh installs them."""

import ctypes
import math
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import DIST
from zoo import MASTER, REPO, pack, run

SUPPORTED = sys.platform == "linux" and platform.machine() == "x86_64" and sys.version_info[:2] == (3, 11)


def _missing(package, error):
    if SUPPORTED:
        pytest.fail(f"{package} is not installed ({error}); tests/run_all.sh installs tests/requirements.txt into .venv")
    pytest.skip(f"{package}: no build for {sys.platform} {platform.machine()} CPython {platform.python_version()}")


@pytest.fixture(scope="module")
def libcosim():
    try:
        from libcosimpy.CosimExecution import CosimExecution
        from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
        from libcosimpy.CosimObserver import CosimObserver
    except ImportError as e:
        _missing("libcosimpy", e)
    log_output_level(CosimLogLevel.ERROR)
    return CosimExecution, CosimObserver


@pytest.fixture(scope="module")
def ecos():
    # ecospy's library links libtbb.so.12: the `tbb` wheel puts it in the environment's lib/
    tbb = Path(sys.prefix) / "lib" / "libtbb.so.12"
    try:
        if tbb.exists():
            ctypes.CDLL(str(tbb), mode=ctypes.RTLD_GLOBAL)
        from ecospy import EcosLib, EcosSimulation
    except (ImportError, OSError) as e:
        _missing("ecospy (with the tbb wheel)", e)
    EcosLib.set_log_level("err")
    return EcosSimulation


def libcosim_run(engine, ssp, step, steps, names):
    """libcosim on `ssp` at `step` seconds: the values of `names` (`component.variable`) after
    every step, until `steps` or a failed step. Returns (times, {name: list}, failed_at_step)."""
    CosimExecution, CosimObserver = engine
    ns = round(step * 1e9)
    ex = CosimExecution.from_ssp_file(str(ssp), step_size=ns)  # times are integer nanoseconds
    observer = CosimObserver.create_last_value()
    ex.add_observer(observer)
    infos = ex.slave_infos()
    index = {infos[i].name.decode(): infos[i].index for i in range(ex.num_slaves())}
    readers = {}
    for name in names:
        component, variable = name.split(".", 1)
        k = index[component]
        v = next(v for v in ex.slave_variables(k) if v.name.decode() == variable)
        read = {0: observer.last_real_values, 1: observer.last_integer_values,
                2: observer.last_string_values, 3: observer.last_boolean_values}[int(v.type)]
        readers[name] = (read, k, v.reference)
    values = {n: [] for n in names}
    times, failed = [], None
    for n in range(1, steps + 1):
        if not ex.step(1):
            failed = n
            break
        times.append(n * ns / 1e9)
        for name, (read, k, ref) in readers.items():
            x = read(k, [ref])[0]
            values[name].append(x.decode() if isinstance(x, bytes) else x)
    return np.array(times), values, failed


@pytest.fixture(scope="module")
def zoo_ssp(tmp_path_factory):
    d = tmp_path_factory.mktemp("engines")
    return {name: pack(name, d) for name in ["chain", "loop", "ball", "stair", "resource", "oscillators", "sampled"]}


@pytest.fixture(scope="module")
def lt50m(tmp_path_factory):
    """`master export-ssp` of scene C (the FMUs under test), and the master's Jacobi and IJCSA on it."""
    d = tmp_path_factory.mktemp("lt50m")
    scene = d / "lt50m_C.toml"
    scene.write_text((REPO / "scenes" / "lt50m_C.toml").read_text().replace('"../dist/', f'"{DIST}/'))
    ssp = d / "lt50m_C.ssp"
    p = subprocess.run([str(MASTER), "export-ssp", "--scene", str(scene), "--out", str(ssp)], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    return ssp


CABIN = [f"cable.cabin.r[{k}]" for k in (1, 2, 3)]


def cabin_offset(values):
    """Distance of the cabin centre from scene C's target pose, at every sample."""
    r = np.column_stack([values[n] for n in CABIN])
    r0 = np.array([0.0, 0.0, 9.8])  # scene C's target pose
    return np.linalg.norm(r - r0, axis=1)


def test_libcosim_loads_lt50m_runs_jacobi_as_the_master_and_diverges(libcosim, lt50m):
    t, v, failed = libcosim_run(libcosim, lt50m, 0.01, 200, CABIN + ["cable.cabin.w[2]"])
    ours, _, _ = run(lt50m, "jacobi", 0.01, t_end=0.5)
    # 0.3 s, before the instability amplifies rounding: libcosim's steps are integer nanoseconds
    # (h = 0.010000000000000009 in double), so it agrees to 1.6e-8 of the motion, not bit for bit
    n = 30
    for name in CABIN + ["cable.cabin.w[2]"]:
        theirs, mine = np.array(v[name][:n]), ours[name][1:n + 1]
        scale = np.max(np.abs(mine - mine[0])) + 1e-300
        assert np.max(np.abs(theirs - mine)) <= 1e-7 * scale, name
    # then the Jacobi coupling runs away (×10 every 0.1–0.2 s): the cabin is 10 cm off its pose
    # at about 0.9 s (IJCSA: under 5 mm over 3 s), and the cable FMU's Newton iteration fails
    # or the offset passes a metre before 1.5 s
    offset = cabin_offset(v)
    grown = np.nonzero(offset > 0.1)[0]
    assert len(grown) and 0.8 < t[grown[0]] < 1.1, f"10 cm first exceeded at {t[grown[0]] if len(grown) else None} s"
    assert (failed is not None and failed * 0.01 < 1.5) or offset.max() > 1.0


def test_the_masters_ijcsa_runs_the_same_ssp_stably(lt50m):
    cols, js, _ = run(lt50m, "ijcsa", 0.01, t_end=3.0)
    offset = cabin_offset(cols)
    assert np.all(np.isfinite(offset)) and offset.max() < 5e-3, offset.max()
    assert js["mean_iterations"] <= 3.0, js


ZOO_JACOBI = {
    "chain": ["d1.x", "f.real_continuous_out", "d2.x"],
    "oscillators": ["vdp.x0", "vdp.x1", "d.x"],
    "ball": ["ball.h", "ball.bounces", "ball.resting", "f.real_continuous_out", "f.int_out", "f.bool_out"],
    "resource": ["signal.y", "signal.points", "d.x", "f.int_out", "f.string_out"],
}


@pytest.mark.parametrize("system", sorted(ZOO_JACOBI))
def test_libcosim_runs_the_zoo_like_the_masters_jacobi(libcosim, zoo_ssp, system):
    """Parameter bindings (.ssv and inline), Real, Integer, Boolean and String connections:
    libcosim's Jacobi and the master's agree to rounding at every communication point."""
    names = ZOO_JACOBI[system]
    t, v, failed = libcosim_run(libcosim, zoo_ssp[system], 0.1, 30, names)
    assert failed is None
    ours, _, _ = run(zoo_ssp[system], "jacobi", 0.1, t_end=3.0)
    assert np.allclose(t, ours["time"][1:], atol=1e-12)
    for name in names:
        if isinstance(ours[name], list):
            assert v[name] == ours[name][1:], name
        else:
            assert np.max(np.abs(np.array(v[name], dtype=float) - ours[name][1:])) < 1e-12, name


def test_libcosim_reads_the_samplers_step_from_our_ssp(libcosim, zoo_ssp):
    """sampled.ssd's sampler carries libcosim's own annotation (osp:StepSizeHint, 0.1 s): at a
    base step of 0.025 s libcosim steps it every fourth, as its fixed-step algorithm defines — a
    slow step starts at its first base step with the inputs there, and its outputs reach the
    others when it ends. So the plant's input over [t_j + 0.1, t_j + 0.2) is -2 x(t_j), one
    sampler period later than the master's (which takes the step in the base step that ends it,
    docs/systems.md): the exact answer of that recurrence, to rounding."""
    t, v, failed = libcosim_run(libcosim, zoo_ssp["sampled"], 0.025, 80, ["p.x", "c.real_continuous_out"])
    assert failed is None and len(t) == 80
    e, g = math.exp(-0.025), -math.expm1(-0.025)
    x = [1.0]
    for n in range(80):
        held = 1.0 if n < 8 else x[4 * (n // 4 - 1)]
        x.append(e * x[-1] + g * (-2.0 * held))
    assert np.max(np.abs(np.array(v["p.x"]) - np.array(x[1:]))) < 1e-14
    # the sampler's output changes every fourth step only
    changes = np.flatnonzero(np.diff(np.array(v["c.real_continuous_out"])))
    assert np.all((changes + 2) % 4 == 0), changes


def test_libcosim_hides_the_algebraic_loop_the_master_refuses(libcosim, zoo_ssp):
    """loop.ssd under libcosim's Jacobi: each input a step late, so the loop u = -2 (-x + u)
    becomes u_{n+1} = -2 (-x_n + u_n), which doubles its error every step: at no communication
    point does it hold, and the values run away, with no error reported. The master refuses
    Jacobi here and solves the loop with the iterating schemes (test_zoo_systems.py)."""
    t, v, failed = libcosim_run(libcosim, zoo_ssp["loop"], 0.1, 30, ["d.x", "d.der_x", "f.real_continuous_out"])
    assert failed is None, "libcosim reports nothing"
    x, f_out = np.array(v["d.x"]), np.array(v["f.real_continuous_out"])
    residual = np.abs(f_out - 2.0 * x / 3.0)  # the loop's equation: u = 2x/3
    assert residual.min() > 1e-3 and residual[-1] > 1e3, residual
    _, _, p = run(zoo_ssp["loop"], "jacobi", 0.1, expect_ok=False)
    assert p.returncode != 0 and "algebraic loop" in p.stderr


def test_libcosim_treats_the_stairs_end_as_a_failed_step(libcosim, zoo_ssp):
    """fmi2Discard at t = 9 s: libcosim's step fails there (the master ends the run cleanly,
    exit 0 and stopped_early, test_zoo_systems.py)."""
    t, v, failed = libcosim_run(libcosim, zoo_ssp["stair"], 0.1, 120, ["stair.counter"])
    assert failed == 90 and v["stair.counter"][-1] == 9


def ecos_run(EcosSimulation, ssp, step, steps, names, parameter_set=None):
    sim = EcosSimulation(step_size=step, ssp_path=str(ssp))
    sim.init(parameter_set=parameter_set)
    values = {n: [] for n in names}
    for _ in range(steps):
        sim.step(1)
        for n in names:
            values[n].append(sim.get_real(n.replace(".", "::", 1)))
    sim.terminate()
    return {n: np.array(x) for n, x in values.items()}


def test_ecos_loads_lt50m_runs_jacobi_as_the_master_and_diverges(ecos, lt50m):
    v = ecos_run(ecos, lt50m, 0.01, 130, CABIN)
    ours, _, _ = run(lt50m, "jacobi", 0.01, t_end=0.5)
    n = 30  # ecos steps with the master's h: the same numbers until the instability amplifies them
    for name in CABIN:
        mine = ours[name][1:n + 1]
        scale = np.max(np.abs(mine - mine[0])) + 1e-300
        assert np.max(np.abs(v[name][:n] - mine)) <= 1e-12 * scale, name
    offset = cabin_offset(v)
    grown = np.nonzero(offset > 0.1)[0]
    assert len(grown) and 0.8 < (grown[0] + 1) * 0.01 < 1.1, "ecos's Jacobi runs away like libcosim's"


@pytest.mark.parametrize("system,names", [("chain", ["d1.x", "d2.x"]), ("oscillators", ["vdp.x0", "d.x"])])
def test_ecos_runs_the_zoo_like_the_masters_jacobi(ecos, zoo_ssp, system, names):
    """ecos applies one named parameter set at initialization: the zoo names every set of a
    system after it. Its states agree with the master's Jacobi to rounding."""
    v = ecos_run(ecos, zoo_ssp[system], 0.1, 30, names, parameter_set=system)
    ours, _, _ = run(zoo_ssp[system], "jacobi", 0.1, t_end=3.0)
    for name in names:
        assert np.max(np.abs(v[name] - ours[name][1:])) < 1e-12, name
