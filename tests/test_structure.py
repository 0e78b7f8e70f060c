"""structure.fmu on its own, through fmpy: validation, the linear limit against
the single-mode FRF, the nonlinear steady state against eq:NM with imposed
force (computed here from the table), FMU state round trips, independent
instances and misuse.

The FMU comes from the shared fixtures of conftest.py ($FMU_DIR, as
tests/run.sh packages it). Modal tables are written by the tests (JSON, format
nlmode-modal-table v1) and passed through the `modal_table` parameter or packed
into a copy of the FMU's resources folder.
"""

import json
import math
import pathlib
import shutil
import zipfile

import numpy as np
import pytest
from fmpy import extract
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu

from conftest import Instance

ROOT = pathlib.Path(__file__).resolve().parent.parent

# value references (modelDescription/structure/modelDescription.xml)
VR_F, VR_X, VR_V, VR_X_TIP, VR_A, VR_OMEGA, VR_EPS = 0, 1, 2, 3, 4, 5, 6
VR_DRIVE_POINT, VR_MODAL_TABLE = 0, 1  # String
VR_DRIVE_POINT_INDEX = 0  # Integer

W0 = 356.2  # rad/s, the paper's beam (DESIGN.md)
PHI = {"tip": 1.43, "l3": 0.32, "2l3": -1.04}  # fundamental shape at the points [1/sqrt(kg)]


# ---------------------------------------------------------------------------
# fixtures


@pytest.fixture(scope="session")
def structure_fmu(fmu_dir):
    return fmu_dir / "structure.fmu"


@pytest.fixture(scope="session")
def structure_dir(unzipped):
    return unzipped("structure")


def table_dict(amplitude, omega, damping, points, harmonics=1, description="test table"):
    """A modal table; `points` maps a name to a function a -> list of complex phi_0..phi_H."""
    pts = []
    for name, shape in points.items():
        rows = [shape(a) for a in amplitude]
        pts.append({"name": name, "re": [[c.real for c in r] for r in rows], "im": [[c.imag for c in r] for r in rows]})
    return {
        "format": "nlmode-modal-table",
        "version": 1,
        "description": description,
        "harmonics": harmonics,
        "amplitude": list(amplitude),
        "omega_rad_s": list(omega),
        "damping_ratio": list(damping),
        "points": pts,
        "coordinates": [],
        "truncated_at_fold": None,
    }


def linear_table(d=0.01):
    amp = [1e-9, 1.0]
    return table_dict(amp, [W0, W0], [d, d], {k: (lambda a, p=p: [0j, complex(p)]) for k, p in PHI.items()})


# Duffing-like mode: omega(a)^2 = W0^2 + C a^2, third harmonic at the tip
DUFFING_C = 3.0e6 * (W0 / 100.0) ** 2
DUFFING_D = 0.01


def duffing_table():
    amp = np.linspace(1e-4, 0.1, 400)
    omega = np.sqrt(W0**2 + DUFFING_C * amp**2)
    pts = {
        "tip": lambda a: [0j, complex(PHI["tip"]), 0j, complex(0.02 * a / 0.1, -0.01 * a / 0.1)],
        "l3": lambda a: [0j, complex(PHI["l3"]), 0j, 0j],
        "2l3": lambda a: [0j, complex(PHI["2l3"]), 0j, 0j],
    }
    return table_dict(amp, omega, np.full_like(amp, DUFFING_D), pts, harmonics=3, description="Duffing-like")


def write_table(tmp_path, table, name="modal_table.json"):
    p = tmp_path / name
    p.write_text(json.dumps(table))
    return p


_COUNTER = [0]


def open_fmu(unzipdir, name="s"):
    """An instantiated structure FMU (logging on); `.fmu` is the fmpy FMU2Slave,
    `.messages` the (status, category, message) tuples logged for it."""
    _COUNTER[0] += 1
    return Instance(str(unzipdir), f"structure-{name}-{_COUNTER[0]}", logging_on=True)


def start(unzipdir, table_path=None, drive="2l3", eps=0.0, name="s"):
    inst = open_fmu(unzipdir, name)
    fmu = inst.fmu
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    if table_path is not None:
        fmu.setString([VR_MODAL_TABLE], [str(table_path)])
    fmu.setString([VR_DRIVE_POINT], [drive])
    fmu.setReal([VR_EPS], [eps])
    fmu.exitInitializationMode()
    fmu.inst = inst
    return fmu


