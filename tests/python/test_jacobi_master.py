"""A small Jacobi master written on fmpy runs the same .fmu files as `master run --scheme jacobi`
and must produce the same cabin motion and wrench (to 1e-9). Jacobi is unstable on the LT50m
scenes after about 0.6 s (the platform's added mass), so 0.3 s are compared."""

import pathlib
import subprocess
import tempfile

import numpy as np
import tomllib

from conftest import DIST, REPO, Slave
import fmpy
from fmpy import read_model_description

MASTER = REPO / "target" / "release" / "master"
SCENE = REPO / "scenes" / "lt50m_C.toml"
H, STEPS = 0.01, 30


def open_fmu(name, directory):
    fmpy.extract(str(DIST / f"{name}.fmu"), directory)
    return Slave(directory, read_model_description(directory), name=name)


def jacobi_with_fmpy():
    system = tomllib.loads(SCENE.read_text())["system"]
    with tempfile.TemporaryDirectory() as d:
        units = {f["name"]: open_fmu(pathlib.Path(f["path"]).stem, f"{d}/{f['name']}") for f in system["fmus"]}
        for u in units.values():
            u.fmu.setupExperiment(startTime=0.0)
            u.fmu.enterInitializationMode()
        for key, value in system["parameters"].items():
            fmu, var = key.split(".", 1)
            unit = units[fmu]
            value = str(SCENE.resolve()) if value == "@scene" else value
            kind = unit.var[var].type
            unit.set(var, float(value) if kind == "Real" else int(value) if kind == "Integer" else value)
        # connections: every output `from.prefix*` feeds the input `to.prefix*` of the same name
        links = []
        for c in system["connections"]:
            (a, pa), (b, pb) = c["from"].split(".", 1), c["to"].split(".", 1)
            for v in units[a].md.modelVariables:
                if v.causality == "output" and v.name.startswith(pa):
                    links.append((a, v.name, b, pb + v.name[len(pa):]))
        # FMI 2.0: connected inputs from outputs in initialization mode, until nothing changes
        # (in the order of the master: unit by unit, each from the newest outputs)
        for _ in range(20):
            changed = False
            for name in units:
                for a, o, b, i in [l for l in links if l[2] == name]:
                    y = units[a].get_real([o])[0]
                    if units[b].get_real([i])[0] != y:
                        units[b].fmu.setReal([units[b].vr[i]], [y])
                        changed = True
            if not changed:
                break
        for u in units.values():
            u.fmu.exitInitializationMode()
        cable, stewart = units["cable"], units["stewart"]
        r_names = [f"cabin.r[{k}]" for k in (1, 2, 3)]
        w_names = [f"wrench.{p}[{k}]" for p in ("f", "m") for k in (1, 2, 3)]
        r0 = np.array(cable.get_real(r_names))
        rows = []
        t = 0.0
        for _ in range(STEPS):
            values = {(a, o): units[a].get_real([o])[0] for a, o, _, _ in links}
            for a, o, b, i in links:
                units[b].fmu.setReal([units[b].vr[i]], [values[(a, o)]])
            for u in units.values():
                u.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=H)
            t += H
            r = (np.array(cable.get_real(r_names)) - r0) * 1e3
            rows.append([t, *r, *stewart.get_real(w_names)])
        for u in units.values():
            u.free()
    return np.array(rows)


def jacobi_with_master():
    with tempfile.TemporaryDirectory() as d:
        out = pathlib.Path(d) / "jacobi.csv"
        subprocess.run(
            [str(MASTER), "run", "--scene", str(SCENE), "--scheme", "jacobi", "--dt", str(H), "--t-end", str(H * STEPS),
             "--out", str(out), "--quiet"],
            check=True,
        )
        data = np.genfromtxt(out, delimiter=",", names=True)
    cols = ["t", "dx_mm", "dy_mm", "dz_mm", "fx_n", "fy_n", "fz_n", "mx_nm", "my_nm", "mz_nm"]
    return np.column_stack([data[c] for c in cols])[1:]  # the CSV starts with t = 0


def test_fmpy_jacobi_master_matches_master_run():
    ours = jacobi_with_master()
    theirs = jacobi_with_fmpy()
    assert ours.shape == theirs.shape
    scale = np.maximum(np.abs(theirs).max(axis=0), 1e-12)
    err = (np.abs(ours - theirs) / scale).max(axis=0)
    assert (err <= 1e-9).all(), f"relative differences per column: {err}"
    # the run is not trivially at rest: the platform's motion moved the cabin
    assert np.abs(theirs[:, 1:4]).max() > 1e-4
