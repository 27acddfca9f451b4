"""The zoo's SSP systems (tests/systems) run by `master run --system` with every scheme, each
against the answer that scheme must give (closed forms and recurrences computed here, not by
the FMUs' code), and against fmpy's SSP reader where the method is the same (Jacobi).

What each scheme must give: at a communication point t_n, a Real input over the step to t_{n+1}
holds the value of its output at t_{n+1} for the converged iterating schemes and for Gauss-Seidel
when the source steps first, and at t_n for Jacobi (and Gauss-Seidel reversed here); Integer,
Boolean and String connections carry the value at t_n in every scheme (sampled at communication
points)."""

import math
import re
import subprocess
import zipfile
from types import SimpleNamespace

import numpy as np
import pytest
from fmpy.ssp.ssd import read_ssd
from fmpy.ssp.simulation import simulate_ssp

from conftest import DIST
from zoo import (
    TIGHT,
    END_VALUES,
    ITERATING,
    MASTER,
    REPO,
    SCHEMES,
    SYSTEMS,
    ball_exact,
    chain_expected,
    check_oscillators,
    dahlquist_steps,
    delayed,
    fmu_file,
    loop_expected,
    pack,
    sampled_expected,
    read_table,
    run,
)


@pytest.fixture(scope="module")
def systems(tmp_path_factory):
    """Every system packed once as an .ssp archive with the FMUs under test."""
    d = tmp_path_factory.mktemp("zoo-systems")
    return {name: pack(name, d) for name in ["chain", "loop", "ball", "stair", "resource", "oscillators", "sampled"]}


@pytest.mark.parametrize("name", ["chain", "loop", "ball", "stair", "resource", "oscillators", "sampled"])
def test_every_system_is_valid_ssp(systems, name):
    """fmpy validates the .ssd against the SSP 1.0 schema; the .ssv files travel in the archive."""
    ssd = read_ssd(str(systems[name]), validate=True)
    assert ssd.system.connections and len(ssd.system.elements) >= 2


@pytest.mark.parametrize("scheme", SCHEMES)
def test_chain_gives_each_schemes_exact_answer(systems, scheme):
    cols, js, _ = run(systems["chain"], scheme, 0.1, *TIGHT)
    t = cols["time"]
    assert len(t) == 51 and t[-1] == 5.0, "the end time from the DefaultExperiment"
    x1, f_out, x2 = chain_expected(t, scheme)
    assert np.max(np.abs(cols["d1.x"] - x1)) < 1e-14
    assert np.max(np.abs(cols["f.real_continuous_out"] - f_out)) < 1e-12
    assert np.max(np.abs(cols["d2.x"] - x2)) < 1e-12
    if scheme in ITERATING:
        assert js["max_interface_residual"] < 1e-13
    if scheme == "gauss-seidel":
        assert js["max_interface_residual"] == 0.0, "every unit stepped with its source's newest output"
    if scheme in ("jacobi", "gauss-seidel-reversed"):
        # inputs a step old: the largest change of x1 over a step, 1 - e^{-0.1}, at the first
        assert js["max_interface_residual"] == pytest.approx(-math.expm1(-0.1), rel=1e-12)


def test_chain_converges_to_the_continuous_solution_at_first_order(systems):
    """Inputs held over the step: the coupling error of every scheme is O(h); halving h halves it."""
    def error(scheme, h):
        cols, _, _ = run(systems["chain"], scheme, h, *TIGHT, out_dir=systems["chain"].parent)
        t = cols["time"]
        exact = 0.5 - np.exp(-t) + 0.5 * np.exp(-2 * t)
        return np.max(np.abs(cols["d2.x"] - exact))

    for scheme in ("jacobi", "ijcsa"):
        e1, e2 = error(scheme, 0.1), error(scheme, 0.05)
        assert 1.8 < e1 / e2 < 2.2, (scheme, e1, e2)
    assert error("ijcsa", 0.1) < error("jacobi", 0.1) / 2, "end values beat the doubly delayed chain"


