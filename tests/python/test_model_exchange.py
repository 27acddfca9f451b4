"""Model Exchange components in systems: the master integrates them (dopri5, esdirk3), events and
all, checked against closed forms and against fmpy's Model Exchange simulation with CVode."""

import math
import shutil
from types import SimpleNamespace

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.ssp.simulation import simulate_ssp
from fmpy.ssp.ssd import read_ssd

import c_fmus
from conftest import DIST
from zoo import SCHEMES, ball_exact, chain_expected, pack, parameter_bindings, run, ssd_text

TIGHT = ("--tol", "1e-13", "--max-iter", "500", "--me-rtol", "1e-10", "--me-atol", "1e-12")


def fmi3(names):
    return {n: DIST / "fmi3" / f"{n}.fmu" for n in names}


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("scheme", SCHEMES)
def test_dahlquist_as_model_exchange_meets_its_exact_solution_in_every_scheme(tmp_path, scheme, version):
    """chain with d1 integrated by the master: x1 = 1 - exp(-t) to 1e-8 at rtol 1e-10; d2 (CS)
    gets what it gets from the Co-Simulation d1 (the same held inputs)."""
    fmus = fmi3(["dahlquist", "feedthrough"]) if version == 3 else None
    ssp = pack("chain", tmp_path, fmus=fmus)
    me, j, p = run(ssp, scheme, 0.1, *TIGHT, "--interface", "d1=me", out_dir=tmp_path)
    cs, _, _ = run(ssp, scheme, 0.1, *TIGHT, out_dir=tmp_path / "..")
    t = me["time"]
    assert np.max(np.abs(me["d1.x"] - (1.0 - np.exp(-t)))) < 1e-8
    assert np.max(np.abs(me["d2.x"] - cs["d2.x"])) < 1e-8
    stats = j["model_exchange"]
    assert [s["component"] for s in stats] == ["d1"] and stats[0]["solver"] == "dopri5" and stats[0]["steps"] > 0
    assert "component `d1` (Model Exchange, dopri5)" not in p.stdout  # --json prints the JSON only


@pytest.mark.parametrize("version", [2, 3])
def test_the_bouncing_ball_bounces_at_the_closed_form_times_and_heights(tmp_path, version):
    fmus = fmi3(["bouncing_ball", "feedthrough"]) if version == 3 else None
    ssp = pack("ball", tmp_path, fmus=fmus)
    c, j, _ = run(ssp, "jacobi", 0.01, *TIGHT, "--interface", "ball=me", out_dir=tmp_path)
    h, v, bounces, resting = ball_exact(c["time"])
    assert np.max(np.abs(c["ball.h"] - h)) < 1e-8
    assert np.max(np.abs(c["ball.v"] - v)) < 1e-7
    assert list(c["ball.bounces"]) == list(bounces) and bounces[-1] == 11
    assert j["model_exchange"][0]["state_events"] == 11


@pytest.mark.parametrize("scheme", SCHEMES)
def test_the_stairs_time_events_fall_exactly_on_their_times(tmp_path, scheme):
    ssp = pack("stair", tmp_path)
    c, j, _ = run(ssp, scheme, 0.4, "--interface", "stair=me", out_dir=tmp_path)
    assert j["stopped_early"] and j["stopped_at"] == pytest.approx(8.8) and "terminateSimulation" in j["note"]
    assert list(c["stair.counter"]) == [1 + math.floor(t + 1e-9) for t in c["time"]]
    assert j["model_exchange"][0]["time_events"] == 9


def van_der_pol_ssp(tmp_path, mu, x0=0.0, x1=2.0):
    """`oscillators` with the Van der Pol oscillator's mu and start set."""
    def edit(text):
        text = text.replace('<ssv:Parameter name="x0_start"><ssv:Real value="0"/></ssv:Parameter>',
                            f'<ssv:Parameter name="mu"><ssv:Real value="{mu}"/></ssv:Parameter>'
                            f'<ssv:Parameter name="x0_start"><ssv:Real value="{x0}"/></ssv:Parameter>')
        return text.replace('<ssv:Parameter name="x1_start"><ssv:Real value="2"/></ssv:Parameter>',
                            f'<ssv:Parameter name="x1_start"><ssv:Real value="{x1}"/></ssv:Parameter>')
    return pack("oscillators", tmp_path, edit=edit)


