"""shaker.fmu on its own, through fmpy (the exported C API as masters use it)."""
import math

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu

H = 1e-5  # the macro step the stiff stinger coupling needs


def params(md):
    """Start values of the parameters, read from the modelDescription."""
    return {v.name: float(v.start) for v in md.modelVariables if v.causality == "parameter" and v.type == "Real"}


def blocked_force(p, omega, u_hat):
    """Paper Section 4: F = k_s/(z_a + k_s) G u_hat/(R + i W L), computed here
    independently of the Rust code (d_a from 2 D_a sqrt(k_a m_a) = d_a + G^2/R)."""
    L, R, G, m, k, Da, ks = (p[n] for n in ("L", "R", "G", "m_a", "k_a", "D_a", "k_s"))
    d_a = 2 * Da * math.sqrt(k * m) - G * G / R
    coil = R + 1j * omega * L
    z_a = -omega**2 * m + 1j * omega * d_a + k + 1j * omega * G * G / coil
    return ks / (z_a + ks) * G * u_hat / coil


def fundamental(t, y, omega):
    """Complex amplitude Z with y ~ Re(Z e^{i W t}) (least squares)."""
    A = np.column_stack([np.cos(omega * t), np.sin(omega * t)])
    (a, b), *_ = np.linalg.lstsq(A, y, rcond=None)
    return a - 1j * b


def run(inst, t0, n, h=H, drive=None):
    """n steps from t0; drive(t) -> (x, v) sets the inputs before each step.
    Returns the times and forces at the communication points after each step."""
    ts, fs = np.empty(n), np.empty(n)
    vr_F = inst.vr["F"]
    t = t0
    for k in range(n):
        if drive is not None:
            x, v = drive(t)
            inst.set(x=x, v=v)
        inst.fmu.doStep(t, h)
        t = t0 + (k + 1) * h
        ts[k] = t
        fs[k] = inst.fmu.getReal([vr_F])[0]
    return ts, fs


def test_validate_fmu_reports_no_problem(fmu_dir):
    assert validate_fmu(str(fmu_dir / "shaker.fmu")) == []


@pytest.mark.parametrize("omega", [100.0, 356.2, 3000.0])
def test_blocked_force_amplitude_and_phase(new_instance, omega):
    inst = new_instance("shaker", f"blocked{omega}")
    u_hat = 7.5
    inst.init(u_hat=u_hat, Omega_start=omega, Omega_rate=0.0)
    exact = blocked_force(params(inst.md), omega, u_hat)
    # settle 60 ms (slowest decay ~940 1/s), then fit 4 periods
    n_settle = int(0.06 / H)
    n_fit = int(round(4 * 2 * math.pi / omega / H))
    run(inst, 0.0, n_settle)
    t, f = run(inst, n_settle * H, n_fit)
    z = fundamental(t, f, omega)
    rel = abs(z - exact) / abs(exact)
    print(f"W = {omega} rad/s: F = {z:.6f} N, closed form {exact:.6f} N, relative error {rel:.2e}")
    assert rel < 5e-3, (z, exact)
    assert abs(abs(z) / abs(exact) - 1) < 5e-3
    assert abs(np.angle(z / exact)) < 5e-3
    # the applied voltage output is the fixed sine, Omega the fixed frequency
    assert inst.get("Omega") == pytest.approx(omega, rel=1e-15)
    tn = t[-1]
    assert inst.get("u") == pytest.approx(u_hat * math.cos(omega * tn), abs=1e-9 * u_hat)


def test_default_experiment_runs_the_sweep(fmu_dir):
    md = read_model_description(str(fmu_dir / "shaker.fmu"))
    assert md.defaultExperiment.stepSize == "1e-05"
    res = simulate_fmu(str(fmu_dir / "shaker.fmu"), stop_time=0.02, output=["Omega", "u", "F"])
    t = res["time"]
    # Omega = 285 + 404 t (paper: 2 % per pseudo period from 0.8 omega0)
    assert np.allclose(res["Omega"], 285.0 + 404.0 * t, rtol=1e-12)
    assert np.all(np.abs(res["u"]) <= 10.0 + 1e-12)
    assert np.max(np.abs(res["F"])) > 10.0


def test_fmu_state_round_trips_reproduce_the_trajectory(new_instance):
    a = new_instance("shaker", "state-a")
    a.init()  # default sweep
    drive = lambda t: (1e-6 * math.sin(300 * t), 3e-4 * math.cos(300 * t))
    run(a, 0.0, 500, drive=drive)
    s = a.fmu.getFMUstate()
    _, f1 = run(a, 500 * H, 800, drive=drive)
    a.fmu.setFMUstate(s)
    _, f2 = run(a, 500 * H, 800, drive=drive)
    assert np.array_equal(f1, f2)
    # serialize, restore into another instance: same trajectory, bit for bit
    blob = a.fmu.serializeFMUstate(s)
    b = new_instance("shaker", "state-b")
    b.init()
    s2 = b.fmu.deSerializeFMUstate(blob)
    b.fmu.setFMUstate(s2)
    _, f3 = run(b, 500 * H, 800, drive=drive)
    assert np.array_equal(f1, f3)
    a.fmu.freeFMUstate(s)
    b.fmu.freeFMUstate(s2)
    # a corrupted blob is refused with a message
    with pytest.raises(FMICallException):
        b.fmu.deSerializeFMUstate(blob[:-3])
    assert any("truncated" in m for _, _, m in b.messages)


