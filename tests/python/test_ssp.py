"""SSP 1.0 files of the master, read by fmpy's SSP reader (a reader we did not write).

* `master export-ssp` of the LT50m scene: fmpy validates the .ssd against the SSP schema and
  finds both components and all 25 connections; each packed FMU is instantiated and initialized
  with its bound parameters. (fmpy's `simulate_ssp` cannot step LT50m: it starts every connector
  at 0, and a cabin attitude of four zeros is no rotation.)
* A system of two fmi test oscillators coupled one way (b.F = a.x through a linear
  transformation of factor 1, which converts metres to newtons for the master's unit check;
  fmpy's `simulate_ssp` ignores transformations, hence factor 1): fmpy and `master run --system
  ... --scheme jacobi` give the same response. fmpy starts every connector at 0 while the master
  starts b.F from a.x(0), so a starts at x = 0 (moving at v0 = 1 m/s) to make both agree.
  fmpy's `simulate_ssp` ignores the components' parameter bindings (it takes a parameter set as an
  argument instead). fmpy's rows carry the values one step early (the row at t holds the state after the step
  from t, fmi2-facts.md), so its row k is compared with the master's row k + 1.
"""

import csv
import subprocess
import zipfile
from types import SimpleNamespace

import numpy as np
from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.ssp.ssd import read_ssd
from fmpy.ssp.simulation import simulate_ssp

from conftest import DIST, REPO
from fmus import MASTER
from zoo import parameter_bindings, ssd_text



def master(*args):
    out = subprocess.run([str(MASTER), *args], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return out.stdout


def test_exported_lt50m_ssp_is_valid_for_fmpy(tmp_path):
    scene = tmp_path / "lt50m_C.toml"
    text = (REPO / "scenes" / "lt50m_C.toml").read_text()
    scene.write_text(text.replace('"../dist/', f'"{DIST}/'))
    ssp = tmp_path / "lt50m_C.ssp"
    master("export-ssp", "--scene", str(scene), "--out", str(ssp))
    ssd = read_ssd(str(ssp), validate=True)
    assert [c.name for c in ssd.system.elements] == ["cable", "stewart"]
    assert len(ssd.system.connections) == 25
    # start: each packed FMU instantiated and initialized by fmpy with the bound parameters
    unpacked = tmp_path / "unpacked"
    with zipfile.ZipFile(ssp) as z:
        z.extractall(unpacked)
    for component in ssd.system.elements:
        fmu_dir = tmp_path / component.name
        with zipfile.ZipFile(unpacked / component.source) as z:
            z.extractall(fmu_dir)
        md = read_model_description(str(fmu_dir))
        slave = FMU2Slave(guid=md.guid, unzipDirectory=str(fmu_dir),
                          modelIdentifier=md.coSimulation.modelIdentifier, instanceName=component.name)
        slave.instantiate()
        slave.setupExperiment(startTime=0.0)
        vr = {v.name: v.valueReference for v in md.modelVariables}
        for binding in component.parameterBindings:
            for p in (p for values in binding.parameterValues for p in values.parameters):
                if p.type == "String":
                    slave.setString([vr[p.name]], [p.value])
                else:
                    slave.setReal([vr[p.name]], [float(p.value)])
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        slave.terminate()
        slave.freeInstance()


A_PARAMETERS = parameter_bindings("a", [("x0", "Real", 0), ("v0", "Real", 1)])
ONE_WAY = ssd_text(
    "chain",
    f"""      <ssd:Component name="a" source="oscillator.fmu">
        <ssd:Connectors>
          <ssd:Connector name="x" kind="output"><ssc:Real/></ssd:Connector>
        </ssd:Connectors>
{A_PARAMETERS}
      </ssd:Component>
      <ssd:Component name="b" source="oscillator.fmu">
        <ssd:Connectors>
          <ssd:Connector name="F" kind="input"><ssc:Real/></ssd:Connector>
          <ssd:Connector name="x" kind="output"><ssc:Real/></ssd:Connector>
        </ssd:Connectors>
      </ssd:Component>""",
    '      <ssd:Connection startElement="a" startConnector="x" endElement="b" endConnector="F">'
    '<ssc:LinearTransformation factor="1"/></ssd:Connection>',
)


def test_oscillator_chain_matches_fmpy(tmp_path):
    ssd = tmp_path / "chain.ssp"  # fmpy simulates archives only
    with zipfile.ZipFile(ssd, "w") as z:
        z.writestr("SystemStructure.ssd", ONE_WAY)
        z.write(DIST / "oscillator.fmu", "oscillator.fmu")
    out = tmp_path / "master.csv"
    master("run", "--system", str(ssd), "--scheme", "jacobi", "--dt", "0.01", "--t-end", "2", "--out", str(out))
    with open(out) as f:
        rows = list(csv.DictReader(f))
    ours = np.array([[float(r["time"]), float(r["a.x"]), float(r["b.x"])] for r in rows])
    # fmpy's simulate_ssp does not apply the components' parameter bindings; it takes them as an
    # argument, by `component.variable`
    bindings = SimpleNamespace(
        parameters=[SimpleNamespace(name="a.x0", value=0.0), SimpleNamespace(name="a.v0", value=1.0)]
    )
    theirs = simulate_ssp(str(ssd), stop_time=2.0, step_size=0.01, parameter_set=bindings)
    n = min(len(theirs) - 1, len(ours) - 1)
    assert n >= 150
    # fmpy's row k holds the state after its step from t_k: our row k + 1
    assert np.max(np.abs(theirs["a.x"][:n] - ours[1 : n + 1, 1])) < 1e-12
    assert np.max(np.abs(theirs["b.x"][:n] - ours[1 : n + 1, 2])) < 1e-9
    assert np.max(np.abs(ours[:, 2])) > 1e-3  # b moves: the connection and its factor act
