"""Controllers a user writes, in the loop of LT50m C (docs/controllers.md): one in C on
testfmus/c's framework (FMI 3.0), one in Python with pythonfmu (FMI 2.0, loaded by the master
from the command line: its binary leaves the Python C API to the host); a controller that holds
every command at zero reproduces `--compensation off`."""

import os
import re
import subprocess

import numpy as np
import pytest

import controllers
from controllers import MASTER, SCENE, export, feed_error_mm, read, run


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    d = tmp_path_factory.mktemp("controllers")
    return {"c": controllers.build_c(d / "c"), "python": controllers.build_python(d / "python"), "dir": d}


@pytest.fixture(scope="module")
def uncompensated(fmus):
    out = fmus["dir"] / "off.csv"
    subprocess.run([str(MASTER), "run", "--scene", str(SCENE), "--scheme", "ijcsa", "--t-end", "20", "--compensation", "off",
                    "--out", str(out)], check=True, capture_output=True)
    return read(out)


def test_both_controllers_hold_the_feed_and_agree(fmus, uncompensated):
    """The same law in C and in Python: the same feed error to 1e-9 of its peak, far below the
    uncompensated one (these controllers read the cabin's true pose, without the instruments'
    delay and noise the built-in controller has)."""
    d = fmus["dir"]
    runs = {name: run(export(fmus[name], d / f"{name}.ssp"), d / f"{name}.csv") for name in ("c", "python")}
    e = {name: feed_error_mm(cols) for name, cols in runs.items()}
    off = np.sqrt(sum(uncompensated[f"feed_err_{a}_mm"] ** 2 for a in "xyz"))
    rms = {name: float(np.sqrt(np.mean(x ** 2))) for name, x in e.items()}
    print({**rms, "off": float(np.sqrt(np.mean(off ** 2)))})
    assert np.max(np.abs(e["c"] - e["python"])) < 1e-9 * np.max(e["c"])
    assert rms["c"] < 0.25 * np.sqrt(np.mean(off ** 2))


def test_a_zero_command_reproduces_compensation_off(fmus, uncompensated):
    """The C controller with gain 0 holds every command at zero (home): the platform stays where
    the uncompensated run keeps it, the feed error the same to 1e-9 of its peak (IJCSA both)."""
    d = fmus["dir"]
    cols = run(export(fmus["c"], d / "zero.ssp", gain=0.0), d / "zero.csv")
    assert np.all(cols["control.command.r[1]"] == 0.0) and np.all(cols["control.command.rot[3]"] == 0.0)
    ours = np.column_stack([cols[f"stewart.feed.err[{k}]"] for k in (1, 2, 3)])[::4] * 1e3
    theirs = np.column_stack([uncompensated[f"feed_err_{a}_mm"] for a in "xyz"])
    assert ours.shape == theirs.shape
    peak = np.max(np.abs(theirs))
    assert peak > 10.0, "the uncompensated feed error is tens of mm"
    assert np.max(np.abs(ours - theirs)) < 1e-9 * peak, np.max(np.abs(ours - theirs)) / peak


def test_the_python_controller_runs_from_feedsim_as_from_the_command_line(fmus):
    """Inside Python the interpreter's symbols are there already: the same columns bit for bit."""
    import feedsim

    d = fmus["dir"]
    ssp = export(fmus["python"], d / "py2.ssp")
    cli = run(ssp, d / "py2.csv", "ijcsa", 2.0)
    r = feedsim.run_system(ssp, "ijcsa", dt=0.0025, t_end=2.0)
    for name in ("stewart.feed.err[1]", "control.command.r[1]", "control.command.rot[2]"):
        assert r.frame[name].to_numpy().tolist() == cli[name].tolist(), name


def test_a_python_library_that_cannot_be_found_is_named(fmus, tmp_path):
    ssp = export(fmus["python"], tmp_path / "py.ssp")
    cmd = [str(MASTER), "run", "--system", str(ssp), "--scheme", "jacobi", "--dt", "0.0025", "--t-end", "0.01"]
    missing = tmp_path / "libpython3.11.so"
    p = subprocess.run(cmd + ["--python-library", str(missing)], capture_output=True, text=True)
    assert p.returncode != 0
    assert re.search(r"undefined symbol: _?Py", p.stderr), p.stderr  # the loader's own reason
    assert str(missing) in p.stderr and "--python-library" in p.stderr, p.stderr
    p = subprocess.run(cmd, capture_output=True, text=True, env=dict(os.environ, PATH=str(tmp_path)))
    assert p.returncode != 0 and "no `python3` on PATH" in p.stderr and re.search(r"undefined symbol: _?Py", p.stderr), p.stderr