def test_chain_ssd_with_its_ssv_runs_in_place(tmp_path):
    """tests/systems/chain.ssd as it is: FMUs from ../../dist, d1's parameters from chain_d1.ssv."""
    if DIST.resolve() != (REPO / "dist").resolve():
        pytest.skip(f"FMU_DIST={DIST}: the .ssd files name ../../dist")
    cols, _, _ = run(SYSTEMS / "chain.ssd", "gauss-seidel", 0.1, out_dir=tmp_path)
    x1, _, x2 = chain_expected(cols["time"], "gauss-seidel")
    assert np.max(np.abs(cols["d1.x"] - x1)) < 1e-14 and np.max(np.abs(cols["d2.x"] - x2)) < 1e-12


def jacobi_matches_fmpy(system, stop_time, params, names):
    """Jacobi at 0.01 s against fmpy's simulate_ssp, which couples by Jacobi too; it ignores
    parameter bindings (given to it as a parameter set instead) and its rows are one step early
    (fmi2-facts.md)."""
    cols, _, _ = run(system, "jacobi", 0.01)
    theirs = simulate_ssp(str(system), stop_time=stop_time, step_size=0.01,
                          parameter_set=SimpleNamespace(parameters=[SimpleNamespace(name=k, value=v) for k, v in params.items()]))
    n = min(len(theirs), len(cols["time"]) - 1)
    assert n >= round(stop_time / 0.01) - 1
    for name in names:
        assert np.max(np.abs(theirs[name][:n] - cols[name][1:n + 1])) < 1e-12, name


def test_chain_jacobi_matches_fmpy(systems):
    params = {"d1.k": 1.0, "d1.x0": 0.0, "d1.u": 1.0, "d2.k": 2.0, "d2.x0": 0.0}
    jacobi_matches_fmpy(systems["chain"], 5.0, params, ("d1.x", "f.real_continuous_out", "d2.x"))


@pytest.mark.parametrize("scheme", SCHEMES)
def test_loop_is_solved_by_iterating_schemes_and_refused_by_the_others(systems, scheme):
    if scheme not in ITERATING:
        _, _, p = run(systems["loop"], scheme, 0.1, expect_ok=False)
        assert p.returncode != 0
        assert f"scheme {scheme} cannot solve the system's algebraic loop" in p.stderr, p.stderr
        assert "`d.u` → `d.der_x` → `f.real_continuous_in` → `f.real_continuous_out` → `d.u`" in p.stderr, p.stderr
        return
    cols, js, _ = run(systems["loop"], scheme, 0.1, *TIGHT)
    x, der_x, f_out = cols["d.x"], cols["d.der_x"], cols["f.real_continuous_out"]
    assert np.max(np.abs(x - loop_expected(cols["time"]))) < 1e-12
    # the loop's equations at every communication point: f.in = -2 der_x = f.out = d.u, and so
    # der_x = -x + u = -x/3
    assert np.max(np.abs(der_x + x / 3.0)) < 1e-12
    assert np.max(np.abs(f_out - 2.0 * x / 3.0)) < 1e-12
    assert js["max_interface_residual"] < 1e-13


def test_iterations_per_step_on_linear_couplings(systems):
    """At the default tolerance (1e-8): IJCSA's Newton (Jacobian by central differences with
    rollback, as these FMUs offer no step-map derivative) converges in one update on these
    linear couplings; IQN-ILS, from its residual history, within n + 1 evaluations (n = 2);
    the relaxed fixed point (ω = 0.5) needs many more on the loop, whose gain is -2."""
    mean = {}
    for system in ("chain", "loop"):
        for scheme in ("ijcsa", "iqn-ils", "iterative"):
            mean[system, scheme] = run(systems[system], scheme, 0.1)[1]["mean_iterations"]
    assert mean["chain", "ijcsa"] == 2.0 and mean["loop", "ijcsa"] == 2.0, mean
    assert mean["chain", "iqn-ils"] <= 3.0 and mean["loop", "iqn-ils"] <= 3.0, mean
    assert mean["loop", "iterative"] > 10 * mean["loop", "iqn-ils"], mean


