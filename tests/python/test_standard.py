"""FMI 2.0 as written, seen through fmpy: derivatives and dependencies at a communication point,
initialization with the inputs the importer gives, and misuse through the C ABI."""

import json
import math
import shutil
import subprocess

import numpy as np
import pytest

from conftest import Slave, expect_error, fmu_path, DIST, REPO
import fmpy
from fmpy import read_model_description, simulate_fmu
from zoo import MASTER

SCENES = ["lt50m_C.toml", "lt50m_B.toml"]


def open_fmu(name, directory, instance=None):
    fmpy.extract(str(DIST / f"{name}.fmu"), directory)
    return Slave(directory, read_model_description(directory), name=instance or name)


def dependencies(md, initial):
    """{output name: set of known names} from <Outputs> or <InitialUnknowns>."""
    unknowns = md.initialUnknowns if initial else md.outputs
    return {u.variable.name: {d.name for d in (u.dependencies or [])} for u in unknowns}


def static_wrench(stewart_dir, scene):
    """The platform's wrench at the scene's pose at rest (from the Stewart FMU in
    initialization mode, the importer's way)."""
    s = Slave(stewart_dir, read_model_description(stewart_dir), name="probe")
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    s.set("scene", scene)
    names = [f"wrench.{p}[{k}]" for p in ("f", "m") for k in (1, 2, 3)]
    w = s.get_real(names)
    s.free()
    return w


CASES = {
    # name: (inputs, input perturbations, relative tolerance of the declared pairs)
    "cable_fmu": ([f"wrench.{p}[{k}]" for p in ("f", "m") for k in (1, 2, 3)], [2.0] * 3 + [1.0] * 3, 1e-4),
    "stewart_fmu": (
        [f"cabin.{p}[{k}]" for p, n in (("r", 3), ("q", 4), ("v", 3), ("w", 3), ("a", 3), ("alpha", 3)) for k in range(1, n + 1)],
        [1e-5] * 19,
        1e-6,
    ),
}


@pytest.mark.parametrize("name", list(CASES))
def test_derivatives_and_dependencies_at_a_communication_point(name, tmp_path):
    """Every declared and every undeclared output/input pair, at B and C, in initialization
    and step mode: fmi2GetDirectionalDerivative equals central differences of fmi2GetReal after
    fmi2SetReal (no step); an undeclared pair does not move."""
    inputs, deltas, rtol = CASES[name]
    stewart_dir = str(tmp_path / "probe")
    fmpy.extract(str(DIST / "stewart_fmu.fmu"), stewart_dir)
    for scene in SCENES:
        for initial in (True, False):
            s = open_fmu(name, str(tmp_path / f"{scene}-{initial}"))
            deps = dependencies(s.md, initial)
            outputs = list(deps)
            s.fmu.setupExperiment(startTime=0.0)
            s.fmu.enterInitializationMode()
            s.set("scene", scene)
            if name == "cable_fmu":
                s.fmu.setReal([s.vr[i] for i in inputs], static_wrench(stewart_dir, scene))
            if not initial:
                s.fmu.exitInitializationMode()
                for k in range(10):
                    s.fmu.doStep(currentCommunicationPoint=0.01 * k, communicationStepSize=0.01)
            out_vrs = [s.vr[o] for o in outputs]
            for name_in, delta in zip(inputs, deltas):
                vr = s.vr[name_in]
                u0 = s.fmu.getReal([vr])[0]
                s.fmu.setReal([vr], [u0 + delta])
                p = np.array(s.fmu.getReal(out_vrs))
                s.fmu.setReal([vr], [u0 - delta])
                q = np.array(s.fmu.getReal(out_vrs))
                s.fmu.setReal([vr], [u0])
                y = np.array(s.fmu.getReal(out_vrs))
                d = np.array(s.fmu.getDirectionalDerivative(out_vrs, [vr], [1.0]))
                fd = (p - q) / (2 * delta)
                scale = max(np.abs(d).max(), 1e-3)
                for r, o in enumerate(outputs):
                    what = f"{scene} {'init' if initial else 'step'}: d {o} / d {name_in}"
                    if name_in in deps[o]:
                        assert abs(fd[r] - d[r]) <= rtol * max(scale, 1.0 if name == "stewart_fmu" else scale), (
                            f"{what}: fd {fd[r]:e}, exact {d[r]:e}")
                    else:
                        assert abs(p[r] - q[r]) <= 1e-13 * max(abs(y[r]), 1.0), f"{what}: undeclared, moves by {fd[r]:e}"
                        assert d[r] == 0.0, f"{what}: undeclared, derivative {d[r]:e}"
            s.free()


