"""The Python package `nlmode` (python/, built and installed by tests/run.sh)
against the `host` command line: the same numbers, the same error messages."""
import json
import pathlib
import re
import subprocess
import threading
import time

import numpy as np
import pytest
from conftest import HOST, import_nlmode

nlmode = import_nlmode()

REPO = pathlib.Path(__file__).resolve().parent.parent
SWEEP = (REPO / "sweep.toml").read_text()
# case (a) by every method but cosim (which needs the FMU libraries in the Python process)
CASE_A_METHODS = ["reference", "nlmode", "linear-slowflow", "linear-steady", "linear-frf"]
# numbers that are measurements of this run, not results
TIMES = {"wall_time_s", "speedup_nlmode_over_reference"}


def case_a_text():
    methods = ", ".join(f'"{m}"' for m in CASE_A_METHODS)
    text = re.sub(r"(?m)^methods = \[.*\]$", f"methods = [{methods}]", SWEEP)
    assert methods in text
    return text.replace("fmus = true", "fmus = false")


def host(*args, check=True):
    assert HOST.is_file(), f"{HOST} missing (tests/run.sh builds it)"
    return subprocess.run([str(HOST), *map(str, args)], cwd=REPO, capture_output=True, text=True, check=check)


def strip_times(x):
    if isinstance(x, dict):
        return {k: strip_times(v) for k, v in x.items() if k not in TIMES}
    if isinstance(x, list):
        return [strip_times(v) for v in x]
    return x