def test_loop_converges_to_the_continuous_solution(systems):
    """u = 2x/3 makes x' = -x/3: x = e^{-t/3}; held inputs give a first-order error."""
    errors = []
    for h in (0.1, 0.05):
        cols, _, _ = run(systems["loop"], "iqn-ils", h, *TIGHT)
        errors.append(np.max(np.abs(cols["d.x"] - np.exp(-cols["time"] / 3.0))))
    assert 1.8 < errors[0] / errors[1] < 2.2, errors


@pytest.mark.parametrize("scheme", SCHEMES)
def test_ball_events_and_integer_boolean_connections(systems, scheme):
    cols, _, _ = run(systems["ball"], scheme, 0.01, *TIGHT)
    t = cols["time"]
    h, v, bounces, resting = ball_exact(t)
    assert np.max(np.abs(cols["ball.h"] - h)) < 1e-12
    assert np.max(np.abs(cols["ball.v"] - v)) < 1e-12
    assert np.array_equal(cols["ball.bounces"], bounces) and np.array_equal(cols["ball.resting"] == 1, resting)
    # Real: at once for the end values, a step late otherwise; Integer and Boolean: a step late
    late = lambda x: np.concatenate([x[:1], x[:-1]])  # noqa: E731
    expected_h = h if scheme in END_VALUES else late(h)
    assert np.max(np.abs(cols["f.real_continuous_out"] - expected_h)) < 1e-12
    assert np.array_equal(cols["f.int_out"], late(bounces))
    assert np.array_equal(cols["f.bool_out"] == 1, late(resting))
    assert bounces[-1] == 11 and resting[-1]


def test_ball_jacobi_matches_fmpy(systems):
    """fmpy starts every connector at 0 (the master sets f's inputs from the ball's outputs in
    initialization mode), so the rows after the first step are compared."""
    cols, _, _ = run(systems["ball"], "jacobi", 0.01)
    theirs = simulate_ssp(str(systems["ball"]), stop_time=3.0, step_size=0.01)
    n = min(len(theirs), len(cols["time"]) - 1)
    assert n >= 299
    for name in ("ball.h", "f.real_continuous_out"):
        assert np.max(np.abs(theirs[name][1:n] - cols[name][2:n + 1])) < 1e-12, name
    for name in ("ball.bounces", "f.int_out", "ball.resting", "f.bool_out"):
        assert np.array_equal(theirs[name][1:n].astype(int), cols[name][2:n + 1].astype(int)), name


@pytest.mark.parametrize("scheme", SCHEMES)
def test_stair_ends_the_run_early_and_cleanly(systems, scheme):
    cols, js, p = run(systems["stair"], scheme, 0.4, *TIGHT)
    assert js["stopped_early"] is True
    assert js["stopped_at"] == pytest.approx(8.8, abs=1e-12), "the last point every component reached"
    assert "fmi2Terminated" in js["note"] and "last successful time 9 s" in js["note"], js["note"]
    assert "ended early at t = 8.8" in p.stderr, p.stderr
    t = cols["time"]
    assert len(t) == 23 and t[-1] == pytest.approx(8.8), "every row up to the stop, none after"
    counter = 1 + np.floor(t + 1e-9)
    assert np.array_equal(cols["stair.counter"], counter)
    assert np.array_equal(cols["f.int_out"], np.concatenate([[1], counter[:-1]]))


