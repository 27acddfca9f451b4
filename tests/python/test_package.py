"""The Python package feedsim against the master command: the same scene and options give the
same CSV, the same --json, the same statics and modes; errors are exceptions naming the key."""

import json
import re
import os
import pathlib
import subprocess
import sys
import threading
import time
import tomllib

import numpy as np
import pandas as pd
import pytest

import feedsim
from fmus import MASTER

REPO = pathlib.Path(__file__).resolve().parents[2]
C = REPO / "scenes" / "lt50m_C.toml"
B = REPO / "scenes" / "lt50m_B.toml"

# what differs between two runs of the same thing: the clock and the process's memory
VOLATILE = {"wall_time_s", "setup_s", "peak_memory_bytes"}


def master(*args):
    out = subprocess.run([str(MASTER), *map(str, args)], capture_output=True, text=True, cwd=REPO)
    assert out.returncode == 0, out.stderr
    return out.stdout


def stable(d):
    return {k: v for k, v in d.items() if k not in VOLATILE}


def flags(options):
    """The command line's flags for keyword options: ``t_end=5`` → ``--t-end 5``, ``True`` a flag."""
    argv = []
    for key, v in options.items():
        flag = "--" + key.replace("_", "-")
        argv += [flag] if v is True else [flag, repr(v) if isinstance(v, float) else str(v)]
    return argv


@pytest.mark.parametrize(
    "scene, scheme, options",
    [
        (C, "ijcsa", {"t_end": 2.0}),
        (B, "iqn-ils", {"t_end": 1.0, "dt": 0.02}),
        (C, "monolithic", {"t_end": 2.0, "adaptive": True, "rtol": 1e-4}),
        (REPO / "scenes" / "lt50m_C_compensated.toml", "monolithic", {"t_end": 1.0}),
        (REPO / "scenes" / "lt50m_C_compensated.toml", "ijcsa", {"t_end": 1.0, "compensation": "off"}),
    ],
    ids=["C-ijcsa", "B-iqn-dt", "C-monolithic-adaptive", "C-compensated", "C-compensation-off"],
)
def test_run_equals_the_command(tmp_path, scene, scheme, options):
    r = feedsim.run(scene, scheme, **options)
    argv = flags(options)
    csv = tmp_path / "out.csv"
    cli = json.loads(master("run", "--scene", scene, "--scheme", scheme, *argv, "--out", csv, "--json", "--quiet"))
    assert r.csv == csv.read_text()
    pd.testing.assert_frame_equal(r.frame, pd.read_csv(csv), check_exact=True)
    assert list(r.frame.columns) == csv.read_text().splitlines()[0].split(",")
    assert stable(r.summary) == stable(cli)
    for name, column in r.arrays().items():
        np.testing.assert_array_equal(column, r.frame[name].to_numpy())


def test_statics_and_modes_equal_the_command():
    assert feedsim.statics(B) == json.loads(master("statics", "--scene", B, "--json"))
    mine = feedsim.modes(C, count=4)
    cli = json.loads(master("modes", "--scene", C, "--count", 4, "--json"))
    assert stable(mine) == stable(cli)
    assert len(mine["frequencies_hz"]) == 4


def test_a_dict_is_the_scene_file():
    scene = tomllib.loads(C.read_text())
    assert feedsim.statics(scene) == {**feedsim.statics(C), "scene": scene["name"]}
    a = feedsim.run(scene, "monolithic", t_end=0.5)
    b = feedsim.run(C, "monolithic", t_end=0.5)
    assert a.csv == b.csv and stable(a.summary) == stable(b.summary)
    # numpy values are scene values too
    scene["cables"]["youngs_modulus_pa"] = np.float64(scene["cables"]["youngs_modulus_pa"] * 2)
    assert feedsim.modes(scene, 1)["frequencies_hz"][0] > feedsim.modes(C, 1)["frequencies_hz"][0]