# mu = 1000 starts near its slow manifold (x1 = x0 / (mu (1 - x0²))) and runs its slow phase up to
# the first relaxation jump (near t = 807 s): fmpy's CVode stops at its step limit in the jump, and
# in the fast start from x1 = 2
@pytest.mark.parametrize("mu, x0, x1, solver, t_end, dt, rtol, bound", [
    (1.0, 0.0, 2.0, "dopri5", 10.0, 0.1, "1e-10", 1e-7),
    (1000.0, 2.0, -2.0 / 3000.0, "esdirk3", 800.0, 1.0, "1e-8", 1e-4),
])
def test_van_der_pol_against_fmpys_cvode(tmp_path, mu, x0, x1, solver, t_end, dt, rtol, bound):
    ssp = van_der_pol_ssp(tmp_path, mu, x0, x1)
    c, j, _ = run(ssp, "jacobi", dt, "--interface", "vdp=me", "--me-solver", solver, "--me-rtol", rtol,
                  "--me-atol", "1e-10", t_end=t_end, out_dir=tmp_path)
    assert j["model_exchange"][0]["solver"] == solver
    ref = simulate_fmu(str(DIST / "van_der_pol.fmu"), fmi_type="ModelExchange", solver="CVode",
                       relative_tolerance=1e-11, stop_time=t_end, output_interval=dt / 10,
                       start_values={"mu": mu, "x0_start": x0, "x1_start": x1}, output=["x0", "x1"])
    x0 = np.interp(c["time"], ref["time"], ref["x0"])
    assert np.max(np.abs(c["vdp.x0"] - x0)) < bound


def test_a_stiff_model_with_the_explicit_solver_stops_with_a_clear_error(tmp_path):
    ssp = van_der_pol_ssp(tmp_path, 1e9)
    _, _, p = run(ssp, "jacobi", 1.0, "--interface", "vdp=me", t_end=1.0, out_dir=tmp_path, expect_ok=False)
    assert p.returncode != 0
    assert "vdp" in p.stderr and "esdirk3" in p.stderr and "t = " in p.stderr, p.stderr


def test_an_interface_the_fmu_does_not_offer_is_refused(tmp_path):
    ssp = pack("resource", tmp_path)
    _, _, p = run(ssp, "jacobi", 0.1, "--interface", "me", out_dir=tmp_path, expect_ok=False)
    assert p.returncode != 0 and "no Model Exchange" in p.stderr, p.stderr


D1_BINDINGS = '<ssd:ParameterBinding source="chain_d1.ssv"/>\n        </ssd:ParameterBindings>'