def connect_in_initialization(cable, stewart):
    """The importer's part: connected inputs from connected outputs in initialization mode,
    until nothing changes; returns the passes it took."""
    to_stewart = [f"cabin.{p}[{k}]" for p, n in (("r", 3), ("q", 4), ("v", 3), ("w", 3), ("a", 3), ("alpha", 3)) for k in range(1, n + 1)]
    to_cable = [f"wrench.{p}[{k}]" for p in ("f", "m") for k in (1, 2, 3)]
    for passes in range(1, 20):
        changed = False
        for src, dst, names in ((stewart, cable, to_cable), (cable, stewart, to_stewart)):
            y = src.get_real(names)
            if y != dst.get_real(names):
                dst.fmu.setReal([dst.vr[n] for n in names], y)
                changed = True
        if not changed:
            return passes, to_stewart, to_cable
    raise AssertionError("initialization did not settle")


def test_scene_b_starts_at_rest_under_a_standard_importer(tmp_path):
    """fmpy drives both FMUs at scene B with the platform held still: inputs set from outputs
    in initialization mode (iterated), then a fixed-point iteration with rollback per step
    (Jacobi alone is unstable here: the platform's added mass). Drift over 10 s ≤ 1e-6 m."""
    cable = open_fmu("cable_fmu", str(tmp_path / "cable"), "cable")
    stewart = open_fmu("stewart_fmu", str(tmp_path / "stewart"), "stewart")
    for u in (cable, stewart):
        u.fmu.setupExperiment(startTime=0.0)
        u.fmu.enterInitializationMode()
        u.set("scene", "lt50m_B.toml")
    stewart.set("speed", 0.0)
    passes, to_stewart, to_cable = connect_in_initialization(cable, stewart)
    assert passes <= 3
    for u in (cable, stewart):
        u.fmu.exitInitializationMode()
    r_names = [f"cabin.r[{k}]" for k in (1, 2, 3)]
    r0 = np.array(cable.get_real(r_names))
    assert np.abs(r0 - [-2.82, 8.89, 16.1]).max() < 1e-12, "the target pose of B"
    h, drift, t = 0.01, 0.0, 0.0
    states = [cable.fmu.getFMUstate(), stewart.fmu.getFMUstate()]
    for _ in range(1000):
        states = [cable.fmu.getFMUstate(), stewart.fmu.getFMUstate()]
        for it in range(50):
            w = stewart.get_real(to_cable) if it == 0 else w_new
            cable.fmu.setReal([cable.vr[n] for n in to_cable], w)
            cable.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
            stewart.fmu.setReal([stewart.vr[n] for n in to_stewart], cable.get_real(to_stewart))
            stewart.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
            w_new = stewart.get_real(to_cable)
            if max(abs(a - b) for a, b in zip(w, w_new)) <= 1e-9 * 2000.0:
                break
            w_new = [0.5 * (a + b) for a, b in zip(w, w_new)]
            cable.fmu.setFMUstate(states[0])
            stewart.fmu.setFMUstate(states[1])
        else:
            raise AssertionError(f"no convergence at t = {t}")
        for st, u in zip(states, (cable, stewart)):
            u.fmu.freeFMUstate(st)
        t += h
        drift = max(drift, np.abs(np.array(cable.get_real(r_names)) - r0).max())
    print(f"scene B, platform held still: drift over 10 s {drift:.2e} m")
    assert drift <= 1e-6
    cable.free()
    stewart.free()