def test_scene_errors_name_the_key():
    scene = tomllib.loads(C.read_text())
    scene["cables"]["area_m2"] = -1.0
    with pytest.raises(feedsim.SceneError, match=r"cables\.area_m2") as e:
        feedsim.statics(scene)
    assert isinstance(e.value, ValueError) and "-1" in str(e.value)
    scene = tomllib.loads(C.read_text())
    scene["cabin"]["colour"] = "red"
    with pytest.raises(feedsim.SceneError, match="colour"):
        feedsim.run(scene, "monolithic", t_end=0.1)
    scene = tomllib.loads(C.read_text())
    scene["cables"]["area_m2"] = float("nan")
    with pytest.raises(feedsim.SceneError, match=r"cables\.area_m2"):
        feedsim.modes(scene)
    with pytest.raises(feedsim.SceneError, match="no-such-scene.toml"):
        feedsim.run(REPO / "scenes" / "no-such-scene.toml")
    with pytest.raises(TypeError):
        feedsim.run(42)


def test_runs_that_cannot_go_on_raise_run_error():
    with pytest.raises(feedsim.RunError, match="stopped at t = ") as e:
        feedsim.run(C, "jacobi", t_end=2.0)
    assert isinstance(e.value, RuntimeError) and "diverged" in str(e.value)
    with pytest.raises(feedsim.RunError, match="whole number of steps"):
        feedsim.run(C, "monolithic", dt=0.03, t_end=0.1)


def test_bad_options_raise_value_error():
    with pytest.raises(ValueError, match="nonsense"):
        feedsim.run(C, "nonsense")
    with pytest.raises(ValueError, match="unexpected argument"):
        feedsim.run(C, "ijcsa", colour="red")
    with pytest.raises(ValueError, match="adaptive"):
        feedsim.run(C, "jacobi", adaptive=True)
    with pytest.raises(ValueError, match="tolerance"):
        feedsim.run(C, "ijcsa", adaptive=True, rtol=2.0)
    with pytest.raises(ValueError, match="count"):
        feedsim.modes(C, 0)
    with pytest.raises(ValueError, match="no compensation to switch off"):
        feedsim.run(C, "monolithic", compensation="off")


