"""The FMI 3.0 FMUs (issue 26, item 1): `<id>_fmi3.fmu`, packaged by
`host package --fmi all` (tests/run.sh) from the same libraries as the FMI
2.0 ones.

* fmpy's `validate_fmu` (the FMI 3.0 XML schema, variable names, the
  ModelStructure, start values, causality/variability, units, exactly one
  independent variable, unique value references) finds no problem;
* fmpy's `simulate_fmu` of each as Co-Simulation and, for the structure and
  the shaker, Model Exchange at fmpy's defaults: every output finite;
* the FMI 3.0 Co-Simulation result equals the FMI 2.0 one (same library,
  same steps) for the same settings.
"""
import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu

CASES = [
    ("structure", "CoSimulation"),
    ("structure", "ModelExchange"),
    ("shaker", "CoSimulation"),
    ("shaker", "ModelExchange"),
    ("controller", "CoSimulation"),
]

NAMES = ["structure", "shaker", "controller"]


@pytest.mark.parametrize("name", NAMES)
def test_validate_fmu_reports_no_problem(fmu_dir, name):
    assert validate_fmu(str(fmu_dir / f"{name}_fmi3.fmu")) == []


@pytest.mark.parametrize("name", NAMES)
def test_fmi3_declares_what_fmi2_declares(fmu_dir, name):
    md3 = read_model_description(str(fmu_dir / f"{name}_fmi3.fmu"))
    md2 = read_model_description(str(fmu_dir / f"{name}.fmu"))
    assert md3.fmiVersion == "3.0"
    assert md3.instantiationToken == md2.guid
    assert (md3.modelExchange is None) == (md2.modelExchange is None)
    indep = [v for v in md3.modelVariables if v.causality == "independent"]
    assert [(v.name, v.valueReference) for v in indep] == [("time", 999999999)]
    # every Float64 keeps its FMI 2.0 value reference
    reals2 = {v.name: v.valueReference for v in md2.modelVariables if v.type == "Real"}
    reals3 = {
        v.name: v.valueReference
        for v in md3.modelVariables
        if v.type == "Float64" and v.name != "time" and not v.dimensions
    }
    assert reals3 == reals2
    # FMI 3.0 only: the structure's mode-shape arrays (sized by a UInt64
    # structural parameter); FMI 2.0 has no arrays
    arrays = {v.name for v in md3.modelVariables if v.dimensions}
    assert arrays == ({"mode_shape_re", "mode_shape_im"} if name == "structure" else set())


@pytest.mark.parametrize("name,fmi_type", CASES)
def test_simulate_fmu3_at_defaults_gives_finite_outputs(fmu_dir, name, fmi_type):
    path = str(fmu_dir / f"{name}_fmi3.fmu")
    md = read_model_description(path)
    outputs = [v.name for v in md.modelVariables if v.causality == "output" and v.type == "Float64"]
    result = simulate_fmu(path, fmi_type=fmi_type, output=outputs)
    assert len(result) > 10
    assert result["time"][-1] > 0.0
    for o in outputs:
        col = np.asarray(result[o], dtype=float)
        assert np.all(np.isfinite(col)), f"{name} {fmi_type}: {o} not finite"


@pytest.mark.parametrize("name", NAMES)
def test_fmi3_co_simulation_equals_fmi2(fmu_dir, name):
    kw = dict(fmi_type="CoSimulation", stop_time=0.02, step_size=1e-4, output_interval=1e-4)
    r3 = simulate_fmu(str(fmu_dir / f"{name}_fmi3.fmu"), **kw)
    r2 = simulate_fmu(str(fmu_dir / f"{name}.fmu"), **kw)
    outputs = [n for n in r2.dtype.names if n != "time"]
    assert len(r3) == len(r2)
    for o in outputs:
        np.testing.assert_array_equal(np.asarray(r3[o], float), np.asarray(r2[o], float), err_msg=o)


def _slave(fmu_dir, tmp_path, name):
    from fmpy import extract
    from fmpy.fmi3 import FMU3Slave

    path = str(fmu_dir / f"{name}_fmi3.fmu")
    md = read_model_description(path)
    d = extract(path, str(tmp_path / name))
    fmu = FMU3Slave(
        guid=md.instantiationToken,
        unzipDirectory=d,
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName=f"{name}-fmi3",
    )
    fmu.instantiate()
    return md, fmu


