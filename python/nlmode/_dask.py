"""A study on a Dask cluster: ``nlmode.study(..., client=...)``.

The samples are split into batches of indices, one Dask task each
(``client.map``); a task runs :func:`run_batch` on a worker, which finds the
study in its process-global registry (keyed by the study fingerprint) or loads
it once, so the structures and their modal tables are built once per worker
process and kept for all the batches it runs. Each task returns its rows as
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


def run_batch(samples: List[int], text: str, base_dir: str, fingerprint: str, threads: int = 1) -> str:
    """The rows of ``samples`` (``results.csv`` text without header), on a worker."""
    st = _native.Study.cached(fingerprint, text, base_dir)
    return st.evaluate(list(samples), threads, False)


def default_batch_size(n: int, worker_threads: int) -> int:
    return max(1, min(MAX_BATCH, -(-n // max(1, BATCHES_PER_THREAD * worker_threads))))


def evaluate_on_client(client, st, text: str, base_dir: str, batch_size: Optional[int] = None) -> str:
    """``results.csv`` text (header, rows sorted by sample) of the study ``st``
    computed by the workers of ``client``."""
    n = len(st)
    if batch_size is None:
        threads = sum(client.nthreads().values()) or 1
        batch_size = default_batch_size(n, threads)
    if not isinstance(batch_size, int) or not 1 <= batch_size <= MAX_BATCH:
        raise _native.ScenarioError(f"batch_size: {batch_size!r} is not an integer between 1 and {MAX_BATCH}")
    batches = [list(range(i, min(n, i + batch_size))) for i in range(0, n, batch_size)]
    futures = client.map(
        run_batch,
        batches,
        text=text,
        base_dir=base_dir,
        fingerprint=st.fingerprint,
        pure=False,
    )
    parts = client.gather(futures)
    header = st.evaluate([], None, True)
    # batches are contiguous and in order: the rows are sorted by sample
    return header + "".join(parts)