def assert_close(a, b, path="summary"):
    """Equal structures, numbers to 1e-12 relative."""
    if isinstance(a, dict):
        assert sorted(a) == sorted(b), path
        for k in a:
            assert_close(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            assert_close(x, y, f"{path}[{i}]")
    elif isinstance(a, float) or isinstance(b, float):
        assert a == pytest.approx(b, rel=1e-12, abs=0.0), path
    else:
        assert a == b, path


def read_csv_columns(path):
    header = path.read_text().splitlines()[0].split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {h: data[:, i] for i, h in enumerate(header)}


@pytest.fixture(scope="module")
def case_a(tmp_path_factory):
    """(host run's output folder, nlmode.run's result) of case (a)."""
    d = tmp_path_factory.mktemp("case_a")
    sc = d / "case_a.toml"
    sc.write_text(case_a_text())
    host("run", sc, "-o", d / "out")
    return d / "out", nlmode.run(sc)


def test_case_a_sweep_equals_host_run(case_a):
    out, r = case_a
    summary = json.loads((out / "summary.json").read_text())
    assert_close(strip_times(r.summary), strip_times(summary))
    assert set(r.methods) == set(summary["methods"])
    for m in r.methods:
        env = r.envelope(m)
        csv = read_csv_columns(out / f"{m}_envelope.csv")
        assert list(env) == list(csv), m
        for k in csv:
            np.testing.assert_allclose(env[k], csv[k], rtol=1e-12, atol=0, err_msg=f"{m} {k}")
    ts = r.time_series("nlmode")
    csv = read_csv_columns(out / "nlmode_timeseries.csv")
    assert list(ts) == list(csv)
    for k in csv:
        np.testing.assert_allclose(ts[k], csv[k], rtol=1e-12, atol=0, err_msg=k)


def test_methods_argument_and_dict_scenario(case_a):
    out, _ = case_a
    import tomllib

    tree = tomllib.loads(case_a_text())
    r = nlmode.run(tree, methods=["nlmode"])
    assert r.methods == ["nlmode"]
    csv = read_csv_columns(out / "nlmode_envelope.csv")
    for k, v in r.envelope("nlmode").items():
        np.testing.assert_allclose(v, csv[k], rtol=1e-12, atol=0, err_msg=k)
    with pytest.raises(KeyError, match="reference"):
        r.envelope("reference")


def test_bad_scenario_raises_with_the_key_and_the_cli_message(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(SWEEP.replace("voltage_v = 10.0", "voltage_v = -1.0"))
    cli = host("run", bad, "-o", tmp_path / "out", check=False)
    assert cli.returncode == 2
    with pytest.raises(nlmode.ScenarioError) as e:
        nlmode.run(bad)
    assert isinstance(e.value, ValueError)
    assert "excitation.voltage_v" in str(e.value)
    assert cli.stderr.strip() == f"error: {e.value}"
    with pytest.raises(nlmode.ScenarioError, match=r"excitation\.voltage_vv"):
        nlmode.run("[excitation]\nvoltage_vv = 3.0\n")
    with pytest.raises(nlmode.ScenarioError, match=r"run\.methods\[0\]"):
        nlmode.run(methods=["magic"])
    with pytest.raises(nlmode.ScenarioError, match=r"excitation\.voltage_v"):
        nlmode.run({"excitation": {"voltage_v": "ten"}})


def longest_stall_while(call):
    """Run `call` in a second thread; meanwhile this thread runs Python and
    records the longest stretch in which it could not (its longest gap
    between two clock readings that ends after the call started), and the
    duration of the call. The loop allocates no containers: a growing list
    would itself stall this thread (its resizing and the garbage collector
    run with the GIL held)."""
    done = threading.Event()
    span = [0.0, 0.0]

    def worker():
        span[0] = time.perf_counter()
        try:
            call()
        finally:
            span[1] = time.perf_counter()
            done.set()

    t = threading.Thread(target=worker)
    longest = 0.0
    last = time.perf_counter()
    t.start()
    while not done.is_set():
        now = time.perf_counter()
        if span[0] and now - last > longest:
            longest = now - last
        last = now
    t.join()
    return longest, span[1] - span[0]


def test_the_gil_is_released_during_a_sweep():
    """A call that held the GIL from start to end would stall this thread
    for the whole call: with it released, this thread runs on. Not a speed
    ratio: the NMA inside the call already runs on both cores (rayon), so two
    calls in two threads are not much faster than two in a row on 2 cores,
    and a loaded machine hides any speed-up; what the GIL allows is checked
    instead. The time slices of a loaded machine are milliseconds, the call
    is a tenth of a second or more."""
    nlmode.run(methods=["nlmode"])  # warm up

    def calls():
        # three in a row: one takes about 0.05 s on a quiet machine, and the
        # check needs a call well above the time slices
        for _ in range(3):
            nlmode.run(methods=["nlmode", "reference"])

    stall, call = longest_stall_while(calls)
    assert call > 0.05, call
    assert stall < 0.5 * call, (stall, call)
    # and the check can fail: a C loop that keeps the GIL (the builtin sum
    # over a range) stalls this thread for the whole call
    held, call = longest_stall_while(lambda: sum(range(10_000_000)))
    assert held > 0.5 * call, (held, call)


def test_nma_arrays(tmp_path):
    t = nlmode.nma()
    n = len(t.amplitude)
    assert n > 10 and np.all(np.diff(t.amplitude) > 0)
    assert t.omega_rad_s.shape == t.damping_ratio.shape == (n,)
    assert t.omega_rad_s[0] == pytest.approx(t.omega0_rad_s, rel=1e-3)
    # hardening (k3 > 0)
    assert t.omega_rad_s[-1] > t.omega_rad_s[0]
    assert "tip" in t.shapes
    for shape in t.shapes.values():
        assert shape.shape == (n, t.harmonics + 1) and shape.dtype == complex
    acc = t.accuracy
    assert acc["omega_rel"] <= acc["target_omega_rel"] or acc["capped"]
    # the same table as `host nma` writes
    host("nma", "-o", tmp_path)
    ref = json.loads((tmp_path / "modal_table.json").read_text())
    np.testing.assert_allclose(t.amplitude, ref["amplitude"], rtol=1e-12, atol=0)
    np.testing.assert_allclose(t.omega_rad_s, ref["omega_rad_s"], rtol=1e-12, atol=0)


def test_frf_branches():
    f = nlmode.frf()
    w = f["omega_rad_s"]
    assert len(w) >= 100 and f["stable"].dtype == bool
    assert f["tip_amplitude_m"].shape == w.shape == f["force_amplitude_N"].shape
    # hardening: several solutions (an unstable middle branch) somewhere
    assert not f["stable"].all()


def test_hb_branches_as_arrays(tmp_path):
    # the full model's harmonic balance at case (a) (10 V, H = 3): every
    # branch as arrays, branch 0 equal to the hb envelope and to host run's
    # hb_frc.csv
    sc = {"run": {"methods": ["hb"]}, "hb": {"harmonics": 3, "seeds": False}}
    r = nlmode.run(sc)
    br = r.branches("hb")
    assert len(br) == 1
    b = br[0]
    env = r.envelope("hb")
    np.testing.assert_array_equal(b["omega_rad_s"], env["omega_rad_s"])
    np.testing.assert_array_equal(b["tip_amplitude_m"], env["tip_amplitude_m"])
    assert b["stable"].dtype == bool and not b["stable"].all() and b["stable"][0]
    folds = [i for i, x in enumerate(b["bifurcation"]) if x == "fold"]
    assert len(folds) == len(r.summary["methods"]["hb"]["folds"]) == 2
    for h in range(4):
        assert b[f"tip_h{h}_amplitude_m"].shape == b["omega_rad_s"].shape
    # the same numbers host run writes
    toml = tmp_path / "hb.toml"
    toml.write_text('[run]\nmethods = ["hb"]\n[hb]\nharmonics = 3\nseeds = false\n')
    out = tmp_path / "out"
    host("run", toml, "-o", out)
    lines = (out / "hb_frc.csv").read_text().splitlines()
    assert len(lines) == len(b["omega_rad_s"]) + 1
    w = [float(x.split(",")[1]) for x in lines[1:]]
    np.testing.assert_array_equal(np.array(w), b["omega_rad_s"])


GRID = {
    "design": "grid",
    "parameter": [
        {"key": "excitation.voltage_v", "values": [2.0, 5.0, 10.0]},
        {"key": "exciter.0.stinger_stiffness_n_per_m", "values": [1e7, 2.6e7]},
    ],
}


def test_study_equals_host_study(tmp_path):
    import tomllib  # noqa: F401

    st = tmp_path / "study.toml"
    st.write_text(
        'design = "grid"\n[[parameter]]\nkey = "excitation.voltage_v"\nvalues = [2.0, 5.0, 10.0]\n'
        '[[parameter]]\nkey = "exciter.0.stinger_stiffness_n_per_m"\nvalues = [1e7, 2.6e7]\n'
    )
    host("study", st, "-o", tmp_path / "out")
    expected = nlmode.read_results(tmp_path / "out" / "results.csv")
    import pandas as pd

    for df in (nlmode.study(st), nlmode.study(GRID, threads=1), nlmode.study(st.read_text())):
        assert list(df.columns) == list(expected.columns)
        pd.testing.assert_frame_equal(df, expected, check_exact=True)
    assert expected["status"].eq("ok").all() and len(expected) == 6
    with pytest.raises(nlmode.ScenarioError, match=r"excitation\.voltage_vv"):
        nlmode.study({"design": "grid", "parameter": [{"key": "excitation.voltage_vv", "values": [1.0]}]})


def test_study_reference_subset_rows_equal_host_study(tmp_path):
    import pandas as pd

    st = tmp_path / "study.toml"
    st.write_text(
        'design = "grid"\nreference_subset = 2\n'
        '[[parameter]]\nkey = "excitation.voltage_v"\nvalues = [2.0, 5.0, 10.0]\n'
    )
    host("study", st, "-o", tmp_path / "out")
    df = nlmode.study(st)
    pd.testing.assert_frame_equal(df, nlmode.read_results(tmp_path / "out" / "results.csv"), check_exact=True)
    ref = df.attrs["reference"]
    expected = nlmode.read_results(tmp_path / "out" / "results_reference.csv")
    assert list(ref.columns) == list(df.columns) and list(ref["sample"]) == [0, 1]
    pd.testing.assert_frame_equal(ref, expected, check_exact=True)
    assert ref["status"].eq("ok").all()
    # no reference subset: no reference rows
    assert "reference" not in nlmode.study(GRID, threads=1).attrs


def test_example_case_a_plot(tmp_path):
    import os
    import sys

    png = tmp_path / "case_a.png"
    p = subprocess.run(
        [sys.executable, str(REPO / "examples" / "case_a.py"), str(png)],
        cwd=tmp_path,
        env={**os.environ, "MPLBACKEND": "Agg"},
        capture_output=True,
        text=True,
    )
    assert p.returncode == 0, p.stderr
    assert png.stat().st_size > 10_000 and "peak tip" in p.stdout


def _frame_without_files():
    """examples/matrices_frame.toml with its matrices read by scipy instead of
    named as files: (scenario text, {"mass": M, "stiffness": K})."""
    import scipy.io

    here = pathlib.Path(__file__).resolve().parent.parent / "examples"
    text = (here / "matrices_frame.toml").read_text()
    text = re.sub(r'^(mass_mtx|stiffness_mtx) = .*$', "", text, flags=re.M)
    mats = {
        "mass": scipy.io.mmread(here / "matrices" / "frame_M.mtx").tocsr(),
        "stiffness": scipy.io.mmread(here / "matrices" / "frame_K.mtx").tocsc(),
    }
    return text, mats


def test_scipy_sparse_matrices_equal_the_files():
    """The portal frame's M and K as scipy.sparse matrices (no files): the
    modal table and a sweep equal those of the same matrices read from the
    Matrix Market files (feio), to the last digits; dense numpy arrays too."""
    nl = import_nlmode()
    here = pathlib.Path(__file__).resolve().parent.parent / "examples"
    text, mats = _frame_without_files()
    from_files = nl.nma(here / "matrices_frame.toml")
    in_memory = nl.nma(text, matrices=mats)
    assert in_memory.omega0_rad_s == pytest.approx(from_files.omega0_rad_s, rel=1e-13)
    np.testing.assert_allclose(in_memory.omega_rad_s, from_files.omega_rad_s, rtol=1e-11)
    np.testing.assert_allclose(
        in_memory.amplitude, from_files.amplitude, rtol=1e-11, atol=1e-18
    )
    dense = {k: m.toarray() for k, m in mats.items()}
    assert nl.nma(text, matrices=dense).omega0_rad_s == pytest.approx(
        from_files.omega0_rad_s, rel=1e-13
    )
    a = nl.run(here / "matrices_frame.toml", ["nlmode"])
    b = nl.run(text, ["nlmode"], matrices=mats)
    pa = a.summary["methods"]["nlmode"]["peak_tip_amplitude_m"]
    pb = b.summary["methods"]["nlmode"]["peak_tip_amplitude_m"]
    assert pb == pytest.approx(pa, rel=1e-10)


def test_bad_in_memory_matrices_name_the_argument():
    nl = import_nlmode()
    import scipy.sparse as sp

    text, mats = _frame_without_files()
    n = mats["mass"].shape[0]
    cases = [
        ({"mass": mats["mass"]}, "'stiffness' is missing"),
        ({**mats, "mas": mats["mass"]}, "unknown key 'mas'"),
        ({**mats, "mass": sp.eye(n + 1, format="csr")}, "mass"),
        ({**mats, "mass": np.full((n, n - 1), 1.0)}, "mass"),
        ({**mats, "stiffness": sp.csr_matrix(np.full((n, n), np.nan))}, "stiffness"),
        ({**mats, "mass": np.ones(n)}, "2-D"),
    ]
    for m, needle in cases:
        with pytest.raises(nl.ScenarioError, match=re.escape(needle)):
            nl.nma(text, matrices=m)
    # the files named as well, or a beam scenario: the key named
    here = pathlib.Path(__file__).resolve().parent.parent / "examples"
    with pytest.raises(nl.ScenarioError, match="structure.mass_mtx"):
        nl.nma(here / "matrices_frame.toml", matrices=mats)
    with pytest.raises(nl.ScenarioError, match="structure.kind"):
        nl.nma(None, matrices=mats)
