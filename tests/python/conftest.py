"""Fixtures: where the packaged FMUs are, and FMU2Slave instances whose log messages are kept."""

import os
import pathlib
import shutil
import tempfile
from ctypes import byref

import fmpy
import pytest
from fmpy import read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)
from fmpy.logging import addLoggerProxy

from fmus import CASES

REPO = pathlib.Path(__file__).resolve().parents[2]
DIST = pathlib.Path(os.environ.get("FMU_DIST", REPO / "dist"))


def fmu_path(case):
    path = DIST / f"{case.name}.fmu"
    if not path.is_file():
        pytest.fail(f"{path} is missing: run `target/release/master package --out {DIST}` first")
    return path


@pytest.fixture(params=CASES, ids=[c.name for c in CASES], scope="module")
def case(request):
    return request.param


@pytest.fixture(scope="module")
def unpacked(case):
    """The FMU extracted once per module, with its parsed model description."""
    directory = tempfile.mkdtemp(prefix=f"fmi-{case.name}-")
    fmpy.extract(str(fmu_path(case)), directory)
    yield directory, read_model_description(directory)
    shutil.rmtree(directory, ignore_errors=True)


class Slave:
    """An FMU2Slave instance that records the FMU's log messages (formatted by fmpy's proxy)."""

    def __init__(self, directory, md, name="test", logging_on=False):
        self.md = md
        self.messages = []
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.var = {v.name: v for v in md.modelVariables}
        self.fmu = FMU2Slave(
            guid=md.guid,
            unzipDirectory=directory,
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName=name,
        )
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = fmi2CallbackLoggerTYPE(self._log)
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(fmpy.calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(fmpy.free)
        addLoggerProxy(byref(self.callbacks))
        self.fmu.instantiate(callbacks=self.callbacks, loggingOn=logging_on)

    def _log(self, env, instance, status, category, message):
        self.messages.append((status, category.decode(), message.decode()))

    def errors(self):
        return [m for (s, _, m) in self.messages if s >= 3]

    def initialize(self, start_values=None):
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        for name, value in (start_values or {}).items():
            self.set(name, value)
        self.fmu.exitInitializationMode()
        return self

    def set(self, name, value):
        t = self.var[name].type
        vr = [self.vr[name]]
        {"Real": self.fmu.setReal, "Integer": self.fmu.setInteger, "Boolean": self.fmu.setBoolean,
         "String": self.fmu.setString}[t](vr, [value])

    def get_real(self, names):
        return self.fmu.getReal([self.vr[n] for n in names])

    def free(self):
        self.fmu.freeInstance()


def expect_error(slave, call, *fragments):
    """`call` fails with fmi2Error, and the FMU's log of errors names every fragment."""
    with pytest.raises(FMICallException) as e:
        call()
    assert e.value.status == 3, e.value
    text = " ".join(slave.errors())
    for f in fragments:
        assert f in text, f"`{f}` not in the FMU log: {slave.messages}"
