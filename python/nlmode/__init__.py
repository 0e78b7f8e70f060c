"""nlmode: the single-nonlinear-mode theory with linear attachments (M. Krack)
from Python.

A sweep through resonance by any method of ``host run``, the nonlinear modal
analysis as numpy arrays, the steady-state frequency response, and parameter
studies on the local cores or on a Dask cluster. The computations are those of
the ``host`` command line (the same Rust code, the same numbers); every long
call releases the GIL.

    import nlmode
    r = nlmode.run(methods=["nlmode", "reference"])   # the paper's case (a)
    r.summary["methods"]["nlmode"]["peak_tip_amplitude_m"]
    env = r.envelope("nlmode")                          # dict of numpy arrays
    df = nlmode.study("examples/study_lhs.toml")        # pandas DataFrame

A scenario is ``None`` (the embedded default, the paper's case (a)), TOML text,
a path (``str`` or ``os.PathLike``) or a dict of the TOML tables. A ``str`` is
TOML text when it holds a newline or an ``=``, a path otherwise.
"""
from __future__ import annotations

import io
import json
import os
import pathlib
from typing import Any, Dict, List, Mapping, Optional, Sequence, Union

import numpy as np

from . import _native
from ._native import NlmodeError, ScenarioError

__all__ = [
    "run",
    "nma",
    "frf",
    "study",
    "read_results",
    "RunResult",
    "ModalTable",
    "ScenarioError",
    "NlmodeError",
]

Source = Union[None, str, "os.PathLike[str]", Mapping[str, Any]]


def _source(scenario: Source):
    """(text, path) for the native module."""
    if scenario is None:
        return None, None
    if isinstance(scenario, Mapping):
        return _native.dict_to_toml(dict(scenario)), None
    if isinstance(scenario, os.PathLike):
        return None, os.fspath(scenario)
    if isinstance(scenario, str):
        if "\n" in scenario or "=" in scenario:
            return scenario, None
        return None, scenario
    raise TypeError(
        f"scenario: expected None, TOML text, a path or a dict, not {type(scenario).__name__}"
    )


Matrices = Mapping[str, Any]


def _matrices(matrices: Optional[Matrices]):
    """The ``matrices`` argument for the native module: each of ``mass``,
    ``stiffness`` (required) and ``damping`` (optional) as ``(nrows, ncols,
    rows, cols, values)`` with int64 / float64 arrays of its stored entries
    (duplicates summed), from a ``scipy.sparse`` matrix or array (any format)
    or a dense 2-D array. The matrices are not written to files."""
    if matrices is None:
        return None
    if not isinstance(matrices, Mapping):
        raise TypeError(
            "matrices: expected a dict {'mass': M, 'stiffness': K[, 'damping': C]}, "
            f"not {type(matrices).__name__}"
        )
    out = {}
    for key, m in matrices.items():
        if hasattr(m, "tocoo"):  # scipy.sparse, any format
            c = m.tocoo(copy=True)
            c.sum_duplicates()
            rows, cols, vals = c.row, c.col, c.data
            shape = c.shape
        else:
            a = np.asarray(m)
            if a.ndim != 2:
                raise ScenarioError(
                    f"matrices['{key}']: expected a 2-D array or a scipy.sparse matrix, "
                    f"got {a.ndim} dimensions"
                )
            rows, cols = np.nonzero(a)
            vals = a[rows, cols]
            shape = a.shape
        if np.iscomplexobj(vals):
            raise ScenarioError(f"matrices['{key}']: expected real values, got complex")
        out[str(key)] = (
            int(shape[0]),
            int(shape[1]),
            np.ascontiguousarray(rows, dtype=np.int64),
            np.ascontiguousarray(cols, dtype=np.int64),
            np.ascontiguousarray(vals, dtype=np.float64),
        )
    return out