@pytest.mark.parametrize("how", ["annotation", "attribute"])
def test_the_ssd_chooses_model_exchange_per_component(tmp_path, how):
    """`chain` with d1 marked in the .ssd — by this master's annotation (a preference other tools
    skip) or by SSP's own `implementation` attribute — runs d1 as Model Exchange without
    --interface (x1 = 1 - e^-t to 1e-8); --interface d1=cs overrides the file (Jacobi's exact
    answer of the Co-Simulation chain, to 1e-14). fmpy validates the annotated .ssd against the
    SSP 1.0 schema and runs it as before."""
    annotation = ('<ssd:Annotations><ssc:Annotation type="org.feedsim.interface">'
                  '<Interface implementation="ModelExchange"/></ssc:Annotation></ssd:Annotations>')

    def edit(text):
        if how == "attribute":
            return text.replace('<ssd:Component name="d1" source="../../dist/dahlquist.fmu">',
                                '<ssd:Component name="d1" source="../../dist/dahlquist.fmu" implementation="ModelExchange">')
        # after the component's parameter bindings, as the schema orders them
        return text.replace(D1_BINDINGS, D1_BINDINGS + "\n        " + annotation)
    ssp = pack("chain", tmp_path, edit=edit)
    me, j, _ = run(ssp, "jacobi", 0.1, *TIGHT, out_dir=tmp_path)
    assert [s["component"] for s in j["model_exchange"]] == ["d1"]
    assert np.max(np.abs(me["d1.x"] - (1.0 - np.exp(-me["time"])))) < 1e-8
    (tmp_path / "cs").mkdir()
    cs, j, _ = run(ssp, "jacobi", 0.1, *TIGHT, "--interface", "d1=cs", out_dir=tmp_path / "cs")
    assert j["model_exchange"] == []
    x1, _, x2 = chain_expected(cs["time"], "jacobi")
    assert np.max(np.abs(cs["d1.x"] - x1)) < 1e-14 and np.max(np.abs(cs["d2.x"] - x2)) < 1e-12
    if how == "annotation":
        read_ssd(str(ssp), validate=True)
        params = {"d1.k": 1.0, "d1.x0": 0.0, "d1.u": 1.0, "d2.k": 2.0, "d2.x0": 0.0}
        theirs = simulate_ssp(str(ssp), stop_time=1.0, step_size=0.1, parameter_set=SimpleNamespace(
            parameters=[SimpleNamespace(name=k, value=v) for k, v in params.items()]))
        # fmpy's rows are one step early (fmi2-facts.md)
        assert np.max(np.abs(theirs["d1.x"][:10] - cs["d1.x"][1:11])) < 1e-12


def test_an_ssd_asking_for_an_interface_the_fmu_lacks_is_refused(tmp_path):
    """SSP: "It is an error if the specified type of FMU implementation is not present"."""
    ssp = pack("resource", tmp_path, edit=lambda t: t.replace(
        'source="../../dist/resource.fmu"', 'source="../../dist/resource.fmu" implementation="ModelExchange"'))
    _, _, p = run(ssp, "jacobi", 0.1, out_dir=tmp_path, expect_ok=False)
    assert p.returncode == 1 and "signal" in p.stderr and "no Model Exchange" in p.stderr, p.stderr


# --- the FMI 3.0 Model Exchange FMUs written in C (testfmus/c/), independent of our export layer


@pytest.fixture(scope="module")
def c_built(tmp_path_factory):
    return c_fmus.build(tmp_path_factory.mktemp("c-fmus-me"))


def test_fmpy_integrates_the_c_model_exchange_fmus_to_their_exact_answers(c_built):
    """fmpy's own Model Exchange simulation (CVode) of the C FMUs: Dahlquist's closed form, the
    ball's bounces and heights, the stair's counts on their time events."""
    r = simulate_fmu(str(c_built["dahlquist"]), fmi_type="ModelExchange", solver="CVode", relative_tolerance=1e-10,
                     stop_time=2.0, output_interval=0.1, start_values={"k": 1.5, "x0": 2.0})
    assert np.max(np.abs(r["x"] - 2.0 * np.exp(-1.5 * r["time"]))) < 1e-8
    r = simulate_fmu(str(c_built["bouncing_ball"]), fmi_type="ModelExchange", solver="CVode",
                     relative_tolerance=1e-10, stop_time=3.0, output_interval=0.01)
    h, _, bounces, _ = ball_exact(r["time"])
    assert np.max(np.abs(r["h"] - h)) < 1e-6 and r["bounces"][-1] == 11
    # fmpy ends on the final count's time event (9 s), recording the values before it
    r = simulate_fmu(str(c_built["stair"]), fmi_type="ModelExchange", stop_time=20.0, output_interval=0.4)
    between = r["time"] % 1.0 > 1e-9
    assert r["time"][-1] == pytest.approx(9.0)
    assert np.array_equal(r["counter"][between], 1 + np.floor(r["time"][between]))