@pytest.mark.parametrize("name", NAMES)
def test_fmu_state_serializes_and_restores_through_the_c_api(fmu_dir, tmp_path, name):
    md, fmu = _slave(fmu_dir, tmp_path, name)
    outs = [
        v.valueReference
        for v in md.modelVariables
        if v.causality == "output" and v.type == "Float64" and not v.dimensions
    ]
    fmu.enterInitializationMode(startTime=0.0)
    fmu.exitInitializationMode()
    h = 1e-4
    for k in range(3):
        ev, term, early, last = fmu.doStep(k * h, h)
        assert (ev, term, early) == (False, False, False) and last == pytest.approx((k + 1) * h)
    state = fmu.getFMUState()
    blob = fmu.serializeFMUState(state)
    fmu.doStep(3 * h, h)
    reference = fmu.getFloat64(outs)
    fmu.setFMUState(state)
    fmu.doStep(3 * h, h)
    assert fmu.getFloat64(outs) == reference
    restored = fmu.deserializeFMUState(blob)
    fmu.setFMUState(restored)
    fmu.doStep(3 * h, h)
    assert fmu.getFloat64(outs) == reference
    assert fmu.getFloat64([999999999]) == [pytest.approx(4 * h)]
    fmu.freeFMUState(state)
    fmu.freeFMUState(restored)
    fmu.terminate()
    fmu.freeInstance()


def test_shaker_directional_derivative_through_the_c_api(fmu_dir, tmp_path):
    md, fmu = _slave(fmu_dir, tmp_path, "shaker")
    vr = {v.name: v.valueReference for v in md.modelVariables}
    k_s = [v.start for v in md.modelVariables if v.name == "k_s"][0]
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    fmu.doStep(0.0, 1e-5)
    (dF,) = fmu.getDirectionalDerivative([vr["F"]], [vr["x"]], [1.0])
    assert dF == -float(k_s)
    fmu.terminate()
    fmu.freeInstance()


# Early return (mightReturnEarlyFromDoStep): a linear modal table whose end
# the response to a constant force crosses inside one long step.
OMEGA, DAMPING, A_MAX, FORCE = 100.0, 0.01, 1e-3, 6.0


def _linear_table(path):
    import json

    n = 3
    amplitude = [1e-9, 0.5 * A_MAX, A_MAX]
    shape = {"re": [[0.0, 1.0]] * n, "im": [[0.0, 0.0]] * n}
    table = {
        "format": "nlmode-modal-table",
        "version": 1,
        "description": "linear test table",
        "harmonics": 1,
        "amplitude": amplitude,
        "omega_rad_s": [OMEGA] * n,
        "damping_ratio": [DAMPING] * n,
        "points": [dict(name="tip", **shape), dict(name="2l3", **shape)],
    }
    path.write_text(json.dumps(table))
    return path


def _crossing_time():
    """First time the analytic step response of eta'' + 2 D w eta' + w^2 eta = F
    from rest has a = |eta - i eta'/w| = A_MAX (scan and bisection)."""
    xs = FORCE / OMEGA**2
    wd = OMEGA * np.sqrt(1.0 - DAMPING**2)

    def a(t):
        e = np.exp(-DAMPING * OMEGA * t)
        eta = xs * (1.0 - e * (np.cos(wd * t) + DAMPING * OMEGA / wd * np.sin(wd * t)))
        deta = xs * OMEGA**2 / wd * e * np.sin(wd * t)
        return np.hypot(eta, deta / OMEGA)

    t = np.arange(0.0, 0.1, 1e-6)
    i = int(np.argmax(a(t) >= A_MAX))
    lo, hi = t[i - 1], t[i]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if a(mid) < A_MAX else (lo, mid)
    return 0.5 * (lo + hi)