def run_harmonic(fmu, omega, f0, t_end, h, t_meas):
    """Drive with F = f0 cos(omega t) (value + 1st and 2nd derivatives per step);
    return the fitted complex amplitudes of x and x_tip (and the 3rd harmonic of x_tip)
    over the window [t_end - t_meas, t_end]."""
    n = int(round(t_end / h))
    n_meas = int(round(t_meas / h))
    ts, xs, xts, avals = [], [], [], []
    for k in range(n):
        t = k * h
        c, s = math.cos(omega * t), math.sin(omega * t)
        fmu.setReal([VR_F], [f0 * c])
        fmu.setRealInputDerivatives([VR_F, VR_F], [1, 2], [-f0 * omega * s, -f0 * omega**2 * c])
        fmu.doStep(t, h)
        if k >= n - n_meas:
            x, xt, a = fmu.getReal([VR_X, VR_X_TIP, VR_A])
            ts.append(t + h)
            xs.append(x)
            xts.append(xt)
            avals.append(a)
    ts = np.array(ts)
    basis = np.column_stack(
        [np.cos(omega * ts), -np.sin(omega * ts), np.cos(3 * omega * ts), -np.sin(3 * omega * ts), np.ones_like(ts)]
    )
    fx = np.linalg.lstsq(basis, np.array(xs), rcond=None)[0]
    ft = np.linalg.lstsq(basis, np.array(xts), rcond=None)[0]
    return complex(fx[0], fx[1]), complex(ft[0], ft[1]), complex(ft[2], ft[3]), np.array(avals)


# ---------------------------------------------------------------------------
# tests


def test_validate_fmu_reports_no_problem(structure_fmu):
    assert validate_fmu(str(structure_fmu)) == []


@pytest.mark.parametrize("ratio", [0.2, 0.98, 1.5])
def test_linear_table_equals_single_mode_frf(structure_dir, tmp_path, ratio):
    d = 0.01
    fmu = start(structure_dir, write_table(tmp_path, linear_table(d)))
    omega = ratio * W0
    f0 = 2.0
    # 12 decay times 1/(D w0), then 5 periods (at least 0.1 s) for the fit
    t_meas = max(5 * 2 * math.pi / omega, 0.1)
    x, xt, _, _ = run_harmonic(fmu, omega, f0, 12 / (d * W0) + t_meas, 2e-4, t_meas)
    fmu.terminate()
    fmu.freeInstance()
    h = 1.0 / (W0**2 - omega**2 + 2j * d * W0 * omega)
    x_ref = PHI["2l3"] ** 2 * h * f0
    xt_ref = PHI["tip"] * PHI["2l3"] * h * f0
    assert abs(x - x_ref) < 5e-3 * abs(x_ref), (x, x_ref)
    assert abs(xt - xt_ref) < 5e-3 * abs(xt_ref), (xt, xt_ref)
    # separately: amplitude within 0.5 % and phase within 0.005 rad
    assert abs(abs(x) / abs(x_ref) - 1) < 5e-3
    assert abs(np.angle(x / x_ref)) < 5e-3