@pytest.mark.parametrize("scheme", SCHEMES)
def test_the_c_dahlquist_as_model_exchange_meets_its_exact_solution(c_built, tmp_path, scheme):
    fmus = {n: c_built[n] for n in ["dahlquist", "feedthrough"]}
    ssp = pack("chain", tmp_path, fmus=fmus)
    me, j, _ = run(ssp, scheme, 0.1, *TIGHT, "--interface", "d1=me", out_dir=tmp_path)
    cs, _, _ = run(ssp, scheme, 0.1, *TIGHT, out_dir=tmp_path / "..")
    assert np.max(np.abs(me["d1.x"] - (1.0 - np.exp(-me["time"])))) < 1e-8
    assert np.max(np.abs(me["d2.x"] - cs["d2.x"])) < 1e-8
    assert [s["component"] for s in j["model_exchange"]] == ["d1"]


@pytest.mark.parametrize("scheme", ["jacobi", "ijcsa", "iqn-ils"])
def test_the_c_ball_offering_only_model_exchange_bounces_at_the_closed_form(c_built, tmp_path, scheme):
    """No --interface: the C ball offers only Model Exchange; with the exported FMI 3.0
    feedthrough (Int32 and Boolean connections)."""
    ssp = pack("ball", tmp_path, fmus={"bouncing_ball": c_built["bouncing_ball"],
                                       "feedthrough": DIST / "fmi3" / "feedthrough.fmu"})
    c, j, _ = run(ssp, scheme, 0.01, *TIGHT, out_dir=tmp_path)
    h, v, bounces, resting = ball_exact(c["time"])
    assert np.max(np.abs(c["ball.h"] - h)) < 1e-8 and np.max(np.abs(c["ball.v"] - v)) < 1e-7
    assert list(c["ball.bounces"]) == list(bounces) and bounces[-1] == 11
    assert j["model_exchange"][0]["state_events"] == 11


def test_the_c_stairs_time_events_fall_exactly_on_their_times(c_built, tmp_path):
    ssp = pack("stair", tmp_path, fmus={"stair": c_built["stair"], "feedthrough": DIST / "fmi3" / "feedthrough.fmu"})
    c, j, _ = run(ssp, "jacobi", 0.4, "--interface", "stair=me", out_dir=tmp_path)
    assert j["stopped_early"] and j["stopped_at"] == pytest.approx(8.8) and "terminateSimulation" in j["note"]
    assert list(c["stair.counter"]) == [1 + math.floor(t + 1e-9) for t in c["time"]]
    assert j["model_exchange"][0]["time_events"] == 9


def test_the_c_van_der_pol_as_model_exchange_against_fmpys_cvode(c_built, tmp_path):
    ssp = pack("oscillators", tmp_path, fmus={n: c_built[n] for n in ["van_der_pol", "dahlquist"]})
    c, _, _ = run(ssp, "jacobi", 0.1, "--interface", "vdp=me", "--me-rtol", "1e-10", "--me-atol", "1e-10",
                  t_end=10.0, out_dir=tmp_path)
    ref = simulate_fmu(str(c_built["van_der_pol"]), fmi_type="ModelExchange", solver="CVode",
                       relative_tolerance=1e-11, stop_time=10.0, output_interval=0.01,
                       start_values={"x0_start": 0.0, "x1_start": 2.0}, output=["x0"])
    assert np.max(np.abs(c["vdp.x0"] - np.interp(c["time"], ref["time"], ref["x0"]))) < 1e-7


def careless_system(tmp_path, c_built, misbehaviour):
    """The C hostile_me (`bad`) feeding the C feedthrough, with its misbehaviour set."""
    for n in ["hostile_me", "feedthrough"]:
        shutil.copy(c_built[n], tmp_path / f"{n}.fmu")
    ssd = tmp_path / "careless.ssd"
    bindings = parameter_bindings("bad", [("misbehaviour", "Integer", misbehaviour)])
    elements = f"""      <ssd:Component name="bad" source="hostile_me.fmu">
{bindings}
      </ssd:Component>
      <ssd:Component name="f" source="feedthrough.fmu"/>"""
    connections = (
        '      <ssd:Connection startElement="bad" startConnector="x" endElement="f" endConnector="real_continuous_in"/>'
    )
    ssd.write_text(ssd_text("careless", elements, connections, stop_time=2))
    return ssd