@pytest.mark.parametrize("allowed", [True, False])
def test_structure_returns_early_at_the_table_end_through_fmpy(fmu_dir, tmp_path, allowed):
    from fmpy import extract
    from fmpy.fmi3 import FMU3Slave

    path = str(fmu_dir / "structure_fmi3.fmu")
    md = read_model_description(path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    d = extract(path, str(tmp_path / "s"))
    fmu = FMU3Slave(guid=md.instantiationToken, unzipDirectory=d,
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="early")
    messages = []
    fmu.instantiate(earlyReturnAllowed=allowed,
                    logMessage=lambda env, status, cat, msg: messages.append(msg.decode()))
    fmu.setString([vr["modal_table"]], [str(_linear_table(tmp_path / "linear.json"))])
    fmu.enterInitializationMode(startTime=0.0)
    fmu.setFloat64([vr["F"]], [FORCE])
    fmu.exitInitializationMode()
    h = 0.05
    if not allowed:
        # the FMI 2.0 behaviour: fmi3Error naming the amplitude
        with pytest.raises(Exception):
            fmu.doStep(0.0, h)
        assert any("above the modal table's range" in m for m in messages), messages
        fmu.freeInstance()
        return
    event, terminate, early, last = fmu.doStep(0.0, h)
    assert (event, terminate, early) == (False, True, True)
    # RK4 sub-step: ceil(h / h_max) equal parts, h_max = 2 pi / (40 max omega)
    h_max = 2 * np.pi / (40 * OMEGA)
    h_sub = h / np.ceil(h / h_max)
    t_cross = _crossing_time()
    print(f"early return at {last:.9f} s, analytic crossing {t_cross:.9f} s, sub-step {h_sub:.3e} s")
    assert 0.0 <= t_cross - last <= h_sub
    a, x = fmu.getFloat64([vr["a"], vr["x"]])
    assert 0.9 * A_MAX < a <= A_MAX and np.isfinite(x)
    assert any("returning early" in m and "a_max = 1.000000e-3" in m for m in messages), messages
    fmu.terminate()
    fmu.freeInstance()


def test_structure_mode_shape_array_is_the_tables_shape_at_the_output_amplitude(fmu_dir, tmp_path):
    """The FMI 3.0 arrays mode_shape_re/_im (sized by the UInt64 structural
    parameter mode_shape_points) read through fmpy equal a phi_1,k(a) / g(a)
    computed here from the packaged modal_table.json: scipy's PCHIP of the
    fundamental harmonic at the output amplitude a, in the gauge g of the
    drive point 2l3 (its fundamental real and positive)."""
    import json

    from scipy.interpolate import PchipInterpolator

    md, fmu = _slave(fmu_dir, tmp_path, "structure")
    vr = {v.name: v for v in md.modelVariables}
    table = json.loads((tmp_path / "structure" / "resources" / "modal_table.json").read_text())
    n = len(table["points"])
    assert vr["mode_shape_points"].start == str(n) or int(vr["mode_shape_points"].start) == n
    assert vr["mode_shape_re"].shape == (n,)
    assert fmu.getUInt64([vr["mode_shape_points"].valueReference]) == [n]
    fmu.enterInitializationMode(startTime=0.0)
    fmu.setFloat64([vr["F"].valueReference], [2.0])
    fmu.exitInitializationMode()
    h = 1e-4
    for k in range(300):
        fmu.doStep(k * h, h)
    arrays = [vr["mode_shape_re"].valueReference, vr["mode_shape_im"].valueReference]
    values = fmu.getFloat64(arrays + [vr["a"].valueReference], nValues=2 * n + 1)
    re, im, a = np.array(values[:n]), np.array(values[n:2 * n]), values[2 * n]
    amp = np.array(table["amplitude"])
    assert amp[0] < a < amp[-1], a

    def phi1(point):
        re_k = PchipInterpolator(amp, [r[1] for r in point["re"]])(a)
        im_k = PchipInterpolator(amp, [r[1] for r in point["im"]])(a)
        return complex(re_k, im_k)

    names = [p["name"] for p in table["points"]]
    g = phi1(table["points"][names.index("2l3")])
    g /= abs(g)
    expected = np.array([a * phi1(p) / g for p in table["points"]])
    got = re + 1j * im
    err = np.max(np.abs(got - expected)) / np.max(np.abs(expected))
    print(f"mode shape at a = {a:.4e}: {dict(zip(names, np.round(got, 8)))}, max relative error {err:.2e}")
    assert err < 1e-9
    x_drive = fmu.getFloat64([vr["x"].valueReference])[0]
    assert abs(x_drive) <= 1.5 * abs(got[names.index("2l3")])
    fmu.terminate()
    fmu.freeInstance()