def pchip(x, y):
    """Monotone piecewise cubic Hermite interpolant (Fritsch-Carlson, scipy's end
    conditions), written here so that the reference does not share code with the FMU."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    h = np.diff(x)
    delta = np.diff(y) / h
    d = np.zeros_like(y)
    if len(x) == 2:
        d[:] = delta[0]
    else:
        w1, w2 = 2 * h[1:] + h[:-1], h[1:] + 2 * h[:-1]
        same = delta[:-1] * delta[1:] > 0
        with np.errstate(divide="ignore", invalid="ignore"):
            hm = (w1 + w2) / (w1 / delta[:-1] + w2 / delta[1:])
        d[1:-1] = np.where(same, hm, 0.0)

        def end(h0, h1, d0, d1):
            s_ = ((2 * h0 + h1) * d0 - h0 * d1) / (h0 + h1)
            if np.sign(s_) != np.sign(d0):
                return 0.0
            if np.sign(d0) != np.sign(d1) and abs(s_) > 3 * abs(d0):
                return 3 * d0
            return s_

        d[0] = end(h[0], h[1], delta[0], delta[1])
        d[-1] = end(h[-1], h[-2], delta[-1], delta[-2])

    def f(xq):
        xq = np.asarray(xq, float)
        k = np.clip(np.searchsorted(x, xq) - 1, 0, len(x) - 2)
        t = (xq - x[k]) / h[k]
        h00, h10, h01, h11 = 2 * t**3 - 3 * t**2 + 1, t**3 - 2 * t**2 + t, -2 * t**3 + 3 * t**2, t**3 - t**2
        return h00 * y[k] + h10 * h[k] * d[k] + h01 * y[k + 1] + h11 * h[k] * d[k + 1]

    return f


class NM:
    """Steady state of eq:NM with imposed force F at the drive point (no attachment):
    |omega(a)^2 - Omega^2 + 2 i D(a) omega(a) Omega| a = |phi_ex(a)| F, from the table."""

    def __init__(self, table, drive):
        amp = table["amplitude"]
        p = next(p for p in table["points"] if p["name"] == drive)
        self.a_min, self.a_max = amp[0], amp[-1]
        self.omega = pchip(amp, table["omega_rad_s"])
        self.damping = pchip(amp, table["damping_ratio"])
        re, im = pchip(amp, [r[1] for r in p["re"]]), pchip(amp, [r[1] for r in p["im"]])
        self.phi_ex = lambda a: np.abs(re(a) + 1j * im(a))
        self.grid = np.linspace(self.a_min, self.a_max, 20001)

    def residual(self, a, omega, f0):
        w, d = self.omega(a), self.damping(a)
        return np.abs(w**2 - omega**2 + 2j * d * w * omega) * a - self.phi_ex(a) * f0

    def roots(self, omega, f0):
        """All roots in the table's range: sign changes on a grid, then bisection."""
        a = self.grid
        r = self.residual(a, omega, f0)
        out = []
        for i in np.nonzero(np.sign(r[:-1]) != np.sign(r[1:]))[0]:
            lo, hi, r_lo = a[i], a[i + 1], r[i]
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                r_mid = self.residual(mid, omega, f0)
                if np.sign(r_mid) == np.sign(r_lo):
                    lo, r_lo = mid, r_mid
                else:
                    hi = mid
            out.append(0.5 * (lo + hi))
        return out


def nm_steady_roots(table, omega, phi_ex, f0, drive="2l3"):
    return NM(table, drive).roots(omega, f0)


@pytest.mark.parametrize("ratio", [1.0, 1.02])
def test_nonlinear_settled_amplitude_equals_nm_steady_state(structure_dir, tmp_path, ratio):
    table = duffing_table()
    fmu = start(structure_dir, write_table(tmp_path, table))
    omega = ratio * W0
    # the Rust unit test's case (w0 = 100, phi = 0.9, F = 16 N) scaled to W0 at the same amplitudes
    f0 = 16.0 * (W0 / 100.0) ** 2 * 0.9 / abs(PHI["2l3"])
    roots = nm_steady_roots(table, omega, PHI["2l3"], f0)
    assert len(roots) == 1, roots  # unique steady state: reached from rest
    a_nm = roots[0]
    a_lin = abs(PHI["2l3"]) * f0 / abs(W0**2 - omega**2 + 2j * DUFFING_D * W0 * omega)
    assert abs(a_lin - a_nm) > 0.2 * a_nm  # the nonlinearity matters
    t_meas = 20 * 2 * math.pi / omega
    x, _, xt3, avals = run_harmonic(fmu, omega, f0, 15 / (DUFFING_D * W0) + t_meas, 1e-4, t_meas)
    fmu.terminate()
    fmu.freeInstance()
    a_fmu = abs(x) / abs(PHI["2l3"])
    assert abs(a_fmu - a_nm) < 0.02 * a_nm, (a_fmu, a_nm, a_lin)
    # the amplitude output agrees with the fundamental (ripple off resonance only)
    assert abs(avals.mean() - a_nm) < 0.03 * a_nm
    # the tip shows the table's third harmonic, |x_tip,3| ~ a |phi_3,tip(a)|; off resonance
    # the ripple of |z| distorts it (here by about 12 %; exact in free motion, see the Rust tests)
    phi3 = abs(complex(0.02, -0.01)) * a_nm / 0.1
    assert abs(abs(xt3) - a_nm * phi3) < 0.2 * a_nm * phi3, (abs(xt3), a_nm * phi3)


