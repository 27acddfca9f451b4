"""The FMI 3.0 test FMUs written in C (testfmus/c/): compiled with the system's C compiler and
packed as .fmu archives, once per test session. They mirror a few of the Reference FMUs'
models under the names of the zoo's FMI 2.0 FMUs (dahlquist, van_der_pol, feedthrough with an
array, stair; the first two and stair offer Model Exchange too; bouncing_ball offers only
Model Exchange), so the zoo's systems and answers apply to them unchanged; hostile_me is a
careless Model Exchange FMU for the master's tests."""

import os
import pathlib
import shutil
import subprocess
import zipfile

REPO = pathlib.Path(__file__).resolve().parents[2]
SOURCES = REPO / "testfmus" / "c"
NAMES = ["dahlquist", "van_der_pol", "feedthrough", "stair", "bouncing_ball", "hostile_me"]


def build(out_dir):
    """Every C FMU compiled and packed into out_dir; returns {name: path of the .fmu}."""
    out_dir = pathlib.Path(out_dir)
    compiler = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    assert compiler, "a C compiler (cc or gcc, or $CC) is needed to build the C test FMUs"
    fmus = {}
    for name in NAMES:
        library = out_dir / f"{name}.so"
        cmd = [compiler, "-std=c99", "-Wall", "-Werror", "-O2", "-fPIC", "-shared", "-fvisibility=hidden",
               "-o", str(library), str(SOURCES / "framework.c"), str(SOURCES / f"{name}.c"), "-lm"]
        subprocess.run(cmd, check=True)
        fmu = out_dir / f"{name}.fmu"
        with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as z:
            z.write(SOURCES / f"{name}.xml", "modelDescription.xml")
            z.write(library, f"binaries/x86_64-linux/{name}.so")
            z.writestr("resources/", "")
        fmus[name] = fmu
    return fmus