@pytest.mark.parametrize("scheme", SCHEMES)
def test_resource_file_and_string_connection_inside_an_ssp(systems, scheme):
    """The .ssv inside the archive selects ramp.txt; the FMU reads it from its own resources."""
    cols, _, _ = run(systems["resource"], scheme, 0.1, *TIGHT)
    t = cols["time"]
    title, ts, ys = read_table(REPO / "testfmus" / "fmus" / "resources" / "ramp.txt")
    y = np.interp(t, ts, ys)
    assert np.max(np.abs(cols["signal.y"] - y)) < 1e-14
    x = dahlquist_steps(1.0, 0.0, 0.1, delayed(y, scheme))
    assert np.max(np.abs(cols["d.x"] - x)) < 1e-12
    assert cols["f.string_out"] == [title] * len(t) and title == "ramp from resources/ramp.txt"
    assert np.all(cols["f.int_out"] == len(ts)) and np.all(cols["signal.title"] == np.array([title] * len(t)))


@pytest.mark.parametrize("scheme", SCHEMES)
def test_oscillators_follow_the_van_der_pol_reference(systems, scheme):
    cols, _, _ = run(systems["oscillators"], scheme, 0.05, *TIGHT)
    check_oscillators(cols, scheme)


def test_oscillators_jacobi_matches_fmpy(systems):
    params = {"vdp.x0_start": 0.0, "vdp.x1_start": 2.0, "d.x0": 0.0}
    jacobi_matches_fmpy(systems["oscillators"], 10.0, params, ("vdp.x0", "vdp.x1", "d.x"))


def test_a_scheme_an_fmu_cannot_support_is_refused_up_front(systems, tmp_path):
    """The chain with d2 from an FMU that declares no get/set state (its modelDescription.xml
    edited): the schemes that roll back are refused before anything runs, naming the component
    and the attribute; Jacobi and Gauss-Seidel run it as before."""
    stateless = tmp_path / "dahlquist_nostate.fmu"
    with zipfile.ZipFile(fmu_file("dahlquist")) as src, zipfile.ZipFile(stateless, "w") as dst:
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == "modelDescription.xml":
                data = re.sub(rb'canGetAndSetFMUstate="true" canSerializeFMUstate="true"',
                              b'canGetAndSetFMUstate="false" canSerializeFMUstate="false"', data)
                assert b'canGetAndSetFMUstate="false"' in data
            dst.writestr(item, data)
    edit = lambda text: text.replace(  # noqa: E731
        '<ssd:Component name="d2" source="../../dist/dahlquist.fmu">',
        f'<ssd:Component name="d2" source="{stateless}">')
    ssd = pack("chain", tmp_path / "nostate", archive=False, edit=edit)
    for scheme in SCHEMES:
        cols, _, p = run(ssd, scheme, 0.1, *TIGHT, expect_ok=scheme not in ITERATING)
        if scheme in ITERATING:
            assert p.returncode != 0
            assert "needs rollback (get/set FMU state) from every FMU: component `d2`" in p.stderr, p.stderr
            assert "canGetAndSetFMUstate" in p.stderr, p.stderr
            assert not (tmp_path / "nostate" / f"chain-{scheme}-0.1.csv").exists(), "no output of a refused run"
        else:
            x1, f_out, x2 = chain_expected(cols["time"], scheme)
            assert np.max(np.abs(cols["d2.x"] - x2)) < 1e-12
    # the adaptive step rolls back too
    p = subprocess.run([str(MASTER), "run", "--system", str(ssd), "--scheme", "ijcsa", "--adaptive",
                        "--allow-external-fmus"],
                       capture_output=True, text=True)
    assert p.returncode != 0 and "canGetAndSetFMUstate" in p.stderr, p.stderr