def outputs_after(fmu, t0, n, h=1e-4, f0=50.0, omega=W0):
    out = []
    for k in range(n):
        t = t0 + k * h
        fmu.setReal([VR_F], [f0 * math.cos(omega * t)])
        fmu.doStep(t, h)
        out.append(tuple(fmu.getReal([VR_X, VR_V, VR_X_TIP, VR_A, VR_OMEGA])))
    return out


def test_state_get_set_and_serialize_round_trips_are_exact(structure_dir, tmp_path):
    path = write_table(tmp_path, duffing_table())
    fmu = start(structure_dir, path)
    outputs_after(fmu, 0.0, 500)
    t1 = 500 * 1e-4
    state = fmu.getFMUstate()
    first = outputs_after(fmu, t1, 300)
    fmu.setFMUstate(state)
    assert outputs_after(fmu, t1, 300) == first
    blob = fmu.serializeFMUstate(state)
    fmu.freeFMUstate(state)
    # into a second instance of the same configuration
    other = start(structure_dir, path, name="other")
    s2 = other.deSerializeFMUstate(blob)
    other.setFMUstate(s2)
    other.freeFMUstate(s2)
    assert outputs_after(other, t1, 300) == first
    for f in (fmu, other):
        f.terminate()
        f.freeInstance()


def test_two_instances_run_independently(structure_dir, tmp_path):
    path = write_table(tmp_path, duffing_table())
    a, b = start(structure_dir, path, name="a"), start(structure_dir, path, eps=0.05, name="b")
    ref_a = outputs_after(start(structure_dir, path, name="ref_a"), 0.0, 400)
    ref_b = outputs_after(start(structure_dir, path, eps=0.05, name="ref_b"), 0.0, 400, f0=20.0)
    got_a, got_b = [], []
    for k in range(400):
        t = k * 1e-4
        got_a += outputs_after(a, t, 1)
        got_b += outputs_after(b, t, 1, f0=20.0)
    assert got_a == ref_a and got_b == ref_b
    assert got_a != got_b
    assert a.getReal([VR_OMEGA])[0] != b.getReal([VR_OMEGA])[0]


def expect_error(inst, call, *args, text=None):
    n = len(inst.messages)
    with pytest.raises(FMICallException):
        call(*args)
    new = inst.messages[n:]
    assert any(status >= 3 for status, _, _ in new), new  # fmi2Error logged
    if text:
        assert any(text in m for _, _, m in new), new


def test_misuse_gives_error_status_and_log_and_the_process_survives(structure_dir, tmp_path):
    path = write_table(tmp_path, linear_table())
    # wrong call order: DoStep before initialization
    inst = open_fmu(structure_dir, "order")
    expect_error(inst, inst.fmu.doStep, 0.0, 1e-3, text="illegal call sequence")
    inst.free()

    fmu = start(structure_dir, path, name="misuse")
    # unknown value reference
    expect_error(fmu.inst, fmu.getReal, [99])
    # NaN input
    expect_error(fmu.inst, fmu.setReal, [VR_F], [float("nan")])
    # negative step
    expect_error(fmu.inst, fmu.doStep, 0.0, -1e-3)
    fmu.freeInstance()

    # missing resources: no table in resources/ and no modal_table parameter
    nores = tmp_path / "nores"
    shutil.copytree(structure_dir, nores)
    (nores / "resources" / "modal_table.json").unlink(missing_ok=True)
    inst = open_fmu(nores, "nores")
    inst.fmu.setupExperiment(startTime=0.0)
    inst.fmu.enterInitializationMode()
    expect_error(inst, inst.fmu.exitInitializationMode, text="modal_table.json")
    inst.free()

    # leaving the table's amplitude range
    small = linear_table()
    small["amplitude"] = [1e-9, 1e-4]
    fmu = start(structure_dir, write_table(tmp_path, small, "small.json"), name="range")
    fmu.setReal([VR_F], [1e3])
    with pytest.raises(FMICallException):
        for k in range(1000):
            fmu.doStep(k * 1e-3, 1e-3)
    assert any("above the modal table's range" in m and status >= 3 for status, _, m in fmu.inst.messages)
    fmu.freeInstance()

    # after all that, a fresh instance works
    fmu = start(structure_dir, path, name="fresh")
    outputs_after(fmu, 0.0, 10)
    fmu.terminate()
    fmu.freeInstance()