class RunResult:
    """What a sweep computed: ``summary`` (the dict of ``summary.json``),
    ``methods`` (the output names, e.g. ``nlmode``, ``closed-form``),
    ``envelope(method)``, ``time_series(method)``, ``table(name)`` (further
    tables such as ``hb_frc``) and ``branches(method)`` (``hb``'s branches)."""

    def __init__(self, summary: Dict[str, Any], results):
        self.summary = summary
        self._envelopes = {name: env for name, env, _, _ in results}
        self._series = {name: ts for name, _, ts, _ in results}
        self._tables = {t: cols for _, _, _, tabs in results for t, cols in tabs.items()}
        self.methods: List[str] = [name for name, _, _, _ in results]

    def envelope(self, method: str) -> Dict[str, np.ndarray]:
        """The columns of ``<method>_envelope.csv`` as numpy arrays."""
        try:
            return self._envelopes[method]
        except KeyError:
            raise KeyError(f"no envelope of {method!r}; the run has {self.methods}") from None

    def time_series(self, method: str) -> Dict[str, np.ndarray]:
        """The columns of ``<method>_timeseries.csv`` as numpy arrays."""
        ts = self._series.get(method)
        if ts is None:
            with_ts = [m for m, t in self._series.items() if t is not None]
            raise KeyError(f"no time series of {method!r}; methods with one: {with_ts}")
        return ts

    def table(self, name: str) -> Dict[str, Any]:
        """The columns of the further table ``<name>.csv`` (e.g. ``hb_frc``):
        numpy arrays, and lists of str for label columns (``stable``,
        ``bifurcation``)."""
        try:
            return self._tables[name]
        except KeyError:
            raise KeyError(f"no table {name!r}; the run has {sorted(self._tables)}") from None

    def branches(self, method: str = "hb") -> List[Dict[str, Any]]:
        """The solution branches of ``hb`` (branch 0 the main one, then the
        isolated branches found from the seeds), each a dict of the
        ``hb_frc.csv`` columns for its points: numpy arrays, ``stable`` a
        bool array (``None`` where stability was not computed, then an object
        array) and ``bifurcation`` a list of labels."""
        if method != "hb":
            raise KeyError(f"no branches of {method!r}; only 'hb' has branches")
        t = self.table("hb_frc")
        branch = np.asarray(t["branch"]).astype(int)
        out = []
        for b in range(int(branch.max()) + 1 if branch.size else 0):
            idx = np.flatnonzero(branch == b)
            d: Dict[str, Any] = {}
            for k, v in t.items():
                if k == "branch":
                    continue
                if isinstance(v, list):
                    vals = [v[i] for i in idx]
                    if k == "stable":
                        d[k] = (
                            np.array([x == "true" for x in vals])
                            if all(x in ("true", "false") for x in vals)
                            else np.array([None if x == "" else x == "true" for x in vals], dtype=object)
                        )
                    else:
                        d[k] = vals
                else:
                    d[k] = np.asarray(v)[idx]
            out.append(d)
        return out

    def __repr__(self) -> str:
        return f"RunResult(methods={self.methods})"


def run(
    scenario: Source = None,
    methods: Optional[Sequence[str]] = None,
    *,
    out_dir: Union[None, str, "os.PathLike[str]"] = None,
    fmu_dir: Union[None, str, "os.PathLike[str]"] = None,
    matrices: Optional[Matrices] = None,
) -> RunResult:
    """Sweep through resonance by every method the scenario lists (or
    ``methods``, which replaces ``[run] methods``), as ``host run``.

    ``out_dir``: where the files some methods need besides their results go
    (the FMUs that ``cosim`` packages, ``phase_resonance.csv``; with it the
    FMUs are packaged as ``output.fmus`` says); default a temporary folder.
    ``fmu_dir``: the FMU libraries for ``cosim`` (else ``$NLMODE_FMU_DIR``);
    without them ``cosim`` is listed under ``summary["failed_methods"]``.
    ``matrices``: the mass, stiffness and damping matrices of a ``[structure]
    kind = "matrices"`` scenario in memory (``{"mass": M, "stiffness": K,
    "damping": C}``, ``scipy.sparse`` or dense; the scenario then names no
    matrix files).
    """
    text, path = _source(scenario)
    mats = _matrices(matrices)
    m = None if methods is None else [str(x) for x in methods]
    summary, results = _native.run(
        text,
        path,
        m,
        None if out_dir is None else os.fspath(out_dir),
        None if fmu_dir is None else os.fspath(fmu_dir),
        mats,
    )
    return RunResult(json.loads(summary), results)


class ModalTable(dict):
    """The nonlinear modal table of ``nma()`` (a dict): ``amplitude`` [sqrt(kg) m],
    ``omega_rad_s``, ``damping_ratio`` (numpy arrays), ``shapes`` (point name ->
    complex array ``[amplitude index, harmonic 0..H]``), ``harmonics``,
    ``accuracy`` (the measured interpolation errors, a dict, or None),
    ``truncated_at_fold``, ``omega0_rad_s``, ``note``, ``description``."""

    def __getattr__(self, name):
        try:
            return self[name]
        except KeyError:
            raise AttributeError(name) from None