def test_misuse_through_the_c_abi_fails_cleanly(tmp_path):
    """Too many elements (never an abort of this process), a scene path leaving resources/, a
    wrench of 1e300 and a NaN input derivative: fmi2Error with the reason, the process alive."""
    d = str(tmp_path / "cable")
    fmpy.extract(str(DIST / "cable_fmu.fmu"), d)
    md = read_model_description(d)
    for n in (10_000_000, 2**31 - 1):
        s = Slave(d, md, name=f"big{n}")
        s.fmu.setupExperiment(startTime=0.0)
        s.fmu.enterInitializationMode()
        expect_error(s, lambda: s.set("elements_per_cable", n), "elements_per_cable", f"{n} elements per cable would need about")
        s.free()
    s = Slave(d, md, name="escape")
    (tmp_path / "secret.toml").write_text('password = "hunter2"\n')
    expect_error(s, lambda: s.set("scene", "../../secret.toml"), "leaves the FMU's resources/ directory")
    assert not any("hunter2" in m for _, _, m in s.messages)
    s.free()
    s = Slave(d, md, name="huge").initialize()
    expect_error(s, lambda: s.fmu.setReal([s.vr["wrench.f[3]"]], [1e300]),
                 "`wrench.f[3]` (input, continuous) = 1e300: outside the declared range [-1e7, 1e7]")
    s.free()
    st = open_fmu("stewart_fmu", tmp_path / "stewart")
    expect_error(st, lambda: st.set("speed", 1e6), "`speed` (parameter, fixed) = 1e6: outside the declared range [-1e0, 1e1]")
    st.fmu.reset()
    st.initialize()
    expect_error(st, lambda: st.set("cabin.r[1]", 1e300), "`cabin.r[1]` (input, continuous) = 1e300: outside")
    st.free()
    s = Slave(d, md, name="rate").initialize()
    expect_error(s, lambda: s.fmu.setRealInputDerivatives([s.vr["wrench.f[1]"]], [1], [math.inf]), "not a finite number")
    s.free()


POSE_B = {"cabin.r[1]": -2.82, "cabin.r[2]": 8.89, "cabin.r[3]": 16.1,
          "cabin.q[1]": 0.939692621, "cabin.q[2]": 0.326011192, "cabin.q[3]": 0.103414124, "cabin.q[4]": 0.0}
WRENCH = [f"wrench.{p}[{k}]" for p in ("f", "m") for k in (1, 2, 3)]
FORCES = [f"actuator.force[{k}]" for k in range(1, 7)]


# The platform's first revolution (radius 0.1 m at 0.02 m/s) in 3142 equal steps: the samples of
# `master stewart`, which takes ceil(T / 0.01) of them.
REVOLUTION = 2 * math.pi * 0.1 / 0.02
SAMPLE = REVOLUTION / 3142


def platform_revolution(scene, pose, messages=None):
    """The Stewart FMU under fmpy.simulate_fmu, cabin held still, over the platform's first
    revolution at the samples of `master stewart`; `messages` collects the FMU's log."""

    def logger(env, instance, status, category, message):
        messages.append((status, category.decode(), message.decode()))

    return simulate_fmu(
        str(DIST / "stewart_fmu.fmu"), stop_time=REVOLUTION, output_interval=SAMPLE,
        start_values={"scene": scene, "speed": 0.02, **pose}, output=WRENCH + FORCES,
        logger=logger if messages is not None else None,
    )


def master_stewart(scene):
    done = subprocess.run([str(MASTER), "stewart", "--scene", str(REPO / "scenes" / scene), "--json"],
                          check=True, capture_output=True, text=True)
    return json.loads(done.stdout)