def test_table_from_the_resources_folder(structure_fmu, tmp_path):
    """The default table location is resources/modal_table.json of the FMU, found
    through the resource URI (here with a space in the path: percent-encoded)."""
    fmu_copy = tmp_path / "with resources.fmu"
    with zipfile.ZipFile(structure_fmu) as src, zipfile.ZipFile(fmu_copy, "w") as dst:
        for item in src.infolist():
            if item.filename != "resources/modal_table.json":
                dst.writestr(item, src.read(item.filename))
        dst.writestr("resources/modal_table.json", json.dumps(linear_table()))
    unz = extract(str(fmu_copy), unzipdir=str(tmp_path / "unzipped with space"))
    fmu = start(unz, None)
    assert fmu.getReal([VR_OMEGA])[0] == W0
    fmu.setReal([VR_F], [10.0])
    for k in range(20000):
        fmu.doStep(k * 2.5e-4, 2.5e-4)
    x = fmu.getReal([VR_X])[0]
    assert abs(x - PHI["2l3"] ** 2 * 10.0 / W0**2) < 2e-3 * PHI["2l3"] ** 2 * 10.0 / W0**2
    fmu.terminate()
    fmu.freeInstance()


# The paper's beam as a Duffing-like mode (DESIGN.md section 3): cantilever mode 1 with the
# cubic tip spring k3, single-term harmonic balance omega(a)^2 = w0^2 + 3/4 k3 phi_tip^4 a^2,
# D = 0.4 %, modal mass about 0.92 kg at 2l/3.
K3 = 6e9
PAPER_PHI = {"tip": 1.905, "l3": 0.318, "2l3": 1.043}


def paper_like_table():
    amp = np.geomspace(1e-5, 4e-3, 300)
    omega = np.sqrt(W0**2 + 0.75 * K3 * PAPER_PHI["tip"] ** 4 * amp**2)
    pts = {k: (lambda a, p=p: [0j, complex(p)]) for k, p in PAPER_PHI.items()}
    return table_dict(amp, omega, np.full_like(amp, 0.004), pts, description="paper-like Duffing mode")


def near_resonance_case(nm, ratio_max=1.5):
    """A forcing F and frequency Omega near the backbone with a unique steady state that
    the response reaches from rest, in a range where the nonlinearity matters: target
    amplitude a_t = 0.3 a_max, F from phase resonance at a_t, then the frequency in
    (omega0, omega(a_t)) with a unique root and the smallest detuning
    |omega(a) - Omega|/Omega that is still at least 4 D."""
    w0 = float(nm.omega(nm.a_min))
    a_t = 0.3 * nm.a_max
    w_t, d_t = float(nm.omega(a_t)), float(nm.damping(a_t))
    f0 = 2 * d_t * w_t**2 * a_t / float(nm.phi_ex(a_t))
    best = None
    for om in np.linspace(w0, min(w_t, ratio_max * w0), 200):
        roots = nm.roots(om, f0)
        if len(roots) != 1:
            continue
        a = roots[0]
        det = abs(float(nm.omega(a)) - om) / om
        if float(nm.omega(a)) - w0 > 4 * d_t * w0 and det >= 4 * d_t and (best is None or det < best[2]):
            best = (om, f0, det, a)
    assert best is not None, "no unique near-resonant steady state found"
    return best


def settle_and_compare(structure_dir, table_path, nm, drive, h=1e-4):
    om, f0, det, a_nm = near_resonance_case(nm)
    d = float(nm.damping(a_nm))
    fmu = start(structure_dir, table_path, drive=drive)
    t_meas = 20 * 2 * math.pi / om
    x, _, _, _ = run_harmonic(fmu, om, f0, 15 / (d * float(nm.omega(nm.a_min))) + t_meas, h, t_meas)
    fmu.terminate()
    fmu.freeInstance()
    a_fmu = abs(x) / float(nm.phi_ex(a_nm))
    return a_fmu, a_nm, om, det


