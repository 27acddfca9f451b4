"""The controllers a user writes (docs/controllers.md), built as the page builds them: the C one
on testfmus/c's framework (FMI 3.0), the Python one with pythonfmu (FMI 2.0); put into LT50m C
by `master export-ssp --controller FILE.fmu` and run by `master run --system`. The page's
blocks and tests/python/test_controllers.py use these functions."""

import csv
import os
import pathlib
import shutil
import subprocess
import sys
import zipfile

import numpy as np

REPO = pathlib.Path(__file__).resolve().parents[2]
TARGET = REPO / os.environ.get("CARGO_TARGET_DIR", "target")
MASTER = TARGET / "release" / "master"
SCENE = REPO / "scenes" / "lt50m_C_compensated.toml"


def build_c(out_dir):
    """testfmus/c/controller.c compiled and packed: the .fmu's path."""
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    compiler = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    c = REPO / "testfmus" / "c"
    library = out_dir / "controller.so"
    subprocess.run([compiler, "-std=c99", "-Wall", "-Werror", "-O2", "-fPIC", "-shared", "-fvisibility=hidden",
                    "-o", str(library), str(c / "framework.c"), str(c / "controller.c"), "-lm"], check=True)
    fmu = out_dir / "controller.fmu"
    with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as z:
        z.write(c / "controller.xml", "modelDescription.xml")
        z.write(library, "binaries/x86_64-linux/controller.so")
        z.writestr("resources/", "")
    return fmu


def build_python(out_dir):
    """docs/controllers/hold_feed.py built by pythonfmu (get/set state on): the .fmu's path."""
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    subprocess.run([sys.executable, "-m", "pythonfmu", "build", "-f", str(REPO / "docs" / "controllers" / "hold_feed.py"),
                    "-d", str(out_dir), "--handle-state"], check=True, capture_output=True)
    return out_dir / "HoldFeed.fmu"


def export(controller, ssp, gain=None):
    """LT50m C compensated with `controller` (an .fmu, or `fmu` for control_fmu) as `control`;
    with `gain`, the controller's parameter `gain` bound to it in the system."""
    subprocess.run([str(MASTER), "export-ssp", "--scene", str(SCENE), "--out", str(ssp), "--controller", str(controller)],
                   check=True, capture_output=True)
    if gain is not None:
        bind_gain(ssp, gain)
    return ssp


def bind_gain(ssp, gain):
    """The archive's `control` component with its parameter `gain` bound (SSP ParameterBinding)."""
    with zipfile.ZipFile(ssp) as z:
        entries = {n: z.read(n) for n in z.namelist()}
    ssd = entries["SystemStructure.ssd"].decode()
    head, rest = ssd.split('<ssd:Component name="control"', 1)
    component, tail = rest.split("</ssd:Component>", 1)
    connector = '          <ssd:Connector name="gain" kind="parameter"><ssc:Real/></ssd:Connector>\n        </ssd:Connectors>'
    binding = (f'        <ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues><ssv:ParameterSet version="1.0" '
               f'name="control"><ssv:Parameters><ssv:Parameter name="gain"><ssv:Real value="{gain!r}"/></ssv:Parameter>'
               f'</ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding></ssd:ParameterBindings>\n')
    component = component.replace("        </ssd:Connectors>", connector, 1)
    component = component.replace("        <ssd:Annotations>", binding + "        <ssd:Annotations>", 1)
    entries["SystemStructure.ssd"] = (head + '<ssd:Component name="control"' + component + "</ssd:Component>" + tail).encode()
    with zipfile.ZipFile(ssp, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in entries.items():
            z.writestr(name, data)


def run(ssp, out, scheme="ijcsa", t_end=20.0, *extra):
    """`master run --system` at the scene's step: the CSV's columns by name."""
    subprocess.run([str(MASTER), "run", "--system", str(ssp), "--scheme", scheme, "--dt", "0.0025", "--t-end", repr(t_end),
                    "--out", str(out), *extra], check=True, capture_output=True)
    return read(out)


def read(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return {name: np.array([float(r[j]) for r in rows[1:]]) for j, name in enumerate(rows[0])}


def feed_error_mm(cols):
    """|feed error| (mm) at every step of a system's run."""
    e = np.column_stack([cols[f"stewart.feed.err[{k}]"] for k in (1, 2, 3)]) * 1e3
    return np.sqrt((e ** 2).sum(axis=1))
