"""A study on a Dask cluster: ``nlmode.study(..., client=...)``.

The samples are split into contiguous batches, one Dask task each
(``client.map``) carrying only its index range; the study (fingerprint, text,
base folder) is scattered to every worker once per call. A task runs
:func:`run_batch` on a worker, which finds the study in its process-global
registry (keyed by the study fingerprint) or loads it once, so the study is
parsed and checked, and the structures and their modal tables are built, once
per worker process and kept for all the batches it runs. Each task returns its rows as
``results.csv`` text; they are gathered and sorted by sample. Dask does the
scheduling, transport and retries: there is nothing else here.
"""
from __future__ import annotations

from typing import List, Optional

from . import _native

#: Largest batch (samples per task).
MAX_BATCH = 100_000
#: Batches per worker thread by default: enough to balance the load, few
#: enough that the per-task overhead (a few ms) stays small against a batch.
BATCHES_PER_THREAD = 4


def run_batch(
    start: int,
    stop: int,
    study,
    threads: int = 1,
    reference: bool = False,
) -> str:
    """The rows of the samples ``start..stop`` of the study (``results.csv``
    text without header), on a worker; ``study``: ``(fingerprint, text,
    base_dir)``, scattered to the workers once per call; the study is loaded
    once per worker process (:meth:`_native.Study.cached`). ``reference``:
    the ``start..stop`` entries of the ``reference_subset`` by ``reference``."""
    fingerprint, text, base_dir = study
    st = _native.Study.cached(fingerprint, text, base_dir)
    samples = st.reference_samples[start:stop] if reference else list(range(start, stop))
    return st.evaluate(samples, threads, False, reference)


def default_batch_size(n: int, worker_threads: int) -> int:
    return max(1, min(MAX_BATCH, -(-n // max(1, BATCHES_PER_THREAD * worker_threads))))


def evaluate_on_client(
    client, st, text: str, base_dir: str, batch_size: Optional[int] = None, reference: bool = False
) -> str:
    """``results.csv`` text (header, rows sorted by sample) of the study ``st``
    computed by the workers of ``client`` (``reference``: the rows of
    ``results_reference.csv``, the ``reference_subset`` by ``reference``).

    The tasks carry sample index ranges only; the study's text goes to each
    worker once (``client.scatter(..., broadcast=True)``)."""
    n = len(st.reference_samples) if reference else len(st)
    if batch_size is None:
        threads = sum(client.nthreads().values()) or 1
        batch_size = default_batch_size(n, threads)
    if not isinstance(batch_size, int) or not 1 <= batch_size <= MAX_BATCH:
        raise _native.ScenarioError(f"batch_size: {batch_size!r} is not an integer between 1 and {MAX_BATCH}")
    header = st.evaluate([], None, True, reference)
    if n == 0:
        return header
    study = client.scatter((st.fingerprint, text, base_dir), broadcast=True, hash=False)
    starts = list(range(0, n, batch_size))
    futures = client.map(
        run_batch,
        starts,
        [min(n, i + batch_size) for i in starts],
        study=study,
        reference=reference,
        pure=False,
    )
    parts = client.gather(futures)
    # batches are contiguous and in order: the rows are sorted by sample
    return header + "".join(parts)