def test_two_instances_are_independent(new_instance):
    a = new_instance("shaker", "twin-a")
    b = new_instance("shaker", "twin-b")
    a.init(u_hat=2.0, Omega_start=500.0, Omega_rate=0.0)
    b.init(u_hat=6.0, Omega_start=500.0, Omega_rate=0.0)
    fa, fb = [], []
    t = 0.0
    for k in range(2000):  # interleaved
        a.fmu.doStep(t, H)
        b.fmu.doStep(t, H)
        t = (k + 1) * H
        fa.append(a.get("F"))
        fb.append(b.get("F"))
    # linear model: three times the voltage, three times the force
    assert np.allclose(np.array(fb), 3.0 * np.array(fa), rtol=1e-12, atol=1e-12)
    c = new_instance("shaker", "twin-c")
    c.init(u_hat=2.0, Omega_start=500.0, Omega_rate=0.0)
    _, fc = run(c, 0.0, 2000)
    assert np.array_equal(fc, np.array(fa))


def test_variable_steps_are_exact_for_linear_inputs(new_instance):
    # no voltage, drive point moving at constant speed: the input is linear in
    # time, so any partition of [0, 12 ms] gives the same state
    def go(steps, name):
        inst = new_instance("shaker", name)
        inst.init(u_hat=0.0)
        t = 0.0
        for h in steps:
            inst.set(x=2e-3 * t, v=2e-3)
            inst.fmu.doStep(t, h)
            t += h
        inst.set(x=2e-3 * t, v=2e-3)
        return np.array(inst.get("F", "I", "q_a", "v_a"))

    uniform = go([1e-5] * 1200, "uniform")
    mixed = go([3e-3, 1e-3, 1e-5, 2e-3 - 1e-5, 4e-3, 2e-3], "mixed")
    assert np.allclose(mixed, uniform, rtol=1e-7, atol=0)
    assert abs(uniform[0]) > 1e-3  # a real force, not zero


def test_directional_and_output_derivatives(new_instance):
    inst = new_instance("shaker", "deriv")
    ks = params(inst.md)["k_s"]
    inst.init(Omega_rate=0.0)
    run(inst, 0.0, 300)
    vr = inst.vr
    d = inst.fmu.getDirectionalDerivative([vr["F"], vr["I"]], [vr["x"]], [1.0])
    assert d == [-ks, 0.0]
    dF, dq = inst.fmu.getRealOutputDerivatives([vr["F"], vr["q_a"]], [1, 1])
    va = inst.get("v_a")
    assert dq == va and dF == pytest.approx(ks * va, rel=1e-12)
    # der(F) matches the difference quotient over one more small step
    f0 = inst.get("F")
    inst.fmu.doStep(300 * H, 1e-8)
    assert (inst.get("F") - f0) / 1e-8 == pytest.approx(dF, rel=1e-4)


def expect_error(inst, call, text):
    with pytest.raises(FMICallException):
        call()
    msgs = [m for _, _, m in inst.messages]
    assert any(text in m for m in msgs), msgs


def test_misuse_is_answered_with_error_and_message(new_instance, unzipped):
    inst = new_instance("shaker", "misuse")
    # wrong call order: DoStep before initialization
    expect_error(inst, lambda: inst.fmu.doStep(0.0, H), "fmi2DoStep: illegal call sequence")
    inst.init()
    # unknown value reference
    expect_error(inst, lambda: inst.fmu.getReal([999]), "unknown value reference 999")
    status, category, _ = inst.messages[-1]
    assert status == 3 and category == "logStatusError"
    # an fmi2Error leaves the instance in the error state until fmi2Reset
    expect_error(inst, lambda: inst.fmu.doStep(0.0, H), "illegal call sequence (called in state Error)")
    inst.fmu.reset()
    inst.init()
    # a parameter that is fixed after initialization
    expect_error(inst, lambda: inst.set(k_s=1e6), "k_s (value reference 6")
    inst.fmu.reset()
    inst.init()
    # NaN input
    expect_error(inst, lambda: inst.set(x=float("nan")), "value of x (value reference 20) must be finite, got NaN")
    inst.fmu.reset()
    inst.init()
    # negative step
    expect_error(inst, lambda: inst.fmu.doStep(0.0, -1e-3), "communicationStepSize must be positive and finite, got -0.001")
    inst.fmu.reset()
    inst.init()
    # communication point that does not match
    expect_error(inst, lambda: inst.fmu.doStep(0.5, H), "expected currentCommunicationPoint = 0 but was 0.5")
    inst.fmu.reset()
    # invalid parameter: exit initialization refuses it
    inst.fmu.setupExperiment(startTime=0.0)
    inst.set(m_a=-1.0)
    inst.fmu.enterInitializationMode()
    expect_error(inst, inst.fmu.exitInitializationMode, "armature_mass_kg")
    # cancelStep: steps are synchronous, never in progress
    expect_error(inst, inst.fmu.cancelStep, "fmi2CancelStep: illegal call sequence")
    # wrong GUID: instantiation fails with a message, the process survives
    with pytest.raises(Exception):
        new_instance("shaker", "bad-guid", guid="{00000000-0000-0000-0000-000000000000}")
    assert any("GUID mismatch" in m for _, _, m in __import__("conftest").MESSAGES["bad-guid"])
    # the process is alive and a fresh instance works
    ok = new_instance("shaker", "after-misuse")
    ok.init()
    run(ok, 0.0, 10)
    assert math.isfinite(ok.get("F"))