@pytest.mark.parametrize("misbehaviour, cause", [
    (1, "the derivative of state `x` is NaN at t = 0.5"),
    (2, "event indicator 0 is NaN at t = 0.5"),
])
@pytest.mark.parametrize("scheme", ["jacobi", "ijcsa"])
def test_a_careless_fmu_returning_nan_with_fmi3ok_is_stopped(c_built, tmp_path, misbehaviour, cause, scheme):
    """NaN derivatives or indicators from an FMU that says fmi3OK: the master's own checks name
    the component, the time and the cause; exit 1, no NaN in a result."""
    ssd = careless_system(tmp_path, c_built, misbehaviour)
    _, _, p = run(ssd, scheme, 0.1, out_dir=tmp_path, expect_ok=False)
    assert p.returncode == 1 and "panicked" not in p.stderr, p.stderr
    assert "FMU `bad`" in p.stderr and cause in p.stderr, p.stderr
    assert not list(tmp_path.glob("*.csv")), "no result written"
    well, j, _ = run(careless_system(tmp_path / "..", c_built, 0), scheme, 0.1, *TIGHT, out_dir=tmp_path)
    assert np.max(np.abs(well["bad.x"] - np.exp(-well["time"]))) < 1e-8 and j["model_exchange"][0]["time_events"] == 1


@pytest.mark.parametrize("scheme", ["jacobi", "gauss-seidel", "ijcsa", "iqn-ils"])
def test_discrete_inputs_of_a_model_exchange_unit_change_in_event_mode(c_built, tmp_path, scheme):
    """The C feedthrough as Model Exchange (no states) refuses a discrete input set in
    continuous-time mode, as FMI 3.0 says: the master sets a changed one in event mode (an input
    event). The ball's Int32 and Boolean values, and the chain routed through the Float64
    discrete input, pass as through the Co-Simulation feedthrough, to the bit."""
    ball = pack("ball", tmp_path / "ball", fmus={n: c_built[n] for n in ["bouncing_ball", "feedthrough"]})
    me, _, _ = run(ball, scheme, 0.01, *TIGHT, "--interface", "f=me", out_dir=tmp_path / "ball")
    (tmp_path / "ball-cs").mkdir()
    cs, _, _ = run(ball, scheme, 0.01, *TIGHT, out_dir=tmp_path / "ball-cs")
    for name in ("f.int_out", "f.bool_out", "f.real_continuous_out"):
        assert np.array_equal(me[name], cs[name]), name
    assert me["f.int_out"][-1] == 11

    def discrete(text):
        return text.replace('endConnector="real_continuous_in"', 'endConnector="real_discrete_in"').replace(
            'startConnector="real_continuous_out"', 'startConnector="real_discrete_out"').replace(
            '<ssd:Connector name="real_continuous_in" kind="input"><ssc:Real/></ssd:Connector>',
            '<ssd:Connector name="real_discrete_in" kind="input"><ssc:Real/></ssd:Connector>').replace(
            '<ssd:Connector name="real_continuous_out" kind="output"><ssc:Real/></ssd:Connector>',
            '<ssd:Connector name="real_discrete_out" kind="output"><ssc:Real/></ssd:Connector>')
    chain = pack("chain", tmp_path / "chain", edit=discrete, fmus={n: c_built[n] for n in ["dahlquist", "feedthrough"]})
    me, _, _ = run(chain, scheme, 0.1, *TIGHT, "--interface", "f=me", out_dir=tmp_path / "chain")
    (tmp_path / "chain-cs").mkdir()
    cs, _, _ = run(chain, scheme, 0.1, *TIGHT, out_dir=tmp_path / "chain-cs")
    assert np.array_equal(me["f.real_discrete_out"], cs["f.real_discrete_out"])
    assert np.array_equal(me["d2.x"], cs["d2.x"])
    assert np.max(np.abs(me["d1.x"] - (1.0 - np.exp(-me["time"])))) < 1e-14
