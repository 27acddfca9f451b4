"""Costs of an FMU seen from fmpy (not a test): load time and one fmi2DoStep.

Run: .venv/bin/python tests/python/bench_fmpy.py [dist/oscillator.fmu]
"""

import shutil
import sys
import tempfile
import time

import fmpy
from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave


def median(xs):
    return sorted(xs)[len(xs) // 2]


def main(path):
    t = []
    for _ in range(11):
        s = time.perf_counter()
        d = fmpy.extract(path)
        t.append(time.perf_counter() - s)
        shutil.rmtree(d)
    extract = median(t)
    md = read_model_description(path)
    loads = []
    for _ in range(11):
        d = tempfile.mkdtemp()
        fmpy.extract(path, d)  # a fresh file each time: dlopen really loads it
        s = time.perf_counter()
        fmu = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier)
        fmu.instantiate()
        loads.append(time.perf_counter() - s)
        fmu.freeInstance()
        shutil.rmtree(d)
    d = fmpy.extract(path)
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier)
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu.setReal([vr["F"]], [1.0])
    n, h, time_now = 20000, 0.01, 0.0
    runs = []
    for _ in range(5):
        s = time.perf_counter()
        for _ in range(n):
            fmu.doStep(time_now, h)
            time_now += h
        runs.append((time.perf_counter() - s) / n)
    raw = []
    for _ in range(5):
        s = time.perf_counter()
        for _ in range(n):
            fmu.fmi2DoStep(fmu.component, time_now, h, 0)
            time_now += h
        raw.append((time.perf_counter() - s) / n)
    fmu.terminate()
    fmu.freeInstance()
    shutil.rmtree(d)
    print(f"fmpy.extract                                 {extract * 1e3:8.2f} ms")
    print(f"FMU2Slave load + instantiate                 {median(loads) * 1e3:8.3f} ms")
    print(f"FMU2Slave.doStep                             {median(runs) * 1e6:8.2f} µs")
    print(f"fmi2DoStep through ctypes (no wrapper)       {median(raw) * 1e6:8.2f} µs")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "dist/oscillator.fmu")