FMI2_FUNCTIONS = """
GetTypesPlatform GetVersion SetDebugLogging Instantiate FreeInstance SetupExperiment
EnterInitializationMode ExitInitializationMode Terminate Reset GetReal GetInteger
GetBoolean GetString SetReal SetInteger SetBoolean SetString GetFMUstate SetFMUstate
FreeFMUstate SerializedFMUstateSize SerializeFMUstate DeSerializeFMUstate
GetDirectionalDerivative SetRealInputDerivatives GetRealOutputDerivatives DoStep
CancelStep GetStatus GetRealStatus GetIntegerStatus GetBooleanStatus GetStringStatus
EnterEventMode NewDiscreteStates EnterContinuousTimeMode CompletedIntegratorStep SetTime
SetContinuousStates GetDerivatives GetEventIndicators GetContinuousStates
GetNominalsOfContinuousStates
""".split()


def test_every_fmi2_symbol_is_exported(unzipped):
    import ctypes
    import os

    lib = ctypes.CDLL(os.path.join(unzipped("shaker"), "binaries", "linux64", "shaker.so"))
    missing = [f for f in FMI2_FUNCTIONS if not hasattr(lib, "fmi2" + f)]
    assert len(FMI2_FUNCTIONS) == 44 and missing == []
    lib.fmi2GetVersion.restype = ctypes.c_char_p
    lib.fmi2GetTypesPlatform.restype = ctypes.c_char_p
    assert lib.fmi2GetVersion() == b"2.0" and lib.fmi2GetTypesPlatform() == b"default"


def test_model_exchange_calls_are_refused_on_a_co_simulation_instance(new_instance):
    """The FMU provides Model Exchange (tests/test_me.py), but only to an
    instance made with fmuType fmi2ModelExchange."""
    inst = new_instance("shaker", "me-call")
    inst.init()
    import ctypes

    set_time = inst.fmu.dll.fmi2SetTime
    set_time.argtypes = [ctypes.c_void_p, ctypes.c_double]
    set_time.restype = ctypes.c_int
    assert set_time(inst.fmu.component, 0.0) == 3
    assert "fmi2SetTime: the instance was instantiated as fmi2CoSimulation" in inst.messages[-1][2]


def test_instances_step_concurrently_from_two_threads(new_instance):
    """OMSimulator steps two instances of one library from two threads at once
    (ctypes releases the GIL during the calls)."""
    import threading

    def make(name, u_hat):
        inst = new_instance("shaker", name)
        inst.init(u_hat=u_hat)
        return inst

    drive = lambda t: (2e-6 * math.sin(400 * t), 8e-4 * math.cos(400 * t))
    seq = [run(make(f"seq{k}", u), 0.0, 5000, drive=drive)[1] for k, u in enumerate((3.0, 9.0))]
    par = [make(f"par{k}", u) for k, u in enumerate((3.0, 9.0))]
    out = [None, None]

    def work(k):
        out[k] = run(par[k], 0.0, 5000, drive=drive)[1]

    threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert np.array_equal(out[0], seq[0]) and np.array_equal(out[1], seq[1])
    assert not np.array_equal(seq[0], seq[1])


def test_master_input_derivatives_every_step(new_instance):
    """OMSimulator-style extrapolation: SetReal and SetRealInputDerivatives
    (order 1) on every input before every step. der(x) = v gives exactly the
    trajectory of the plain velocity input; der(v) is accepted."""
    a = new_instance("shaker", "ider-a")
    b = new_instance("shaker", "ider-b")
    a.init()
    b.init()
    vr = a.vr
    drive = lambda t: (1e-6 * math.sin(300 * t), 3e-4 * math.cos(300 * t), -0.09 * math.sin(300 * t))
    t = 0.0
    for k in range(3000):
        x, v, acc = drive(t)
        a.set(x=x, v=v)
        b.set(x=x, v=0.0, u_ext=0.0)
        b.fmu.setRealInputDerivatives([vr["x"], vr["v"], vr["u_ext"]], [1, 1, 1], [v, acc, 0.0])
        a.fmu.doStep(t, H)
        b.fmu.doStep(t, H)
        t = (k + 1) * H
    assert a.get("F", "I", "q_a", "v_a") == b.get("F", "I", "q_a", "v_a")
    with pytest.raises(FMICallException):
        b.fmu.setRealInputDerivatives([vr["x"]], [2], [1.0])
    assert "only first-order input derivatives" in b.messages[-1][2]