@pytest.mark.parametrize("scheme", SCHEMES)
def test_sampled_gives_each_schemes_exact_discrete_answer(systems, scheme):
    """A multi-rate system: the sampler c steps every 0.1 s (its osp:StepSizeHint), four macro
    steps of 0.025 s, and holds its output in between; the plant p steps every macro step. Each
    scheme against the exact discrete answer of the sampled loop (sampled_expected)."""
    cols, js, _ = run(systems["sampled"], scheme, 0.025, *TIGHT)
    t = cols["time"]
    assert len(t) == 81 and t[-1] == 2.0
    x, out = sampled_expected(0.025, 80, scheme)
    assert np.max(np.abs(cols["p.x"] - x)) < 1e-13, np.max(np.abs(cols["p.x"] - x))
    assert np.max(np.abs(cols["c.real_continuous_out"] - out)) < 1e-13
    # the held input is not a second-order hold: the sampled loop differs from the continuous one
    assert np.max(np.abs(x - np.exp(-3.0 * t))) > 1e-2


def test_sampled_rate_from_the_command_line(systems):
    """--rate overrides the file's step: c every 0.05 s (two macro steps) is that answer."""
    cols, _, _ = run(systems["sampled"], "ijcsa", 0.025, "--rate", "c=0.05", *TIGHT)
    x, _ = sampled_expected(0.025, 80, "ijcsa", every=2)
    assert np.max(np.abs(cols["p.x"] - x)) < 1e-13
    # every component at the macro step: the single-rate system, whose iterating schemes couple
    # end values both ways, u_n = -2 x_{n+1}: x_{n+1} = e^{-h} x_n / (1 + 2 (1 - e^{-h}))
    cols, _, _ = run(systems["sampled"], "ijcsa", 0.025, "--rate", "c=0.025", *TIGHT)
    rho = math.exp(-0.025) / (1.0 - 2.0 * math.expm1(-0.025))
    assert np.max(np.abs(cols["p.x"] - rho ** np.arange(81))) < 1e-13


@pytest.mark.parametrize("rate, reason", [
    ("c=0.03", "whole multiple"),
    ("c=0.01", "whole multiple"),
    ("c=0", "positive number"),
    ("c=-0.1", "positive number"),
    ("c=abc", "not a number"),
    ("q=0.1", "no component `q`"),
    ("0.1", "COMPONENT=H"),
])
def test_bad_rates_are_refused_by_name_before_anything_runs(systems, tmp_path, rate, reason):
    csv_path = tmp_path / "out.csv"
    p = subprocess.run([str(MASTER), "run", "--system", str(systems["sampled"]), "--scheme", "jacobi", "--dt", "0.025",
                        "--rate", rate, "--out", str(csv_path)], capture_output=True, text=True)
    assert p.returncode != 0 and reason in p.stderr, p.stderr
    name = rate.split("=")[0]
    assert "=" not in rate or name in p.stderr, p.stderr
    assert not csv_path.exists(), "nothing ran"


def test_the_adaptive_step_refuses_a_multi_rate_system(systems, tmp_path):
    p = subprocess.run([str(MASTER), "run", "--system", str(systems["sampled"]), "--scheme", "ijcsa", "--adaptive"],
                       capture_output=True, text=True)
    assert p.returncode != 0 and "component `c`" in p.stderr and "adaptive" in p.stderr, p.stderr


def test_sampled_from_python_takes_the_rates(systems):
    """feedsim.run_system takes the rates as --rate does (a dict or the flag's text): the same
    columns, bit for bit, and the exact discrete answer."""
    import feedsim

    cols, _, _ = run(systems["sampled"], "iqn-ils", 0.025, "--rate", "c=0.05", *TIGHT)
    for rate in ({"c": 0.05}, "c=0.05"):
        r = feedsim.run_system(systems["sampled"], "iqn-ils", dt=0.025, rate=rate, tol=1e-13, max_iter=500)
        assert r.frame["p.x"].to_numpy().tolist() == cols["p.x"].tolist()
    x, _ = sampled_expected(0.025, 80, "iqn-ils", every=2)
    assert np.max(np.abs(cols["p.x"] - x)) < 1e-13
    with pytest.raises(feedsim.RunError, match="component `c`.*whole multiple"):
        feedsim.run_system(systems["sampled"], "jacobi", dt=0.025, rate={"c": 0.03})
