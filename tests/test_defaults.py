"""Every FMU runs in every tool at its defaults (issue 26, item 3).

* fmpy's `simulate_fmu` of each FMU as Co-Simulation and, where declared,
  Model Exchange, with fmpy's default settings (stop time and output interval
  from fmpy, inputs at their start values): every output finite. The
  controller at its defaults sees zero inputs (a bench before the exciter is
  on) and fmpy's default output interval, longer than 1/8 of its period.
* Every Real variable read in Initialization Mode through fmpy's low-level
  API (as libcosim does before it exits Initialization Mode): fmi2OK and
  finite values, derivatives included.
* libcosim (libcosimpy from the package index, when it is installed) runs
  structure.fmu at its defaults: before issue 26 it aborted at
  initialization, because `der(eta)` read in Initialization Mode was an error.
"""
import math
import pathlib
import subprocess
import sys

import numpy as np
import pytest
from conftest import CALLBACKS
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Model, FMU2Slave

HERE = pathlib.Path(__file__).resolve().parent

CASES = [
    ("structure", "CoSimulation"),
    ("structure", "ModelExchange"),
    ("shaker", "CoSimulation"),
    ("shaker", "ModelExchange"),
    ("controller", "CoSimulation"),
]


def test_every_declared_interface_is_covered(fmu_dir):
    for name in ["structure", "shaker", "controller"]:
        md = read_model_description(str(fmu_dir / f"{name}.fmu"))
        declared = {"CoSimulation": md.coSimulation, "ModelExchange": md.modelExchange}
        for kind, d in declared.items():
            assert ((name, kind) in CASES) == (d is not None), (name, kind)


@pytest.mark.parametrize("name,fmi_type", CASES)
def test_simulate_fmu_at_defaults_gives_finite_outputs(fmu_dir, name, fmi_type):
    path = str(fmu_dir / f"{name}.fmu")
    md = read_model_description(path)
    outputs = [v.name for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    result = simulate_fmu(path, fmi_type=fmi_type, output=outputs)
    assert len(result) > 10
    assert result["time"][-1] > 0.0
    for o in outputs:
        col = np.asarray(result[o], dtype=float)
        assert np.all(np.isfinite(col)), f"{name} {fmi_type}: {o} not finite"


def _real_vrs(md):
    return [v.valueReference for v in md.modelVariables if v.type == "Real"]


@pytest.mark.parametrize("name", ["structure", "shaker", "controller"])
def test_every_real_is_readable_in_initialization_mode_cs(unzipped, name):
    d = unzipped(name)
    md = read_model_description(d)
    fmu = FMU2Slave(
        guid=md.guid,
        unzipDirectory=d,
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName=f"{name}-init-cs",
    )
    fmu.instantiate(callbacks=CALLBACKS)
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    # fmpy raises on any status other than fmi2OK (and fmi2Warning)
    vals = fmu.getReal(_real_vrs(md))
    assert all(math.isfinite(x) for x in vals), vals
    fmu.exitInitializationMode()
    after = fmu.getReal(_real_vrs(md))
    assert all(math.isfinite(x) for x in after), after
    if name == "structure":
        omega = fmu.getReal([md.modelVariables[[v.name for v in md.modelVariables].index("omega")].valueReference])[0]
        by_name = dict(zip([v.name for v in md.modelVariables if v.type == "Real"], vals))
        # omega in Initialization Mode is the one of the start state, as after it
        assert by_name["omega"] == omega and omega > 300.0
        assert by_name["der(eta)"] == 0.0 and by_name["der(u)"] == 0.0
    fmu.terminate()
    fmu.freeInstance()


@pytest.mark.parametrize("name", ["structure", "shaker"])
def test_every_real_and_the_derivatives_are_readable_in_initialization_mode_me(unzipped, name):
    d = unzipped(name)
    md = read_model_description(d)
    fmu = FMU2Model(
        guid=md.guid,
        unzipDirectory=d,
        modelIdentifier=md.modelExchange.modelIdentifier,
        instanceName=f"{name}-init-me",
    )
    fmu.instantiate(callbacks=CALLBACKS)
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    vals = fmu.getReal(_real_vrs(md))
    assert all(math.isfinite(x) for x in vals), vals
    n = md.numberOfContinuousStates
    dx = np.zeros(n)
    x = np.zeros(n)
    from fmpy.fmi2 import fmi2Real
    import ctypes

    fmu.getDerivatives(dx.ctypes.data_as(ctypes.POINTER(fmi2Real)), n)
    fmu.getContinuousStates(x.ctypes.data_as(ctypes.POINTER(fmi2Real)), n)
    assert np.all(np.isfinite(dx)) and np.all(np.isfinite(x))
    fmu.exitInitializationMode()
    fmu.terminate()
    fmu.freeInstance()


LIBCOSIM_SCRIPT = r"""
import math, sys
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimSlave import CosimLocalSlave
from libcosimpy.CosimObserver import CosimObserver
from libcosimpy.CosimLogging import log_output_level, CosimLogLevel
log_output_level(CosimLogLevel.WARNING)
ex = CosimExecution.from_step_size(int(1e4))  # 1e-5 s in ns, the DefaultExperiment step
idx = ex.add_local_slave(CosimLocalSlave(fmu_path=sys.argv[1], instance_name="structure"))
obs = CosimObserver.create_last_value()
ex.add_observer(obs)
ex.real_initial_value(idx, 0, 1.0)  # F = 1 N
assert ex.simulate_until(int(0.05e9)), "simulate_until failed"
vals = obs.last_real_values(idx, list(range(11)))
print(" ".join(repr(v) for v in vals))
"""


def test_libcosim_runs_structure_fmu_at_its_defaults(fmu_dir, tmp_path):
    pytest.importorskip("libcosimpy", reason="libcosimpy is not installed (tests/requirements.txt)")
    # in a child process: libcosim aborts (SIGABRT) on a model error
    script = tmp_path / "run_libcosim.py"
    script.write_text(LIBCOSIM_SCRIPT)
    p = subprocess.run(
        [sys.executable, str(script), str(fmu_dir / "structure.fmu")],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert p.returncode == 0, f"libcosim: exit {p.returncode}\n{p.stdout[-2000:]}\n{p.stderr[-4000:]}"
    vals = [float(v) for v in p.stdout.split()[-11:]]
    assert all(math.isfinite(v) for v in vals), vals
    # F = 1 N, omega from the paper beam's table, the drive point moving
    assert vals[0] == 1.0
    assert 300.0 < vals[5] < 400.0, vals
    assert vals[1] != 0.0
