"""Type stubs of the native module ``nlmode._native`` (Rust, PyO3).

The public API is in ``nlmode`` (``run``, ``nma``, ``frf``, ``study``);
these are the functions it calls. Every long call releases the GIL.
"""
from typing import Any, Dict, List, Optional, Tuple

import numpy as np
import numpy.typing as npt

class ScenarioError(ValueError):
    """A bad scenario or study; the message names the key, as ``host`` prints it."""

class NlmodeError(RuntimeError):
    """A computation that failed (e.g. an NMA that did not converge)."""

def dict_to_toml(d: dict) -> str:
    """The TOML text of a scenario or study given as a dict."""

def run(
    text: Optional[str] = None,
    path: Optional[str] = None,
    methods: Optional[List[str]] = None,
    out_dir: Optional[str] = None,
    fmu_dir: Optional[str] = None,
    matrices: Optional[dict] = None,
) -> Tuple[
    str,
    List[
        Tuple[
            str,
            Dict[str, npt.NDArray[np.float64]],
            Optional[Dict[str, npt.NDArray[np.float64]]],
            Dict[str, Dict[str, Any]],
        ]
    ],
]:
    """A sweep as ``host run`` computes it: (summary.json text, [(output name,
    envelope columns, time-series columns or None, further tables)])."""

def nma(
    text: Optional[str] = None, path: Optional[str] = None, matrices: Optional[dict] = None
) -> Tuple[str, str, float]:
    """(modal_table.json text, how the table was made, omega0 [rad/s])."""

def frf(
    text: Optional[str] = None, path: Optional[str] = None, matrices: Optional[dict] = None
) -> dict:
    """The steady-state branches (frf.csv's columns as arrays, ``stable`` as
    bool), ``omega0_rad_s`` and ``note``."""

class Study:
    """A study loaded and checked, with its per-process structure cache."""

    def __init__(self, text: str, base_dir: str) -> None:
        """STUDY.toml text; a relative ``scenario`` is taken from ``base_dir``."""
    @staticmethod
    def cached(fingerprint: str, text: str, base_dir: str) -> "Study":
        """The study this process holds under ``fingerprint``, else loaded once."""
    @property
    def fingerprint(self) -> str:
        """The text identifying the study (``study_fingerprint.json``)."""
    @property
    def keys(self) -> List[str]:
        """The parameter keys (the columns after ``sample``)."""
    @property
    def method(self) -> str:
        """The study's method (``nlmode``, ``linear-slowflow``, ``reference``)."""
    @property
    def reference_samples(self) -> List[int]:
        """Samples also run by ``reference`` in ``host study``."""
    @property
    def distinct_structures(self) -> int:
        """Structures built so far in this process."""
    def __len__(self) -> int: ...
    def evaluate(
        self,
        samples: Optional[List[int]] = None,
        threads: Optional[int] = None,
        header: bool = True,
        reference: bool = False,
    ) -> str:
        """``results.csv`` text of these samples (all if None) in their order,
        on ``threads`` threads (None: all cores); ``reference``: the rows of
        ``results_reference.csv`` by ``reference`` instead (None: the
        ``reference_subset``)."""