@pytest.mark.parametrize("scene,pose", [("lt50m_B.toml", POSE_B), ("lt50m_C.toml", {})], ids=["B", "C"])
def test_the_platform_in_a_cabin_set_to_the_scene_pose_is_the_scene_platform(scene, pose):
    """The README's fmpy example, over a whole revolution: with the cabin inputs at the scene's
    pose the FMU gives the wrench and actuator-force ranges `master stewart` computes from the
    library on a fixed cabin (another path: no FMU, no importer)."""
    messages = []
    result = platform_revolution(scene, pose, messages)
    expected = master_stewart(scene)
    assert not messages, messages
    assert len(result) == expected["samples"] and abs(expected["revolution_s"] - REVOLUTION) < 1e-12
    got = np.array([[result[n].min() for n in WRENCH + FORCES], [result[n].max() for n in WRENCH + FORCES]])
    want = np.array([expected["wrench_min"] + expected["actuator_forces_n"]["min"],
                     expected["wrench_max"] + expected["actuator_forces_n"]["max"]])
    # B's quaternion, given to nine digits, turns the cabin by ~1e-9 rad from the scene's exact
    # pose: ~1e-9 of the 1.8e3 N weight (6e-7 measured). C's pose is the declared start, exact.
    tolerance = 2e-6 if pose else 1e-10
    assert np.abs(got - want).max() <= tolerance, np.abs(got - want).max()


def test_cabin_inputs_left_at_scene_c_under_scene_b_are_warned_about():
    """Inputs never set keep their declared start values (scene C's pose): at B the platform is
    then computed in a cabin at C. The FMU warns at fmi2ExitInitializationMode and the results
    are C's, not B's."""
    messages = []
    unset = platform_revolution("lt50m_B.toml", {}, messages)
    warnings = [m for m in messages if m[0] == 1]
    assert len(warnings) == 1 and warnings[0][1] == "logWarning", messages
    assert "fmi2ExitInitializationMode: the cabin inputs hold the pose" in warnings[0][2]
    assert "scene `lt50m_B.toml`" in warnings[0][2]
    at_c = platform_revolution("lt50m_C.toml", {})
    at_b = platform_revolution("lt50m_B.toml", POSE_B)
    for name in WRENCH + FORCES:
        assert np.array_equal(unset[name], at_c[name]), name
    # B tilts the cabin 40°: the platform's weight shifts the moment about y by ~400 N·m
    assert abs(at_b["wrench.m[2]"].mean() - at_c["wrench.m[2]"].mean()) > 300.0


@pytest.mark.parametrize("name", ["cable_fmu", "stewart_fmu"])
def test_a_damaged_or_edited_state_is_refused(name, tmp_path):
    """A serialized state ends with a digest of its bytes: a flipped byte anywhere is refused at
    fmi2DeSerializeFMUstate; a state whose scene name was edited (and its digest made to fit)
    is refused at fmi2SetFMUstate, because the state keeps the digest of the scene it was made
    with; an intact state restores."""
    scene = tmp_path / "scene.toml"
    shutil.copy(REPO / "scenes" / "lt50m_C.toml", scene)
    s = open_fmu(name, tmp_path / "unpacked")
    s.initialize({"scene": str(scene)})
    s.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.01)
    state = s.fmu.getFMUstate()
    data = bytes(s.fmu.serializeFMUstate(state))
    s.fmu.freeFMUstate(state)

    for at in (0, len(data) // 2, len(data) - 1):
        flipped = bytearray(data)
        flipped[at] ^= 1
        expect_error(s, lambda: s.fmu.deSerializeFMUstate(bytes(flipped)), "its digest does not match its bytes")
        s.fmu.reset()
        s.initialize({"scene": str(scene)})

    s.free()

    # another instance restores the state: its scene file changed on disk since the state was
    # made, so the file the state names is not the one it was made with
    scene.write_text(scene.read_text().replace("mass_kg = 720.0", "mass_kg = 721.0", 1))
    s = open_fmu(name, tmp_path / "unpacked", instance="other")
    s.initialize()
    restored = s.fmu.deSerializeFMUstate(data)
    expect_error(s, lambda: s.fmu.setFMUstate(restored), "scene.toml", "is not the file the state was saved with")
    shutil.copy(REPO / "scenes" / "lt50m_C.toml", scene)
    s.fmu.reset()
    s.messages.clear()
    s.initialize()
    s.fmu.setFMUstate(restored)
    s.fmu.doStep(currentCommunicationPoint=0.01, communicationStepSize=0.01)
    s.fmu.freeFMUstate(restored)
    assert not s.errors(), s.messages
    s.free()
