"""nlmode: sweeps, NMA, FRF and parameter studies (local or on Dask) of the
single-nonlinear-mode theory with linear attachments."""
import os
from typing import Any, Dict, List, Mapping, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

from ._native import NlmodeError as NlmodeError
from ._native import ScenarioError as ScenarioError

Source = Union[None, str, os.PathLike, Mapping[str, Any]]
Arrays = Dict[str, npt.NDArray[np.float64]]

class RunResult:
    """What a sweep computed."""

    summary: Dict[str, Any]
    """The dict of ``summary.json``."""
    methods: List[str]
    """The output names (``nlmode``, ``reference``, ``closed-form``, ...)."""
    def envelope(self, method: str) -> Arrays:
        """The columns of ``<method>_envelope.csv`` as numpy arrays."""
    def time_series(self, method: str) -> Arrays:
        """The columns of ``<method>_timeseries.csv`` as numpy arrays."""
    def table(self, name: str) -> Dict[str, Any]:
        """The columns of a further table (``hb_frc``): arrays, label lists."""
    def branches(self, method: str = "hb") -> List[Dict[str, Any]]:
        """``hb``'s branches (0 the main one), each the ``hb_frc.csv`` columns."""

class ModalTable(Dict[str, Any]):
    """``amplitude``, ``omega_rad_s``, ``damping_ratio`` (arrays), ``shapes``
    (point -> complex ``[amplitude, harmonic]``), ``harmonics``, ``accuracy``,
    ``truncated_at_fold``, ``omega0_rad_s``, ``note``, ``description``;
    also as attributes."""

    amplitude: npt.NDArray[np.float64]
    omega_rad_s: npt.NDArray[np.float64]
    damping_ratio: npt.NDArray[np.float64]
    shapes: Dict[str, npt.NDArray[np.complex128]]
    harmonics: int
    accuracy: Optional[Dict[str, Any]]
    omega0_rad_s: float

def run(
    scenario: Source = None,
    methods: Optional[Sequence[str]] = None,
    *,
    out_dir: Union[None, str, os.PathLike] = None,
    fmu_dir: Union[None, str, os.PathLike] = None,
    matrices: Optional[Mapping[str, Any]] = None,
) -> RunResult:
    """Sweep through resonance by the scenario's methods (or ``methods``), as ``host run``."""

def nma(scenario: Source = None, *, matrices: Optional[Mapping[str, Any]] = None) -> ModalTable:
    """The refined nonlinear modal table (``host nma``'s ``modal_table.json``)."""

def frf(scenario: Source = None, *, matrices: Optional[Mapping[str, Any]] = None) -> Dict[str, Any]:
    """The steady-state branches of ``eq:NM`` (``host frf``'s ``frf.csv``)."""

def read_results(source: Union[str, os.PathLike]) -> Any:
    """A ``results.csv`` (path or text) as the DataFrame ``study()`` returns."""

def study(
    study: Union[str, os.PathLike, Mapping[str, Any]],
    client: Any = None,
    *,
    batch_size: Optional[int] = None,
    threads: Optional[int] = None,
) -> Any:
    """A parameter study as a pandas DataFrame with ``results.csv``'s columns;
    on a ``dask.distributed.Client`` if given. ``df.attrs["reference"]`` (a study
    with a ``reference_subset``): those rows by ``reference``
    (``results_reference.csv``'s columns)."""
