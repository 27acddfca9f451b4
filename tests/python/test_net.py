"""The net's VTK files read back by meshio (a reader we did not write) against the run's CSV, the
statics, the scene's own numbers and the modal solver; the Python package's Result.net()."""

import json
import math
import os
import pathlib
import subprocess
import tomllib
import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pandas as pd
import pytest

import feedsim

REPO = pathlib.Path(__file__).resolve().parents[2]
MASTER = REPO / os.environ.get("CARGO_TARGET_DIR", "target") / "release" / "master"
C = REPO / "scenes" / "lt50m_C.toml"
B = REPO / "scenes" / "lt50m_B.toml"
CABLE_ONLY = REPO / "scenes" / "lt50m_C_cable_only.toml"


def master(*args):
    out = subprocess.run([str(MASTER), *map(str, args)], capture_output=True, text=True, cwd=REPO)
    assert out.returncode == 0, out.stderr
    return out.stdout


def series(index):
    """(time, mesh) of every file a .pvd lists, in its order."""
    root = ET.parse(index).getroot()
    return [(float(d.get("timestep")), meshio.read(index.parent / d.get("file"))) for d in root.iter("DataSet")]


def scene_numbers(path):
    s = tomllib.loads(path.read_text())
    cables, anchors = s["cables"], s["anchors"]
    angles = [math.radians(a) for a in anchors["angle_deg"]]
    points = np.array([[anchors["radius_m"] * math.cos(a), anchors["radius_m"] * math.sin(a), anchors["z_m"]] for a in angles])
    return cables["elements"], cables["youngs_modulus_pa"] * cables["area_m2"], points


def cell_array(mesh, name):
    return np.concatenate(mesh.cell_data[name])


@pytest.mark.parametrize(
    "scene, scheme, every",
    [(C, "monolithic", 10), (B, "monolithic", 25), (CABLE_ONLY, "cable", 10)],
    ids=["C-monolithic", "B-monolithic", "C-cable"],
)
def test_a_run_series_reads_back_as_the_run(tmp_path, scene, scheme, every):
    csv, vtk = tmp_path / "run.csv", tmp_path / "vtk"
    master("run", "--scene", scene, "--scheme", scheme, "--t-end", 2, "--out", csv, "--vtk", vtk, "--vtk-every", every, "--quiet")
    name = tomllib.loads(scene.read_text())["name"]
    frames = series(vtk / f"{name}.pvd")
    rows = pd.read_csv(csv)
    assert len(frames) == (len(rows) - 1) // every + 1
    elements, ea, anchors = scene_numbers(scene)
    n = elements + 1
    statics = json.loads(master("statics", "--scene", scene, "--json"))
    lengths = np.array([c["unstretched_length_m"] for c in statics["cables"]]) / elements
    platform = tomllib.loads(scene.read_text())["analyses"]["stewart"] != "absent"
    for k, (t, mesh) in enumerate(frames):
        # the points: every cable's, the towers' feet, the cabin centre, the platform's 14
        assert len(mesh.points) == 6 * n + 6 + 1 + (14 if platform else 0)
        assert t == rows["t"][every * k] == mesh.field_data["TimeValue"][0]
        # the anchors never move, and sit where the scene puts them
        np.testing.assert_allclose(mesh.points[0 : 6 * n : n], anchors, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(mesh.point_data["displacement"][0 : 6 * n : n], 0.0)
        # the cabin centre's displacement is the CSV's to round-off
        d = mesh.point_data["displacement"][6 * n + 6] * 1e3
        expected = rows[["dx_mm", "dy_mm", "dz_mm"]].iloc[every * k].to_numpy()
        np.testing.assert_allclose(d, expected, rtol=1e-12, atol=1e-15)
        # every element's tension is the bar's EA (L - L0) / L0 at the points written
        tension, part = cell_array(mesh, "tension_n"), cell_array(mesh, "part")
        elements_t = tension[part == 0].reshape(6, elements)
        for i in range(6):
            p = mesh.points[i * n : (i + 1) * n]
            stretch = np.linalg.norm(np.diff(p, axis=0), axis=1)
            bar = np.maximum(ea * (stretch - lengths[i]) / lengths[i], 0.0)
            np.testing.assert_allclose(elements_t[i], bar, rtol=1e-10, atol=1e-9)
            if k == 0:
                # at the start (the equilibrium) the end tensions `master statics` prints
                c = statics["cables"][i]
                np.testing.assert_allclose(elements_t[i][[0, -1]], [c["tension_anchor_n"], c["tension_cabin_n"]], rtol=2e-8)
        assert np.isnan(tension[part != 0][: 6 + 2]).all()


def test_a_mode_reads_back_as_the_solvers(tmp_path):
    vtk = tmp_path / "vtk"
    modes = json.loads(master("modes", "--scene", C, "--count", 6, "--vtk", vtk, "--json"))
    frames = series(vtk / "lt50m_C_modes.pvd")
    assert [t for t, _ in frames] == [1, 2, 3, 4, 5, 6]
    elements, _, anchors = scene_numbers(C)
    n = elements + 1
    for (number, mesh), m in zip(frames, modes["modes"]):
        assert mesh.field_data["frequency_hz"][0] == m["frequency_hz"]
        shape = mesh.point_data["mode_shape"]
        np.testing.assert_array_equal(shape[0 : 6 * n : n], 0.0)
        np.testing.assert_allclose(mesh.points[0 : 6 * n : n], anchors, rtol=0, atol=1e-12)
        # the cabin centre moves as the solver's cabin part, its attachment points rigidly with it
        centre = mesh.points[6 * n + 6]
        dr, dth = np.array(m["cabin_shape"][:3]), np.array(m["cabin_shape"][3:])
        np.testing.assert_array_equal(shape[6 * n + 6], dr)
        ends = mesh.points[n - 1 : 6 * n : n]
        np.testing.assert_allclose(shape[n - 1 : 6 * n : n], dr + np.cross(dth, ends - centre), rtol=1e-12, atol=1e-15)


def test_result_net_is_the_runs_net(tmp_path):
    r = feedsim.run(C, "monolithic", t_end=0.5, net=True)
    net = r.net()
    assert net.shape == (51, 6, 21, 3)
    vtk = tmp_path / "vtk"
    master("run", "--scene", C, "--scheme", "monolithic", "--t-end", 0.5, "--vtk", vtk, "--quiet")
    frames = series(vtk / "lt50m_C.pvd")
    assert [t for t, _ in frames] == list(r.arrays()["t"])
    for k, (_, mesh) in enumerate(frames):
        np.testing.assert_array_equal(net[k].reshape(-1, 3), mesh.points[: 6 * 21])
    with pytest.raises(ValueError, match="net=True"):
        feedsim.run(C, "monolithic", t_end=0.1).net()
    with pytest.raises(ValueError, match="monolithic"):
        feedsim.run(C, "ijcsa", t_end=0.1, net=True)
