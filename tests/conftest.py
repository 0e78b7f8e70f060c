"""Shared fixtures of the fmpy harness.

The FMUs are taken from $FMU_DIR (tests/run.sh packages them there); without it
the workspace is built (`cargo build --profile $NLMODE_CARGO_PROFILE`, which puts
the FMU libraries beside the host binary in BUILD_DIR) and the built
`host package` writes them into target/fmus.

NLMODE_CARGO_PROFILE is the cargo profile of every binary the harness runs:
tests/run.sh sets `dev`, whose units `cargo test` has already compiled (so the
harness compiles nothing again); `release` tests the optimised build users ship.
"""
import ctypes
import os
import pathlib
import subprocess
from collections import defaultdict

import pytest
from fmpy import calloc, extract, free, read_model_description
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)
from fmpy.logging import addLoggerProxy

REPO = pathlib.Path(__file__).resolve().parent.parent
CARGO_PROFILE = os.environ.get("NLMODE_CARGO_PROFILE", "release")
# cargo's output folder per profile: dev and test build into target/debug
BUILD_DIR = REPO / "target" / ("debug" if CARGO_PROFILE in ("dev", "test") else CARGO_PROFILE)
HOST = BUILD_DIR / "host"


def import_nlmode():
    """The installed nlmode package. tests/run.sh has built and installed the
    wheel and sets NLMODE_WHEEL=required: then a missing or broken module
    fails the tests; run by plain pytest without the wheel, they are skipped."""
    if os.environ.get("NLMODE_WHEEL") == "required":
        import nlmode

        return nlmode
    return pytest.importorskip("nlmode", reason="the nlmode wheel is not installed (tests/run.sh builds it)")

# Log messages per instance name: (status, category, message). fmpy's native
# logger proxy (which formats the message with vsnprintf, as C masters do) has
# a single slot, so one Python logger serves every instance and routes by name.
MESSAGES = defaultdict(list)


def _logger(env, instance_name, status, category, message):
    name = instance_name.decode("utf-8") if instance_name else "<NULL>"
    MESSAGES[name].append(
        (status, category.decode("utf-8") if category else "<NULL>", message.decode("utf-8") if message else "<NULL>")
    )


CALLBACKS = fmi2CallbackFunctions()
CALLBACKS.logger = fmi2CallbackLoggerTYPE(_logger)
CALLBACKS.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
CALLBACKS.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
addLoggerProxy(ctypes.byref(CALLBACKS))


@pytest.fixture(scope="session")
def fmu_dir():
    d = os.environ.get("FMU_DIR")
    if d:
        return pathlib.Path(d)
    out = REPO / "target" / "fmus"
    subprocess.run(["cargo", "build", "--quiet", "--profile", CARGO_PROFILE], cwd=REPO, check=True)
    subprocess.run([str(HOST), "package", "--fmi", "all", "--out", str(out)], cwd=REPO, check=True)
    return out


@pytest.fixture(scope="session")
def unzipped(fmu_dir, tmp_path_factory):
    """unzipped(name) -> directory of the extracted <name>.fmu (extracted once,
    into a folder whose name has a space and a percent sign to exercise the
    resource-URI decoding)."""
    cache = {}

    def get(name):
        if name not in cache:
            path = fmu_dir / f"{name}.fmu"
            assert path.is_file(), f"{path} missing (run tests/run.sh)"
            cache[name] = extract(str(path), str(tmp_path_factory.mktemp(f"{name} 100%")))
        return cache[name]

    return get


class Instance:
    """An fmpy FMU2Slave with the log messages of its instance name."""

    def __init__(self, unzipdir, instance_name, guid=None, logging_on=False):
        self.md = read_model_description(unzipdir)
        self.name = instance_name
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        MESSAGES.pop(instance_name, None)
        self.fmu = FMU2Slave(
            guid=guid or self.md.guid,
            unzipDirectory=unzipdir,
            modelIdentifier=self.md.coSimulation.modelIdentifier,
            instanceName=instance_name,
        )
        self.fmu.instantiate(callbacks=CALLBACKS, loggingOn=logging_on)

    @property
    def messages(self):
        return MESSAGES[self.name]

    def init(self, start_time=0.0, stop_time=None, **params):
        self.fmu.setupExperiment(startTime=start_time, stopTime=stop_time)
        for k, v in params.items():
            if isinstance(v, bool):
                self.fmu.setBoolean([self.vr[k]], [v])
            else:
                self.fmu.setReal([self.vr[k]], [float(v)])
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        return self

    def get(self, *names):
        vals = self.fmu.getReal([self.vr[n] for n in names])
        return vals[0] if len(names) == 1 else vals

    def set(self, **values):
        self.fmu.setReal([self.vr[k] for k in values], [float(v) for v in values.values()])

    def free(self):
        self.fmu.freeInstance()


@pytest.fixture
def new_instance(unzipped):
    """new_instance(fmu_name, instance_name, **kw) -> Instance; freed after the test."""
    made = []

    def make(fmu_name, instance_name, **kw):
        inst = Instance(unzipped(fmu_name), instance_name, **kw)
        made.append(inst)
        return inst

    yield make
    for inst in made:
        try:
            inst.fmu.fmi2FreeInstance(inst.fmu.component)
        except Exception:
            pass