def test_paper_like_mode_settles_on_the_nm_steady_state(structure_dir, tmp_path):
    table = paper_like_table()
    nm = NM(table, "2l3")
    a_fmu, a_nm, om, det = settle_and_compare(structure_dir, write_table(tmp_path, table), nm, "2l3")
    assert abs(a_fmu - a_nm) < 0.02 * a_nm, (a_fmu, a_nm, om, det)


def test_packaged_modal_table_settles_on_the_nm_steady_state(structure_dir):
    """With the paper's modal table in the FMU's resources (packaged from `host nma`)."""
    path = pathlib.Path(structure_dir) / "resources" / "modal_table.json"
    if not path.is_file():
        pytest.skip("this structure.fmu has no resources/modal_table.json")
    table = json.loads(path.read_text())
    names = [p["name"] for p in table["points"]]
    drive = "2l3" if "2l3" in names else names[0]
    nm = NM(table, drive)
    a_fmu, a_nm, om, det = settle_and_compare(structure_dir, None, nm, drive)
    assert abs(a_fmu - a_nm) < 0.02 * a_nm, (a_fmu, a_nm, om, det)


def test_output_derivatives_are_the_time_derivatives_of_the_outputs(structure_dir, tmp_path):
    fmu = start(structure_dir, write_table(tmp_path, duffing_table()), name="derivatives")
    outputs_after(fmu, 0.0, 300, f0=2000.0)
    t = 300 * 1e-4
    f = 123.0
    fmu.setReal([VR_F], [f])
    vrs = [VR_X, VR_V, VR_X_TIP, VR_A, VR_OMEGA]
    y0 = np.array(fmu.getReal(vrs))
    dy = np.array(fmu.getRealOutputDerivatives(vrs, [1] * len(vrs)))
    h = 1e-7
    fmu.doStep(t, h)
    y1 = np.array(fmu.getReal(vrs))
    fd = (y1 - y0) / h
    # forward difference: error ~ h/2 * second derivative ~ 1e-7 * omega ~ 1e-4 relative
    scale = np.abs(dy) + 1e-3 * np.abs(y0) * 356.2
    assert np.all(np.abs(fd - dy) < 1e-3 * scale), (fd, dy)
    # x and v are a consistent pair: dx/dt is close to v (equal in the linear limit)
    assert abs(dy[0] - y0[1]) < 0.05 * abs(y0[1])
    fmu.freeInstance()


def test_two_instances_step_concurrently_in_two_threads(structure_dir, tmp_path):
    """OMSimulator steps two instances of one FMU from two threads at once."""
    import threading

    path = write_table(tmp_path, duffing_table())
    refs = [outputs_after(start(structure_dir, path, eps=e, name=f"seq{e}"), 0.0, 3000, f0=f) for e, f in ((0.0, 50.0), (0.05, 20.0))]
    fmus = [start(structure_dir, path, eps=e, name=f"thr{e}") for e in (0.0, 0.05)]
    results = [None, None]

    def work(i, f):
        results[i] = outputs_after(fmus[i], 0.0, 3000, f0=f)

    threads = [threading.Thread(target=work, args=(0, 50.0)), threading.Thread(target=work, args=(1, 20.0))]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert results[0] == refs[0] and results[1] == refs[1]


# ---------------------------------------------------------------------------
# harmonic_force_projection (nlmode/src/oscillator/projection.rs)

VR_HARMONIC_FORCE_PROJECTION = 0  # Boolean


def projected_normal_form(table, drive, projection):
    """The oscillator's normal form written from its documentation, for a
    table with constant omega and D and a real drive shape `drive(a)` =
    phi_0..phi_H with phi_1 > 0 (gauge g = 1): eta' = omega u + Re f,
    u' = -omega eta - 2 D omega u - Im f, f = (c/omega) e^{i psi} (s' - i s),
    s = Re sum phi_n e^{i n psi}; without the projection f = -i phi_1 c/omega."""
    w, d = table["omega_rad_s"][0], table["damping_ratio"][0]

    def rhs(c, eta, u):
        a = math.hypot(eta, u)
        phi = np.array(drive(a))
        n = np.arange(len(phi))
        if projection and a > 0.0:
            e = complex(eta, -u) / a
            terms = phi * e**n
            s, ds = terms.real.sum(), -(n * terms.imag).sum()
            f = c / w * e * complex(ds, -s)
        else:
            f = -1j * phi[1].real * c / w
        return w * u + f.real, -w * eta - 2.0 * d * w * u - f.imag

    return rhs