def test_two_threads_run_in_parallel():
    """The GIL is released while a run steps: two runs started together in two threads end
    together. Were the GIL held, one would run after the other and end a whole run later (the end
    times a run apart, whoever waited where); released, both step at once and end within a small
    part of a run of each other, even on a loaded machine that stretches both (which the runs'
    wall times against one run alone would not survive)."""
    if (os.cpu_count() or 1) < 2:
        pytest.skip("one core")

    start = threading.Barrier(2)
    intervals = []

    def one():
        start.wait()
        t0 = time.perf_counter()
        feedsim.run(C, "monolithic", t_end=100.0)
        intervals.append((t0, time.perf_counter()))

    threads = [threading.Thread(target=one) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    (a0, a1), (b0, b1) = intervals
    shorter = min(a1 - a0, b1 - b0)
    print(f"runs of {a1 - a0:.3f} s and {b1 - b0:.3f} s, ending {abs(a1 - b1):.3f} s apart")
    assert abs(a1 - b1) < 0.75 * shorter


def test_sweep_equals_the_command(tmp_path):
    grid = ["--grid", "x=0,2", "--grid", "mass=1,2"]
    master("sweep", "--scene", C, *grid, "--modes", 2, "--run", "monolithic", "--t-end", 0.5, "--out", tmp_path, "--quiet")
    cli = pd.read_csv(tmp_path / "sweep.csv", comment="#", keep_default_na=False)
    mine = feedsim.sweep(C, {"x": [0, 2], "mass": [1, 2]}, modes=2, run="monolithic", t_end=0.5, jobs=2)
    assert list(mine.columns) == list(cli.columns)
    assert len(mine) == 4 and mine["feasible"].all()
    for name in cli.columns:
        if name in ("wall_s", "run_wall_s", "feasible", "note"):
            continue
        np.testing.assert_array_equal(mine[name].to_numpy(float), cli[name].to_numpy(float), err_msg=name)
    assert (mine["note"] == cli["note"]).all()
    # a bad axis is an option error naming it
    with pytest.raises(ValueError, match="colour"):
        feedsim.sweep(C, {"colour": [1, 2]})


def test_a_dask_sweep_equals_the_runs_one_by_one():
    """The docs' dask example in small: runs of dict scenes mapped by dask's local scheduler
    (threads; the GIL is released while each steps) equal the same runs one by one."""
    dask = pytest.importorskip("dask")
    base = tomllib.loads(C.read_text())

    def with_mass(f):
        scene = json.loads(json.dumps(base))
        scene["stewart"]["platform"]["mass_kg"] *= f
        return scene

    def peak(f):
        return feedsim.run(with_mass(f), "monolithic", t_end=1.0).summary["peak_disp_mm"]

    factors = [0.5, 1.0, 2.0]
    tasks = [dask.delayed(peak)(f) for f in factors]
    parallel = dask.compute(*tasks, scheduler="threads", num_workers=2)
    assert list(parallel) == [peak(f) for f in factors]
    assert parallel[0] != parallel[2]


@pytest.mark.parametrize("options", [{"dt": 0.01, "t_end": 1.0}, {"t_end": 1.0, "adaptive": True}], ids=["fixed", "adaptive"])
def test_run_system_equals_the_command(tmp_path, options):
    ssp = tmp_path / "C.ssp"
    master("export-ssp", "--scene", C, "--out", ssp)
    r = feedsim.run_system(ssp, "ijcsa", **options)
    csv = tmp_path / "out.csv"
    argv = flags(options)
    cli = json.loads(master("run", "--system", ssp, "--scheme", "ijcsa", *argv, "--out", csv, "--json", "--quiet"))
    assert r.csv == csv.read_text()
    assert stable(r.summary) == stable(cli)
    assert r.frame.columns[0] == "time" and "cable.cabin.r[1]" in r.frame.columns
    # the scene's run with the same scheme: the same cabin motion, bit for bit
    if not options.get("adaptive"):
        scene = feedsim.run(C, "ijcsa", dt=0.01, t_end=1.0).frame
        dx = (r.frame["cable.cabin.r[1]"] - r.frame["cable.cabin.r[1]"][0]) * 1e3
        np.testing.assert_allclose(dx.to_numpy(), scene["dx_mm"].to_numpy(), rtol=0, atol=1e-12)


def test_run_system_integrates_model_exchange_components_as_the_command(tmp_path):
    """interface=, me_solver=, me_rtol=, me_atol= reach the master: the zoo's chain with d1 as
    Model Exchange, the CSV of the command's run byte for byte, d1.x on 1 - e^-t to 1e-8."""
    from zoo import pack

    ssp = pack("chain", tmp_path)
    options = {"dt": 0.1, "interface": "d1=me", "me_solver": "esdirk3", "me_rtol": 1e-10, "me_atol": 1e-12}
    r = feedsim.run_system(ssp, "jacobi", **options)
    csv = tmp_path / "out.csv"
    cli = json.loads(master("run", "--system", ssp, "--scheme", "jacobi", *flags(options), "--out", csv,
                            "--json", "--quiet"))
    assert r.csv == csv.read_text() and stable(r.summary) == stable(cli)
    assert [(m["component"], m["solver"]) for m in r.summary["model_exchange"]] == [("d1", "esdirk3")]
    t = r.frame["time"].to_numpy()
    assert np.max(np.abs(r.frame["d1.x"].to_numpy() - (1.0 - np.exp(-t)))) < 1e-8


def test_run_system_errors():
    with pytest.raises(feedsim.RunError, match="no-such.ssp"):
        feedsim.run_system(REPO / "no-such.ssp", "ijcsa", dt=0.01, t_end=1.0)
    with pytest.raises(feedsim.RunError, match="coupling scheme"):
        feedsim.run_system(REPO / "no-such.ssp", "monolithic", dt=0.01, t_end=1.0)
    with pytest.raises(TypeError):
        feedsim.run_system({"a": 1})


def test_progress_is_reported_and_an_exception_in_it_stops_the_run():
    seen = []
    r = feedsim.run(C, "monolithic", t_end=100.0, progress=lambda t, end: seen.append((t, end)))
    assert seen and all(end == 100.0 for _, end in seen)
    assert [t for t, _ in seen] == sorted(t for t, _ in seen) and 0 < seen[-1][0] <= 100.0
    assert r.summary["steps"] == 10000

    class Enough(Exception):
        pass

    def stop(t, end):
        raise Enough(f"stopped at {t}")

    with pytest.raises(Enough):
        feedsim.run(C, "monolithic", t_end=100.0, progress=stop)


def test_ctrl_c_stops_a_run():
    """Ctrl-C during a run raises KeyboardInterrupt within a moment, as in any Python code."""
    import signal

    code = f"import feedsim; print('started', flush=True); feedsim.run({str(C)!r}, 'monolithic', t_end=3000.0)"
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "started"
    time.sleep(1.0)
    p.send_signal(signal.SIGINT)
    t0 = time.perf_counter()
    _, err = p.communicate(timeout=30)
    print(f"stopped {time.perf_counter() - t0:.2f} s after Ctrl-C")
    assert p.returncode != 0 and "KeyboardInterrupt" in err, err
    assert time.perf_counter() - t0 < 5.0


# A value each option of a run refuses, by its keyword (the command line's flag with _ for -).
REFUSED = {
    "dt": "0",
    "t_end": "-1",
    "tol": "0",
    "max_iter": "0",
    "relaxation": "2",
    "jacobian": "sometimes",
    "extrapolation": "cubic",
    "iqn_reuse": "-1",
    "iqn_filter": "1",
    "iqn_relaxation": "0",
    "rtol": "2",
    "atol": "-1",
    "h_min": "0",
    "h_max": "nan",
    "estimate": "guess",
    "compensation": "maybe",
    "wind_seed": "-1",
}


def test_the_two_front_ends_take_the_same_options():
    """The command line (clap) and the package (its own keyword code) read a run's options
    through the same checks of the library: every option of `master run` but the command line's
    own (files, printing, the system's) is a keyword of feedsim.run, and a value one refuses the
    other refuses with the same reason. Their defaults are the library's on both sides (a Rust
    test holds the flags' defaults to it)."""
    help_text = master("run", "--help")
    cli_only = {"scene", "system", "scheme", "out", "json", "plot", "quiet", "help", "vtk", "vtk-every", "adaptive",
                "watch", "allow-external-fmus", "max-archive-entries", "max-unpacked-mb", "interface", "me-solver",
                "me-rtol", "me-atol", "max-steps",
                "max-memory-mb", "max-scene-bytes"}
    options = set(re.findall(r"^\s+--([a-z][a-z0-9-]*)", help_text, re.M)) - cli_only
    assert options == {k.replace("_", "-") for k in REFUSED}, options ^ {k.replace("_", "-") for k in REFUSED}
    for key, bad in REFUSED.items():
        out = subprocess.run([str(MASTER), "run", "--scene", str(C), "--scheme", "ijcsa", "--" + key.replace("_", "-"), bad],
                             capture_output=True, text=True, cwd=REPO)
        assert out.returncode != 0, key
        with pytest.raises(ValueError) as e:
            feedsim.run(C, "ijcsa", **{key: bad})
        python = str(e.value)
        assert f"'{bad}'" in python and key in python, python
        cli = out.stderr.splitlines()[0]
        if key in ("dt", "t_end"):
            # the command line checks the step and the end time with the run's plan (which says
            # where each came from: the flag or the scene); both name a positive number
            assert "positive" in out.stderr and "positive" in python, (out.stderr, python)
        elif "possible values" in out.stderr:
            # a named choice: clap lists the names itself; the package names them as the library does
            names = re.search(r"\[possible values: (.*)\]", out.stderr).group(1).split(", ")
            assert all(n in python for n in names), (python, names)
        else:
            assert cli.split("': ", 1)[1] == python.split("': ", 1)[1], (cli, python)
    with pytest.raises(ValueError, match="unexpected argument 'colour'"):
        feedsim.run(C, "ijcsa", colour="red")