def nma(scenario: Source = None, *, matrices: Optional[Matrices] = None) -> ModalTable:
    """The nonlinear modal analysis of the scenario's structure: the refined
    modal table that ``host nma`` writes to ``modal_table.json``.
    ``matrices``: as for :func:`run` (a ``kind = "matrices"`` structure's
    matrices in memory)."""
    text, path = _source(scenario)
    table, note, omega0 = _native.nma(text, path, _matrices(matrices))
    t = json.loads(table)
    shapes = {
        p["name"]: np.asarray(p["re"], dtype=float) + 1j * np.asarray(p["im"], dtype=float)
        for p in t["points"]
    }
    return ModalTable(
        amplitude=np.asarray(t["amplitude"], dtype=float),
        omega_rad_s=np.asarray(t["omega_rad_s"], dtype=float),
        damping_ratio=np.asarray(t["damping_ratio"], dtype=float),
        shapes=shapes,
        harmonics=t["harmonics"],
        accuracy=t.get("accuracy"),
        truncated_at_fold=t.get("truncated_at_fold"),
        description=t.get("description", ""),
        omega0_rad_s=omega0,
        note=note,
    )


def frf(scenario: Source = None, *, matrices: Optional[Matrices] = None) -> Dict[str, Any]:
    """The steady state of ``eq:NM`` at the scenario's voltage, as ``host frf``:
    every solution branch point (``omega_rad_s``, ``modal_amplitude``,
    ``tip_amplitude_m``, ``force_amplitude_N``, ``stable`` as bool arrays),
    plus ``omega0_rad_s`` and ``note``."""
    text, path = _source(scenario)
    return _native.frf(text, path, _matrices(matrices))


def _study_source(study):
    """(text, base_dir) of a STUDY.toml given as a path, text or dict."""
    if isinstance(study, Mapping):
        return _native.dict_to_toml(dict(study)), os.getcwd()
    if isinstance(study, os.PathLike) or (
        isinstance(study, str) and "\n" not in study and "=" not in study
    ):
        p = pathlib.Path(os.fspath(study))
        try:
            text = p.read_text()
        except OSError as e:
            raise ScenarioError(f"cannot read study file {p}: {e}") from None
        return text, str(p.resolve().parent)
    if isinstance(study, str):
        return study, os.getcwd()
    raise TypeError(f"study: expected a path, TOML text or a dict, not {type(study).__name__}")


def read_results(source) -> "pandas.DataFrame":  # noqa: F821
    """A ``results.csv`` (a path or its text) as the DataFrame ``study()``
    returns: the same columns, numbers read exactly (round trip)."""
    import pandas as pd

    if isinstance(source, str) and "\n" in source:
        source = io.StringIO(source)
    return pd.read_csv(source, keep_default_na=False, na_values=[""])


def study(
    study,
    client=None,
    *,
    batch_size: Optional[int] = None,
    threads: Optional[int] = None,
):
    """Run a parameter study (STUDY.toml as a path, TOML text or a dict) and
    return a pandas DataFrame with the columns of ``host study``'s
    ``results.csv``, one row per sample, sorted by sample.

    ``client``: a ``dask.distributed.Client``; the samples go to its workers
    in batches of ``batch_size`` (default: about four batches per worker
    thread) and each worker process loads the study and builds each
    structure and modal table once for all its batches. ``None``: the local
    cores (``threads``, default all).

    A study with a ``reference_subset`` also runs those samples by
    ``reference``: their rows (``host study``'s ``results_reference.csv``, the
    same columns) are the DataFrame ``df.attrs["reference"]``.
    """
    text, base_dir = _study_source(study)
    st = _native.Study(text, base_dir)
    if client is None:
        df = read_results(st.evaluate(None, threads))
        ref = st.evaluate(None, threads, True, True) if st.reference_samples else None
    else:
        from ._dask import evaluate_on_client

        df = read_results(evaluate_on_client(client, st, text, base_dir, batch_size))
        ref = (
            evaluate_on_client(client, st, text, base_dir, batch_size, reference=True)
            if st.reference_samples
            else None
        )
    if ref is not None:
        df.attrs["reference"] = read_results(ref)
    return df