@pytest.mark.parametrize("projection", [False, True])
def test_harmonic_force_projection_follows_its_documented_equations(structure_dir, tmp_path, projection):
    """The structure FMU with and without `harmonic_force_projection`, driven
    at its drive point by a force with a strong third harmonic on a mode with
    a third harmonic there, against the normal form integrated here from the
    documentation (scipy DOP853, rtol 1e-11): the drive point's displacement
    agrees to 1e-6 of its largest value (measured 1.3e-8 and 7.6e-8: RK4 at
    2e-5 s). The two settings differ by 24-31 % there (asserted: more than
    2 %), so the check separates them. The third harmonic grows with the
    amplitude (linearly, which the table's PCHIP reproduces exactly), as a
    mode's harmonics do, so the phase is regular at rest."""
    from scipy.integrate import solve_ivp

    amp = np.linspace(1e-6, 0.1, 50)
    shapes = {
        "2l3": lambda a: [0j, 1.0 + 0j, 0j, 15.0 * a + 0j],
        "tip": lambda a: [0j, 1.4 + 0j, 0j, 0j],
        "l3": lambda a: [0j, 0.3 + 0j, 0j, 0j],
    }
    table = table_dict(amp, np.full_like(amp, W0), np.full_like(amp, 0.01), shapes, harmonics=3)
    path = write_table(tmp_path, table)
    f1, f3, beta = 30.0, 40.0, 0.5
    force = lambda t: f1 * math.cos(W0 * t) + f3 * math.cos(3 * W0 * t + beta)
    dforce = lambda t: -f1 * W0 * math.sin(W0 * t) - 3 * W0 * f3 * math.sin(3 * W0 * t + beta)
    ddforce = lambda t: -f1 * W0**2 * math.cos(W0 * t) - 9 * W0**2 * f3 * math.cos(3 * W0 * t + beta)

    def oracle(proj):
        rhs = projected_normal_form(table, shapes["2l3"], proj)
        sol = solve_ivp(
            lambda t, y: rhs(force(t), y[0], y[1]), (0.0, 0.3), [0.0, 0.0], method="DOP853", rtol=1e-11, atol=1e-14, dense_output=True
        )

        def x(t):
            eta, u = sol.sol(t)
            a = math.hypot(eta, u)
            e = complex(eta, -u) / a
            phi = np.array(shapes["2l3"](a))
            return float((a * phi * e ** np.arange(len(phi))).real.sum())

        return x

    fmu = open_fmu(structure_dir, "projection").fmu
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.setString([VR_MODAL_TABLE], [str(path)])
    fmu.setBoolean([VR_HARMONIC_FORCE_PROJECTION], [projection])
    fmu.exitInitializationMode()
    assert fmu.getBoolean([VR_HARMONIC_FORCE_PROJECTION]) == [projection]
    h = 2e-5
    ts, xs = [], []
    for k in range(int(round(0.3 / h))):
        t = k * h
        fmu.setReal([VR_F], [force(t)])
        fmu.setRealInputDerivatives([VR_F, VR_F], [1, 2], [dforce(t), ddforce(t)])
        fmu.doStep(t, h)
        if k % 50 == 49:
            ts.append(t + h)
            xs.append(fmu.getReal([VR_X])[0])
    xs = np.array(xs)
    mine, other = oracle(projection), oracle(not projection)
    expected = np.array([mine(t) for t in ts])
    alternative = np.array([other(t) for t in ts])
    scale = np.abs(expected).max()
    print("projection", projection, "error", np.abs(xs - expected).max() / scale, "other setting", np.abs(alternative - expected).max() / scale)
    assert np.abs(xs - expected).max() < 1e-6 * scale, np.abs(xs - expected).max() / scale
    assert np.abs(alternative - expected).max() > 0.02 * scale
