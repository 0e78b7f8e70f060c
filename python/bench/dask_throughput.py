"""Dask overhead of `nlmode.study`: N case-(a) `nlmode` samples (lhs over the
voltage, the sweep rate and the stinger stiffness: one structure) on a
2-worker LocalCluster (one thread each) against the local call on all cores,
in the same run. Prints samples/s of each and their ratio per batch size.

    python python/bench/dask_throughput.py [N=10000] [BATCH ...]
"""
import sys
import time

from dask.distributed import Client, LocalCluster

import nlmode

N = int(sys.argv[1]) if len(sys.argv) > 1 else 10_000
BATCHES = [int(b) for b in sys.argv[2:]] or [None, 500, 2500]
STUDY = {
    "design": "lhs",
    "samples": N,
    "seed": 7,
    "parameter": [
        {"key": "excitation.voltage_v", "distribution": "uniform", "low": 2.0, "high": 10.0},
        {"key": "excitation.rate_per_pseudo_period", "distribution": "uniform", "low": 0.01, "high": 0.05},
        {"key": "exciter.0.stinger_stiffness_n_per_m", "distribution": "uniform", "low": 1e7, "high": 4e7},
    ],
}


def timed(f):
    t0 = time.perf_counter()
    r = f()
    return r, time.perf_counter() - t0


def main():
    # cold: the study loaded and checked, the NMA computed; warm: the NMA kept
    # (every call loads and checks the study where it is called)
    local, t_cold = timed(lambda: nlmode.study(STUDY))
    print(f"local cold ({N} samples, all cores): {t_cold:.2f} s, {N / t_cold:.0f} samples/s")
    local, t_local = timed(lambda: nlmode.study(STUDY))
    print(f"local warm: {t_local:.2f} s, {N / t_local:.0f} samples/s")
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, Client(
        cluster
    ) as client:
        # first call: each worker loads the study and computes its NMA
        _, t_first = timed(lambda: nlmode.study(STUDY, client=client))
        print(
            f"dask cold (the workers load the study, NMA): {t_first:.2f} s, {N / t_first:.0f} samples/s, "
            f"{t_cold / t_first:.2f} of the local cold throughput"
        )
        for b in BATCHES:
            df, t = timed(lambda: nlmode.study(STUDY, client=client, batch_size=b))
            assert df.equals(local)
            print(
                f"dask batch_size={b or 'default'}: {t:.2f} s, {N / t:.0f} samples/s, "
                f"{t_local / t:.2f} of the local warm throughput"
            )


if __name__ == "__main__":
    main()
